"""The sheen layer of KHR_materials_sheen: Charlie's lobe over the glTF material.

KHR_materials_sheen (README, "Implementation Notes", non-normative; the
glTF Sample Viewer's brdf.glsl writes the same): with alpha = sheenRoughness^2
(floored at ALPHA_MIN, as every alpha here),

    D(h)   = (2 + 1/alpha) sin(theta_h)^(1/alpha) / (2 pi)          ("Charlie",
             Estevez & Kulla 2017, "Production Friendly Microfacet Sheen BRDF")
    V      = 1 / ((1 + Lambda(n.v) + Lambda(n.l)) 4 (n.l)(n.v))     (Charlie's visibility,
             Lambda the same paper's fit, the one the extension recommends)
    f      = sheenColor D V + f_base scaling
    scaling = min(1 - max3(sheenColor) E(n.v), 1 - max3(sheenColor) E(n.l))

E(mu) = int D V (n.l) dl is the sheen lobe's directional albedo for sheenColor 1
(the extension's table "E(x)", looked up with x = n.v, y = sheenRoughness).  Here
it is computed once, by quadrature of the very lobe below (numpy, float64, about
0.3 s on first use), on a (mu, sheenRoughness) grid and interpolated bilinearly
in JAX, as brdf/energy.py does for GGX: differentiable, and the GLSL twin
(shaders/sheen.glsl) reads the same table from a texture.

three.js r187 (src/renderers/shaders/ShaderChunk/lights_physical_pars_fragment.glsl.js)
draws the same D (with sin^2(theta_h) floored at 2^-7) but Neubelt & Pettineo's
visibility 1 / (4 (n.l + n.v - n.l n.v)) (the extension's cheaper alternative,
``neubelt_visibility``) and, for E, a curve fit exp(a n.v + b) (``IBLSheenBRDF``,
``three_sheen_albedo``) in 1 - max3(sheenColor) max(E(n.v), E(n.l)).
docs/gltf.md compares the two.

sheenColor 0 gives the base material exactly (the extension: "If sheenColorFactor
is zero, the whole sheen layer is disabled").
"""

from __future__ import annotations

import functools
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np
from jaxtyping import Float

from ._lazy import jnp
from .constants import ALPHA_MIN, ROUGHNESS_MIN
from .declare import GltfKey, Param, Term
from .energy import _interp_coord  # (the grid coordinates of brdf.energy's tables)

if TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import Array, ArrayLike

# sin^2(theta_h) is held at this or above inside D's power: at n.h = 1 the power's
# derivative in alpha is sin^(1/alpha) log(sin^2) = 0 x -inf.  (three.js r187 holds
# it at 2^-7 for half floats; at 1e-7 D changes by less than 1e-7 relative for alpha > 0.05.)
SHEEN_SIN2H_MIN = 1e-7
# The argument of x^c in Charlie's Lambda fit is held at this or above (x^c log x at 0).
SHEEN_LAMBDA_X_MIN = 1e-6
# Charlie's Lambda fit (Estevez & Kulla 2017; the extension's l(x, alphaG)): each
# coefficient is mix(at alpha = 1, at alpha = 0, (1 - alpha)^2).
CHARLIE_L_ROUGH = (21.5473, 3.82987, 0.19823, -1.97760, -4.32054)
CHARLIE_L_SMOOTH = (25.3245, 3.32435, 0.16801, -1.27393, -4.85967)
# The albedo table: nodes uniform in mu^(1/SHEEN_MU_POWER) and in the sheen roughness.
# Bilinear, it is within 1e-3 of the quadrature for sheenRoughness >= 0.3 and mu >= 0.05
# (0.013 at sheenRoughness 0.04, where E falls from 1 to 0 within a few nodes).
SHEEN_TABLE_SIZE = 32
SHEEN_MU_POWER = 4
SHEEN_QUADRATURE_NODES = 48  # Gauss-Legendre nodes per panel of n.l (two panels) and of phi


