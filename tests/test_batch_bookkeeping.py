"""batch's bookkeeping under hostile conditions: its own files as inputs, two batches
into one folder, another batch's temporary files, SIGTERM with --jobs 2, file
names that are not UTF-8, material names that would leave the folder.

The rule every test checks: ``summary.csv`` lists every result file in the
output folder (``_listed``), and nothing is written outside it.
"""

import csv
import os
import signal
import subprocess
import sys
import time

import pytest

from brdf_fit.cli import main
from fitting.file_names import safe_stem
from fitting.result import FitResult

from test_cli_corpus import FAST, TRUTH, _samples

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
START_LIMIT = 300.0          # seconds for a subprocess batch to reach a state (a loaded 2-core machine)


def _rows(out):
    with open(out / "summary.csv", newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def _results(out):
    return sorted(p.name for p in out.glob("*.json"))


def _listed(out):
    """The result files summary.csv names (and asserts each is in the folder)."""
    names = sorted(r["result"] for r in _rows(out) if r["result"])
    assert set(names) <= set(_results(out))
    return names


def _command_env():
    return dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""),
                BRDF_JAX_CACHE="off", PYTHONUNBUFFERED="1")


def test_one_measurement_in_two_folders_keeps_a_row_for_each_file(tmp_path, capsys):
    """Issue 60: `batch lab1 lab2` with the same file in both ended "2 fit(s) done" with one
    summary row (lab1's gone).  One measurement (one sha256) is one result; each input keeps
    its row, the second one resuming the first's result."""
    import shutil
    first, second = tmp_path / "lab1", tmp_path / "lab2"
    first.mkdir()
    second.mkdir()
    _samples(first / "same.csv")
    shutil.copy(first / "same.csv", second / "same.csv")
    out = tmp_path / "out"
    assert main(["batch", str(first), str(second), "--out", str(out), "--jobs", "1", *FAST]) == 0
    assert "2 fit(s) done" in capsys.readouterr().out
    rows = _rows(out)
    assert sorted((r["file"], r["status"]) for r in rows) == [(str(first / "same.csv"), "fitted"),
                                                              (str(second / "same.csv"), "resumed")]
    assert len(_results(out)) == 1 and {r["result"] for r in rows} == set(_results(out))


def test_a_batch_into_its_input_folder_does_not_read_its_own_files(tmp_path, capsys):
    folder = tmp_path / "lab"
    folder.mkdir()
    _samples(folder / "a.csv")
    argv = ["batch", str(folder), "--out", str(folder), *FAST]
    assert main(argv) == 0
    assert main(argv) == 0                      # summary.csv is now in the folder: not an input
    err = capsys.readouterr().err
    assert "summary" not in err and "Traceback" not in err, err
    rows = _rows(folder)
    assert [(r["file"], r["status"]) for r in rows] == [(str(folder / "a.csv"), "resumed")]
    assert _listed(folder) == _results(folder) == ["a.ggx+lambert.json"]


def test_two_batches_interleaved_keep_every_row(tmp_path, capsys):
    """Batch B runs from start to end while batch A is between two files: A's later
    summary writes must keep B's rows (the summary is rebuilt from the folder)."""
    from brdf_fit.batch.run import run_batch
    from brdf_fit.batch.task import fit_task
    out = tmp_path / "out"
    a = [_samples(tmp_path / f"a{k}.npz") for k in range(2)]
    b = [_samples(tmp_path / f"b{k}.npz") for k in range(2)]
    options = {"samples": 2000, "starts": 1}

    class ThenB:
        def run(self, tasks, out_dir, results):
            for k, task in enumerate(tasks):
                if k == 1:              # A has written its first row; B runs to the end
                    run_batch(b, ["ggx+lambert"], out, fit_options=options, progress=False, log=print)
                yield task, fit_task(task, str(out_dir))

    run_batch(a, ["ggx+lambert"], out, fit_options=options, executor=ThenB(), progress=False, log=print)
    assert _listed(out) == _results(out) == sorted(f"{p.stem}.ggx+lambert.json" for p in a + b)
    assert {r["file"]: r["status"] for r in _rows(out)} == {**{str(p): "fitted" for p in a},
                                                            **{str(p): "fitted" for p in b}}


