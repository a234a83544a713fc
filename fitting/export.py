"""Export a fit as a glTF 2.0 material on a UV sphere (``brdf-fit export``).

The conversion follows REFERENCE.md section 7 ("Honest conversion of a fit"):

1. ``roughnessFactor = sqrt(alpha)`` (the fitted perceptual roughness).
2. Metal -- Fresnel F0 high (max >= ``METAL_F0_MIN``) and the diffuse albedo
   negligible beside it (max rho_d <= ``METAL_DIFFUSE_RATIO`` x max F0), or
   a conductor Fresnel without a diffuse lobe: ``metallic = 1``,
   ``baseColor = F0`` (glTF metals use Schlick with F90 = 1).
3. Dielectric, achromatic F0 (spread <= ``ACHROMATIC_TOLERANCE``):
   ``metallic = 0``, ``KHR_materials_ior`` with ``ior = (1 + sqrt F0) /
   (1 - sqrt F0)`` (0.04 -> 1.5, 0.05 -> 1.576, 0.08 -> 1.789), and
   ``baseColor = rho_d / (1 - F0)``, the first-order correction for the
   glTF diffuse weight (1 - max F).  A *coupled* fit (its diffuse already
   weighted by 1 - F) keeps ``baseColor = rho_d (1 - F0) / (1 - max F0)``,
   which is exact for achromatic F0.
4. Dielectric, chromatic F0: ``KHR_materials_specular`` with the IOR chosen so
   that F0(ior) = max F0 and ``specularColorFactor = F0 / F0(ior)`` (so the
   factor stays <= 1, the REFERENCE's second option), ``specularFactor = 1``.
   A fitted F90 < 1 (``+f90``) becomes ``specularFactor = F90`` (glTF scales
   F0 and F90 together), with the colour divided accordingly.
5. Intermediate metallic is never produced from a non-glTF fit.
6. Anisotropy from (alpha_t, alpha_b): ``roughness = sqrt(alpha_b)``,
   ``anisotropyStrength = sqrt((alpha_t - alpha_b) / (1 - alpha_b))``,
   ``anisotropyRotation`` = the tangent angle (+ pi/2 when the fit's lobe is
   wider along the bitangent).  Kulla-Conty (alpha, a) gives alpha_t =
   alpha (1 + a), alpha_b = alpha (1 - a).
7. The error of the *exported* material -- the glTF BRDF a viewer evaluates,
   i.e. ``brdf.evaluate("gltf+...", exported values)`` -- is measured against
   the data (M1, the fit's own metric) and reported next to the fitted
   model's.

Fits made with a ``gltf`` model string map 1:1 (lossless).  Clearcoat maps
1:1 to ``KHR_materials_clearcoat`` (the same layering in both).  What glTF
cannot carry -- non-Lambert diffuse factors, energy compensation, the exact
or conductor Fresnel curves, separable masking, Oren-Nayar's sigma -- is
dropped, named in the export's notes, and shows in the exported M1.

The asset: one UV sphere (positions, normals, tangents, texcoords, indices)
with the material, as ``.gltf`` (embedded base64 buffer) or ``.glb``; the fit
(spec, parameters, errors, provenance, optimizer) and the conversion go in the
material's ``extras``.
"""

import base64
import json
import math
import pathlib
import struct
import sys

import numpy as np

from brdf import __version__
from brdf.constants import ALPHA_MIN, IOR_DEFAULT, ROUGHNESS_MIN
from brdf.model import model_string, parse_model

from .errors import BAD_INPUT, OK, fail  # noqa: F401  (BAD_INPUT: the exit codes' one home)
from .result import FitResult, ResultFileError, first_non_finite

METAL_F0_MIN = 0.2             # no common dielectric reaches F0 = 0.2 (diamond: 0.17)
METAL_DIFFUSE_RATIO = 0.1      # "rho_d ~ 0": at most a tenth of the specular F0
ACHROMATIC_TOLERANCE = 0.1     # (max F0 - min F0) <= 10 % of max F0 (+ 0.001) is grey
SPHERE_SEGMENTS = (32, 64)     # latitude rings, longitude segments

