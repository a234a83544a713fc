"""ModelSpec: the one declaration a BRDF model is built from.

A ``ModelSpec`` names the terms (NDF, masking, Fresnel, diffuse lobe, how they
are composed, energy compensation, clearcoat).  From it derive the parameter
schema (``spec.schema()``), the evaluation (``evaluate(spec, params, wi,
wo)``), the model string users type (``str(spec)`` / ``parse_model``), and,
in the other packages, the GLSL defines, the JSON form and the glTF mapping.

Compositions
    additive  f = D V F + f_diffuse                       (the classic fit model)
    coupled   f = D V F + (1 - F(v.h)) f_diffuse          (energy-aware sum, as
              most real-time renderers and the glTF dielectric weight it)
    gltf      the glTF 2.0 metallic-roughness BRDF (brdf.gltf), so a fit in
              that space exports losslessly

Model strings: an NDF (``ggx``, ``ggx_aniso``) or ``gltf``, then ``+``-joined
options in any order, e.g. ``ggx+lambert``, ``ggx+frostbite``,
``ggx_aniso+cod_wwii+ms+clearcoat``, ``gltf+specular+clearcoat``.
"""

import dataclasses
import math
import typing

import jax
import jax.numpy as jnp

from . import diffuse as _diffuse
from .clearcoat import apply_clearcoat
from .constants import ALPHA_MIN, IOR_DEFAULT, ROUGHNESS_MIN
from .energy import kulla_conty, turquin_factor
from .fresnel import (f0_from_ior, fresnel_conductor, fresnel_dielectric,
                      fresnel_schlick, fresnel_schlick_average)
from .geometry import dot, half_vector, rotate_tangent
from .gltf import gltf_combine
from .specular import (anisotropy_gltf, anisotropy_kulla_conty, ggx_ndf,
                       ggx_ndf_aniso, visibility_height_correlated,
                       visibility_height_correlated_aniso,
                       visibility_separable, visibility_separable_aniso)


class UnknownModelError(ValueError):
    """A model string or option the toolkit does not know."""


@dataclasses.dataclass(frozen=True)
class Param:
    """One entry of a parameter schema."""
    name: str
    size: int            # 1 (shared by R, G, B) or 3 (per channel)
    lower: float
    upper: float
    default: float
    description: str
    unit: str = ""


NDFS = ("ggx", "ggx_aniso")
MASKINGS = ("height_correlated", "separable")
FRESNELS = ("schlick", "schlick_f90", "dielectric", "conductor")
DIFFUSES = ("none", "lambert", "burley", "frostbite", "cod_wwii", "oren_nayar")
COMPOSITIONS = ("additive", "coupled", "gltf")
ENERGIES = ("none", "kulla_conty", "turquin")
ANISOTROPY_REMAPS = ("kulla_conty", "gltf")
GLTF_EXTENSIONS = ("ior", "specular")


@dataclasses.dataclass(frozen=True)
class ModelSpec:
    """Which terms make up a BRDF model.  Hashable: usable as a jit static argument."""
    ndf: str = "ggx"
    masking: str = "height_correlated"
    fresnel: str = "schlick"
    diffuse: str = "lambert"
    composition: str = "additive"
    energy: str = "none"
    clearcoat: bool = False
    anisotropy: str = "kulla_conty"
    gltf_extensions: tuple = ()

    def __post_init__(self):
        for field, allowed in (("ndf", NDFS), ("masking", MASKINGS), ("fresnel", FRESNELS),
                               ("diffuse", DIFFUSES), ("composition", COMPOSITIONS),
                               ("energy", ENERGIES), ("anisotropy", ANISOTROPY_REMAPS)):
            value = getattr(self, field)
            if value not in allowed:
                raise UnknownModelError(f"unknown {field} {value!r}; valid: {', '.join(allowed)}")
        for ext in self.gltf_extensions:
            if ext not in GLTF_EXTENSIONS:
                raise UnknownModelError(f"unknown glTF extension {ext!r}; valid: {', '.join(GLTF_EXTENSIONS)}")
        if self.composition == "gltf":
            if self.diffuse != "lambert" or self.fresnel != "schlick" or self.masking != "height_correlated":
                raise UnknownModelError("the gltf model fixes its terms (Lambert, Schlick, height-correlated Smith)")
            if self.energy != "none":
                raise UnknownModelError("the glTF BRDF has no energy compensation; drop 'ms'/'turquin'")
        elif self.gltf_extensions:
            raise UnknownModelError("glTF extensions (ior, specular) only apply to the gltf model")
        # Canonical form, so that parse_model(str(spec)) == spec and equal specs
        # evaluate the same BRDF: the remap only exists for ggx_aniso, and the
        # glTF model always uses KHR_materials_anisotropy's; extensions in
        # GLTF_EXTENSIONS order, as a tuple.
        remap = ("gltf" if self.composition == "gltf" else self.anisotropy) if self.anisotropic \
            else "kulla_conty"
        object.__setattr__(self, "anisotropy", remap)
        object.__setattr__(self, "gltf_extensions",
                           tuple(e for e in GLTF_EXTENSIONS if e in self.gltf_extensions))

    @property
    def anisotropic(self):
        return self.ndf == "ggx_aniso"

    def __str__(self):
        return model_string(self)

    def schema(self):
        """The parameter schema: a tuple of Param, in a fixed order."""
        return parameter_schema(self)