def sheen_alpha(roughness: Float[ArrayLike, "*#batch"], xp: ModuleType = jnp) -> Float[ArrayLike, "*#batch"]:
    """alpha = sheenRoughness^2, floored at ALPHA_MIN (the roughness at ROUGHNESS_MIN)."""
    r = xp.clip(roughness, ROUGHNESS_MIN, 1.0)
    return xp.maximum(r * r, ALPHA_MIN)


def charlie_ndf(n_dot_h: Float[ArrayLike, "*batch"], alpha: Float[ArrayLike, "*#batch"],
                xp: ModuleType = jnp) -> Float[Array, "*batch"]:
    """Charlie: D = (2 + 1/alpha) sin(theta_h)^(1/alpha) / (2 pi), normalised
    (int D (n.h) dh = 1 for every alpha)."""
    inv = 1.0 / alpha
    c = xp.clip(n_dot_h, 0.0, 1.0)
    sin2 = xp.maximum(1.0 - c * c, SHEEN_SIN2H_MIN)
    return (2.0 + inv) * xp.exp(0.5 * inv * xp.log(sin2)) / (2.0 * np.pi)


def _charlie_l(x, alpha, xp):
    """The extension's l(x, alphaG): a / (1 + b x^c) + d x + e."""
    t = (1.0 - alpha) * (1.0 - alpha)
    a, b, c, d, e = (rough + (smooth - rough) * t for rough, smooth in zip(CHARLIE_L_ROUGH, CHARLIE_L_SMOOTH))
    x = xp.maximum(x, SHEEN_LAMBDA_X_MIN)
    return a / (1.0 + b * xp.exp(c * xp.log(x))) + d * x + e


def charlie_lambda(cos_theta: Float[ArrayLike, "*batch"], alpha: Float[ArrayLike, "*#batch"],
                   xp: ModuleType = jnp) -> Float[Array, "*batch"]:
    """Lambda of the sheen's visibility: exp(l(cos)) below cos 0.5, exp(2 l(0.5) - l(1 - cos)) above."""
    c = xp.clip(xp.abs(cos_theta), 0.0, 1.0)
    low = c < 0.5
    l_x = _charlie_l(xp.where(low, c, 1.0 - c), alpha, xp)     # one l per direction: l(cos) or l(1 - cos)
    return xp.exp(xp.where(low, l_x, 2.0 * _charlie_l(0.5, alpha, xp) - l_x))


def charlie_visibility(n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
                       alpha: Float[ArrayLike, "*#batch"], xp: ModuleType = jnp) -> Float[Array, "*batch"]:
    """V = 1 / ((1 + Lambda(n.v) + Lambda(n.l)) 4 (n.l)(n.v)), the extension's recommended
    visibility, clamped to [0, 1] as the glTF Sample Viewer's ``V_Sheen`` clamps it: unclamped,
    the Lambda fit lets V grow to ~1500 where both directions graze, and the lobe's albedo
    passes 1 (E(n.v = 0.05) = 1.03 at sheenRoughness 0.1)."""
    nl = xp.clip(n_dot_l, SHEEN_LAMBDA_X_MIN, 1.0)
    nv = xp.clip(n_dot_v, SHEEN_LAMBDA_X_MIN, 1.0)
    lam = charlie_lambda(nv, alpha, xp) + charlie_lambda(nl, alpha, xp)
    return xp.minimum(1.0 / ((1.0 + lam) * (4.0 * nl * nv)), 1.0)


def neubelt_visibility(n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
                       xp: ModuleType = jnp) -> Float[Array, "*batch"]:
    """Neubelt & Pettineo 2013 (Ashikhmin & Premoze 2007): V = 1 / (4 (n.l + n.v - n.l n.v)),
    clamped to [0, 1]: three.js r187's ``V_Neubelt`` (for comparison; not our model's)."""
    nl, nv = xp.clip(n_dot_l, 0.0, 1.0), xp.clip(n_dot_v, 0.0, 1.0)
    return xp.clip(1.0 / (4.0 * (nl + nv - nl * nv)), 0.0, 1.0)


