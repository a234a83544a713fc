"""A full disk, temporary files of killed or concurrent writers, an unusable cache folder.

The full disk is real where the tests may mount one (a small tmpfs, as root:
``full_disk``), else those tests skip; ``test_cli_corpus`` injects ENOSPC
into the writer everywhere.  Every write that fails names the file the user
asked for (not a temporary one) and leaves no temporary file behind.
"""

import contextlib
import errno
import os
import subprocess
import sys
import time
import uuid

import pytest

from data_loaders import atomic
from data_loaders.atomic import STALE_TEMP_SECONDS, stale_temp_files, write_file_atomic
from brdf_fit.cli import main

from test_cli_corpus import FAST, _check_clean_error, _samples

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TMPFS_BYTES = 256 * 1024        # room for a few results; filled up before a test writes


@contextlib.contextmanager
def mounted_tmpfs(folder, size=TMPFS_BYTES):
    """A tmpfs of ``size`` bytes at ``folder`` (pytest.skip where mounting is not allowed)."""
    folder.mkdir(parents=True, exist_ok=True)
    try:
        subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size},mode=0777", "tmpfs", str(folder)],
                       check=True, capture_output=True, timeout=60)
    except (OSError, subprocess.SubprocessError) as err:
        pytest.skip(f"cannot mount a tmpfs here ({err}); test_cli_corpus injects ENOSPC instead")
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], capture_output=True, timeout=60)


def fill(folder, leave=0):
    """Write a filler file into ``folder`` until the file system is full, then give
    back ``leave`` bytes.  Returns the filler's path."""
    filler = folder / "filler"
    with open(filler, "wb", buffering=0) as f:
        with contextlib.suppress(OSError):
            while True:
                f.write(b"\0" * 4096)
    if leave:
        os.truncate(filler, max(0, filler.stat().st_size - leave))
    return filler


@pytest.fixture
def full_disk(tmp_path):
    """A full tmpfs at tmp_path / "disk" (filled by ``fill``)."""
    with mounted_tmpfs(tmp_path / "disk") as disk:
        fill(disk)
        yield disk


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    root = tmp_path_factory.mktemp("disk-faults")
    good = _samples(root / "good.npz")
    assert main(["fit", str(good), "--out", str(root / "results"), *FAST]) == 0
    import numpy as np
    wi, wo = np.array([0.1, 0.2, 1.0]), np.array([-0.3, 0.1, 1.0])
    np.save(root / "dirs.npy", np.tile(np.r_[wi / np.linalg.norm(wi), wo / np.linalg.norm(wo)], (5, 1)))
    return dict(good=good, result=root / "results" / "good.ggx+lambert.json", dirs=root / "dirs.npy")


def _no_temp_files(folder):
    return not [p for p in folder.rglob(".*.tmp")]


def test_the_writer_names_the_target_on_a_full_disk(full_disk):
    target = full_disk / "kept.txt"
    with pytest.raises(OSError) as caught:
        write_file_atomic(target, "x" * 10_000)
    assert caught.value.errno == errno.ENOSPC
    assert caught.value.filename == str(target)
    assert not target.exists() and _no_temp_files(full_disk)


def test_a_failed_rewrite_keeps_the_old_file(tmp_path):
    with mounted_tmpfs(tmp_path / "disk") as disk:
        target = disk / "kept.txt"
        write_file_atomic(target, "old")
        fill(disk)
        with pytest.raises(OSError, match="No space left on device"):
            write_file_atomic(target, "new" * 5000)
        assert target.read_text() == "old" and _no_temp_files(disk)


@pytest.mark.parametrize("command", ["fit", "eval", "export"])
def test_a_full_disk_is_one_line_naming_the_file(files, full_disk, capsys, command):
    out = full_disk / "out"
    argv, named = {
        "fit": (["fit", files["good"], "--out", out, *FAST], out / "good.ggx+lambert.json"),
        "eval": (["eval", files["good"], files["dirs"], out / "x.npy"], out / "x.npy"),
        "export": (["export", files["result"], "--out", out / "x.glb"], out / "x.glb"),
    }[command]
    code = main([str(a) for a in argv])
    _check_clean_error(capsys, code, command, [named, "No space left on device"])
    assert not named.exists() and _no_temp_files(full_disk)


