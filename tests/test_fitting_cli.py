"""brdf-fit fit / batch / eval / demo end to end, including bad input."""

import csv
import json
import subprocess
import sys

import numpy as np
import pytest

from data_loaders import load, write_samples
from brdf_fit.cli import main
from brdf_fit.export.export_first import GLTF_FAMILY
from fitting.fit_models import APART_MOST
from fitting.fit import evaluate_result
from fitting.result import FitResult
from fitting.synthetic import synthetic_measured

TRUTH = {"albedo": [0.4, 0.25, 0.1], "roughness": 0.45, "f0": [0.05, 0.05, 0.05]}


def write_sample_file(path, material, truth=TRUTH):
    m = synthetic_measured("ggx+lambert", truth, grid=(24, 24, 48, 1))
    keep = m.valid
    write_samples(path, m.wi[keep], m.wo[keep], m.values[keep], weights=m.weights[keep],
                  material=material, isotropic=True)
    return path


@pytest.fixture(scope="module")
def sample_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("inputs")
    a = write_sample_file(folder / "mat_a.npz", "mat_a")
    b = write_sample_file(folder / "mat_b.npz", "mat_b", dict(TRUTH, roughness=0.3))
    bad = folder / "broken.binary"
    bad.write_bytes(np.array([90, 90, 180], "<i4").tobytes() + b"\x00" * 100)   # truncated MERL
    return folder, a, b, bad