# --- model strings ----------------------------------------------------------

_DIFFUSE_TOKENS = {d: d for d in DIFFUSES if d != "none"}
_OPTION_TOKENS = {
    "ms": ("energy", "kulla_conty"),
    "turquin": ("energy", "turquin"),
    "clearcoat": ("clearcoat", True),
    "separable": ("masking", "separable"),
    "f90": ("fresnel", "schlick_f90"),
    "dielectric": ("fresnel", "dielectric"),
    "conductor": ("fresnel", "conductor"),
    "coupled": ("composition", "coupled"),
    "gltf_aniso": ("anisotropy", "gltf"),
}
_GLTF_TOKENS = {"ior": "ior", "specular": "specular", "aniso": None, "clearcoat": None}

MODEL_EXAMPLES = (
    "ggx+lambert", "ggx+burley", "ggx+frostbite", "ggx+cod_wwii", "ggx+oren_nayar",
    "ggx+lambert+ms", "ggx+lambert+coupled", "ggx+lambert+clearcoat",
    "ggx_aniso+lambert", "ggx_aniso+cod_wwii+ms+clearcoat",
    "ggx+lambert+dielectric", "ggx+conductor", "ggx+lambert+turquin",
    "gltf", "gltf+ior", "gltf+specular", "gltf+clearcoat", "gltf+aniso",
)


def describe_tokens():
    """Text listing every token a model string may contain."""
    return "\n".join([
        "first token: ggx | ggx_aniso | gltf",
        "diffuse (ggx): " + " | ".join(_DIFFUSE_TOKENS) + " (none: specular only)",
        "options (ggx): ms (Kulla-Conty) | turquin | clearcoat | separable (Smith) |"
        " f90 | dielectric (exact, IOR) | conductor (n, k) | coupled ((1-F) diffuse) |"
        " gltf_aniso (KHR anisotropy remap)",
        "options (gltf): ior | specular | aniso | clearcoat",
    ])


def _quoted(text, limit=60):
    """repr of user text, cut to ``limit`` characters (a 100 000-character string is not echoed)."""
    text = str(text)
    return repr(text) if len(text) <= limit else repr(text[:limit]) + f"... ({len(text):,} characters)"


