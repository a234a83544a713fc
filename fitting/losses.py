"""Fit losses and the M1 error every result reports.

All losses compare the model f with the measurement fhat over valid samples
with per-sample solid-angle weights w, each direction pair counted in both
orientations (wi, wo) and (wo, wi); cos_i is the cosine of the first
direction of the orientation.

- ``log`` (default, = M1): mean over RGB of
  sqrt( sum w (log1p(f cos_i) - log1p(fhat cos_i))^2 / sum w )  (Loew et al. 2012's
  log compression, cosine-weighted).
- ``ngan``: Ngan et al. 2005 cosine-weighted L2, sqrt(sum w (f - fhat)^2 cos_i^2 / sum w).
- ``relative``: relative L2, sqrt(sum w ((f - fhat) / (fhat + eps))^2 / sum w).
- ``cuberoot``: L2 of cube-root compressed cosine-weighted values (Fores et al. 2012
  found cube-root compression perceptually best; exact form not retrieved).
Every loss is the mean over RGB of a per-channel root-mean-square.
"""

import jax.numpy as jnp

LOSSES = ("log", "ngan", "relative", "cuberoot")
RELATIVE_EPS = 1e-3   # 1/sr; keeps the relative loss finite on black cells


def compress(name, f, cos_i):
    if name == "log":
        return jnp.log1p(f * cos_i)
    if name == "ngan":
        return f * cos_i
    if name == "cuberoot":
        return jnp.cbrt(f * cos_i + 1e-12)
    raise ValueError(f"unknown loss {name!r}; valid: {', '.join(LOSSES)}")


def channel_mse(name, f, fhat, cos_i, weights):
    """Weighted mean square error per channel: (3,), for one orientation.

    ``f``, ``fhat``: (N, 3); ``cos_i``, ``weights``: (N,).  Weights are
    normalised by the caller (they sum to 1 over both orientations).
    """
    if name == "relative":
        r = (f - fhat) / (fhat + RELATIVE_EPS)
    else:
        r = compress(name, f, cos_i[:, None]) - compress(name, fhat, cos_i[:, None])
    return jnp.dot(weights, r * r)   # a matrix-vector product: far faster than sum(axis=0) on XLA:CPU


def check_loss(name):
    if name not in LOSSES:
        raise ValueError(f"unknown loss {name!r}; valid: {', '.join(LOSSES)}")
    return name