# --- temporary files: whose are stale ------------------------------------------------------

def _temp(folder, target, owner):
    p = folder / f".{target}.{owner}.{uuid.uuid4().hex[:8]}.tmp"
    p.write_text("{")
    return p


def _dead_pid():
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait(timeout=60)
    return proc.pid


def test_only_temp_files_of_gone_writers_are_stale(tmp_path):
    host = atomic._host()
    live = _temp(tmp_path, "a.json", f"{host}-{os.getpid()}")          # this process is writing it
    dead = _temp(tmp_path, "b.json", f"{host}-{_dead_pid()}")
    elsewhere_new = _temp(tmp_path, "c.json", "otherhost-1")            # a Dask worker on another host
    elsewhere_old = _temp(tmp_path, "d.json", "otherhost-2")
    old_style = _temp(tmp_path, "e.json", "k3j2")                        # no owner in the name
    an_hour_ago = time.time() - STALE_TEMP_SECONDS - 60
    os.utime(elsewhere_old, (an_hour_ago, an_hour_ago))
    os.utime(old_style, (an_hour_ago, an_hour_ago))
    assert stale_temp_files(tmp_path) == sorted([dead, elsewhere_old, old_style])
    assert live.exists() and elsewhere_new.exists()


def test_the_writer_names_its_temp_files_with_its_owner(tmp_path, monkeypatch):
    seen = []
    replace = os.replace

    def spy(src, dst):
        seen.append(os.path.basename(src))
        replace(src, dst)

    monkeypatch.setattr(atomic.os, "replace", spy)
    write_file_atomic(tmp_path / "r.json", "{}")
    assert len(seen) == 1 and seen[0].startswith(f".r.json.{atomic._host()}-{os.getpid()}.")
    assert seen[0].endswith(".tmp") and atomic._TEMP_NAME.match(seen[0])


# --- JAX's compilation cache in a folder that cannot be made ------------------------------

def test_an_unusable_cache_folder_prints_nothing(files, tmp_path):
    """HOME=/dev/null: no cache (it is a speed-up), and none of JAX's two-line warnings."""
    env = {k: v for k, v in os.environ.items() if k not in ("XDG_CACHE_HOME", "BRDF_JAX_CACHE")}
    env.update(HOME="/dev/null", PYTHONPATH=ROOT + os.pathsep + env.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-m", "brdf_fit", "fit", str(files["good"]), "-q",
                           "--out", str(tmp_path / "out"), *FAST], env=env, cwd=tmp_path,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr
    assert (tmp_path / "out" / "good.ggx+lambert.json").is_file()


# --- batch and report on a full disk -------------------------------------------------------

def test_a_batch_on_a_full_disk_keeps_its_results_and_lists_them(tmp_path, capsys):
    """Room for a few pages: the first results are written, the rest fail on the
    full disk; every result in the folder is listed in summary.csv."""
    import csv
    inputs = [_samples(tmp_path / f"m{k}.npz") for k in range(4)]
    with mounted_tmpfs(tmp_path / "disk") as disk:
        out = disk / "out"
        out.mkdir()
        fill(disk, leave=3 * 4096)
        code = main(["batch", *map(str, inputs), "--out", str(out), *FAST])
        err = capsys.readouterr().err
        results = sorted(p.name for p in out.glob("*.json"))
        with open(out / "summary.csv", newline="") as f:
            rows = list(csv.DictReader(f))
        assert _no_temp_files(disk)
    assert code == 2 and "Traceback" not in err, err
    assert "No space left on device" in err and str(out) in err, err
    assert 1 <= len(results) < len(inputs), results
    assert sorted(r["result"] for r in rows if r["result"]) == results
    assert {r["file"] for r in rows} == {str(p) for p in inputs}     # the others: error rows


