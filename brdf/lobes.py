"""The classic lobe models: Blinn-Phong, modified Phong, Ward, Ward-Duer, Ashikhmin-Shirley, Lafortune.

Each is a whole specular term -- no microfacet masking, no Fresnel term --
declared in the NDF's place (``Lobe``), so ``blinn_phong+lambert`` is
rho_d / pi + its lobe.  Every lobe keeps the toolkit's ``roughness`` r
(alpha = r^2, the same floor) as its width, and a ``specular_albedo`` rho_s
(RGB) as its scale:

    Blinn-Phong (Blinn 1977), the normalised half-vector lobe in NDF form:
        rho_s (n + 2) / (2 pi) (n.h)^n           integral (n+2)/(2pi) (n.h)^n (n.h) dw_h = 1
    modified Phong (Lafortune & Willems 1994), the mirror lobe, r = 2 (n.wi) n - wi:
        rho_s (n + 2) / (2 pi) max(0, r.wo)^n     energy-conserving for rho_d + rho_s <= 1
    the same two lobes with the microfacet factor (blinn_phong_mf, phong_mf), the lobe read as
    an NDF D in D / (4 (wi.h) max(n.wi, n.wo)), Ashikhmin & Shirley 2000's denominator:
        rho_s (n + 2) / (2 pi) max(0, c)^n / (4 (wi.h) max(n.wi, n.wo)),   c = n.h or r.wo
    (the normalisation unchanged, so each differs from its bare lobe by the factor alone;
    rho_s reads as a microfacet F0: rho_s D / 4 at wi = wo = n)
    Ward (Ward 1992), isotropic (ward) and anisotropic (ward_aniso: alpha_t, alpha_b
    from the anisotropy remap, in the frame turned by ``rotation``, as ggx_aniso's):
        rho_s exp(-tan^2 theta_h / alpha^2) / (4 pi alpha^2 sqrt((n.wi)(n.wo)))
        rho_s exp(-tan^2 theta_h (cos^2 phi_h / at^2 + sin^2 phi_h / ab^2)) / (4 pi at ab sqrt(...))
    Ward-Duer (Duer 2006): the same over (n.wi)(n.wo) instead of its square root
    (ward_duer, ward_duer_aniso).
    Ashikhmin-Shirley (2000), isotropic (n_u = n_v = n), with Schlick F of R_s = rho_s:
        (n + 1) / (8 pi) (n.h)^n / ((h.wi) max(n.wi, n.wo)) F(wi.h)
    Lafortune (Lafortune et al. 1997, eq. 4), one isotropic generalised cosine lobe
    with Ngan et al. 2005's normalisation (bbm's NganLafortune):
        rho_s (n + 2) / (2 pi) max(0, (Cxy (wi_x wo_x + wi_y wo_y) + Cz wi_z wo_z) / m)^n,
        m = max(|Cxy|, |Cz|), C a unit vector: Cxy = -sqrt((1 - Cz^2) / 2) <= 0 <= Cz
    (a forward lobe; ``lafortune_cz`` is the one shape parameter: Cz = 1/sqrt(3) is the
    modified Phong lobe, Cz -> 0 bends it to grazing).  The scale of C cancels in the
    normalisation, so the unit C loses nothing of the published form.

The Phong exponent is n = 2 / alpha^2 - 2, Walter et al. 2007's correspondence
of the Phong and Beckmann distributions (eq. 33), so a lobe's roughness reads as
a Beckmann / GGX roughness of about the same peak width; Ward's alpha is the
rms slope, alpha itself.  Formulas restated in docs/models.md ("Lobe models").
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from jaxtyping import Float

from ._lazy import jnp
from .beckmann import NDF_COS_MIN, beckmann_ndf, beckmann_ndf_aniso
from .constants import ALPHA_MIN, INV_PI, ROUGHNESS_MIN
from .declare import GltfRule, Lobe, Param, Start
from .fresnel import fresnel_schlick
from .geometry import clamp_cos, dot
from .specular import ROUGHNESS

if TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import Array, ArrayLike

# log c by its atanh series above this cosine (log_cosine)
LOG_SERIES_MIN = 0.9
THIRD, FIFTH, SEVENTH = 1.0 / 3.0, 1.0 / 5.0, 1.0 / 7.0
# (1 - Cz^2) / 2 below this reads as this under Lafortune's square root (a finite gradient at Cz = 1)
LAFORTUNE_SQUARE_MIN = 1e-12
# Cz of the unit C whose lobe is the mirror lobe (Cxy = -Cz)
LAFORTUNE_MIRROR_CZ = 0.57735026918962576
# h's tangential sin^2 below this: h is the normal, where anisotropic Ashikhmin-Shirley's
# exponent has no direction (its (n.h)^e is 1 whatever e): the mean exponent is taken
AS_SIN2_MIN = 1e-12


def phong_exponent(alpha: Float[ArrayLike, "*#batch"]) -> Float[Array, "*#batch"]:
    """Walter et al. 2007 eq. 33: the Phong exponent of Beckmann's alpha, n = 2 / alpha^2 - 2."""
    a = jnp.maximum(alpha, ALPHA_MIN)
    return 2.0 / (a * a) - 2.0


