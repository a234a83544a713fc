"""OpenPBR Surface's two bases, each a model of its own (issue 61): the metal, GGX with
the F82-tint Fresnel, and the non-metal, a GGX dielectric layered over EON's diffuse.
The coat over either (``openpbr+metal+coat``, ``openpbr+nonmetal+coat``), the registry of
the four models and their open_pbr_surface inputs: brdf/openpbr_coat.py.

Read in the MaterialX python package 1.39.5 (``pip install materialx``):

    MaterialX/libraries/bxdf/open_pbr_surface.mtlx            the node graph (metal_bsdf,
                                                              dielectric_reflection, diffuse_bsdf,
                                                              dielectric_base = layer of the two)
    MaterialX/libraries/pbrlib/genglsl/mx_generalized_schlick_bsdf.glsl
    MaterialX/libraries/pbrlib/genglsl/mx_dielectric_bsdf.glsl  (its throughput)
    MaterialX/libraries/pbrlib/genglsl/mx_layer_bsdf.glsl       top + base x top's throughput
    MaterialX/libraries/pbrlib/genglsl/lib/mx_microfacet_specular.glsl
                                  mx_fresnel_hoffman_schlick, mx_fresnel_dielectric,
                                  mx_ggx_dir_albedo_analytic (the genglsl default method)

**The metal** (base_metalness 1) is a ``generalized_schlick_bsdf`` with color0 =
base_weight base_color, color82 = specular_color, color90 = 1 and exponent 5, weighted
by specular_weight, over a GGX lobe of alpha = specular_roughness^2 with
height-correlated Smith masking.  The Fresnel is Hoffman's F82 form (Hoffman 2023,
"Generalization of Adobe's Fresnel Model"; Kutz et al. 2021, "Novel aspects of the
Adobe Standard Material"):

    S(mu)  = F0 + (1 - F0)(1 - mu)^5                                (Schlick)
    F(mu)  = S(mu) - a mu (1 - mu)^6,
    a      = S(1/7) (1 - F82) / ((1/7)(1 - 1/7)^6)

so F(1) = F0, F(0) = 1 and F(1/7) = F82 x S(1/7): ``specular_color`` is the metal's
colour near grazing relative to Schlick's (1: plain Schlick, as glTF's metal).
F is clamped at 0 here: with a dark tint over a dark F0 the form dips below 0 between
mu = 1/7 and 6/7 (F0 = 0, F82 = 0: F = (1 - mu)^5 (1 - 49/6 mu (1 - mu)), -0.0326 at
mu = 1/2); MaterialX's genglsl leaves it negative, a BRDF is never negative.

    f_metal = F(v.h) D V

**The non-metal** (base_metalness 0, no transmission, subsurface, fuzz or thin film; the
coat: brdf/openpbr_coat.py) is ``dielectric_base``, MaterialX's ``layer`` of ``dielectric_reflection`` (a
dielectric_bsdf, scatter mode R) over ``diffuse_bsdf`` (an oren_nayar_diffuse_bsdf with
energy_compensation, i.e. EON).  mx_layer_bsdf adds the base weighted by the top's
throughput, and mx_dielectric_bsdf's throughput is 1 - its directional albedo at the
view direction, MaterialX's analytic fit of GGX's (A, B) with F0 of the IOR and F90 = 1
(not 1 - F per direction pair):

    F0       = ((eta - 1) / (eta + 1))^2,  eta = specular_ior
    E(mu)    = F0 A(mu, alpha) + B(mu, alpha)                        (mx_ggx_dir_albedo_analytic)
    f_nonmetal = F_dielectric(v.h, eta) D V + (1 - E(n.v)) f_EON(base_color, base_diffuse_roughness)

F_dielectric is the exact unpolarised Fresnel (brdf.fresnel.fresnel_dielectric, as
mx_fresnel_dielectric), f_EON brdf.diffuse.eon (Portsmouth et al. 2025).  The layering
weighs the diffuse by the view direction's albedo only: the model is not reciprocal.
With a white base its albedo is the specular lobe's own plus 1 - E: above 1 by the
amount the exact Fresnel's albedo exceeds E (the fit stands for Schlick's Fresnel), by
up to 2 % (eta 2, r 0.3, n.v 0.4; tests/test_openpbr_nonmetal.py).

OpenPBR's specular_weight scales F0 and turns it back into an IOR (the graph's
``modulated_eta_s``: F0' = clamp(specular_weight F0, 0, 0.99999), eta' =
(1 + sqrt F0') / (1 - sqrt F0')), so at specular_weight 1 eta' = specular_ior and below
1 it is a lower IOR: with specular_ior fitted, specular_weight adds nothing a fit could
tell apart, and it is held at 1.  specular_color (a tint of the dielectric's response,
not of its throughput) is held at 1, base_weight at 1.

Where MaterialX's genglsl EON (mx_oren_nayar_compensated_diffuse) differs from the one
drawn here (the paper's, as three.js r187 and KHR_materials_diffuse_roughness have
it): its bsdf clamps l.v to 1e-8 or above before s = l.v - (n.l)(n.v), so where l.v < 0
its s is less negative than EON's; and it takes Fujii's exact directional albedo where
the paper's fit is used here.  Both only matter at base_diffuse_roughness > 0.

MaterialX's genglsl multiplies each GGX lobe (and the dielectric's directional albedo in
its throughput) by its energy compensation (``mx_ggx_energy_compensation``: multiple
scattering); the lobes here leave it out (the single-scattering ones the toolkit's other
GGX models fit), and the option ``mx`` puts it in (``openpbr+metal+mx``, brdf/openpbr_coat.py):

    comp = 1 + F (1 - Ess(n.v)) / Ess(n.v),  Ess = ggx_dir_albedo(n.v, alpha, 1)   (ggx_energy_compensation)
    f_metal+mx    = F82(v.h) D V comp                        (comp per channel, F = F82(v.h))
    f_nonmetal+mx = F_dielectric(v.h) D V comp + (1 - E(n.v) comp) f_EON   (F = F_dielectric(v.h))

The model strings are ``openpbr+metal`` and ``openpbr+nonmetal`` (``nonmetal`` as glTF's:
``dielectric`` is the exact Fresnel's token of the GGX models), each with ``+coat`` under
OpenPBR's coat (brdf/openpbr_coat.py); the schema's
``roughness`` is OpenPBR's ``specular_roughness`` (alpha = r^2 in both), the other
names are OpenPBR's own.  docs/models.md (openpbr).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from jaxtyping import Float

from ._lazy import jnp
from .constants import ALPHA_MIN, ROUGHNESS_MIN
from .declare import Composition, GltfRule, Param, Start
from .diffuse import eon
from .fresnel import f0_from_ior, fresnel_dielectric, ior_from_f0
from .geometry import dot, half_vector
from .specular import ggx_ndf, visibility_height_correlated

if TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import Array, ArrayLike

#: The cosine at which the F82 tint is specified: mu = 1/7 (theta ~ 82 degrees),
#: where the Schlick-minus-correction term peaks (mx_fresnel_hoffman_schlick's COS_THETA_MAX).
F82_COS = 1.0 / 7.0
#: Schlick's weight (1 - mu)^5 at mu = 1/7, and 1 / (mu (1 - mu)^6) there: the two
#: constants of the correction (named in GLSL too, so both languages round alike).
F82_SCHLICK_W = (1.0 - F82_COS) ** 5
F82_FACTOR = 1.0 / (F82_COS * (1.0 - F82_COS) ** 6)


def f82_tint_b(f0: Float[ArrayLike, "*#batch #3"], f82: Float[ArrayLike, "*#batch #3"]) -> Float[Array, "*#batch #3"]:
    """Hoffman's F82-tint coefficient (Cycles' fresnel_f82tint_B): Schlick(F0, 1/7) (1 - F82) /
    ((1/7)(6/7)^6), the a of ``fresnel_f82`` and the b of Cycles' average (brdf.cycles.cycles_f82_fss)."""
    f0 = jnp.asarray(f0)
    return (f0 + (1.0 - f0) * F82_SCHLICK_W) * (1.0 - jnp.asarray(f82)) * F82_FACTOR


