"""ModelSpec: which terms make up a model, its model string and its parameter schema.

A ``ModelSpec`` names one option per field (NDF, masking, Fresnel, diffuse
lobe, composition, energy compensation, clearcoat, anisotropy remap, glTF
extensions).  Each option is a Term declared beside its formula
(brdf/declare.py); ``FIELDS`` below is the configuration block that gathers
them, and everything here reads it: the valid values, the model-string
tokens, the schema.  Adding an option to a field is one entry in its
module's dictionary.

Compositions
    additive  f = D V F + f_diffuse                       (the classic fit model)
    coupled   f = D V F + (1 - F(v.h)) f_diffuse          (energy-aware sum, as
              most real-time renderers and the glTF dielectric weight it)
    gltf      the glTF 2.0 metallic-roughness BRDF (brdf.gltf), so a fit in
              that space exports losslessly
    openpbr   OpenPBR Surface's metal and non-metal (brdf/openpbr.py), bare or under its coat, also
              as MaterialX draws them (+mx, brdf/openpbr_coat.py), or Blender's coat (brdf/principled.py)

Model strings: an NDF (``ggx``, ``ggx_aniso``, ``beckmann``, ``beckmann_aniso``),
a classic lobe (``blinn_phong``, ``phong``, both with the microfacet factor ``blinn_phong_mf``,
``phong_mf``, ``ward``, ``ward_duer``, ``ward_aniso``, ``ward_duer_aniso``, ``ashikhmin_shirley``
(``_aniso``; ``_scaled``, Ngan et al.'s), ``lafortune`` (``lafortune2``, ``lafortune3``: sums of lobes): a diffuse
lobe and ``clearcoat`` are their only options), ``gltf``, ``openpbr`` or ``principled``, then ``+``-joined
options in any order, e.g. ``ggx+lambert``, ``ggx+frostbite``,
``ggx_aniso+cod_wwii+ms+clearcoat``, ``gltf+specular+clearcoat``,
``beckmann+lambert``, ``ward+lambert``, ``openpbr+metal``, ``openpbr+nonmetal+coat``;
Cook-Torrance is ``beckmann+vgroove`` (+ a diffuse lobe).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import TYPE_CHECKING

from jaxtyping import Float
from numpy.typing import DTypeLike

from ._lazy import jnp
from .clearcoat import CLEARCOAT
from .declare import Composition, Lobe, Param, Term
from .own import PREFIX as OWN_PREFIX
from .own import OwnModel, lookup, register
from .diffuse import DIFFUSES
from .energy import ENERGIES
from .fresnel import FRESNELS
from .gltf import GLTF_COMPOSITION, GLTF_EXTENSIONS
from .lobes import LOBES
from .principled import FIXED_COMPOSITIONS, FIXED_HEADS, FIXED_TERMS, fixed_composition, fixed_model_string
from .beckmann import NDFS as BECKMANN_NDFS
from .beckmann import VGROOVE
from .specular import ANISOTROPY_REMAPS
from .specular import MASKINGS as SMITH_MASKINGS
from .specular import NDFS as GGX_NDFS

if TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import Array


class UnknownModelError(ValueError):
    """A model string or option the toolkit does not know."""


NDFS = {**GGX_NDFS, **BECKMANN_NDFS, **LOBES}        # brdf/specular.py, beckmann.py, lobes.py
MASKINGS = {**SMITH_MASKINGS, VGROOVE.name: VGROOVE}  # (the Smith ones combine the NDF's own Lambda)

COMPOSITIONS = {
    "additive": Composition(name="additive", fused=True),
    "coupled": Composition(name="coupled", token="coupled", hint="(1-F) diffuse", weights_diffuse=True),
    "gltf": GLTF_COMPOSITION,
    **FIXED_COMPOSITIONS,              # openpbr (the metal), openpbr_nonmetal, openpbr_*_coat, principled_*_coat
}

# --- the configuration block: ModelSpec field -> {value: Term} ------------------
FIELDS = {
    "ndf": NDFS,                       # above
    "masking": MASKINGS,               # above
    "fresnel": FRESNELS,               # brdf/fresnel.py
    "diffuse": DIFFUSES,               # brdf/diffuse.py
    "composition": COMPOSITIONS,       # here and brdf/gltf.py
    "energy": ENERGIES,                # brdf/energy.py
    "anisotropy": ANISOTROPY_REMAPS,   # brdf/specular.py
}
# clearcoat (a bool): brdf/clearcoat.py's CLEARCOAT; gltf_extensions (a tuple): GLTF_EXTENSIONS.

# The order a spec's terms are listed in (``terms``): the glTF conversion's
# notes and the nesting of start variants follow it.
TERM_ORDER = ("fresnel", "diffuse", "energy", "masking", "clearcoat", "ndf", "anisotropy",
              "composition", "gltf_extensions")
# The order options appear in a canonical model string.
TOKEN_ORDER = ("energy", "clearcoat", "masking", "fresnel", "composition", "anisotropy")


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
    own: OwnModel | None = None      # a model of one's own (brdf/own.py): the other fields are unused

    def __post_init__(self):
        if self.own is not None:
            if not isinstance(self.own, OwnModel):
                raise UnknownModelError(f"own must be a brdf.own.OwnModel, found {type(self.own).__name__}")
            for field in dataclasses.fields(self):      # canonical: every other field at its default
                if field.name != "own":
                    object.__setattr__(self, field.name, "none" if field.name == "diffuse" else field.default)
            return
        if self.composition in FIXED_COMPOSITIONS:       # its own lobes (canonical diffuse: "none")
            object.__setattr__(self, "diffuse", "none")
            if (self.ndf, self.masking, self.energy, self.fresnel, self.clearcoat) != FIXED_TERMS:
                raise UnknownModelError("an openpbr or principled model fixes its terms (GGX, height-correlated "
                                        "Smith, its own Fresnel, diffuse and coat; energy compensation as +mx only)")
        for field, allowed in FIELDS.items():
            value = getattr(self, field)
            if value not in allowed:
                raise UnknownModelError(f"unknown {field} {value!r}; valid: {', '.join(allowed)}")
        for ext in self.gltf_extensions:
            if ext not in GLTF_EXTENSIONS:
                raise UnknownModelError(f"unknown glTF extension {ext!r}; valid: {', '.join(GLTF_EXTENSIONS)}")
        if self.composition == "gltf":
            if {"metal", "nonmetal"} <= set(self.gltf_extensions):
                raise UnknownModelError("'metal' holds metallic at 1 and 'nonmetal' at 0: one of them, not both")
            if "metal" in self.gltf_extensions and set(self.gltf_extensions) & METAL_UNUSED:
                raise UnknownModelError("a glTF metal's Fresnel is its baseColor: "
                                        f"{', '.join(sorted(METAL_UNUSED))} do not apply to 'metal'")
            if {"specular", "tint"} <= set(self.gltf_extensions):
                raise UnknownModelError("'tint' is KHR_materials_specular's colour with its factor held at 1: "
                                        "use 'specular' (factor and colour) or 'tint', not both")
            if self.diffuse != "lambert" or self.fresnel != "schlick" or self.masking != "height_correlated":
                raise UnknownModelError("the gltf model fixes its terms (Lambert, Schlick, height-correlated Smith)")
            if self.energy not in ("none", "turquin"):
                raise UnknownModelError("the glTF BRDF's one energy compensation is the engines' ('turquin', "
                                        "as three.js draws it under direct light): drop 'ms'")
            if self.ndf not in GGX_NDFS:
                raise UnknownModelError("the gltf model's NDF is GGX")
        elif self.gltf_extensions:
            raise UnknownModelError("glTF extensions (ior, specular) only apply to the gltf model")
        if self.lobe_model and (self.masking, self.fresnel, self.composition) != \
                ("height_correlated", "schlick", "additive"):
            raise UnknownModelError(f"{self.ndf} is a whole lobe: it takes no masking, Fresnel or composition "
                                    "option (a diffuse lobe and clearcoat only)")
        if self.energy != "none" and not NDFS[self.ndf].energy_tables:
            raise UnknownModelError(f"energy compensation ('ms', 'turquin') uses GGX's tables: not for {self.ndf}")
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
    def anisotropic(self) -> bool:
        return NDFS[self.ndf].anisotropic

    @property
    def lobe_model(self) -> bool:
        """True for a classic lobe model (brdf/lobes.py): its NDF is the whole specular term."""
        return isinstance(NDFS[self.ndf], Lobe)

    def __str__(self):
        return model_string(self)

    def schema(self) -> tuple[Param, ...]:
        """The parameter schema: a tuple of Param, in a fixed order."""
        return parameter_schema(self)


# glTF options a metal (metallic 1) never draws: fitted beside 'metal' they would be unidentifiable
METAL_UNUSED = frozenset({"ior", "specular", "tint", "diffuse_roughness"})


def terms(spec: ModelSpec) -> tuple[Term, ...]:
    """The Terms ``spec`` is made of (those in use), in TERM_ORDER."""
    if spec.own is not None:
        return (spec.own.term,)
    composition = COMPOSITIONS[spec.composition]
    out = []
    for field in TERM_ORDER:
        if field in ("fresnel", "diffuse") and composition.own_lobes:
            continue
        if field in ("fresnel", "masking") and spec.lobe_model:
            continue
        if field == "clearcoat":
            out += [CLEARCOAT] if spec.clearcoat else []
        elif field == "gltf_extensions":
            out += [GLTF_EXTENSIONS[e] for e in spec.gltf_extensions]
        elif field != "anisotropy" or spec.anisotropic:
            out.append(FIELDS[field][getattr(spec, field)])
    return tuple(out)


def all_terms() -> list[Term]:
    """Every declared Term (of every field)."""
    return ([t for registry in FIELDS.values() for t in registry.values()] + [CLEARCOAT]
            + list(GLTF_EXTENSIONS.values()))


# --- parameter schema -------------------------------------------------------

def parameter_schema(spec: ModelSpec) -> tuple[Param, ...]:
    """Tuple of Param for a ModelSpec (order fixed: it is the fit vector's order).

    The diffuse lobe's (or a composition's own), the NDF's (roughness), the
    glTF extensions', the anisotropy remap's, the Fresnel term's, the clearcoat's.
    """
    if spec.own is not None:
        return spec.own.params
    composition = COMPOSITIONS[spec.composition]
    params = list(composition.params if composition.own_lobes else DIFFUSES[spec.diffuse].params)
    params = [p for p in params if p.name not in held_values(spec)]
    params += NDFS[spec.ndf].params
    params += [p for e in spec.gltf_extensions for p in GLTF_EXTENSIONS[e].params]
    if spec.anisotropic:
        params += ANISOTROPY_REMAPS[spec.anisotropy].params
    if not composition.own_lobes and not spec.lobe_model:
        params += FRESNELS[spec.fresnel].params
    if spec.clearcoat:
        params += CLEARCOAT.params
    return tuple(params)


def held_values(spec: ModelSpec) -> dict[str, float]:
    """{name: value} of the composition's parameters ``spec``'s options hold (``Term.holds``):
    not in its schema, evaluated at that value (glTF's metal: metallic 1)."""
    if not spec.gltf_extensions:
        return {}
    return {name: value for e in spec.gltf_extensions for name, value in GLTF_EXTENSIONS[e].holds}


def default_params(spec: ModelSpec, dtype: DTypeLike | None = None) -> dict[str, Float[Array, "*channels"]]:
    """{name: array} with every parameter at its schema default."""
    return {p.name: jnp.full((3,) if p.size == 3 else (), p.default, dtype=dtype)
            for p in parameter_schema(spec)}


def check_params(spec: ModelSpec, params: Mapping[str, object]) -> None:
    """Raise ValueError if ``params`` lacks a schema entry or has a foreign one."""
    names = [p.name for p in parameter_schema(spec)]
    missing = [n for n in names if n not in params]
    extra = [n for n in params if n not in names]
    if missing or extra:
        raise ValueError(f"parameters for {model_string(spec)}: missing {missing}, unexpected {extra}")


# --- model strings ----------------------------------------------------------

MODEL_EXAMPLES = (
    "ggx+lambert", "ggx+burley", "ggx+frostbite", "ggx+cod_wwii", "ggx+oren_nayar",
    "ggx+lambert+ms", "ggx+lambert+coupled", "ggx+lambert+clearcoat",
    "ggx_aniso+lambert", "ggx_aniso+cod_wwii+ms+clearcoat",
    "ggx+lambert+dielectric", "ggx+conductor", "ggx+lambert+turquin",
    "gltf", "gltf+ior", "gltf+specular", "gltf+clearcoat", "gltf+aniso", "gltf+diffuse_roughness", "gltf+sheen",
    "gltf+nonmetal+ior+tint+clearcoat", "gltf+metal+clearcoat", "gltf+metal+turquin",
    "gltf+nonmetal+ior+turquin+clearcoat",
    "beckmann+lambert", "beckmann+burley+clearcoat", "beckmann+lambert+separable",
    "beckmann_aniso+lambert", "beckmann+lambert+vgroove",
    "blinn_phong+lambert", "phong+lambert", "ward+lambert", "ward_duer+lambert", "blinn_phong+burley+clearcoat",
    "ashikhmin_shirley+lambert", "ashikhmin_shirley_scaled+lambert", "ward_aniso+lambert", "lafortune+lambert",
    "blinn_phong_mf+lambert", "phong_mf+lambert",   # every openpbr and principled model (principled+metal: openpbr's)
    *(f"{head}+{o}" for head, models in FIXED_HEADS.items() for o in models if o != "metal" or head == "openpbr"))


def _diffuse_tokens():
    return {t.token: name for name, t in DIFFUSES.items() if t.token}


def _option_tokens():
    """{token: (field, value)} of the ggx options, in canonical-string order."""
    out = {}
    for field in TOKEN_ORDER:
        if field == "clearcoat":
            out[CLEARCOAT.token] = ("clearcoat", True)
        else:
            out.update({t.token: (field, name) for name, t in FIELDS[field].items() if t.token})
    return out


def _gltf_tokens():
    """{token: extension or None} of the gltf options (aniso: the NDF, clearcoat: the layer)."""
    return {**{t.token: name for name, t in GLTF_EXTENSIONS.items()}, ENERGIES["turquin"].token: None, "aniso": None,
            CLEARCOAT.token: None}


def _quoted(text, limit=60):
    """repr of user text, cut to ``limit`` characters (a 100 000-character string is not echoed)."""
    text = str(text)
    return repr(text) if len(text) <= limit else repr(text[:limit]) + f"... ({len(text):,} characters)"


def parse_model(text: ModelSpec | OwnModel | str) -> ModelSpec:
    """Model string -> ModelSpec; unknown names raise UnknownModelError listing valid ones.
    An OwnModel (brdf/own.py), or ``own:NAME`` of a registered one, gives its ModelSpec."""
    if isinstance(text, ModelSpec):
        return text
    if isinstance(text, OwnModel):       # registered: own:NAME (its results' model string) names it
        return ModelSpec(own=register(text))
    if str(text).strip().lower().startswith(OWN_PREFIX):
        try:
            return ModelSpec(own=lookup(str(text).strip()[len(OWN_PREFIX):]))
        except ValueError as err:
            raise UnknownModelError(str(err)) from None
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
        return _parse_gltf(text, options)
    if head in FIXED_HEADS:     # a base, coated or not (brdf/openpbr.py, brdf/openpbr_coat.py, brdf/principled.py)
        if (composition := fixed_composition(head, options)) is None:
            raise UnknownModelError(f"{_quoted(text)}: a model of {head} is one of: "
                                    + ", ".join(f"{head}+{tok}" for tok in FIXED_HEADS[head]))
        return ModelSpec(composition=composition)
    if head not in NDFS:
        raise UnknownModelError(
            f"unknown model {_quoted(head, 30)} in {_quoted(text)}; a model string starts with "
            f"{', '.join(NDFS)}, gltf, openpbr or principled "
            f"(examples: {', '.join(MODEL_EXAMPLES[:6])}; `brdf-fit models` lists all)")
    diffuse_tokens, option_tokens = _diffuse_tokens(), _option_tokens()
    kwargs = {"ndf": head, "diffuse": "none"}
    for tok in options:
        if tok in diffuse_tokens:
            if kwargs["diffuse"] != "none":
                raise UnknownModelError(f"two diffuse lobes in {_quoted(text)}")
            kwargs["diffuse"] = diffuse_tokens[tok]
        elif tok in option_tokens:
            field, value = option_tokens[tok]
            if field in kwargs:
                raise UnknownModelError(f"conflicting options for {field} in {_quoted(text)}")
            kwargs[field] = value
        else:
            valid = list(diffuse_tokens) + list(option_tokens)
            raise UnknownModelError(f"unknown option {_quoted(tok, 30)} in {_quoted(text)}; valid: {', '.join(valid)}")
    if ANISOTROPY_REMAPS[kwargs.get("anisotropy", "kulla_conty")].token and not NDFS[head].anisotropic:
        raise UnknownModelError(f"{ANISOTROPY_REMAPS[kwargs['anisotropy']].token} needs an anisotropic NDF "
                                f"({', '.join(n for n, t in NDFS.items() if t.anisotropic)})")
    return ModelSpec(**kwargs)


def _parse_gltf(text, options):
    gltf_tokens = _gltf_tokens()
    kwargs = {"composition": "gltf"}
    exts, aniso = [], False
    for tok in options:
        if tok not in gltf_tokens:
            raise UnknownModelError(
                f"unknown option {_quoted(tok, 30)} for gltf in {_quoted(text)}; valid: {', '.join(gltf_tokens)}")
        if tok == "aniso":
            aniso = True
        elif tok == ENERGIES["turquin"].token:         # the engines' reading (brdf/gltf.py)
            kwargs["energy"] = "turquin"
        elif tok == CLEARCOAT.token:
            kwargs["clearcoat"] = True
        else:
            exts.append(gltf_tokens[tok])
    if aniso:
        kwargs.update(ndf="ggx_aniso", anisotropy="gltf")
    kwargs["gltf_extensions"] = tuple(e for e in GLTF_EXTENSIONS if e in exts)
    return ModelSpec(**kwargs)


def model_string(spec: ModelSpec) -> str:
    """The canonical model string of a spec (parse_model(model_string(s)) == s)."""
    if spec.own is not None:
        return spec.own.model_string
    if spec.composition == "gltf":
        parts = ["gltf"] + [GLTF_EXTENSIONS[e].token for e in spec.gltf_extensions]
        if spec.energy == "turquin":
            parts.append(ENERGIES["turquin"].token)
        if spec.anisotropic:
            parts.append("aniso")
        if spec.clearcoat:
            parts.append(CLEARCOAT.token)
        return "+".join(parts)
    if spec.composition in FIXED_COMPOSITIONS:
        return fixed_model_string(spec.composition)
    parts = [spec.ndf]
    if DIFFUSES[spec.diffuse].token:
        parts.append(DIFFUSES[spec.diffuse].token)
    for tok, (field, value) in _option_tokens().items():
        if getattr(spec, field) == value:
            parts.append(tok)
    return "+".join(parts)
