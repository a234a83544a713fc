"""Blender's Principled BSDF (issue 61): ``principled+metal``, ``principled+nonmetal``, each
bare or under its coat (``+coat``), and the model strings of the models that fix their own
terms (``openpbr`` and ``principled``; brdf/spec.py calls ``fixed_composition`` and
``fixed_model_string``).

Blender 4's and 5's Principled BSDF draws OpenPBR's bare bases (brdf/openpbr.py; the
single-scattering "GGX" distribution), so ``principled+metal`` and ``principled+nonmetal``
parse to the compositions of ``openpbr+metal`` and ``openpbr+nonmetal``: one BRDF, one
composition, its canonical model string the ``openpbr`` one (results, GLSL and every writer
already know it; a second name for one BRDF would split them).

Its coat (Coat Weight w, Coat Roughness r_c, Coat IOR c, Coat Tint white) is OpenPBR's
(brdf/openpbr_coat.py) without the coat's three effects on the base:

    f = w F_dielectric(v.h, c) D_c V_c + (1 - w E_c(n.v)) f_base(r, s)

the base at its own roughness r (no roughening), its own IOR s (no inversion under the coat)
and no coat darkening (Delta = 1); E_c is the same analytic directional albedo.  Measured
(Cycles 5.0.1 against this formula, the lit sphere, 2026-12-06): metals 0.998-1.000, non-metals
0.984-0.988 (the non-metal base alone is drawn 1-9 % darker: docs/blender.md), where OpenPBR's
coat is 1.13-1.64 (metal) and the inverted IOR 1.04-1.31 (non-metal).  Compositions
"principled_metal_coat" and "principled_nonmetal_coat": the OpenPBR coat's functions with
their switches off (``roughens``, ``darkens``, ``inverts_ior``; the composition's ``openpbr``).
They are not OpenPBR's coat: they stay out of OPENPBR_COMPOSITIONS (no open_pbr_surface is
written for them).  docs/models.md (principled), docs/blender.md.
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

from jaxtyping import Float

from .openpbr import BASE_COMPOSITIONS, BASE_MODELS
from .openpbr_coat import (OPENPBR_COMPOSITIONS, OPENPBR_FIXED, OPENPBR_MODELS, _coated_composition,
                           _metal_coat_material, _nonmetal_coat_material, openpbr_composition, openpbr_metal_coat,
                           openpbr_nonmetal_coat)

if TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import Array, ArrayLike


def principled_metal_coat(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"],
                          base_color: Float[ArrayLike, "*#batch #3"], specular_color: Float[ArrayLike, "*#batch #3"],
                          roughness: Float[ArrayLike, "*#batch"], coat_weight: Float[ArrayLike, "*#batch"],
                          coat_roughness: Float[ArrayLike, "*#batch"],
                          coat_ior: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch 3"]:
    """The Principled BSDF's coated metal (RGB, 1/sr, without the cosine; ``wo`` the view direction)."""
    return openpbr_metal_coat(wi, wo, base_color, specular_color, roughness, coat_weight, coat_roughness, coat_ior,
                              roughens=False, darkens=False)


def principled_nonmetal_coat(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"],
                             base_color: Float[ArrayLike, "*#batch #3"], specular_ior: Float[ArrayLike, "*#batch"],
                             roughness: Float[ArrayLike, "*#batch"], diffuse_roughness: Float[ArrayLike, "*#batch"],
                             coat_weight: Float[ArrayLike, "*#batch"], coat_roughness: Float[ArrayLike, "*#batch"],
                             coat_ior: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch 3"]:
    """The Principled BSDF's coated non-metal (RGB, 1/sr, without the cosine; ``wo`` the view direction)."""
    return openpbr_nonmetal_coat(wi, wo, base_color, specular_ior, roughness, diffuse_roughness, coat_weight,
                                 coat_roughness, coat_ior, roughens=False, darkens=False, inverts_ior=False)


# --- declarations -------------------------------------------------------------

_GLTF_COAT = ("the coat (weight {coat_weight:.3g}, IOR {coat_ior:.4g}, roughness {coat_roughness:.3g}) is dropped: "
              "KHR_materials_clearcoat would draw another coat (IOR 1.5 fixed, Schlick's Fresnel at n.v mixed over "
              "the base, where the Principled BSDF's is the exact Fresnel of its IOR at v.h, the base weighed by "
              "1 - w E_c)")

# The same parameters, bounds, start rules (brdf.openpbr_coat.COAT_PARAMS, COAT_VARIANTS) as OpenPBR's.
PRINCIPLED_COAT_COMPOSITIONS = {
    "principled_metal_coat": _coated_composition(
        BASE_COMPOSITIONS["openpbr"], "principled_metal_coat", functools.partial(_metal_coat_material, openpbr=False),
        "Blender's Principled BSDF: its metal under its coat", _GLTF_COAT),
    "principled_nonmetal_coat": _coated_composition(
        BASE_COMPOSITIONS["openpbr_nonmetal"], "principled_nonmetal_coat",
        functools.partial(_nonmetal_coat_material, openpbr=False),
        "Blender's Principled BSDF: its dielectric base under its coat", _GLTF_COAT),
}
#: the base each coated composition is drawn over (bare: OpenPBR's, brdf/openpbr.py)
PRINCIPLED_COAT_BASES = {"principled_metal_coat": "openpbr", "principled_nonmetal_coat": "openpbr_nonmetal"}

# The model string's options ("+"-joined after "principled", the base's first): composition
PRINCIPLED_MODELS = {**BASE_MODELS, "metal+coat": "principled_metal_coat", "nonmetal+coat": "principled_nonmetal_coat"}

#: every composition that fixes its terms (GGX, height-correlated Smith, its own Fresnel, diffuse, coat)
FIXED_COMPOSITIONS = {**OPENPBR_COMPOSITIONS, **PRINCIPLED_COAT_COMPOSITIONS}
#: model-string head -> {its options: composition}
FIXED_HEADS = {"openpbr": OPENPBR_MODELS, "principled": PRINCIPLED_MODELS}
#: the ModelSpec fields every one fixes: (ndf, masking, energy, fresnel, clearcoat)
FIXED_TERMS = OPENPBR_FIXED


def principled_composition(options: list[str]) -> str | None:
    """The composition of a principled model string's options (any order), None if none is."""
    return PRINCIPLED_MODELS.get("+".join(sorted(options, key=lambda tok: tok == "coat")))


def fixed_composition(head: str, options: list[str]) -> str | None:
    """The composition of an ``openpbr`` or ``principled`` model string's options, None if none is."""
    return openpbr_composition(options) if head == "openpbr" else principled_composition(options)


def fixed_model_string(composition: str) -> str:
    """The canonical model string of a composition of FIXED_COMPOSITIONS (the bare bases: ``openpbr+...``)."""
    head = "principled" if composition in PRINCIPLED_COAT_COMPOSITIONS else "openpbr"
    return f"{head}+" + {c: tok for tok, c in FIXED_HEADS[head].items()}[composition]