def fresnel_f82(f0: Float[ArrayLike, "*#batch #3"], f82: Float[ArrayLike, "*#batch #3"],
                cos: Float[ArrayLike, "*batch"]) -> Float[Array, "*batch #3"]:
    """Hoffman's F82-tint Fresnel (F90 = 1, exponent 5), as MaterialX 1.39's
    mx_fresnel_hoffman_schlick: Schlick(F0, mu) - a mu (1 - mu)^6 with
    a = Schlick(F0, 1/7) (1 - F82) / ((1/7)(6/7)^6), clamped at 0 (the module's
    docstring says where it would be negative).  RGB on the last axis."""
    mu = jnp.clip(cos, 0.0, 1.0)[..., None]
    f0 = jnp.asarray(f0)
    x = 1.0 - mu
    x2 = x * x
    x5 = x2 * x2 * x
    schlick = f0 + (1.0 - f0) * x5
    return jnp.maximum(schlick - f82_tint_b(f0, f82) * mu * (x5 * x), 0.0)


def openpbr_metal(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"],
                  base_color: Float[ArrayLike, "*#batch #3"], specular_color: Float[ArrayLike, "*#batch #3"],
                  roughness: Float[ArrayLike, "*#batch"], mx: bool = False) -> Float[Array, "*batch 3"]:
    """OpenPBR's metal (RGB, 1/sr, without the cosine): F82(v.h) D V, GGX of alpha =
    roughness^2 with height-correlated Smith (brdf/specular.py); ``mx``: times MaterialX's comp."""
    alpha = roughness * roughness
    h = half_vector(wi, wo)
    dv = ggx_ndf(h[..., 2], alpha) * visibility_height_correlated(wi[..., 2], wo[..., 2], alpha)
    v_dot_h = jnp.sum(jnp.asarray(wo) * h, axis=-1)
    fresnel = fresnel_f82(base_color, specular_color, v_dot_h)
    return metal_lobe(fresnel, dv, wo[..., 2], alpha, mx)


