"""MaterialX export: the document validates with MaterialX's own library, its
values round-trip to the glTF conversion's, OpenPBR reproduces glTF's F0, F90
and alpha pair, shaders generate, the honesty numbers, the command line."""

import json
import math
import pathlib
import xml.etree.ElementTree as ET

import numpy as np
import pytest

MaterialX = pytest.importorskip("MaterialX")   # the dev extra; not a run-time dependency

from brdf import parse_model  # noqa: E402
from brdf.fresnel import f0_from_ior  # noqa: E402
from brdf.gltf_material import convert  # noqa: E402
from brdf.materialx import FULL_GLTF_MODEL, GLTF_PBR_INPUTS, OPEN_PBR_ONLY, gltf_values, value_string  # noqa: E402
from brdf.specular import anisotropy_gltf  # noqa: E402
from brdf_fit.export.gltf import export_gltf, export_main  # noqa: E402
from brdf_fit.export.gltf_file import ExportError  # noqa: E402
from brdf_fit.export.materialx_file import export_materialx  # noqa: E402
from fitting.result import FitResult  # noqa: E402
from fitting.synthetic import synthetic_measured  # noqa: E402

PACKAGE = pathlib.Path(MaterialX.__file__).resolve().parent
FLOAT32 = dict(rtol=2e-7, atol=1e-7)     # MaterialX holds its values as 32-bit floats
APPROX32 = dict(rel=2e-7, abs=1e-7)

CASES = {
    "ggx+lambert": ("ggx+lambert", {"albedo": [0.3, 0.2, 0.1], "roughness": 0.5, "f0": [0.05] * 3}),
    "ggx+lambert-chromatic": ("ggx+lambert", {"albedo": [0.3, 0.2, 0.1], "roughness": 0.5,
                                               "f0": [0.08, 0.04, 0.02]}),
    "gltf+ior+specular": ("gltf+ior+specular",
                          {"base_color": [0.7, 0.4, 0.2], "metallic": 0.0, "roughness": 0.4, "ior": 1.7,
                           "specular": 0.8, "specular_color": [1.0, 0.7, 0.4]}),
    "gltf+clearcoat": ("gltf+clearcoat", {"base_color": [0.6, 0.3, 0.2], "metallic": 0.0, "roughness": 0.35,
                                          "clearcoat": 0.7, "clearcoat_roughness": 0.08}),
    "ggx_aniso+lambert": ("ggx_aniso+lambert", {"albedo": [0.1] * 3, "roughness": 0.4, "anisotropy": -0.7,
                                                "rotation": 0.5, "f0": [0.05] * 3}),
    "ggx_aniso+lambert-metal": ("ggx_aniso+lambert", {"albedo": [0.02] * 3, "roughness": 0.3,
                                                      "anisotropy": 0.5, "rotation": -0.3,
                                                      "f0": [0.9, 0.8, 0.6]}),
    "ggx+lambert+clearcoat": ("ggx+lambert+clearcoat",
                              {"albedo": [0.02, 0.03, 0.1], "roughness": 0.5, "f0": [0.3, 0.2, 0.05],
                               "clearcoat": 0.8, "clearcoat_roughness": 0.05}),
    "gold": ("ggx+conductor", {"roughness": 0.3, "eta": [0.18, 0.42, 1.37], "k": [3.42, 2.35, 1.77]}),
    "everything": ("gltf+ior+specular+aniso+clearcoat",
                   {"base_color": [0.8, 0.2, 0.1], "metallic": 0.25, "roughness": 0.5, "ior": 1.7,
                    "specular": 0.9, "specular_color": [2.0, 1.0, 0.5], "anisotropy": 0.6,
                    "rotation": -1.0, "clearcoat": 0.5, "clearcoat_roughness": 0.1}),
    "gltf+diffuse_roughness": ("gltf+specular+diffuse_roughness+clearcoat",
                               {"base_color": [0.6, 0.5, 0.4], "metallic": 0.0, "roughness": 0.45,
                                "specular": 0.7, "specular_color": [1.0, 0.9, 0.8], "diffuse_roughness": 0.65,
                                "clearcoat": 0.3, "clearcoat_roughness": 0.1}),
    "gltf+sheen": ("gltf+specular+sheen+clearcoat",
                   {"base_color": [0.3, 0.1, 0.15], "metallic": 0.0, "roughness": 0.7, "specular": 0.8,
                    "specular_color": [1.0, 1.0, 1.0], "sheen_color": [0.8, 0.4, 0.6], "sheen_roughness": 0.35,
                    "clearcoat": 0.2, "clearcoat_roughness": 0.3}),
}


