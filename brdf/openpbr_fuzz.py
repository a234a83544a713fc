"""OpenPBR Surface's fuzz over its non-metal (issue 61): ``openpbr+nonmetal+fuzz``, the
microfibre layer of fabrics (velvet, satin, felt) and dust.

Read in the MaterialX python package 1.39.5 (``pip install materialx``):

    MaterialX/libraries/bxdf/open_pbr_surface.mtlx        fuzz_bsdf (a sheen_bsdf, mode zeltner,
                                                          weight fuzz_weight, color fuzz_color,
                                                          roughness fuzz_roughness), fuzz_layer
                                                          (layer: top fuzz_bsdf over the rest)
    MaterialX/libraries/pbrlib/genglsl/mx_sheen_bsdf.glsl  response dirAlbedo fr weight,
                                                           throughput 1 - dirAlbedo weight
    MaterialX/libraries/pbrlib/genglsl/lib/mx_microfacet_sheen.glsl
                                  mx_zeltner_sheen_dir_albedo, mx_zeltner_sheen_ltc_aInv / _bInv,
                                  mx_orthonormal_basis_ltc, mx_zeltner_sheen_brdf
    MaterialX/libraries/pbrlib/genglsl/mx_layer_bsdf.glsl  top + base x top's throughput

The lobe is Zeltner et al. 2022's sheen ("Practical Multiple-Scattering Sheen Using Linearly
Transformed Cosines"): a clamped cosine D_o(w) = max(w_z, 0) / pi transformed by the inverse
matrix M^-1 = [[a, 0, b], [0, a, 0], [0, 0, 1]] in the frame whose x axis is the view's
projection on the surface (X = normalise(v - n (n.v)), Y = n x X); a and b are MaterialX's
rational fits in (n.v, r), r = fuzz_roughness clamped to [0.01, 1] (the original's range).
With w = (X.l, Y.l, n.l) and w' = M^-1 w:

    D(l)     = D_o(w') a^2 / |w'|^4                    (the LTC's density; it integrates to 1)
    E(n.v)   = MaterialX's Gaussian fit of the lobe's directional albedo (mx_zeltner_sheen_dir_albedo),
               clamped at 0 here (it dips to -2e-5 at low roughness and a high n.v; MaterialX leaves it)
    f_fuzz   = fuzz_weight fuzz_color E D(l) / n.l = fuzz_weight fuzz_color E a^2 / (pi |w'|^4)
    f        = f_fuzz + (1 - fuzz_weight E(n.v)) f_nonmetal          (the layer; 1 - w E at the view)

so the fuzz's own albedo is fuzz_weight fuzz_color E, and what it takes from the base below is
fuzz_weight E: grey, whatever fuzz_color (the graph's throughput).  n.v is clamped to
[1e-8, 1] (M_FLOAT_EPS) first.  f_nonmetal is brdf/openpbr.py's non-metal; ``mx`` is MaterialX's
reading of it (its GGX energy compensation, brdf/openpbr_coat.py); the fuzz has no
compensation of its own.  The layer weighs the base by the view direction's E: not reciprocal.

The model strings: ``openpbr+nonmetal+fuzz`` and ``openpbr+nonmetal+fuzz+mx`` (compositions
"openpbr_nonmetal_fuzz", "openpbr_nonmetal_fuzz_mx"), written 1:1 as open_pbr_surface's
fuzz_weight, fuzz_color and fuzz_roughness.  Not over the coat or the metal (fabrics are
neither); not Blender's Principled sheen, which Cycles draws from its own table of the same
lobe (bsdf_sheen.h), not from these fits.  docs/models.md (openpbr).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from jaxtyping import Float

from ._lazy import jnp
from .constants import INV_PI, ROUGHNESS_MIN
from .declare import Composition, GltfRule, Param, Start
from .openpbr import BASE_COMPOSITIONS, _nonmetal_material, openpbr_nonmetal

if TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import Array, ArrayLike

#: MaterialX's M_FLOAT_EPS: mx_sheen_bsdf clamps n.v to [M_FLOAT_EPS, 1]
N_DOT_V_MIN = 1e-8
#: mx_sheen_bsdf clamps the roughness to [0.01, 1] ("the range of the original implementation")
FUZZ_ROUGHNESS_MIN = 0.01


def zeltner_dir_albedo(n_dot_v: Float[ArrayLike, "*batch"],
                       roughness: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """mx_zeltner_sheen_dir_albedo: the sheen lobe's directional albedo, a Gaussian in n.v fitted per roughness."""
    x, y = n_dot_v, roughness
    s = y * (0.0206607 + 1.58491 * y) / (0.0379424 + y * (1.32227 + y))
    m = y * (-0.193854 + y * (-1.14885 + y * (1.7932 - 0.95943 * y * y))) / (0.046391 + y)
    o = y * (0.000654023 + (-0.0207818 + 0.119681 * y) * y) / (1.26264 + y * (-1.92021 + y))
    return jnp.exp(-0.5 * ((x - m) / s) ** 2) / (s * math.sqrt(2.0 * math.pi)) + o


