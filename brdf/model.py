"""Evaluation of a ModelSpec: the one dispatch section over the declared terms.

``evaluate(spec, params, wi, wo)`` composes the terms a ModelSpec names
(brdf/spec.py) from their declarations: each Term's ``lobe`` has its field's
signature, so this file names no option.

    ndf          lobe(n_dot_h, alpha) or, anisotropic, lobe(h_rotated, alpha_t, alpha_b)
                 (a Lobe, brdf/lobes.py: lobe(params, g, alpha) -> the whole specular term);
                 smith_lambda(n_dot_v, alpha) or (v_rotated, alpha_t, alpha_b); visibility:
                 closed forms of V per masking (GGX's), used when present
    masking      combine(Lambda(l), Lambda(v)) -> G (Smith, with the NDF's Lambda) or
                 geometric(n_dot_l, n_dot_v, n_dot_h, v_dot_h) -> G (V-groove)
    anisotropy   remap(alpha, anisotropy) -> (alpha_t, alpha_b)
    fresnel      lobe(params, v_dot_h) -> (F, F0)
    energy       lobe(f_ss, g, roughness, F0) -> f        (None: no compensation)
    diffuse      lobe(params, g, roughness, alpha) -> f_d (None: no diffuse lobe)
    composition  weights_diffuse: f_d (1 - F); own_lobes: lobe(params, g, D V) -> f
    clearcoat    lobe(f, params, g) -> coated f

ModelSpec, the model strings and the schema are defined in brdf.spec and
importable from here.
"""

from __future__ import annotations

import typing
from types import ModuleType

from jaxtyping import Float

from ._lazy import jax, jnp
from .clearcoat import CLEARCOAT
from .geometry import clamp_cos, dot, half_vector, rotate_tangent
from .spec import (ANISOTROPY_REMAPS, COMPOSITIONS, DIFFUSES, ENERGIES, FIELDS,  # noqa: F401 (re-exported)
                   FRESNELS, GLTF_EXTENSIONS, MASKINGS, MODEL_EXAMPLES, NDFS, ModelSpec,
                   UnknownModelError, all_terms, check_params, default_params,
                   held_values, model_string, parameter_schema, parse_model, terms)
from .spec import _diffuse_tokens, _gltf_tokens, _option_tokens   # the model-string vocabulary
from .openpbr_coat import OPENPBR_TOKENS
from .principled import PRINCIPLED_TOKENS
from .constants import ALPHA_MIN, ROUGHNESS_MIN
from .declare import Param  # noqa: F401 (re-exported)

if typing.TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import Array, ArrayLike

# A model family's program (fitting/family.py) takes the diffuse model as a
# runtime input, passed among the parameters:
DIFFUSE_SWITCH = "diffuse_index"   # int: which of SWITCH_DIFFUSES is the diffuse lobe
ENERGY_SWITCH = "energy_on"        # 1.0: the spec's energy compensation applied, 0.0: left out
SWITCHES = (DIFFUSE_SWITCH, ENERGY_SWITCH)
# the diffuse lobes of the albedo x factor form (one parameter set: interchangeable)
SWITCH_DIFFUSES = tuple(name for name, term in DIFFUSES.items() if term.fused and term.lobe is not None)


class Geometry(typing.NamedTuple):
    """A batch of direction pairs and the cosines every term reads.

    Computing it once per data set (it does not depend on the parameters)
    lets a fit evaluate isotropic models from four contiguous arrays.
    """
    wi: Array         # (..., 3)
    wo: Array         # (..., 3)
    h: Array          # (..., 3) half vector
    n_dot_l: Array    # (...)
    n_dot_v: Array
    n_dot_h: Array
    v_dot_h: Array    # = l.h

    def reversed(self) -> "Geometry":
        """The same pairs with wi and wo exchanged."""
        return Geometry(self.wo, self.wi, self.h, self.n_dot_v, self.n_dot_l,
                        self.n_dot_h, self.v_dot_h)


