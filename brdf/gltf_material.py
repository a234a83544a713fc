"""A fit as a glTF 2.0 material: the conversion (docs/gltf.md) and the material JSON.

Pure functions of (model, parameters), in numpy float64, reading the model
declarations: each term's ``gltf`` rule says what it gives the material (the
diffuse albedo, F0 and F90) or what is approximated (its note), each glTF
parameter's ``gltf`` key where it lives in the material.  The formulas are
the models' own (brdf.fresnel's F0 <-> IOR, brdf.specular's roughness clamp
and anisotropy remaps, the rotation's period), called with ``xp=numpy``.

1. ``roughnessFactor = sqrt(alpha)`` (the fitted perceptual roughness).
2. Metal -- Fresnel F0 high (max >= ``METAL_F0_MIN``) and the diffuse albedo
   negligible beside it (max rho_d <= ``METAL_DIFFUSE_RATIO`` x max F0), or
   a conductor Fresnel without a diffuse lobe: ``metallic = 1``,
   ``baseColor = F0`` (glTF metals use Schlick with F90 = 1).
3. Dielectric, achromatic F0 (spread <= ``ACHROMATIC_TOLERANCE``):
   ``metallic = 0``, ``KHR_materials_ior`` with ``ior = (1 + sqrt F0) /
   (1 - sqrt F0)`` (0.04 -> 1.5, 0.05 -> 1.576, 0.08 -> 1.789), and
   ``baseColor = rho_d / (1 - F0)``, the first-order correction for the
   glTF diffuse weight (1 - max F).  A composition whose diffuse is already
   weighted by 1 - F (*coupled*) keeps ``baseColor = rho_d (1 - F0) / (1 -
   max F0)``, which is exact for achromatic F0.
4. Dielectric, chromatic F0: ``KHR_materials_specular`` with the IOR chosen so
   that F0(ior) = max F0 and ``specularColorFactor = F0 / F0(ior)`` (so the
   factor stays <= 1, docs/gltf.md, dielectric kinds), ``specularFactor = 1``.
   A fitted F90 < 1 (``+f90``) becomes ``specularFactor = F90`` (glTF scales
   F0 and F90 together), with the colour divided accordingly.
5. Intermediate metallic is never produced from a non-glTF fit.
6. Anisotropy from (alpha_t, alpha_b) -- the fit's remap of (alpha,
   anisotropy): ``roughness = sqrt(alpha_b)``, ``anisotropyStrength =
   sqrt((alpha_t - alpha_b) / (1 - alpha_b))``, ``anisotropyRotation`` = the
   tangent angle (+ pi/2 when the fit's lobe is wider along the bitangent).

Fits of a ``gltf`` model map 1:1 (lossless), and so do the parameters that
are glTF values themselves (the clearcoat's).  What glTF cannot carry is
dropped and named in the notes (the terms' ``gltf`` rules).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from .constants import ALPHA_MIN, IOR_DEFAULT
from .declare import CORE
from .fresnel import f0_from_ior, ior_from_f0
from .model import roughness_alpha
from .spec import (ANISOTROPY_REMAPS, COMPOSITIONS, GLTF_EXTENSIONS, ModelSpec, held_values, model_string,
                   parse_model, terms)
from .specular import ROTATION

if TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import ArrayLike

METAL_F0_MIN = 0.2             # no common dielectric reaches F0 = 0.2 (diamond: 0.17)
METAL_DIFFUSE_RATIO = 0.1      # "rho_d ~ 0": at most a tenth of the specular F0
ACHROMATIC_TOLERANCE = 0.1     # (max F0 - min F0) <= 10 % of max F0 (+ 0.001) is grey
# Plain values where extremes draw the same (an artist reads and edits the material):
IOR_PLAIN_MAX = 3.0            # a dielectric F0 above F0(3) = 0.25 is carried by specularColorFactor (> 1, as
                               # KHR_materials_specular allows), not by an ior of millions
SPECULAR_NEGLIGIBLE = 1e-4     # F0 and F90 below this reflect nothing visible: specular written as 0, with the
                               # ior and specular colour it then leaves unused at their defaults


class GltfConversion(dict):
    """The glTF form of a fit: a dict with

    model       the brdf model string of the glTF BRDF ("gltf", "gltf+ior+clearcoat", ...);
                None for a model of one's own (brdf/own.py): no material, its note says so
    parameters  that model's parameters ({name: float or [r, g, b]})
    kind        "lossless" (a gltf fit), "metal", "dielectric", "dielectric-chromatic"
                or "unavailable"
    lossless    True when the glTF BRDF equals the fitted model exactly
    notes       what was approximated or dropped (list of sentences)
    """


def _rgb(x):
    return np.broadcast_to(np.asarray(x, dtype=np.float64), (3,)).copy()


def _fmt(v):
    v = np.atleast_1d(np.asarray(v, dtype=np.float64))
    return "(" + ", ".join(f"{x:.4g}" for x in v) + ")" if v.size > 1 else f"{v[0]:.4g}"


def _plain(v):
    return [float(x) for x in v] if isinstance(v, (list, tuple, np.ndarray)) and np.ndim(v) else float(v)


def anisotropy_to_gltf(alpha_t: float, alpha_b: float, rotation: float) -> tuple[float, float, float, bool]:
    """(alpha_t, alpha_b, rotation) -> (roughness, strength, rotation, clipped).

    docs/gltf.md, roughness and anisotropy: roughness = sqrt(alpha_b), strength =
    sqrt((alpha_t - alpha_b) / (1 - alpha_b)); if alpha_t < alpha_b the axes
    are exchanged and the direction turned by pi/2.  ``clipped`` is True when
    alpha_t > 1 (glTF's strength 1 reaches alpha_t = 1 only).
    """
    alpha_t = max(float(alpha_t), ALPHA_MIN)
    alpha_b = max(float(alpha_b), ALPHA_MIN)
    if alpha_t < alpha_b:
        alpha_t, alpha_b = alpha_b, alpha_t
        rotation = rotation + np.pi / 2
    alpha_b = min(alpha_b, 1.0)
    ratio = (alpha_t - alpha_b) / (1.0 - alpha_b) if alpha_b < 1.0 else 0.0
    clipped = ratio > 1.0
    strength = float(np.sqrt(min(max(ratio, 0.0), 1.0)))
    return float(np.sqrt(alpha_b)), strength, float(ROTATION.wrap(rotation)), clipped


def convert(spec: ModelSpec | str, params: dict[str, float | list[float] | ArrayLike]) -> GltfConversion:
    """Fit (model string or ModelSpec, {name: value}) -> GltfConversion (docs/gltf.md)."""
    spec = parse_model(spec)
    if spec.own is not None:        # a model of one's own: no glTF material (brdf/own.py)
        return GltfConversion(model=None, parameters={}, kind="unavailable", lossless=False,
                              notes=[spec.own.term.gltf.note.format(name=model_string(spec))])
    if spec.composition == "gltf":       # the glTF BRDF itself
        # metal and nonmetal are the glTF model with metallic held: written as its value
        held = held_values(spec)
        plain = dataclasses.replace(spec, gltf_extensions=tuple(e for e in spec.gltf_extensions
                                                                 if not GLTF_EXTENSIONS[e].holds))
        parameters = {k: _plain(v) for k, v in {**held, **params}.items()}
        if {"ior", "tint"} <= set(spec.gltf_extensions):     # F0(ior) x tint: one F0, many pairs
            f0 = np.minimum(float(f0_from_ior(parameters["ior"])) * _rgb(parameters["specular_color"]), 1.0)
            ior, color = _plain_ior(float(np.max(f0)), f0)
            parameters.update(ior=ior, specular_color=_plain(np.minimum(color, 1.0)))
        notes = ["fitted with the glTF BRDF itself: exported 1:1"]
        if spec.energy == "turquin":
            notes.append("fitted in the engines' reading (+turquin: their multiple scattering, not in the file)")
        return GltfConversion(model=model_string(plain),
                              parameters={q.name: parameters[q.name] for q in plain.schema()},
                              kind="lossless", lossless=True, notes=notes)
    p = {k: np.asarray(v, np.float64) if np.ndim(v) else float(v) for k, v in params.items()}
    # each term's share -- rho_d (None: no diffuse lobe), F0, F90 -- and its note if approximated
    quantities, notes = {"rho": None, "f90": 1.0, "conductor": False}, []
    for term in terms(spec):
        given = term.gltf.quantities(p) if term.gltf.quantities else {}
        quantities.update(given)
        if term.gltf.note:
            notes.append(term.gltf.note.format(**{**p, **{k: _fmt(v) for k, v in given.items()},
                                                  "name": term.name}))
    rho = np.zeros(3) if quantities["rho"] is None else _rgb(quantities["rho"])
    f0, f90 = _rgb(quantities["f0"]), float(quantities["f90"])

    roughness, alpha = roughness_alpha(p["roughness"], xp=np)
    out = {"roughness": roughness}
    if spec.anisotropic:
        alpha_t, alpha_b = ANISOTROPY_REMAPS[spec.anisotropy].remap(alpha, p["anisotropy"], xp=np)
        r_g, strength, rotation, clipped = anisotropy_to_gltf(alpha_t, alpha_b, p["rotation"])
        if clipped:
            notes.append(f"alpha_t = {alpha_t:.4g} exceeds glTF's maximum 1: anisotropy strength clipped to 1")
        out.update(roughness=r_g, anisotropy=strength, rotation=rotation)

    f0_max = float(np.max(f0))
    metal = (quantities["conductor"] and quantities["rho"] is None) or (
        f0_max >= METAL_F0_MIN and float(np.max(rho)) <= METAL_DIFFUSE_RATIO * f0_max)
    if metal:
        kind, extensions = "metal", []
        out.update(base_color=list(np.clip(f0, 0.0, 1.0)), metallic=1.0)
        if np.max(rho) > 0:
            notes.append(f"metal: diffuse albedo {_fmt(rho)} dropped (glTF metals have no diffuse)")
        if f90 != 1.0:
            notes.append(f"metal: fitted F90 {f90:.4g} replaced by glTF's 1")
    else:
        kind, extensions = _dielectric(spec, rho, f0, f90, out, notes)
    gspec = ModelSpec(ndf="ggx_aniso" if spec.anisotropic else "ggx", composition="gltf", clearcoat=spec.clearcoat,
                      gltf_extensions=tuple(extensions))
    # the fit's parameters that are glTF values themselves (the clearcoat's) map 1:1
    parameters = {q.name: _plain(out[q.name] if q.name in out else p[q.name]) for q in gspec.schema()}
    # every approximation has its note; F0 above 1 in a metal is clipped silently
    lossless = not notes and not (metal and np.any(f0 > 1.0))
    return GltfConversion(model=model_string(gspec), parameters=parameters, kind=kind,
                          lossless=bool(lossless), notes=notes)


def _dielectric(spec, rho, f0, f90, out, notes):
    """Rules 3 and 4: the glTF values into ``out``, notes into ``notes``; (kind, extensions)."""
    specular = min(max(f90, 0.0), 1.0)
    if float(np.max(f0)) > specular:     # glTF's F90 (the specular factor) is never below its F0
        notes.append(f"F0 {_fmt(f0)} above F90 {f90:.3g}: F90 raised to max F0 (KHR_materials_specular's "
                     "F90 is never below its F0)")
        specular = min(float(np.max(f0)), 1.0)
    if specular < SPECULAR_NEGLIGIBLE:
        notes.append(f"specular lobe negligible (F0 {_fmt(f0)}, F90 {f90:.2g}): written as specular 0")
        specular, f0 = 0.0, np.zeros(3)
    target = np.clip(f0 / specular, 0.0, 1.0) if specular > 0 else np.zeros(3)
    t_max, t_min = float(np.max(target)), float(np.min(target))
    achromatic = t_max - t_min <= ACHROMATIC_TOLERANCE * t_max + 1e-3
    if achromatic:
        kind = "dielectric"
        grey = float(np.mean(target))
        ior, color = _plain_ior(grey, np.full(3, grey) if grey > 0 else np.ones(3))
        if t_max - t_min > 0:
            notes.append(f"F0 {_fmt(f0)} taken as grey {grey * specular:.4g} (achromatic within "
                         f"{ACHROMATIC_TOLERANCE:.0%})")
    else:
        kind = "dielectric-chromatic"
        ior, color = _plain_ior(t_max, target)
    if specular == 0.0:         # nothing of F0 is drawn: the ior and colour at their defaults
        ior, color = IOR_DEFAULT, np.ones(3)
    f0_gltf = np.minimum(float(f0_from_ior(ior)) * color, 1.0) * specular
    weight = 1.0 - float(np.max(f0_gltf))
    if weight <= 0.0:           # F0 = F90 = 1: glTF's (1 - F) weight hides any base colour
        notes.append("F0 = F90 = 1 hides the diffuse base in glTF: baseColor = rho_d, not drawn")
        base = rho
    elif COMPOSITIONS[spec.composition].weights_diffuse:
        base = rho * (1.0 - f0_gltf) / weight
        if not achromatic:
            notes.append("coupled diffuse with chromatic F0: baseColor = rho (1 - F0) / (1 - max F0), "
                         "exact at normal incidence only")
    else:
        base = rho / weight
        if np.max(rho) > 0:
            notes.append("baseColor = rho_d / (1 - max F0): first-order correction for glTF's "
                         "(1 - F) diffuse weight (docs/gltf.md, dielectric kinds)")
    if np.any(base > 1.0):
        notes.append(f"baseColor {_fmt(base)} clipped to 1")
    out.update(base_color=list(np.clip(base, 0.0, 1.0)), metallic=0.0)
    extensions = []
    if abs(ior - IOR_DEFAULT) > 1e-12:
        extensions.append("ior")
        out["ior"] = ior
    if kind == "dielectric-chromatic" or specular != 1.0 or np.any(color != 1.0):
        extensions.append("specular")
        out.update(specular=specular, specular_color=list(color))
    return kind, extensions


def _plain_ior(f0_max, target):
    """(ior, specularColorFactor) drawing the F0 ``target`` (RGB, max ``f0_max``) with
    KHR_materials_ior and _specular: the ior whose F0 is ``f0_max`` (1 for no F0 at all),
    at most IOR_PLAIN_MAX, the colour the rest (1 where the ior carries it all)."""
    if f0_max <= 1e-12:
        return 1.0, np.ones(3)
    ior = min(float(ior_from_f0(f0_max, xp=np)), IOR_PLAIN_MAX)
    color = np.asarray(target, np.float64) / float(f0_from_ior(ior))
    return ior, (np.ones(3) if np.allclose(color, 1.0, rtol=1e-12, atol=0.0) else color)


def portable(conversion: dict) -> bool:
    """Whether a glTF material relies on nothing the engines draw differently from the
    specification and holds values an artist reads (docs/gltf.md, "Portable"): metallic 0
    or 1, ``specularFactor`` 1 (Blender's importer keeps F90 = 1 whatever it says), a grey
    ``specularColorFactor`` within [0, 1] (three.js weights the diffuse by 1 - F per
    channel, the specification by 1 - max F: the same for a grey F), and no
    KHR_materials_diffuse_roughness (Blender's importer drops it).  A model of one's own
    (no material) is not."""
    if conversion.get("model") is None:
        return False
    p = conversion["parameters"]
    color = _rgb(p.get("specular_color", 1.0))
    return (float(p["metallic"]) in (0.0, 1.0) and float(p.get("specular", 1.0)) == 1.0
            and float(np.max(color)) <= 1.0 and float(np.ptp(color)) <= 1e-9 and "diffuse_roughness" not in p)


def engines_reading(conversion: dict) -> dict:
    """The material a conversion writes, as the engines draw it (docs/gltf.md, "The engines'
    reading"): its glTF model with ``+turquin`` (the same file).  A conversion that is not
    lossless is judged so (its exported errors, the honesty check), as export-first's family
    is fitted so; a glTF fit stands in the reading it was fitted in."""
    spec = parse_model(conversion["model"])
    if conversion["lossless"] or spec.energy == "turquin":
        return conversion
    return dict(conversion, model=model_string(dataclasses.replace(spec, energy="turquin")))


def blender_reading(conversion: dict) -> dict:
    """The material as Blender 5's glTF importer reads it (checked in its node tree:
    benchmarks/engine_blender.py, docs/performance.md): ``specularFactor`` becomes Specular
    IOR Level, which scales F0 and leaves F90 at 1, so the factor moves into the colour
    (F0 = F0(ior) colour specular, F90 = 1); KHR_materials_diffuse_roughness is dropped
    (Lambert).  A portable material reads as written."""
    spec = parse_model(conversion["model"])
    p = dict(conversion["parameters"])
    if "specular" in p:
        p["specular_color"] = _plain(_rgb(p["specular_color"]) * float(p["specular"]))
        p["specular"] = 1.0
    p.pop("diffuse_roughness", None)
    read = dataclasses.replace(spec, gltf_extensions=tuple(e for e in spec.gltf_extensions if e != "diffuse_roughness"))
    return dict(conversion, model=model_string(read), parameters=p)


# --- the material JSON ------------------------------------------------------------

def _extensions_of(spec):
    return {p.gltf.owner for p in spec.schema() if p.gltf and p.gltf.owner != CORE}


def material_json(conversion: dict, name: str = "material", extras: dict | None = None) -> tuple[dict, list[str]]:
    """The glTF material object (and the KHR extensions it uses) for a conversion:
    every parameter of its (gltf) model written under its declared glTF key."""
    spec = parse_model(conversion["model"])
    material, ext = {"name": name, CORE: {}}, {}
    for param in spec.schema():
        key, value = param.gltf, conversion["parameters"][param.name]
        value = [float(c) for c in value] + list(key.extra) if param.size == 3 else float(value)
        (material[CORE] if key.owner == CORE else ext.setdefault(key.owner, {}))[key.key] = value
    if ext:
        material["extensions"] = ext
    if extras is not None:
        material["extras"] = extras
    return material, list(ext)


def parameters_from_material(material: dict) -> tuple[str, dict[str, float | list[float]]]:
    """The inverse of ``material_json``: (gltf model string, parameters) from a
    material dict (as written, or as pygltflib returns it via ``to_dict``)."""
    present = {CORE} | set(material.get("extensions") or {})
    # the glTF model whose extensions the material has: each option whose keys are present
    # (KHR_materials_specular is read as 'specular', its factor and colour; 'tint' is its colour alone)
    options = {**{e: ModelSpec(composition="gltf", gltf_extensions=(e,)) for e, term in GLTF_EXTENSIONS.items()
                  if e != "tint" and not term.holds},
               "aniso": ModelSpec(composition="gltf", ndf="ggx_aniso"),
               "clearcoat": ModelSpec(composition="gltf", clearcoat=True)}
    tokens = [tok for tok, option in options.items() if _extensions_of(option) <= present]
    spec = parse_model("+".join(["gltf"] + tokens))
    params = {}
    for param in spec.schema():
        key = param.gltf
        source = (material.get(CORE) if key.owner == CORE else material["extensions"][key.owner]) or {}
        value = source.get(key.key, [key.default] * 3 if param.size == 3 else key.default)
        params[param.name] = [float(c) for c in value[:3]] if param.size == 3 else float(value)
    return model_string(spec), params