def zeltner_ltc(n_dot_v: Float[ArrayLike, "*batch"],
                roughness: Float[ArrayLike, "*#batch"]) -> tuple[Float[Array, "*batch"], Float[Array, "*batch"]]:
    """(a, b) of the inverse LTC matrix: mx_zeltner_sheen_ltc_aInv and _bInv."""
    x, y = n_dot_v, roughness
    a = (2.58126 * x + 0.813703 * y) * y / (1.0 + 0.310327 * x * x + 2.60994 * x * y)
    b = jnp.sqrt(1.0 - x) * (y - 1.0) * y * y * y / (0.0000254053 + 1.71228 * x - 1.71506 * x * y + 1.34174 * y * y)
    return a, b


def zeltner_density(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"],
                    n_dot_v: Float[ArrayLike, "*batch"],
                    roughness: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """D(l) / n.l (the module's docstring): a^2 / (pi |M^-1 w|^4), 0 where n.l <= 0; ``wo`` the view,
    ``n_dot_v`` its clamped cosine, ``roughness`` clamped already.  Where the view is the normal
    any frame serves (b = 0 there: the lobe is round), x along +x here."""
    wi, wo = jnp.asarray(wi), jnp.asarray(wo)
    across = wo[..., 0] ** 2 + wo[..., 1] ** 2
    inv = jnp.where(across > 0.0, 1.0 / jnp.sqrt(jnp.where(across > 0.0, across, 1.0)), 0.0)
    xx, xy = jnp.where(across > 0.0, wo[..., 0] * inv, 1.0), wo[..., 1] * inv     # X
    wx = xx * wi[..., 0] + xy * wi[..., 1]          # X.l
    wy = xx * wi[..., 1] - xy * wi[..., 0]          # (n x X).l
    a, b = zeltner_ltc(n_dot_v, roughness)
    tx, ty, tz = a * wx + b * wi[..., 2], a * wy, wi[..., 2]
    length2 = tx * tx + ty * ty + tz * tz
    q = a / length2
    return jnp.where(wi[..., 2] > 0.0, q * q * INV_PI, 0.0)


def fuzz_layer(below: Float[ArrayLike, "*batch 3"], wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"],
               fuzz_weight: Float[ArrayLike, "*#batch"], fuzz_color: Float[ArrayLike, "*#batch #3"],
               fuzz_roughness: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch 3"]:
    """The fuzz over the BRDF ``below`` (RGB): f_fuzz + (1 - fuzz_weight E(n.v)) below (the module's docstring)."""
    n_dot_v = jnp.clip(jnp.asarray(wo)[..., 2], N_DOT_V_MIN, 1.0)
    r = jnp.clip(fuzz_roughness, FUZZ_ROUGHNESS_MIN, 1.0)
    albedo = fuzz_weight * jnp.maximum(zeltner_dir_albedo(n_dot_v, r), 0.0)
    top = (albedo * zeltner_density(wi, wo, n_dot_v, r))[..., None] * jnp.asarray(fuzz_color)
    return top + (1.0 - albedo)[..., None] * below


def openpbr_nonmetal_fuzz(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"],
                          base_color: Float[ArrayLike, "*#batch #3"], specular_ior: Float[ArrayLike, "*#batch"],
                          roughness: Float[ArrayLike, "*#batch"], diffuse_roughness: Float[ArrayLike, "*#batch"],
                          fuzz_weight: Float[ArrayLike, "*#batch"], fuzz_color: Float[ArrayLike, "*#batch #3"],
                          fuzz_roughness: Float[ArrayLike, "*#batch"], mx: bool = False) -> Float[Array, "*batch 3"]:
    """OpenPBR's non-metal under its fuzz (RGB, 1/sr, without the cosine; ``wo`` the view direction;
    ``mx``: the non-metal with MaterialX's comp)."""
    below = openpbr_nonmetal(wi, wo, base_color, specular_ior, roughness, diffuse_roughness, mx)
    return fuzz_layer(below, wi, wo, fuzz_weight, fuzz_color, fuzz_roughness)


# --- declarations -------------------------------------------------------------

def _nonmetal_fuzz_material(p, g, dv, mx=False):
    """The openpbr_nonmetal_fuzz composition's BRDF from the model's D V (``mx``: _mx's)."""
    return fuzz_layer(_nonmetal_material(p, g, dv, mx), g.wi, g.wo, p["fuzz_weight"], p["fuzz_color"],
                      p["fuzz_roughness"])


# The peak probe sees the bare non-metal (fuzz_weight 0), so the base's start rules read it as
# they do bare; the fit then starts the fuzz at half weight, colour 0.8 (inside its range: at its
# bound 1 the bounded transform's slope is ~0), of a medium or a high roughness (FUZZ_VARIANTS:
# fabrics' sheen is broad).
FUZZ_PARAMS = (
    Param("fuzz_weight", 1, 0.0, 1.0, 0.5, "OpenPBR fuzz_weight: the fuzz layer's presence",
          start=Start(probe=0.0)),
    Param("fuzz_color", 3, 0.0, 1.0, 1.0, "OpenPBR fuzz_color: the fuzz's colour (linear RGB)",
          start=Start(rule=lambda e: np.full(3, 0.8))),
    Param("fuzz_roughness", 1, ROUGHNESS_MIN, 1.0, 0.5,
          "OpenPBR fuzz_roughness: the fuzz's roughness (Zeltner's sheen; from ROUGHNESS_MIN as every roughness)"),
)
FUZZ_VARIANTS = (("fuzz_weight", "fuzz_roughness"), ((0.5, 0.4), (0.5, 0.8)))

_NONMETAL = BASE_COMPOSITIONS["openpbr_nonmetal"]
FUZZ_COMPOSITIONS = {
    "openpbr_nonmetal_fuzz": Composition(
        name="openpbr_nonmetal_fuzz", own_lobes=True, params=_NONMETAL.params + FUZZ_PARAMS,
        lobe=_nonmetal_fuzz_material, hint="OpenPBR Surface's dielectric base under its fuzz (Zeltner's sheen)",
        variants=FUZZ_VARIANTS, reciprocal=False,        # the base under 1 - w E at n.v
        gltf=GltfRule(quantities=_NONMETAL.gltf.quantities,
                      note=_NONMETAL.gltf.note + "; the fuzz (weight {fuzz_weight:.3g}, roughness "
                           "{fuzz_roughness:.3g}) is dropped: KHR_materials_sheen draws another lobe (Charlie's)")),
}
#: the fuzz's open_pbr_surface inputs, 1:1 (brdf/openpbr_coat.py's registry)
FUZZ_INPUTS = {"fuzz_weight": "fuzz_weight", "fuzz_color": "fuzz_color", "fuzz_roughness": "fuzz_roughness"}
