"""The library's materials.glb (brdf_fit.library.glb): seven materials of different model
families in one binary glTF file.

- the Khronos glTF validator reports 0 errors and 0 warnings, and the union of the
  materials' extensions;
- node, mesh and material names are the given names; each material is, key for key,
  the material ``export_gltf`` writes for that result alone (read back from both
  files); the node labels carry the model and the exported material's errors;
- the nodes sit on the grid the module documents (3 columns for 7 entries, SPACING
  2.5 apart, centred at the origin), the sphere's buffer is stored once;
- three.js draws it in headless Chromium with an orthographic camera: each grid cell
  of a material holds one disc of the projected area pi r^2 (r = SPHERE_RADIUS in
  pixels) centred where the layout puts it, most of it lit; the two empty cells are
  empty;
- bad input (no entries, a duplicate name, not .glb, a NaN) is an ExportError and writes nothing.
"""

import base64
import io
import json
import math
import pathlib
import struct

import numpy as np
import pytest

from brdf_fit.export.gltf import export_gltf
from brdf_fit.export.gltf_file import ExportError
from brdf_fit.library.glb import SPACING, SPHERE_RADIUS, grid_columns, write_materials_glb
from data_loaders.samples import write_samples
from fitting.result import FitResult
from fitting.synthetic import synthetic_measured

# name: (model, parameters, errors); names equal the results' own material names
CASES = {
    "red-gltf": ("gltf", {"base_color": [0.8, 0.2, 0.1], "metallic": 0.0, "roughness": 0.5},
                 {"m1": 0.11, "image": 0.021}),
    "coated-gltf": ("gltf+clearcoat", {"base_color": [0.1, 0.3, 0.7], "metallic": 0.0, "roughness": 0.6,
                                       "clearcoat": 0.8, "clearcoat_roughness": 0.1}, {"m1": 0.2}),
    "tinted-gltf": ("gltf+specular", {"base_color": [0.4, 0.4, 0.1], "metallic": 0.0, "roughness": 0.4,
                                      "specular": 0.9, "specular_color": [2.0, 1.0, 0.5]}, {"m1": 0.3}),
    "plastic": ("ggx+lambert", {"albedo": [0.27, 0.04, 0.01], "roughness": 0.35, "f0": [0.05] * 3},
                {"m1": 0.12, "image": 0.03, "exported_model": "gltf+ior", "exported_m1": 0.125,
                 "exported_image": 0.031}),
    "gold": ("ggx+conductor", {"roughness": 0.3, "eta": [0.18, 0.42, 1.37], "k": [3.42, 2.35, 1.77]},
             {"m1": 0.09}),
    "brushed": ("ggx_aniso+lambert", {"albedo": [0.1] * 3, "roughness": 0.4, "anisotropy": -0.7,
                                      "rotation": 0.5, "f0": [0.9, 0.9, 0.9]}, {"m1": 0.15}),
    "measured-paint": ("ggx+lambert+clearcoat", {"albedo": [0.3, 0.2, 0.1], "roughness": 0.5,
                                                 "f0": [0.08, 0.04, 0.02], "clearcoat": 0.4,
                                                 "clearcoat_roughness": 0.2}, {"m1": 0.4}),
}
MEASURED = "measured-paint"          # its provenance file exists: the export measures its errors
# the documented layout for 7 entries: 3 columns, 3 rows, read like text, centred at the origin
EXPECTED_CENTRES = [(-2.5, 2.5), (0.0, 2.5), (2.5, 2.5), (-2.5, 0.0), (0.0, 0.0), (2.5, 0.0), (-2.5, -2.5)]
PIXELS_PER_UNIT = 40                 # the render: 3 x 2.5 units -> 300 px square
DISC_TOLERANCE = 0.01                # drawn pixels of a sphere against pi r^2 (5024 of 5027 measured:
                                     # the 64-gon silhouette, its rasterised edge)
