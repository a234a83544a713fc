"""A fit as a MaterialX 1.39 document: ``gltf_pbr`` and ``open_pbr_surface`` (docs/materialx.md).

Pure functions of a glTF conversion (brdf.gltf_material.convert): no file
I/O, no MaterialX library (the XML is written with the standard library;
the tests validate it with MaterialX's own).  The input names and defaults
are those of the node definitions shipped with MaterialX 1.39
(libraries/bxdf/gltf_pbr.mtlx, ``ND_gltf_pbr_surfaceshader``;
open_pbr_surface.mtlx, ``ND_open_pbr_surface_surfaceshader``).

1. ``gltf_pbr`` is the glTF material as a MaterialX node: every parameter of
   the conversion's gltf model is written to the input of its glTF key
   (``GLTF_PBR_INPUTS``, keyed by the parameters' declared ``GltfKey``), the
   same value (a periodic one, the anisotropy rotation, wrapped to
   [0, period) as the node's UI range asks).
2. ``open_pbr_surface`` is an alternative for look development: the same
   glTF values re-expressed for OpenPBR (``open_pbr_inputs``).  Anisotropy
   and roughness convert exactly (in alpha); the Fresnel curves, the layering
   and the coat are OpenPBR's own, and each difference is named in its notes.
   A fit of OpenPBR's own metal or non-metal (``openpbr+metal``,
   ``openpbr+nonmetal``, brdf/openpbr.py), bare or ``+coat``, is written 1:1 instead
   (``native``: brdf.openpbr_coat.open_pbr_surface_inputs).
"""

import math
import re
import xml.etree.ElementTree as ET

import numpy as np

from .constants import F0_DIELECTRIC, IOR_DEFAULT
from .declare import CORE
from .fresnel import f0_from_ior, ior_from_f0
from .spec import parse_model

MATERIALX_VERSION = "1.39"
COLORSPACE = "lin_rec709"          # the toolkit's linear sRGB (docs/colour.md)

# glTF key (owner, key) of a parameter's declaration -> the gltf_pbr input it is
GLTF_PBR_INPUTS = {
    (CORE, "baseColorFactor"): "base_color",
    (CORE, "metallicFactor"): "metallic",
    (CORE, "roughnessFactor"): "roughness",
    ("KHR_materials_ior", "ior"): "ior",
    ("KHR_materials_specular", "specularFactor"): "specular",
    ("KHR_materials_specular", "specularColorFactor"): "specular_color",
    ("KHR_materials_anisotropy", "anisotropyStrength"): "anisotropy_strength",
    ("KHR_materials_anisotropy", "anisotropyRotation"): "anisotropy_rotation",
    ("KHR_materials_clearcoat", "clearcoatFactor"): "clearcoat",
    ("KHR_materials_clearcoat", "clearcoatRoughnessFactor"): "clearcoat_roughness",
    ("KHR_materials_sheen", "sheenColorFactor"): "sheen_color",
    ("KHR_materials_sheen", "sheenRoughnessFactor"): "sheen_roughness",
}
# glTF keys gltf_pbr (1.39) has no input for: the open_pbr_surface input each is written to
OPEN_PBR_ONLY = {
    ("KHR_materials_diffuse_roughness", "diffuseRoughnessFactor"): "base_diffuse_roughness",
}

# every glTF value the toolkit writes: the defaults of the missing ones come from here
FULL_GLTF_MODEL = "gltf+ior+specular+diffuse_roughness+sheen+aniso+clearcoat"

# what a MaterialX renderer of gltf_pbr does differently from glTF's Appendix B
GLTF_PBR_NOTES = ("MaterialX's gltf_pbr graph layers its lobes by directional albedo (layer/mix nodes) "
                  "and its generated GLSL adds GGX energy compensation; the M1 reported is that of "
                  "glTF's own BRDF with these values",)