def test_a_report_that_fails_half_way_leaves_no_orphan_page(files, tmp_path, capsys, monkeypatch):
    """ENOSPC injected at the index page, after the material page was written: the
    new pages are not left behind, the previous report stays whole."""
    import brdf_fit.report.pages as report
    out = tmp_path / "report"
    assert main(["report", str(files["result"]), "--out", str(out)]) == 0
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    capsys.readouterr()
    write = report.atomic_write_text

    def full_at_index(path, text):
        if os.path.basename(path) == "index.html":
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        write(path, text)

    monkeypatch.setattr(report, "atomic_write_text", full_at_index)
    other = tmp_path / "other.json"
    other.write_text(files["result"].read_text().replace('"good"', '"other"'))
    for target in (out, tmp_path / "new-report"):
        code = main(["report", str(files["result"]), str(other), "--out", str(target)])
        err = capsys.readouterr().err      # report's progress lines, then the one error line
        assert code == 2 and "Traceback" not in err, err
        assert [ln for ln in err.splitlines() if "error" in ln] == [
            f"brdf-fit report: error: {target / 'index.html'}: No space left on device"], err
    after = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert after == before
    assert not (tmp_path / "new-report").exists()


def test_a_report_removes_only_staging_folders_of_gone_reports(files, tmp_path, capsys):
    """A report killed (kill -9) while writing leaves its staging folder; the next
    report removes it, but not the staging folder of a report still running."""
    out = tmp_path / "report"
    host = atomic._host()
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])
    try:
        dead = out / f".report-staging-{host}-{_dead_pid()}"
        live = out / f".report-staging-{host}-{sleeper.pid}"
        for folder in (dead, live):
            folder.mkdir(parents=True)
            (folder / "half.html").write_text("<html>half</html>")
        assert main(["report", str(files["result"]), "--out", str(out)]) == 0
        assert not dead.exists() and (live / "half.html").is_file()
        assert (out / "index.html").is_file() and not (out / "half.html").exists()
    finally:
        sleeper.kill()
        sleeper.wait()


# --- report: a full disk is an error, not a missing figure or viewer -----------------------

def _no_space(path):
    return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))


@pytest.mark.parametrize("where", ["figure", "viewer"])
def test_a_report_whose_figure_or_viewer_meets_a_full_disk_fails(files, tmp_path, capsys, monkeypatch, where):
    """Was: exit 0, the figure or the 3D viewer silently replaced by a note."""
    import brdf_fit.report.plots as plots
    import brdf_fit.report.web_viewer as web_viewer
    if where == "figure":
        def full(fig, path, dpi=100):
            raise _no_space(path)
        monkeypatch.setattr(plots, "save", full)
        named = "good-lobes.png"
    else:
        def full(out_dir, folder=None):
            raise _no_space(out_dir / web_viewer.BUNDLE_NAME)
        monkeypatch.setattr(web_viewer, "write_three_bundle", full)
        named = web_viewer.BUNDLE_NAME
    out = tmp_path / "report"
    code = main(["report", str(files["result"]), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err, err
    assert [ln for ln in err.splitlines() if "error" in ln or "not shown" in ln] == [
        f"brdf-fit report: error: {out / named}: No space left on device"], err
    assert not out.exists()


def test_a_report_on_a_real_full_disk_fails_naming_the_file(files, tmp_path):
    """A 2 MiB file system: the figures fit, three.js's bundle (2.4 MB) does not."""
    from brdf_fit.report.web_viewer import BUNDLE_NAME, three_dir
    if three_dir() is None:
        pytest.skip("three.js is not installed (npm ci): the report writes no viewer")
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    with mounted_tmpfs(tmp_path / "disk", size=2 * 2**20) as disk:
        out = disk / "report"
        proc = subprocess.run([sys.executable, "-m", "brdf_fit", "report", str(files["result"]), "--out", str(out)],
                              env=env, capture_output=True, text=True, timeout=600)
        left = sorted(p.name for p in disk.iterdir())
    assert proc.returncode == 2 and proc.stdout == "", proc.stderr
    assert [ln for ln in proc.stderr.splitlines() if "error" in ln or "not shown" in ln] == [
        f"brdf-fit report: error: {out / BUNDLE_NAME}: No space left on device"], proc.stderr
    assert left == []
