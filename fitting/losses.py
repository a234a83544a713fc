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

Pure JAX functions: they compute in the dtype of their inputs (the fitter
calls them on float64 arrays, see ``fitting/_jax.py``).
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .choices import HYBRID, LOSSES  # noqa: F401 (re-exported; the names live without JAX)

RELATIVE_EPS = 1e-3   # 1/sr; keeps the relative loss finite on black cells


def _log(x):
    """Natural log of x > 0 from its binary exponent and an atanh series.

    x = m 2^k with m in [sqrt(1/2), sqrt(2)); log m = 2 atanh(s), s = (m-1)/(m+1),
    |s| <= 0.172, summed to the precision of the dtype.  Every step is a plain
    arithmetic op, which XLA:CPU vectorises; its own float64 log is a scalar
    loop about five times slower, and the loss evaluates it on every sample.
    k and m come from x's bits (as musl's log): x's bits less those of sqrt(1/2),
    shifted right by the mantissa's width, are k, and x's bits less k in the
    exponent field are m's -- for a normal x the k and m that jnp.frexp with m
    doubled below sqrt(1/2) gives (the same logs, bit for bit), at a fifth of
    the cost (4 M logs: 9 ms against 47 ms; frexp's handling of zero, subnormals,
    inf and NaN, none of them a normal x, was most of it).  inf and NaN come
    back as they are.
    """
    info = np.finfo(x.dtype)
    ints = np.int64 if info.bits == 64 else np.int32
    bits = jax.lax.bitcast_convert_type(x, ints)
    k = (bits - np.sqrt(np.array(0.5, x.dtype)).view(ints)) >> info.nmant      # arithmetic shift: floor
    m = jax.lax.bitcast_convert_type(bits - (k << info.nmant), x.dtype)
    s = (m - 1.0) / (m + 1.0)
    s2 = s * s
    terms = 9 if x.dtype == jnp.float64 else 4
    series = 1.0 / (2 * terms + 1)
    for j in range(terms - 1, -1, -1):
        series = series * s2 + 1.0 / (2 * j + 1)
    log = k.astype(x.dtype) * math.log(2.0) + 2.0 * s * series     # a Python float keeps float32 float32
    return jnp.where(x < jnp.inf, log, x)


@jax.custom_jvp
def log1p(y):
    """log(1 + y) for y >= 0 with an absolute error of a few ulp of max(1, result).

    Not jnp.log1p's relative accuracy for tiny y: a residual of the log loss
    is a difference of two such logs, and needs only the absolute one.
    """
    return _log(1.0 + y)


@log1p.defjvp
def _log1p_jvp(primals, tangents):
    (y,), (dy,) = primals, tangents
    return log1p(y), dy / (1.0 + y)


def compress(name: str, f: Float[Array, "n 3"], cos_i: Float[Array, "n 1"]) -> Float[Array, "n 3"]:
    if name == "log":
        return log1p(f * cos_i)
    if name == "ngan":
        return f * cos_i
    if name == "cuberoot":
        return jnp.cbrt(f * cos_i + 1e-12)
    raise ValueError(f"unknown loss {name!r}; valid: {', '.join(LOSSES)}")


def channel_mse(name: str, f: Float[Array, "n 3"], fhat: Float[Array, "n 3"], cos_i: Float[Array, "n 1"],
                weights: Float[Array, " n"]) -> Float[Array, "3"]:
    """Weighted mean square error per channel: (3,), for one orientation.

    ``f``, ``fhat``: (N, 3); ``cos_i``, ``weights``: (N,).  Weights are
    normalised by the caller (they sum to 1 over both orientations).
    """
    if name == "relative":
        r = (f - fhat) / (fhat + RELATIVE_EPS)
    else:
        r = compress(name, f, cos_i[:, None]) - compress(name, fhat, cos_i[:, None])
    return jnp.dot(weights, r * r)   # a matrix-vector product: far faster than sum(axis=0) on XLA:CPU


def rms(mse: Float[Array, "*shape"]) -> Float[Array, "*shape"]:
    """sqrt of a mean square error, with a finite gradient at 0 (a perfect fit)."""
    return jnp.sqrt(mse + jnp.finfo(mse.dtype).tiny)


def check_loss(name: str) -> str:
    if name not in LOSSES:
        raise ValueError(f"unknown loss {name!r}; valid: {', '.join(LOSSES)}")
    return name