def test_fit_writes_result_and_prints_table(tmp_path, sample_files, capsys):
    _, a, _, _ = sample_files
    assert main(["fit", str(a), "--model", "ggx+lambert", "--samples", "5000",
                 "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "ggx+lambert" in out and "M1" in out
    result = FitResult.load(tmp_path / "mat_a.ggx+lambert.json")
    np.testing.assert_allclose(result.parameters["roughness"], TRUTH["roughness"], rtol=1e-3)
    assert result.provenance["format"] == "npz"
    assert result.provenance["sha256"] == load(a).provenance.sha256


def test_eval_of_a_result_matches_the_model(tmp_path, sample_files):
    _, a, _, _ = sample_files
    main(["fit", str(a), "--samples", "5000", "--out", str(tmp_path)])
    result_file = tmp_path / "mat_a.ggx+lambert.json"
    rng = np.random.default_rng(0)
    d = rng.normal(size=(50, 6))
    d[:, 2], d[:, 5] = np.abs(d[:, 2]), np.abs(d[:, 5])
    np.save(tmp_path / "dirs.npy", d)
    assert main(["eval", str(result_file), str(tmp_path / "dirs.npy"), str(tmp_path / "out.npy")]) == 0
    out = np.load(tmp_path / "out.npy", allow_pickle=False)
    wi = d[:, :3] / np.linalg.norm(d[:, :3], axis=1, keepdims=True)
    wo = d[:, 3:] / np.linalg.norm(d[:, 3:], axis=1, keepdims=True)
    expected = evaluate_result(FitResult.load(result_file), wi, wo)
    np.testing.assert_allclose(out, expected, rtol=1e-12)
    assert out.shape == (50, 3) and out.dtype == np.float64


@pytest.mark.parametrize("argv, message", [
    (["fit", "/nonexistent/file.binary"], "no such file"),
    (["fit", "{bad}", "--model", "ggx+lambert"], "truncated"),
    (["fit", "{a}", "--model", "ggx+lamberd"], "unknown option 'lamberd'"),
    (["fit", "{a}", "--model", "torrance_sparrow"], "unknown model 'torrance_sparrow'"),
    (["eval", "{json}", "{a}", "out.npy"], "not valid JSON"),
])
def test_bad_input_is_one_line_and_exit_2(tmp_path, sample_files, capsys, argv, message):
    _, a, _, bad = sample_files
    broken_json = tmp_path / "r.json"
    broken_json.write_text("{not json")
    argv = [x.format(a=a, bad=bad, json=broken_json) for x in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err.lower() or message in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_cli_process_exit_code_without_traceback(tmp_path):
    res = subprocess.run([sys.executable, "-m", "brdf_fit.cli", "fit", str(tmp_path / "missing.binary")],
                         capture_output=True, text=True)
    assert res.returncode == 2
    assert "no such file" in res.stderr and "Traceback" not in res.stderr


def test_batch_skips_bad_file_writes_summary_and_resumes(tmp_path, sample_files, capsys):
    folder, a, b, bad = sample_files
    out = tmp_path / "batch"
    argv = ["batch", str(folder), "--models", "ggx+lambert,ggx+burley", "--samples", "5000",
            "--starts", "1", "--out", str(out)]
    assert main(argv) == 2                      # one input failed: non-zero exit, the rest done
    rows = list(csv.DictReader(open(out / "summary.csv")))
    fitted = [r for r in rows if r["status"] == "fitted"]
    failed = [r for r in rows if r["status"].startswith("error")]
    assert {(r["material"], r["model"]) for r in fitted} == {
        ("mat_a", "ggx+lambert"), ("mat_a", "ggx+burley"), ("mat_b", "ggx+lambert"), ("mat_b", "ggx+burley")}
    assert len(failed) == 2 and all("broken.binary" in r["file"] for r in failed)
    stamps = {p.name: p.stat().st_mtime_ns for p in out.glob("*.json")}
    assert len(stamps) == 4

    # Re-running resumes: nothing is refitted, the results stay as they were.
    main(argv)
    rows = list(csv.DictReader(open(out / "summary.csv")))
    assert sorted(r["status"] for r in rows if not r["status"].startswith("error")) == ["resumed"] * 4
    assert {p.name: p.stat().st_mtime_ns for p in out.glob("*.json")} == stamps

    # A result deleted (as by an interrupted batch) is the only one refitted.
    (out / "mat_b.ggx+burley.json").unlink()
    main(argv)
    rows = list(csv.DictReader(open(out / "summary.csv")))
    assert [r["model"] for r in rows if r["status"] == "fitted"] == ["ggx+burley"]


def test_auto_ranks_the_family(tmp_path, sample_files, capsys):
    _, a, _, _ = sample_files
    assert main(["fit", str(a), "--model", "ggx+lambert,ggx+frostbite,ggx+lambert+clearcoat",
                 "--samples", "4000", "--starts", "1", "--out", str(tmp_path)]) == 0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("ggx")]
    m1 = [float(ln.split()[1]) for ln in lines]
    assert m1 == sorted(m1) and len(m1) == 3
    assert lines[0].split()[0] in ("ggx+lambert", "ggx+lambert+clearcoat")   # the generating model


def test_result_file_is_versioned_json(tmp_path, sample_files):
    _, a, _, _ = sample_files
    main(["fit", str(a), "--samples", "3000", "--starts", "1", "--out", str(tmp_path)])
    data = json.loads((tmp_path / "mat_a.ggx+lambert.json").read_text())
    assert data["schema_version"] == 1
    assert set(data) >= {"spec", "parameters", "errors", "optimizer", "provenance", "toolkit_version"}
    data["schema_version"] = 99
    (tmp_path / "future.json").write_text(json.dumps(data))
    with pytest.raises(ValueError, match="schema_version"):
        FitResult.load(tmp_path / "future.json")


def test_parallel_batch_matches_serial(tmp_path, sample_files):
    """--jobs 2 fits files in worker processes; the results equal a serial run's
    (to the optimizer's tolerance: XLA's reductions may split differently)."""
    folder, a, b, _ = sample_files
    common = ["--models", "ggx+lambert", "--samples", "3000", "--starts", "1"]
    assert main(["batch", str(a), str(b), *common, "--jobs", "2", "--out", str(tmp_path / "p")]) == 0
    assert main(["batch", str(a), str(b), *common, "--out", str(tmp_path / "s")]) == 0
    for name in ("mat_a.ggx+lambert.json", "mat_b.ggx+lambert.json"):
        par, ser = FitResult.load(tmp_path / "p" / name), FitResult.load(tmp_path / "s" / name)
        for name_ in par.parameters:
            np.testing.assert_allclose(par.parameters[name_], ser.parameters[name_], rtol=1e-6)
        assert par.errors["m1"] == pytest.approx(ser.errors["m1"], rel=1e-6)


def test_auto_screens_models_that_cannot_win(tmp_path, sample_files, capsys, monkeypatch):
    """--model auto screens every model and fits only the contenders: a screened model has
    no result file, is listed as screened with its screening errors (fit's table and
    --json; a "screened" row of summary.csv with its M1 and image error); --keep-all
    fits it.  The family is shortened here to two diffuse models and one without a
    diffuse lobe; the refined results equal --keep-all's."""
    import fitting.auto
    monkeypatch.setattr(fitting.auto, "AUTO_FAMILY", ("ggx+lambert", "ggx", "ggx+burley"))
    _, a, _, _ = sample_files
    common = ["--samples", "4000", "--starts", "1"]
    assert main(["fit", str(a), "--model", "auto", *common, "--json", "--out", str(tmp_path / "f")]) == 0
    doc = json.loads(capsys.readouterr().out)
    screened = {s["model"]: s for s in doc["screened"]}
    assert "ggx" in screened and doc["cut"] == []
    s = screened["ggx"]
    assert s["status"] == "screened" and s["screening"]["ranking_error"] > s["margin"] * s["best_screened_ranking_error"]
    assert s["screening"]["m1"] > 0 and s["screening"]["image"] > 0
    fitted = {r["spec"]: r for r in doc["results"]}
    assert set(fitted) | set(screened) == {"ggx+lambert", "ggx", "ggx+burley"} and "ggx+lambert" in fitted
    assert not (tmp_path / "f" / "mat_a.ggx.json").exists()
    assert main(["fit", str(a), "--model", "auto", *common, "--out", str(tmp_path / "f")]) == 0
    out = capsys.readouterr().out
    assert "screened, not refined" in out and out.count("  screened: ") == len(screened)
    assert f"screened: > {s['margin']:g} x the best screened" in out      # why, on its line
    assert main(["fit", str(a), "--model", "auto", "--keep-all", *common, "--json", "--out", str(tmp_path / "k")]) == 0
    keep = {r["spec"]: r for r in json.loads(capsys.readouterr().out)["results"]}
    assert (tmp_path / "k" / "mat_a.ggx.json").exists() and len(keep) == 3
    for model, r in fitted.items():
        assert (r["parameters"], r["errors"]) == (keep[model]["parameters"], keep[model]["errors"])

    out = tmp_path / "b"
    argv = ["batch", str(a), "--models", "auto", *common, "--out", str(out)]
    assert main(argv) == 0
    assert f"{len(fitted)} fit(s) done, {len(screened)} screened (not refined" in capsys.readouterr().out
    rows = list(csv.DictReader(open(out / "summary.csv")))
    by_model = {r["model"]: r for r in rows}
    assert by_model["ggx"]["status"] == "screened" and not by_model["ggx"]["result"]
    assert float(by_model["ggx"]["m1"]) == pytest.approx(s["screening"]["m1"], rel=1e-5)
    assert all(by_model[m]["status"] == "fitted" for m in fitted) and len(rows) == 3
    assert sorted(p.name for p in out.glob("*.json")) == sorted(f"mat_a.{m}.json" for m in fitted)
    assert main(argv) == 0          # resumed: the fitted ones read back, the screened one screened again
    rows = list(csv.DictReader(open(out / "summary.csv")))
    assert sorted(r["status"] for r in rows) == sorted(["resumed"] * len(fitted) + ["screened"] * len(screened))
    # export MEASURED --model auto: screened as the batch screens (the library ships what export writes),
    # the glTF family fitted beside the contenders, which equal fit's
    gltf = tmp_path / "m.gltf"
    capsys.readouterr()
    assert main(["export", str(a), "--model", "auto", *common, "--json", "--out", str(gltf)]) == 0
    doc = json.loads(capsys.readouterr().out)
    # auto's models screened as fit screens them, the glTF family apart (at most APART_MOST refined)
    assert [e["model"] for e in doc["screened"] if e["model"] not in GLTF_FAMILY] == ["ggx"]
    assert doc["screened"][0]["screening"]["m1"] == pytest.approx(s["screening"]["m1"], rel=1e-5)
    candidates = {c["spec"]: c for c in doc["candidates"]}
    family = [m for m in GLTF_FAMILY if m in candidates]
    assert sorted(family + [e["model"] for e in doc["screened"] if e["model"] in GLTF_FAMILY]) == sorted(GLTF_FAMILY)
    assert 1 <= len(family) <= APART_MOST
    assert sorted(candidates) == sorted([*fitted, *family]) and gltf.exists()
    for model, r in fitted.items():
        assert (candidates[model]["parameters"], candidates[model]["errors"]) == (r["parameters"], r["errors"])
    # a model named beside auto is fitted fully, even one of auto's (a comparison wants its own
    # errors): "auto,ggx" fits the screened ggx, its result that of --keep-all's fit of it
    assert main(["fit", str(a), "--model", "auto,ggx", *common, "--json", "--out", str(tmp_path / "n")]) == 0
    doc = json.loads(capsys.readouterr().out)
    named = {r["spec"]: r for r in doc["results"]}
    assert [e["model"] for e in doc["screened"]] == [m for m in screened if m != "ggx"]
    assert set(named) == set(fitted) | {"ggx"}
    assert (named["ggx"]["parameters"], named["ggx"]["errors"]) == (keep["ggx"]["parameters"], keep["ggx"]["errors"])
