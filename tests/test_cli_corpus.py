"""A corpus of hostile but realistic inputs, run through every command that reads them.

Every bad input or option must end with exit code 2, exactly one line on
stderr that starts ``brdf-fit COMMAND: error:`` and names the file (or the
option), no traceback, and no output file left behind.  The corpus is made at
test time (nothing is committed); the counts are printed with ``-s``.
"""

import csv
import json
import os
import struct
import zipfile

import numpy as np
import pytest

from data_loaders import write_samples
from brdf_fit.cli import main
from fitting.result import FitResult
from fitting.synthetic import synthetic_measured

TRUTH = {"albedo": [0.4, 0.25, 0.1], "roughness": 0.45, "f0": [0.05, 0.05, 0.05]}
FAST = ["--samples", "2000", "--starts", "1"]


def _samples(path, n=None, scale=1.0, dir_scale=1.0, weights=None):
    m = synthetic_measured("ggx+lambert", TRUTH, grid=(12, 12, 24, 1))
    keep = np.flatnonzero(m.valid)[:n]
    w = m.weights[keep] if weights is None else np.full(len(keep), weights)
    write_samples(path, m.wi[keep] * dir_scale, m.wo[keep] * dir_scale, m.values[keep] * scale,
                  weights=w, material=path.stem, isotropic=True)
    return path


def _npy_header(shape, dtype="<f8"):
    header = repr({"descr": dtype, "fortran_order": False, "shape": shape}).encode()
    header += b" " * (-(len(header) + 11) % 64) + b"\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header


def _rgl_with_ndim(path, ndim):
    """A tensor file whose one field claims ``ndim`` dimensions of 1000."""
    body = b"tensor_file\0" + bytes([1, 0]) + struct.pack("<I", 1)
    body += struct.pack("<H", 4) + b"data" + struct.pack("<HBQ", ndim, 10, 30)
    body += struct.pack(f"<{ndim}Q", *[1000] * ndim) + b"\0" * 64
    path.write_bytes(body)
    return path


def _bad_measured(folder):
    """{case name: path} of measured files no reader can use."""
    folder.mkdir()
    cases = {}

    def add(name, data):
        p = folder / name
        p.write_bytes(data)
        cases[name] = p

    cases["missing.binary"] = folder / "missing.binary"
    (folder / "a-folder.binary").mkdir()
    cases["a-folder.binary"] = folder / "a-folder.binary"
    add("empty.binary", b"")
    add("truncated.binary", np.array([90, 90, 180], "<i4").tobytes() + b"\0" * 1000)
    add("wrong-dims.binary", np.array([90, 90, 179], "<i4").tobytes() + b"\0" * 1000)
    add("png-bytes.binary", b"\x89PNG\r\n\x1a\n" + b"\0" * 200)
    add("garbage.csv", "theta_i,phi_i\nnot,numbers\n1,2,3,4\n".encode())
    add("binary-noise.csv", bytes(range(256)) * 8)
    cases["ndim-60000.bsdf"] = _rgl_with_ndim(folder / "ndim-60000.bsdf", 60000)
    cases["ndim-40.bsdf"] = _rgl_with_ndim(folder / "ndim-40.bsdf", 40)
    huge = folder / "huge-member.npz"
    with zipfile.ZipFile(huge, "w") as z:
        for key in ("wi", "wo", "values"):
            z.writestr(f"{key}.npy", _npy_header((10**12, 3)) + b"\0" * 48)
    cases["huge-member.npz"] = huge
    nan = _samples(folder / "nan-values.csv", n=200)
    lines = nan.read_text().splitlines()
    row = next(i for i, ln in enumerate(lines) if ln and ln[0].isdigit())
    lines[row] = ",".join(["nan"] * len(lines[row].split(",")))
    nan.write_text("\n".join(lines) + "\n")
    cases["nan-values.csv"] = nan
    cases["zero-weights.csv"] = _samples(folder / "zero-weights.csv", n=200, weights=0.0)
    return cases