# what gltf_pbr draws differently for KHR_materials_sheen (added when the model has it)
GLTF_PBR_SHEEN_NOTE = ("gltf_pbr's sheen is MaterialX's sheen_bsdf (mode conty_kulla: Charlie's D with its own "
                       "visibility and albedo table), layered by 1 - max(sheenColor) E(n.v) alone; glTF's "
                       "(brdf.sheen) takes min over n.v and n.l")

# gltf_pbr's own implementation graph turns the tangent by anisotropy_rotation
# (radians) with rotate3d(tangent, amount = rotation x this, axis = normal); the
# OpenPBR tangent graph repeats it so both materials point the same way
GLTF_PBR_ROTATE3D_DEGREES_PER_RADIAN = -57.295780

OPEN_PBR_F0_MAX = 0.99999          # OpenPBR's own clamp of the dielectric F0
BISECTION_STEPS = 60

Value = float | list[float]


def gltf_values(conversion: dict) -> dict[str, Value]:
    """Every glTF value (the full gltf model's parameters) of a conversion:
    its own parameters, the declared glTF defaults (``GltfKey.default``) for the rest."""
    out = {}
    for param in parse_model(FULL_GLTF_MODEL).schema():
        value = conversion["parameters"].get(param.name, param.gltf.default)
        out[param.name] = [float(c) for c in np.broadcast_to(value, (3,))] if param.size == 3 else float(value)
    return out


def gltf_pbr_inputs(conversion: dict) -> dict[str, Value]:
    """{gltf_pbr input: value}: each parameter of the conversion's gltf model at
    the input of its glTF key (but those of ``OPEN_PBR_ONLY``); a periodic parameter
    wrapped to [0, period)."""
    inputs = {}
    for param in parse_model(conversion["model"]).schema():
        if (param.gltf.owner, param.gltf.key) in OPEN_PBR_ONLY:
            continue
        value = conversion["parameters"][param.name]
        if param.size == 3:
            value = [float(c) for c in value]
        else:
            value = float(value)
            if param.period:
                value = float(np.mod(value, param.period))
        inputs[GLTF_PBR_INPUTS[(param.gltf.owner, param.gltf.key)]] = value
    return inputs


def _coat_roughened(roughness: float, coat: float, coat_roughness: float) -> float:
    """OpenPBR's base roughness under its coat: mix(r, min(1, 2 r_c^4 + r^4)^(1/4), coat)."""
    under = min(1.0, 2.0 * coat_roughness ** 4 + roughness ** 4) ** 0.25
    return (1.0 - coat) * roughness + coat * under


def _uncoat_roughness(target: float, coat: float, coat_roughness: float) -> tuple[float, bool]:
    """(r, exact): the specular_roughness OpenPBR roughens to ``target`` under the coat
    (bisection: the roughening is increasing in r); exact False when target is below reach."""
    if _coat_roughened(0.0, coat, coat_roughness) > target:
        return 0.0, False
    lo, hi = 0.0, target
    for _ in range(BISECTION_STEPS):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _coat_roughened(mid, coat, coat_roughness) < target else (lo, mid)
    return 0.5 * (lo + hi), True


def _uncoat_ior(eta: float, coat: float, coat_ior: float) -> tuple[float, bool]:
    """(specular_ior, exact): OpenPBR uses eta_s = mix(specular_ior, specular_ior / coat_ior,
    coat) for the base under its coat (when specular_ior > coat_ior); this is the
    specular_ior whose eta_s is ``eta``.  Not exact (``eta`` returned) when that
    specular_ior would not exceed coat_ior."""
    ior = eta / (1.0 - coat + coat / coat_ior)
    return (ior, True) if ior > coat_ior else (eta, False)


