"""``brdf_fit.notebook.results_table``: many results as one pandas DataFrame.

Every cell is checked against the result files' JSON read here with ``json``
(not through FitResult), for results given as objects, files and a batch
folder (which also holds a summary and a non-result JSON, skipped).
"""

import json
import math
import warnings

import pytest

from fitting.result import FitResult

pd = pytest.importorskip("pandas")

from brdf_fit.notebook import results_table  # noqa: E402
from brdf_fit.notebook.table import COLUMNS  # noqa: E402

FITS = [
    ("chrome", "ggx+lambert", {"albedo": [0.1, 0.2, 0.3], "roughness": 0.032, "f0": [0.9, 0.8, 0.7]},
     {"m1": 0.05, "loss_name": "log", "loss": 0.04, "image": 0.2, "exported_model": "gltf+ior",
      "exported_m1": 0.06, "exported_image": 0.25}, {"name": "lbfgs", "seconds": 3.0, "seconds_total": 4.5,
                                                      "converged": True}),
    ("chrome", "gltf", {"base_color": [0.9, 0.8, 0.7], "metallic": 1.0, "roughness": 0.2},
     {"m1": 0.07, "loss_name": "log", "loss": 0.06}, {"name": "lbfgs", "seconds": 1.0, "converged": False}),
    ("paint", "ggx+lambert", {"albedo": [0.5, 0.4, 0.3], "roughness": 0.5, "f0": [0.04, 0.04, 0.04]},
     {"m1": 0.01, "loss_name": "log", "loss": 0.009, "image": 0.03}, {}),
]


def _results():
    return [FitResult(spec=spec, parameters=p, errors=e, optimizer=o,
                      provenance={"file": f"{m}.binary", "sha256": None, "format": "merl", "material": m})
            for m, spec, p, e, o in FITS]


@pytest.fixture
def batch(tmp_path):
    folder = tmp_path / "results"
    paths = [r.save(folder / f"{r.material}.{r.spec.replace('+', '_')}.json") for r in _results()]
    (folder / "summary.csv").write_text("material,model,status\n")
    (folder / "batch.json").write_text(json.dumps({"rows": []}))       # not a fit result: skipped
    return folder, paths


def _expected(data, file):
    """The row from the JSON itself (the module docstring's definitions)."""
    e, o = data["errors"], data["optimizer"]
    row = {"material": data["provenance"]["material"], "model": data["spec"],
           "m1": e.get("m1", math.nan), "image": e.get("image", math.nan),
           "exported_model": e.get("exported_model"), "exported_m1": e.get("exported_m1", math.nan),
           "exported_image": e.get("exported_image", math.nan), "loss_name": e.get("loss_name"),
           "loss": e.get("loss", math.nan), "seconds": o.get("seconds_total", o.get("seconds", math.nan)),
           "converged": o.get("converged"),
           "at_bounds": ", ".join(f"{k}:{v}" for k, v in data["at_bounds"].items()),
           "file": file, "created": data["created"]}
    for name, value in data["parameters"].items():
        if isinstance(value, list):
            row.update({f"{name}_{c}": v for c, v in zip("rgb", value)})
        else:
            row[name] = value
    return row


def _same(a, b):
    if b is None:                       # pandas may hold a missing text as NaN
        return a is None or (isinstance(a, float) and math.isnan(a))
    if isinstance(b, float) and math.isnan(b):
        return isinstance(a, float) and math.isnan(a)
    return a == b


def test_a_batch_folder_becomes_a_table(batch):
    folder, paths = batch
    table = results_table(folder)
    files = sorted(str(p) for p in paths)
    assert list(table["file"]) == files                      # file-name order, summaries skipped
    params = ["albedo_r", "albedo_g", "albedo_b", "roughness", "f0_r", "f0_g", "f0_b",
              "base_color_r", "base_color_g", "base_color_b", "metallic"]
    assert list(table.columns) == list(COLUMNS) + params
    for i, file in enumerate(files):
        with open(file) as f:
            expected = _expected(json.load(f), file)
        for column in table.columns:
            want = expected.get(column, math.nan)
            assert _same(table[column].iloc[i], want), (file, column, table[column].iloc[i], want)
    assert table.loc[table["model"] == "ggx+lambert", "at_bounds"].tolist() == ["roughness:lower", ""]
    # the table sorts and filters as pandas does
    assert table.sort_values("m1")["material"].tolist() == ["paint", "chrome", "chrome"]


def test_objects_files_and_folders_mix(batch):
    folder, paths = batch
    objects = _results()
    table = results_table([objects[2], paths[0], folder])
    assert len(table) == 1 + 1 + 3
    assert pd.isna(table["file"].iloc[0]) and table["file"].iloc[1] == str(paths[0])
    assert table["model"].tolist()[:2] == [objects[2].spec, objects[0].spec]
    assert table["m1"].tolist()[:2] == [objects[2].errors["m1"], objects[0].errors["m1"]]
    assert results_table(objects[1])["metallic"].tolist() == [1.0]        # a single result


def test_broken_results_in_a_folder_are_skipped_with_a_warning(batch):
    folder, _ = batch
    text = (folder / "paint.ggx_lambert.json").read_text().replace('"roughness": 0.5', '"roughness": 7.5')
    (folder / "paint.ggx_lambert.json").write_text(text)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table = results_table(folder)
    assert len(table) == 2 and "paint" not in table["material"].tolist()
    assert any("outside its bounds" in str(w.message) for w in caught)
    with pytest.raises(FileNotFoundError):
        results_table(folder / "nowhere")