LIT_FRACTION = 0.5                   # of the disc brighter than 16/255 (measured: 0.91 gold, 1.0 the others)


def _results(folder):
    truth = {"albedo": [0.3, 0.2, 0.1], "roughness": 0.5, "f0": [0.05] * 3}
    m = synthetic_measured("ggx+lambert", truth, grid=(6, 6, 12, 1), seed=1)
    keep = np.flatnonzero(m.valid)
    table = folder / f"{MEASURED}.npz"
    write_samples(table, m.wi[keep], m.wo[keep], m.values[keep], material=MEASURED, isotropic=True)
    out = []
    for name, (spec, params, errors) in CASES.items():
        provenance = {"file": str(table) if name == MEASURED else None, "sha256": None, "format": None,
                      "material": name}
        out.append((name, FitResult(spec=spec, parameters=params, errors=errors,
                                    optimizer={"max_theta": 80.0}, provenance=provenance)))
    return out


def read_glb(path):
    """(JSON dict, BIN chunk bytes) of a .glb (glTF 2.0 spec, section "Binary glTF Layout")."""
    data = pathlib.Path(path).read_bytes()
    magic, version, total = struct.unpack_from("<4sII", data, 0)
    assert (magic, version, total) == (b"glTF", 2, len(data))
    n, kind = struct.unpack_from("<I4s", data, 12)
    assert kind == b"JSON"
    doc = json.loads(data[20:20 + n])
    m, kind = struct.unpack_from("<I4s", data, 20 + n)
    assert kind == b"BIN\0"
    return doc, data[28 + n:28 + n + m]


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    folder = tmp_path_factory.mktemp("library-glb")
    entries = _results(folder)
    path = write_materials_glb(entries, folder / "materials.glb")
    return folder, entries, path


def test_the_khronos_validator_reports_no_errors_or_warnings(written):
    from test_export import _validator, run_validator
    _validator()
    _, entries, path = written
    [report] = run_validator([path])
    assert report["numErrors"] == 0 and report["numWarnings"] == 0, report["messages"]
    assert set(report["extensionsUsed"]) == {"KHR_materials_clearcoat", "KHR_materials_specular",
                                             "KHR_materials_ior", "KHR_materials_anisotropy"}


def test_each_material_is_its_single_export(written):
    folder, entries, path = written
    doc, _ = read_glb(path)
    names = [name for name, _ in entries]
    assert [n["name"] for n in doc["nodes"]] == names
    assert [m["name"] for m in doc["materials"]] == names
    assert [m["name"] for m in doc["meshes"]] == names
    assert doc["scenes"][doc["scene"]]["nodes"] == list(range(len(names)))
    used = []
    for i, (name, result) in enumerate(entries):
        node = doc["nodes"][i]
        [primitive] = doc["meshes"][node["mesh"]]["primitives"]
        alone, _ = read_glb(export_gltf(result, folder / f"alone-{i}.glb")["path"])
        assert doc["materials"][primitive["material"]] == alone["materials"][0], name
        used += [e for e in alone.get("extensionsUsed", []) if e not in used]
    assert doc["extensionsUsed"] == used
    # the measured one carries the export's honesty numbers, computed from its provenance file
    honesty = doc["materials"][names.index(MEASURED)]["extras"]["brdf_fit"]["honesty"]
    assert honesty["m1_exported_gltf"] > 0 and honesty["measured_file"].endswith(f"{MEASURED}.npz")