def open_pbr_inputs(conversion: dict) -> tuple[dict[str, Value], float, list[str]]:
    """(inputs, tangent rotation in radians, notes): the glTF values for OpenPBR.

    base_color, base_metalness = baseColor, metallic; base_diffuse_roughness =
    KHR_materials_diffuse_roughness's factor (0, Lambert, without it: both draw EON).
    Dielectric specular: glTF's F0 per channel is t x specular with t = min(F0(ior)
    specularColor, 1); OpenPBR gets specular_ior with F0 = max t and specular_color =
    specular x t / max t (its tint scales the whole Fresnel curve, so F0 is glTF's
    and F90 = specular in the largest channel).  Roughness: (alpha_t, alpha_b) of glTF's anisotropy
    -> specular_roughness = ((alpha_t^2 + alpha_b^2) / 2)^(1/4),
    specular_roughness_anisotropy = 1 - alpha_b / alpha_t (OpenPBR's
    open_pbr_anisotropy gives them back); the rotation turns the tangent.
    Coat: coat_weight, coat_roughness = clearcoat, clearcoat roughness,
    coat_ior of F0 0.04, coat_darkening 0, and the base's roughness and IOR
    compensated for OpenPBR's coupling of base and coat.  KHR_materials_sheen: fuzz_weight
    = max sheenColor, fuzz_color = sheenColor / max, fuzz_roughness = sheenRoughness (as
    MaterialX's own gltf_pbr graph splits the colour for its sheen_bsdf), with a note: the
    lobe (Zeltner et al. 2022's LTC sheen, not Charlie) and the layer order differ.
    """
    g = gltf_values(conversion)
    notes = []
    metallic, specular = g["metallic"], g["specular"]
    inputs = {"base_weight": 1.0, "base_color": g["base_color"], "base_metalness": metallic,
              "base_diffuse_roughness": g["diffuse_roughness"], "specular_weight": 1.0}

    # dielectric Fresnel: glTF's F0 = t x specular, F90 = specular
    t = np.minimum(f0_from_ior(g["ior"]) * np.asarray(g["specular_color"]), 1.0)
    t_max = float(np.max(t))
    if metallic >= 1.0:                           # the dielectric is not seen: OpenPBR's defaults
        eta, color = g["ior"], np.ones(3)
    elif t_max <= 0.0:
        eta, color = 1.0, np.full(3, specular)
        notes.append("glTF's F0 is 0: OpenPBR's dielectric (IOR 1) reflects nothing, even at grazing "
                     f"angles where glTF's goes to {specular:.4g}")
    else:
        if t_max > OPEN_PBR_F0_MAX:
            notes.append(f"glTF's F0 {t_max:.6g} clipped to OpenPBR's maximum {OPEN_PBR_F0_MAX}")
        eta = float(ior_from_f0(min(t_max, OPEN_PBR_F0_MAX), xp=np))
        color = specular * t / t_max
        notes.append(f"OpenPBR's dielectric Fresnel is the exact one of IOR {eta:.4g}; glTF's is Schlick "
                     f"with the same F0 ({_fmt(t * specular)}): equal at normal incidence, different "
                     "towards grazing angles")
        if float(np.max(t) - np.min(t)) > 0.0:
            notes.append(f"specular_color {_fmt(color)} tints OpenPBR's whole dielectric Fresnel curve "
                         f"(F90 = {_fmt(color)}); glTF's colour acts on F0 only (F90 = {specular:.4g})")
        if float(np.max(g["base_color"])) > 0.0:
            notes.append("OpenPBR weights the diffuse base by the specular layer's directional albedo; "
                         "glTF by 1 - max F(v.h)")
        if metallic > 0.0 and np.any(color != 1.0):
            notes.append(f"metallic {metallic:.4g}: specular_color {_fmt(color)} is also the F82 tint "
                         "of OpenPBR's metal, which glTF's metal does not have")
    inputs["specular_color"] = [float(c) for c in color]

    # roughness: the alpha pair of glTF's anisotropy, exactly
    alpha_b = g["roughness"] ** 2
    alpha_t = alpha_b + (1.0 - alpha_b) * g["anisotropy"] ** 2
    if g["anisotropy"] > 0.0 and alpha_t > 0.0:
        roughness = ((alpha_t ** 2 + alpha_b ** 2) / 2.0) ** 0.25
        inputs["specular_roughness_anisotropy"] = 1.0 - alpha_b / alpha_t
        rotation = gltf_pbr_inputs(conversion)["anisotropy_rotation"]      # the same angle as gltf_pbr's
    else:
        roughness, rotation = g["roughness"], 0.0

    coat = g["clearcoat"]
    if coat > 0.0:
        coat_ior = IOR_DEFAULT                # glTF's coat: F0_DIELECTRIC = F0 of IOR 1.5
        inputs.update(coat_weight=coat, coat_roughness=g["clearcoat_roughness"], coat_ior=coat_ior,
                      coat_color=[1.0, 1.0, 1.0], coat_darkening=0.0)
        notes.append(f"coat: OpenPBR's exact Fresnel of IOR {coat_ior:.4g} and albedo-based layering; "
                     f"glTF's Schlick {F0_DIELECTRIC:g} + {1 - F0_DIELECTRIC:g} (1 - n.v)^5 weight; "
                     "coat_darkening 0 (glTF's coat does not darken the base)")
        roughness_in, exact = _uncoat_roughness(roughness, coat, g["clearcoat_roughness"])
        reached = _coat_roughened(roughness_in, coat, g["clearcoat_roughness"])
        if exact:
            notes.append(f"specular_roughness {roughness_in:.6g}: OpenPBR roughens the base under its "
                         f"coat, to glTF's {roughness:.6g}")
        else:
            notes.append(f"OpenPBR roughens the base under the coat to at least {reached:.4g}; "
                         f"glTF's is {roughness:.4g}")
        roughness = roughness_in
        if metallic < 1.0 and eta > 1.0:
            eta_in, exact = _uncoat_ior(eta, coat, coat_ior)
            if exact:
                notes.append(f"specular_ior {eta_in:.6g}: under its coat OpenPBR uses the IOR relative "
                             f"to the coat's, which is then {eta:.6g}, glTF's F0 (glTF's base ignores the coat)")
            else:
                notes.append(f"under the coat OpenPBR's base IOR is relative to the coat's ({coat_ior:.4g}): "
                             "its base F0 is lower than glTF's, which ignores the coat")
            eta = eta_in
    inputs.update(specular_roughness=roughness, specular_ior=eta)
    inputs.update(_fuzz(g, notes))
    return inputs, rotation, notes


