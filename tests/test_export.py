"""glTF export: REFERENCE.md s.7 conversions, lossless gltf round trips,
the honesty numbers, the Khronos validator, pygltflib round trips, the CLI."""

import json
import math
import pathlib
import shutil
import subprocess
import zlib

import jax.numpy as jnp
import numpy as np
import pygltflib
import pytest

from brdf import evaluate, fresnel, parameter_schema, parse_model
from brdf.fresnel import f0_from_ior
from brdf.gltf_material import anisotropy_to_gltf, parameters_from_material
from brdf_fit.export.gltf import convert, export_gltf, export_main
from fitting.fit import evaluate_result
from brdf_fit.export.gltf_file import mesh_arrays
from shaders.mesh import uv_sphere
from fitting.result import FitResult
from fitting.synthetic import synthetic_measured

ROOT = pathlib.Path(__file__).resolve().parent.parent
VALIDATOR_SCRIPT = ROOT / "tools" / "validate_gltf.mjs"

# REFERENCE.md test geometry: v = wo = (theta 40, phi 20), l = wi = (theta 55, phi 200)
V = np.array([0.604023, 0.219846, 0.766044])
L = np.array([-0.769751, -0.280166, 0.573576])


def result(spec, params, material="test-material", provenance=None):
    return FitResult(spec=spec, parameters=params, errors={"m1": 0.0}, optimizer={"max_theta": 80.0},
                     provenance=provenance or {"file": None, "sha256": None, "format": None,
                                               "material": material})


def ior_from_f0(f0):
    """The conversion's float64 (numpy) path of brdf.fresnel.ior_from_f0."""
    return float(fresnel.ior_from_f0(f0, xp=np))