def parse_model(text):
    """Model string -> ModelSpec; unknown names raise UnknownModelError listing valid ones."""
    if isinstance(text, ModelSpec):
        return text
    if not str(text).strip():
        raise UnknownModelError("empty model string; examples: " + ", ".join(MODEL_EXAMPLES))
    tokens = [t.strip().lower() for t in str(text).split("+")]
    if not all(tokens):
        raise UnknownModelError(
            f"malformed model string {_quoted(text)}: an empty term before or after a '+'; "
            f"write terms joined by single '+' signs, e.g. {', '.join(MODEL_EXAMPLES[:3])}")
    head, options = tokens[0], tokens[1:]
    if len(set(options)) != len(options):
        raise UnknownModelError(f"repeated option in model string {_quoted(text)}")
    if head == "gltf":
        kwargs = {"composition": "gltf"}
        exts, aniso = [], False
        for tok in options:
            if tok not in _GLTF_TOKENS:
                raise UnknownModelError(
                    f"unknown option {_quoted(tok, 30)} for gltf in {_quoted(text)}; valid: {', '.join(_GLTF_TOKENS)}")
            if tok == "aniso":
                aniso = True
            elif tok == "clearcoat":
                kwargs["clearcoat"] = True
            else:
                exts.append(tok)
        if aniso:
            kwargs.update(ndf="ggx_aniso", anisotropy="gltf")
        kwargs["gltf_extensions"] = tuple(e for e in GLTF_EXTENSIONS if e in exts)
        return ModelSpec(**kwargs)
    if head not in NDFS:
        raise UnknownModelError(
            f"unknown model {_quoted(head, 30)} in {_quoted(text)}; a model string starts with ggx, ggx_aniso or gltf "
            f"(examples: {', '.join(MODEL_EXAMPLES[:6])}; `brdf-fit models` lists all)")
    kwargs = {"ndf": head, "diffuse": "none"}
    for tok in options:
        if tok in _DIFFUSE_TOKENS:
            if kwargs["diffuse"] != "none":
                raise UnknownModelError(f"two diffuse lobes in {_quoted(text)}")
            kwargs["diffuse"] = tok
        elif tok in _OPTION_TOKENS:
            field, value = _OPTION_TOKENS[tok]
            if field in kwargs and field != "diffuse":
                raise UnknownModelError(f"conflicting options for {field} in {_quoted(text)}")
            kwargs[field] = value
        else:
            valid = list(_DIFFUSE_TOKENS) + list(_OPTION_TOKENS)
            raise UnknownModelError(f"unknown option {_quoted(tok, 30)} in {_quoted(text)}; valid: {', '.join(valid)}")
    if kwargs.get("anisotropy") == "gltf" and head != "ggx_aniso":
        raise UnknownModelError("gltf_aniso needs ggx_aniso")
    return ModelSpec(**kwargs)


def model_string(spec):
    """The canonical model string of a spec (parse_model(model_string(s)) == s)."""
    if spec.composition == "gltf":
        parts = ["gltf"] + list(spec.gltf_extensions)
        if spec.anisotropic:
            parts.append("aniso")
        if spec.clearcoat:
            parts.append("clearcoat")
        return "+".join(parts)
    parts = [spec.ndf]
    if spec.diffuse != "none":
        parts.append(spec.diffuse)
    for tok, (field, value) in _OPTION_TOKENS.items():
        if getattr(spec, field) == value:
            parts.append(tok)
    return "+".join(parts)


# --- parameter schema -------------------------------------------------------

_ROUGHNESS = Param("roughness", 1, ROUGHNESS_MIN, 1.0, 0.5,
                   "perceptual roughness r (alpha = r^2), glTF roughnessFactor")
_CLEARCOAT = (
    Param("clearcoat", 1, 0.0, 1.0, 0.0, "clearcoat layer weight (KHR_materials_clearcoat)"),
    Param("clearcoat_roughness", 1, ROUGHNESS_MIN, 1.0, 0.1, "perceptual roughness of the coat"),
)