def _fuzz(g: dict, notes: list[str]) -> dict[str, Value]:
    """open_pbr_surface's fuzz inputs for KHR_materials_sheen's values ({} without a sheen),
    the differences appended to ``notes``."""
    color = np.asarray(g["sheen_color"], np.float64)
    weight = float(np.max(color))
    if weight <= 0.0:
        return {}
    notes.append(f"fuzz: fuzz_weight {weight:.4g} and fuzz_color {_fmt(color / weight)} (glTF's sheenColor "
                 f"{_fmt(color)}), fuzz_roughness = sheenRoughness {g['sheen_roughness']:.4g}; OpenPBR's fuzz "
                 "lobe is Zeltner et al. 2022's (MaterialX sheen_bsdf mode 'zeltner'), not glTF's Charlie "
                 "sheen, its roughness is not on the same scale, and it lies over the coat where glTF's "
                 "coat lies over the sheen")
    return {"fuzz_weight": weight, "fuzz_color": [float(c) for c in color / weight],
            "fuzz_roughness": float(g["sheen_roughness"])}


def _fmt(v):
    return "(" + ", ".join(f"{x:.4g}" for x in np.asarray(v, np.float64)) + ")"


# --- the XML ----------------------------------------------------------------------

def valid_name(name: str) -> str:
    """A MaterialX element name from any text: letters, digits and underscores."""
    return re.sub(r"[^A-Za-z0-9_]", "_", str(name)) or "material"