def result(spec, params, material="test material", provenance=None):
    return FitResult(spec=spec, parameters=params, errors={"m1": 0.0}, optimizer={"max_theta": 80.0},
                     provenance=provenance or {"file": None, "sha256": None, "format": None,
                                               "material": material})


@pytest.fixture(scope="module")
def libraries():
    libs = MaterialX.createDocument()
    MaterialX.loadLibraries(["libraries"], MaterialX.FileSearchPath(str(PACKAGE)), libs)
    return libs


def read(path, libraries):
    doc = MaterialX.createDocument()
    MaterialX.readFromXmlFile(doc, str(path))
    doc.setDataLibrary(libraries)
    return doc


def python_value(value):
    """A MaterialX value as a float or an [r, g, b] list."""
    return list(value.asTuple()) if hasattr(value, "asTuple") else float(value)


def inputs_of(node):
    return {i.getName(): python_value(i.getValue()) for i in node.getInputs() if i.hasValueString()}


def shader_of(doc, material_name):
    return doc.getNode(material_name).getInput("surfaceshader").getConnectedNode()


@pytest.fixture(scope="module", params=sorted(CASES))
def exported(request, tmp_path_factory, libraries):
    spec, params = CASES[request.param]
    path = tmp_path_factory.mktemp("mtlx") / f"{request.param}.mtlx"
    info = export_materialx(result(spec, params), path)
    return convert(spec, params), info, read(path, libraries), path


# --- the document ----------------------------------------------------------------

def test_document_validates_without_messages(exported):
    _, info, doc, _ = exported
    valid, message = doc.validate()
    assert valid and message == ""
    assert {m.getName() for m in doc.getMaterialNodes()} == set(info["materials"])
    nodedefs = {"gltf_pbr": "ND_gltf_pbr_surfaceshader", "open_pbr_surface": "ND_open_pbr_surface_surfaceshader"}
    for name, category in info["materials"].items():
        shader = shader_of(doc, name)
        assert shader.getCategory() == category
        assert shader.getNodeDef().getName() == nodedefs[category]


def test_gltf_pbr_values_round_trip_to_the_conversion(exported):
    conversion, info, doc, path = exported
    (material,) = [n for n, c in info["materials"].items() if c == "gltf_pbr"]
    back = inputs_of(shader_of(doc, material))
    schema = [p for p in parse_model(conversion["model"]).schema() if (p.gltf.owner, p.gltf.key) not in OPEN_PBR_ONLY]
    assert set(back) == {GLTF_PBR_INPUTS[(p.gltf.owner, p.gltf.key)] for p in schema}
    # through our own XML reading (float64): every value exactly, the rotation up to its period
    root = ET.parse(path).getroot()
    (node,) = root.iter("gltf_pbr")
    text = {i.get("name"): [float(x) for x in i.get("value").split(",")] for i in node.iter("input")}
    for param in schema:
        expected = conversion["parameters"][param.name]
        name = GLTF_PBR_INPUTS[(param.gltf.owner, param.gltf.key)]
        # MaterialX reads the written value as a 32-bit float
        assert np.atleast_1d(back[name]).tolist() == np.float32(text[name]).astype(float).tolist()
        if param.size == 3:
            assert text[name] == list(expected)
        else:
            assert 0.0 <= text[name][0] < (param.period or math.inf)
            assert float(param.wrap(text[name][0])) == pytest.approx(expected, rel=1e-15, abs=1e-15)