@pytest.fixture(scope="module")
def corpus(tmp_path_factory):
    root = tmp_path_factory.mktemp("corpus")
    good = _samples(root / "good.npz")
    result_dir = root / "results"
    assert main(["fit", str(good), "--out", str(result_dir), *FAST]) == 0
    result = result_dir / "good.ggx+lambert.json"
    rng = np.random.default_rng(1)
    dirs = rng.normal(size=(20, 6))
    dirs[:, 2], dirs[:, 5] = np.abs(dirs[:, 2]) + 0.1, np.abs(dirs[:, 5]) + 0.1
    np.save(root / "dirs.npy", dirs)
    return dict(root=root, good=good, result=result, dirs=root / "dirs.npy",
                bad=_bad_measured(root / "bad"))


def _check_clean_error(capsys, code, command, names, out_paths=()):
    """Exit 2, one stderr line 'brdf-fit COMMAND: error: ...' naming ``names``, no outputs."""
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1, err
    assert lines[0].startswith(f"brdf-fit {command}: error:"), err
    assert "Traceback" not in err
    for name in names:
        assert str(name) in lines[0], (name, lines[0])
    for p in out_paths:
        assert not os.path.exists(p), p


MEASURED_COMMANDS = ["info", "eval", "fit", "render", "export", "report", "view"]


def _argv(command, path, c, out):
    return {
        "info": ["info", str(path)],
        "eval": ["eval", str(path), str(c["dirs"]), str(out / "x.npy")],
        "fit": ["fit", str(path), "--out", str(out / "fits"), *FAST],
        "render": ["render", str(c["result"]), "--measured", str(path), "--out", str(out / "x.png")],
        "export": ["export", str(c["result"]), "--measured", str(path), "--out", str(out / "x.glb")],
        "report": ["report", str(c["result"]), "--measured", str(path), "--out", str(out / "report")],
        "view": ["view", str(c["result"]), "--measured", str(path)],
    }[command]


CASES = ["missing.binary", "a-folder.binary", "empty.binary", "truncated.binary", "wrong-dims.binary",
         "png-bytes.binary", "garbage.csv", "binary-noise.csv", "ndim-60000.bsdf", "ndim-40.bsdf",
         "huge-member.npz", "nan-values.csv", "zero-weights.csv"]


@pytest.mark.parametrize("command", MEASURED_COMMANDS)
@pytest.mark.parametrize("case", CASES)
def test_bad_measured_file(corpus, tmp_path, capsys, command, case):
    path = corpus["bad"][case]
    code = main(_argv(command, path, corpus, tmp_path))
    _check_clean_error(capsys, code, command, [path], out_paths=[tmp_path / "x.npy", tmp_path / "fits",
                                                                 tmp_path / "x.png", tmp_path / "x.glb",
                                                                 tmp_path / "report"])


@pytest.mark.parametrize("rows", [1, 2])
@pytest.mark.parametrize("command", ["fit", "batch"])
def test_too_few_samples_is_an_error_and_writes_nothing(tmp_path, capsys, rows, command):
    path = _samples(tmp_path / f"tiny{rows}.csv", n=rows)
    out = tmp_path / "out"
    code = main([command, str(path), "--out", str(out), *FAST])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err and "cannot determine" in err, err
    assert not list(out.glob("*.json"))
    if command == "batch":
        rows_ = list(csv.DictReader(open(out / "summary.csv")))
        assert rows_ and all(r["status"].startswith("error") and str(path) == r["file"] for r in rows_)


BAD_DIRECTIONS = {
    "missing.npy": None,
    "huge-rows.npy": _npy_header((10**12, 6)) + b"\0" * 96,
    "truncated.npy": _npy_header((100, 6)) + b"\0" * 96,
    "wrong-shape.npy": _npy_header((4, 5)) + b"\0" * 160,
    "pickled.npy": _npy_header((2,), "|O") + b"\0" * 16,
    "not-npy.npy": b"hello, world\n",
}


@pytest.mark.parametrize("name", sorted(BAD_DIRECTIONS))
@pytest.mark.parametrize("source", ["measured", "result"])
def test_bad_directions(corpus, tmp_path, capsys, name, source):
    path = tmp_path / name
    if BAD_DIRECTIONS[name] is not None:
        path.write_bytes(BAD_DIRECTIONS[name])
    first = corpus["good"] if source == "measured" else corpus["result"]
    code = main(["eval", str(first), str(path), str(tmp_path / "out.npy")])
    _check_clean_error(capsys, code, "eval", [path], [tmp_path / "out.npy"])