_EXTENSIONS = ("KHR_materials_ior", "KHR_materials_specular",
               "KHR_materials_clearcoat", "KHR_materials_anisotropy")


class ExportError(ValueError):
    """An export that cannot be done (bad path suffix, unusable result)."""


# --- conversion -------------------------------------------------------------

def f0_from_ior(ior):
    """Dielectric F0 = ((n - 1) / (n + 1))^2 (numpy, float64)."""
    return ((np.asarray(ior, dtype=np.float64) - 1.0) / (np.asarray(ior, dtype=np.float64) + 1.0)) ** 2


def ior_from_f0(f0):
    """Dielectric IOR n = (1 + sqrt F0) / (1 - sqrt F0) (REFERENCE s.3, s.7 rule 3)."""
    s = math.sqrt(min(max(float(f0), 0.0), 0.999999))
    return (1.0 + s) / (1.0 - s)


def _conductor_f0(n, k):
    n, k = np.asarray(n, np.float64), np.asarray(k, np.float64)
    return ((n - 1.0) ** 2 + k * k) / ((n + 1.0) ** 2 + k * k)


def _rgb(x):
    return np.broadcast_to(np.asarray(x, dtype=np.float64), (3,)).copy()


def _wrap_angle(angle):
    return (angle + math.pi / 2) % math.pi - math.pi / 2


def anisotropy_to_gltf(alpha_t, alpha_b, rotation):
    """(alpha_t, alpha_b, rotation) -> (roughness, strength, rotation, clipped).

    REFERENCE s.7 rule 6: roughness = sqrt(alpha_b), strength =
    sqrt((alpha_t - alpha_b) / (1 - alpha_b)); if alpha_t < alpha_b the axes
    are exchanged and the direction turned by pi/2.  ``clipped`` is True when
    alpha_t > 1 (glTF's strength 1 reaches alpha_t = 1 only).
    """
    alpha_t = max(float(alpha_t), ALPHA_MIN)
    alpha_b = max(float(alpha_b), ALPHA_MIN)
    if alpha_t < alpha_b:
        alpha_t, alpha_b = alpha_b, alpha_t
        rotation = rotation + math.pi / 2
    alpha_b = min(alpha_b, 1.0)
    ratio = (alpha_t - alpha_b) / (1.0 - alpha_b) if alpha_b < 1.0 else 0.0
    clipped = ratio > 1.0
    strength = math.sqrt(min(max(ratio, 0.0), 1.0))
    return math.sqrt(alpha_b), strength, _wrap_angle(rotation), clipped


class GltfConversion(dict):
    """The glTF form of a fit: a dict with

    model       the brdf model string of the glTF BRDF ("gltf", "gltf+ior+clearcoat", ...)
    parameters  that model's parameters ({name: float or [r, g, b]})
    kind        "lossless" (a gltf fit), "metal", "dielectric" or "dielectric-chromatic"
    lossless    True when the glTF BRDF equals the fitted model exactly
    notes       what was approximated or dropped (list of sentences)
    """


