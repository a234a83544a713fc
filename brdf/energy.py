"""Multiple-scattering energy compensation for the GGX lobe.

Single-scattering GGX (height-correlated Smith) loses energy at high
roughness.  E(mu, alpha) is its directional albedo with F = 1 and
E_avg(alpha) = 2 int E(mu) mu dmu.  Both are computed here by quadrature when
first needed (about 0.2 s, numpy), tabulated on a (mu, r) grid and
interpolated bilinearly in JAX, so the compensation is differentiable.

- Kulla & Conty 2017, "Revisiting physically based shading at Imageworks":
  f_ms = (1 - E(mu_o))(1 - E(mu_i)) / (pi (1 - E_avg)) times the Fresnel
  factor F_avg^2 E_avg / (1 - F_avg (1 - E_avg)).
- Turquin 2019, "Practical multiple scattering compensation for microfacet
  models": f = f_ss (1 + F0 (1 - E) / E).
- The split-sum DFG terms A, B (Karis 2013) that the IBL renderer uses come
  from the same quadrature: E = A + B.

docs/models.md (multiple-scattering energy compensation) has the formulas.
The energy options of a model are declared at the end (``ENERGIES``).
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

import numpy as np
from jaxtyping import Float

from ._lazy import jnp
from .constants import ALPHA_MIN, ROUGHNESS_MIN
from .declare import GltfRule, Term
from .fresnel import fresnel_schlick_average

if TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import Array, ArrayLike

TABLE_SIZE = 32          # mu and perceptual-roughness nodes of the tables
QUADRATURE_NODES = 32    # Gauss-Legendre nodes per panel of xi (two panels) and of phi


def _gauss_legendre01(n):
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


def dfg_terms(mu: Float[ArrayLike, "*batch"], alpha: Float[ArrayLike, "*#batch"],
              nodes: int = QUADRATURE_NODES) -> tuple[Float[Array, "*batch"], Float[Array, "*batch"]]:
    """Split-sum terms (A, B) of GGX + height-correlated Smith, by quadrature.

    A = int (1 - (1 - v.h)^5) f_ss cos dw_i, B = int (1 - v.h)^5 f_ss cos dw_i
    (F = 1 inside f_ss), so E = A + B.  ``mu`` and ``alpha`` broadcast.
    Half vectors are importance-sampled from D(h) n.h: theta_h =
    atan(alpha sqrt(xi / (1 - xi))), each node weighted by
    G2 (v.h) / (n.v n.h) where n.l > 0.  numpy, float64; agrees with
    the reference 512^2-node values to about 1e-5.
    """
    mu, alpha = np.broadcast_arrays(np.asarray(mu, float), np.asarray(alpha, float))
    mu = np.maximum(mu, 1e-4)[..., None, None]
    alpha = np.maximum(alpha, ALPHA_MIN)[..., None, None]
    # The horizon n.l = 0 bends the integrand: for theta_h < pi/4 - theta_v/2 every
    # phi is above it, beyond pi/4 + theta_v/2 none is.  Those two angles are
    # panel edges in xi, and phi runs only over the part above the horizon, so
    # Gauss-Legendre sees smooth integrands (about 1e-6 with 32 x 2 x 32 nodes).
    theta_v = np.arccos(np.clip(mu[..., 0], 0.0, 1.0))             # (..., 1)
    a2_ = alpha[..., 0] ** 2
    xi_of = lambda th: (lambda t2: t2 / (a2_ + t2))(np.tan(np.clip(th, 0.0, np.pi / 2 - 1e-9)) ** 2)
    edges = [np.zeros_like(theta_v), xi_of(np.pi / 4 - theta_v / 2), xi_of(np.pi / 4 + theta_v / 2)]
    t, wt = _gauss_legendre01(nodes)
    # cosine-clustered nodes: phi_max(xi) has square-root ends at the edges
    g, wg = 0.5 * (1.0 - np.cos(np.pi * t)), wt * 0.5 * np.pi * np.sin(np.pi * t)
    x, wx = _gauss_legendre01(nodes)
    xi = np.concatenate([lo + (hi - lo) * g for lo, hi in zip(edges[:-1], edges[1:])], axis=-1)
    wxi = np.concatenate([(hi - lo) * wg for lo, hi in zip(edges[:-1], edges[1:])], axis=-1)
    xi, wxi = xi[..., :, None], wxi[..., :, None]
    tan2 = alpha * alpha * xi / (1.0 - xi)
    nh = 1.0 / np.sqrt(1.0 + tan2)
    sh = np.sqrt(np.maximum(0.0, 1.0 - nh * nh))
    sv = np.sqrt(1.0 - mu * mu)
    # n.l = 2 (v.h)(n.h) - mu > 0 exactly for cos(phi) > c: integrate phi over
    # [-phi_max, phi_max] only, so the horizon is a panel edge, not a kink
    # inside the Gauss-Legendre panel (1e-6 instead of 1e-3 accuracy).
    c = (mu / (2.0 * nh) - mu * nh) / np.maximum(sv * sh, 1e-300)
    phi_max = np.arccos(np.clip(c, -1.0, 1.0))
    phi = phi_max * (2.0 * x[None, :] - 1.0)
    weight = wxi * wx[None, :] * (phi_max / np.pi)      # (1/2pi) * 2 phi_max * wx
    vh = sv * sh * np.cos(phi) + mu * nh                 # v = (sv, 0, mu)
    nl = 2.0 * vh * nh - mu
    a2 = alpha * alpha
    lam = lambda cos: 0.5 * (np.sqrt(1.0 + a2 * (1.0 - cos * cos) / (cos * cos)) - 1.0)
    ok = (nl > 0.0) & (vh > 0.0)
    nl_safe = np.where(ok, nl, 1.0)
    g2 = 1.0 / (1.0 + lam(mu) + lam(nl_safe))
    f = np.where(ok, g2 * vh / (mu * nh), 0.0) * weight
    fw = (1.0 - np.clip(vh, 0.0, 1.0)) ** 5
    return (f * (1.0 - fw)).sum(axis=(-2, -1)), (f * fw).sum(axis=(-2, -1))


def directional_albedo(mu: Float[ArrayLike, "*batch"], alpha: Float[ArrayLike, "*#batch"],
                       nodes: int = QUADRATURE_NODES) -> Float[Array, "*batch"]:
    """E(mu, alpha) of single-scattering GGX with F = 1, by quadrature (numpy)."""
    a, b = dfg_terms(mu, alpha, nodes)
    return a + b


@functools.lru_cache(maxsize=None)
def tables(size=TABLE_SIZE):
    """Numpy tables on the grid mu_j = j/(size-1), r_k = ROUGHNESS_MIN..1.

    Returns a dict with ``mu`` (size,), ``roughness`` (size,), ``A``, ``B``,
    ``E`` (size, size) indexed [mu, r], and ``E_avg`` (size,).
    """
    mu = np.linspace(0.0, 1.0, size)
    r = np.linspace(ROUGHNESS_MIN, 1.0, size)
    alpha = r * r
    a, b = dfg_terms(mu[:, None], alpha[None, :])
    x, w = _gauss_legendre01(size)
    e_nodes = directional_albedo(x[:, None], alpha[None, :])
    e_avg = 2.0 * np.sum(w[:, None] * x[:, None] * e_nodes, axis=0)
    return {"mu": mu, "roughness": r, "A": a, "B": b, "E": a + b, "E_avg": e_avg}


def _interp_coord(x, lo, hi, size):
    """Fractional index of x on a uniform grid, and its integer floor (the energy and sheen tables')."""
    u = jnp.clip((x - lo) / (hi - lo) * (size - 1), 0.0, size - 1.0)
    i0 = jnp.clip(jnp.floor(u), 0, size - 2).astype(jnp.int32)
    return i0, u - i0


def lookup_e(mu: Float[ArrayLike, "*batch"], roughness: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """E(mu, alpha = r^2) bilinearly interpolated from the table (JAX, differentiable)."""
    t = tables()
    table = jnp.asarray(t["E"], dtype=jnp.result_type(mu, roughness, float))
    n = table.shape[0]
    i, fi = _interp_coord(mu, 0.0, 1.0, n)
    k, fk = _interp_coord(roughness, ROUGHNESS_MIN, 1.0, n)
    e00, e01 = table[i, k], table[i, k + 1]
    e10, e11 = table[i + 1, k], table[i + 1, k + 1]
    return ((1 - fi) * ((1 - fk) * e00 + fk * e01) + fi * ((1 - fk) * e10 + fk * e11))


def lookup_e_avg(roughness: Float[ArrayLike, "*#batch"]) -> Float[Array, "*#batch"]:
    """E_avg(alpha = r^2) linearly interpolated from the table (JAX)."""
    t = tables()
    table = jnp.asarray(t["E_avg"], dtype=jnp.result_type(roughness, float))
    k, fk = _interp_coord(roughness, ROUGHNESS_MIN, 1.0, table.shape[0])
    return (1 - fk) * table[k] + fk * table[k + 1]


def kulla_conty_fresnel_factor(f_avg: Float[ArrayLike, "*#batch #3"],
                               e_avg: Float[ArrayLike, "*#batch"]) -> Float[Array, "*#batch #3"]:
    """F_avg^2 E_avg / (1 - F_avg (1 - E_avg)): the colour of the extra bounces."""
    return f_avg * f_avg * e_avg / (1.0 - f_avg * (1.0 - e_avg))


def kulla_conty_lobe(n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
                     roughness: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """(1 - E(mu_o))(1 - E(mu_i)) / (pi (1 - E_avg)): the lobe of the extra bounces, uncoloured."""
    e_i = lookup_e(jnp.clip(n_dot_l, 0.0, 1.0), roughness)
    e_o = lookup_e(jnp.clip(n_dot_v, 0.0, 1.0), roughness)
    return (1.0 - e_i) * (1.0 - e_o) / (jnp.pi * (1.0 - lookup_e_avg(roughness)))


def kulla_conty(n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
                roughness: Float[ArrayLike, "*#batch"],
                f_avg: Float[ArrayLike, "*#batch #3"] = 1.0) -> Float[Array, "*batch #3"]:
    """Kulla-Conty multiple-scattering lobe (1/sr), to add to D V F.

    f_ms = (1 - E(mu_o))(1 - E(mu_i)) / (pi (1 - E_avg)), times the Fresnel
    factor when ``f_avg`` (hemispherical average Fresnel, scalar or RGB) is given.
    """
    f_ms = kulla_conty_lobe(n_dot_l, n_dot_v, roughness)
    factor = kulla_conty_fresnel_factor(f_avg, lookup_e_avg(roughness))
    if jnp.ndim(factor) and jnp.shape(factor)[-1] == 3:
        f_ms = f_ms[..., None]
    return f_ms * factor


def turquin_factor(n_dot_v: Float[ArrayLike, "*batch"], roughness: Float[ArrayLike, "*#batch"],
                   f0: Float[ArrayLike, "*#batch #3"]) -> Float[Array, "*batch #3"]:
    """Turquin 2019: 1 + F0 (1 - E(mu_o)) / E(mu_o), multiplying the specular lobe."""
    e = lookup_e(jnp.clip(n_dot_v, 0.0, 1.0), roughness)
    if jnp.ndim(f0) and jnp.shape(f0)[-1] == 3:
        e = e[..., None]
    return 1.0 + f0 * (1.0 - e) / e


# --- declarations -------------------------------------------------------------
# lobe(f_ss, g, roughness, f0) -> the compensated specular lobe (..., 3);
# None leaves it as it is.

_DROPPED = GltfRule(note="glTF has no multiple-scattering compensation: '{name}' dropped")

ENERGIES = {
    "none": Term(name="none", fused=True),
    "kulla_conty": Term(
        name="kulla_conty", token="ms", hint="Kulla-Conty", fused=True, gltf=_DROPPED,
        lobe=lambda f, g, r, f0: f + kulla_conty(g.n_dot_l, g.n_dot_v, r, fresnel_schlick_average(f0))),
    "turquin": Term(name="turquin", token="turquin", gltf=_DROPPED, reciprocal=False,     # 1/E at n.v
                    lobe=lambda f, g, r, f0: f * turquin_factor(g.n_dot_v, r, f0)),
}
