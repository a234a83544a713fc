"""Provenance a library can be trusted with (issue 53, item 6).

- an input folder moved, and the same command run on its new path: each input is
  found by its sha256 in the results, which are not fitted again but name the new
  file (their provenance, the gallery's pages), and one line says so;
- an input no longer given is left out of the gallery and materials.glb, one line says so;
- results that another version of the toolkit fitted are kept on a resume and one line
  says how many; ``--refit-stale`` fits them again.
"""

import json
import shutil

import pytest

from brdf import __version__
from brdf_fit.cli import main
from fitting.result import FitResult

FAST = ["--models", "ggx+lambert", "--samples", "400", "--starts", "1", "-q"]
NAMES = ("oak", "slate")


def _inputs(folder):
    from test_library_names import _table
    for seed, name in enumerate(NAMES):
        _table(folder / f"{name}.npz", name, seed)
    return folder


def _results(lib):
    return {p.name: FitResult.load(p) for p in (lib / "results").glob("*.json")}


def _library(inputs, lib):
    return main(["library", str(inputs), "--out", str(lib), *FAST])


def test_a_moved_input_folder_is_found_by_its_sha256(tmp_path, capfd):
    old, new, lib = tmp_path / "old", tmp_path / "new", tmp_path / "lib"
    assert _library(_inputs(old), lib) == 0
    before = _results(lib)
    old.rename(new)
    capfd.readouterr()
    assert _library(new, lib) == 0
    err = capfd.readouterr().err
    after = _results(lib)
    assert sorted(after) == sorted(before)
    for name, result in after.items():
        assert result.provenance["file"] == str(new / f"{result.material}.npz")
        assert result.created == before[name].created and result.parameters == before[name].parameters
    for material in NAMES:
        lines = [ln for ln in err.splitlines() if f"{material}.npz" in ln]
        assert lines == [f"{new / material}.npz: found by its sha256 in the results of {old / material}.npz, "
                         "which is gone: their provenance names this file now"]
    pages = [p.read_text(encoding="utf-8") for p in (lib / "materials").glob("*.html")]
    assert len(pages) == len(NAMES)
    assert all(str(old) not in page and str(new) in page for page in pages)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    root = tmp_path_factory.mktemp("provenance")
    inputs = _inputs(root / "in")
    assert _library(inputs, root / "lib") == 0
    return inputs, root / "lib"


def test_an_input_no_longer_given_is_left_out(built, tmp_path, capfd):
    from test_library_glb import read_glb
    from test_library_names import cards
    inputs, library = built
    lib = tmp_path / "lib"
    shutil.copytree(library, lib)
    capfd.readouterr()
    assert main(["library", str(inputs / "oak.npz"), "--out", str(lib), *FAST]) == 0
    err = capfd.readouterr().err
    assert sorted(cards(lib)) == ["oak"]
    doc, _ = read_glb(lib / "materials.glb")
    assert [n["name"] for n in doc["nodes"]] == ["oak"]
    assert ("1 material(s) of results/ not among the inputs given this time left out of the library (their "
            "results are kept: give their files again to show them)") in err.splitlines()
    assert sorted(_results(lib)) == sorted(_results(library))


def test_results_of_another_version_are_kept_and_said_then_fitted_again(built, tmp_path, capfd):
    inputs, library = built
    lib = tmp_path / "lib"
    shutil.copytree(library, lib)
    [path] = (lib / "results").glob("oak.ggx+lambert.json")     # (the glTF family is fitted beside it)
    data = json.loads(path.read_text(encoding="utf-8"))
    data["toolkit_version"] = "0.0.1"
    path.write_text(json.dumps(data), encoding="utf-8")
    capfd.readouterr()
    assert _library(inputs, lib) == 0
    err = capfd.readouterr().err
    assert [ln for ln in err.splitlines() if "0.0.1" in ln] == [
        f"1 result(s) resumed were fitted by brdf-fit 0.0.1 (this is {__version__}): kept; "
        "--refit-stale fits them again"]
    assert FitResult.load(path).toolkit_version == "0.0.1"
    assert main(["library", str(inputs), "--out", str(lib), "--refit-stale", *FAST]) == 0
    assert FitResult.load(path).toolkit_version == __version__
    assert "0.0.1" not in capfd.readouterr().err
    import csv
    with open(lib / "results" / "summary.csv", newline="", encoding="utf-8") as f:
        status = {r["result"]: r["status"] for r in csv.DictReader(f)}
    assert status[path.name] == "fitted" and {s for n, s in status.items() if n != path.name} == {"resumed"}
