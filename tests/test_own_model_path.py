"""A result names its model file by the path the user gave (issue 60, item 5): ``model_file``
holds {"name", "sha256", "path"}, the path exactly as typed (relative stays relative, not
resolved), through ``fit`` and through ``batch``'s worker processes (the task carries the path
beside the bytes).  The path is data: a result of an older toolkit without it reads as before,
a hostile one is read and quoted, never opened nor suggested; the library's page names its
own copy of the file (by sha256), never a name read from a result.  The model files are a
few lines this test writes; the tables are small synthetic Lambertians."""

import html
import json
import pathlib
import re
import shlex

import jax.numpy as jnp
import pytest

from brdf import own
from brdf_fit.cli import main
from fitting.result import FitResult, ResultFileError

MODEL_FILE = '''
import jax.numpy as jnp
from brdf.own import OwnModel, Param

M = OwnModel("mine", (Param("a", 3, 0.0, 1.0, 0.5, "albedo"),),
             lambda p, wi, wo: jnp.broadcast_to(p["a"] / jnp.pi, wi.shape))
'''
HOSTILE = ["/etc/x.py; rm -rf ~", "$(reboot)/\x1b[31mred.py\u202e", "/" + "deep/" * 80 + "m.py"]


def _table(path, albedo):
    from data_loaders import write_samples
    from fitting.synthetic import synthetic_measured
    model = own.OwnModel("lambert_table", (own.Param("a", 3, 0.0, 1.0, 0.5, "albedo"),),
                         lambda p, wi, wo: jnp.broadcast_to(p["a"] / jnp.pi, wi.shape))
    m = synthetic_measured(model, {"a": [albedo] * 3}, grid=(12, 12, 24, 1))
    write_samples(path, m.wi[m.valid], m.wo[m.valid], m.values[m.valid], weights=m.weights[m.valid],
                  material=path.stem, isotropic=True)
    return path


