"""The command line's standard streams, run as real processes (brdf_fit/streams.py):
a closed stdout is taken as /dev/null (exit 0, results written), a reader that
stops early ends the command silently with 141 (128 + SIGPIPE, as coreutils),
names the stream's encoding lacks are shown as backslash escapes, and a deleted
working directory is said in one line."""

import os
import subprocess
import sys

import pytest

from brdf_fit.errors import CWD_GONE, OUTPUT_CLOSED

from test_cli_corpus import FAST, _samples

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# No empty entry: Python cannot make "" absolute from a deleted working directory.
ENV = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [ROOT, os.environ.get("PYTHONPATH")])))
BRDF_FIT = [sys.executable, "-m", "brdf_fit"]


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    return _samples(tmp_path_factory.mktemp("streams") / "good.npz")


@pytest.mark.parametrize("command", ["fit", "batch"])
def test_a_closed_stdout_is_taken_as_dev_null(good, tmp_path, command):
    """``>&-``: the results are written, nothing is said, exit 0 (was: a traceback, exit 1)."""
    out = tmp_path / "out"
    argv = [*BRDF_FIT, command, str(good), "--json", "-q", "--out", str(out), *FAST]
    proc = subprocess.run(["sh", "-c", 'exec "$@" >&-', "sh", *argv], env=ENV, stdin=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True, timeout=600)
    assert (proc.returncode, proc.stderr) == (0, "")
    assert (out / "good.ggx+lambert.json").is_file()


def _with_gone_reader(argv, **kwargs):
    """Run with stdout a pipe whose reading end is already closed (``| head -c 0``,
    deterministically): every write to it fails with EPIPE."""
    read, write = os.pipe()
    os.close(read)
    try:
        return subprocess.run([*BRDF_FIT, *argv], env=ENV, stdin=subprocess.DEVNULL, stdout=write,
                              stderr=subprocess.PIPE, text=True, timeout=600, **kwargs)
    finally:
        os.close(write)


@pytest.mark.parametrize("argv", [["info", "--json"], ["info"], ["schema"], ["models", "--json"]],
                         ids=lambda a: " ".join(a))
def test_a_reader_that_stops_early_ends_the_command_silently(good, argv):
    proc = _with_gone_reader(argv + ([str(good)] if argv[0] == "info" else []))
    assert (proc.returncode, proc.stderr) == (OUTPUT_CLOSED, "") == (141, "")


def test_results_are_written_before_the_reader_is_found_gone(good, tmp_path):
    proc = _with_gone_reader(["fit", str(good), "--json", "-q", "--out", str(tmp_path), *FAST])
    assert (proc.returncode, proc.stderr) == (141, "")
    assert (tmp_path / "good.ggx+lambert.json").is_file()


def test_names_are_escaped_where_the_encoding_lacks_their_characters(good, tmp_path):
    named = tmp_path / "g\u00f6\u00f6d.npz"
    named.write_bytes(good.read_bytes())
    env = dict(ENV, PYTHONIOENCODING="ascii")
    proc = subprocess.run([*BRDF_FIT, "info", str(named)], env=env, capture_output=True, timeout=600)
    assert (proc.returncode, proc.stderr) == (0, b"")
    shown = str(tmp_path).encode("ascii", "backslashreplace") + b"/g\\xf6\\xf6d.npz"
    assert proc.stdout.splitlines()[0] == b"file:       " + shown
    missing = tmp_path / "m\u00e4ngel.npz"
    proc = subprocess.run([*BRDF_FIT, "info", str(missing)], env=env, capture_output=True, timeout=600)
    assert proc.returncode == 2 and proc.stdout == b""
    assert proc.stderr.splitlines() == [
        b"brdf-fit info: error: " + str(tmp_path).encode("ascii", "backslashreplace") + b"/m\\xe4ngel.npz: no such file"]


def _from_deleted_folder(tmp_path, argv):
    """Run ``brdf-fit ARGV`` in a folder deleted after the shell entered it."""
    gone = tmp_path / "gone"
    gone.mkdir()
    script = 'cd "$1" && rmdir "$1" && shift && exec "$@"'
    return subprocess.run(["sh", "-c", script, "sh", str(gone), *BRDF_FIT, *argv], env=ENV,
                          capture_output=True, text=True, timeout=600)


def test_a_deleted_working_directory_is_said_in_one_line(good, tmp_path):
    (tmp_path / "x.csv").write_bytes(b"")
    proc = _from_deleted_folder(tmp_path, ["batch", "../x.csv", *FAST])
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.splitlines() == [f"brdf-fit batch: error: {CWD_GONE}"]
    assert proc.stderr.splitlines() == [
        "brdf-fit batch: error: the working directory no longer exists (deleted or moved since the "
        "shell entered it); cd to an existing folder, or give absolute paths"]
    # absolute paths alone still work there
    proc = _from_deleted_folder(tmp_path, ["info", str(good)])
    assert (proc.returncode, proc.stderr) == (0, "")
    assert proc.stdout.splitlines()[0] == f"file:       {good}"