def convert(result):
    """A FitResult (or {"spec", "parameters"}) -> GltfConversion (REFERENCE s.7)."""
    spec_text = result.spec if isinstance(result, FitResult) else result["spec"]
    params = result.parameters if isinstance(result, FitResult) else result["parameters"]
    spec = parse_model(spec_text)
    if spec.composition == "gltf":
        return GltfConversion(model=model_string(spec),
                              parameters={k: (list(map(float, v)) if isinstance(v, (list, tuple))
                                              else float(v)) for k, v in params.items()},
                              kind="lossless", lossless=True,
                              notes=["fitted with the glTF BRDF itself: exported 1:1"])
    notes = []
    exact = True
    # --- the fit's physical quantities: rho_d, F0 (RGB), F90, alpha(s)
    rho = _rgb(params["albedo"]) if spec.diffuse != "none" else np.zeros(3)
    f90 = 1.0
    if spec.fresnel == "schlick":
        f0 = _rgb(params["f0"])
    elif spec.fresnel == "schlick_f90":
        f0, f90 = _rgb(params["f0"]), float(params["f90"])
    elif spec.fresnel == "dielectric":
        f0 = _rgb(f0_from_ior(params["ior"]))
        notes.append(f"exact dielectric Fresnel (ior {params['ior']:.4g}) replaced by glTF's Schlick "
                     "with the same F0")
        exact = False
    else:
        f0 = _rgb(_conductor_f0(params["eta"], params["k"]))
        notes.append("conductor Fresnel (n, k) replaced by Schlick with its F0 = "
                     + _fmt(f0) + " (F90 = 1)")
        exact = False
    if spec.diffuse not in ("none", "lambert"):
        notes.append(f"glTF's diffuse is Lambert: the {spec.diffuse} factor is dropped, its albedo kept")
        exact = False
    if spec.energy != "none":
        notes.append(f"glTF has no multiple-scattering compensation: '{spec.energy}' dropped")
        exact = False
    if spec.masking != "height_correlated":
        notes.append("glTF uses height-correlated Smith masking: the separable form is dropped")
        exact = False

    roughness = min(max(float(params["roughness"]), ROUGHNESS_MIN), 1.0)
    alpha = max(roughness * roughness, ALPHA_MIN)
    out = {}
    if spec.anisotropic:
        a = float(params["anisotropy"])
        if spec.anisotropy == "gltf":
            alpha_t, alpha_b = alpha + (1.0 - alpha) * a * a, alpha
        else:
            alpha_t, alpha_b = alpha * (1.0 + a), alpha * (1.0 - a)
        r_g, strength, rotation, clipped = anisotropy_to_gltf(alpha_t, alpha_b, float(params["rotation"]))
        if clipped:
            notes.append(f"alpha_t = {alpha_t:.4g} exceeds glTF's maximum 1: anisotropy strength clipped to 1")
            exact = False
        out.update(roughness=r_g, anisotropy=strength, rotation=rotation)
    else:
        out["roughness"] = roughness

    f0_max = float(np.max(f0))
    metal = (spec.fresnel == "conductor" and spec.diffuse == "none") or (
        f0_max >= METAL_F0_MIN and float(np.max(rho)) <= METAL_DIFFUSE_RATIO * f0_max)
    extensions = []
    if metal:
        kind = "metal"
        out.update(base_color=list(np.clip(f0, 0.0, 1.0)), metallic=1.0)
        if np.max(rho) > 0:
            notes.append(f"metal: diffuse albedo {_fmt(rho)} dropped (glTF metals have no diffuse)")
            exact = False
        if f90 != 1.0:
            notes.append(f"metal: fitted F90 {f90:.4g} replaced by glTF's 1")
            exact = False
        if np.any(f0 > 1.0):
            exact = False
    else:
        specular = min(max(f90, 0.0), 1.0)
        target = np.clip(f0 / specular, 0.0, 1.0) if specular > 0 else np.zeros(3)
        if specular <= 0 or np.any(f0 / max(specular, 1e-300) > 1.0 + 1e-12):
            notes.append("F0 above F90 cannot be encoded by KHR_materials_specular: clipped")
            exact = False
        t_max, t_min = float(np.max(target)), float(np.min(target))
        achromatic = t_max - t_min <= ACHROMATIC_TOLERANCE * t_max + 1e-3
        if achromatic:
            kind = "dielectric"
            grey = float(np.mean(target))
            ior = ior_from_f0(grey)
            color = np.ones(3)
            if t_max - t_min > 0:
                notes.append(f"F0 {_fmt(f0)} taken as grey {grey * specular:.4g} (achromatic within "
                             f"{ACHROMATIC_TOLERANCE:.0%})")
                exact = False
        else:
            kind = "dielectric-chromatic"
            ior = ior_from_f0(t_max) if t_max > 1e-12 else 1.0
            f0_ior = float(f0_from_ior(ior))
            color = target / f0_ior if f0_ior > 0 else np.ones(3)
        f0_gltf = np.minimum(float(f0_from_ior(ior)) * color, 1.0) * specular
        weight = 1.0 - float(np.max(f0_gltf))
        if spec.composition == "coupled":
            base = rho * (1.0 - f0_gltf) / weight
            if not achromatic:
                notes.append("coupled diffuse with chromatic F0: baseColor = rho (1 - F0) / (1 - max F0), "
                             "exact at normal incidence only")
                exact = False
        else:
            base = rho / weight
            if np.max(rho) > 0:
                notes.append("baseColor = rho_d / (1 - max F0): first-order correction for glTF's "
                             "(1 - F) diffuse weight (REFERENCE s.7 rule 3)")
                exact = False
        if np.any(base > 1.0):
            notes.append(f"baseColor {_fmt(base)} clipped to 1")
            exact = False
        out.update(base_color=list(np.clip(base, 0.0, 1.0)), metallic=0.0)
        if abs(ior - IOR_DEFAULT) > 1e-12:
            extensions.append("ior")
            out["ior"] = ior
        if kind == "dielectric-chromatic" or specular != 1.0:
            extensions.append("specular")
            out.update(specular=specular, specular_color=list(color))
    if spec.clearcoat:
        out.update(clearcoat=float(params["clearcoat"]),
                   clearcoat_roughness=float(params["clearcoat_roughness"]))
    gspec = parse_model("+".join(["gltf"] + extensions + (["aniso"] if spec.anisotropic else [])
                                 + (["clearcoat"] if spec.clearcoat else [])))
    schema_order = [p.name for p in gspec.schema()]
    parameters = {k: ([float(v) for v in out[k]] if isinstance(out[k], list) else float(out[k]))
                  for k in schema_order}
    return GltfConversion(model=model_string(gspec), parameters=parameters, kind=kind,
                          lossless=bool(exact), notes=notes)