def value_string(value: Value | bool) -> str:
    """A MaterialX value string: "0.5", "0.3, 0.2, 0.1", "true"; finite numbers only."""
    if isinstance(value, bool):
        return "true" if value else "false"
    values = value if isinstance(value, list) else [value]
    if not all(math.isfinite(v) for v in values):
        raise ValueError(f"a MaterialX value must be finite, got {values}")
    return ", ".join(repr(float(v)) for v in values)


def value_type(value: Value | bool) -> str:
    """The MaterialX type of a value: boolean, color3 (an RGB list) or float."""
    if isinstance(value, bool):
        return "boolean"
    return "color3" if isinstance(value, list) else "float"


def _shader(root, category, name, inputs, doc):
    node = ET.SubElement(root, category, name=name, type="surfaceshader", doc=doc)
    for key, value in inputs.items():
        ET.SubElement(node, "input", name=key, type=value_type(value), value=value_string(value))
    return node


def _material(root, name, shader, attributes, doc):
    mat = ET.SubElement(root, "surfacematerial", name=name, type="material", doc=doc,
                        **{f"brdf_fit_{k}": v for k, v in attributes.items()})
    ET.SubElement(mat, "input", name="surfaceshader", type="surfaceshader", nodename=shader)
    return mat


def _tangent_graph(root, name, rotation):
    """A nodegraph: the world tangent turned about the normal as gltf_pbr's graph does."""
    graph = ET.SubElement(root, "nodegraph", name=name)
    for category, node in (("tangent", "tangent"), ("normal", "normal")):
        ET.SubElement(ET.SubElement(graph, category, name=node, type="vector3"),
                      "input", name="space", type="string", value="world")
    rotate = ET.SubElement(graph, "rotate3d", name="rotated_tangent", type="vector3")
    ET.SubElement(rotate, "input", name="in", type="vector3", nodename="tangent")
    ET.SubElement(rotate, "input", name="amount", type="float",
                  value=value_string(rotation * GLTF_PBR_ROTATE3D_DEGREES_PER_RADIAN))
    ET.SubElement(rotate, "input", name="axis", type="vector3", nodename="normal")
    norm = ET.SubElement(graph, "normalize", name="out_tangent", type="vector3")
    ET.SubElement(norm, "input", name="in", type="vector3", nodename="rotated_tangent")
    ET.SubElement(graph, "output", name="out", type="vector3", nodename="out_tangent")


def _text(value):
    return repr(float(value)) if isinstance(value, (float, np.floating)) else str(value)


def _native_notes(spec: str | None, native: dict[str, Value]) -> list[str]:
    """What a 1:1 open_pbr_surface of a fit of OpenPBR's own BRDF (brdf/openpbr.py) says."""
    mx = spec is not None and "mx" in str(spec).split("+")       # MaterialX's reading (brdf/openpbr_coat.py)
    notes = [f"fitted with OpenPBR's own BRDF ({spec or 'openpbr'}): written 1:1; MaterialX's generated GLSL "
             + ("draws it as fitted, its GGX energy compensation included (+mx)" if mx else
                "adds its GGX energy compensation, which the fit leaves out")]
    if native["base_metalness"] == 0.0 and native["base_diffuse_roughness"] > 0.0:
        notes.append("MaterialX's generated GLSL draws EON with l.v clamped to 1e-8 or above and Fujii's exact albedo; "
                     "the fit's EON is the paper's (they differ where l.v < 0)")
    return notes


