"""``brdf-fit library DIR --models openpbr,principled`` (or ``auto,openpbr,principled``): beside
materials.glb, each material's best fit of OpenPBR's models read as MaterialX draws them as one
MaterialX document (materials.mtlx), and its best fit a Principled BSDF draws as one Blender file of
assets (materials.blend, or the script that writes it): brdf_fit/library/native.py."""

import ast
import json
import re
import subprocess

import pytest

import brdf_fit.export.blender_file as blender_file
from brdf_fit.cli import main
from brdf_fit.export.blender_file import material_entry
from brdf_fit.export.openpbr_first import materialx_library
from brdf_fit.export.other_kind import other_kind
from brdf_fit.library.native import NATIVE_FILES, write_native
from data_loaders.samples import write_samples
from fitting.auto import OPENPBR_FAMILY, PRINCIPLED_FAMILY, expand_models
from fitting.ranking import ranked
from fitting.result import FitResult
from fitting.synthetic import synthetic_measured
from materialx_code import validated_open_pbr_surface

TRUTHS = {"tinted-metal": ("openpbr+metal+mx", {"base_color": [0.9, 0.6, 0.5], "specular_color": [0.8, 0.5, 0.3],
                                             "roughness": 0.3}),
          "red plastic": ("openpbr+nonmetal+mx", {"base_color": [0.5, 0.1, 0.05], "specular_ior": 1.5,
                                               "base_diffuse_roughness": 0.3, "roughness": 0.25})}
FAST = ["--samples", "2000", "--starts", "1"]
# each set's bare bases, both kinds (the sets' expansion: the first test below): what the files are
# chosen from and what each names as its other kind
MODELS = "openpbr+metal+mx,openpbr+nonmetal+mx,openpbr+metal,principled+nonmetal"


@pytest.fixture(scope="module")
def library(tmp_path_factory):
    """A library of two small sample lists with the openpbr and principled sets, without a Blender Python
    (the script)."""
    folder = tmp_path_factory.mktemp("database")
    for name, (model, params) in TRUTHS.items():
        m = synthetic_measured(model, params, grid=(12, 12, 24, 1), material=name)
        write_samples(folder / f"{name}.npz", m.wi[m.valid], m.wo[m.valid], m.values[m.valid], material=name,
                      isotropic=True)
    out = tmp_path_factory.mktemp("lib") / "lib"
    patch = pytest.MonkeyPatch()
    patch.setattr(blender_file, "blender_python", lambda: None)
    try:
        assert main(["library", str(folder), "--out", str(out), "--models", MODELS, *FAST, "-q"]) == 0
    finally:
        patch.undo()
    by_material = {}
    for path in sorted((out / "results").glob("*.json")):
        result = FitResult.load(path)
        by_material.setdefault(result.material, []).append(result)
    best = {m: ranked([r for r in rs if r.spec in OPENPBR_FAMILY])[0] for m, rs in by_material.items()}
    bare = {m: ranked([r for r in rs if r.spec in PRINCIPLED_FAMILY])[0] for m, rs in by_material.items()}
    return out, folder, best, bare


def test_the_sets_are_both_families_and_the_fixture_fits_their_bare_bases():
    assert expand_models("openpbr,principled") == list(OPENPBR_FAMILY) + list(PRINCIPLED_FAMILY)
    assert set(MODELS.split(",")) <= set(OPENPBR_FAMILY) | set(PRINCIPLED_FAMILY)
    assert not any("coat" in m or "fuzz" in m or "sheen" in m for m in MODELS.split(","))


def test_the_mtlx_holds_each_materials_best_openpbr_fit(library):
    out, _, best, _ = library
    text = (out / "materials.mtlx").read_text()
    for material, result in best.items():
        name = "M_" + re.sub(r"[^A-Za-z0-9_]", "_", material) + "_open_pbr"
        values = validated_open_pbr_surface(out / "materials.mtlx", {"materials": {name: "open_pbr_surface"}})
        assert values["specular_roughness"] == pytest.approx(result.parameters["roughness"], rel=2e-7)
        assert values["base_metalness"] == (1.0 if result.spec.startswith("openpbr+metal") else 0.0)
        assert result.spec.endswith("+mx")                  # read as MaterialX draws it
        assert values.get("coat_weight", 0.0) == pytest.approx(result.parameters.get("coat_weight", 0.0), rel=2e-7)
    assert text.count("<open_pbr_surface ") == 2 and "gltf_pbr" not in text
    assert text.count('brdf_fit_other_kind="openpbr+') == 2          # each names its other kind (both fitted)
    assert best["tinted-metal"].spec.startswith("openpbr+metal")
    assert best["red plastic"].spec.startswith("openpbr+nonmetal")