def _fmt(v):
    v = np.atleast_1d(np.asarray(v, dtype=np.float64))
    return "(" + ", ".join(f"{x:.4g}" for x in v) + ")" if v.size > 1 else f"{v[0]:.4g}"


def material_json(conversion, name="material", extras=None):
    """The glTF material object (and the KHR extensions it uses) for a conversion."""
    p = conversion["parameters"]
    spec = parse_model(conversion["model"])
    material = {
        "name": name,
        "pbrMetallicRoughness": {
            "baseColorFactor": [float(c) for c in p["base_color"]] + [1.0],
            "metallicFactor": float(p["metallic"]),
            "roughnessFactor": float(p["roughness"]),
        },
    }
    ext = {}
    if "ior" in spec.gltf_extensions:
        ext["KHR_materials_ior"] = {"ior": float(p["ior"])}
    if "specular" in spec.gltf_extensions:
        ext["KHR_materials_specular"] = {"specularFactor": float(p["specular"]),
                                         "specularColorFactor": [float(c) for c in p["specular_color"]]}
    if spec.clearcoat:
        ext["KHR_materials_clearcoat"] = {"clearcoatFactor": float(p["clearcoat"]),
                                          "clearcoatRoughnessFactor": float(p["clearcoat_roughness"])}
    if spec.anisotropic:
        ext["KHR_materials_anisotropy"] = {"anisotropyStrength": float(p["anisotropy"]),
                                           "anisotropyRotation": float(p["rotation"])}
    if ext:
        material["extensions"] = ext
    if extras is not None:
        material["extras"] = extras
    return material, [e for e in _EXTENSIONS if e in ext]


def parameters_from_material(material):
    """The inverse of ``material_json``: (gltf model string, parameters) from a
    material dict (as written, or as pygltflib returns it via ``to_dict``)."""
    pbr = material.get("pbrMetallicRoughness") or {}
    ext = material.get("extensions") or {}
    base = pbr.get("baseColorFactor", [1.0, 1.0, 1.0, 1.0])
    params = {"base_color": [float(c) for c in base[:3]],
              "metallic": float(pbr.get("metallicFactor", 1.0)),
              "roughness": float(pbr.get("roughnessFactor", 1.0))}
    tokens = ["gltf"]
    if "KHR_materials_ior" in ext:
        tokens.append("ior")
        params["ior"] = float(ext["KHR_materials_ior"].get("ior", IOR_DEFAULT))
    if "KHR_materials_specular" in ext:
        tokens.append("specular")
        s = ext["KHR_materials_specular"]
        params["specular"] = float(s.get("specularFactor", 1.0))
        params["specular_color"] = [float(c) for c in s.get("specularColorFactor", [1.0, 1.0, 1.0])]
    if "KHR_materials_anisotropy" in ext:
        tokens.append("aniso")
        a = ext["KHR_materials_anisotropy"]
        params["anisotropy"] = float(a.get("anisotropyStrength", 0.0))
        params["rotation"] = float(a.get("anisotropyRotation", 0.0))
    if "KHR_materials_clearcoat" in ext:
        tokens.append("clearcoat")
        c = ext["KHR_materials_clearcoat"]
        params["clearcoat"] = float(c.get("clearcoatFactor", 0.0))
        params["clearcoat_roughness"] = float(c.get("clearcoatRoughnessFactor", 0.0))
    return model_string(parse_model("+".join(tokens))), params