def test_nan_direction_rows(corpus, tmp_path, capsys):
    d = np.ones((5, 6))
    d[3, 1] = np.nan
    np.save(tmp_path / "nan.npy", d)
    code = main(["eval", str(corpus["good"]), str(tmp_path / "nan.npy"), str(tmp_path / "out.npy")])
    _check_clean_error(capsys, code, "eval", [tmp_path / "nan.npy", "row 3"], [tmp_path / "out.npy"])


BAD_OPTIONS = [
    (["render", "R", "--size", "0"], "--size"),
    (["render", "R", "--size", "-5"], "--size"),
    (["view", "R", "--size", "0"], "--size"),
    (["fit", "G", "--max-theta", "-10"], "--max-theta"),
    (["fit", "G", "--max-theta", "nan"], "--max-theta"),
    (["fit", "G", "--max-theta", "120"], "--max-theta"),
    (["fit", "G", "--samples", "-1"], "--samples"),
    (["fit", "G", "--starts", "0"], "--starts"),
    (["batch", "G", "--jobs", "0"], "--jobs"),
    (["fit", "G", "--model", "ggx++lambert"], "ggx++lambert"),
    (["fit", "G", "--model", "ggx+"], "'ggx+'"),
    (["fit", "G", "--model", "+ggx"], "'+ggx'"),
    (["fit", "G", "--model", "torrance_sparrow"], "torrance_sparrow"),
    (["batch", "G", "--models", "ggx+lambert,ggx+nope"], "nope"),
    (["fit", "G", "--optimizer", "newton"], "--optimizer"),
]


@pytest.mark.parametrize("argv,named", BAD_OPTIONS, ids=[" ".join(a[0::2]) + a[-1] for a, _ in BAD_OPTIONS])
def test_bad_options(corpus, tmp_path, capsys, argv, named):
    argv = [str(corpus["result"]) if a == "R" else str(corpus["good"]) if a == "G" else a for a in argv]
    try:
        code = main(argv + ["--out", str(tmp_path / "out")] if argv[0] != "view" else argv)
    except SystemExit as stop:
        code = stop.code
    _check_clean_error(capsys, code, argv[0], [named], [tmp_path / "out"])


def test_a_very_long_model_string_is_not_echoed(corpus, tmp_path, capsys):
    code = main(["fit", str(corpus["good"]), "--model", "ggx+" + "x" * 100_000, "--out", str(tmp_path / "o")])
    _check_clean_error(capsys, code, "fit", ["characters"], [tmp_path / "o"])
    assert len(capsys.readouterr().err) == 0


def _output_cases(c, tmp):
    a_file = tmp / "a-file.txt"
    a_file.write_text("not a folder")
    result_copy = tmp / "copy.json"
    result_copy.write_bytes(c["result"].read_bytes())
    return [
        (["fit", str(c["good"]), "--out", str(a_file), *FAST], "fit", a_file),
        (["fit", str(c["good"]), "--out", str(a_file / "sub"), *FAST], "fit", a_file),
        (["batch", str(c["good"]), "--out", str(a_file), *FAST], "batch", a_file),
        (["eval", str(c["good"]), str(c["dirs"]), str(a_file / "x.npy")], "eval", a_file),
        (["eval", str(c["good"]), str(c["dirs"]), str(c["dirs"])], "eval", c["dirs"]),
        (["eval", str(c["good"]), str(c["dirs"]), str(tmp / "out.txt")], "eval", tmp / "out.txt"),
        (["render", str(result_copy), "--out", str(result_copy)], "render", result_copy),
        (["render", str(result_copy), "--out", str(tmp / "x.jpg")], "render", tmp / "x.jpg"),
        (["render", str(result_copy), "--out", str(a_file / "x.png")], "render", a_file),
        (["render", str(result_copy), "--out", str(tmp)], "render", tmp),
        (["export", str(result_copy), "--out", str(result_copy)], "export", result_copy),
        (["export", str(result_copy), "--out", str(tmp / "x.txt")], "export", tmp / "x.txt"),
        (["export", str(result_copy), "--out", str(a_file / "x.glb")], "export", a_file),
        (["report", str(result_copy), "--out", str(a_file)], "report", a_file),
    ]


