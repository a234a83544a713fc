"""Microfacet specular terms: the GGX / Trowbridge-Reitz NDF and Smith masking.

Sources: Trowbridge & Reitz 1975; Walter et al. 2007 ("Microfacet models for
refraction through rough surfaces", GGX); Heitz 2014 ("Understanding the
masking-shadowing function in microfacet-based BRDFs", Smith Lambda, the
height-correlated form and the anisotropic extension); Karis 2013 (UE4
Schlick-GGX); Kulla & Conty 2017 (anisotropy remap); glTF
KHR_materials_anisotropy.  Formulas restated in docs/models.md.

Every function takes alpha = roughness**2 (not the perceptual roughness) and
floors it at ALPHA_MIN.  The declarations at the end (roughness, the NDFs,
maskings and anisotropy remaps) are what brdf.spec builds models from.
"""

from __future__ import annotations

import math
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np
from jaxtyping import Float

from ._lazy import jnp
from .constants import ALPHA_MIN, INV_PI, ROUGHNESS_MIN
from .declare import CORE, GltfKey, GltfRule, Masking, Ndf, Param, Remap, Start
from .geometry import clamp_cos

if TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import Array, ArrayLike


def _floor(alpha):
    return jnp.maximum(alpha, ALPHA_MIN)


# --- normal distribution --------------------------------------------------