# --- honesty: the exported material's error against the measurement -----------

def m1_errors(measured, models, max_theta=80.0):
    """M1 (the fit's metric, on every valid sample with theta <= max_theta) of
    each (model string, parameters) in ``models`` against ``measured``.

    Returns a list of (M1, [M1_r, M1_g, M1_b]).
    """
    from brdf.model import parse_model as _parse
    from .fit import full_set_errors, prepare
    from .transforms import to_jax
    full, _ = prepare(measured, max_theta=max_theta, samples=0)
    out = []
    for model, params in models:
        spec = _parse(model)
        channels = np.sqrt(full_set_errors(spec, "log", to_jax(spec, params), full))
        out.append((float(np.mean(channels)), [float(c) for c in channels]))
    return out


def _load_measured(measured, result):
    """(MeasuredBRDF or None, note) from an object, a path, or the provenance."""
    from data_loaders import MeasuredBRDF, load
    if isinstance(measured, MeasuredBRDF):
        return measured, None
    path = measured or (result.provenance or {}).get("file")
    if not path:
        return None, "no measured file given and none in the result's provenance"
    if measured is None and not pathlib.Path(path).is_file():
        return None, f"the provenance file {path} is not here (pass --measured)"
    return load(path), None


def honesty(result, conversion, measured):
    """{"measured_file", "sha256_matches", "max_theta", "m1_fitted_model",
    "m1_exported_gltf", ...} for a loaded MeasuredBRDF."""
    max_theta = float((result.optimizer or {}).get("max_theta", 80.0))
    (m1_fit, ch_fit), (m1_gltf, ch_gltf) = m1_errors(
        measured, [(result.spec, result.parameters),
                   (conversion["model"], conversion["parameters"])], max_theta)
    sha = (result.provenance or {}).get("sha256")
    return {
        "measured_file": measured.provenance.path,
        "sha256_matches": (bool(sha) and sha == measured.provenance.sha256) if sha else None,
        "max_theta": max_theta,
        "m1_recorded": float(result.errors.get("m1", float("nan"))),
        "m1_fitted_model": m1_fit,
        "m1_fitted_model_per_channel": ch_fit,
        "m1_exported_gltf": m1_gltf,
        "m1_exported_gltf_per_channel": ch_gltf,
    }


# --- the sphere mesh ----------------------------------------------------------

def uv_sphere(rings=SPHERE_SEGMENTS[0], segments=SPHERE_SEGMENTS[1]):
    """A unit UV sphere (glTF: +y up, counter-clockwise front faces).

    P(theta, phi) = (sin theta sin phi, cos theta, sin theta cos phi) with
    u = phi / 2 pi, v = theta / pi (glTF's v points down).  The tangent is
    dP/dphi normalised (the +u direction, w = +1, so bitangent = n x t),
    defined at the poles too.  Pole quads become single triangles (no
    degenerate triangles).  Returns float32 positions, normals, tangents
    (vec4), texcoords and uint16 indices.
    """
    theta = np.linspace(0.0, np.pi, rings + 1)
    phi = np.linspace(0.0, 2.0 * np.pi, segments + 1)
    T, P = np.meshgrid(theta, phi, indexing="ij")
    st, ct, sp, cp = np.sin(T), np.cos(T), np.sin(P), np.cos(P)
    pos = np.stack([st * sp, ct, st * cp], axis=-1).reshape(-1, 3)
    pos[np.abs(pos) < 1e-15] = 0.0
    normal = pos / np.linalg.norm(pos, axis=1, keepdims=True)
    tangent = np.stack([cp, np.zeros_like(cp), -sp, np.ones_like(cp)], axis=-1).reshape(-1, 4)
    uv = np.stack([P / (2 * np.pi), T / np.pi], axis=-1).reshape(-1, 2)
    idx = []
    width = segments + 1
    for i in range(rings):
        for j in range(segments):
            a, b = i * width + j, (i + 1) * width + j
            c, d = b + 1, a + 1
            if i != rings - 1:
                idx.append((a, b, c))
            if i != 0:
                idx.append((a, c, d))
    indices = np.asarray(idx, dtype=np.uint16).ravel()
    return (pos.astype(np.float32), normal.astype(np.float32), tangent.astype(np.float32),
            uv.astype(np.float32), indices)