def three_sheen_albedo(n_dot_v: Float[ArrayLike, "*batch"], roughness: Float[ArrayLike, "*#batch"],
                       xp: ModuleType = np) -> Float[Array, "*batch"]:
    """three.js r187's ``IBLSheenBRDF``: its curve fit of the sheen albedo (for comparison)."""
    nv = xp.clip(n_dot_v, 0.0, 1.0)
    r2, r_inv = roughness * roughness, 1.0 / (roughness + 0.1)
    a = -1.9362 + 1.0678 * roughness + 0.4573 * r2 - 0.8469 * r_inv
    b = -0.6014 + 0.5538 * roughness - 0.4670 * r2 - 0.1255 * r_inv
    return xp.clip(xp.exp(a * nv + b), 0.0, 1.0)


def sheen_dv(n_dot_h: Float[ArrayLike, "*batch"], n_dot_l: Float[ArrayLike, "*batch"],
             n_dot_v: Float[ArrayLike, "*batch"], roughness: Float[ArrayLike, "*#batch"],
             xp: ModuleType = jnp) -> Float[Array, "*batch"]:
    """D V of the sheen lobe (1/sr; times sheenColor it is f_sheen)."""
    alpha = sheen_alpha(roughness, xp)
    return charlie_ndf(n_dot_h, alpha, xp) * charlie_visibility(n_dot_l, n_dot_v, alpha, xp)


# --- the directional albedo E(mu, sheenRoughness) -------------------------------

def sheen_albedo_quadrature(mu: Float[ArrayLike, "*batch"], roughness: Float[ArrayLike, "*#batch"],
                            nodes: int = SHEEN_QUADRATURE_NODES) -> np.ndarray:
    """E(mu) = int D V (n.l) dl of the sheen lobe (sheenColor 1), by quadrature (numpy, float64).

    n.l = t^5 on two Gauss-Legendre panels of t (split where n.l = 0.5, Lambda's seam):
    Lambda's x^0.2 at grazing becomes smooth in t; phi over [0, pi] (the lobe is even
    in phi).  ``mu`` and ``roughness`` broadcast.
    """
    mu, roughness = np.broadcast_arrays(np.asarray(mu, float), np.asarray(roughness, float))
    mu = np.clip(mu, 1e-6, 1.0)[..., None, None]
    alpha = sheen_alpha(roughness, np)[..., None, None]
    x, w = np.polynomial.legendre.leggauss(nodes)
    x, w = 0.5 * (x + 1.0), 0.5 * w
    seam = 0.5 ** 0.2
    t = np.concatenate([seam * x, seam + (1.0 - seam) * x])
    wt = np.concatenate([seam * w, (1.0 - seam) * w])
    nl, wnl = t ** 5, wt * 5.0 * t ** 4                       # d(n.l) = 5 t^4 dt
    phi, wphi = np.pi * x, np.pi * w
    nl, wnl = nl[:, None], wnl[:, None]
    sl, sv = np.sqrt(1.0 - nl * nl), np.sqrt(1.0 - mu * mu)
    # l = (sl cos phi, sl sin phi, nl), v = (sv, 0, mu): n.h = (nl + mu) / |l + v|
    l_dot_v = sl * sv * np.cos(phi) + nl * mu
    n_dot_h = (nl + mu) / np.sqrt(2.0 + 2.0 * l_dot_v)
    f = charlie_ndf(n_dot_h, alpha, np) * charlie_visibility(nl, mu, alpha, np)
    return 2.0 * np.sum(f * nl * wnl * wphi[None, :], axis=(-2, -1))


@functools.lru_cache(maxsize=None)
def sheen_table(size: int = SHEEN_TABLE_SIZE) -> dict:
    """{"mu": (size,), "roughness": (size,), "E": (size, size) [mu, r]} on mu_j = (j/(size-1))^4
    (E climbs steeply towards grazing, like Lambda's mu^0.2: nodes uniform in mu^(1/4)),
    r_k = ROUGHNESS_MIN..1 (float64)."""
    mu = np.linspace(0.0, 1.0, size) ** SHEEN_MU_POWER
    r = np.linspace(ROUGHNESS_MIN, 1.0, size)
    return {"mu": mu, "roughness": r, "E": sheen_albedo_quadrature(mu[:, None], r[None, :])}


