"""Special files and odd bytes given where a file is read: never a hang, one clean line.

A FIFO (named pipe) given as the measured file, the DIRECTIONS array, a
result JSON or an environment map would block ``open`` forever, waiting for
a writer; a character device (``/dev/zero``) never ends.  Every reader checks
the file type first (``data_loaders.errors.require_file`` / ``open_regular``)
and every command ends with exit 2 and one line naming the file.  Should a
reader open a FIFO again, a watchdog thread opens its write end after
UNBLOCK_SECONDS, so the test fails instead of hanging the suite.

Also here: a result JSON with a key twice, and a UTIA-sized ``.bin`` that
starts like a PNG image or a zip archive.
"""

import contextlib
import json
import os
import pathlib
import threading

import numpy as np
import pytest

from data_loaders import MeasuredDataError, UTIA_FILE_SIZE, detect_format, load
from data_loaders.errors import open_regular, require_file
from brdf_fit.cli import main
from fitting.result import FitResult, ResultFileError

from test_cli_corpus import FAST, _check_clean_error, _samples

UNBLOCK_SECONDS = 60.0      # far beyond a refusal's milliseconds on a loaded machine

pytestmark = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this platform")


@contextlib.contextmanager
def fifo_guard(path):
    """Make a FIFO at ``path``; if anything still blocks opening it for reading after
    UNBLOCK_SECONDS, open (and close) its write end so the reader sees end-of-file."""
    os.mkfifo(path)
    done = threading.Event()

    def unblock():
        if done.wait(UNBLOCK_SECONDS):
            return
        with contextlib.suppress(OSError):     # ENXIO: nobody is reading, nothing to unblock
            os.close(os.open(path, os.O_WRONLY | os.O_NONBLOCK))

    watchdog = threading.Thread(target=unblock, daemon=True)
    watchdog.start()
    try:
        yield path
    finally:
        done.set()
        watchdog.join()


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    root = tmp_path_factory.mktemp("special")
    good = _samples(root / "good.npz")
    assert main(["fit", str(good), "--out", str(root / "results"), *FAST]) == 0
    rng = np.random.default_rng(2)
    dirs = rng.normal(size=(8, 6))
    dirs[:, 2], dirs[:, 5] = np.abs(dirs[:, 2]) + 0.1, np.abs(dirs[:, 5]) + 0.1
    np.save(root / "dirs.npy", dirs)
    return dict(good=good, result=root / "results" / "good.ggx+lambert.json", dirs=root / "dirs.npy")


def _argv(role, fifo, f, out):
    """The command line that reads ``fifo`` in ``role``; outputs under ``out``."""
    return {
        "info": ["info", fifo],
        "eval measured": ["eval", fifo, f["dirs"], out / "x.npy"],
        "eval directions": ["eval", f["good"], fifo, out / "x.npy"],
        "eval result": ["eval", fifo, f["dirs"], out / "x.npy"],
        "fit": ["fit", fifo, "--out", out / "fits", *FAST],
        "render measured": ["render", f["result"], "--measured", fifo, "--out", out / "x.png"],
        "render result": ["render", fifo, "--out", out / "x.png"],
        "render env": ["render", "-q", f["result"], "--env", fifo, "--out", out / "x.png", "--size", "64"],
        "export measured": ["export", f["result"], "--measured", fifo, "--out", out / "x.glb"],
        "export result": ["export", fifo, "--out", out / "x.glb"],
        "export-first": ["export", fifo, "--out", out / "x.glb", *FAST],
        "report measured": ["report", f["result"], "--measured", fifo, "--out", out / "report"],
        "report result": ["report", fifo, "--out", out / "report"],
        "view measured": ["view", f["result"], "--measured", fifo],
        "view result": ["view", fifo],
    }[role]


ROLES = ["info", "eval measured", "eval directions", "eval result", "fit", "render measured",
         "render result", "render env", "export measured", "export result", "export-first",
         "report measured", "report result", "view measured", "view result"]