def parameter_schema(spec):
    """Tuple of Param for a ModelSpec (order fixed: it is the fit vector's order)."""
    if spec.composition == "gltf":
        params = [
            Param("base_color", 3, 0.0, 1.0, 0.5, "glTF baseColorFactor (linear RGB)"),
            Param("metallic", 1, 0.0, 1.0, 0.0, "glTF metallicFactor"),
            _ROUGHNESS,
        ]
        if "ior" in spec.gltf_extensions:
            params.append(Param("ior", 1, 1.0, 3.0, 1.5, "KHR_materials_ior index of refraction"))
        if "specular" in spec.gltf_extensions:
            params.append(Param("specular", 1, 0.0, 1.0, 1.0, "KHR_materials_specular specularFactor"))
            params.append(Param("specular_color", 3, 0.0, 10.0, 1.0,
                                "KHR_materials_specular specularColorFactor (may exceed 1)"))
        if spec.anisotropic:
            params.append(Param("anisotropy", 1, 0.0, 1.0, 0.0,
                                "KHR_materials_anisotropy anisotropyStrength"))
            params.append(Param("rotation", 1, -math.pi / 2, math.pi / 2, 0.0,
                                "anisotropy direction, CCW from the tangent", "rad"))
    else:
        params = []
        if spec.diffuse != "none":
            params.append(Param("albedo", 3, 0.0, 1.0, 0.5, "diffuse albedo rho (f_d = rho/pi * factor)"))
        if spec.diffuse == "oren_nayar":
            params.append(Param("sigma", 1, 0.0, 1.5, 0.3, "Oren-Nayar slope deviation", "rad"))
        params.append(_ROUGHNESS)
        if spec.anisotropic:
            if spec.anisotropy == "gltf":
                params.append(Param("anisotropy", 1, 0.0, 1.0, 0.0, "KHR anisotropy strength s"))
            else:
                params.append(Param("anisotropy", 1, -0.95, 0.95, 0.0,
                                    "Kulla-Conty anisotropy a: alpha_t = alpha(1+a), alpha_b = alpha(1-a)"))
            params.append(Param("rotation", 1, -math.pi / 2, math.pi / 2, 0.0,
                                "tangent rotation, CCW from +x", "rad"))
        if spec.fresnel in ("schlick", "schlick_f90"):
            params.append(Param("f0", 3, 0.0, 1.0, 0.04, "Fresnel reflectance at normal incidence"))
        if spec.fresnel == "schlick_f90":
            params.append(Param("f90", 1, 0.0, 1.0, 1.0, "Fresnel reflectance at grazing incidence"))
        if spec.fresnel == "dielectric":
            params.append(Param("ior", 1, 1.0, 3.0, 1.5, "index of refraction (exact dielectric Fresnel)"))
        if spec.fresnel == "conductor":
            params.append(Param("eta", 3, 0.05, 5.0, 1.0, "conductor IOR, real part n"))
            params.append(Param("k", 3, 0.0, 10.0, 3.0, "conductor IOR, imaginary part k"))
    if spec.clearcoat:
        params.extend(_CLEARCOAT)
    return tuple(params)


def default_params(spec, dtype=None):
    """{name: array} with every parameter at its schema default."""
    return {p.name: jnp.full((3,) if p.size == 3 else (), p.default, dtype=dtype)
            for p in parameter_schema(spec)}


def check_params(spec, params):
    """Raise ValueError if ``params`` lacks a schema entry or has a foreign one."""
    names = [p.name for p in parameter_schema(spec)]
    missing = [n for n in names if n not in params]
    extra = [n for n in params if n not in names]
    if missing or extra:
        raise ValueError(f"parameters for {model_string(spec)}: missing {missing}, unexpected {extra}")


# --- evaluation -------------------------------------------------------------

class Geometry(typing.NamedTuple):
    """A batch of direction pairs and the cosines every term reads.

    Computing it once per data set (it does not depend on the parameters)
    lets a fit evaluate isotropic models from four contiguous arrays.
    """
    wi: jax.Array        # (..., 3)
    wo: jax.Array        # (..., 3)
    h: jax.Array         # (..., 3) half vector
    n_dot_l: jax.Array   # (...)
    n_dot_v: jax.Array
    n_dot_h: jax.Array
    v_dot_h: jax.Array   # = l.h

    def reversed(self):
        """The same pairs with wi and wo exchanged."""
        return Geometry(self.wo, self.wi, self.h, self.n_dot_v, self.n_dot_l,
                        self.n_dot_h, self.v_dot_h)


def geometry(wi, wo):
    """Geometry of (..., 3) direction pairs (local frame, pointing away)."""
    h = half_vector(wi, wo)
    return Geometry(wi, wo, h, wi[..., 2], wo[..., 2], h[..., 2], dot(wo, h))


def _specular_dv(spec, params, g, alpha):
    """D V of the specular lobe (isotropic or anisotropic, either masking)."""
    if not spec.anisotropic:
        vis = visibility_height_correlated if spec.masking == "height_correlated" else visibility_separable
        return ggx_ndf(g.n_dot_h, alpha) * vis(g.n_dot_l, g.n_dot_v, alpha)
    remap = anisotropy_kulla_conty if spec.anisotropy == "kulla_conty" else anisotropy_gltf
    alpha_t, alpha_b = remap(alpha, params["anisotropy"])
    angle = params["rotation"]
    l, v, hr = (rotate_tangent(x, angle) for x in (g.wi, g.wo, g.h))
    vis = (visibility_height_correlated_aniso if spec.masking == "height_correlated"
           else visibility_separable_aniso)
    return ggx_ndf_aniso(hr, alpha_t, alpha_b) * vis(l, v, alpha_t, alpha_b)