def test_open_pbr_reproduces_gltf_f0_f90_and_alphas(exported, libraries):
    """F0, F90 (OpenPBR's dielectric_bsdf with its tint and the coat-relative IOR of
    open_pbr_surface.mtlx's eta_s nodes), the alpha pair (its open_pbr_anisotropy
    graph, after its coat roughening) against glTF's from the conversion."""
    conversion, info, doc, _ = exported
    (material,) = [n for n, c in info["materials"].items() if c == "open_pbr_surface"]
    shader = shader_of(doc, material)
    o = {**inputs_of(shader.getNodeDef()), **inputs_of(shader)}      # the nodedef's defaults, then ours
    g = gltf_values(conversion)
    np.testing.assert_allclose(o["base_color"], g["base_color"], **FLOAT32)
    assert o["base_metalness"] == pytest.approx(g["metallic"], **APPROX32)
    assert o["coat_weight"] == pytest.approx(g["clearcoat"], **APPROX32)
    if g["clearcoat"] > 0:
        assert o["coat_roughness"] == pytest.approx(g["clearcoat_roughness"], **APPROX32)
        assert f0_from_ior(o["coat_ior"]) == pytest.approx(0.04, rel=1e-6)   # glTF's coat F0
    # OpenPBR's graph: eta_s = mix(specular_ior, ratio to coat_ior, coat_weight), F = tint F(eta_s)
    ratio = o["specular_ior"] / o["coat_ior"]
    eta_s = (1 - o["coat_weight"]) * o["specular_ior"] + o["coat_weight"] * (ratio if ratio > 1 else 1 / ratio)
    if g["metallic"] < 1:
        f0_gltf = np.minimum(f0_from_ior(g["ior"]) * np.array(g["specular_color"]), 1.0) * g["specular"]
        np.testing.assert_allclose(np.array(o["specular_color"]) * f0_from_ior(eta_s), f0_gltf, rtol=2e-6)
        assert max(o["specular_color"]) == pytest.approx(g["specular"], rel=1e-6)     # F90
    else:
        assert o["specular_color"] == [1.0, 1.0, 1.0]            # no F82 tint: glTF's Schlick metal
    assert o["specular_weight"] == 1.0
    r = o["specular_roughness"]
    r_eff = ((1 - o["coat_weight"]) * r
             + o["coat_weight"] * min(1.0, 2 * o["coat_roughness"] ** 4 + r ** 4) ** 0.25)
    a = o["specular_roughness_anisotropy"]
    alpha_x = r_eff ** 2 * math.sqrt(2 / (1 + (1 - a) ** 2))
    alpha_t, alpha_b = anisotropy_gltf(g["roughness"] ** 2, g["anisotropy"])
    assert (alpha_x, (1 - a) * alpha_x) == pytest.approx((float(alpha_t), float(alpha_b)), rel=1e-5)


def test_open_pbr_tangent_turns_as_gltf_pbr_does(exported, libraries):
    conversion, info, doc, _ = exported
    (material,) = [n for n, c in info["materials"].items() if c == "open_pbr_surface"]
    tangent = shader_of(doc, material).getInput("geometry_tangent")
    rotation = info["materialx_inputs"]["gltf_pbr"].get("anisotropy_rotation", 0.0)
    if rotation == 0.0:
        assert tangent is None
        return
    graph = doc.getNodeGraph(tangent.getNodeGraphString())
    amount = graph.getNode("rotated_tangent").getInputValue("amount")
    # gltf_pbr's implementation: rotate3d by anisotropy_rotation x (its rad_2_deg factor)
    factor = libraries.getNodeGraph("IMPL_gltf_pbr_surfaceshader").getNode("rad_2_deg").getInputValue("in2")
    assert amount == pytest.approx(rotation * factor, rel=1e-6)


def test_notes_name_what_open_pbr_approximates(exported):
    conversion, info, _, _ = exported
    notes = " ".join(info["materialx_notes"]["open_pbr_surface"])
    g = gltf_values(conversion)
    if g["metallic"] < 1:
        assert "exact one of IOR" in notes
    if g["clearcoat"] > 0:
        assert "coat_darkening 0" in notes and "specular_roughness" in notes
    assert "GGX energy compensation" in info["materialx_notes"]["gltf_pbr"][0]