def test_bad_output_paths(corpus, tmp_path, capsys):
    cases = _output_cases(corpus, tmp_path)
    before = {p: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()}
    for argv, command, named in cases:
        code = main(argv)
        _check_clean_error(capsys, code, command, [named])
    after = {p: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()}
    assert after == before          # nothing overwritten, nothing new
    assert not [p for p in tmp_path.iterdir() if p.is_dir()]


def test_missing_output_folders_are_created(corpus, tmp_path, capsys):
    out = tmp_path / "new" / "folder" / "x.npy"
    assert main(["eval", str(corpus["good"]), str(corpus["dirs"]), str(out)]) == 0
    assert np.load(out, allow_pickle=False).shape == (20, 3)
    assert (out.stat().st_mode & 0o777) == 0o666 & ~_umask()


def _umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


# --- batch bookkeeping ---------------------------------------------------------------

def test_batch_with_a_corrupt_file_skips_it_and_summarises_all(corpus, tmp_path, capsys):
    bad = corpus["bad"]["ndim-60000.bsdf"]
    out = tmp_path / "out"
    code = main(["batch", str(corpus["good"]), str(bad), "--out", str(out), *FAST])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err and str(bad) in err
    rows = list(csv.DictReader(open(out / "summary.csv")))
    assert {(r["file"], r["status"].split(":")[0]) for r in rows} == {(str(corpus["good"]), "fitted"),
                                                                      (str(bad), "error")}