def test_node_labels_carry_the_model_and_the_exported_errors(written):
    _, entries, path = written
    doc, _ = read_glb(path)
    labels = {n["name"]: n["extras"]["brdf_fit"] for n in doc["nodes"]}
    for name, result in entries:
        assert labels[name]["material"] == name and labels[name]["model"] == result.spec
    # lossless (a gltf fit): the fit's own errors are the material's
    assert labels["red-gltf"]["exported_m1"] == 0.11 and labels["red-gltf"]["exported_image"] == 0.021
    assert "exported_image" not in labels["coated-gltf"]
    # recorded by an export-first fit
    assert labels["plastic"]["exported_model"] == "gltf+ior"
    assert (labels["plastic"]["exported_m1"], labels["plastic"]["exported_image"]) == (0.125, 0.031)
    # lossy, nothing recorded, no measured file: unknown, not invented
    assert "exported_m1" not in labels["gold"] and "exported_image" not in labels["gold"]
    # measured by the export's honesty check
    [measured] = [m for m in doc["materials"] if m["name"] == MEASURED]
    honesty = measured["extras"]["brdf_fit"]["honesty"]
    assert labels[MEASURED]["exported_m1"] == honesty["m1_exported_gltf"]
    assert labels[MEASURED]["exported_image"] == honesty["image_exported_gltf"]


def test_the_spheres_form_the_documented_grid(written):
    _, entries, path = written
    doc, binary = read_glb(path)
    assert grid_columns(len(entries)) == 3 and SPACING == 2.5
    centres = np.array([n["translation"] for n in doc["nodes"]])
    np.testing.assert_array_equal(centres[:, :2], EXPECTED_CENTRES)
    assert np.all(centres[:, 2] == 0.0)
    # centred: the grid's rectangle (3 x 3 cells) is symmetric about the origin
    assert centres[:, 0].min() == -centres[:, 0].max() and centres[:, 1].min() == -centres[:, 1].max()
    # the sphere's radius (POSITION bounds) leaves a gap between neighbours
    primitive = doc["meshes"][0]["primitives"][0]
    position = doc["accessors"][primitive["attributes"]["POSITION"]]
    assert max(position["max"]) == pytest.approx(SPHERE_RADIUS, abs=1e-6)
    gaps = np.linalg.norm(centres[:, None] - centres[None], axis=-1) + np.eye(len(centres)) * 1e9
    assert gaps.min() == SPACING > 2 * SPHERE_RADIUS
    # one set of accessors for every mesh: the sphere is stored once
    assert all(m["primitives"][0]["attributes"] == primitive["attributes"]
               and m["primitives"][0]["indices"] == primitive["indices"] for m in doc["meshes"])
    assert len(doc["accessors"]) == 5 and doc["buffers"] == [{"byteLength": len(binary)}]


@pytest.mark.parametrize("case", ["empty", "duplicate", "suffix", "nan"])
def test_bad_input_is_an_export_error_and_writes_nothing(tmp_path, case):
    def gltf(seconds=1.0):
        return FitResult(spec="gltf", parameters={"base_color": [0.5] * 3, "metallic": 0.0, "roughness": 0.5},
                         errors={"m1": 0.1}, optimizer={"seconds_total": seconds},
                         provenance={"file": None, "material": "a"})
    path = tmp_path / ("materials.gltf" if case == "suffix" else "materials.glb")
    # "nan": a non-finite number anywhere (here the optimizer's time, copied into the material's
    # extras) is refused: a glTF file holds finite numbers only
    entries = {"empty": [], "duplicate": [("a", gltf()), ("a", gltf())], "suffix": [("a", gltf())],
               "nan": [("a", gltf()), ("b", gltf(float("nan")))]}[case]
    expected = {"empty": "no materials", "duplicate": "given twice", "suffix": "must end in .glb",
                "nan": "finite numbers only"}[case]
    with pytest.raises(ExportError, match=expected):
        write_materials_glb(entries, path)
    assert list(tmp_path.iterdir()) == []


# --- three.js in headless Chromium ---------------------------------------------------------