def lookup_sheen_e(mu: Float[ArrayLike, "*batch"], roughness: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """E(mu, sheenRoughness) bilinearly interpolated in (mu^(1/4), r) from ``sheen_table``
    (JAX, differentiable in the roughness)."""
    table = jnp.asarray(sheen_table()["E"], dtype=jnp.result_type(mu, roughness, float))
    n = table.shape[0]
    i, fi = _interp_coord(jnp.sqrt(jnp.sqrt(jnp.clip(mu, 0.0, 1.0))), 0.0, 1.0, n)
    k, fk = _interp_coord(roughness, ROUGHNESS_MIN, 1.0, n)
    e00, e01 = table[i, k], table[i, k + 1]
    e10, e11 = table[i + 1, k], table[i + 1, k + 1]
    return (1 - fi) * ((1 - fk) * e00 + fk * e01) + fi * ((1 - fk) * e10 + fk * e11)


def _max3(c):
    """max over RGB as pairwise maxima (a jnp.max reduction's gradient can be NaN: brdf/gltf.py)."""
    return jnp.maximum(jnp.maximum(c[..., 0], c[..., 1]), c[..., 2])


def sheen_layer(base: Float[ArrayLike, "*batch 3"], sheen_color: Float[ArrayLike, "*#batch 3"],
                sheen_roughness: Float[ArrayLike, "*#batch"], n_dot_l: Float[ArrayLike, "*batch"],
                n_dot_v: Float[ArrayLike, "*batch"], n_dot_h: Float[ArrayLike, "*batch"]) -> Float[Array, "*batch 3"]:
    """sheenColor D V + base min(1 - max3(sheenColor) E(n.v), 1 - max3(sheenColor) E(n.l)):
    the extension's albedo-scaling layering of the sheen over the glTF material ``base``."""
    color = jnp.broadcast_to(jnp.asarray(sheen_color), (*jnp.shape(sheen_color)[:-1], 3)) \
        if jnp.ndim(sheen_color) else jnp.full((3,), sheen_color)
    e_v = lookup_sheen_e(jnp.clip(n_dot_v, 0.0, 1.0), sheen_roughness)
    e_l = lookup_sheen_e(jnp.clip(n_dot_l, 0.0, 1.0), sheen_roughness)
    # held at 0 or above: E passes 1 where n.v or n.l < ~0.05 (the visibility fit's grazing
    # gain, docs/gltf.md), and a negative base would be the formula's artefact, not light
    scaling = jnp.maximum(1.0 - _max3(color) * jnp.maximum(e_v, e_l), 0.0)
    dv = sheen_dv(n_dot_h, n_dot_l, n_dot_v, sheen_roughness)
    return color * dv[..., None] + base * scaling[..., None]


# --- declaration ------------------------------------------------------------------
# Not fused (the layer is not linear in the glTF parameters fitting.fused's sums cover)
# and without a neutral value (sheen colour 0 is the base material exactly, but a
# neutral would put the term in the glTF family's root program and change every other
# glTF model's fit: docs/gltf.md).  Starts inside the bounds: a start on a bound never
# moves under the bounded transform.
_KHR = "KHR_materials_sheen"
SHEEN = Term(name="sheen", token="sheen", hint="KHR_materials_sheen (Charlie)", params=(
    Param("sheen_color", 3, 0.0, 1.0, 0.2, "KHR_materials_sheen sheenColorFactor (linear RGB)",
          gltf=GltfKey(_KHR, "sheenColorFactor", 0.0)),
    Param("sheen_roughness", 1, ROUGHNESS_MIN, 1.0, 0.5,
          "KHR_materials_sheen sheenRoughnessFactor (Charlie's alpha = its square)",
          gltf=GltfKey(_KHR, "sheenRoughnessFactor", 0.0))))