def test_diffuse_roughness_is_open_pbrs_base_diffuse_roughness(exported):
    """KHR_materials_diffuse_roughness (EON in both) is open_pbr_surface's base_diffuse_roughness,
    the same value; gltf_pbr has no such input, and its notes say so."""
    conversion, info, doc, path = exported
    factor = conversion["parameters"].get("diffuse_roughness")
    (material,) = [n for n, c in info["materials"].items() if c == "open_pbr_surface"]
    written = inputs_of(shader_of(doc, material)).get("base_diffuse_roughness", 0.0)
    assert written == pytest.approx(factor or 0.0, rel=1e-7)
    (gltf_material,) = [n for n, c in info["materials"].items() if c == "gltf_pbr"]
    assert "base_diffuse_roughness" not in inputs_of(shader_of(doc, gltf_material))
    dropped = [n for n in info["materialx_notes"]["gltf_pbr"] if "diffuseRoughnessFactor" in n]
    assert len(dropped) == (factor is not None)


def test_sheen_is_gltf_pbrs_sheen_and_open_pbrs_fuzz(exported):
    """KHR_materials_sheen: gltf_pbr's sheen_color / sheen_roughness, the same values (the
    round trip above); open_pbr_surface's fuzz split as MaterialX's own gltf_pbr graph splits
    it for its sheen_bsdf (weight max sheenColor, colour sheenColor / max), its notes naming
    the other lobe; no fuzz without a sheen."""
    conversion, info, doc, path = exported
    color = conversion["parameters"].get("sheen_color")
    (material,) = [n for n, c in info["materials"].items() if c == "open_pbr_surface"]
    written = inputs_of(shader_of(doc, material))
    if color is None:
        assert "fuzz_weight" not in written
        return
    assert written["fuzz_weight"] == pytest.approx(max(color), rel=1e-7)
    np.testing.assert_allclose(np.asarray(written["fuzz_color"]) * written["fuzz_weight"], color, rtol=1e-7)
    assert written["fuzz_roughness"] == pytest.approx(conversion["parameters"]["sheen_roughness"], rel=1e-7)
    assert any("Zeltner" in n for n in info["materialx_notes"]["open_pbr_surface"])
    assert any("sheen_bsdf" in n for n in info["materialx_notes"]["gltf_pbr"])


def test_gltf_pbr_nodedef_agrees_with_the_declarations(libraries):
    """Every glTF parameter has its gltf_pbr input (or, gltf_pbr lacking one, its
    open_pbr_surface input), of its size, with the glTF default."""
    for param in parse_model(FULL_GLTF_MODEL).schema():
        key = (param.gltf.owner, param.gltf.key)
        if key in OPEN_PBR_ONLY:
            inp = libraries.getNodeDef("ND_open_pbr_surface_surfaceshader").getInput(OPEN_PBR_ONLY[key])
            assert libraries.getNodeDef("ND_gltf_pbr_surfaceshader").getInput(OPEN_PBR_ONLY[key]) is None
        else:
            inp = libraries.getNodeDef("ND_gltf_pbr_surfaceshader").getInput(GLTF_PBR_INPUTS[key])
        assert inp is not None and inp.getType() == ("color3" if param.size == 3 else "float")
        default = python_value(inp.getValue())
        assert default == ([param.gltf.default] * 3 if param.size == 3 else param.gltf.default)


@pytest.mark.parametrize("case", ["ggx_aniso+lambert", "ggx+lambert+clearcoat", "everything"])
def test_shaders_generate(tmp_path, case, libraries):
    from MaterialX import PyMaterialXGenGlsl as gen_glsl
    from MaterialX import PyMaterialXGenOsl as gen_osl
    from MaterialX import PyMaterialXGenShader as gen_shader
    path = tmp_path / "m.mtlx"
    info = export_materialx(result(*CASES[case]), path)
    doc = read(path, libraries)
    for generator in (gen_glsl.GlslShaderGenerator.create(), gen_osl.OslShaderGenerator.create()):
        context = gen_shader.GenContext(generator)
        context.registerSourceCodeSearchPath(MaterialX.FileSearchPath(str(PACKAGE)))
        for name in info["materials"]:
            shader = generator.generate(name, doc.getNode(name), context)
            assert len(shader.getSourceCode(gen_shader.PIXEL_STAGE)) > 1000


