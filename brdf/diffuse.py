"""Diffuse lobes.  Each returns f = albedo / pi * factor (RGB when albedo is).

Sources: Lambert 1760; Burley 2012 ("Physically-based shading at Disney");
Lagarde & de Rousiers 2014 ("Moving Frostbite to PBR", renormalised Burley);
Chan 2018 ("Material advances in Call of Duty: WWII", SIGGRAPH course, with
its gloss parameterisation); Oren & Nayar 1994; Portsmouth, Kutz & Hill 2025
(EON, KHR_materials_diffuse_roughness's lobe).  docs/models.md#diffuse-lobes.

Which roughness each takes is part of its name: ``roughness`` is the
perceptual r (glTF roughnessFactor), ``alpha`` = r^2.  The diffuse options of
a model are declared at the end (``DIFFUSES``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from jaxtyping import Float

from ._lazy import jnp
from .constants import INV_PI, ALPHA_MIN
from .declare import GltfRule, Param, Start, Term

# Frostbite's renormalisation: energyFactor goes from 1 to 1/1.51.
FROSTBITE_ENERGY_FACTOR_ROUGH = 1.0 / 1.51
# Call of Duty WWII gloss parameterisation alpha^2 = 2 / (1 + 2^(18 g)).
COD_GLOSS_BITS = 18.0
# EON (Portsmouth et al. 2025): A = 1 / (1 + EON_A_SLOPE r), the average albedo of its
# single-scattering (Fujii) lobe A (1 + EON_AVERAGE_SLOPE r), and the polynomial in
# 1 - mu of its directional albedo's G(mu) / pi (the paper's fit, as three.js r187 has it).
EON_A_SLOPE = 0.5 - 2.0 / (3.0 * np.pi)
EON_AVERAGE_SLOPE = 2.0 / 3.0 - 28.0 / (15.0 * np.pi)
EON_G_POLY = (0.0571085289, 0.491881867, -0.332181442, 0.0714429953)
EON_EPS = 1e-7

if TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import Array, ArrayLike


def _pow5(x):
    x2 = x * x
    return x2 * x2 * x


def _scale(albedo, factor):
    """albedo / pi * factor, broadcasting an RGB albedo over the last axis."""
    if jnp.ndim(albedo):
        factor = factor[..., None]
    return albedo * INV_PI * factor


def _schlick_pair(fd90, n_dot_l, n_dot_v):
    """(1 + (FD90 - 1)(1 - n.l)^5)(1 + (FD90 - 1)(1 - n.v)^5)."""
    nl = jnp.clip(n_dot_l, 0.0, 1.0)
    nv = jnp.clip(n_dot_v, 0.0, 1.0)
    return (1.0 + (fd90 - 1.0) * _pow5(1.0 - nl)) * (1.0 + (fd90 - 1.0) * _pow5(1.0 - nv))


def lambert(albedo: Float[ArrayLike, "*#batch #3"], n_dot_l: Float[ArrayLike, "*batch"],
            n_dot_v: Float[ArrayLike, "*batch"]) -> Float[Array, "*batch 3"]:
    """Lambert: albedo / pi (the cosines only set the shape for broadcasting)."""
    return _scale(albedo, jnp.ones_like(n_dot_l * n_dot_v))


def burley(albedo: Float[ArrayLike, "*#batch #3"], roughness: Float[ArrayLike, "*#batch"],
           n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
           l_dot_h: Float[ArrayLike, "*batch"]) -> Float[Array, "*batch 3"]:
    """Burley 2012: FD90 = 0.5 + 2 r (l.h)^2, factor = Schlick pair with FD90.

    ``roughness`` is the perceptual r, as in Disney's ``disney.brdf``.
    """
    fd90 = 0.5 + 2.0 * roughness * l_dot_h * l_dot_h
    return _scale(albedo, _schlick_pair(fd90, n_dot_l, n_dot_v))


def frostbite(albedo: Float[ArrayLike, "*#batch #3"], roughness: Float[ArrayLike, "*#batch"],
              n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
              l_dot_h: Float[ArrayLike, "*batch"]) -> Float[Array, "*batch 3"]:
    """Frostbite renormalised Burley (Lagarde & de Rousiers 2014, listing 10).

    With r = their linearRoughness (= our perceptual roughness):
    energyBias = 0.5 r, energyFactor = lerp(1, 1/1.51, r),
    FD90 = energyBias + 2 (l.h)^2 r, factor = energyFactor * Schlick pair.
    """
    energy_bias = 0.5 * roughness
    energy_factor = 1.0 + (FROSTBITE_ENERGY_FACTOR_ROUGH - 1.0) * roughness
    fd90 = energy_bias + 2.0 * l_dot_h * l_dot_h * roughness
    return _scale(albedo, energy_factor * _schlick_pair(fd90, n_dot_l, n_dot_v))


def cod_gloss_from_alpha(alpha: Float[ArrayLike, "*#batch"]) -> Float[Array, "*#batch"]:
    """Chan 2018 gloss from alpha: g = clamp(log2(2/alpha^2 - 1) / 18, 0, 1).

    The clamp matters: alpha < 0.00276 would give g > 1, alpha > 1 g < 0.
    """
    a2 = jnp.maximum(alpha, ALPHA_MIN) ** 2
    return jnp.clip(jnp.log2(jnp.maximum(2.0 / a2 - 1.0, 1e-12)) / COD_GLOSS_BITS, 0.0, 1.0)


def cod_wwii(albedo: Float[ArrayLike, "*#batch #3"], alpha: Float[ArrayLike, "*#batch"],
             n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
             l_dot_h: Float[ArrayLike, "*batch"], n_dot_h: Float[ArrayLike, "*batch"]) -> Float[Array, "*batch 3"]:
    """Call of Duty: WWII diffuse (Chan 2018), identical to UE's Diffuse_Chan.

    f_rough = l.h + (1 - l.h)^5; f_smooth = (1 - 0.75 (1-n.l)^5)(1 - 0.75 (1-n.v)^5);
    fd = lerp(f_rough, f_smooth, clamp(2.2 g - 0.5, 0, 1));
    fb = (34.5 g^2 - 59 g + 24.5) l.h 2^(-max(73.2 g - 21.2, 8.9) sqrt(n.h));
    factor = fd + fb, with g the gloss from alpha.
    """
    g = cod_gloss_from_alpha(alpha)
    nl = jnp.clip(n_dot_l, 0.0, 1.0)
    nv = jnp.clip(n_dot_v, 0.0, 1.0)
    lh = jnp.clip(l_dot_h, 0.0, 1.0)
    nh = jnp.clip(n_dot_h, 0.0, 1.0)
    f_rough = lh + _pow5(1.0 - lh)
    f_smooth = (1.0 - 0.75 * _pow5(1.0 - nl)) * (1.0 - 0.75 * _pow5(1.0 - nv))
    t = jnp.clip(2.2 * g - 0.5, 0.0, 1.0)
    fd = f_rough + (f_smooth - f_rough) * t
    # sqrt(n.h) has an infinite slope at n.h = 0; n.h >= 1e-12 keeps it finite.
    fb = (34.5 * g * g - 59.0 * g + 24.5) * lh * jnp.exp2(
        -jnp.maximum(73.2 * g - 21.2, 8.9) * jnp.sqrt(jnp.maximum(nh, 1e-12)))
    return _scale(albedo, fd + fb)


def _oren_nayar_angles(wi, wo):
    """(sin alpha_o, tan beta, cos(phi_i - phi_o), alpha_o, beta) with safe roots."""
    ci = jnp.clip(wi[..., 2], 1e-6, 1.0)
    co = jnp.clip(wo[..., 2], 1e-6, 1.0)
    si = jnp.sqrt(jnp.maximum(1.0 - ci * ci, 1e-12))
    so = jnp.sqrt(jnp.maximum(1.0 - co * co, 1e-12))
    proj = wi[..., 0] * wo[..., 0] + wi[..., 1] * wo[..., 1]
    cos_phi = jnp.clip(proj / (si * so), -1.0, 1.0)
    sin_alpha = jnp.maximum(si, so)          # alpha_o = max(theta_i, theta_o)
    cos_beta = jnp.maximum(ci, co)           # beta = min(theta_i, theta_o)
    tan_beta = jnp.minimum(si, so) / cos_beta
    alpha_o = jnp.arctan2(sin_alpha, jnp.minimum(ci, co))
    beta = jnp.arctan2(jnp.minimum(si, so), cos_beta)
    return sin_alpha, tan_beta, cos_phi, alpha_o, beta


def oren_nayar(albedo: Float[ArrayLike, "*#batch #3"], sigma: Float[ArrayLike, "*#batch"],
               wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"]) -> Float[Array, "*batch 3"]:
    """Qualitative Oren-Nayar 1994; sigma = slope standard deviation (radians).

    factor = A + B max(0, cos(phi_i - phi_o)) sin(alpha_o) tan(beta),
    A = 1 - 0.5 s^2/(s^2 + 0.33), B = 0.45 s^2/(s^2 + 0.09).
    """
    s2 = sigma * sigma
    a = 1.0 - 0.5 * s2 / (s2 + 0.33)
    b = 0.45 * s2 / (s2 + 0.09)
    sin_alpha, tan_beta, cos_phi, _, _ = _oren_nayar_angles(wi, wo)
    return _scale(albedo, a + b * jnp.maximum(0.0, cos_phi) * sin_alpha * tan_beta)


def oren_nayar_full(albedo: Float[ArrayLike, "*#batch #3"], sigma: Float[ArrayLike, "*#batch"],
                    wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"]) -> Float[Array, "*batch 3"]:
    """Full Oren-Nayar 1994 (eqs. 47-50 with the interreflection term L2).

    L2 carries an extra factor albedo, so this lobe is not linear in albedo.
    """
    s2 = sigma * sigma
    sin_alpha, tan_beta, cos_phi, alpha_o, beta = _oren_nayar_angles(wi, wo)
    c1 = 1.0 - 0.5 * s2 / (s2 + 0.33)
    b = 0.45 * s2 / (s2 + 0.09)
    c2 = jnp.where(cos_phi >= 0.0, b * sin_alpha,
                   b * (sin_alpha - (2.0 * beta * INV_PI) ** 3))
    c3 = 0.125 * s2 / (s2 + 0.09) * (4.0 * alpha_o * beta * INV_PI * INV_PI) ** 2
    l1 = (c1 + cos_phi * c2 * tan_beta
          + (1.0 - jnp.abs(cos_phi)) * c3 * jnp.tan(0.5 * (alpha_o + beta)))
    l2 = 0.17 * s2 / (s2 + 0.13) * (1.0 - cos_phi * (2.0 * beta * INV_PI) ** 2)
    if jnp.ndim(albedo):
        l1, l2 = l1[..., None], l2[..., None]
    return albedo * INV_PI * (l1 + albedo * l2)


def _eon_g_over_pi(mu):
    """G(mu) / pi of EON's directional albedo: the paper's polynomial in 1 - mu (eq. 21)."""
    x = 1.0 - jnp.clip(mu, 0.0, 1.0)
    c0, c1, c2, c3 = EON_G_POLY
    return x * (c0 + x * (c1 + x * (c2 + x * c3)))


def fon_directional_albedo(roughness: Float[ArrayLike, "*#batch"],
                           mu: Float[ArrayLike, "*batch"]) -> Float[Array, "*batch"]:
    """E_FON(mu) = A (1 + r G(mu) / pi): the directional albedo of EON's single-scattering
    lobe for albedo 1 (Portsmouth et al. 2025, eq. 20, with their fit of G)."""
    return (1.0 + roughness * _eon_g_over_pi(mu)) / (1.0 + EON_A_SLOPE * roughness)


def eon(albedo: Float[ArrayLike, "*#batch #3"], roughness: Float[ArrayLike, "*#batch"],
        n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
        l_dot_v: Float[ArrayLike, "*batch"]) -> Float[Array, "*batch 3"]:
    """EON, the energy-preserving Oren-Nayar lobe (Portsmouth, Kutz & Hill 2025, JCGT 14(1)),
    as three.js r187 draws KHR_materials_diffuse_roughness (``BRDF_EON``).

    ``roughness`` is the diffuse roughness r in [0, 1] (diffuseRoughnessFactor),
    ``albedo`` rho is clipped to [0, 1].  With s = l.v - (n.l)(n.v), t = max(n.l, n.v)
    where s > 0 else 1, A = 1 / (1 + (1/2 - 2/(3 pi)) r):

        f_ss   = rho / pi A (1 + r s / t)                           (Fujii's Oren-Nayar)
        f_ms   = rho_ms / pi (1 - E(n.v)) (1 - E(n.l)) / (1 - E_avg)
        rho_ms = rho^2 E_avg / (1 - rho (1 - E_avg)),   E = fon_directional_albedo,
        E_avg  = A (1 + (2/3 - 28/(15 pi)) r).

    As 1 - E(mu) = A r (c - G(mu)/pi) and 1 - E_avg = A r (c - c'), c and c' the two
    slopes above, f_ms is written without the 0/0 at r = 0, where EON is Lambert.
    c - G(mu)/pi is held at 0 or above (G/pi's fit exceeds c by 4e-4 at mu = 0), as
    three.js holds 1 - E at 1e-7 or above.
    """
    rho = jnp.clip(albedo, 0.0, 1.0)
    nl = jnp.clip(n_dot_l, 0.0, 1.0)
    nv = jnp.clip(n_dot_v, 0.0, 1.0)
    s = l_dot_v - nl * nv
    s_over_t = jnp.where(s > 0.0, s / jnp.maximum(jnp.maximum(nl, nv), EON_EPS), s)
    a = 1.0 / (1.0 + EON_A_SLOPE * roughness)
    single = a * (1.0 + roughness * s_over_t)
    lack_l = jnp.maximum(EON_A_SLOPE - _eon_g_over_pi(nl), 0.0)
    lack_v = jnp.maximum(EON_A_SLOPE - _eon_g_over_pi(nv), 0.0)
    multiple = a * roughness * lack_l * lack_v / (EON_A_SLOPE - EON_AVERAGE_SLOPE)
    average = a * (1.0 + EON_AVERAGE_SLOPE * roughness)
    if jnp.ndim(rho):
        single, multiple = single[..., None], multiple[..., None]
        average = average[..., None] if jnp.ndim(average) else average
    rho_ms = rho * rho * average / (1.0 - rho * (1.0 - average))
    return INV_PI * (rho * single + rho_ms * multiple)


# --- declarations -------------------------------------------------------------
# lobe(params, g, roughness, alpha) -> f_diffuse (..., 3), g a brdf.model.Geometry.
# ``fused``: the lobe is albedo x a factor of the geometry and the roughness
# only, the form fitting.fused differentiates in closed form.

ALBEDO = Param("albedo", 3, 0.0, 1.0, 0.5, "diffuse albedo rho (f_d = rho/pi * factor)",
               start=Start(probe=0.0, rule=lambda e: e.albedo, peak=lambda e: e.albedo / np.pi))
# glTF's diffuse is Lambert's: any other factor is dropped, the albedo kept.
NOT_LAMBERT = GltfRule(lambda p: {"rho": p["albedo"]},
                       "glTF's diffuse is Lambert: the {name} factor is dropped, its albedo kept")

DIFFUSES = {
    "none": Term(name="none", hint="specular only", fused=True),
    "lambert": Term(name="lambert", token="lambert", params=(ALBEDO,), fused=True,
                    lobe=lambda p, g, r, a: lambert(p["albedo"], g.n_dot_l, g.n_dot_v),
                    gltf=GltfRule(lambda p: {"rho": p["albedo"]})),
    "burley": Term(name="burley", token="burley", params=(ALBEDO,), fused=True, gltf=NOT_LAMBERT,
                   lobe=lambda p, g, r, a: burley(p["albedo"], r, g.n_dot_l, g.n_dot_v, g.v_dot_h)),
    "frostbite": Term(name="frostbite", token="frostbite", params=(ALBEDO,), fused=True, gltf=NOT_LAMBERT,
                      lobe=lambda p, g, r, a: frostbite(p["albedo"], r, g.n_dot_l, g.n_dot_v, g.v_dot_h)),
    "cod_wwii": Term(name="cod_wwii", token="cod_wwii", params=(ALBEDO,), fused=True, gltf=NOT_LAMBERT,
                     lobe=lambda p, g, r, a: cod_wwii(p["albedo"], a, g.n_dot_l, g.n_dot_v, g.v_dot_h,
                                                      g.n_dot_h)),
    "oren_nayar": Term(name="oren_nayar", token="oren_nayar", gltf=NOT_LAMBERT,
                       params=(ALBEDO, Param("sigma", 1, 0.0, 1.5, 0.3, "Oren-Nayar slope deviation", "rad")),
                       lobe=lambda p, g, r, a: oren_nayar(p["albedo"], p["sigma"], g.wi, g.wo)),
}