def random_pairs(n=4000, seed=3):
    rng = np.random.default_rng(seed)

    def hemi(k):
        v = rng.normal(size=(k, 3))
        v[:, 2] = np.abs(v[:, 2]) + 1e-3
        return v / np.linalg.norm(v, axis=1, keepdims=True)
    wi, wo = hemi(n), hemi(n)
    # add near-mirror and grazing pairs
    wo[: n // 8] = wi[: n // 8] * np.array([-1, -1, 1]) + rng.normal(0, 0.01, (n // 8, 3))
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    wo[:, 2] = np.abs(wo[:, 2]) + 1e-4
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    return wi, wo


def gltf_eval(model, params, wi, wo):
    spec = parse_model(model)
    p = {k: jnp.asarray(v, jnp.float64) for k, v in params.items()}
    return np.asarray(evaluate(spec, p, jnp.asarray(wi), jnp.asarray(wo)))


def random_params(spec_text, rng):
    out = {}
    for p in parameter_schema(parse_model(spec_text)):
        lo, hi = p.lower, min(p.upper, 3.0)
        if p.name in ("roughness", "clearcoat_roughness"):
            lo = 0.05
        x = rng.uniform(lo, hi, p.size)
        out[p.name] = [float(v) for v in x] if p.size == 3 else float(x[0])
    return out


# --- conversion rules (REFERENCE.md s.7) ----------------------------------------

def test_ior_from_f0_matches_reference():
    # REFERENCE s.3 / s.7 rule 3: F0 0.04 -> 1.5, 0.05 -> 1.576014, 0.08 -> 1.789; F0(1.33) = 0.020059
    assert ior_from_f0(0.04) == pytest.approx(1.5, abs=1e-12)
    assert ior_from_f0(0.05) == pytest.approx(1.576014, abs=1e-6)
    assert ior_from_f0(0.08) == pytest.approx(1.789, abs=1e-3)
    assert f0_from_ior(1.33) == pytest.approx(0.020059, abs=1e-6)
    assert f0_from_ior(ior_from_f0(0.0123)) == pytest.approx(0.0123, rel=1e-12)


def test_achromatic_dielectric_uses_ior_and_first_order_base_color():
    conv = convert(result("ggx+lambert", {"albedo": [0.3, 0.2, 0.1], "roughness": 0.5, "f0": [0.05] * 3}))
    assert conv["model"] == "gltf+ior" and conv["kind"] == "dielectric"
    p = conv["parameters"]
    assert p["ior"] == pytest.approx(1.576014, abs=1e-6)
    assert p["metallic"] == 0.0 and p["roughness"] == 0.5
    np.testing.assert_allclose(p["base_color"], np.array([0.3, 0.2, 0.1]) / 0.95, rtol=1e-12)
    assert not conv["lossless"]


def test_f0_of_glass_needs_no_extension():
    conv = convert(result("ggx+lambert", {"albedo": [0.5] * 3, "roughness": 0.4, "f0": [0.04] * 3}))
    assert conv["model"] == "gltf"            # ior 1.5 is glTF's default
    np.testing.assert_allclose(conv["parameters"]["base_color"], [0.5 / 0.96] * 3, rtol=1e-12)


def test_chromatic_dielectric_uses_specular_color():
    conv = convert(result("ggx+lambert", {"albedo": [0.3, 0.2, 0.1], "roughness": 0.5,
                                          "f0": [0.08, 0.04, 0.02]}))
    assert conv["model"] == "gltf+ior+specular" and conv["kind"] == "dielectric-chromatic"
    p = conv["parameters"]
    # IOR chosen so that F0(ior) = max F0 = 0.08 -> 1.789 and the colour stays <= 1
    assert p["ior"] == pytest.approx(1.789, abs=1e-3)
    np.testing.assert_allclose(p["specular_color"], [1.0, 0.5, 0.25], rtol=1e-9)
    assert p["specular"] == 1.0
    # glTF's f0 = min(F0(ior) specularColor, 1) specular reproduces the fitted F0
    np.testing.assert_allclose(f0_from_ior(p["ior"]) * np.array(p["specular_color"]),
                               [0.08, 0.04, 0.02], rtol=1e-9)
    np.testing.assert_allclose(p["base_color"], np.array([0.3, 0.2, 0.1]) / 0.92, rtol=1e-12)


def test_an_F90_below_F0_keeps_the_lobe_and_plain_values():
    """alum-bronze's best fit once had F0 ~0.9 and F90 2e-7: its conversion scaled F0 down to F90 (a
    near-black sphere, ior 3,999,998 beside specular 2e-7). glTF's F90 is never below its F0: F90 is
    raised to max F0 instead, so the lobe keeps its colour at normal incidence, with a plain ior."""
    r = result("ggx+lambert+f90", {"albedo": [0.3, 0.2, 0.1], "roughness": 0.4, "f0": [0.9, 0.6, 0.3],
                                   "f90": 2e-7})
    conv = convert(r)
    p = conv["parameters"]
    assert conv["model"] == "gltf+ior+specular" and p["specular"] == pytest.approx(0.9)
    assert 1.0 <= p["ior"] <= 3.0 and any("F90 raised" in n for n in conv["notes"])
    # glTF's F0 = min(((n - 1) / (n + 1))^2 x specularColor, 1) x specular: the fitted F0
    f0 = np.minimum(((p["ior"] - 1.0) / (p["ior"] + 1.0)) ** 2 * np.array(p["specular_color"]), 1.0) * p["specular"]
    np.testing.assert_allclose(f0, [0.9, 0.6, 0.3], rtol=1e-12)


def test_a_white_flat_fresnel_hides_the_base_without_dividing_by_zero():
    """F0 = F90 = 1 (a grey F0 of 1): glTF's f0 = min(0.25 x 4, 1) x 1 = 1 and the (1 - F) weight is 0
    everywhere; the base colour is the fit's albedo, with a note, and no division by zero."""
    with np.errstate(divide="raise", invalid="raise"):
        conv = convert(result("ggx+lambert", {"albedo": [0.3, 0.2, 0.1], "roughness": 0.4, "f0": [1.0] * 3}))
    p = conv["parameters"]
    assert p["ior"] == 3.0 and p["specular_color"] == [4.0] * 3
    np.testing.assert_allclose(p["base_color"], [0.3, 0.2, 0.1])
    assert any("hides the diffuse base" in n for n in conv["notes"])


def test_a_negligible_specular_lobe_is_written_as_plain_zero():
    r = result("ggx+lambert+f90", {"albedo": [0.3, 0.2, 0.1], "roughness": 0.4, "f0": [2e-5] * 3, "f90": 2e-7})
    conv = convert(r)
    p = conv["parameters"]
    assert conv["model"] == "gltf+specular" and p["specular"] == 0.0
    assert p["specular_color"] == [1.0, 1.0, 1.0] and not conv["lossless"]
    assert any("negligible" in n for n in conv["notes"])
    # glTF draws a pure Lambertian base then (F = 0): base_color / pi, the fit's albedo / pi
    wi, wo = random_pairs()
    np.testing.assert_allclose(p["base_color"], [0.3, 0.2, 0.1], rtol=1e-12)
    np.testing.assert_allclose(gltf_eval(conv["model"], p, wi, wo), np.array(p["base_color"]) / math.pi
                               * np.ones((len(wi), 1)), rtol=1e-12)


def test_a_high_dielectric_f0_keeps_a_plain_ior():
    """A dielectric F0 of 0.5 (F0 = F90 = 1 would need an infinite ior): ior at most 3, the rest in the
    specular colour (> 1, as KHR_materials_specular allows); F0 = ((n - 1) / (n + 1))^2 x colour."""
    conv = convert(result("ggx+lambert", {"albedo": [0.3, 0.3, 0.3], "roughness": 0.4, "f0": [0.5] * 3}))
    p = conv["parameters"]
    assert p["ior"] == 3.0
    np.testing.assert_allclose(np.array(p["specular_color"]) * ((3.0 - 1.0) / (3.0 + 1.0)) ** 2, [0.5] * 3,
                               rtol=1e-12)
    conv = convert(result("ggx+lambert+f90", {"albedo": [0.3, 0.3, 0.3], "roughness": 0.4, "f0": [0.5] * 3,
                                              "f90": 0.5}))          # F0 = F90: a flat Fresnel
    assert conv["parameters"]["ior"] == 3.0 and conv["parameters"]["specular"] == 0.5
    np.testing.assert_allclose(conv["parameters"]["specular_color"], [4.0] * 3, rtol=1e-12)


def test_metal_is_metallic_one_and_exact():
    params = {"roughness": 0.3, "f0": [0.95, 0.64, 0.54]}
    r = result("ggx", params)
    conv = convert(r)
    assert conv["kind"] == "metal" and conv["model"] == "gltf" and conv["lossless"]
    assert conv["parameters"]["metallic"] == 1.0
    np.testing.assert_allclose(conv["parameters"]["base_color"], params["f0"])
    wi, wo = random_pairs()
    np.testing.assert_allclose(gltf_eval(conv["model"], conv["parameters"], wi, wo),
                               evaluate_result(r, wi, wo), rtol=1e-9, atol=1e-12)


def test_anisotropy_rule_six_reference_values():
    # REFERENCE s.1: Kulla-Conty (alpha .25, a .5) -> (0.375, 0.125); s.7 rule 6
    rough, strength, rot, clipped = anisotropy_to_gltf(0.375, 0.125, 0.0)
    assert rough == pytest.approx(math.sqrt(0.125)) and not clipped
    assert strength == pytest.approx(math.sqrt(0.25 / 0.875))
    # glTF's own remap (REFERENCE s.1: glTF(alpha, s) = (mix(alpha, 1, s^2), alpha)) goes back
    assert 0.125 + (1 - 0.125) * strength ** 2 == pytest.approx(0.375)
    # a lobe wider along the bitangent turns by pi/2
    _, s2, rot2, _ = anisotropy_to_gltf(0.125, 0.375, 0.2)
    assert s2 == pytest.approx(strength) and rot2 == pytest.approx(0.2 + math.pi / 2 - math.pi)


@pytest.mark.parametrize("a, rotation", [(0.5, 0.3), (-0.6, -0.4), (0.0, 1.0)])
def test_kulla_conty_anisotropy_exports_exactly(a, rotation):
    """A specular-only ggx_aniso with grey F0 has an exact glTF form (rules 3 and 6)."""
    r = result("ggx_aniso", {"roughness": 0.5, "anisotropy": a, "rotation": rotation, "f0": [0.05] * 3})
    conv = convert(r)
    assert conv["model"] == "gltf+ior+aniso" and conv["lossless"]
    wi, wo = random_pairs()
    np.testing.assert_allclose(gltf_eval(conv["model"], conv["parameters"], wi, wo),
                               evaluate_result(r, wi, wo), rtol=1e-9, atol=1e-12)


def test_fitted_f90_becomes_specular_factor_exactly():
    """Schlick with F90 < 1: glTF's specularFactor scales F0 and F90 together (rule 4)."""
    r = result("ggx+f90", {"roughness": 0.4, "f0": [0.04] * 3, "f90": 0.5})
    conv = convert(r)
    p = conv["parameters"]
    assert conv["model"] == "gltf+ior+specular" and conv["lossless"]
    assert p["specular"] == 0.5 and p["ior"] == pytest.approx(ior_from_f0(0.08))
    np.testing.assert_allclose(p["specular_color"], [1.0, 1.0, 1.0])
    wi, wo = random_pairs()
    np.testing.assert_allclose(gltf_eval(conv["model"], p, wi, wo), evaluate_result(r, wi, wo),
                               rtol=1e-9, atol=1e-12)


def test_coupled_lambert_with_grey_f0_exports_exactly():
    r = result("ggx+lambert+coupled+clearcoat",
               {"albedo": [0.6, 0.3, 0.1], "roughness": 0.35, "f0": [0.045] * 3,
                "clearcoat": 0.7, "clearcoat_roughness": 0.08})
    conv = convert(r)
    assert conv["model"] == "gltf+ior+clearcoat" and conv["lossless"]
    np.testing.assert_allclose(conv["parameters"]["base_color"], [0.6, 0.3, 0.1], rtol=1e-12)
    wi, wo = random_pairs()
    np.testing.assert_allclose(gltf_eval(conv["model"], conv["parameters"], wi, wo),
                               evaluate_result(r, wi, wo), rtol=1e-9, atol=1e-12)


def test_dropped_terms_are_named():
    conv = convert(result("ggx+burley+ms", {"albedo": [0.3] * 3, "roughness": 0.5, "f0": [0.04] * 3}))
    text = " ".join(conv["notes"])
    assert "burley" in text and "kulla_conty" in text and not conv["lossless"]


# --- lossless gltf round trip through the file ---------------------------------

GLTF_MODELS = ["gltf", "gltf+ior", "gltf+specular", "gltf+ior+specular+clearcoat",
               "gltf+aniso", "gltf+ior+specular+aniso+clearcoat", "gltf+specular+sheen+clearcoat"]


@pytest.mark.parametrize("model", GLTF_MODELS)
@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
def test_gltf_fits_export_losslessly(tmp_path, model, suffix):
    # a fixed seed per case (Python's str hash changes from process to process)
    rng = np.random.default_rng(zlib.crc32(f"{model}{suffix}".encode()))
    params = random_params(model, rng)
    r = result(model, params)
    path = tmp_path / f"m{suffix}"
    info = export_gltf(r, path)
    assert info["lossless"] and info["model"] == parse_model(model).__str__()
    doc = pygltflib.GLTF2().load(str(path))
    mat = doc.materials[0]
    back_model, back = parameters_from_material(
        {"pbrMetallicRoughness": {"baseColorFactor": mat.pbrMetallicRoughness.baseColorFactor,
                                  "metallicFactor": mat.pbrMetallicRoughness.metallicFactor,
                                  "roughnessFactor": mat.pbrMetallicRoughness.roughnessFactor},
         "extensions": mat.extensions})
    assert back_model == str(parse_model(model))
    wi, wo = random_pairs(seed=11)
    fitted = evaluate_result(r, wi, wo)
    exported = gltf_eval(back_model, back, wi, wo)
    # relative, with an absolute floor of 1e-12 1/sr: values reach 1e3 1/sr in a sharp peak
    assert np.max(np.abs(exported - fitted) / np.maximum(np.abs(fitted), 1e-6)) <= 1e-6
    extras = mat.extras["brdf_fit"]
    assert extras["spec"] == model and extras["parameters"] == params
    assert extras["provenance"]["material"] == "test-material"


@pytest.mark.parametrize("metallic, spec_color, clearcoat, expected", [
    (0.0, None, None, (0.320248, 0.137560, 0.107112)),
    (1.0, None, None, (1.412829, 0.357962, 0.182151)),
    (0.0, (2.0, 1.0, 0.5), None, (0.380423, 0.135023, 0.070681)),
    (0.0, None, (1.0, 0.1), (0.309731, 0.134474, 0.105264)),
])
def test_exported_material_reproduces_reference_values(tmp_path, metallic, spec_color, clearcoat, expected):
    """REFERENCE s.6 / s.7 refs at the test geometry (baseColor (0.8, 0.2, 0.1), r = 0.5),
    evaluated from the values read back out of the written file."""
    model = "gltf" + ("+specular" if spec_color else "") + ("+clearcoat" if clearcoat else "")
    params = {"base_color": [0.8, 0.2, 0.1], "metallic": metallic, "roughness": 0.5}
    if spec_color:
        params.update(specular=1.0, specular_color=list(spec_color))
    if clearcoat:
        params.update(clearcoat=clearcoat[0], clearcoat_roughness=clearcoat[1])
    path = tmp_path / "ref.gltf"
    export_gltf(result(model, params), path)
    material = json.loads(path.read_text())["materials"][0]
    back_model, back = parameters_from_material(material)
    f = gltf_eval(back_model, back, L[None], V[None])[0]
    np.testing.assert_allclose(f, expected, rtol=2e-5)


# --- the mesh and the file structure -------------------------------------------

def test_uv_sphere_mesh_is_well_formed():
    pos, normal, tangent, uv, idx = mesh_arrays(uv_sphere(rings=8, segments=16))
    assert pos.dtype == np.float32 and idx.dtype == np.uint16
    np.testing.assert_allclose(np.linalg.norm(normal, axis=1), 1.0, atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(tangent[:, :3], axis=1), 1.0, atol=1e-6)
    np.testing.assert_allclose(np.sum(normal * tangent[:, :3], axis=1), 0.0, atol=1e-6)
    assert np.all(tangent[:, 3] == 1.0)
    assert uv.min() >= 0.0 and uv.max() <= 1.0
    tri = idx.reshape(-1, 3)
    assert len(tri) == 2 * 16 * (8 - 1)     # quads, single triangles at the two poles
    a, b, c = pos[tri[:, 0]], pos[tri[:, 1]], pos[tri[:, 2]]
    n = np.cross(b - a, c - a)
    assert np.all(np.linalg.norm(n, axis=1) > 1e-6)                 # no degenerate triangle
    assert np.all(np.sum(n * (a + b + c), axis=1) > 0)               # counter-clockwise outward


def test_pygltflib_reads_mesh_and_material(tmp_path):
    params = {"albedo": [0.3, 0.2, 0.1], "roughness": 0.5, "f0": [0.08, 0.04, 0.02],
              "clearcoat": 0.4, "clearcoat_roughness": 0.2}
    for suffix in (".gltf", ".glb"):
        path = tmp_path / f"paint{suffix}"
        info = export_gltf(result("ggx+lambert+clearcoat", params), path)
        doc = pygltflib.GLTF2().load(str(path))
        prim = doc.meshes[0].primitives[0]
        for attr in ("POSITION", "NORMAL", "TANGENT", "TEXCOORD_0"):
            assert getattr(prim.attributes, attr) is not None
        assert doc.accessors[prim.attributes.TANGENT].type == "VEC4"
        binary = doc.binary_blob() if suffix == ".glb" else doc.get_data_from_buffer_uri(doc.buffers[0].uri)
        acc = doc.accessors[prim.attributes.POSITION]
        view = doc.bufferViews[acc.bufferView]
        pos = np.frombuffer(binary, np.float32, acc.count * 3, view.byteOffset).reshape(-1, 3)
        np.testing.assert_allclose(np.linalg.norm(pos, axis=1), 1.0, atol=1e-6)
        np.testing.assert_allclose(acc.min, pos.min(axis=0))
        mat = doc.materials[0]
        pbr = info["parameters"]
        assert mat.pbrMetallicRoughness.baseColorFactor[:3] == pytest.approx(pbr["base_color"], rel=1e-12)
        assert mat.extensions["KHR_materials_ior"]["ior"] == pytest.approx(1.789, abs=1e-3)
        assert mat.extensions["KHR_materials_specular"]["specularColorFactor"] == pytest.approx([1, 0.5, 0.25])
        assert mat.extensions["KHR_materials_clearcoat"] == {"clearcoatFactor": 0.4,
                                                             "clearcoatRoughnessFactor": 0.2}
        assert set(doc.extensionsUsed) == {"KHR_materials_ior", "KHR_materials_specular",
                                           "KHR_materials_clearcoat"}
        assert mat.extras["brdf_fit"]["spec"] == "ggx+lambert+clearcoat"


# --- the Khronos validator --------------------------------------------------------

def _validator():
    if shutil.which("node") is None:
        pytest.skip("node is not installed: the Khronos glTF validator (npm gltf-validator) cannot run")
    if not (ROOT / "node_modules" / "gltf-validator").is_dir():
        pytest.skip("node_modules/gltf-validator is missing: `make test` installs it (npm ci)")


def run_validator(paths):
    proc = subprocess.run(["node", str(VALIDATOR_SCRIPT)] + [str(p) for p in paths],
                          capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert proc.returncode in (0, 1), proc.stderr
    return [json.loads(line) for line in proc.stdout.splitlines() if line.strip()]


EXPORT_CASES = {
    "glass": ("ggx+lambert", {"albedo": [0.5, 0.5, 0.5], "roughness": 0.4, "f0": [0.04] * 3}),
    "plastic": ("ggx+burley", {"albedo": [0.27, 0.04, 0.01], "roughness": 0.6, "f0": [0.05] * 3}),
    "paint": ("ggx+lambert+clearcoat", {"albedo": [0.02, 0.03, 0.1], "roughness": 0.5,
                                        "f0": [0.3, 0.2, 0.05], "clearcoat": 0.8,
                                        "clearcoat_roughness": 0.05}),
    "gold": ("ggx+conductor", {"roughness": 0.3, "eta": [0.18, 0.42, 1.37], "k": [3.42, 2.35, 1.77]}),
    "brushed": ("ggx_aniso+lambert", {"albedo": [0.1] * 3, "roughness": 0.4, "anisotropy": -0.7,
                                      "rotation": 0.5, "f0": [0.9, 0.9, 0.9]}),
    "everything": ("gltf+ior+specular+aniso+clearcoat",
                   {"base_color": [0.8, 0.2, 0.1], "metallic": 0.25, "roughness": 0.5, "ior": 1.7,
                    "specular": 0.9, "specular_color": [2.0, 1.0, 0.5], "anisotropy": 0.6,
                    "rotation": -1.0, "clearcoat": 0.5, "clearcoat_roughness": 0.1}),
    "velvet": ("gltf+sheen", {"base_color": [0.3, 0.05, 0.1], "metallic": 0.0, "roughness": 0.8,
                              "sheen_color": [0.6, 0.3, 0.4], "sheen_roughness": 0.5}),
}


def test_khronos_validator_reports_no_errors_and_no_warnings(tmp_path):
    _validator()
    paths = []
    for name, (spec, params) in EXPORT_CASES.items():
        for suffix in (".gltf", ".glb"):
            path = tmp_path / f"{name}{suffix}"
            export_gltf(result(spec, params, material=name), path)
            paths.append(path)
    reports = run_validator(paths)
    assert len(reports) == len(paths)
    for rep in reports:
        assert rep["numErrors"] == 0 and rep["numWarnings"] == 0, rep["messages"]
        assert rep["validatorVersion"].startswith("2.0.0")
    used = {r["file"]: set(r["extensionsUsed"]) for r in reports}
    assert used[str(tmp_path / "everything.glb")] == {
        "KHR_materials_ior", "KHR_materials_specular", "KHR_materials_clearcoat", "KHR_materials_anisotropy"}
    assert used[str(tmp_path / "gold.gltf")] == set()
    # KHR_materials_sheen in extensionsUsed only: a viewer without it draws the base material
    assert used[str(tmp_path / "velvet.glb")] == {"KHR_materials_sheen"}
    for path in (tmp_path / "velvet.gltf",):
        doc = json.loads(path.read_text())
        assert "extensionsRequired" not in doc
        assert doc["materials"][0]["extensions"]["KHR_materials_sheen"] == {
            "sheenColorFactor": [0.6, 0.3, 0.4], "sheenRoughnessFactor": 0.5}


def test_khronos_validator_catches_a_broken_file(tmp_path):
    """The validator run is not a rubber stamp: a non-unit normal is an error."""
    _validator()
    path = tmp_path / "broken.gltf"
    export_gltf(result("gltf", {"base_color": [0.5] * 3, "metallic": 0.0, "roughness": 0.5}), path)
    doc = json.loads(path.read_text())
    doc["materials"][0]["pbrMetallicRoughness"]["roughnessFactor"] = 1.5   # outside [0, 1]
    path.write_text(json.dumps(doc))
    (rep,) = run_validator([path])
    assert rep["numErrors"] >= 1


# --- honesty ------------------------------------------------------------------------

TRUTH = {"albedo": [0.45, 0.2, 0.08], "roughness": 0.35, "f0": [0.05] * 3}


@pytest.fixture(scope="module")
def lambert_data():
    return synthetic_measured("ggx+lambert", TRUTH, grid=(30, 30, 60, 1))


def m1_numpy(model, params, measured, max_theta=80.0):
    """M1 from its definition, with numpy, for any (model, parameters)."""
    sel = measured.select(max_theta_deg=max_theta)
    wi, wo, fhat, w = sel.wi, sel.wo, sel.values, sel.weights
    total = np.zeros(3)
    for a, b in ((wi, wo), (wo, wi)):
        f = gltf_eval(model, params, a, b)
        c = a[:, 2:3]
        total += np.sum(w[:, None] * (np.log1p(f * c) - np.log1p(fhat * c)) ** 2, axis=0)
    return float(np.mean(np.sqrt(total / (2 * w.sum()))))


def test_honesty_reports_both_errors(tmp_path, lambert_data):
    info = export_gltf(result("ggx+lambert", TRUTH), tmp_path / "m.glb", measured=lambert_data)
    h = info["honesty"]
    assert h["m1_fitted_model"] < 1e-9                   # the truth fits its own data exactly
    # the converted material as the engines draw it (brdf.gltf_material.engines_reading)
    expected = m1_numpy(info["model"].replace("gltf+ior", "gltf+ior+turquin"), info["parameters"], lambert_data)
    assert h["m1_exported_gltf"] == pytest.approx(expected, rel=1e-9)
    assert 1e-4 < h["m1_exported_gltf"] < 0.05           # the (1 - F) weighting costs a little
    extras = pygltflib.GLTF2().load(str(tmp_path / "m.glb")).materials[0].extras["brdf_fit"]
    assert extras["honesty"]["m1_exported_gltf"] == pytest.approx(h["m1_exported_gltf"], rel=1e-12)
    assert extras["honesty"]["m1_fitted_model"] == pytest.approx(h["m1_fitted_model"], abs=1e-12)


def test_honesty_of_a_gltf_fit_is_zero(tmp_path):
    params = {"base_color": [0.6, 0.3, 0.2], "metallic": 0.0, "roughness": 0.4, "ior": 1.6}
    data = synthetic_measured("gltf+ior", params, grid=(24, 24, 48, 1))
    info = export_gltf(result("gltf+ior", params), tmp_path / "m.gltf", measured=data)
    assert info["honesty"]["m1_fitted_model"] < 1e-9 and info["honesty"]["m1_exported_gltf"] < 1e-9


def test_without_measurement_the_reason_is_recorded(tmp_path, capsys):
    info = export_gltf(result("ggx+lambert", TRUTH), tmp_path / "m.gltf")
    assert "reason" in info["honesty"] and "m1_exported_gltf" not in info["honesty"]


# --- the command ------------------------------------------------------------------

@pytest.fixture(scope="module")
def fitted_standin(tmp_path_factory):
    """A real fit of ggx+lambert to the red-plastic stand-in (MERL file on disk)."""
    from data_loaders import load
    from brdf_fit.demo import write_standins
    from fitting.fit import fit
    folder = tmp_path_factory.mktemp("standin")
    (path,) = write_standins(folder, ["red-plastic"])
    r = fit(load(path), "ggx+lambert", samples=20_000, starts=1)
    return r.save(folder / "red-plastic.ggx+lambert.json"), path


def test_export_command_prints_both_errors(tmp_path, fitted_standin, capsys):
    from brdf_fit.cli import main
    result_path, measured_path = fitted_standin
    out = tmp_path / "red.glb"
    assert main(["export", str(result_path), "--out", str(out)]) == 0   # measured from provenance
    text = capsys.readouterr().out
    assert "fitted model" in text and "exported material" in text and "image error" in text
    extras = pygltflib.GLTF2().load(str(out)).materials[0].extras["brdf_fit"]
    h = extras["honesty"]
    recorded = FitResult.load(result_path).errors["m1"]
    # the export recomputes the fitted model's M1 on the same samples as the fit did
    assert h["m1_fitted_model"] == pytest.approx(recorded, rel=1e-6)
    assert h["sha256_matches"] is True
    assert h["m1_exported_gltf"] > 0 and h["measured_file"] == str(measured_path)
    assert f"{h['m1_exported_gltf']:.6g}" in text and f"{h['m1_fitted_model']:.6g}" in text


@pytest.mark.parametrize("case", ["missing", "not-json", "suffix", "measured"])
def test_export_command_bad_input(tmp_path, capsys, case, fitted_standin):
    result_path, _ = fitted_standin
    args = {"missing": (tmp_path / "nope.json", tmp_path / "a.glb", None),
            "not-json": (tmp_path / "bad.json", tmp_path / "a.glb", None),
            "suffix": (result_path, tmp_path / "a.obj", None),
            "measured": (result_path, tmp_path / "a.glb", tmp_path / "nope.binary")}[case]
    (tmp_path / "bad.json").write_text("{not json")
    assert export_main(str(args[0]), str(args[1]), measured_path=args[2] and str(args[2])) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("brdf-fit export: error:") and "Traceback" not in err[0]
    assert not (tmp_path / "a.glb").exists()
