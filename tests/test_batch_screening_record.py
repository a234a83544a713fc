"""batch --models auto records each input's screening (``MATERIAL.screening``): a re-run,
or a run resuming a batch killed between two contenders, takes the screened models from
the record instead of screening again; a record that is not this run's is ignored.

The family is shortened (as in test_fitting_cli) to two diffuse models and one without a
diffuse lobe, which the screening leaves out on a diffuse material.  Every number checked
comes from the first run (its summary, its results, its screening's ModelScreened).
"""

import csv
import json
import shutil

import pytest

import fitting.auto
import fitting.fit
import fitting.screen
from brdf_fit.batch.folder import ResultFolder
from brdf_fit.batch.screening_record import VERSION, ScreeningRecord, record_name
from brdf_fit.cli import main
from fitting.result import MAX_RESULT_BYTES, FitResult
from fitting.screen import ModelScreened

from test_fitting_cli import write_sample_file

FAMILY = ("ggx+lambert", "ggx", "ggx+burley")
COMMON = ["--samples", "4000", "--starts", "1"]
RECORD = record_name("mat_a")
FIELDS = ("model", "errors", "bound", "margin", "seconds", "parameters")


def _rows(out):
    with open(out / "summary.csv", newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def _results(out):
    return {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in out.glob("*.json")}


class Calls:
    """Wraps ``module.name`` (in a MonkeyPatch) and keeps the arguments and outcome of each call."""

    def __init__(self, patch, module, name):
        self.real, self.calls = getattr(module, name), []
        patch.setattr(module, name, self)

    def __call__(self, *args, **kwargs):
        outcome = self.real(*args, **kwargs)
        self.calls.append((args, outcome))
        return outcome


@pytest.fixture(scope="module")
def first(tmp_path_factory):
    """The first batch: (input, output folder, its summary rows, its screening's outcome)."""
    folder = tmp_path_factory.mktemp("first")
    source = write_sample_file(folder / "mat_a.npz", "mat_a")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(fitting.auto, "AUTO_FAMILY", FAMILY)
        screenings = Calls(patch, fitting.screen, "screened_out")
        assert main(["batch", str(source), "--models", "auto", *COMMON, "--out", str(folder / "out")]) == 0
    assert len(screenings.calls) == 1
    screened = screenings.calls[0][1]
    assert "ggx" in screened and len(screened) < len(FAMILY)       # one screened, contenders fitted
    return source, folder / "out", _rows(folder / "out"), screened


def _rerun(first, tmp_path, monkeypatch, change=None):
    """Run the first batch again on a copy of its folder (``change``d first); returns
    (exit status, the copy, its screening calls, the models fitted)."""
    source, out, _, _ = first
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    if change is not None:
        change(copy)
    monkeypatch.setattr(fitting.auto, "AUTO_FAMILY", FAMILY)
    screenings = Calls(monkeypatch, fitting.screen, "screened_out")
    fits = Calls(monkeypatch, fitting.fit, "fit")
    status = main(["batch", str(source), "--models", "auto", *COMMON, "--out", str(copy)])
    return status, copy, screenings.calls, [args[1] for args, _ in fits.calls]


def _record(out):
    return json.loads((out / RECORD).read_text(encoding="utf-8"))


def test_the_record_holds_the_screening_and_a_rerun_does_not_screen(first, tmp_path, monkeypatch):
    """The first run's record gives back its screening's ModelScreened; a re-run screens
    nothing, fits nothing, writes no result and gives the first run's rows (fitted ->
    resumed; the screened rows equal, seconds included: they are the recorded ones)."""
    source, out, rows, screened = first
    record = _record(out)
    assert record["models"] == list(FAMILY) and [s["model"] for s in record["screened"]] == list(screened)
    before = _results(out)
    status, copy, screenings, fitted = _rerun(first, tmp_path, monkeypatch)
    assert (status, screenings, fitted) == (0, [], [])
    assert _results(copy).keys() == before.keys()
    assert all(_results(copy)[name][0] == before[name][0] for name in before)
    again = [dict(r, status="resumed" if r["status"] == "fitted" else r["status"]) for r in rows]
    assert _rows(copy) == again
    assert [r["status"] for r in again].count("screened") == len(screened)


def test_a_batch_killed_after_the_screening_fits_only_the_missing_contenders(first, tmp_path, monkeypatch):
    """The record present, every contender's result but the first deleted (a kill -9 after
    the first contender): the re-run does not screen and fits exactly the deleted ones, to
    the first run's parameters and errors.  Their ``seconds`` are this run's timing."""
    _, out, rows, screened = first
    contenders = [m for m in FAMILY if m not in screened]
    missing = contenders[1:]
    assert missing
    status, copy, screenings, fitted = _rerun(
        first, tmp_path, monkeypatch, lambda d: [(d / f"mat_a.{m}.json").unlink() for m in missing])
    assert (status, screenings, fitted) == (0, [], missing)
    for model in contenders:
        new, old = FitResult.load(copy / f"mat_a.{model}.json"), FitResult.load(out / f"mat_a.{model}.json")
        assert (new.parameters, new.errors) == (old.parameters, old.errors)
    by_model = {r["model"]: r for r in _rows(copy)}
    for r in rows:
        expected = dict(r, status="fitted" if r["model"] in missing else
                        "resumed" if r["status"] == "fitted" else r["status"])
        if r["model"] in missing:
            expected["seconds"] = by_model[r["model"]]["seconds"]
        assert by_model[r["model"]] == expected


def _edit(change):
    """A change to the record's parsed JSON, written back."""
    def apply(folder):
        data = json.loads((folder / RECORD).read_text(encoding="utf-8"))
        change(data)
        (folder / RECORD).write_text(json.dumps(data), encoding="utf-8")
    return apply


def _raw(change):
    """A change to the record's bytes."""
    def apply(folder):
        (folder / RECORD).write_bytes(change((folder / RECORD).read_bytes()))
    return apply


BAD_RECORDS = {
    "other sha256": _edit(lambda d: d.update(sha256="0" * 64)),
    "other options": _edit(lambda d: d["options"].update(samples=d["options"]["samples"] + 1)),
    "other model list": _edit(lambda d: d.update(models=d["models"][::-1])),
    "a model not in the list": _edit(lambda d: d["screened"].append(dict(d["screened"][0], model="ggx+lambert+ms"))),
    "a model twice": _edit(lambda d: d["screened"].append(d["screened"][0])),
    "a number of the wrong type": _edit(lambda d: d["screened"][0].update(seconds=str(d["screened"][0]["seconds"]))),
    "an integer for a float": _edit(lambda d: d["screened"][0].update(margin=1)),
    "a field missing": _edit(lambda d: d["screened"][0].pop("bound")),
    "an infinite number": _edit(lambda d: d["screened"][0].update(bound=float("inf"))),
    "a NaN error": _edit(lambda d: d["screened"][0]["errors"].update(m1=float("nan"))),
    "other format version": _edit(lambda d: d.update(version=d["version"] + 1)),
    "another screening margin": _edit(lambda d: d["settings"].update(margin=d["settings"]["margin"] + 0.25)),
    "another small table's tolerance": _edit(lambda d: d["settings"].update(small_tol=d["settings"]["small_tol"] / 100)),
    "no screening settings": _edit(lambda d: d.pop("settings")),
    "truncated": _raw(lambda b: b[:len(b) // 2]),
    "not an object": _raw(lambda b: b"[" + b + b"]"),
    "huge": _raw(lambda b: b + b" " * MAX_RESULT_BYTES),       # valid JSON, but larger than any result
    "not UTF-8": _raw(lambda b: b.replace(b'"models"', b'"m\xffodels"', 1)),
    # the same value twice, so only the duplicate itself is wrong (a result file refuses it too)
    "a key twice": _raw(lambda b: b.replace(b'"format":', b'"version": %d, "format":' % VERSION, 1)),
}


@pytest.mark.parametrize("case", sorted(BAD_RECORDS))
def test_a_record_that_is_not_this_runs_is_ignored_and_replaced(first, tmp_path, monkeypatch, capsys, case):
    """The input is screened again (to the first run's screening), nothing is fitted, the exit
    status and the rows are the first run's (fitted -> resumed; a screened row's seconds
    are this screening's), no traceback; the record is replaced by this run's."""
    _, out, rows, screened = first
    status, copy, screenings, fitted = _rerun(first, tmp_path, monkeypatch, BAD_RECORDS[case])
    assert "Traceback" not in capsys.readouterr().err
    assert (status, len(screenings), fitted) == (0, 1, [])
    fresh = screenings[0][1]
    assert {m: (s.errors, s.bound, s.margin, s.parameters) for m, s in fresh.items()} == \
        {m: (s.errors, s.bound, s.margin, s.parameters) for m, s in screened.items()}
    data = _record(out)
    recorded = ScreeningRecord(ResultFolder(copy), "mat_a", data["sha256"], data["options"], FAMILY).load()
    assert {m: s.to_record() for m, s in recorded.items()} == {m: s.to_record() for m, s in fresh.items()}
    assert _rows(copy) == [dict(r, status="resumed") if r["status"] == "fitted" else
                           dict(r, seconds=f"{fresh[r['model']].seconds:.3f}") for r in rows]


def test_a_screened_model_survives_its_record(first):
    """ModelScreened -> record -> JSON -> ModelScreened: every field equal, and the record
    file of the first run gives back its screening exactly."""
    _, out, _, screened = first
    for s in screened.values():
        back = ModelScreened.from_record(json.loads(json.dumps(s.to_record())))
        assert tuple(getattr(back, f) for f in FIELDS) == tuple(getattr(s, f) for f in FIELDS)
        assert (str(back), back.to_dict()) == (str(s), s.to_dict())
    data = _record(out)
    recorded = ScreeningRecord(ResultFolder(out), "mat_a", data["sha256"], data["options"], FAMILY).load()
    assert {m: tuple(getattr(s, f) for f in FIELDS) for m, s in recorded.items()} == \
        {m: tuple(getattr(s, f) for f in FIELDS) for m, s in screened.items()}


BAD_ENTRIES = {
    "NaN seconds": lambda r: r.update(seconds=float("nan")),
    "a bool for a float": lambda r: r.update(bound=True),
    "a field more": lambda r: r.update(extra=1.0),
    "no ranking error": lambda r: r["errors"].pop("ranking_error"),
    "a list for an error": lambda r: r["errors"].update(m1=[r["errors"]["m1"]]),
    "parameters not an object": lambda r: r.update(parameters=[]),
    "a nested parameter": lambda r: r["parameters"].update(x=[[1.0]]),
    "no model": lambda r: r.update(model=None),
}


@pytest.mark.parametrize("case", sorted(BAD_ENTRIES))
def test_a_bad_screened_model_record_is_refused(first, case):
    record = next(iter(first[3].values())).to_record()
    BAD_ENTRIES[case](record)
    with pytest.raises(ValueError):
        ModelScreened.from_record(record)


def test_a_send_data_worker_screens_again_and_sends_its_record_back(first, monkeypatch):
    """--send-data (``fit_bytes``, no Dask needed): the worker has the results of the folder but
    no record, so it screens again (to the first run's screening) and fits nothing; its record
    comes back in ``written`` beside the results (none here: every contender is done)."""
    from brdf_fit.batch.task import fit_bytes, make_task
    source, out, _, screened = first
    results = {p.name: FitResult.load(p) for p in out.glob("*.json")}
    monkeypatch.setattr(fitting.auto, "AUTO_FAMILY", FAMILY)     # 'auto' here, as the first run had it
    task = make_task(source, FAMILY, _record(out)["options"], False, cut=True)    # the CLI's fit options
    screenings = Calls(monkeypatch, fitting.screen, "screened_out")
    outcome = fit_bytes(source.read_bytes(), task, results)
    assert len(screenings.calls) == 1 and list(outcome.written) == [RECORD]
    sent = json.loads(outcome.written[RECORD])
    assert {e["model"]: (e["errors"], e["parameters"]) for e in sent["screened"]} == \
        {m: (s.errors, s.parameters) for m, s in screened.items()}
    assert (sent["sha256"], sent["options"], sent["models"]) == tuple(_record(out)[k] for k in
                                                                      ("sha256", "options", "models"))


def test_a_library_rerun_screens_nothing(tmp_path, monkeypatch):
    """library screens auto and, apart, the glTF family: both go into the record, so the
    command again on the same folder screens nothing and fits nothing (a record without the
    family's models was refused as not this run's, and every re-run screened again)."""
    source = write_sample_file(tmp_path / "mat_a.npz", "mat_a")
    monkeypatch.setattr(fitting.auto, "AUTO_FAMILY", FAMILY)
    argv = ["library", str(source), "--models", "auto", *COMMON, "--out", str(tmp_path / "lib"), "-q"]
    assert main(argv) == 0
    record = json.loads((tmp_path / "lib" / "results" / RECORD).read_text(encoding="utf-8"))
    assert any(s["model"].startswith("gltf") for s in record["screened"])     # the family was screened
    screenings = Calls(monkeypatch, fitting.screen, "screened_out")
    fits = Calls(monkeypatch, fitting.fit, "fit")
    assert main(argv) == 0
    assert (screenings.calls, fits.calls) == ([], [])
