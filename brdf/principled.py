"""Blender's Principled BSDF as Cycles draws it (issue 61): ``principled+metal``,
``principled+nonmetal``, each bare or under its coat (``+coat``), the dielectric base under its
sheen (``principled+nonmetal+sheen``), either bare base with Multiscatter GGX (``+ms``), and the
model strings of the
models that fix their own terms (``openpbr`` and ``principled``; brdf/spec.py calls
``fixed_composition`` and ``fixed_model_string``).

Blender 4's and 5's Principled BSDF with the single-scattering "GGX" distribution draws a metal
as OpenPBR's bare metal (brdf/openpbr.py: GGX with Hoffman's F82-tint Fresnel of Base Color and
Specular Tint), so ``principled+metal`` parses to the composition of ``openpbr+metal``: one BRDF,
one composition, its canonical model string the ``openpbr`` one.

Its dielectric base (``principled+nonmetal``, composition "principled_nonmetal") is the same
specular lobe (GGX, the exact Fresnel of IOR eta) over the diffuse, but layered in Cycles' own
terms (brdf/cycles.py): the diffuse weighed by saturate(1 - albedo(n.v)) with Cycles' estimate
albedo = F0 + (1 - F0) S(r, n.v, eta) of the specular's albedo, and at Diffuse Roughness > 0
Cycles' Oren-Nayar (Fujii's, with OpenPBR's multiple scattering as bsdf_oren_nayar.h has it):

    f = F_dielectric(v.h, eta) D V + saturate(1 - albedo(n.v)) f_diffuse(base_color, sigma)

OpenPBR's (MaterialX's) non-metal weighs its EON by 1 - E(n.v), an analytic fit of the lobe's
own albedo: drawn by Cycles it was 0.8 % (IOR 1.5, r 0.3) to 9 % (IOR 2.2, r 0.8, Diffuse
Roughness 1) darker than fitted; in Cycles' terms 1.0000-1.0003 (docs/blender.md).

Its coat (Coat Weight w, Coat Roughness r_c, Coat IOR c, Coat Tint white) keeps its energy as
Cycles' microfacet_ggx_preserve_energy does (C, E: brdf.cycles.cycles_coat_layer) and lies over
either base as closure_layering_weight puts it:

    f = w C F_dielectric(v.h, c) D_c V_c + saturate(1 - w E C albedo_c(n.v)) f_base

albedo_c Cycles' estimate at (r_c, c); the base at its own roughness and IOR, not darkened:
none of OpenPBR's three effects of its coat on the base (brdf/openpbr_coat.py: roughening,
the inverted IOR, coat darkening; drawn by Cycles that coat is 1.13-2.36x too bright).
Compositions "principled_metal_coat" and "principled_nonmetal_coat".

Its sheen (Sheen Weight, Tint, Roughness: the parameters fuzz_weight, fuzz_color, fuzz_roughness,
OpenPBR's fuzz's names, as the other Principled models take OpenPBR's) is the top layer, over the
dielectric base (composition "principled_nonmetal_sheen"; brdf.cycles.cycles_sheen_layer):

    f = w t E(n.v) D(l) / n.l + saturate(1 - max_c(w t_c E(n.v))) f_nonmetal

Zeltner et al.'s lobe as OpenPBR's fuzz (brdf/openpbr_fuzz.py), layered in Cycles' terms (the
largest channel of the sheen's albedo, where OpenPBR's fuzz takes 1 - w E whatever its colour).
Not over the coat or the metal (as OpenPBR's fuzz).

With the distribution Multiscatter GGX (``principled+metal+ms``, ``principled+nonmetal+ms``:
compositions "principled_metal_ms", "principled_nonmetal_ms") Cycles keeps the metal's and the
specular's lobes' energy as it keeps the coat's: the lobe times C = 1 + F_ms (1 - E) / E
(brdf.cycles.cycles_multiscatter; F_ss the F82-tint Fresnel's average per channel, or the
dielectric's), the diffuse below the specular weighed by saturate(1 - E C albedo(n.v)).  None of
these is
OpenPBR's: they stay out of OPENPBR_COMPOSITIONS (no open_pbr_surface is written for them).
docs/models.md (principled), docs/blender.md.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

from jaxtyping import Float

from ._lazy import jnp
from .constants import ALPHA_MIN
from .cycles import cycles_coat_layer, cycles_f82_fss, cycles_multiscatter, cycles_nonmetal, cycles_sheen_layer
from .declare import GltfRule
from .fresnel import fresnel_dielectric
from .geometry import dot, half_vector
from .openpbr import BASE_COMPOSITIONS, BASE_MODELS, fresnel_f82, metal_lobe
from .openpbr_fuzz import FUZZ_COMPOSITIONS
from .openpbr_coat import (OPENPBR_COMPOSITIONS, OPENPBR_FIXED, OPENPBR_MODELS, _clamped, _coated_composition, _dv,
                           openpbr_composition)

if TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import Array, ArrayLike


def principled_nonmetal(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"],
                        base_color: Float[ArrayLike, "*#batch #3"], specular_ior: Float[ArrayLike, "*#batch"],
                        roughness: Float[ArrayLike, "*#batch"],
                        diffuse_roughness: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch 3"]:
    """The Principled BSDF's dielectric base as Cycles draws it (RGB, 1/sr, without the cosine; ``wo`` the
    view direction), GGX of alpha = roughness^2 with height-correlated Smith."""
    h = half_vector(wi, wo)
    dv = _dv(h[..., 2], wi[..., 2], wo[..., 2], roughness * roughness)
    return cycles_nonmetal(dv, dot(wo, h), wi[..., 2], wo[..., 2], dot(wi, wo), roughness, base_color, specular_ior,
                           diffuse_roughness)


def _coat(base, wi, wo, h, coat_weight, coat_roughness, coat_ior):
    alpha_c = coat_roughness * coat_roughness
    top = fresnel_dielectric(dot(wo, h), coat_ior) * _dv(h[..., 2], wi[..., 2], wo[..., 2], alpha_c)
    return cycles_coat_layer(top, base, wo[..., 2], coat_roughness, coat_ior, coat_weight)


def principled_metal_coat(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"],
                          base_color: Float[ArrayLike, "*#batch #3"], specular_color: Float[ArrayLike, "*#batch #3"],
                          roughness: Float[ArrayLike, "*#batch"], coat_weight: Float[ArrayLike, "*#batch"],
                          coat_roughness: Float[ArrayLike, "*#batch"],
                          coat_ior: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch 3"]:
    """The Principled BSDF's coated metal as Cycles draws it (RGB, 1/sr, without the cosine; ``wo`` the view)."""
    h = half_vector(wi, wo)
    base = metal_lobe(fresnel_f82(base_color, specular_color, dot(wo, h)),
                      _dv(h[..., 2], wi[..., 2], wo[..., 2], roughness * roughness), wo[..., 2], roughness * roughness)
    return _coat(base, wi, wo, h, coat_weight, coat_roughness, coat_ior)