PAGE = """<!doctype html>
<html><head><meta charset="utf-8"><link rel="icon" href="data:,"><title>materials.glb</title></head>
<body style="margin:0;background:#000">
<canvas id="c" width="{size}" height="{size}" style="width:{size}px;height:{size}px;display:block"></canvas>
<script src="three-bundle.js"></script>
<script>
"use strict";
const {{ THREE, GLTFLoader }} = window.BRDF_THREE;
const half = {half};
const canvas = document.getElementById("c");
const renderer = new THREE.WebGLRenderer({{ canvas, antialias: false, alpha: true, preserveDrawingBuffer: true }});
renderer.setPixelRatio(1);
renderer.setSize({size}, {size}, false);
renderer.setClearColor(0x000000, 0);
const scene = new THREE.Scene();
const sun = new THREE.DirectionalLight(0xffffff, 3.0);
sun.position.set(0.3, 0.5, 1.0);
scene.add(sun);
scene.add(new THREE.AmbientLight(0xffffff, 0.5));
const camera = new THREE.OrthographicCamera(-half, half, half, -half, 0.1, 100);
camera.position.set(0, 0, 10);
camera.lookAt(0, 0, 0);
const bytes = Uint8Array.from(atob("{glb}"), (c) => c.charCodeAt(0));
new GLTFLoader().parse(bytes.buffer, "", (gltf) => {{
  scene.add(gltf.scene);
  renderer.render(scene, camera);
  window.names = gltf.scene.children.map((o) => o.name);
  window.result = canvas.toDataURL("image/png");
}}, (err) => {{ console.error(String(err)); window.renderError = String(err); }});
</script></body></html>
"""


def _decode_png(url):
    from PIL import Image
    return np.asarray(Image.open(io.BytesIO(base64.b64decode(url.split(",", 1)[1]))).convert("RGBA"))


def test_three_draws_one_lit_sphere_per_material(written, tmp_path):
    from headless_chromium import HeadlessChromium, find_chromium

    from brdf_fit.report.web_viewer import ViewerUnavailable, write_three_bundle
    if find_chromium() is None:
        pytest.skip("chromium is not installed (Debian package chromium; make test installs it)")
    try:
        write_three_bundle(tmp_path)
    except ViewerUnavailable as err:
        pytest.skip(str(err))
    _, entries, path = written
    columns = grid_columns(len(entries))
    size = round(columns * SPACING * PIXELS_PER_UNIT)
    glb = base64.b64encode(path.read_bytes()).decode("ascii")
    (tmp_path / "grid.html").write_text(PAGE.format(size=size, half=columns * SPACING / 2, glb=glb))
    with HeadlessChromium(tmp_path, size + 64, size + 64, timeout=240) as browser:
        browser.open((tmp_path / "grid.html").as_uri())
        browser.wait_for("!!window.result || !!window.renderError")
        assert browser.evaluate("window.renderError || null") is None, browser.errors
        assert browser.evaluate("window.names") == [name for name, _ in entries]
        image = _decode_png(browser.evaluate("window.result"))
        assert not browser.errors, browser.errors
    assert image.shape[:2] == (size, size)
    drawn = image[..., 3] > 0
    lit = drawn & (image[..., :3].max(axis=-1) >= 16)
    cell = round(SPACING * PIXELS_PER_UNIT)
    disc = math.pi * (SPHERE_RADIUS * PIXELS_PER_UNIT) ** 2
    for k in range(columns * columns):
        row, column = divmod(k, columns)
        block = np.s_[row * cell:(row + 1) * cell, column * cell:(column + 1) * cell]
        if k >= len(entries):
            assert not drawn[block].any(), f"cell {k} should be empty"
            continue
        name = entries[k][0]
        ys, xs = np.nonzero(drawn[block])
        print(f"{name}: {len(xs)} drawn pixels (disc {disc:.0f}), {lit[block].sum()} lit")
        assert abs(len(xs) / disc - 1.0) < DISC_TOLERANCE, name
        # centred in its cell (pixel centres at +0.5), within a pixel
        assert abs(xs.mean() + 0.5 - cell / 2) < 1.0 and abs(ys.mean() + 0.5 - cell / 2) < 1.0, name
        assert lit[block].sum() > LIT_FRACTION * disc, name