def _pad4(data, fill=b"\0"):
    return data + fill * (-len(data) % 4)


def gltf_document(material, extensions_used, mesh=None):
    """(glTF JSON dict, binary buffer bytes) of a UV sphere carrying ``material``."""
    pos, normal, tangent, uv, indices = mesh or uv_sphere()
    blobs, views, accessors = [], [], []
    offset = 0

    def add(array, gl_type, component, target, minmax=False):
        nonlocal offset
        data = _pad4(array.tobytes())
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": array.nbytes, "target": target})
        acc = {"bufferView": len(views) - 1, "componentType": component,
               "count": int(array.shape[0]), "type": gl_type}
        if minmax:
            acc["min"] = [float(x) for x in array.min(axis=0)]
            acc["max"] = [float(x) for x in array.max(axis=0)]
        accessors.append(acc)
        blobs.append(data)
        offset += len(data)
        return len(accessors) - 1

    FLOAT, USHORT, ARRAY, ELEMENT = 5126, 5123, 34962, 34963
    attributes = {
        "POSITION": add(pos, "VEC3", FLOAT, ARRAY, minmax=True),
        "NORMAL": add(normal, "VEC3", FLOAT, ARRAY),
        "TANGENT": add(tangent, "VEC4", FLOAT, ARRAY),
        "TEXCOORD_0": add(uv, "VEC2", FLOAT, ARRAY),
    }
    index_accessor = add(indices, "SCALAR", USHORT, ELEMENT)
    binary = b"".join(blobs)
    doc = {
        "asset": {"version": "2.0", "generator": f"brdf-fit {__version__} (fitting.export)"},
        "scene": 0,
        "scenes": [{"name": "scene", "nodes": [0]}],
        "nodes": [{"name": "sphere", "mesh": 0}],
        "meshes": [{"name": "sphere", "primitives": [
            {"attributes": attributes, "indices": index_accessor, "material": 0, "mode": 4}]}],
        "materials": [material],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(binary)}],
    }
    if extensions_used:
        doc["extensionsUsed"] = list(extensions_used)
    return doc, binary


def write_gltf_file(path, doc, binary):
    """Write ``.gltf`` (buffer as a base64 data URI) or ``.glb`` atomically."""
    from data_loaders.measured import write_file_atomic
    path = pathlib.Path(path)
    suffix = path.suffix.lower()
    bad = first_non_finite(doc)
    if bad is not None:        # glTF (JSON) has no NaN / Infinity: refuse, write nothing
        where, value = bad
        shown = "NaN" if value != value else ("Infinity" if value > 0 else "-Infinity")
        raise ExportError(f"{path}: not written: {where} would be {shown}; a glTF file holds "
                          "finite numbers only")
    doc = json.loads(json.dumps(doc, allow_nan=False))
    if suffix == ".gltf":
        doc["buffers"][0]["uri"] = ("data:application/octet-stream;base64,"
                                    + base64.b64encode(binary).decode("ascii"))
        data = (json.dumps(doc, indent=1, allow_nan=False) + "\n").encode("utf-8")
    elif suffix == ".glb":
        js = _pad4(json.dumps(doc, separators=(",", ":"), allow_nan=False).encode("utf-8"), b" ")
        bin_chunk = _pad4(binary)
        total = 12 + 8 + len(js) + 8 + len(bin_chunk)
        data = (struct.pack("<4sII", b"glTF", 2, total)
                + struct.pack("<I4s", len(js), b"JSON") + js
                + struct.pack("<I4s", len(bin_chunk), b"BIN\0") + bin_chunk)
    else:
        raise ExportError(f"{path}: the output must end in .gltf or .glb")
    path.parent.mkdir(parents=True, exist_ok=True)
    write_file_atomic(path, data)
    return path