@pytest.fixture
def folder(tmp_path, monkeypatch):
    """tmp_path as the working folder, with mymodels/m.py and a table t.npz; no own model registered."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(own, "_REGISTRY", {})
    (tmp_path / "mymodels").mkdir()
    (tmp_path / "mymodels" / "m.py").write_text(MODEL_FILE)
    _table(tmp_path / "t.npz", 0.7)
    return tmp_path


def _sha256(path):
    import hashlib
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.parametrize("typed", ["mymodels/m.py", "./mymodels/../mymodels/m.py", "ABSOLUTE"])
def test_fit_records_the_path_as_typed(folder, typed):
    typed = str(folder / "mymodels" / "m.py") if typed == "ABSOLUTE" else typed
    assert main(["fit", "t.npz", "--model-file", typed, "--model", "own:mine", "--samples", "2000",
                 "--out", "out"]) == 0
    data = json.loads((folder / "out" / "t.own:mine.json").read_text())
    assert data["model_file"] == {"name": "m.py", "sha256": _sha256(folder / "mymodels" / "m.py"), "path": typed}
    assert FitResult.load(folder / "out" / "t.own:mine.json").model_file["path"] == typed


def test_a_fit_from_python_records_the_path_given(folder):
    """load_file(path): the path as given (a pathlib.Path as its str); the same bytes loaded by
    another path are recorded by that one."""
    from data_loaders import load
    from fitting.fit import fit
    measured = load("t.npz")
    relative = own.load_file(pathlib.Path("mymodels") / "m.py", "M")
    assert fit(measured, relative, samples=2000).model_file["path"] == "mymodels/m.py"
    absolute = own.load_file(folder / "mymodels" / "m.py", "M")
    assert fit(measured, absolute, samples=2000).model_file["path"] == str(folder / "mymodels" / "m.py")


def test_batch_workers_record_the_path_typed(folder):
    """--jobs 2: spawned workers have no registry; the task carries (path as typed, bytes)."""
    _table(folder / "u.npz", 0.4)
    assert main(["batch", "t.npz", "u.npz", "--jobs", "2", "--models", "mymodels/m.py:M", "--samples", "2000",
                 "--out", "out"]) == 0
    for stem in ("t", "u"):
        result = FitResult.load(folder / "out" / f"{stem}.own:mine.json")
        assert result.model_file == {"name": "m.py", "sha256": _sha256(folder / "mymodels" / "m.py"),
                                     "path": "mymodels/m.py"}


def test_a_result_reads_with_its_path_and_without_it(folder):
    """A result of an older toolkit (no "path") reads as before; one with it keeps it; both are
    valid against `brdf-fit schema` (schema_version 1 either way: the key is optional)."""
    jsonschema = pytest.importorskip("jsonschema")
    from fitting.result_schema import result_schema
    assert main(["fit", "t.npz", "--model", "mymodels/m.py:M", "--samples", "2000", "--out", "out"]) == 0
    path = folder / "out" / "t.own:mine.json"
    data = json.loads(path.read_text())
    assert data["schema_version"] == 1 and data["model_file"]["path"] == "mymodels/m.py"
    jsonschema.validate(data, result_schema())
    assert FitResult.load(path).model_file["path"] == "mymodels/m.py"
    del data["model_file"]["path"]
    path.write_text(json.dumps(data))
    jsonschema.validate(data, result_schema())
    assert FitResult.load(path).model_file == {"name": "m.py", "sha256": _sha256(folder / "mymodels" / "m.py")}
    assert "path" not in FitResult.load(path).to_dict()["model_file"]


@pytest.mark.parametrize("given", [5, None, ["mymodels/m.py"]])
def test_a_path_that_is_no_string_is_refused(folder, given):
    assert main(["fit", "t.npz", "--model", "mymodels/m.py:M", "--samples", "2000", "--out", "out"]) == 0
    path = folder / "out" / "t.own:mine.json"
    data = json.loads(path.read_text())
    data["model_file"]["path"] = given
    path.write_text(json.dumps(data))
    with pytest.raises(ResultFileError, match=r"'model_file' must be an object of the strings name and sha256 "
                                              r"\(and path\)"):
        FitResult.load(path)


@pytest.mark.parametrize("hostile", HOSTILE)
def test_a_hostile_path_is_data(folder, capsys, hostile):
    """With the file given, the result reads (the path is kept, never opened); without it, the one
    error line quotes the path (repr, shortened) and asks for your copy, never the result's path."""
    assert main(["fit", "t.npz", "--model", "mymodels/m.py:M", "--samples", "2000", "--out", "out"]) == 0
    path = folder / "out" / "t.own:mine.json"
    data = json.loads(path.read_text())
    data["model_file"]["path"] = hostile
    path.write_text(json.dumps(data))
    assert FitResult.load(path).model_file["path"] == hostile      # registered (this process): read as data
    assert main(["report", str(path), "--model-file", "mymodels/m.py", "--out", "report"]) == 0
    capsys.readouterr()
    own._REGISTRY.clear()
    assert main(["report", str(path), "--out", "report2"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "\x1b" not in err and "\u202e" not in err
    quoted = own._as_data(hostile)
    assert f"given as {quoted} when fitted" in err and (len(hostile) <= 60 or hostile not in err)
    assert "--model-file PATH.py" in err and f"--model-file {hostile}" not in err
    assert "--model-file mymodels" not in err


@pytest.mark.parametrize("path", [None, "/etc/evil.py"])
def test_the_library_page_names_its_copy_never_the_results_name(folder, monkeypatch, path):
    """A result whose model_file name (and path, or none: an older result) was altered, the
    sha256 still the file's: the material page's report command names the library's copy,
    models/m.py, and runs as printed from the library's folder."""
    from brdf_fit.library.build import write_library
    from data_loaders import load
    from fitting.fit import fit
    measured = load(folder / "t.npz")
    results = folder / "lib" / "results"
    model = own.load_file("mymodels/m.py", "M")
    fit(measured, "ggx+lambert", samples=2000).save(results / "t.ggx+lambert.json")
    data = fit(measured, model, samples=2000).to_dict()
    data["model_file"] = {"name": "evil.py; rm -rf ~", "sha256": data["model_file"]["sha256"],
                          **({"path": path} if path else {})}
    (results / "t.own:mine.json").write_text(json.dumps(data))
    write_library([results], folder / "lib", log=lambda line: None)
    assert (folder / "lib" / "models" / "m.py").read_text() == MODEL_FILE
    page = next((folder / "lib" / "materials").glob("t*.html")).read_text()
    command = html.unescape(re.search(r"<pre>(brdf-fit report [^<]*)</pre>", page).group(1))
    assert "--model-file models/m.py" in command and "evil" not in command
    monkeypatch.chdir(folder / "lib")
    own._REGISTRY.clear()
    assert main(shlex.split(command)[1:]) == 0