def test_without_blender_the_script_is_written_and_linked(library):
    """The Blender file holds each material's best fit of the bare bases (Blender's coat is not OpenPBR's)."""
    out, _, _, bare = library
    assert not (out / "materials.blend").exists()
    text = (out / "materials_blender.py").read_text()
    compile(text, "materials_blender.py", "exec")
    payload = json.loads(ast.literal_eval(re.search(r"^MATERIALS = json.loads\((.*)\)$", text, re.M).group(1)))
    results = {}
    for path in (out / "results").glob("*.json"):
        result = FitResult.load(path)
        results.setdefault(result.material, []).append(result)
    # each names the best fit of the other kind (both kinds are in the set 'principled')
    expected = [material_entry(r, other_kind(r, results[m], blender_file.drawn_by_principled)) for m, r in bare.items()]
    assert all(e["properties"]["brdf_fit_other_kind"] for e in expected)
    assert sorted(payload, key=lambda e: e["name"]) == sorted(expected, key=lambda e: e["name"])
    index = (out / "index.html").read_text()
    assert 'href="materials.mtlx"' in index and 'href="materials_blender.py"' in index


def test_the_command_names_the_files(library, capsys):
    """``library --json`` lists the native files written (here, again from the results on disk)."""
    out, folder, _, _ = library
    patch = pytest.MonkeyPatch()
    patch.setattr(blender_file, "blender_python", lambda: None)
    try:
        assert main(["library", str(folder), "--out", str(out), "--models", MODELS, *FAST,
                     "--json", "-q"]) == 0
    finally:
        patch.undo()
    doc = json.loads(capsys.readouterr().out)
    assert sorted(doc["native"]) == sorted(str(out / n) for n in ("materials.mtlx", "materials_blender.py"))


@pytest.mark.skipif(blender_file.blender_python() is None or len(blender_file.blender_python()) != 1,
                    reason="no Blender Python with bpy (make blender)")
def test_with_blender_the_same_command_writes_the_blend(library):
    out, folder, _, bare = library
    assert main(["library", str(folder), "--out", str(out), "--models", MODELS, *FAST, "-q"]) == 0
    assert (out / "materials.blend").is_file() and not (out / "materials_blender.py").exists()
    read = ("import bpy, json, sys\nbpy.ops.wm.open_mainfile(filepath=sys.argv[1])\n"
            "print(json.dumps({m.name: [m.asset_data is not None, m['brdf_fit_spec']] for m in bpy.data.materials}))")
    run = subprocess.run(blender_file.blender_python() + ["-c", read, str(out / "materials.blend")],
                         capture_output=True, text=True, check=True)
    got = json.loads(run.stdout.strip().splitlines()[-1])
    assert got == {m: [True, r.spec] for m, r in bare.items()}


def test_names_are_made_unique_and_a_library_without_openpbr_fits_has_none(tmp_path):
    def fit(material, model, params):
        return FitResult(spec=model, parameters=params, errors={"m1": 0.01, "image": 0.02},
                         optimizer={"max_theta": 80.0}, provenance={"file": None, "sha256": None, "format": None,
                                                                     "material": material})
    text = materialx_library([fit("a-b", *TRUTHS["tinted-metal"]), fit("a_b", *TRUTHS["red plastic"])])
    assert 'name="M_a_b_open_pbr"' in text and 'name="M_a_b_2_open_pbr"' in text
    assert text.count('<attributedef name="AD_brdf_fit_spec"') == 1
    for name in NATIVE_FILES:
        (tmp_path / name).write_text("an earlier run's")
    gltf = fit("m", "gltf+metal", {"base_color": [0.9, 0.6, 0.5], "roughness": 0.3})
    assert write_native({"m": [gltf]}, tmp_path, log=print) == []
    assert not any((tmp_path / name).exists() for name in NATIVE_FILES)