def _gltf_pbr_material(root, base, conversion, summary, attributes, out):
    """The gltf_pbr shader and material of a conversion, their inputs and notes added to ``out``."""
    gltf_inputs = gltf_pbr_inputs(conversion)
    shader, material = f"SR_{base}_gltf_pbr", f"M_{base}_gltf_pbr"
    _shader(root, "gltf_pbr", shader, gltf_inputs, f"{summary}; the glTF values 1:1")
    _material(root, material, shader, attributes, f"{summary}; glTF's material model (gltf_pbr)")
    out["materials"][material] = "gltf_pbr"
    out["gltf_pbr"] = gltf_inputs
    dropped = [p for p in parse_model(conversion["model"]).schema() if (p.gltf.owner, p.gltf.key) in OPEN_PBR_ONLY]
    out["notes"]["gltf_pbr"] = list(GLTF_PBR_NOTES) + [
        f"gltf_pbr has no input for {p.gltf.key} ({conversion['parameters'][p.name]:.4g}): its base is Lambert's; "
        "open_pbr_surface carries it" for p in dropped]
    if "sheen" in parse_model(conversion["model"]).gltf_extensions:
        out["notes"]["gltf_pbr"].append(GLTF_PBR_SHEEN_NOTE)


def materialx_document(conversion: dict, name: str = "material",
                       provenance: dict[str, object] | None = None,
                       open_pbr: bool = True, native: dict[str, Value] | None = None,
                       gltf_pbr: bool = True) -> dict[str, object]:
    """The MaterialX document of a glTF conversion, as XML text and its parts.

    ``provenance``: {key: value} written on every material as the attribute
    ``brdf_fit_<key>`` (declared with an attributedef), e.g. spec, m1, source.
    Returns {"xml": str, "materials": {material name: shader category},
    "gltf_pbr": inputs, "open_pbr_surface": inputs or None,
    "notes": {shader category: [sentences]}}.  ``native``: the open_pbr_surface inputs of a
    fit of OpenPBR's own BRDF (brdf.openpbr_coat.open_pbr_surface_inputs), written as they are;
    with it, ``gltf_pbr`` False writes that material alone (``export --format openpbr``).
    """
    if not gltf_pbr and native is None:
        raise ValueError("a document without gltf_pbr is a 1:1 open_pbr_surface: native inputs needed")
    base = valid_name(name)
    attributes = {valid_name(k): _text(v) for k, v in (provenance or {}).items() if v is not None}
    summary = (f"brdf-fit: {provenance.get('spec')} fit" if provenance and provenance.get("spec")
               else "brdf-fit fit") + (f", as glTF {conversion['model']} ({conversion['kind']})" if gltf_pbr else "")
    root = ET.Element("materialx", version=MATERIALX_VERSION, colorspace=COLORSPACE)
    for key in attributes:
        ET.SubElement(root, "attributedef", name=f"AD_brdf_fit_{key}", attrname=f"brdf_fit_{key}",
                      type="string", elements="surfacematerial")
    out = {"materials": {}, "notes": {}, "open_pbr_surface": None, "gltf_pbr": None}
    if gltf_pbr:
        _gltf_pbr_material(root, base, conversion, summary, attributes, out)
    if open_pbr or not gltf_pbr:
        inputs, rotation, notes = open_pbr_inputs(conversion) if native is None else (
            native, 0.0, _native_notes(provenance.get("spec") if provenance else None, native))
        shader, material = f"SR_{base}_open_pbr", f"M_{base}_open_pbr"
        node = _shader(root, "open_pbr_surface", shader, inputs, f"{summary}; OpenPBR "
                       + ("1:1" if native is not None else "approximation (docs/materialx.md)"))
        if rotation != 0.0:
            graph = f"NG_{base}_open_pbr_tangent"
            _tangent_graph(root, graph, rotation)
            ET.SubElement(node, "input", name="geometry_tangent", type="vector3", nodegraph=graph, output="out")
        _material(root, material, shader, attributes,
                  f"{summary}; OpenPBR " + ("1:1" if native is not None else "approximation"))
        out["materials"][material] = "open_pbr_surface"
        out["open_pbr_surface"] = inputs
        out["notes"]["open_pbr_surface"] = notes

    ET.indent(root, space="  ")
    out["xml"] = '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"
    return out