def _fresnel(spec, params, v_dot_h):
    """RGB (or broadcastable) Fresnel and its normal-incidence F0."""
    if spec.fresnel == "schlick":
        f0 = params["f0"]
        return fresnel_schlick(f0, v_dot_h), f0
    # RGB ones in the inputs' dtype: a bare jnp.ones(3) is float64 under
    # jax_enable_x64 and would silently promote a float32 evaluation.
    if spec.fresnel == "schlick_f90":
        f0 = params["f0"]
        ones = jnp.ones(3, jnp.result_type(params["f90"], v_dot_h))
        return fresnel_schlick(f0, v_dot_h, params["f90"] * ones), f0
    if spec.fresnel == "dielectric":
        ior = params["ior"]
        ones = jnp.ones(3, jnp.result_type(ior, v_dot_h))
        f = fresnel_dielectric(v_dot_h, ior)[..., None] * ones
        return f, f0_from_ior(ior) * ones
    n, k = params["eta"], params["k"]
    return fresnel_conductor(v_dot_h[..., None], n, k), f0_from_ior(n, k)


def _diffuse_lobe(spec, params, g, roughness, alpha):
    nl, nv, lh = g.n_dot_l, g.n_dot_v, g.v_dot_h
    albedo = params["albedo"]
    if spec.diffuse == "lambert":
        return _diffuse.lambert(albedo, nl, nv)
    if spec.diffuse == "burley":
        return _diffuse.burley(albedo, roughness, nl, nv, lh)
    if spec.diffuse == "frostbite":
        return _diffuse.frostbite(albedo, roughness, nl, nv, lh)
    if spec.diffuse == "cod_wwii":
        return _diffuse.cod_wwii(albedo, alpha, nl, nv, lh, g.n_dot_h)
    return _diffuse.oren_nayar(albedo, params["sigma"], g.wi, g.wo)


def evaluate(spec, params, wi, wo):
    """The BRDF of ``spec`` (RGB, 1/sr, without the cosine) at (..., 3) direction pairs.

    ``params`` maps every schema name to an array (shape () or (3,)).  Pairs
    with either direction at or below the horizon give 0.
    """
    return evaluate_geometry(parse_model(spec), params, geometry(wi, wo))


def roughness_alpha(roughness):
    """(roughness clamped to [ROUGHNESS_MIN, 1], alpha = roughness^2 floored at ALPHA_MIN)."""
    roughness = jnp.clip(roughness, ROUGHNESS_MIN, 1.0)
    return roughness, jnp.maximum(roughness * roughness, ALPHA_MIN)


def evaluate_geometry(spec, params, g):
    """``evaluate`` on a precomputed Geometry (the fitter's fast path)."""
    roughness, alpha = roughness_alpha(params["roughness"])
    if spec.composition == "gltf":
        dv = _specular_dv(spec, params, g, alpha)
        f = gltf_combine(dv, g.v_dot_h, params["base_color"], params["metallic"],
                         ior=params.get("ior", IOR_DEFAULT),
                         specular=params.get("specular", 1.0),
                         specular_color=params.get("specular_color", 1.0))
    else:
        fresnel, f0 = _fresnel(spec, params, g.v_dot_h)
        f = _specular_dv(spec, params, g, alpha)[..., None] * fresnel
        if spec.energy == "kulla_conty":
            f = f + kulla_conty(g.n_dot_l, g.n_dot_v, roughness, fresnel_schlick_average(f0))
        elif spec.energy == "turquin":
            f = f * turquin_factor(g.n_dot_v, roughness, f0)
        if spec.diffuse != "none":
            fd = _diffuse_lobe(spec, params, g, roughness, alpha)
            if spec.composition == "coupled":
                fd = fd * (1.0 - fresnel)
            f = f + fd
    if spec.clearcoat:
        f = apply_clearcoat(f, params["clearcoat"], params["clearcoat_roughness"],
                            g.n_dot_l, g.n_dot_v, g.n_dot_h)
    above = (g.n_dot_l > 0.0) & (g.n_dot_v > 0.0)
    return jnp.where(above[..., None], f, 0.0)