def test_value_strings_refuse_non_finite_numbers():
    assert value_string([0.25, 0.5, 1.0]) == "0.25, 0.5, 1.0"
    for bad in (float("nan"), [0.1, float("inf"), 0.2]):
        with pytest.raises(ValueError, match="finite"):
            value_string(bad)


# --- honesty and provenance -----------------------------------------------------------

TRUTH = {"albedo": [0.45, 0.2, 0.08], "roughness": 0.35, "f0": [0.05] * 3}


def test_honesty_is_the_gltf_exports(tmp_path, libraries):
    data = synthetic_measured("ggx+lambert", TRUTH, grid=(24, 24, 48, 1))
    r = result("ggx+lambert", TRUTH)
    info = export_materialx(r, tmp_path / "m.mtlx", measured=data)
    gltf_info = export_gltf(r, tmp_path / "m.gltf", measured=data)
    h = info["honesty"]
    assert h == gltf_info["honesty"]
    assert h["m1_fitted_model"] < 1e-9 < h["m1_exported_gltf"]
    doc = read(tmp_path / "m.mtlx", libraries)
    for name in info["materials"]:
        mat = doc.getNode(name)
        assert float(mat.getAttribute("brdf_fit_m1_exported_gltf")) == h["m1_exported_gltf"]
        assert mat.getAttribute("brdf_fit_spec") == "ggx+lambert"
        assert mat.getAttribute("brdf_fit_gltf_model") == info["model"]
        assert mat.getAttribute("brdf_fit_honesty_measured_file") == h["measured_file"]


def test_without_measurement_the_reason_is_given(tmp_path):
    info = export_materialx(result("ggx+lambert", TRUTH), tmp_path / "m.mtlx")
    assert "reason" in info["honesty"] and "m1_exported_gltf" not in info["honesty"]


def test_wrong_suffix_is_refused(tmp_path):
    with pytest.raises(ExportError, match=r"\.mtlx"):
        export_materialx(result("ggx+lambert", TRUTH), tmp_path / "m.gltf")
    assert not (tmp_path / "m.gltf").exists()


# --- the command ------------------------------------------------------------------------

@pytest.fixture(scope="module")
def result_on_disk(tmp_path_factory):
    """A result whose provenance is a measured file on disk (the red-plastic stand-in)."""
    from data_loaders import load
    from brdf_fit.demo import write_standins
    folder = tmp_path_factory.mktemp("standin")
    (path,) = write_standins(folder, ["red-plastic"])
    measured = load(path)
    r = result("ggx+lambert", TRUTH, provenance={"file": str(path), "sha256": measured.provenance.sha256,
                                                 "format": None, "material": "red-plastic"})
    return r.save(folder / "red-plastic.ggx+lambert.json")


def test_export_command_writes_mtlx_and_prints_the_m1_line(tmp_path, result_on_disk, capsys, libraries):
    from brdf_fit.cli import main
    out = tmp_path / "red.mtlx"
    assert main(["export", str(result_on_disk), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    doc = read(out, libraries)
    assert doc.validate() == (True, "")
    (mat,) = [m for m in doc.getMaterialNodes() if m.getName().endswith("_gltf_pbr")]
    m1_exported = float(mat.getAttribute("brdf_fit_m1_exported_gltf"))
    line = next(li for li in text.splitlines() if li.strip().startswith("M1 "))
    assert "fitted model" in line and f"exported material {m1_exported:.6g}" in line
    assert "open_pbr_surface note:" in text


def test_export_command_json(tmp_path, result_on_disk, capsys):
    from brdf_fit.cli import main
    out = tmp_path / "red.mtlx"
    assert main(["export", str(result_on_disk), "--out", str(out), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert set(info["materials"].values()) == {"gltf_pbr", "open_pbr_surface"}
    assert info["path"] == str(out) and info["honesty"]["m1_exported_gltf"] > 0


@pytest.mark.parametrize("via", ["cli", "export_main"])
def test_export_command_bad_suffix(tmp_path, result_on_disk, capsys, via):
    from brdf_fit.cli import main
    out = tmp_path / "m.mtl"
    code = (main(["export", str(result_on_disk), "--out", str(out)]) if via == "cli"
            else export_main(str(result_on_disk), str(out)))
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("brdf-fit export: error:") and ".mtlx" in err[0]
    assert not out.exists()
