"""Clearcoat layer as KHR_materials_clearcoat specifies it.

coated = mix(base, coat_brdf, clearcoat * Fc) with
Fc = 0.04 + 0.96 (1 - |n_c . v|)^5 (coat IOR 1.5, Fresnel at the coat
normal's n.v, the extension README's implementation section) and
coat_brdf = D V of GGX with height-correlated Smith at alpha_c =
clearcoatRoughness^2, no Fresnel inside.  docs/models.md#clearcoat-layer.

The layering uses n.v only, so a coated BRDF is not reciprocal; that is the
specification's choice, kept here so that a fit exports to glTF losslessly.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from jaxtyping import Float

from ._lazy import jnp
from .constants import F0_DIELECTRIC, ROUGHNESS_MIN
from .declare import GltfKey, Param, Term
from .specular import ggx_ndf, visibility_height_correlated

if TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import Array, ArrayLike


def clearcoat_fresnel(n_dot_v: Float[ArrayLike, "*batch"]) -> Float[Array, "*batch"]:
    """Fc = 0.04 + 0.96 (1 - |n.v|)^5."""
    x = 1.0 - jnp.clip(jnp.abs(n_dot_v), 0.0, 1.0)
    x2 = x * x
    return F0_DIELECTRIC + (1.0 - F0_DIELECTRIC) * x2 * x2 * x


def clearcoat_brdf(n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
                   n_dot_h: Float[ArrayLike, "*batch"],
                   coat_roughness: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """The coat's own lobe D V (1/sr), alpha_c = coat_roughness^2."""
    alpha = coat_roughness * coat_roughness
    return ggx_ndf(n_dot_h, alpha) * visibility_height_correlated(n_dot_l, n_dot_v, alpha)


def apply_clearcoat(base: Float[ArrayLike, "*#batch #3"], clearcoat: Float[ArrayLike, "*#batch"],
                    coat_roughness: Float[ArrayLike, "*#batch"], n_dot_l: Float[ArrayLike, "*batch"],
                    n_dot_v: Float[ArrayLike, "*batch"],
                    n_dot_h: Float[ArrayLike, "*batch"]) -> Float[Array, "*batch 3"]:
    """mix(base, coat_brdf, clearcoat * Fc) for an RGB ``base`` (..., 3)."""
    weight = clearcoat * clearcoat_fresnel(n_dot_v)
    coat = clearcoat_brdf(n_dot_l, n_dot_v, n_dot_h, coat_roughness)
    return base * (1.0 - weight)[..., None] + (weight * coat)[..., None]


# --- declaration ----------------------------------------------------------------
# lobe(base, params, g) -> the coated BRDF.  The parameters are the extension's
# own, so the layer exports 1:1.  Start variants: the coat is a second lobe, so
# the fit tries it off, sharp (a core over a wide base) and wide (a halo under
# a sharp base); from clearcoat = 0 alone the sigmoid's flat tail would keep it off.
# A full coat from a start is dropped where the data wants a weak one (white-paint:
# every start ends coat-less, M1 0.0101), so the best optimum is tried once more with
# a weak, broad coat (``reseed``; white-paint: coat 0.08 at roughness 0.20, M1 0.0097).

_KHR = "KHR_materials_clearcoat"
CLEARCOAT = Term(
    name="clearcoat", token="clearcoat", fused=True, reciprocal=False,     # Fc at n.v
    params=(Param("clearcoat", 1, 0.0, 1.0, 0.0, "clearcoat layer weight (KHR_materials_clearcoat)",
                  gltf=GltfKey(_KHR, "clearcoatFactor", 0.0)),
            Param("clearcoat_roughness", 1, ROUGHNESS_MIN, 1.0, 0.1, "perceptual roughness of the coat",
                  gltf=GltfKey(_KHR, "clearcoatRoughnessFactor", 0.0))),
    lobe=lambda base, p, g: apply_clearcoat(base, p["clearcoat"], p["clearcoat_roughness"],
                                            g.n_dot_l, g.n_dot_v, g.n_dot_h),
    variants=(("clearcoat", "clearcoat_roughness"), ((0.0, 0.1), (1.0, 0.05), (1.0, 0.15), (1.0, 0.4))),
    reseed=(0.1, 0.2))