def ggx_ndf(n_dot_h: Float[ArrayLike, "*batch"], alpha: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Isotropic GGX: D = a^2 / (pi ((n.h)^2 (a^2 - 1) + 1)^2), 0 for n.h <= 0."""
    a2 = _floor(alpha) ** 2
    c = jnp.maximum(n_dot_h, 0.0)
    d = c * c * (a2 - 1.0) + 1.0
    return jnp.where(n_dot_h > 0.0, a2 / (jnp.pi * d * d), 0.0)


def ggx_ndf_aniso(h: Float[ArrayLike, "*batch 3"], alpha_t: Float[ArrayLike, "*#batch"],
                  alpha_b: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Anisotropic GGX in the overflow-safe form (Heitz 2014; UE D_GGXaniso).

    ``h`` is the (unit) half vector in the tangent frame (t.h, b.h, n.h).
    D = a2 (a2 / |f|^2)^2 / pi with a2 = at ab, f = (ab t.h, at b.h, a2 n.h).
    """
    at, ab = _floor(alpha_t), _floor(alpha_b)
    a2 = at * ab
    up = h[..., 2] > 0.0
    # Below the horizon (including h = 0 when wi = -wo, where |f| = 0) read the
    # normal instead, so the discarded branch of the where has a finite gradient.
    hx, hy, hz = (jnp.where(up, h[..., 0], 0.0), jnp.where(up, h[..., 1], 0.0),
                  jnp.where(up, h[..., 2], 1.0))
    fx, fy, fz = ab * hx, at * hy, a2 * hz
    w2 = a2 / (fx * fx + fy * fy + fz * fz)
    return jnp.where(up, a2 * w2 * w2 * INV_PI, 0.0)


# --- anisotropy remaps ------------------------------------------------------

def anisotropy_kulla_conty(alpha: Float[ArrayLike, "*#batch"], anisotropy: Float[ArrayLike, "*#batch"],
                           xp: ModuleType = jnp) -> tuple[Float[ArrayLike, "*#batch"], Float[ArrayLike, "*#batch"]]:
    """Kulla & Conty 2017: (alpha, a in [-1, 1]) -> (alpha (1 + a), alpha (1 - a))."""
    return (xp.maximum(alpha * (1.0 + anisotropy), ALPHA_MIN),
            xp.maximum(alpha * (1.0 - anisotropy), ALPHA_MIN))


def anisotropy_gltf(alpha: Float[ArrayLike, "*#batch"], strength: Float[ArrayLike, "*#batch"],
                    xp: ModuleType = jnp) -> tuple[Float[ArrayLike, "*#batch"], Float[ArrayLike, "*#batch"]]:
    """KHR_materials_anisotropy: alpha_t = mix(alpha, 1, s^2), alpha_b = alpha.

    (``xp`` is unused -- operators only -- and kept for the remaps' one signature.)
    """
    s2 = strength * strength
    return alpha + (1.0 - alpha) * s2, alpha


def anisotropy_burley(
    roughness: Float[ArrayLike, "*#batch"], anisotropic: Float[ArrayLike, "*#batch"],
) -> tuple[Float[Array, "*#batch"], Float[Array, "*#batch"]]:
    """Burley 2012 (Disney): aspect = sqrt(1 - 0.9 a); (r^2/aspect, r^2 aspect)."""
    aspect = jnp.sqrt(1.0 - 0.9 * anisotropic)
    r2 = roughness * roughness
    return jnp.maximum(r2 / aspect, ALPHA_MIN), jnp.maximum(r2 * aspect, ALPHA_MIN)


# --- Smith masking ----------------------------------------------------------

def smith_lambda(n_dot_v: Float[ArrayLike, "*batch"], alpha: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Lambda(v) = (-1 + sqrt(1 + a^2 tan^2 theta)) / 2 for GGX."""
    c = clamp_cos(n_dot_v)
    c2 = c * c
    a2 = _floor(alpha) ** 2
    tan2 = (1.0 - c2) / c2
    return 0.5 * (jnp.sqrt(1.0 + a2 * tan2) - 1.0)


def smith_lambda_aniso(v: Float[ArrayLike, "*batch 3"], alpha_t: Float[ArrayLike, "*#batch"],
                       alpha_b: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Anisotropic Lambda: a^2 tan^2 becomes (at^2 (t.v)^2 + ab^2 (b.v)^2)/(n.v)^2."""
    at, ab = _floor(alpha_t), _floor(alpha_b)
    c = clamp_cos(v[..., 2])
    x = (at * v[..., 0]) ** 2 + (ab * v[..., 1]) ** 2
    return 0.5 * (jnp.sqrt(1.0 + x / (c * c)) - 1.0)


def smith_g1(n_dot_v: Float[ArrayLike, "*batch"], alpha: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """G1 = 1 / (1 + Lambda) = 2 n.v / (n.v + sqrt(a^2 + (1 - a^2)(n.v)^2))."""
    c = clamp_cos(n_dot_v)
    a2 = _floor(alpha) ** 2
    return 2.0 * c / (c + jnp.sqrt(a2 + (1.0 - a2) * c * c))


def smith_g1_schlick(n_dot_v: Float[ArrayLike, "*batch"], k: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Schlick-GGX (Karis 2013): G1 ~ n.v / (n.v (1 - k) + k).

    k = (r + 1)^2 / 8 for analytic lights, k = alpha / 2 for image lighting.
    """
    c = clamp_cos(n_dot_v)
    return c / (c * (1.0 - k) + k)


def g_separable(n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
                alpha: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Uncorrelated Smith: G = G1(l) G1(v)."""
    return smith_g1(n_dot_l, alpha) * smith_g1(n_dot_v, alpha)


def g_height_correlated(n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
                        alpha: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Height-correlated Smith: G2 = 1 / (1 + Lambda(l) + Lambda(v))."""
    return 1.0 / (1.0 + smith_lambda(n_dot_l, alpha) + smith_lambda(n_dot_v, alpha))


def visibility_height_correlated(n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
                                 alpha: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """V = G2 / (4 n.l n.v) = 0.5 / (n.l sqrt(a^2 + (n.v)^2 (1-a^2)) + n.v sqrt(...l))."""
    nl, nv = clamp_cos(n_dot_l), clamp_cos(n_dot_v)
    a2 = _floor(alpha) ** 2
    gv = nl * jnp.sqrt(a2 + nv * nv * (1.0 - a2))
    gl = nv * jnp.sqrt(a2 + nl * nl * (1.0 - a2))
    return 0.5 / (gv + gl)


def visibility_separable(n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
                         alpha: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """V = G1(l) G1(v) / (4 n.l n.v), written without the cancelling cosines."""
    nl, nv = clamp_cos(n_dot_l), clamp_cos(n_dot_v)
    a2 = _floor(alpha) ** 2
    gl = nl + jnp.sqrt(a2 + (1.0 - a2) * nl * nl)
    gv = nv + jnp.sqrt(a2 + (1.0 - a2) * nv * nv)
    return 1.0 / (gl * gv)


def visibility_height_correlated_aniso(l: Float[ArrayLike, "*batch 3"], v: Float[ArrayLike, "*batch 3"],
                                       alpha_t: Float[ArrayLike, "*#batch"],
                                       alpha_b: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """V = 0.5 / (n.l |(at t.v, ab b.v, n.v)| + n.v |(at t.l, ab b.l, n.l)|) (Heitz 2014)."""
    at, ab = _floor(alpha_t), _floor(alpha_b)
    nl, nv = clamp_cos(l[..., 2]), clamp_cos(v[..., 2])
    lv = jnp.sqrt((at * v[..., 0]) ** 2 + (ab * v[..., 1]) ** 2 + nv * nv)
    ll = jnp.sqrt((at * l[..., 0]) ** 2 + (ab * l[..., 1]) ** 2 + nl * nl)
    return 0.5 / (nl * lv + nv * ll)


def visibility_separable_aniso(l: Float[ArrayLike, "*batch 3"], v: Float[ArrayLike, "*batch 3"],
                               alpha_t: Float[ArrayLike, "*#batch"],
                               alpha_b: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """V = G1(l) G1(v) / (4 n.l n.v) with the anisotropic Lambda."""
    g = 1.0 / ((1.0 + smith_lambda_aniso(l, alpha_t, alpha_b))
               * (1.0 + smith_lambda_aniso(v, alpha_t, alpha_b)))
    return g / (4.0 * clamp_cos(l[..., 2]) * clamp_cos(v[..., 2]))


def visibility_smith_joint_approx(n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
                                  alpha: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """UE Vis_SmithJointApprox: 0.5 / (n.l (n.v (1-a) + a) + n.v (n.l (1-a) + a))."""
    nl, nv = clamp_cos(n_dot_l), clamp_cos(n_dot_v)
    a = _floor(alpha)
    return 0.5 / (nl * (nv * (1.0 - a) + a) + nv * (nl * (1.0 - a) + a))


# --- declarations -------------------------------------------------------------

ROUGHNESS = Param("roughness", 1, ROUGHNESS_MIN, 1.0, 0.5,
                  "perceptual roughness r (alpha = r^2), glTF roughnessFactor",
                  gltf=GltfKey(CORE, "roughnessFactor", 1.0),
                  start=Start(scan=tuple(float(r) for r in np.geomspace(0.04, 1.0, 16))))
ROTATION = Param("rotation", 1, -math.pi / 2, math.pi / 2, 0.0,
                 "anisotropy direction: the tangent rotated CCW from +x", "rad", period=math.pi,
                 gltf=GltfKey("KHR_materials_anisotropy", "anisotropyRotation", 0.0))
# Start variants of an anisotropic lobe (values are clipped to the bounds: a
# remap without negative anisotropy tries 0 instead of -0.5).
ANISOTROPY_STARTS = (("anisotropy", "rotation"),
                     ((0.0, 0.0), (0.5, 0.0), (-0.5, 0.0), (0.5, math.pi / 4), (0.5, -math.pi / 4)))

NDFS = {
    "ggx": Ndf(name="ggx", params=(ROUGHNESS,), lobe=ggx_ndf, fused=True, smith_lambda=smith_lambda,
               visibility=(("height_correlated", visibility_height_correlated),
                           ("separable", visibility_separable))),
    "ggx_aniso": Ndf(name="ggx_aniso", params=(ROUGHNESS,), lobe=ggx_ndf_aniso, anisotropic=True,
                     smith_lambda=smith_lambda_aniso,
                     visibility=(("height_correlated", visibility_height_correlated_aniso),
                                 ("separable", visibility_separable_aniso))),
}


def g2_height_correlated(lambda_l: Float[ArrayLike, "*batch"],
                         lambda_v: Float[ArrayLike, "*batch"]) -> Float[Array, "*batch"]:
    """Height-correlated Smith from the NDF's Lambdas: G2 = 1 / (1 + Lambda(l) + Lambda(v))."""
    return 1.0 / (1.0 + lambda_l + lambda_v)


def g2_separable(lambda_l: Float[ArrayLike, "*batch"],
                 lambda_v: Float[ArrayLike, "*batch"]) -> Float[Array, "*batch"]:
    """Uncorrelated Smith from the NDF's Lambdas: G = 1 / ((1 + Lambda(l)) (1 + Lambda(v)))."""
    return 1.0 / ((1.0 + lambda_l) * (1.0 + lambda_v))


# A Smith masking is how two Lambdas combine; the NDF brings its Lambda (Ndf.smith_lambda)
# and, for GGX, closed forms of V (Ndf.visibility) that brdf.model prefers.
MASKINGS = {
    "height_correlated": Masking(name="height_correlated", combine=g2_height_correlated, fused=True),
    "separable": Masking(name="separable", token="separable", hint="Smith", fused=True,
                         combine=g2_separable,
                         gltf=GltfRule(note="glTF uses height-correlated Smith masking: "
                                            "the separable form is dropped")),
}

ANISOTROPY_REMAPS = {
    "kulla_conty": Remap(
        name="kulla_conty", remap=anisotropy_kulla_conty, variants=ANISOTROPY_STARTS,
        params=(Param("anisotropy", 1, -0.95, 0.95, 0.0,
                      "Kulla-Conty anisotropy a: alpha_t = alpha(1+a), alpha_b = alpha(1-a)"),
                ROTATION)),
    "gltf": Remap(
        name="gltf", token="gltf_aniso", hint="KHR anisotropy remap", remap=anisotropy_gltf,
        variants=ANISOTROPY_STARTS,
        params=(Param("anisotropy", 1, 0.0, 1.0, 0.0,
                      "KHR_materials_anisotropy anisotropyStrength s: alpha_t = mix(alpha, 1, s^2)",
                      gltf=GltfKey("KHR_materials_anisotropy", "anisotropyStrength", 0.0)),
                ROTATION)),
}