#: MaterialX 1.39.5's mx_ggx_dir_albedo_analytic ("rational quadratic fit to Monte Carlo
#: data for GGX directional albedo"): one row per monomial of x = n.v and y = alpha, in
#: its order (1, x, y, x y, x^2, y^2, x^2 y, x y^2, x^2 y^2), the columns the numerators
#: of A and B, then their denominators; A, B = clamp(num / den, 0, 1).
GGX_ALBEDO_FIT = ((0.1003, 0.9345, 1.0, 1.0),
                  (-0.6303, -2.323, -1.765, 0.2281),
                  (9.748, 2.229, 8.263, 15.94),
                  (-2.038, -3.748, 11.53, -55.83),
                  (29.34, 1.424, 28.96, 13.08),
                  (-8.245, -0.7684, -7.507, 41.26),
                  (-26.44, 1.436, -36.11, 54.9),
                  (19.99, 0.2913, 15.86, 300.2),
                  (-5.448, 0.6286, 33.37, -285.1))


def ggx_dir_albedo(n_dot_v: Float[ArrayLike, "*batch"], alpha: Float[ArrayLike, "*#batch"],
                   f0: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """F0 A + B (F90 = 1): GGX's directional albedo by MaterialX's analytic fit of (A, B)
    (mx_ggx_dir_albedo_analytic), terms summed in its order so that float32 rounds alike."""
    x = jnp.clip(n_dot_v, 0.0, 1.0)
    y = jnp.asarray(alpha)
    x2, y2 = x * x, y * y

    def column(k: int) -> Array:       # one column at a time: twice as fast as the four stacked
        c = [row[k] for row in GGX_ALBEDO_FIT]
        return (c[0] + c[1] * x + c[2] * y + c[3] * x * y + c[4] * x2 + c[5] * y2
                + c[6] * x2 * y + c[7] * x * y2 + c[8] * x2 * y2)
    a = jnp.clip(column(0) / column(2), 0.0, 1.0)
    b = jnp.clip(column(1) / column(3), 0.0, 1.0)
    return f0 * a + b


def ggx_energy_compensation(n_dot_v: Float[ArrayLike, "*batch"], alpha: Float[ArrayLike, "*#batch"],
                            fresnel: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """MaterialX 1.39.5's mx_ggx_energy_compensation (Turquin 2019, eq. 14 and 16): 1 + F (1 - Ess) / Ess,
    Ess = ggx_dir_albedo(n.v, alpha, 1), in its order of operations.  For an RGB ``fresnel`` pass
    ``n_dot_v`` and ``alpha`` with a trailing axis of 1."""
    ess = ggx_dir_albedo(n_dot_v, alpha, 1.0)
    return 1.0 + fresnel * (1.0 - ess) / ess


def metal_lobe(fresnel: Float[ArrayLike, "*batch 3"], dv: Float[ArrayLike, "*batch"],
               n_dot_v: Float[ArrayLike, "*batch"], alpha: Float[ArrayLike, "*#batch"],
               mx: bool = False) -> Float[Array, "*batch 3"]:
    """The metal's lobe F D V; ``mx``: times MaterialX's compensation, comp per channel of F."""
    lobe = fresnel * jnp.asarray(dv)[..., None]
    if not mx:
        return lobe
    return lobe * ggx_energy_compensation(jnp.asarray(n_dot_v)[..., None], jnp.asarray(alpha)[..., None], fresnel)


def nonmetal_combine(dv: Float[ArrayLike, "*batch"], v_dot_h: Float[ArrayLike, "*batch"],
                     n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
                     l_dot_v: Float[ArrayLike, "*batch"], alpha: Float[ArrayLike, "*#batch"],
                     base_color: Float[ArrayLike, "*#batch #3"], specular_ior: Float[ArrayLike, "*#batch"],
                     diffuse_roughness: Float[ArrayLike, "*#batch"], mx: bool = False) -> Float[Array, "*batch 3"]:
    """OpenPBR's non-metal from its specular D V: F_dielectric(v.h) D V + (1 - E(n.v)) f_EON
    (RGB, the module's docstring); ``mx``: the lobe and E times MaterialX's comp."""
    fresnel = fresnel_dielectric(v_dot_h, specular_ior)
    albedo = ggx_dir_albedo(n_dot_v, alpha, f0_from_ior(specular_ior))
    if mx:
        comp = ggx_energy_compensation(n_dot_v, alpha, fresnel)
        specular, throughput = fresnel * dv * comp, 1.0 - albedo * comp
    else:
        specular, throughput = fresnel * dv, 1.0 - albedo
    diffuse = eon(base_color, diffuse_roughness, n_dot_l, n_dot_v, l_dot_v)
    return specular[..., None] + throughput[..., None] * diffuse


def openpbr_nonmetal(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"],
                     base_color: Float[ArrayLike, "*#batch #3"], specular_ior: Float[ArrayLike, "*#batch"],
                     roughness: Float[ArrayLike, "*#batch"],
                     diffuse_roughness: Float[ArrayLike, "*#batch"], mx: bool = False) -> Float[Array, "*batch 3"]:
    """OpenPBR's non-metal (RGB, 1/sr, without the cosine), GGX of alpha = roughness^2
    with height-correlated Smith; ``wo`` is the view direction (the layering weighs the
    diffuse by its albedo); ``mx``: with MaterialX's comp."""
    alpha = roughness * roughness
    h = half_vector(wi, wo)
    dv = ggx_ndf(h[..., 2], alpha) * visibility_height_correlated(wi[..., 2], wo[..., 2], alpha)
    return nonmetal_combine(dv, dot(wo, h), wi[..., 2], wo[..., 2], dot(wi, wo), alpha,
                            base_color, specular_ior, diffuse_roughness, mx)


# --- declarations -------------------------------------------------------------

def _metal_material(p, g, dv, mx=False):
    """The openpbr composition's BRDF from the model's D V (brdf/model.py): the metal
    (``mx``: openpbr+metal+mx's, with MaterialX's comp)."""
    fresnel = fresnel_f82(p["base_color"], p["specular_color"], g.v_dot_h)
    return metal_lobe(fresnel, dv, g.n_dot_v, _alpha(p["roughness"]), mx)


BASE_COLOR = Param("base_color", 3, 0.0, 1.0, 0.8,
                   "OpenPBR base_color: the metal's F0 (linear RGB; base_weight 1)",
                   start=Start(probe=1.0, rule=lambda e: np.clip(e.scale, 0.0, 1.0)))
# Neutral 1 (plain Schlick, OpenPBR's default); the start inside the range: at its bound 1
# the bounded transform's slope is ~0.
SPECULAR_COLOR = Param("specular_color", 3, 0.0, 1.0, 1.0,
                       "OpenPBR specular_color: the metal's F82 edge tint (1: Schlick; specular_weight 1)",
                       start=Start(probe=1.0, rule=lambda e: np.full(3, 0.8)))


def _alpha(roughness):
    """alpha as brdf.model.roughness_alpha gives the model's D V: r clamped to
    [ROUGHNESS_MIN, 1], alpha = r^2 floored at ALPHA_MIN."""
    r = jnp.clip(roughness, ROUGHNESS_MIN, 1.0)
    return jnp.maximum(r * r, ALPHA_MIN)


def _nonmetal_material(p, g, dv, mx=False):
    """The openpbr_nonmetal composition's BRDF from the model's D V (brdf/model.py; ``mx``: with MaterialX's comp)."""
    return nonmetal_combine(dv, g.v_dot_h, g.n_dot_l, g.n_dot_v, dot(g.wi, g.wo), _alpha(p["roughness"]),
                            p["base_color"], p["specular_ior"], p["base_diffuse_roughness"], mx)


#: F0 of the largest specular_ior a fit takes (3): the non-metal's peak is probed there
F0_IOR_MAX = float(f0_from_ior(3.0))

NONMETAL_BASE_COLOR = Param("base_color", 3, 0.0, 1.0, 0.5,
                            "OpenPBR base_color: the diffuse albedo (linear RGB; base_weight 1)",
                            start=Start(probe=0.0, rule=lambda e: np.clip(e.albedo / 0.96, 0.0, 1.0),
                                        peak=lambda e: e.albedo / np.pi))
SPECULAR_IOR = Param("specular_ior", 1, 1.0, 3.0, 1.5,
                     "OpenPBR specular_ior: the dielectric's IOR (its exact Fresnel; specular_weight 1)",
                     start=Start(probe=3.0, rule=lambda e: float(np.clip(ior_from_f0(
                         F0_IOR_MAX * float(np.mean(e.scale)), xp=np), 1.01, 2.9))))
# (the start inside the range: at its bound 0, Lambert, the bounded transform's slope is ~0)
BASE_DIFFUSE_ROUGHNESS = Param("base_diffuse_roughness", 1, 0.0, 1.0, 0.5,
                               "OpenPBR base_diffuse_roughness: EON's roughness (0: Lambert)")

# The model string's options: one of OpenPBR's two bases (base_metalness held at 1 or 0),
# each a composition of its own: openpbr+metal is the composition "openpbr" (its first
# slice's name), openpbr+nonmetal "openpbr_nonmetal".  Their coated twins, the registry of
# all four, the ModelSpec fields they fix and their open_pbr_surface inputs: brdf/openpbr_coat.py.
BASE_MODELS = {"metal": "openpbr", "nonmetal": "openpbr_nonmetal"}

# The compositions: lobe(params, g, dv) is the whole BRDF.
# As glTF (brdf/gltf_material.py): the metal is a glTF metal of baseColor F0, whose Fresnel
# is Schlick's (F90 = 1): the edge tint has no glTF form and is dropped, with a note.  The
# non-metal is a glTF dielectric of its F0 and base colour, with a note of what differs.
BASE_COMPOSITIONS = {
    "openpbr": Composition(
        name="openpbr", own_lobes=True, params=(BASE_COLOR, SPECULAR_COLOR), lobe=_metal_material,
        hint="OpenPBR Surface's metal: F82-tint Fresnel, GGX",
        gltf=GltfRule(quantities=lambda p: {"f0": p["base_color"], "conductor": True},
                      note="OpenPBR's F82 edge tint (specular_color {specular_color}) has no glTF form: "
                           "dropped (a glTF metal's Fresnel is Schlick's of baseColor)")),
    "openpbr_nonmetal": Composition(
        name="openpbr_nonmetal", own_lobes=True, lobe=_nonmetal_material, reciprocal=False,   # 1 - E at n.v
        params=(NONMETAL_BASE_COLOR, SPECULAR_IOR, BASE_DIFFUSE_ROUGHNESS),
        hint="OpenPBR Surface's dielectric base: exact Fresnel GGX layered over EON",
        gltf=GltfRule(quantities=lambda p: {"rho": p["base_color"], "f0": np.full(3, f0_from_ior(p["specular_ior"]))},
                      note="OpenPBR's dielectric (exact Fresnel of IOR {specular_ior:.4g}, diffuse weighted by "
                           "the specular's directional albedo, EON of base_diffuse_roughness "
                           "{base_diffuse_roughness:.3g}) becomes glTF's (Schlick of the same F0, the diffuse "
                           "weighted by 1 - F(v.h), Lambert)")),
}