def test_two_batch_processes_at_once_into_one_folder(tmp_path):
    out = tmp_path / "out"
    groups = []
    for group in ("p", "q"):
        folder = tmp_path / group
        folder.mkdir()
        groups.append([_samples(folder / f"{group}{k}.npz") for k in range(3)])
    procs = [subprocess.Popen([sys.executable, "-m", "brdf_fit", "batch", str(tmp_path / g), "-q",
                               "--out", str(out), *FAST], cwd=tmp_path, env=_command_env(),
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for g in ("p", "q")]
    try:
        outputs = [p.communicate(timeout=START_LIMIT * 2) for p in procs]
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait()
    for p, (_, err) in zip(procs, outputs):
        assert p.returncode == 0, err
    assert _listed(out) == _results(out) == sorted(f"{f.stem}.ggx+lambert.json" for g in groups for f in g)


def test_a_starting_batch_leaves_a_live_batchs_temp_files_alone(tmp_path):
    """Only temporary files whose writer is gone are removed (a kill -9 in a write)."""
    from data_loaders import atomic
    out = tmp_path / "out"
    out.mkdir()
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])
    try:
        live = out / f".x.ggx+lambert.json.{atomic._host()}-{sleeper.pid}.abcd1234.tmp"
        live.write_text("{")
        gone = subprocess.Popen([sys.executable, "-c", "pass"])
        gone.wait(timeout=60)
        dead = out / f".y.ggx+lambert.json.{atomic._host()}-{gone.pid}.abcd1234.tmp"
        dead.write_text("{")
        assert main(["batch", str(_samples(tmp_path / "z.npz")), "--out", str(out), *FAST]) == 0
        assert live.exists() and not dead.exists()
    finally:
        sleeper.kill()
        sleeper.wait()


def test_sigterm_with_two_jobs_leaves_every_finished_result_listed(tmp_path):
    folder = tmp_path / "in"
    folder.mkdir()
    for k in range(8):
        _samples(folder / f"m{k}.npz")
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "brdf_fit", "batch", str(folder), "--jobs", "2",
                             "--models", "ggx+lambert,ggx+burley", "--out", str(out), *FAST],
                            cwd=tmp_path, env=_command_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + START_LIMIT
        while len(_results(out) if out.is_dir() else []) < 2 and time.monotonic() < deadline \
                and proc.poll() is None:
            time.sleep(0.05)
        assert proc.poll() is None, "the batch ended before it could be terminated"
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 143, err
    assert err.strip().splitlines()[-1] == "brdf-fit batch: terminated; finished results are on disk"
    assert len(_results(out)) >= 2
    assert _listed(out) == _results(out)
    for name in _results(out):
        FitResult.load(out / name)


def test_a_summary_write_lists_this_runs_rows_while_the_main_thread_adds_more(tmp_path):
    """A signal's write runs on a helper thread while the main thread may add rows (its
    workers just killed, their tasks come back failed): the write lists the rows it began
    with instead of failing (a dict iterated while it grows), which left no summary at all.
    The other thread's add is made to happen in the middle of the write's pass over the rows."""
    from brdf_fit.batch.summary import Summary

    summary = Summary(tmp_path, [])
    writing = []

    class AddsARow(str):     # a model name whose hashing, in the write's pass, adds a row
        def __hash__(self):
            if writing:
                summary.mine[("no result", "late.npz", "ggx+burley")] = {
                    "file": "late.npz", "model": "ggx+burley", "status": "error: killed", "result": ""}
            return str.__hash__(self)

    summary.mine[("no result", "early.npz", AddsARow("ggx+lambert"))] = {
        "file": "early.npz", "model": "ggx+lambert", "status": "error: bad file", "result": ""}
    writing.append(True)
    summary.write()
    assert [(r["file"], r["status"]) for r in _rows(tmp_path)] == [("early.npz", "error: bad file")]
    summary.write()
    assert sorted(r["file"] for r in _rows(tmp_path)) == ["early.npz", "late.npz"]


