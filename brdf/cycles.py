"""Blender Cycles' own terms of the Principled BSDF's layering and diffuse (issue 61), as Cycles
5.0 evaluates them; brdf/principled.py builds the Principled models from them.

Read in Blender's source (github.com/blender/blender, main, December 2026):

    intern/cycles/kernel/svm/closure.h          the Principled BSDF's closures, top down: sheen,
                                                coat, metal, specular, diffuse; each layer below
                                                weighted by closure_layering_weight
    intern/cycles/kernel/closure/bsdf_util.h    closure_layering_weight(albedo, w) =
                                                w saturate(1 - max(albedo / w))
    intern/cycles/kernel/closure/bsdf_microfacet.h   bsdf_microfacet_estimate_albedo
    intern/cycles/app/cycles_precompute.cpp     the tables ggx_gen_schlick_ior_s, ggx_E, ggx_Eavg
    intern/cycles/kernel/closure/bsdf_oren_nayar.h   the diffuse at Diffuse Roughness > 0
    intern/cycles/kernel/closure/bsdf_sheen.h   the sheen: Zeltner et al. 2022's LTC, its a, b and
                                                albedo read from a 32 x 32 table (n.v, roughness)

**The layering.** A dielectric layer (the specular of IOR eta and roughness r, or the coat of
Coat IOR c and Coat Roughness) weighs everything below it by one minus Cycles' estimate of its
albedo at the view direction, which is not the lobe's directional albedo but

    albedo(n.v) = F0 + (1 - F0) S(r, n.v, z),   F0 = ((eta - 1) / (eta + 1))^2,
    z = sqrt(|eta - 1| / (eta + 1))

with S the mean over GGX's visible normals h of the view direction (alpha = r^2, Heitz 2018) of
the exact Fresnel's blend factor (F_dielectric(h.v, eta) - F0) / (1 - F0), a sample whose
mirror direction falls below the horizon counting 0: the microfacet lobe taken as if it kept
all its energy (estimate_albedo's comment says so), so on a rough lobe the estimate exceeds
the lobe's own albedo and the layer below is darker than OpenPBR's (MaterialX's) 1 - E(n.v).
Cycles tabulates S on a 16 x 16 x 16 grid (r_i = i / 15 and n.v_j = j / 15 clamped to
[1e-4, 1], z_k = k / 15 clamped to [1e-4, 0.99], eta = (1 + z^2) / (1 - z^2)) by 2^20
Monte-Carlo samples a node, and reads it trilinearly (lookup_table_read_3D: each coordinate
saturated, times 15, floor, the next node clamped to 15).  ``dielectric_s_table`` computes the
same nodes here (a midpoint grid of QUADRATURE^2 samples of Heitz's visible-normal map, not
Cycles' numbers: within 1.7e-3 of a 256^2 grid, and the models drawn by Cycles agree with it to
5e-4 summed over the lit sphere: docs/blender.md), ``cycles_dielectric_albedo`` reads it as Cycles
does.

**The coat** runs microfacet_ggx_preserve_energy whatever the distribution: its lobe times
C = 1 + F_ms (1 - E) / E with Cycles' GGX albedo tables (ggx_E, ggx_Eavg: ``ggx_albedo_tables``,
on Cycles' nodes from brdf.energy's quadrature of the albedo, where Cycles samples it) and the
closure's weight holding E C, so the layer below it is weighed by
saturate(1 - w E C albedo(n.v)) (``cycles_coat_layer``).

**Multiscatter GGX** (the Principled BSDF's distribution "MULTI_GGX", Blender's default for a new
node; bsdf_microfacet.h's bsdf_microfacet_setup_fresnel_f82_tint and _generalized_schlick with
preserve_energy): the metal's and the specular's lobes kept their energy as the coat's always is,
C = 1 + F_ms (1 - E) / E (``cycles_multiscatter``), with the F82-tint Fresnel's average
F0 + (1 - F0) / 21 - b / 126 per channel for the metal (``cycles_f82_fss``) and the dielectric's
F_ss kept within [F0, 1] for the specular, whose layer then weighs the diffuse by
saturate(1 - E C albedo(n.v)) as a coat of weight 1 does.

**The diffuse** (Diffuse Roughness sigma > 0; below 1e-5 Lambert's rho / pi): Fujii's improved
Oren-Nayar with OpenPBR's multiple-scattering term, as bsdf_oren_nayar.h has it:

    a = 1 / (pi + sigma (pi / 2 - 2 / 3)),  b = sigma a
    t = l.v - (n.l)(n.v), divided by max(n.l, n.v) where it is positive
    G(mu) = sin(theta) (theta - 2/3 - sin(theta) mu) + 2/3 tan(theta) (1 - sin(theta)^3)
    E(mu) = a pi + b G(mu),  E_avg = a pi + (2 pi - 5.6) / 3 b
    E_ms = rho^2 / pi E_avg / (1 - E_avg) / (1 - rho (1 - E_avg))       (rho clamped to [0, 1])
    f = rho (a + b t + E_ms (1 - E(n.v)) (1 - E(n.l)))

rho appears once more in front of E_ms than in EON's paper (brdf.diffuse.eon, the toolkit's and
three.js's), and E(mu) is Fujii's exact albedo where the paper fits it: at Diffuse Roughness 1
on white 0.8 Cycles draws the diffuse 1-2 % darker than EON.

**The sheen** (Sheen Weight w, Sheen Tint t, Sheen Roughness r_s), the top layer: Zeltner, Burley
and Chiang 2022's LTC lobe in the view's frame, the closure's weight w t E(n.v), and below it
closure_layering_weight of that albedo, the largest channel's:

    f = w t E(n.v) D(l) / n.l + saturate(1 - max_c(w t_c E(n.v))) f_below

Cycles reads a, b of M^-1 and E from its 32 x 32 table of the paper's fit (bsdf_sheen.h,
lookup_table_read_2D); that table is data in Blender's source, not copied here, so
``cycles_sheen_layer`` takes MaterialX's analytic fits of the same lobe (brdf/openpbr_fuzz.py:
zeltner_ltc, zeltner_dir_albedo, zeltner_density), r_s clamped to their range [0.01, 1] (Cycles
clamps to [1e-3, 1]).  Cycles' render of the written material measures what that costs
(docs/blender.md).  OpenPBR's fuzz weighs the layer below by 1 - w E, grey whatever its colour.
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

import numpy as np
from jaxtyping import Float

from ._lazy import jnp
from .energy import directional_albedo
from .fresnel import f0_from_ior, fresnel_dielectric
from .openpbr import f82_tint_b
from .openpbr_fuzz import FUZZ_ROUGHNESS_MIN, N_DOT_V_MIN, zeltner_density, zeltner_dir_albedo

if TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import Array, ArrayLike

#: nodes a side of Cycles' table ggx_gen_schlick_ior_s (its axes: roughness, n.v, z)
TABLE_SIZE = 16
#: samples a side of the midpoint grid over the visible-normal map a node is computed from
QUADRATURE = 64
#: nodes a side of Cycles' GGX albedo tables ggx_E (roughness, n.v) and ggx_Eavg (roughness)
ALBEDO_SIZE = 32
#: Gauss-Legendre nodes in n.v of E_avg = 2 int n.v E dn.v
AVERAGE_NODES = 24
#: Diffuse Roughness below which Cycles draws Lambert (diffuse_roughness_is_almost_zero)
LAMBERT_BELOW = 1e-5


def _nodes(lo: float, hi: float) -> np.ndarray:
    return np.clip(np.arange(TABLE_SIZE) / (TABLE_SIZE - 1), lo, hi)


def _fresnel_np(c, eta):
    """The exact unpolarised dielectric Fresnel in numpy (as brdf.fresnel.fresnel_dielectric)."""
    g2 = eta * eta - 1.0 + c * c
    g = np.sqrt(np.maximum(g2, 0.0))
    a = (g - c) / (g + c)
    b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
    return np.where(g2 > 0.0, 0.5 * a * a * (1.0 + b * b), 1.0)


def visible_normals(n_dot_v: np.ndarray, alpha: np.ndarray, n: int = QUADRATURE) -> np.ndarray:
    """Heitz 2018's sampling of GGX's visible normals (isotropic alpha) for views (sin, 0, n.v) at the
    midpoints of an n x n grid of its two random numbers: (*batch, n * n, 3) unit half vectors."""
    mu, alpha = np.broadcast_arrays(np.asarray(n_dot_v, float), np.asarray(alpha, float))
    view = np.stack([alpha * np.sqrt(1.0 - mu * mu), np.zeros_like(mu), mu], -1)
    view /= np.linalg.norm(view, axis=-1, keepdims=True)
    t1 = np.where(view[..., :1] > 0.0, np.stack([np.zeros_like(mu), np.ones_like(mu), np.zeros_like(mu)], -1),
                  np.array([1.0, 0.0, 0.0]))         # (-v.y, v.x, 0) normalised: +y where v.x > 0
    t2 = np.cross(view, t1)
    u = (np.arange(n) + 0.5) / n
    u1, u2 = (x.ravel() for x in np.meshgrid(u, u, indexing="ij"))
    radius, phi = np.sqrt(u1), 2.0 * np.pi * u2
    p1, p2 = radius * np.cos(phi), radius * np.sin(phi)
    s = 0.5 * (1.0 + view[..., 2:3])
    p2 = (1.0 - s) * np.sqrt(1.0 - p1 * p1) + s * p2
    p3 = np.sqrt(np.maximum(0.0, 1.0 - p1 * p1 - p2 * p2))
    h = p1[..., None] * t1[..., None, :] + p2[..., None] * t2[..., None, :] + p3[..., None] * view[..., None, :]
    h = np.concatenate([alpha[..., None, None] * h[..., :2], np.maximum(h[..., 2:], 0.0)], -1)
    return h / np.linalg.norm(h, axis=-1, keepdims=True)


@functools.lru_cache(maxsize=None)
def dielectric_s_table(n: int = QUADRATURE) -> np.ndarray:
    """Cycles' ggx_gen_schlick_ior_s on its nodes, [z, n.v, roughness] (16, 16, 16) float64: the
    mean over the visible normals of the Fresnel's blend factor, 0 where the mirror direction is
    below the horizon (the module's docstring)."""
    rough, mu, z = _nodes(1e-4, 1.0), _nodes(1e-4, 1.0), _nodes(1e-4, 0.99)
    h = visible_normals(mu[:, None], (rough * rough)[None, :], n)             # (mu, r, n*n, 3)
    sin = np.sqrt(1.0 - mu * mu)[:, None, None]
    cos_hv = h[..., 0] * sin + h[..., 2] * mu[:, None, None]
    above = 2.0 * cos_hv * h[..., 2] - mu[:, None, None] >= 0.0
    out = np.empty((TABLE_SIZE,) * 3)
    for k, zk in enumerate(z):
        eta = (1.0 + zk * zk) / (1.0 - zk * zk)
        f0 = ((eta - 1.0) / (eta + 1.0)) ** 2
        blend = np.clip((_fresnel_np(cos_hv, eta) - f0) / (1.0 - f0), 0.0, 1.0)
        out[k] = np.where(above, blend, 0.0).mean(-1)
    return out


@functools.lru_cache(maxsize=None)
def ggx_albedo_tables() -> tuple[np.ndarray, np.ndarray]:
    """Cycles' ggx_E [n.v, roughness] (32, 32) and ggx_Eavg [roughness] (32,) on its nodes (r_i and
    n.v_j = i / 31, j / 31 clamped to [1e-4, 1]): GGX's directional albedo without Fresnel (alpha =
    r^2), which Cycles' precompute_ggx_E estimates by sampling, here brdf.energy's quadrature of it
    (about 1e-5), and E_avg = 2 int_0^1 n.v E dn.v (Gauss-Legendre)."""
    nodes = np.clip(np.arange(ALBEDO_SIZE) / (ALBEDO_SIZE - 1), 1e-4, 1.0)
    alpha = (nodes * nodes)[None, :]
    x, w = np.polynomial.legendre.leggauss(AVERAGE_NODES)
    x, w = 0.5 * (x + 1.0), 0.5 * w
    e_avg = 2.0 * np.sum((w * x)[:, None] * directional_albedo(x[:, None], alpha), axis=0)
    return directional_albedo(nodes[:, None], alpha), e_avg


def _node(x, size=TABLE_SIZE):
    """Cycles' lookup_table_read along one axis: the node below x (saturated, on ``size`` nodes), the one
    above (clamped to the last) and the weight of the one above."""
    u = jnp.clip(x, 0.0, 1.0) * (size - 1)
    i = jnp.minimum(jnp.floor(u), size - 1).astype(jnp.int32)
    return i, jnp.minimum(i + 1, size - 1), u - i


def cycles_dielectric_s(roughness: Float[ArrayLike, "*#batch"], n_dot_v: Float[ArrayLike, "*batch"],
                        z: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """S(r, n.v, z) read from ``dielectric_s_table`` trilinearly, as Cycles' lookup_table_read_3D."""
    table = jnp.asarray(dielectric_s_table(), dtype=jnp.result_type(roughness, n_dot_v, z, float))
    (x0, x1, fx), (y0, y1, fy), (z0, z1, fz) = _node(roughness), _node(n_dot_v), _node(z)

    def plane(k):
        return ((1 - fy) * ((1 - fx) * table[k, y0, x0] + fx * table[k, y0, x1])
                + fy * ((1 - fx) * table[k, y1, x0] + fx * table[k, y1, x1]))
    return (1 - fz) * plane(z0) + fz * plane(z1)


def cycles_dielectric_albedo(n_dot_v: Float[ArrayLike, "*batch"], roughness: Float[ArrayLike, "*#batch"],
                             ior: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Cycles' estimate of a reflecting dielectric layer's albedo at the view: F0 + (1 - F0) S."""
    f0 = f0_from_ior(ior)
    z = jnp.sqrt(jnp.maximum(jnp.abs((ior - 1.0) / (ior + 1.0)), 1e-12))
    return f0 + (1.0 - f0) * cycles_dielectric_s(roughness, n_dot_v, z)


def cycles_dielectric_layer(top: Float[ArrayLike, "*batch"], below: Float[ArrayLike, "*batch 3"],
                            n_dot_v: Float[ArrayLike, "*batch"], roughness: Float[ArrayLike, "*#batch"],
                            ior: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch 3"]:
    """The specular layer over the diffuse: its lobe ``top`` (F D V) + ``below`` x saturate(1 - albedo(n.v))
    (closure_layering_weight)."""
    through = jnp.clip(1.0 - cycles_dielectric_albedo(n_dot_v, roughness, ior), 0.0, 1.0)
    return jnp.asarray(top)[..., None] + through[..., None] * below


def cycles_ggx_albedo(n_dot_v: Float[ArrayLike, "*batch"],
                      roughness: Float[ArrayLike, "*#batch"]) -> tuple[Float[Array, "*batch"], Float[Array, "*#batch"]]:
    """E(r, n.v) and E_avg(r) read from ``ggx_albedo_tables`` as Cycles reads ggx_E (bilinearly) and ggx_Eavg."""
    e, e_avg = (jnp.asarray(t, dtype=jnp.result_type(n_dot_v, roughness, float)) for t in ggx_albedo_tables())
    (x0, x1, fx), (y0, y1, fy) = _node(roughness, ALBEDO_SIZE), _node(n_dot_v, ALBEDO_SIZE)
    albedo = ((1 - fy) * ((1 - fx) * e[y0, x0] + fx * e[y0, x1]) + fy * ((1 - fx) * e[y1, x0] + fx * e[y1, x1]))
    return albedo, (1 - fx) * e_avg[x0] + fx * e_avg[x1]


def cycles_dielectric_fss(ior: Float[ArrayLike, "*#batch"]) -> Float[Array, "*#batch"]:
    """fresnel_dielectric_Fss: Kulla and Conty's fit (c - 1) / (4.08567 + 1.00071 c) of the dielectric
    Fresnel's hemispherical average (IOR at least 1)."""
    return (ior - 1.0) / (4.08567 + 1.00071 * ior)


def cycles_f82_fss(f0: Float[ArrayLike, "*#batch #3"],
                   f82: Float[ArrayLike, "*#batch #3"]) -> Float[Array, "*#batch 3"]:
    """fresnel_f82_Fss: the F82-tint Fresnel's hemispherical average, F0 + (1 - F0) / 21 - b / 126 with b
    brdf.openpbr.f82_tint_b (fresnel_f82tint_B)."""
    f0 = jnp.asarray(f0)
    return f0 + (1.0 - f0) / 21.0 - f82_tint_b(f0, f82) / 126.0


def _kept(e, e_avg, fss):
    """1 + F_ms (1 - E) / E, F_ms = F_ss E_avg / (1 - F_ss (1 - E_avg))."""
    f_ms = fss * e_avg / (1.0 - fss * (1.0 - e_avg))
    return 1.0 + f_ms * (1.0 - e) / e


def cycles_multiscatter(n_dot_v: Float[ArrayLike, "*batch"], roughness: Float[ArrayLike, "*#batch"],
                        fss: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """microfacet_ggx_preserve_energy's factor on a GGX lobe of Fresnel average ``fss``: 1 + F_ms (1 - E) / E,
    F_ms = F_ss E_avg / (1 - F_ss (1 - E_avg)), E and E_avg of ``cycles_ggx_albedo`` (the module's docstring)."""
    e, e_avg = cycles_ggx_albedo(n_dot_v, roughness)
    return _kept(e, e_avg, fss)


def _kept_layer(top, below, n_dot_v, roughness, ior, weight, fss):
    """A dielectric layer kept its energy over ``below``: w C top + saturate(1 - w E C albedo(n.v)) below."""
    e, e_avg = cycles_ggx_albedo(n_dot_v, roughness)
    kept = _kept(e, e_avg, fss)
    through = jnp.clip(1.0 - weight * e * kept * cycles_dielectric_albedo(n_dot_v, roughness, ior), 0.0, 1.0)
    return (weight * kept * jnp.asarray(top))[..., None] + through[..., None] * below


def cycles_coat_layer(top: Float[ArrayLike, "*batch"], below: Float[ArrayLike, "*batch 3"],
                      n_dot_v: Float[ArrayLike, "*batch"], roughness: Float[ArrayLike, "*#batch"],
                      ior: Float[ArrayLike, "*#batch"],
                      weight: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch 3"]:
    """The coat (weight w, its lobe ``top`` F D V) over ``below``, as Cycles sets it up: the lobe kept
    energy by microfacet_ggx_preserve_energy, times C = ``cycles_multiscatter`` of F_ss =
    ``cycles_dielectric_fss``; below it saturate(1 - w E C albedo(n.v)) (the closure's weight holds E C)."""
    return _kept_layer(top, below, n_dot_v, roughness, ior, weight, cycles_dielectric_fss(ior))


def _fujii_missing(mu):
    """k - G(mu), k = pi / 2 - 2 / 3: Fujii's G (bsdf_oren_nayar_G) written without its cancellation
    towards grazing (G -> k there): with s = sin(theta), 1 - s = mu^2 / (1 + s) and 1 - s^3 = (1 - s)(1 + s + s^2),
    k (1 - s) + s asin(mu) + s^2 mu - 2/3 s mu (1 + s + s^2) / (1 + s)."""
    mu = jnp.clip(mu, 0.0, 1.0)
    s = jnp.sqrt(1.0 - mu * mu)
    return ((jnp.pi / 2.0 - 2.0 / 3.0) * mu * mu / (1.0 + s) + s * jnp.arctan2(mu, s) + s * s * mu
            - 2.0 / 3.0 * s * mu * (1.0 + s + s * s) / (1.0 + s))


def cycles_diffuse(base_color: Float[ArrayLike, "*#batch #3"], diffuse_roughness: Float[ArrayLike, "*#batch"],
                   n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
                   l_dot_v: Float[ArrayLike, "*batch"]) -> Float[Array, "*batch 3"]:
    """Cycles' diffuse of Diffuse Roughness sigma (RGB, 1/sr, without the cosine): the module's
    docstring; Lambert below LAMBERT_BELOW."""
    rho = jnp.asarray(base_color)
    lambert = jnp.asarray(diffuse_roughness) < LAMBERT_BELOW
    sigma = jnp.where(lambert, 1.0, jnp.clip(diffuse_roughness, 0.0, 1.0))    # (a safe value where unused)
    nl, nv = jnp.maximum(n_dot_l, 0.0), jnp.maximum(n_dot_v, 0.0)
    a = 1.0 / (jnp.pi + sigma * (jnp.pi / 2.0 - 2.0 / 3.0))
    b = sigma * a
    t = l_dot_v - nl * nv
    t = jnp.where(t > 0.0, t / jnp.maximum(jnp.maximum(nl, nv), 1e-30), t)
    # 1 - E(mu) = b (k - G(mu)) and 1 - E_avg = b (k - c), k = pi / 2 - 2 / 3, c = (2 pi - 5.6) / 3: the
    # same numbers as Cycles' 1 - (a pi + b G), without its cancellation (a pi = 1 - b k)
    missing = b * (jnp.pi / 2.0 - 2.0 / 3.0 - (2.0 * jnp.pi - 5.6) / 3.0)
    albedo = jnp.clip(rho, 0.0, 1.0)
    e_ms = (albedo * albedo / jnp.pi * ((1.0 - missing) / missing)[..., None]
            / (1.0 - albedo * missing[..., None]))
    lost = b * b * _fujii_missing(nv) * _fujii_missing(nl)
    rough = rho * ((a + b * t)[..., None] + e_ms * lost[..., None])
    return jnp.where(lambert[..., None], rho / jnp.pi * jnp.ones_like(rough), rough)


def cycles_nonmetal(dv: Float[ArrayLike, "*batch"], v_dot_h: Float[ArrayLike, "*batch"],
                    n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
                    l_dot_v: Float[ArrayLike, "*batch"], roughness: Float[ArrayLike, "*#batch"],
                    base_color: Float[ArrayLike, "*#batch #3"], ior: Float[ArrayLike, "*#batch"],
                    diffuse_roughness: Float[ArrayLike, "*#batch"], ms: bool = False) -> Float[Array, "*batch 3"]:
    """The Principled BSDF's dielectric base as Cycles draws it, from its specular D V (RGB):
    F_dielectric(v.h, eta) D V + saturate(1 - albedo(n.v)) x ``cycles_diffuse``; ``ms``: with the
    distribution Multiscatter GGX, the lobe kept its energy as the coat's is (F_ss the dielectric's,
    kept within [F0, 1] as the generalized Schlick Fresnel's s is saturated)."""
    top = fresnel_dielectric(v_dot_h, ior) * dv
    below = cycles_diffuse(base_color, diffuse_roughness, n_dot_l, n_dot_v, l_dot_v)
    if not ms:
        return cycles_dielectric_layer(top, below, n_dot_v, roughness, ior)
    fss = jnp.clip(cycles_dielectric_fss(ior), f0_from_ior(ior), 1.0)
    return _kept_layer(top, below, n_dot_v, roughness, ior, 1.0, fss)


def cycles_sheen_layer(below: Float[ArrayLike, "*batch 3"], wi: Float[ArrayLike, "*batch 3"],
                       wo: Float[ArrayLike, "*batch 3"], weight: Float[ArrayLike, "*#batch"],
                       tint: Float[ArrayLike, "*#batch #3"],
                       roughness: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch 3"]:
    """The Principled BSDF's sheen over ``below`` (RGB; ``wo`` the view): w t E D / n.l + saturate(1 -
    max_c(w t_c E(n.v))) below, E, D of MaterialX's fits (the module's docstring)."""
    n_dot_v = jnp.clip(jnp.asarray(wo)[..., 2], N_DOT_V_MIN, 1.0)
    r = jnp.clip(roughness, FUZZ_ROUGHNESS_MIN, 1.0)
    albedo = (weight * jnp.maximum(zeltner_dir_albedo(n_dot_v, r), 0.0))[..., None] * jnp.asarray(tint)
    through = jnp.clip(1.0 - jnp.max(albedo, axis=-1), 0.0, 1.0)
    return albedo * zeltner_density(wi, wo, n_dot_v, r)[..., None] + through[..., None] * below
