"""The glTF 2.0 metallic-roughness BRDF, exactly as the specification writes it.

glTF 2.0 specification, Appendix B (BRDF implementation), with the
KHR_materials_ior, KHR_materials_specular, KHR_materials_anisotropy,
KHR_materials_diffuse_roughness (its README leaves the lobe to the viewer: EON,
as three.js r187 and OpenPBR draw it) and KHR_materials_sheen (brdf/sheen.py)
extensions (their current READMEs).
docs/models.md (gltf):

    fresnel_w  = (1 - |v.h|)^5
    f0         = min(F0(ior) specularColor, 1) specular,   f90 = specular
    F          = mix(f0, f90, fresnel_w)                     (RGB)
    dielectric = F D V + (1 - max(F)) baseColor / pi
    metal      = (baseColor + (1 - baseColor) fresnel_w) D V
    material   = mix(dielectric, metal, metallic)

With KHR_materials_diffuse_roughness, baseColor / pi becomes EON's lobe of
albedo baseColor and roughness diffuseRoughnessFactor (brdf.diffuse.eon).
With KHR_materials_sheen, the material is the base of the sheen layer
(brdf.sheen.sheen_layer); a clearcoat lies over both.

``+turquin`` reads the same material as the engines draw it under direct light:
three.js r187 multiplies the specular lobe by Turquin's 1 + F0 (1/E(n.v) - 1),
F0 the blended mix(f0, baseColor, metallic) (``multiScatteringCompensation``
with ``specularColorBlended`` in its lights_fragment_begin chunk; Filament
does the same), and Cycles' multiple-scattering GGX adds a like amount.  Not in
the file (the material is the same): a way to fit and judge it (docs/gltf.md,
"The engines' reading").  The coat is left single-scattering, as three.js draws it.
With the extensions at their defaults (ior 1.5, specular 1, colour 1) the
dielectric reduces to the core mix(baseColor/pi, D V, 0.04 + 0.96 fresnel_w).
The glTF composition and its extensions are declared at the end; each
parameter carries its glTF key, so a fit of this model exports 1:1.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from jaxtyping import Float

from ._lazy import jnp
from .constants import IOR_DEFAULT
from .declare import CORE, Composition, GltfKey, Param, Start, Term
from .diffuse import eon
from .energy import turquin_factor
from .fresnel import f0_from_ior
from .geometry import dot, half_vector, rotate_tangent
from .sheen import SHEEN, sheen_layer
from .specular import (anisotropy_gltf, ggx_ndf, ggx_ndf_aniso,
                       visibility_height_correlated,
                       visibility_height_correlated_aniso)

if TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import Array, ArrayLike


def gltf_specular_dv(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"],
                     roughness: Float[ArrayLike, "*#batch"],
                     anisotropy_strength: Float[ArrayLike, "*#batch"] | None = None,
                     anisotropy_rotation: Float[ArrayLike, "*#batch"] = 0.0) -> Float[Array, "*batch"]:
    """D V of the glTF BRDF (isotropic, or KHR_materials_anisotropy's lobe)."""
    alpha = roughness * roughness
    h = half_vector(wi, wo)
    if anisotropy_strength is None:
        return (ggx_ndf(h[..., 2], alpha)
                * visibility_height_correlated(wi[..., 2], wo[..., 2], alpha))
    alpha_t, alpha_b = anisotropy_gltf(alpha, anisotropy_strength)
    l = rotate_tangent(wi, anisotropy_rotation)
    v = rotate_tangent(wo, anisotropy_rotation)
    hr = rotate_tangent(h, anisotropy_rotation)
    return (ggx_ndf_aniso(hr, alpha_t, alpha_b)
            * visibility_height_correlated_aniso(l, v, alpha_t, alpha_b))


def gltf_combine(dv: Float[ArrayLike, "*batch"], v_dot_h: Float[ArrayLike, "*batch"],
                 base_color: Float[ArrayLike, "*#batch #3"], metallic: Float[ArrayLike, "*#batch"],
                 ior: Float[ArrayLike, "*#batch"] = IOR_DEFAULT, specular: Float[ArrayLike, "*#batch"] = 1.0,
                 specular_color: Float[ArrayLike, "*#batch #3"] = 1.0,
                 diffuse: Float[ArrayLike, "*batch 3"] | None = None,
                 engines: tuple | None = None) -> Float[Array, "*batch 3"]:
    """The glTF material from its specular D V (...) and |v.h| (...) -> RGB (..., 3);
    ``diffuse``: the diffuse lobe of albedo baseColor (None: Lambert's, baseColor / pi);
    ``engines``: (n.v, roughness) for the engines' reading (+turquin): the specular lobe times
    Turquin's factor (brdf.energy.turquin_factor) at the blended F0 mix(f0, baseColor, metallic)."""
    fw = ((1.0 - jnp.clip(jnp.abs(v_dot_h), 0.0, 1.0)) ** 5)[..., None]
    dv = dv[..., None]
    f0 = jnp.minimum(f0_from_ior(ior) * jnp.asarray(specular_color), 1.0) * specular
    if engines is not None:
        blended = base_color if isinstance(metallic, float) and metallic == 1.0 else f0 + (base_color - f0) * metallic
        dv = dv * turquin_factor(*engines, jnp.asarray(blended))
    fresnel = f0 + (specular - f0) * fw
    # max over RGB as pairwise maximum: the gradient of a jnp.max reduction divides
    # by the number of entries equal to the maximum, which under XLA fusion can be 0
    # (NaN gradients seen at n.h = 1 with the roughness floor).
    f_max = fresnel if fresnel.shape[-1] == 1 else jnp.maximum(
        jnp.maximum(fresnel[..., 0:1], fresnel[..., 1:2]), fresnel[..., 2:3])
    diffuse = jnp.asarray(base_color) / jnp.pi if diffuse is None else diffuse
    dielectric = fresnel * dv + (1.0 - f_max) * diffuse
    metal = (base_color + (1.0 - base_color) * fw) * dv
    if isinstance(metallic, float) and metallic == 1.0:     # held (glTF's metal): the mix would cancel
        return jnp.broadcast_to(metal, jnp.broadcast_shapes(metal.shape, dielectric.shape))   # in float32
    return dielectric + (metal - dielectric) * metallic


def gltf_brdf(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"],
              base_color: Float[ArrayLike, "*#batch #3"], metallic: Float[ArrayLike, "*#batch"],
              roughness: Float[ArrayLike, "*#batch"], ior: Float[ArrayLike, "*#batch"] = IOR_DEFAULT,
              specular: Float[ArrayLike, "*#batch"] = 1.0, specular_color: Float[ArrayLike, "*#batch #3"] = 1.0,
              anisotropy_strength: Float[ArrayLike, "*#batch"] | None = None,
              anisotropy_rotation: Float[ArrayLike, "*#batch"] = 0.0,
              diffuse_roughness: Float[ArrayLike, "*#batch"] | None = None,
              sheen_color: Float[ArrayLike, "*#batch #3"] | None = None,
              sheen_roughness: Float[ArrayLike, "*#batch"] = 0.0) -> Float[Array, "*batch 3"]:
    """The glTF BRDF (RGB, 1/sr, without the cosine) for (..., 3) directions."""
    dv = gltf_specular_dv(wi, wo, roughness, anisotropy_strength, anisotropy_rotation)
    h = half_vector(wi, wo)
    f = gltf_combine(dv, dot(wo, h), base_color, metallic, ior, specular, specular_color,
                     _gltf_diffuse(base_color, diffuse_roughness, wi, wo))
    if sheen_color is None:
        return f
    return sheen_layer(f, sheen_color, sheen_roughness, wi[..., 2], wo[..., 2], h[..., 2])


def _gltf_diffuse(base_color: Float[ArrayLike, "*#batch #3"], diffuse_roughness: Float[ArrayLike, "*#batch"] | None,
                 wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"]) -> Float[Array, "*batch 3"] | None:
    """KHR_materials_diffuse_roughness's lobe of albedo baseColor (EON), or None without it (Lambert)."""
    if diffuse_roughness is None:
        return None
    return eon(base_color, diffuse_roughness, wi[..., 2], wo[..., 2], dot(wi, wo))


# --- declarations -------------------------------------------------------------

def _looks_metal(e):
    """Start selection: a metal when the data show almost no diffuse and a bright peak."""
    return bool(np.mean(e.albedo) < 0.05 and np.mean(e.scale) > 0.2)


BASE_COLOR = Param("base_color", 3, 0.0, 1.0, 0.5, "glTF baseColorFactor (linear RGB)",
                   gltf=GltfKey(CORE, "baseColorFactor", 1.0, extra=(1.0,)),
                   start=Start(probe=1.0, rule=lambda e: e.scale if _looks_metal(e)
                               else np.clip(e.albedo / 0.96, 0, 1)))
METALLIC = Param("metallic", 1, 0.0, 1.0, 0.0, "glTF metallicFactor",
                 gltf=GltfKey(CORE, "metallicFactor", 1.0),
                 start=Start(probe=1.0, rule=lambda e: 1.0 if _looks_metal(e) else 0.0))

def _gltf_material(p, g, dv, roughness=None):
    """The glTF composition's BRDF (before the clearcoat): the material, under its sheen layer
    when the parameters have KHR_materials_sheen's; with ``roughness`` (the clamped one), in
    the engines' reading (+turquin: ``gltf_combine``'s ``engines``)."""
    f = gltf_combine(dv, g.v_dot_h, p["base_color"], p["metallic"],
                     ior=p.get("ior", IOR_DEFAULT), specular=p.get("specular", 1.0),
                     specular_color=p.get("specular_color", 1.0),
                     diffuse=_gltf_diffuse(p["base_color"], p.get("diffuse_roughness"), g.wi, g.wo),
                     engines=None if roughness is None else (g.n_dot_v, roughness))
    if "sheen_color" not in p:
        return f
    return sheen_layer(f, p["sheen_color"], p["sheen_roughness"], g.n_dot_l, g.n_dot_v, g.n_dot_h)


# The composition: lobe(params, g, dv) is the whole BRDF (before the clearcoat).
GLTF_COMPOSITION = Composition(
    name="gltf", own_lobes=True, params=(BASE_COLOR, METALLIC), fused=True, lobe=_gltf_material)

GLTF_EXTENSIONS = {
    # Not extensions: the metal and the non-metal (a dielectric) of a portable material,
    # metallic held at 1 or 0 (no partial metal an artist cannot read; docs/gltf.md,
    # "Portable"; 'dielectric' is the exact Fresnel's token).  A metal's Fresnel is its
    # baseColor's: ior, specular, tint and diffuse_roughness do not apply.
    "metal": Term(name="metal", token="metal", fused=True, holds=(("metallic", 1.0),),
                  hint="metallic held at 1: F0 = baseColor, no diffuse"),
    "nonmetal": Term(name="nonmetal", token="nonmetal", fused=True, holds=(("metallic", 0.0),),
                     hint="metallic held at 0: a dielectric"),
    "ior": Term(name="ior", token="ior", fused=True, params=(
        Param("ior", 1, 1.0, 3.0, IOR_DEFAULT, "KHR_materials_ior index of refraction",
              gltf=GltfKey("KHR_materials_ior", "ior", IOR_DEFAULT)),)),
    "specular": Term(name="specular", token="specular", fused=True, params=(
        Param("specular", 1, 0.0, 1.0, 1.0, "KHR_materials_specular specularFactor",
              gltf=GltfKey("KHR_materials_specular", "specularFactor", 1.0), neutral=1.0),
        Param("specular_color", 3, 0.0, 10.0, 1.0, "KHR_materials_specular specularColorFactor (may exceed 1)",
              gltf=GltfKey("KHR_materials_specular", "specularColorFactor", 1.0), neutral=1.0))),
    # KHR_materials_specular's colour alone, a colour in [0, 1], its factor held at 1: F0 =
    # F0(ior) specularColor below F90 = 1, the Fresnel every engine draws alike (Blender's
    # importer keeps F90 = 1 whatever specularFactor says): a portable material's Fresnel.
    "tint": Term(name="tint", token="tint", fused=True, params=(
        # (the start inside the range: at its bound 1 the bounded transform's slope is ~0)
        Param("specular_color", 3, 0.0, 1.0, 0.5,
              "KHR_materials_specular specularColorFactor, a colour (specularFactor 1: F90 = 1)",
              gltf=GltfKey("KHR_materials_specular", "specularColorFactor", 1.0)),)),
    # Not fused (EON is not linear in baseColor: fitting.fused's sums do not cover it) and
    # without a neutral value, so the family roots of the other glTF models stay as they were.
    "diffuse_roughness": Term(name="diffuse_roughness", token="diffuse_roughness", params=(
        Param("diffuse_roughness", 1, 0.0, 1.0, 0.5,
              "KHR_materials_diffuse_roughness diffuseRoughnessFactor (EON's roughness)",
              gltf=GltfKey("KHR_materials_diffuse_roughness", "diffuseRoughnessFactor", 0.0)),)),
    "sheen": SHEEN,        # brdf/sheen.py: not fused, no neutral value (as diffuse_roughness)
}