def test_batch_of_a_folder_without_measured_files(tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("nothing to fit")
    code = main(["batch", str(tmp_path), "--out", str(tmp_path / "out")])
    _check_clean_error(capsys, code, "batch", [tmp_path], [tmp_path / "out"])


def test_batch_inputs_with_one_base_name_keep_both_results(tmp_path, capsys):
    a = _samples((tmp_path / "lab1").mkdir() or tmp_path / "lab1" / "sample.npz")
    b = tmp_path / "lab2" / "sample.npz"
    b.parent.mkdir()
    m = synthetic_measured("ggx+lambert", dict(TRUTH, roughness=0.25), grid=(12, 12, 24, 1))
    write_samples(b, m.wi[m.valid], m.wo[m.valid], m.values[m.valid], weights=m.weights[m.valid],
                  material="sample", isotropic=True)
    out = tmp_path / "out"
    assert main(["batch", str(a), str(b), "--out", str(out), *FAST]) == 0
    results = sorted(out.glob("*.json"))
    assert len(results) == 2
    files = {FitResult.load(p).provenance["file"] for p in results}
    assert files == {str(a), str(b)}
    roughness = sorted(FitResult.load(p).parameters["roughness"] for p in results)
    assert roughness == pytest.approx([0.25, 0.45], rel=0.05)
    rows = list(csv.DictReader(open(out / "summary.csv")))
    assert sorted(r["result"] for r in rows) == [p.name for p in results]
    # one of them alone, later, resumes its own result and does not touch the other's
    stamps = {p.name: p.stat().st_mtime_ns for p in results}
    assert main(["batch", str(b), "--out", str(out), *FAST]) == 0
    assert {p.name: p.stat().st_mtime_ns for p in out.glob("*.json")} == stamps


def test_two_runs_into_one_folder_keep_every_row(corpus, tmp_path, capsys):
    other = _samples(tmp_path / "other.npz")
    out = tmp_path / "out"
    assert main(["batch", str(corpus["good"]), "--out", str(out), *FAST]) == 0
    import subprocess
    import sys
    from data_loaders import atomic
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait(timeout=60)                                  # as left by a kill -9 during a write:
    stale = out / f".other.ggx+lambert.json.{atomic._host()}-{gone.pid}.k3j2abcd.tmp"   # its writer is gone
    stale.write_text("{")
    assert main(["batch", str(other), "--out", str(out), *FAST]) == 0
    assert not stale.exists()
    rows = list(csv.DictReader(open(out / "summary.csv")))
    assert sorted((r["file"], r["status"]) for r in rows) == sorted(
        [(str(corpus["good"]), "earlier"), (str(other), "fitted")])
    assert len(list(out.glob("*.json"))) == 2


def test_resume_refits_when_the_options_differ(corpus, tmp_path, capsys):
    out = tmp_path / "out"
    argv = ["batch", str(corpus["good"]), "--out", str(out), *FAST]
    assert main(argv) == 0
    assert main(argv) == 0
    status = lambda: [r["status"] for r in csv.DictReader(open(out / "summary.csv"))]  # noqa: E731
    assert status() == ["resumed"]
    assert main(argv + ["--max-theta", "40"]) == 0
    assert status() == ["fitted"]
    result = FitResult.load(out / "good.ggx+lambert.json")
    assert result.optimizer["options"]["max_theta"] == 40.0
    assert main(argv + ["--max-theta", "40"]) == 0
    assert status() == ["resumed"]


def test_result_json_never_holds_non_finite_numbers(corpus):
    text = corpus["result"].read_text()
    json.loads(text, parse_constant=lambda name: pytest.fail(f"{name} in the result JSON"))


@pytest.mark.parametrize("errno_", ["ENOSPC", "EROFS"])
def test_a_full_or_read_only_disk_is_one_line(corpus, tmp_path, capsys, monkeypatch, errno_):
    """The one atomic writer failing as on a full / read-only disk: one line, nothing left."""
    import errno
    import data_loaders.atomic as atomic

    def no_space(*args, **kwargs):
        code = getattr(errno, errno_)
        raise OSError(code, os.strerror(code), str(tmp_path / "out"))

    monkeypatch.setattr(atomic.tempfile, "mkstemp", no_space)
    code = main(["fit", str(corpus["good"]), "--out", str(tmp_path / "out"), *FAST])
    _check_clean_error(capsys, code, "fit", [os.strerror(getattr(errno, errno_)),
                                             tmp_path / "out" / "good.ggx+lambert.json"])
    assert not list((tmp_path / "out").glob("*.json"))


@pytest.mark.parametrize("case", ["all-zero", "1e300-values", "1e300-directions"])
@pytest.mark.parametrize("command", ["info", "fit"])
def test_implausible_input_warns_in_one_line_and_goes_on(tmp_path, capsys, case, command):
    path = tmp_path / f"{case}.npz"
    if case == "all-zero":
        _samples(path, scale=0.0)
    elif case == "1e300-values":
        _samples(path, scale=1e300)
    else:
        _samples(path, dir_scale=1e300)
    argv = ["info", str(path)] if command == "info" else ["fit", str(path), "--out", str(tmp_path), *FAST]
    code = main(argv)
    captured = capsys.readouterr()
    warnings_ = [ln for ln in captured.err.splitlines() if ": warning:" in ln]
    assert "Traceback" not in captured.err
    if case == "1e300-directions":        # written as angles: a valid file, nothing to warn about
        assert code == 0 and not warnings_, captured.err
        return
    assert len(warnings_) == 1 and warnings_[0].startswith(f"brdf-fit {command}: warning: {path}")
    assert code == 0, captured.err          # a warning, and the command goes on
    if command == "fit":
        assert FitResult.load(tmp_path / f"{case}.ggx+lambert.json").errors["m1"] >= 0


def test_an_edited_input_is_refitted_under_its_own_name(tmp_path, capsys, monkeypatch):
    """The same file (given by a relative path), changed between runs: its results are
    replaced, not kept beside a suffixed copy."""
    monkeypatch.chdir(tmp_path)
    _samples(tmp_path / "sample.npz")
    argv = ["batch", "sample.npz", "--out", "out", *FAST]
    assert main(argv) == 0
    _samples(tmp_path / "sample.npz", scale=1.5)          # the lab re-measured it
    assert main(argv) == 0
    assert [p.name for p in (tmp_path / "out").glob("*.json")] == ["sample.ggx+lambert.json"]
    rows = list(csv.DictReader(open(tmp_path / "out" / "summary.csv")))
    assert [r["status"] for r in rows] == ["fitted"]