# --- the export ---------------------------------------------------------------

def export_gltf(result, path, measured=None):
    """Write ``result`` (FitResult or RESULT.json path) as a glTF material on a sphere.

    ``measured``: a MeasuredBRDF, a measured file path, or None (then the
    provenance file, when it exists).  Returns a dict with the conversion
    (``model``, ``parameters``, ``kind``, ``lossless``, ``notes``), the
    ``material`` JSON, ``extensions``, ``path`` and ``honesty`` (M1 of the
    fitted model and of the exported glTF BRDF against the measurement, or a
    ``reason`` why there is none).
    """
    if not isinstance(result, FitResult):
        result = FitResult.load(result)
    path = pathlib.Path(path)
    if path.suffix.lower() not in (".gltf", ".glb"):
        raise ExportError(f"{path}: the output must end in .gltf or .glb")
    conversion = convert(result)
    measured_obj, reason = _load_measured(measured, result)
    report = honesty(result, conversion, measured_obj) if measured_obj is not None else {"reason": reason}
    extras = {"brdf_fit": {
        "toolkit_version": result.toolkit_version,
        "schema_version": result.schema_version,
        "spec": result.spec,
        "parameters": result.parameters,
        "errors": result.errors,
        "provenance": result.provenance,
        "optimizer": {k: result.optimizer.get(k) for k in
                      ("name", "samples", "samples_full", "max_theta", "seed", "converged", "seconds_total")
                      if k in (result.optimizer or {})},
        "gltf_model": conversion["model"],
        "gltf_parameters": conversion["parameters"],
        "conversion": {"kind": conversion["kind"], "lossless": conversion["lossless"],
                       "notes": conversion["notes"], "rules": "REFERENCE.md section 7"},
        "honesty": report,
    }}
    material, used = material_json(conversion, name=result.material, extras=extras)
    doc, binary = gltf_document(material, used)
    write_gltf_file(path, doc, binary)
    return {**conversion, "material": material, "extensions": used, "path": str(path),
            "honesty": report}


def describe_export(info, stream=None):
    """Print what an export wrote and the two errors side by side."""
    stream = stream or sys.stdout
    h = info["honesty"]
    exts = ", ".join(info["extensions"]) or "core only"
    print(f"wrote {info['path']}: {info['model']} ({info['kind']}; {exts})", file=stream)
    for note in info["notes"]:
        print(f"  note: {note}", file=stream)
    if "m1_exported_gltf" in h:
        fit_m1, gltf_m1 = h["m1_fitted_model"], h["m1_exported_gltf"]
        change = (gltf_m1 / fit_m1 - 1.0) * 100.0 if fit_m1 > 0 else float("nan")
        print(f"M1 against {h['measured_file']} (theta <= {h['max_theta']:g} deg): "
              f"fitted model {fit_m1:.6g}, exported glTF {gltf_m1:.6g} ({change:+.1f} %)", file=stream)
        if h["sha256_matches"] is False:
            print("  warning: the measured file differs from the one the fit was made on (sha256)",
                  file=stream)
    else:
        print(f"M1 of the exported material not computed: {h['reason']}", file=stream)


def export_main(result_path, out_path, measured_path=None):
    """``brdf-fit export``: 0 on success, 2 with one line on stderr for bad input."""
    from data_loaders import MeasuredDataError
    try:
        result = FitResult.load(result_path)
        info = export_gltf(result, out_path, measured=measured_path)
    except (ResultFileError, MeasuredDataError, ExportError, ValueError) as err:
        return fail("export", err)
    except OSError as err:
        return fail("export", f"{out_path}: cannot write ({err.strerror or err})")
    describe_export(info)
    return OK