def log_cosine(c: Float[ArrayLike, "*batch"]) -> Float[Array, "*batch"]:
    """log c for c > 0.  Above LOG_SERIES_MIN as 2 atanh(u) = 2 u (1 + u^2/3 + u^4/5 + u^6/7),
    u = (c - 1)/(c + 1) (truncation < 1e-11 relative): accurate near c = 1, where an
    exponent of up to 2e6 multiplies it, and computed by the same operations in GLSL."""
    u = (c - 1.0) / (c + 1.0)
    u2 = u * u
    series = 2.0 * u * (1.0 + u2 * (THIRD + u2 * (FIFTH + u2 * SEVENTH)))
    return jnp.where(c > LOG_SERIES_MIN, series, jnp.log(jnp.where(c > LOG_SERIES_MIN, 1.0, c)))


def cosine_power(c: Float[ArrayLike, "*batch"], exponent: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """max(0, c)^n as exp(n log c), 0 for c <= 0 (the log's argument kept finite for the gradient)."""
    up = c > 0.0
    safe = jnp.where(up, c, 1.0)
    return jnp.where(up, jnp.exp(exponent * log_cosine(safe)), 0.0)


def blinn_phong(n_dot_h: Float[ArrayLike, "*batch"], exponent: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Normalised Blinn-Phong lobe (NDF form): (n + 2) / (2 pi) max(0, n.h)^n."""
    return (exponent + 2.0) * (0.5 * INV_PI) * cosine_power(n_dot_h, exponent)


def mirror_cosine(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"]) -> Float[Array, "*batch"]:
    """r.wo with r = 2 (n.wi) n - wi, the mirror of wi: 2 (n.wi)(n.wo) - wi.wo."""
    return 2.0 * wi[..., 2] * wo[..., 2] - dot(wi, wo)


def phong_modified(r_dot_v: Float[ArrayLike, "*batch"],
                   exponent: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Modified Phong (Lafortune & Willems 1994): (n + 2) / (2 pi) max(0, r.wo)^n."""
    return (exponent + 2.0) * (0.5 * INV_PI) * cosine_power(r_dot_v, exponent)


def microfacet_factor(v_dot_h: Float[ArrayLike, "*batch"], n_dot_l: Float[ArrayLike, "*batch"],
                      n_dot_v: Float[ArrayLike, "*batch"]) -> Float[Array, "*batch"]:
    """1 / (4 (wi.h) max(n.wi, n.wo)): the microfacet BRDF's factor of an NDF, with Ashikhmin &
    Shirley 2000's max(n.wi, n.wo) for (n.wi)(n.wo) / G (cosines floored by clamp_cos)."""
    return 0.25 / (clamp_cos(v_dot_h) * jnp.maximum(clamp_cos(n_dot_l), clamp_cos(n_dot_v)))


def _ward_exp(n_dot_h, alpha):
    """exp(-tan^2 theta_h / alpha^2) / (4 pi alpha^2), 0 for n.h <= 0: Beckmann's D
    (brdf/beckmann.py, n.h floored alike) times cos^4 theta_h / 4."""
    c2 = jnp.square(jnp.maximum(n_dot_h, NDF_COS_MIN))
    return beckmann_ndf(n_dot_h, alpha) * (c2 * c2 / 4.0)


def ward(n_dot_h: Float[ArrayLike, "*batch"], n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
         alpha: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Isotropic Ward (1992): exp(-tan^2 theta_h / alpha^2) / (4 pi alpha^2 sqrt(n.l n.v))."""
    return _ward_exp(n_dot_h, alpha) / jnp.sqrt(clamp_cos(n_dot_l) * clamp_cos(n_dot_v))


def ward_duer(n_dot_h: Float[ArrayLike, "*batch"], n_dot_l: Float[ArrayLike, "*batch"],
              n_dot_v: Float[ArrayLike, "*batch"], alpha: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Ward-Duer (Duer 2006): exp(-tan^2 theta_h / alpha^2) / (4 pi alpha^2 n.l n.v)."""
    return _ward_exp(n_dot_h, alpha) / (clamp_cos(n_dot_l) * clamp_cos(n_dot_v))


def _ward_exp_aniso(h, alpha_t, alpha_b):
    """exp(-((t.h/at)^2 + (b.h/ab)^2) / (n.h)^2) / (4 pi at ab), 0 for n.h <= 0: the
    anisotropic Beckmann D times (n.h)^4 / 4."""
    hz2 = jnp.square(jnp.maximum(h[..., 2], NDF_COS_MIN))
    return beckmann_ndf_aniso(h, alpha_t, alpha_b) * (hz2 * hz2 / 4.0)


def ward_aniso(h: Float[ArrayLike, "*batch 3"], n_dot_l: Float[ArrayLike, "*batch"],
               n_dot_v: Float[ArrayLike, "*batch"], alpha_t: Float[ArrayLike, "*#batch"],
               alpha_b: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Anisotropic Ward (1992), h in the lobe's rotated frame:
    exp(-tan^2 theta_h (cos^2 phi_h / at^2 + sin^2 phi_h / ab^2)) / (4 pi at ab sqrt(n.l n.v))."""
    return _ward_exp_aniso(h, alpha_t, alpha_b) / jnp.sqrt(clamp_cos(n_dot_l) * clamp_cos(n_dot_v))


def ward_duer_aniso(h: Float[ArrayLike, "*batch 3"], n_dot_l: Float[ArrayLike, "*batch"],
                    n_dot_v: Float[ArrayLike, "*batch"], alpha_t: Float[ArrayLike, "*#batch"],
                    alpha_b: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Anisotropic Ward-Duer (Duer 2006): the same over n.l n.v."""
    return _ward_exp_aniso(h, alpha_t, alpha_b) / (clamp_cos(n_dot_l) * clamp_cos(n_dot_v))


def ashikhmin_shirley(n_dot_h: Float[ArrayLike, "*batch"], v_dot_h: Float[ArrayLike, "*batch"],
                      n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
                      exponent: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Ashikhmin & Shirley 2000, isotropic, without its Fresnel factor:
    (n + 1) / (8 pi) (n.h)^n / ((h.wi) max(n.wi, n.wo)) (h.wi = h.wo)."""
    denominator = clamp_cos(v_dot_h) * jnp.maximum(clamp_cos(n_dot_l), clamp_cos(n_dot_v))
    return (exponent + 1.0) * (0.125 * INV_PI) * cosine_power(n_dot_h, exponent) / denominator


def ashikhmin_shirley_aniso(h: Float[ArrayLike, "*batch 3"], v_dot_h: Float[ArrayLike, "*batch"],
                            n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
                            exponent_u: Float[ArrayLike, "*#batch"],
                            exponent_v: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Ashikhmin & Shirley 2000 (their eq. 4), without its Fresnel factor, h in the lobe's
    rotated frame: sqrt((nu + 1)(nv + 1)) / (8 pi) (n.h)^((nu hx^2 + nv hy^2) / (1 - hz^2))
    / ((h.wi) max(n.wi, n.wo)); nu = nv is ``ashikhmin_shirley``.  An exponent below 0 (an
    alpha above 1 from the anisotropy remap) reads as 0, a lobe flat in that direction."""
    exponent_u, exponent_v = jnp.maximum(exponent_u, 0.0), jnp.maximum(exponent_v, 0.0)
    sin2 = h[..., 0] * h[..., 0] + h[..., 1] * h[..., 1]
    mixed = jnp.where(sin2 > AS_SIN2_MIN,
                      (exponent_u * h[..., 0] * h[..., 0] + exponent_v * h[..., 1] * h[..., 1])
                      / jnp.maximum(sin2, AS_SIN2_MIN), 0.5 * (exponent_u + exponent_v))
    denominator = clamp_cos(v_dot_h) * jnp.maximum(clamp_cos(n_dot_l), clamp_cos(n_dot_v))
    scale = jnp.sqrt((exponent_u + 1.0) * (exponent_v + 1.0)) * (0.125 * INV_PI)
    return scale * cosine_power(h[..., 2], mixed) / denominator


def lafortune_cxy(cz: Float[ArrayLike, "*#batch"]) -> Float[Array, "*#batch"]:
    """Cx = Cy of the unit forward C = (Cxy, Cxy, Cz): -sqrt((1 - Cz^2) / 2)."""
    return -jnp.sqrt(jnp.maximum(0.5 * (1.0 - cz * cz), LAFORTUNE_SQUARE_MIN))


def lafortune_cosine(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"],
                     cxy: Float[ArrayLike, "*#batch"], cz: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Lafortune et al. 1997's generalised cosine over Ngan's max(|Cxy|, |Cz|):
    (Cxy (wi_x wo_x + wi_y wo_y) + Cz wi_z wo_z) / max(|Cxy|, |Cz|)."""
    tangential = wi[..., 0] * wo[..., 0] + wi[..., 1] * wo[..., 1]
    return (cxy * tangential + cz * wi[..., 2] * wo[..., 2]) / jnp.maximum(jnp.abs(cxy), jnp.abs(cz))


def lafortune(cosine: Float[ArrayLike, "*batch"], exponent: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Ngan et al. 2005's Lafortune lobe: (n + 2) / (2 pi) max(0, cosine)^n (cosine normalised by
    lafortune_cosine, so the lobe's peak is that of the modified Phong lobe of the same n)."""
    return (exponent + 2.0) * (0.5 * INV_PI) * cosine_power(cosine, exponent)


# --- declarations: lobe(params, g, alpha) -> the RGB specular term, or for an
# anisotropic lobe lobe(params, g, alpha_t, alpha_b, h in the rotated frame) -------------

def _blinn_phong(p, g, alpha):
    return p["specular_albedo"] * blinn_phong(g.n_dot_h, phong_exponent(alpha))[..., None]


def _phong(p, g, alpha):
    return p["specular_albedo"] * phong_modified(mirror_cosine(g.wi, g.wo), phong_exponent(alpha))[..., None]


def _blinn_phong_mf(p, g, alpha):
    lobe = blinn_phong(g.n_dot_h, phong_exponent(alpha)) * microfacet_factor(g.v_dot_h, g.n_dot_l, g.n_dot_v)
    return p["specular_albedo"] * lobe[..., None]


def _phong_mf(p, g, alpha):
    lobe = phong_modified(mirror_cosine(g.wi, g.wo), phong_exponent(alpha)) * microfacet_factor(
        g.v_dot_h, g.n_dot_l, g.n_dot_v)
    return p["specular_albedo"] * lobe[..., None]


def _ward(p, g, alpha):
    return p["specular_albedo"] * ward(g.n_dot_h, g.n_dot_l, g.n_dot_v, alpha)[..., None]


def _ward_duer(p, g, alpha):
    return p["specular_albedo"] * ward_duer(g.n_dot_h, g.n_dot_l, g.n_dot_v, alpha)[..., None]


def _ward_aniso(p, g, alpha_t, alpha_b, h):
    return p["specular_albedo"] * ward_aniso(h, g.n_dot_l, g.n_dot_v, alpha_t, alpha_b)[..., None]


def _ward_duer_aniso(p, g, alpha_t, alpha_b, h):
    return p["specular_albedo"] * ward_duer_aniso(h, g.n_dot_l, g.n_dot_v, alpha_t, alpha_b)[..., None]


def _ashikhmin_shirley(p, g, alpha):
    lobe = ashikhmin_shirley(g.n_dot_h, g.v_dot_h, g.n_dot_l, g.n_dot_v, phong_exponent(alpha))
    return fresnel_schlick(p["specular_albedo"], g.v_dot_h) * lobe[..., None]


def _ashikhmin_shirley_aniso(p, g, alpha_t, alpha_b, h):
    lobe = ashikhmin_shirley_aniso(h, g.v_dot_h, g.n_dot_l, g.n_dot_v, phong_exponent(alpha_t),
                                   phong_exponent(alpha_b))
    return fresnel_schlick(p["specular_albedo"], g.v_dot_h) * lobe[..., None]


def _ashikhmin_shirley_scaled(p, g, alpha):
    lobe = ashikhmin_shirley(g.n_dot_h, g.v_dot_h, g.n_dot_l, g.n_dot_v, phong_exponent(alpha))
    return p["specular_albedo"] * (fresnel_schlick(p["fresnel_reflectance"], g.v_dot_h) * lobe)[..., None]


def _lafortune_term(g, rho, alpha, cz):
    cosine = lafortune_cosine(g.wi, g.wo, lafortune_cxy(cz), cz)
    return rho * lafortune(cosine, phong_exponent(alpha))[..., None]


def _lafortune(p, g, alpha):
    return _lafortune_term(g, p["specular_albedo"], alpha, p["lafortune_cz"])


def _more_lafortune(lobes):
    """Lafortune et al. 1997's sum of ``lobes`` lobes: the first as ``lafortune``'s, lobe j >= 2
    with its own roughness, albedo and Cz (lafortune_roughness_j, _albedo_j, _cz_j)."""
    def lobe(p, g, alpha):
        f = _lafortune(p, g, alpha)
        for j in range(2, lobes + 1):
            r = jnp.clip(p[f"lafortune_roughness_{j}"], ROUGHNESS_MIN, 1.0)
            f = f + _lafortune_term(g, p[f"lafortune_albedo_{j}"], jnp.maximum(r * r, ALPHA_MIN),
                                    p[f"lafortune_cz_{j}"])
        return f
    return lobe


SPECULAR_ALBEDO = Param("specular_albedo", 3, 0.0, 1.0, 0.04, "rho_s, the lobe's specular albedo (its scale)",
                        start=Start(probe=1.0, rule=lambda e: e.scale))

# Ngan et al. 2005's Ashikhmin-Shirley: the lobe scaled by an RGB rho_s, its Schlick Fresnel of a grey R_s
FRESNEL_REFLECTANCE = Param("fresnel_reflectance", 1, 0.0, 1.0, 0.1,
                            "R_s, the grey Schlick reflectance at normal incidence of the scaled "
                            "Ashikhmin-Shirley lobe (rho_s scales it)")

LAFORTUNE_CZ = Param("lafortune_cz", 1, 0.0, 1.0, LAFORTUNE_MIRROR_CZ,
                     "Cz of Lafortune's unit C (Cx = Cy = -sqrt((1 - Cz^2)/2)): 1/sqrt(3) the mirror lobe, "
                     "below it towards grazing")

# Lafortune's lobes 2 and 3: their own width, scale and shape; they start broad and weak
# beside the first (a wide gloss or an off-specular sheen the first lobe leaves)
LAFORTUNE_MORE_START_ROUGHNESS = 0.8
LAFORTUNE_MORE_START_ALBEDO = 0.02


def _lafortune_params(j):
    return (Param(f"lafortune_roughness_{j}", 1, ROUGHNESS_MIN, 1.0, LAFORTUNE_MORE_START_ROUGHNESS,
                  f"roughness of Lafortune lobe {j} (its exponent n = 2/alpha^2 - 2, alpha = r^2)"),
            Param(f"lafortune_albedo_{j}", 3, 0.0, 1.0, LAFORTUNE_MORE_START_ALBEDO, f"rho of Lafortune lobe {j}"),
            Param(f"lafortune_cz_{j}", 1, 0.0, 1.0, LAFORTUNE_MIRROR_CZ, f"Cz of Lafortune lobe {j}'s unit C"))


# glTF: the GGX microfacet lobe of the same alpha, F0 chosen so that the two agree at
# normal incidence (wi = wo = n): D F0 / 4 = rho_s (n+2)/(2 pi) for the Phong lobes
# (D(1) = 1/(pi alpha^2) ~ (n+2)/(2 pi)), F0 = rho_s for Ward's and the _mf lobes (rho_s D / 4).
_PHONG_NOTE = ("the {name} lobe is exported as glTF's GGX microfacet lobe of the same alpha with "
               "F0 = 4 rho_s = {f0} (equal at normal incidence; no Fresnel rise in the fit)")
_WARD_NOTE = ("the {name} lobe is exported as glTF's GGX microfacet lobe of the same alpha with "
              "F0 = rho_s = {f0} (equal at normal incidence; no Fresnel rise in the fit)")
_LAFORTUNE_NOTE = _PHONG_NOTE + "; its Cz = {lafortune_cz:.3g} (the lobe's bend) is dropped"
_LAFORTUNE_MORE_NOTE = "; lobes 2 and up are dropped (glTF has one specular lobe)"

LOBES = {
    "blinn_phong": Lobe(name="blinn_phong", lobe=_blinn_phong, params=(ROUGHNESS, SPECULAR_ALBEDO),
                        gltf=GltfRule(lambda p: {"f0": 4.0 * p["specular_albedo"]}, _PHONG_NOTE)),
    "phong": Lobe(name="phong", lobe=_phong, params=(ROUGHNESS, SPECULAR_ALBEDO),
                  gltf=GltfRule(lambda p: {"f0": 4.0 * p["specular_albedo"]}, _PHONG_NOTE)),
    "blinn_phong_mf": Lobe(name="blinn_phong_mf", lobe=_blinn_phong_mf, params=(ROUGHNESS, SPECULAR_ALBEDO),
                           gltf=GltfRule(lambda p: {"f0": p["specular_albedo"]}, _WARD_NOTE)),
    "phong_mf": Lobe(name="phong_mf", lobe=_phong_mf, params=(ROUGHNESS, SPECULAR_ALBEDO),
                     gltf=GltfRule(lambda p: {"f0": p["specular_albedo"]}, _WARD_NOTE)),
    "ward": Lobe(name="ward", lobe=_ward, params=(ROUGHNESS, SPECULAR_ALBEDO),
                 gltf=GltfRule(lambda p: {"f0": p["specular_albedo"]}, _WARD_NOTE)),
    "ward_aniso": Lobe(name="ward_aniso", lobe=_ward_aniso, params=(ROUGHNESS, SPECULAR_ALBEDO), anisotropic=True,
                       gltf=GltfRule(lambda p: {"f0": p["specular_albedo"]}, _WARD_NOTE)),
    "ward_duer_aniso": Lobe(name="ward_duer_aniso", lobe=_ward_duer_aniso, params=(ROUGHNESS, SPECULAR_ALBEDO),
                            anisotropic=True, gltf=GltfRule(lambda p: {"f0": p["specular_albedo"]}, _WARD_NOTE)),
    "ashikhmin_shirley": Lobe(
        name="ashikhmin_shirley", lobe=_ashikhmin_shirley, params=(ROUGHNESS, SPECULAR_ALBEDO),
        gltf=GltfRule(lambda p: {"f0": p["specular_albedo"]},
                      "the {name} lobe is exported as glTF's GGX microfacet lobe of the same alpha with "
                      "F0 = R_s = {f0} (its own Schlick Fresnel; the two lobes differ away from the peak)")),
    "ashikhmin_shirley_aniso": Lobe(
        name="ashikhmin_shirley_aniso", lobe=_ashikhmin_shirley_aniso, params=(ROUGHNESS, SPECULAR_ALBEDO),
        anisotropic=True,
        gltf=GltfRule(lambda p: {"f0": p["specular_albedo"]},
                      "the {name} lobe is exported as glTF's anisotropic GGX microfacet lobe of the same "
                      "alphas with F0 = R_s = {f0} (its own Schlick Fresnel; the two lobes differ away from "
                      "the peak)")),
    "ashikhmin_shirley_scaled": Lobe(
        name="ashikhmin_shirley_scaled", lobe=_ashikhmin_shirley_scaled,
        params=(ROUGHNESS, SPECULAR_ALBEDO, FRESNEL_REFLECTANCE),
        gltf=GltfRule(lambda p: {"f0": p["specular_albedo"] * p["fresnel_reflectance"],
                                 "f90": float(sum(p["specular_albedo"]) / 3.0)},
                      "the {name} lobe is exported as glTF's GGX microfacet lobe of the same alpha with "
                      "F0 = rho_s R_s = {f0} and F90 the mean of rho_s, {f90} (glTF's F90 is grey; the two "
                      "lobes differ away from the peak)")),
    "lafortune": Lobe(name="lafortune", lobe=_lafortune, params=(ROUGHNESS, SPECULAR_ALBEDO, LAFORTUNE_CZ),
                      gltf=GltfRule(lambda p: {"f0": 4.0 * p["specular_albedo"]}, _LAFORTUNE_NOTE)),
    **{f"lafortune{k}": Lobe(
        name=f"lafortune{k}", lobe=_more_lafortune(k),
        params=(ROUGHNESS, SPECULAR_ALBEDO, LAFORTUNE_CZ) + tuple(q for j in range(2, k + 1)
                                                                  for q in _lafortune_params(j)),
        gltf=GltfRule(lambda p: {"f0": 4.0 * p["specular_albedo"]}, _LAFORTUNE_NOTE + _LAFORTUNE_MORE_NOTE))
       for k in (2, 3)},
    "ward_duer": Lobe(name="ward_duer", lobe=_ward_duer, params=(ROUGHNESS, SPECULAR_ALBEDO),
                      gltf=GltfRule(lambda p: {"f0": p["specular_albedo"]}, _WARD_NOTE)),
}
