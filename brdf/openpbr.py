"""OpenPBR Surface's metal: GGX with the F82-tint Fresnel (the first slice of issue 61).

OpenPBR Surface draws its metal (base_metalness 1) as a ``generalized_schlick_bsdf``
with color0 = base_weight base_color, color82 = specular_color, color90 = 1 and
exponent 5, weighted by specular_weight, over a GGX lobe of alpha =
specular_roughness^2 with height-correlated Smith masking.  Read in the MaterialX
python package 1.39.5 (``pip install materialx``):

    MaterialX/libraries/bxdf/open_pbr_surface.mtlx            the node graph (metal_bsdf)
    MaterialX/libraries/pbrlib/genglsl/mx_generalized_schlick_bsdf.glsl
    MaterialX/libraries/pbrlib/genglsl/lib/mx_microfacet_specular.glsl
                                                              mx_fresnel_hoffman_schlick

The Fresnel is Hoffman's F82 form (Hoffman 2023, "Generalization of Adobe's Fresnel
Model"; Kutz et al. 2021, "Novel aspects of the Adobe Standard Material"):

    S(mu)  = F0 + (1 - F0)(1 - mu)^5                                (Schlick)
    F(mu)  = S(mu) - a mu (1 - mu)^6,
    a      = S(1/7) (1 - F82) / ((1/7)(1 - 1/7)^6)

so F(1) = F0, F(0) = 1 and F(1/7) = F82 x S(1/7): ``specular_color`` is the metal's
colour near grazing relative to Schlick's (1: plain Schlick, as glTF's metal).
F is clamped at 0 here: with a dark tint over a dark F0 the form dips below 0 between
mu = 1/7 and 6/7 (F0 = 0, F82 = 0: F = (1 - mu)^5 (1 - 49/6 mu (1 - mu)), -0.0326 at
mu = 1/2); MaterialX's genglsl leaves it negative, a BRDF is never negative.

    f = F(v.h) D V

What this leaves out, on purpose, for now: MaterialX's genglsl multiplies the lobe by
its GGX energy compensation (``mx_ggx_energy_compensation``: multiple scattering) and
OpenPBR adds it too; the lobe here is the single-scattering one the toolkit's other
GGX models fit.  The model string is ``openpbr+metal``; the schema's ``roughness`` is
OpenPBR's ``specular_roughness`` (alpha = r^2 in both), ``base_color`` its base_color
(base_weight 1), ``specular_color`` its specular_color (specular_weight 1).
docs/models.md (openpbr).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from jaxtyping import Float

from ._lazy import jnp
from .declare import Composition, GltfRule, Param, Start
from .geometry import half_vector
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
    schlick_82 = f0 + (1.0 - f0) * F82_SCHLICK_W
    a = schlick_82 * (1.0 - jnp.asarray(f82)) * F82_FACTOR
    return jnp.maximum(schlick - a * mu * (x5 * x), 0.0)


def openpbr_metal(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"],
                  base_color: Float[ArrayLike, "*#batch #3"], specular_color: Float[ArrayLike, "*#batch #3"],
                  roughness: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch 3"]:
    """OpenPBR's metal (RGB, 1/sr, without the cosine): F82(v.h) D V, GGX of alpha =
    roughness^2 with height-correlated Smith (brdf/specular.py)."""
    alpha = roughness * roughness
    h = half_vector(wi, wo)
    dv = ggx_ndf(h[..., 2], alpha) * visibility_height_correlated(wi[..., 2], wo[..., 2], alpha)
    v_dot_h = jnp.sum(jnp.asarray(wo) * h, axis=-1)
    return fresnel_f82(base_color, specular_color, v_dot_h) * dv[..., None]


# --- declarations -------------------------------------------------------------

def _metal_material(p, g, dv):
    """The openpbr composition's BRDF from the model's D V (brdf/model.py): the metal."""
    return fresnel_f82(p["base_color"], p["specular_color"], g.v_dot_h) * dv[..., None]


BASE_COLOR = Param("base_color", 3, 0.0, 1.0, 0.8,
                   "OpenPBR base_color: the metal's F0 (linear RGB; base_weight 1)",
                   start=Start(probe=1.0, rule=lambda e: np.clip(e.scale, 0.0, 1.0)))
# Neutral 1 (plain Schlick, OpenPBR's default); the start inside the range: at its bound 1
# the bounded transform's slope is ~0.
SPECULAR_COLOR = Param("specular_color", 3, 0.0, 1.0, 1.0,
                       "OpenPBR specular_color: the metal's F82 edge tint (1: Schlick; specular_weight 1)",
                       start=Start(probe=1.0, rule=lambda e: np.full(3, 0.8)))

# The model string's options: only the metal exists so far (base_metalness held at 1), so
# ``metal`` is required (openpbr+metal); the dielectric base and the coat are the rest of
# issue 61.  The ModelSpec fields it fixes: (ndf, masking, energy, fresnel, clearcoat).
OPENPBR_TOKENS = ("metal",)
OPENPBR_FIXED = ("ggx", "height_correlated", "none", "schlick", False)

# The composition: lobe(params, g, dv) is the whole BRDF.  Only the metal exists so far
# (base_metalness held at 1): the model string is openpbr+metal (brdf/spec.py).
# As glTF (brdf/gltf_material.py): a glTF metal of baseColor F0, whose Fresnel is
# Schlick's (F90 = 1): the edge tint has no glTF form and is dropped, with a note.
OPENPBR_COMPOSITION = Composition(
    name="openpbr", own_lobes=True, params=(BASE_COLOR, SPECULAR_COLOR), lobe=_metal_material,
    hint="OpenPBR Surface's metal: F82-tint Fresnel, GGX",
    gltf=GltfRule(quantities=lambda p: {"f0": p["base_color"], "conductor": True},
                  note="OpenPBR's F82 edge tint (specular_color {specular_color}) has no glTF form: "
                       "dropped (a glTF metal's Fresnel is Schlick's of baseColor)"))


# --- as an open_pbr_surface, 1:1 ------------------------------------------------------

#: parameter -> the open_pbr_surface input (ND_open_pbr_surface_surfaceshader, MaterialX
#: 1.39.5's libraries/bxdf/open_pbr_surface.mtlx) it is, the same value
OPEN_PBR_SURFACE_INPUTS = {"base_color": "base_color", "specular_color": "specular_color",
                           "roughness": "specular_roughness"}
#: the inputs the metal holds (their node defaults are base_weight 1, specular_weight 1,
#: base_metalness 0: written all the same, so the document says what it draws)
OPEN_PBR_SURFACE_HELD = {"base_weight": 1.0, "base_metalness": 1.0, "specular_weight": 1.0}


def open_pbr_surface_inputs(parameters: dict) -> dict:
    """An openpbr+metal fit's parameters ({name: float or [r, g, b]}) as the inputs of
    OpenPBR's open_pbr_surface that draw the same metal: {input: value}, 1:1."""
    out = dict(OPEN_PBR_SURFACE_HELD)
    for name, key in OPEN_PBR_SURFACE_INPUTS.items():
        value = parameters[name]
        out[key] = [float(v) for v in value] if np.ndim(value) else float(value)
    return out