SUFFIX = {"eval directions": ".npy", "render env": ".hdr"}


@pytest.mark.parametrize("role", ROLES)
def test_a_fifo_is_refused_not_waited_on(files, tmp_path, capsys, role):
    suffix = SUFFIX.get(role, ".json" if role.endswith("result") else ".csv")
    with fifo_guard(tmp_path / f"pipe{suffix}") as fifo:
        argv = [str(a) for a in _argv(role, fifo, files, tmp_path / "out")]
        code = main(argv)
    _check_clean_error(capsys, code, argv[0], [fifo, "FIFO"], [tmp_path / "out"])


def test_a_fifo_input_of_batch_is_one_error_row(files, tmp_path, capsys):
    out = tmp_path / "out"
    with fifo_guard(tmp_path / "pipe.csv") as fifo:
        code = main(["batch", str(fifo), str(files["good"]), "--out", str(out), *FAST])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err and f"{fifo}: is a FIFO" in err, err
    assert sorted(p.name for p in out.glob("*.json")) == ["good.ggx+lambert.json"]


def test_a_fifo_in_a_folder_is_one_error_row_and_the_rest_is_fitted(files, tmp_path, capsys):
    """batch of a folder names a FIFO named like a measurement in one line and an error
    row (as a FIFO named on the command line: exit 2); report of a folder skips the
    FIFO result with a warning and reports the rest; a FIFO ``*.json`` in a
    batch's output folder does not stop its summary."""
    folder = tmp_path / "in"
    folder.mkdir()
    (folder / "good.npz").write_bytes(files["good"].read_bytes())
    results = tmp_path / "results"
    results.mkdir()
    (results / "good.ggx+lambert.json").write_bytes(files["result"].read_bytes())
    with fifo_guard(folder / "pipe.csv") as fifo, fifo_guard(results / "pipe.json") as fifo_json:
        assert main(["batch", str(folder), "--out", str(results), *FAST]) == 2
        assert main(["report", str(results), "--out", str(tmp_path / "report")]) == 0
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert [ln for ln in err.splitlines() if str(fifo) in ln] == [
        f"skipped {fifo}: is a FIFO (named pipe), not a measured-data file"]
    assert [ln for ln in err.splitlines() if "warning" in ln] == [
        f"brdf-fit report: warning: {fifo_json}: is a FIFO (named pipe), not a fit result file (skipped)"]
    assert (results / "good.ggx+lambert.json").is_file()
    assert (tmp_path / "report" / "index.html").is_file()


def test_what_a_library_folder_holds_and_cannot_fit_is_named(tmp_path, capsys):
    """A symbolic link loop, a dangling link, a FIFO and a folder named like measurements
    inside an input folder: each named with its reason in one line and an error row of
    summary.csv; the measured file beside them is fitted and in the gallery."""
    import csv
    folder = tmp_path / "in"
    folder.mkdir()
    _samples(folder / "good.npz")
    os.symlink("loop-b.csv", folder / "loop-a.csv")
    os.symlink("loop-a.csv", folder / "loop-b.csv")
    os.symlink("gone.csv", folder / "dangling.csv")
    (folder / "folder.npz").mkdir()
    reasons = {"loop-a.csv": "is a symbolic link loop (it never reaches a file)",
               "loop-b.csv": "is a symbolic link loop (it never reaches a file)",
               "dangling.csv": "is a symbolic link to 'gone.csv', which does not exist",
               "pipe.csv": "is a FIFO (named pipe), not a measured-data file",
               "folder.npz": "is a directory, not a measured-data file"}
    out = tmp_path / "lib"
    with fifo_guard(folder / "pipe.csv"):
        code = main(["library", str(folder), "--out", str(out), "--models", "ggx+lambert", "--samples", "400",
                     "--starts", "1", "-q"])
    captured = capsys.readouterr()
    assert code == 2 and "Traceback" not in captured.err
    for name, reason in reasons.items():
        assert [ln for ln in captured.err.splitlines() if name in ln] == [f"skipped {folder / name}: {reason}"]
    with open(out / "results" / "summary.csv", newline="", encoding="utf-8") as f:
        rows = {pathlib.Path(r["file"]).name: r for r in csv.DictReader(f)}
    assert sorted(rows) == sorted([*reasons, "good.npz"])
    for name, reason in reasons.items():
        assert rows[name]["status"] == f"error: {reason}"
    assert rows["good.npz"]["status"] == "fitted"
    assert "good" in (out / "index.html").read_text(encoding="utf-8")
    assert f"{len(reasons)} input(s) failed" in captured.out


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/null"])
def test_a_character_device_is_refused(tmp_path, capsys, device):
    if not os.path.exists(device):
        pytest.skip(f"no {device}")
    code = main(["info", device])
    _check_clean_error(capsys, code, "info", [device, "character device"])


