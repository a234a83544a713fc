"""OpenPBR Surface's coat over either base (issue 61): ``openpbr+metal+coat`` and
``openpbr+nonmetal+coat``, and the registry of the OpenPBR models (the fuzz over the
non-metal: brdf/openpbr_fuzz.py) and their ``open_pbr_surface`` inputs.

Read in the MaterialX python package 1.39.5 (``pip install materialx``):

    MaterialX/libraries/bxdf/open_pbr_surface.mtlx   coat_bsdf, coat_layer, the coat's
                                                     roughening of the base
                                                     (effective_specular_roughness), the base's
                                                     IOR under it (eta_s) and coat darkening
                                                     (Kcoat, base_darkening)
    MaterialX/libraries/pbrlib/genglsl/mx_dielectric_bsdf.glsl   weight x response, throughput
                                                                 1 - weight E
    MaterialX/libraries/pbrlib/genglsl/mx_layer_bsdf.glsl        top + base x top's throughput

What the graph draws with coat weight w, coat_ior c, coat_roughness r_c, no fuzz:

    f = w F_dielectric(v.h, c) D_c V_c                                 (coat_bsdf, alpha_c = r_c^2)
        + (1 - w E_c(n.v)) mix(1, coat_color, w) mix(1, Delta, w k) f_base'
    E_c      = F0(c) A(n.v, alpha_c) + B(n.v, alpha_c)                 (brdf.openpbr.ggx_dir_albedo)
    Delta    = (1 - K) / (1 - E_base K),  K = 1 - (1 - F0(c)) / c^2      (base_darkening; E_base =
               base_color for both bases at specular_weight 1, subsurface_weight 0)
    f_base'  the base (brdf/openpbr.py) at the roughness mix(r_s, min(1, 2 r_c^4 + r_s^4)^(1/4), w)
             and, for the non-metal, the IOR mix(s, s / c if s > c else c / s, w) (the graph's
             ratio inversion; specular_weight 1 leaves it as it is)

with mix(a, b, t) = a (1 - t) + b t.  coat_color is held at 1 (a tint of the whole base
beside base_color: a fit could hardly tell them apart), coat_darkening k at the graph's
default 1 (drawn), coat_roughness_anisotropy at 0.  As the bases, the coat leaves out
MaterialX's GGX energy compensation.  The layering weighs the base by the view
direction's albedo: a coated model is not reciprocal.  The coat's albedo exceeds E_c
by the exact Fresnel's excess, as the non-metal's dielectric does (tests/test_openpbr_coat.py).

The model strings: the base's then ``coat`` (options in any order; canonical
``openpbr+metal+coat``, ``openpbr+nonmetal+coat``), compositions "openpbr_metal_coat" and
"openpbr_nonmetal_coat".  docs/models.md (openpbr).

**MaterialX's reading** (the option ``mx``, last in the canonical string: ``openpbr+metal+mx``,
``openpbr+nonmetal+mx``, ``openpbr+metal+coat+mx``, ``openpbr+nonmetal+coat+mx``; compositions
"openpbr_metal_mx", "openpbr_nonmetal_mx", "openpbr_metal_coat_mx", "openpbr_nonmetal_coat_mx"):
each GGX lobe as MaterialX 1.39.5's genglsl draws it, times mx_ggx_energy_compensation
(brdf.openpbr.ggx_energy_compensation: comp = 1 + F (1 - Ess) / Ess, Ess the GGX albedo at F0 =
F90 = 1 at n.v and the lobe's alpha, F the lobe's Fresnel at v.h), and each dielectric's
throughput 1 - w E comp (mx_dielectric_bsdf: dirAlbedo = E comp); the metal's lobe
(mx_generalized_schlick_bsdf) per channel of its F82 Fresnel, the base's dielectric with its
exact Fresnel of the (coated) IOR at the (roughened) alpha, the coat's with coat_ior at alpha_c.
The same parameters, starts, open_pbr_surface inputs (the document does not change: ``mx`` is
how the fit reads it, as glTF's ``+turquin``) and glTF rule, with a note.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import TYPE_CHECKING

import numpy as np
from jaxtyping import Float

from ._lazy import jnp
from .constants import ALPHA_MIN, ROUGHNESS_MIN
from .declare import Composition, GltfRule, Param, Start
from .fresnel import f0_from_ior, fresnel_dielectric
from .geometry import dot, half_vector
from .openpbr import (BASE_COMPOSITIONS, BASE_MODELS, fresnel_f82, ggx_dir_albedo, ggx_energy_compensation,
                      metal_lobe, nonmetal_combine)
from .openpbr_fuzz import FUZZ_COMPOSITIONS, FUZZ_INPUTS
from .specular import ggx_ndf, visibility_height_correlated

if TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import Array, ArrayLike


def coat_roughened(roughness: Float[ArrayLike, "*#batch"], coat_roughness: Float[ArrayLike, "*#batch"],
                   coat_weight: Float[ArrayLike, "*#batch"]) -> Float[Array, "*#batch"]:
    """The base's roughness under the coat (the graph's effective_specular_roughness):
    mix(r_s, min(1, 2 r_c^4 + r_s^4)^(1/4), w)."""
    r2, c2 = roughness * roughness, coat_roughness * coat_roughness
    coated = jnp.sqrt(jnp.sqrt(jnp.minimum(2.0 * c2 * c2 + r2 * r2, 1.0)))
    return roughness * (1.0 - coat_weight) + coated * coat_weight


def coated_ior(specular_ior: Float[ArrayLike, "*#batch"], coat_ior: Float[ArrayLike, "*#batch"],
               coat_weight: Float[ArrayLike, "*#batch"]) -> Float[Array, "*#batch"]:
    """The non-metal's IOR under the coat (the graph's eta_s): mix(s, s / c if s > c else c / s, w)."""
    ratio = specular_ior / coat_ior
    inverted = jnp.where(ratio > 1.0, ratio, coat_ior / specular_ior)
    return specular_ior * (1.0 - coat_weight) + inverted * coat_weight


def coat_darkening(base_color: Float[ArrayLike, "*#batch #3"], coat_ior: Float[ArrayLike, "*#batch"],
                   coat_weight: Float[ArrayLike, "*#batch"]) -> Float[Array, "*#batch #3"]:
    """mix(1, (1 - K) / (1 - base_color K), w) with K = 1 - (1 - F0(c)) / c^2 (coat_darkening 1)."""
    c = jnp.asarray(coat_ior)[..., None]
    w = jnp.asarray(coat_weight)[..., None]
    k = 1.0 - (1.0 - f0_from_ior(c)) / (c * c)
    return (1.0 - w) + (1.0 - k) / (1.0 - jnp.asarray(base_color) * k) * w


def coat_layer(base: Float[ArrayLike, "*batch 3"], base_color: Float[ArrayLike, "*#batch #3"],
               coat_dv: Float[ArrayLike, "*batch"], v_dot_h: Float[ArrayLike, "*batch"],
               n_dot_v: Float[ArrayLike, "*batch"], coat_alpha: Float[ArrayLike, "*#batch"],
               coat_weight: Float[ArrayLike, "*#batch"], coat_ior: Float[ArrayLike, "*#batch"],
               mx: bool = False, darkens: bool = True) -> Float[Array, "*batch 3"]:
    """The coat's D V and the base's BRDF (already roughened) -> the coated BRDF (RGB):
    w F(v.h) D V + (1 - w E_c(n.v)) Delta f_base (the module's docstring; Delta = 1 unless ``darkens``);
    ``mx``: the coat's lobe and E_c times MaterialX's comp."""
    fresnel = fresnel_dielectric(v_dot_h, coat_ior)
    albedo = ggx_dir_albedo(n_dot_v, coat_alpha, f0_from_ior(coat_ior))
    if mx:
        comp = ggx_energy_compensation(n_dot_v, coat_alpha, fresnel)
        fresnel, albedo = fresnel * comp, albedo * comp
    top = coat_weight * fresnel * coat_dv
    throughput = 1.0 - coat_weight * albedo
    return top[..., None] + throughput[..., None] * coat_darkening(base_color, coat_ior, coat_weight * darkens) * base


def _dv(n_dot_h, n_dot_l, n_dot_v, alpha):
    return ggx_ndf(n_dot_h, alpha) * visibility_height_correlated(n_dot_l, n_dot_v, alpha)


def openpbr_metal_coat(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"],
                       base_color: Float[ArrayLike, "*#batch #3"], specular_color: Float[ArrayLike, "*#batch #3"],
                       roughness: Float[ArrayLike, "*#batch"], coat_weight: Float[ArrayLike, "*#batch"],
                       coat_roughness: Float[ArrayLike, "*#batch"],
                       coat_ior: Float[ArrayLike, "*#batch"], mx: bool = False, roughens: bool = True,
                       darkens: bool = True) -> Float[Array, "*batch 3"]:
    """OpenPBR's coated metal (RGB, 1/sr, without the cosine; ``wo`` the view direction; ``mx``: with
    MaterialX's comp); a switch off leaves that coat's effect on the base out."""
    h = half_vector(wi, wo)
    v_dot_h = dot(wo, h)
    r = coat_roughened(roughness, coat_roughness, coat_weight * roughens)
    fresnel, dv = fresnel_f82(base_color, specular_color, v_dot_h), _dv(h[..., 2], wi[..., 2], wo[..., 2], r * r)
    base = metal_lobe(fresnel, dv, wo[..., 2], r * r, mx)
    alpha_c = coat_roughness * coat_roughness
    return coat_layer(base, base_color, _dv(h[..., 2], wi[..., 2], wo[..., 2], alpha_c), v_dot_h, wo[..., 2],
                      alpha_c, coat_weight, coat_ior, mx, darkens)


def openpbr_nonmetal_coat(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"],
                          base_color: Float[ArrayLike, "*#batch #3"], specular_ior: Float[ArrayLike, "*#batch"],
                          roughness: Float[ArrayLike, "*#batch"], diffuse_roughness: Float[ArrayLike, "*#batch"],
                          coat_weight: Float[ArrayLike, "*#batch"], coat_roughness: Float[ArrayLike, "*#batch"],
                          coat_ior: Float[ArrayLike, "*#batch"], mx: bool = False, roughens: bool = True,
                          darkens: bool = True, inverts_ior: bool = True) -> Float[Array, "*batch 3"]:
    """OpenPBR's coated non-metal (RGB, 1/sr, without the cosine; ``wo`` the view direction; ``mx``: with
    MaterialX's comp); a switch off leaves that coat's effect on the base out."""
    h = half_vector(wi, wo)
    v_dot_h = dot(wo, h)
    r = coat_roughened(roughness, coat_roughness, coat_weight * roughens)
    alpha = r * r
    eta = coated_ior(specular_ior, coat_ior, coat_weight * inverts_ior)
    base = nonmetal_combine(_dv(h[..., 2], wi[..., 2], wo[..., 2], alpha), v_dot_h, wi[..., 2], wo[..., 2],
                            dot(wi, wo), alpha, base_color, eta, diffuse_roughness, mx)
    alpha_c = coat_roughness * coat_roughness
    return coat_layer(base, base_color, _dv(h[..., 2], wi[..., 2], wo[..., 2], alpha_c), v_dot_h, wo[..., 2],
                      alpha_c, coat_weight, coat_ior, mx, darkens)


# --- declarations -------------------------------------------------------------

def _clamped(roughness):
    """r clamped to [ROUGHNESS_MIN, 1], as brdf.model.roughness_alpha clamps the base's."""
    return jnp.clip(roughness, ROUGHNESS_MIN, 1.0)


def _coated(p, g, base_of, mx=False):
    """A coated composition's BRDF: base_of(alpha of the roughened base) is the base's BRDF;
    each alpha floored at ALPHA_MIN, as brdf.model.roughness_alpha floors the base's."""
    r_c = _clamped(p["coat_roughness"])
    r = coat_roughened(_clamped(p["roughness"]), r_c, p["coat_weight"])
    alpha, alpha_c = jnp.maximum(r * r, ALPHA_MIN), jnp.maximum(r_c * r_c, ALPHA_MIN)
    base = base_of(_dv(g.n_dot_h, g.n_dot_l, g.n_dot_v, alpha), alpha)
    return coat_layer(base, p["base_color"], _dv(g.n_dot_h, g.n_dot_l, g.n_dot_v, alpha_c), g.v_dot_h, g.n_dot_v,
                      alpha_c, p["coat_weight"], p["coat_ior"], mx)


def _metal_coat_material(p, g, dv, mx=False):
    """The openpbr_metal_coat composition's BRDF (the model's D V of the bare base unused;
    ``mx``: openpbr_metal_coat_mx's)."""
    def base(dv_base, alpha):
        fresnel = fresnel_f82(p["base_color"], p["specular_color"], g.v_dot_h)
        return metal_lobe(fresnel, dv_base, g.n_dot_v, alpha, mx)
    return _coated(p, g, base, mx)


def _nonmetal_coat_material(p, g, dv, mx=False):
    """The openpbr_nonmetal_coat composition's BRDF (the model's D V of the bare base unused;
    ``mx``: openpbr_nonmetal_coat_mx's)."""
    eta = coated_ior(p["specular_ior"], p["coat_ior"], p["coat_weight"])
    return _coated(p, g, lambda dv_base, alpha: nonmetal_combine(
        dv_base, g.v_dot_h, g.n_dot_l, g.n_dot_v, dot(g.wi, g.wo), alpha, p["base_color"], eta,
        p["base_diffuse_roughness"], mx), mx)


# The peak probe sees the bare base (coat_weight 0), so the base's start rules read it as
# they do uncoated; the fit then starts the coat at half weight, sharp, medium or broad (variants),
# and OpenPBR's coat once more faint and broad (OPENPBR_COAT_VARIANTS): it roughens the base below
# it (``coat_roughened``), so from half weight a sharp base under a faint haze is out of reach.
# That start found it on the polished metals' tables: openpbr+nonmetal+coat+mx's ranking error
# 0.54-0.67x on chrome, ss440 and steel, 0.82x blue-acrylic, 0.93x white-paint; the 25 other fits
# of the two coats on 15 MERL tables the same but pink-plastic's non-metal (0.99x) and steel's
# metal (1.03x); pairs evaluated +7 % (docs/performance.md).  Blender's coat leaves the base's
# roughness alone: the start changed none of its fits (10 fits on 5 tables).
COAT_PARAMS = (
    Param("coat_weight", 1, 0.0, 1.0, 0.5, "OpenPBR coat_weight: the coat's presence (coat_color 1)",
          start=Start(probe=0.0)),
    Param("coat_roughness", 1, ROUGHNESS_MIN, 1.0, 0.1, "OpenPBR coat_roughness: the coat's GGX roughness"),
    Param("coat_ior", 1, 1.0, 3.0, 1.6, "OpenPBR coat_ior: the coat's IOR (its exact Fresnel; default 1.6)"),
)
COAT_VARIANTS = (("coat_weight", "coat_roughness"), ((0.5, 0.05), (0.5, 0.15), (0.5, 0.4)))
OPENPBR_COAT_VARIANTS = (COAT_VARIANTS[0], COAT_VARIANTS[1] + ((0.05, 0.5),))

_GLTF_COAT = ("the coat (weight {coat_weight:.3g}, IOR {coat_ior:.4g}, roughness {coat_roughness:.3g}) is dropped: "
              "KHR_materials_clearcoat would draw another coat (IOR 1.5 fixed, Schlick's Fresnel at n.v mixed over "
              "the base, which it neither roughens nor darkens)")


def _coated_composition(base: Composition, name: str, lobe, hint: str, coat_note: str = _GLTF_COAT,
                        variants: tuple = COAT_VARIANTS) -> Composition:
    return Composition(
        name=name, own_lobes=True, params=base.params + COAT_PARAMS, lobe=lobe, hint=hint,
        variants=variants, reciprocal=False,       # the base under 1 - w E_c at n.v
        gltf=GltfRule(quantities=base.gltf.quantities, note=base.gltf.note + "; " + coat_note))


COAT_COMPOSITIONS = {
    "openpbr_metal_coat": _coated_composition(BASE_COMPOSITIONS["openpbr"], "openpbr_metal_coat",
                                              _metal_coat_material, "OpenPBR Surface's metal under its coat",
                                              variants=OPENPBR_COAT_VARIANTS),
    "openpbr_nonmetal_coat": _coated_composition(BASE_COMPOSITIONS["openpbr_nonmetal"], "openpbr_nonmetal_coat",
                                                 _nonmetal_coat_material,
                                                 "OpenPBR Surface's dielectric base under its coat",
                                                 variants=OPENPBR_COAT_VARIANTS),
}

_GLTF_MX = ("fitted in MaterialX's reading (+mx: its GGX energy compensation, not in the file; "
            "a glTF engine draws its own, or none)")
_PLAIN_COMPOSITIONS = {**BASE_COMPOSITIONS, **COAT_COMPOSITIONS, **FUZZ_COMPOSITIONS}
#: MaterialX's reading (+mx) of each: composition -> the composition it compensates
MX_TWINS = {"openpbr_metal_mx": "openpbr", "openpbr_nonmetal_mx": "openpbr_nonmetal",
            "openpbr_metal_coat_mx": "openpbr_metal_coat", "openpbr_nonmetal_coat_mx": "openpbr_nonmetal_coat",
            "openpbr_nonmetal_fuzz_mx": "openpbr_nonmetal_fuzz"}


def _mx_composition(name: str, twin: Composition) -> Composition:
    """``twin`` in MaterialX's reading: its lobe (each takes ``mx``) with mx=True, all else the same, a note more."""
    return dataclasses.replace(
        twin, name=name, lobe=functools.partial(twin.lobe, mx=True), reciprocal=False,    # comp at n.v
        hint=twin.hint + ", with MaterialX's GGX energy compensation",
        gltf=GltfRule(quantities=twin.gltf.quantities, note=twin.gltf.note + "; " + _GLTF_MX))


# The model string's options ("+"-joined after "openpbr", the base's first): composition
OPENPBR_MODELS = {**BASE_MODELS, "metal+coat": "openpbr_metal_coat", "nonmetal+coat": "openpbr_nonmetal_coat",
                  "metal+mx": "openpbr_metal_mx", "nonmetal+mx": "openpbr_nonmetal_mx",
                  "metal+coat+mx": "openpbr_metal_coat_mx", "nonmetal+coat+mx": "openpbr_nonmetal_coat_mx",
                  "nonmetal+fuzz": "openpbr_nonmetal_fuzz", "nonmetal+fuzz+mx": "openpbr_nonmetal_fuzz_mx"}
OPENPBR_OPTIONS = ("coat", "fuzz", "mx")     # after the base, in this order
OPENPBR_TOKENS = (*BASE_MODELS, *OPENPBR_OPTIONS)
OPENPBR_COMPOSITIONS = {**_PLAIN_COMPOSITIONS,
                        **{name: _mx_composition(name, _PLAIN_COMPOSITIONS[twin]) for name, twin in MX_TWINS.items()}}
# The ModelSpec fields every one fixes: (ndf, masking, energy, fresnel, clearcoat).
OPENPBR_FIXED = ("ggx", "height_correlated", "none", "schlick", False)


def openpbr_composition(options: list[str]) -> str | None:
    """The composition of an openpbr model string's options (any order), None if none is."""
    return OPENPBR_MODELS.get("+".join(sorted(options, key=lambda tok: OPENPBR_OPTIONS.index(tok) + 1
                                              if tok in OPENPBR_OPTIONS else 0)))


# --- as an open_pbr_surface, 1:1 ------------------------------------------------------

_BASE_INPUTS = {
    "openpbr": {"base_color": "base_color", "specular_color": "specular_color", "roughness": "specular_roughness"},
    "openpbr_nonmetal": {"base_color": "base_color", "specular_ior": "specular_ior",
                         "base_diffuse_roughness": "base_diffuse_roughness", "roughness": "specular_roughness"},
}
_COAT_INPUTS = {"coat_weight": "coat_weight", "coat_roughness": "coat_roughness", "coat_ior": "coat_ior"}
#: composition -> {parameter: the open_pbr_surface input (ND_open_pbr_surface_surfaceshader,
#: MaterialX 1.39.5's libraries/bxdf/open_pbr_surface.mtlx) it is, the same value}
OPEN_PBR_SURFACE_INPUTS = {**_BASE_INPUTS, "openpbr_metal_coat": {**_BASE_INPUTS["openpbr"], **_COAT_INPUTS},
                           "openpbr_nonmetal_coat": {**_BASE_INPUTS["openpbr_nonmetal"], **_COAT_INPUTS},
                           "openpbr_nonmetal_fuzz": {**_BASE_INPUTS["openpbr_nonmetal"], **FUZZ_INPUTS}}
OPEN_PBR_SURFACE_INPUTS.update({mx: OPEN_PBR_SURFACE_INPUTS[twin] for mx, twin in MX_TWINS.items()})   # the same
#: the inputs each holds (their node defaults are base_weight 1, specular_weight 1,
#: specular_color 1, base_metalness 0, coat_weight 0, coat_color 1, coat_darkening 1:
#: written all the same, so the document says what it draws)
_BASE_HELD = {
    "openpbr": {"base_weight": 1.0, "base_metalness": 1.0, "specular_weight": 1.0},
    "openpbr_nonmetal": {"base_weight": 1.0, "base_metalness": 0.0, "specular_weight": 1.0,
                         "specular_color": [1.0, 1.0, 1.0]},
}
_COAT_HELD = {"coat_color": [1.0, 1.0, 1.0], "coat_darkening": 1.0}
OPEN_PBR_SURFACE_HELD = {**_BASE_HELD, "openpbr_metal_coat": {**_BASE_HELD["openpbr"], **_COAT_HELD},
                         "openpbr_nonmetal_coat": {**_BASE_HELD["openpbr_nonmetal"], **_COAT_HELD},
                         "openpbr_nonmetal_fuzz": _BASE_HELD["openpbr_nonmetal"]}
OPEN_PBR_SURFACE_HELD.update({mx: OPEN_PBR_SURFACE_HELD[twin] for mx, twin in MX_TWINS.items()})


def open_pbr_surface_inputs(parameters: dict, composition: str = "openpbr") -> dict:
    """A fit's parameters ({name: float or [r, g, b]}) of an OpenPBR composition (one of
    OPENPBR_COMPOSITIONS) as the inputs of OpenPBR's open_pbr_surface that draw the same
    BRDF: {input: value}, 1:1.  Any other composition (Blender's Principled coat: brdf/principled.py,
    whose coat is not OpenPBR's) is a ValueError."""
    if composition not in OPEN_PBR_SURFACE_HELD:
        raise ValueError(f"{composition}: not an OpenPBR composition; open_pbr_surface draws "
                         + ", ".join(OPEN_PBR_SURFACE_HELD))
    out = dict(OPEN_PBR_SURFACE_HELD[composition])
    for name, key in OPEN_PBR_SURFACE_INPUTS[composition].items():
        value = parameters[name]
        out[key] = [float(v) for v in value] if np.ndim(value) else float(value)
    return out