def principled_nonmetal_coat(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"],
                             base_color: Float[ArrayLike, "*#batch #3"], specular_ior: Float[ArrayLike, "*#batch"],
                             roughness: Float[ArrayLike, "*#batch"], diffuse_roughness: Float[ArrayLike, "*#batch"],
                             coat_weight: Float[ArrayLike, "*#batch"], coat_roughness: Float[ArrayLike, "*#batch"],
                             coat_ior: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch 3"]:
    """The Principled BSDF's coated dielectric base as Cycles draws it (RGB, 1/sr, without the cosine; ``wo``
    the view)."""
    base = principled_nonmetal(wi, wo, base_color, specular_ior, roughness, diffuse_roughness)
    return _coat(base, wi, wo, half_vector(wi, wo), coat_weight, coat_roughness, coat_ior)


def principled_metal_ms(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"],
                        base_color: Float[ArrayLike, "*#batch #3"], specular_color: Float[ArrayLike, "*#batch #3"],
                        roughness: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch 3"]:
    """The Principled BSDF's metal with Multiscatter GGX as Cycles draws it (RGB, 1/sr, without the cosine;
    ``wo`` the view): the F82-tint lobe times ``cycles_multiscatter`` of its Fresnel's average, per channel."""
    h = half_vector(wi, wo)
    return _metal_ms(fresnel_f82(base_color, specular_color, dot(wo, h)), _dv(h[..., 2], wi[..., 2], wo[..., 2],
                     roughness * roughness), wo[..., 2], roughness, base_color, specular_color)


def _metal_ms(fresnel, dv, n_dot_v, roughness, base_color, specular_color):
    """The metal's lobe F D V times its multiscatter factor, per channel."""
    kept = cycles_multiscatter(jnp.asarray(n_dot_v)[..., None], jnp.asarray(roughness)[..., None],
                               cycles_f82_fss(base_color, specular_color))
    return fresnel * jnp.asarray(dv)[..., None] * kept


def principled_nonmetal_ms(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"],
                           base_color: Float[ArrayLike, "*#batch #3"], specular_ior: Float[ArrayLike, "*#batch"],
                           roughness: Float[ArrayLike, "*#batch"],
                           diffuse_roughness: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch 3"]:
    """The Principled BSDF's dielectric base with Multiscatter GGX as Cycles draws it (RGB, 1/sr, without
    the cosine; ``wo`` the view)."""
    h = half_vector(wi, wo)
    dv = _dv(h[..., 2], wi[..., 2], wo[..., 2], roughness * roughness)
    return cycles_nonmetal(dv, dot(wo, h), wi[..., 2], wo[..., 2], dot(wi, wo), roughness, base_color, specular_ior,
                           diffuse_roughness, ms=True)


def principled_nonmetal_sheen(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"],
                              base_color: Float[ArrayLike, "*#batch #3"], specular_ior: Float[ArrayLike, "*#batch"],
                              roughness: Float[ArrayLike, "*#batch"], diffuse_roughness: Float[ArrayLike, "*#batch"],
                              sheen_weight: Float[ArrayLike, "*#batch"], sheen_tint: Float[ArrayLike, "*#batch #3"],
                              sheen_roughness: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch 3"]:
    """The Principled BSDF's dielectric base under its sheen as Cycles draws it (RGB, 1/sr, without the
    cosine; ``wo`` the view)."""
    base = principled_nonmetal(wi, wo, base_color, specular_ior, roughness, diffuse_roughness)
    return cycles_sheen_layer(base, wi, wo, sheen_weight, sheen_tint, sheen_roughness)


# --- declarations -------------------------------------------------------------

def _roughness(p):
    """Cycles' roughness of the model's alpha (sqrt(alpha): r clamped, alpha floored as brdf.model.roughness_alpha)."""
    r = _clamped(p["roughness"])
    return jnp.sqrt(jnp.maximum(r * r, ALPHA_MIN))


def _nonmetal_material(p, g, dv, ms=False):
    """The principled_nonmetal composition's BRDF from the model's D V (brdf/model.py); ``ms``: _ms's."""
    return cycles_nonmetal(dv, g.v_dot_h, g.n_dot_l, g.n_dot_v, dot(g.wi, g.wo), _roughness(p), p["base_color"],
                           p["specular_ior"], p["base_diffuse_roughness"], ms)


def _nonmetal_ms_material(p, g, dv):
    """The principled_nonmetal_ms composition's BRDF."""
    return _nonmetal_material(p, g, dv, ms=True)


def _metal_ms_material(p, g, dv):
    """The principled_metal_ms composition's BRDF."""
    return _metal_ms(fresnel_f82(p["base_color"], p["specular_color"], g.v_dot_h), dv, g.n_dot_v, _roughness(p),
                     p["base_color"], p["specular_color"])


def _coated(p, g, base):
    """The coat over a base's BRDF: the coat's roughness clamped, its alpha floored as the base's."""
    r_c = _clamped(p["coat_roughness"])
    alpha_c = jnp.maximum(r_c * r_c, ALPHA_MIN)
    top = fresnel_dielectric(g.v_dot_h, p["coat_ior"]) * _dv(g.n_dot_h, g.n_dot_l, g.n_dot_v, alpha_c)
    return cycles_coat_layer(top, base, g.n_dot_v, jnp.sqrt(alpha_c), p["coat_ior"], p["coat_weight"])


def _metal_coat_material(p, g, dv):
    """The principled_metal_coat composition's BRDF (the base at the model's D V: its own roughness)."""
    return _coated(p, g, metal_lobe(fresnel_f82(p["base_color"], p["specular_color"], g.v_dot_h), dv, g.n_dot_v,
                                    _roughness(p) ** 2))


def _nonmetal_coat_material(p, g, dv):
    """The principled_nonmetal_coat composition's BRDF."""
    return _coated(p, g, _nonmetal_material(p, g, dv))


def _nonmetal_sheen_material(p, g, dv):
    """The principled_nonmetal_sheen composition's BRDF."""
    return cycles_sheen_layer(_nonmetal_material(p, g, dv), g.wi, g.wo, p["fuzz_weight"], p["fuzz_color"],
                              p["fuzz_roughness"])


_GLTF_CYCLES = ("Cycles' layering (the diffuse weighed by 1 - its estimate of the specular's albedo at n.v) and "
                "diffuse (Fujii's Oren-Nayar of Diffuse Roughness {base_diffuse_roughness:.3g}) become glTF's "
                "(Schlick of the same F0, the diffuse weighted by 1 - F(v.h), Lambert)")
_GLTF_COAT = ("the coat (weight {coat_weight:.3g}, IOR {coat_ior:.4g}, roughness {coat_roughness:.3g}) is dropped: "
              "KHR_materials_clearcoat would draw another coat (IOR 1.5 fixed, Schlick's Fresnel at n.v mixed over "
              "the base, where the Principled BSDF's is the exact Fresnel of its IOR at v.h, the base weighed by "
              "1 - w times Cycles' estimate of its albedo)")

_GLTF_SHEEN = ("; the sheen (weight {fuzz_weight:.3g}, roughness {fuzz_roughness:.3g}) is dropped: "
               "KHR_materials_sheen draws another lobe (Charlie's)")

_GLTF_MS = ("Cycles' Multiscatter GGX (the lobe kept its energy, 1 + F_ms (1 - E) / E at n.v) becomes glTF's single "
            "scattering")

_NONMETAL = dataclasses.replace(
    BASE_COMPOSITIONS["openpbr_nonmetal"], name="principled_nonmetal", lobe=_nonmetal_material,
    hint="Blender's Principled BSDF: its dielectric base as Cycles draws it",
    gltf=GltfRule(quantities=BASE_COMPOSITIONS["openpbr_nonmetal"].gltf.quantities, note=_GLTF_CYCLES))

# The same parameters, bounds and start rules (brdf.openpbr_coat.COAT_PARAMS) as OpenPBR's; the coat's
# starts without OpenPBR's faint broad one (COAT_VARIANTS: Blender's coat does not roughen the base).
PRINCIPLED_COMPOSITIONS = {
    "principled_nonmetal": _NONMETAL,
    "principled_metal_coat": _coated_composition(
        BASE_COMPOSITIONS["openpbr"], "principled_metal_coat", _metal_coat_material,
        "Blender's Principled BSDF: its metal under its coat", _GLTF_COAT),
    "principled_nonmetal_coat": _coated_composition(
        _NONMETAL, "principled_nonmetal_coat", _nonmetal_coat_material,
        "Blender's Principled BSDF: its dielectric base under its coat", _GLTF_COAT),
    # with Multiscatter GGX: the bare bases' parameters, bounds and starts
    "principled_metal_ms": dataclasses.replace(
        BASE_COMPOSITIONS["openpbr"], name="principled_metal_ms", lobe=_metal_ms_material,
        hint="Blender's Principled BSDF: its metal with Multiscatter GGX", reciprocal=False,   # C at n.v
        gltf=GltfRule(quantities=BASE_COMPOSITIONS["openpbr"].gltf.quantities, note=_GLTF_MS)),
    "principled_nonmetal_ms": dataclasses.replace(
        _NONMETAL, name="principled_nonmetal_ms", lobe=_nonmetal_ms_material,
        hint="Blender's Principled BSDF: its dielectric base with Multiscatter GGX", reciprocal=False,
        gltf=GltfRule(quantities=_NONMETAL.gltf.quantities, note=_GLTF_CYCLES + "; " + _GLTF_MS)),
    # OpenPBR's fuzz's parameters, bounds, starts and variants (brdf.openpbr_fuzz.FUZZ_PARAMS)
    "principled_nonmetal_sheen": dataclasses.replace(
        FUZZ_COMPOSITIONS["openpbr_nonmetal_fuzz"], name="principled_nonmetal_sheen", lobe=_nonmetal_sheen_material,
        hint="Blender's Principled BSDF: its dielectric base under its sheen",
        gltf=GltfRule(quantities=_NONMETAL.gltf.quantities, note=_GLTF_CYCLES + _GLTF_SHEEN)),
}
#: the OpenPBR base whose parameters (and open_pbr_surface names) each Principled composition shares
PRINCIPLED_BASES = {"principled_nonmetal": "openpbr_nonmetal", "principled_metal_coat": "openpbr",
                    "principled_nonmetal_coat": "openpbr_nonmetal",
                    "principled_nonmetal_sheen": "openpbr_nonmetal_fuzz", "principled_metal_ms": "openpbr",
                    "principled_nonmetal_ms": "openpbr_nonmetal"}
#: the coated ones
PRINCIPLED_COATED = ("principled_metal_coat", "principled_nonmetal_coat")

# The model string's options ("+"-joined after "principled", the base's first): composition
PRINCIPLED_MODELS = {"metal": BASE_MODELS["metal"], "nonmetal": "principled_nonmetal",
                     "metal+coat": "principled_metal_coat", "nonmetal+coat": "principled_nonmetal_coat",
                     "nonmetal+sheen": "principled_nonmetal_sheen", "metal+ms": "principled_metal_ms",
                     "nonmetal+ms": "principled_nonmetal_ms"}
#: the options after the base, in their canonical order
PRINCIPLED_OPTIONS = ("sheen", "coat", "ms")
#: the compositions drawn with Multiscatter GGX (the Principled BSDF's distribution MULTI_GGX)
PRINCIPLED_MS = ("principled_metal_ms", "principled_nonmetal_ms")
PRINCIPLED_TOKENS = ("metal", "nonmetal", *PRINCIPLED_OPTIONS)

#: every composition that fixes its terms (GGX, height-correlated Smith, its own Fresnel, diffuse, coat)
FIXED_COMPOSITIONS = {**OPENPBR_COMPOSITIONS, **PRINCIPLED_COMPOSITIONS}
#: model-string head -> {its options: composition}
FIXED_HEADS = {"openpbr": OPENPBR_MODELS, "principled": PRINCIPLED_MODELS}
#: the ModelSpec fields every one fixes: (ndf, masking, energy, fresnel, clearcoat)
FIXED_TERMS = OPENPBR_FIXED


def principled_composition(options: list[str]) -> str | None:
    """The composition of a principled model string's options (any order), None if none is."""
    return PRINCIPLED_MODELS.get("+".join(sorted(options, key=lambda tok: PRINCIPLED_OPTIONS.index(tok) + 1
                                                 if tok in PRINCIPLED_OPTIONS else 0)))


def fixed_composition(head: str, options: list[str]) -> str | None:
    """The composition of an ``openpbr`` or ``principled`` model string's options, None if none is."""
    return openpbr_composition(options) if head == "openpbr" else principled_composition(options)


def fixed_model_string(composition: str) -> str:
    """The canonical model string of a composition of FIXED_COMPOSITIONS (the bare metal: ``openpbr+metal``)."""
    head = "principled" if composition in PRINCIPLED_COMPOSITIONS else "openpbr"
    return f"{head}+" + {c: tok for tok, c in FIXED_HEADS[head].items()}[composition]