def test_the_helpers_name_the_file_type(tmp_path):
    with fifo_guard(tmp_path / "p") as fifo:
        with pytest.raises(MeasuredDataError, match=r"p: is a FIFO \(named pipe\), not a \.npy array$"):
            require_file(fifo, ".npy array")
        with pytest.raises(OSError, match="is a FIFO"):       # swapped in after a check: still no hang
            open_regular(fifo)
        with pytest.raises(ResultFileError, match="is a FIFO"):
            FitResult.load(fifo)
    with pytest.raises(MeasuredDataError, match="is a directory, not a measured-data file"):
        require_file(tmp_path)
    with pytest.raises(MeasuredDataError, match="no such file"):
        require_file(tmp_path / "absent.csv")


# --- a result JSON with a key twice ------------------------------------------------------

@pytest.mark.parametrize("where", ["top", "parameters", "errors"])
def test_a_duplicate_key_in_a_result_is_refused(files, tmp_path, capsys, where):
    text = files["result"].read_text()
    data = json.loads(text)
    if where == "top":                       # the later "spec" would silently win
        edited = text.replace('"spec": ', '"spec": "ggx+burley",\n  "spec": ', 1)
        key = "spec"
    else:
        first = next(iter(data[where]))
        edited = text.replace(f'"{where}": {{', f'"{where}": {{\n    "{first}": {json.dumps(data[where][first])},', 1)
        key = first
    assert len(edited) > len(text)
    path = tmp_path / "twice.json"
    path.write_text(edited)
    with pytest.raises(ResultFileError, match=f"the key '{key}' appears twice"):
        FitResult.load(path)
    code = main(["export", str(path), "--out", str(tmp_path / "x.glb")])
    _check_clean_error(capsys, code, "export", [path, "twice"], [tmp_path / "x.glb"])


# --- a UTIA-sized file that is something else ---------------------------------------------

@pytest.mark.parametrize("magic,looks", [(b"\x89PNG\r\n\x1a\n", "a PNG image"), (b"\x1f\x8b\x08", "gzip"),
                                         (b"\x93NUMPY\x01\x00", "a .npy array")])
def test_a_utia_sized_file_with_a_foreign_signature_is_refused(tmp_path, capsys, magic, looks):
    path = tmp_path / "table.bin"
    path.write_bytes(magic + b"\0" * (UTIA_FILE_SIZE - len(magic)))
    with pytest.raises(MeasuredDataError, match=f"size of a UTIA .bin .* starts like {looks}"):
        load(path)
    code = main(["info", str(path)])
    _check_clean_error(capsys, code, "info", [path, "UTIA"])


def test_a_utia_sized_zip_goes_to_the_npz_reader(tmp_path):
    path = tmp_path / "table.bin"
    path.write_bytes(b"PK\x03\x04" + b"\0" * (UTIA_FILE_SIZE - 4))
    assert detect_format(path) == "npz"
    with pytest.raises(MeasuredDataError, match=str(path)):
        load(path)
    plain = tmp_path / "plain.bin"                 # the same size of zeros is a (blank) UTIA table
    plain.write_bytes(b"\0" * UTIA_FILE_SIZE)
    assert detect_format(plain) == "utia"