def geometry(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"]) -> Geometry:
    """Geometry of (..., 3) direction pairs (local frame, pointing away)."""
    h = half_vector(wi, wo)
    return Geometry(wi, wo, h, wi[..., 2], wo[..., 2], h[..., 2], dot(wo, h))


def roughness_alpha(roughness: Float[ArrayLike, "*#batch"],
                    xp: ModuleType = jnp) -> tuple[Float[ArrayLike, "*#batch"], Float[ArrayLike, "*#batch"]]:
    """(roughness clamped to [ROUGHNESS_MIN, 1], alpha = roughness^2 floored at ALPHA_MIN).

    ``xp``: jax.numpy in the model, numpy where the glTF conversion needs float64.
    """
    roughness = xp.clip(roughness, ROUGHNESS_MIN, 1.0)
    return roughness, xp.maximum(roughness * roughness, ALPHA_MIN)


def visibility(spec: ModelSpec, g: Geometry, l: Float[ArrayLike, "*batch ..."], v: Float[ArrayLike, "*batch ..."],
               *alphas: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """V = G / (4 n.l n.v) of the spec's masking paired with its NDF: the NDF's closed
    form for that masking if it declares one (GGX), else the masking's G of the NDF's
    own Lambdas at ``l``, ``v`` (n.l, n.v, or the rotated vectors of an anisotropic
    NDF), or of the geometry alone (V-groove)."""
    ndf, masking = NDFS[spec.ndf], MASKINGS[spec.masking]
    closed = dict(ndf.visibility).get(spec.masking)
    if closed is not None:
        return closed(l, v, *alphas)
    if masking.combine is not None:
        g2 = masking.combine(ndf.smith_lambda(l, *alphas), ndf.smith_lambda(v, *alphas))
    else:
        g2 = masking.geometric(g.n_dot_l, g.n_dot_v, g.n_dot_h, g.v_dot_h)
    return g2 / (4.0 * clamp_cos(g.n_dot_l) * clamp_cos(g.n_dot_v))


def specular_dv(spec: ModelSpec, params: dict[str, Float[ArrayLike, "*#channels"]], g: Geometry,
                alpha: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """D V of the specular lobe (isotropic or anisotropic, any masking)."""
    ndf = NDFS[spec.ndf]
    if not ndf.anisotropic:
        return ndf.lobe(g.n_dot_h, alpha) * visibility(spec, g, g.n_dot_l, g.n_dot_v, alpha)
    alpha_t, alpha_b = ANISOTROPY_REMAPS[spec.anisotropy].remap(alpha, params["anisotropy"])
    l, v, hr = (rotate_tangent(x, params["rotation"]) for x in (g.wi, g.wo, g.h))
    return ndf.lobe(hr, alpha_t, alpha_b) * visibility(spec, g, l, v, alpha_t, alpha_b)


def has_diffuse(spec: ModelSpec) -> bool:
    """True when the spec's diffuse term has a lobe (not "none")."""
    return DIFFUSES[spec.diffuse].lobe is not None


def diffuse_lobe(spec: ModelSpec, params: dict[str, Float[ArrayLike, "*#channels"]], g: Geometry,
                 roughness: Float[ArrayLike, "*#batch"],
                 alpha: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch 3"]:
    """The spec's diffuse lobe (RGB); ``has_diffuse(spec)`` must hold.  With
    ``params[DIFFUSE_SWITCH]`` (a family's program), that entry of SWITCH_DIFFUSES."""
    if DIFFUSE_SWITCH in params:
        return jax.lax.switch(params[DIFFUSE_SWITCH], [DIFFUSES[name].lobe for name in SWITCH_DIFFUSES],
                              params, g, roughness, alpha)
    return DIFFUSES[spec.diffuse].lobe(params, g, roughness, alpha)


def energy_switched(params: dict[str, Float[ArrayLike, "*#channels"]], compensated: Float[ArrayLike, "*batch"],
                    without: Float[ArrayLike, "*batch"]) -> Float[Array, "*batch"]:
    """``compensated``, or ``without`` where ``params[ENERGY_SWITCH]`` (a family's program)
    switches the compensation off."""
    if ENERGY_SWITCH not in params:
        return compensated
    return jnp.where(params[ENERGY_SWITCH] > 0, compensated, without)


def evaluate(spec: ModelSpec | str, params: dict[str, Float[ArrayLike, "*#channels"]], wi: Float[ArrayLike, "*batch 3"],
             wo: Float[ArrayLike, "*batch 3"]) -> Float[Array, "*batch 3"]:
    """The BRDF of ``spec`` (RGB, 1/sr, without the cosine) at (..., 3) direction pairs.

    ``params`` maps every schema name to an array (shape () or (3,)).  Pairs
    with either direction at or below the horizon give 0.
    """
    return evaluate_geometry(parse_model(spec), params, geometry(wi, wo))


def evaluate_geometry(spec: ModelSpec, params: dict[str, Float[ArrayLike, "*#channels"]],
                      g: Geometry) -> Float[Array, "*batch 3"]:
    """``evaluate`` on a precomputed Geometry (the fitter's fast path)."""
    above = (g.n_dot_l > 0.0) & (g.n_dot_v > 0.0)
    if spec.own is not None:     # a model of one's own (brdf/own.py): its function is the BRDF
        return jnp.where(above[..., None], spec.own.evaluate(params, g.wi, g.wo), 0.0)
    params = {**held_values(spec), **params}     # glTF's metal and nonmetal: metallic held
    roughness, alpha = roughness_alpha(params["roughness"])
    composition = COMPOSITIONS[spec.composition]
    if spec.lobe_model:          # a classic lobe: its own specular term (brdf/lobes.py)
        if spec.anisotropic:
            alpha_t, alpha_b = ANISOTROPY_REMAPS[spec.anisotropy].remap(alpha, params["anisotropy"])
            f = NDFS[spec.ndf].lobe(params, g, alpha_t, alpha_b, rotate_tangent(g.h, params["rotation"]))
        else:
            f = NDFS[spec.ndf].lobe(params, g, alpha)
        if has_diffuse(spec):
            f = f + diffuse_lobe(spec, params, g, roughness, alpha)
    elif composition.own_lobes:      # (its energy compensation inside: glTF's +turquin, brdf/gltf.py)
        dv = specular_dv(spec, params, g, alpha)
        f = composition.lobe(params, g, dv) if spec.energy == "none" else composition.lobe(params, g, dv, roughness)
    else:
        dv = specular_dv(spec, params, g, alpha)
        fresnel, f0 = FRESNELS[spec.fresnel].lobe(params, g.v_dot_h)
        f = dv[..., None] * fresnel
        energy = ENERGIES[spec.energy]
        if energy.lobe is not None:
            f = energy_switched(params, energy.lobe(f, g, roughness, f0), f)
        if has_diffuse(spec):
            fd = diffuse_lobe(spec, params, g, roughness, alpha)
            f = f + (fd * (1.0 - fresnel) if composition.weights_diffuse else fd)
    if spec.clearcoat:
        f = CLEARCOAT.lobe(f, params, g)
    return jnp.where(above[..., None], f, 0.0)


# --- the model-string vocabulary, as text ---------------------------------------------

def _with_hint(token, term):
    return f"{token} ({term.hint})" if term.hint else token


def describe_tokens() -> str:
    """Text listing every token a model string may contain (``brdf-fit models``; here, not in
    brdf/spec.py beside the parsing, to keep that module short)."""
    options = []
    for tok, (field, value) in _option_tokens().items():
        options.append(_with_hint(tok, CLEARCOAT if field == "clearcoat" else FIELDS[field][value]))
    return "\n".join([
        "first token: " + " | ".join(list(NDFS) + ["gltf", "openpbr", "principled"]),
        "diffuse (after an NDF): " + " | ".join(_diffuse_tokens())
        + f" (none: {DIFFUSES['none'].hint})",
        "options (after an NDF): " + " | ".join(options),
        "options (gltf): " + " | ".join(_gltf_tokens()),
        "options (openpbr): " + " | ".join(OPENPBR_TOKENS) + " (the base, required: metal or nonmetal; coat; "
        "mx: MaterialX's GGX energy compensation)",
        "options (principled): " + " | ".join(PRINCIPLED_TOKENS) + " (the base, required: metal or nonmetal; sheen; "
        "coat; ms: Multiscatter GGX; Blender's Principled BSDF as Cycles draws it)",
    ])