def test_a_file_name_that_is_not_utf8(tmp_path, capsys):
    folder = tmp_path / "in"
    folder.mkdir()
    good = _samples(tmp_path / "source.csv")
    raw = os.fsencode(folder) + b"/bad\xff\xfe.csv"
    with open(raw, "wb") as f:
        f.write(good.read_bytes().replace(b"# material: source\n", b""))
    out = tmp_path / "out"
    assert main(["batch", str(folder), "--out", str(out), *FAST]) == 0
    err = capsys.readouterr().err
    assert "Traceback" not in err and "codec" not in err, err
    assert "'bad\\udcff\\udcfe' is not a safe file name" in err, err
    assert _results(out) == ["bad__.ggx+lambert.json"]
    rows = _rows(out)                      # the summary is UTF-8, the name shown with \x escapes
    assert [r["file"] for r in rows] == [str(folder) + "/bad\\xff\\xfe.csv"]
    assert FitResult.load(out / "bad__.ggx+lambert.json").provenance["file"] == os.fsdecode(raw)


HOSTILE_MATERIALS = {"../../x": "_._x", "ABS/x": None, "": "material", "..": "material",
                     "sub/dir": "sub_dir", ".hidden": "hidden"}      # ABS: tmp_path, absolute


@pytest.mark.parametrize("command", ["fit", "batch"])
@pytest.mark.parametrize("material", sorted(HOSTILE_MATERIALS))
def test_a_material_name_never_leaves_the_output_folder(tmp_path, capsys, monkeypatch, command, material):
    from data_loaders import write_samples
    from fitting.synthetic import synthetic_measured
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    monkeypatch.chdir(work)
    m = synthetic_measured("ggx+lambert", TRUTH, grid=(12, 12, 24, 1))
    stem = HOSTILE_MATERIALS[material]
    if material.startswith("ABS"):      # an absolute path (inside tmp_path: a failure litters nothing)
        material = str(tmp_path / "elsewhere" / "x")
        stem = safe_stem(material)
    source = work / ("in.npz" if material.startswith("/") else "in.csv")
    write_samples(source, m.wi[m.valid], m.wo[m.valid], m.values[m.valid], weights=m.weights[m.valid],
                  material=material, isotropic=True)
    before = set(tmp_path.rglob("*"))
    assert main([command, str(source), "--out", "out", *FAST]) == 0
    captured = capsys.readouterr()
    assert _results(work / "out") == [f"{stem}.ggx+lambert.json"]
    new = set(tmp_path.rglob("*")) - before
    assert all(p.is_relative_to(work / "out") for p in new), new
    assert f"is not a safe file name; its results are named '{stem}'" in captured.err, captured.err
    if command == "batch":
        assert _listed(work / "out") == [f"{stem}.ggx+lambert.json"]


def test_two_inputs_of_one_material_name_fitted_at_once_keep_their_own_names(tmp_path):
    """Two files whose measurements are both named "steel", each fitted by its own worker at
    the same moment: neither has written a result when the other chooses its name.  The first
    to choose claims "steel" (brdf_fit.batch.folder.ResultFolder.claim), the other is suffixed
    with its sha256; before, both chose "steel" and one input's results replaced the other's
    (tests/test_library_names.py lost one, under load).  A resumed run gets the same names."""
    import types

    from brdf_fit.batch.folder import ResultFolder, ResultSnapshot, material_name

    def steel(sha):
        return types.SimpleNamespace(material="steel", provenance=types.SimpleNamespace(sha256=sha))

    first, second = steel("a" * 64), steel("b" * 64)
    paths = {id(first): tmp_path / "first.npz", id(second): tmp_path / "second.npz"}
    models = ["ggx+lambert"]
    for folder in (ResultFolder(tmp_path), ResultSnapshot({})):
        names = [material_name(folder, m, paths[id(m)], models, False) for m in (first, second)]
        assert names == ["steel", "steel-bbbbbbbb"]
        again = [material_name(folder, m, paths[id(m)], models, False) for m in (second, first)]
        assert again == ["steel-bbbbbbbb", "steel"]
    # the first file edited (its sha256 changed) keeps its name; the second still does not get it
    edited = steel("c" * 64)
    assert material_name(ResultFolder(tmp_path), edited, tmp_path / "first.npz", models, False) == "steel"
    assert material_name(ResultFolder(tmp_path), second, tmp_path / "second.npz", models, False) == "steel-bbbbbbbb"
    # the claim is a hidden file, outside what a batch lists (summary.csv lists *.json)
    claim = (tmp_path / ".names" / "steel").read_text().splitlines()
    assert claim == ["c" * 64, str(tmp_path / "first.npz")] and not list(tmp_path.glob("*.json"))
