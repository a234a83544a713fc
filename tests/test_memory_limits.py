"""A fit that would not fit in the memory the process may use says so in one line before it
starts (fitting/memory.py), instead of XLA's ``std::bad_alloc`` abort with no error line."""

import csv
import os
import subprocess
import sys

import pytest

from brdf_fit.cli import main
from fitting import memory

from test_cli_corpus import FAST, _samples

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SMALL_LIMIT = 1_200_000 * 1024          # the tester's `ulimit -v 1200000`


def _run(limit, *args):
    """``brdf-fit ARGS`` under an address-space limit of ``limit`` bytes (bash's ulimit -v:
    no preexec_fn, which would run Python in a fork of this multithreaded process)."""
    env = dict(os.environ, BRDF_JAX_CACHE="off", PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run(["bash", "-c", f'ulimit -v {int(limit) // 1024} && exec "$@"', "bash",
                           sys.executable, "-m", "brdf_fit", *map(str, args)],
                          capture_output=True, text=True, env=env, timeout=300)


def test_a_fit_under_a_small_address_space_limit_says_so_in_one_line(tmp_path):
    table = _samples(tmp_path / "lab.npz")
    for model in ["ggx+lambert", "auto"]:
        proc = _run(SMALL_LIMIT, "fit", table, "--model", model, "--out", tmp_path / "out", *FAST)
        address, _ = memory.needed(memory_cells(table), auto=model == "auto")
        assert proc.returncode == 2, proc.stderr[-2000:]
        assert proc.stderr.splitlines() == [
            f"brdf-fit fit: error: a fit{' with auto' if model == 'auto' else ''} of {table} "
            f"({memory_cells(table):,} cells) needs about {address / memory.GIB:.1f} GiB of address space, "
            f"and this process may use 1.14 GiB (ulimit -v 1200000): raise the limit"]
        assert not (tmp_path / "out").exists() or not list((tmp_path / "out").iterdir())


def memory_cells(path):
    from data_loaders import load
    return len(load(path).values)


def test_the_estimate_lets_a_fit_run_under_a_limit_just_above_it(tmp_path):
    """The other side: under a limit 0.25 GiB above the estimate the fit runs (it ran
    under 2.00 GiB: fitting/memory.py's table), so the estimate is not far above the need."""
    table = _samples(tmp_path / "lab.npz")
    address, _ = memory.needed(memory_cells(table), auto=False)
    proc = _run(address + 0.25 * memory.GIB, "fit", table, "--out", tmp_path / "out", *FAST, "-q")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert (tmp_path / "out" / "lab.ggx+lambert.json").is_file()


def test_the_estimate_grows_with_the_table_and_with_auto():
    small, merl = memory.needed(3456, False), memory.needed(1_458_000, False)
    auto_small, auto_merl = memory.needed(3456, True), memory.needed(1_458_000, True)
    # each between the limits a fit failed and ran under (the module's table)
    for (address, _), fails, runs in [(small, 1.62, 2.00), (merl, 1.72, 1.91), (auto_small, 2.00, 2.29),
                                      (auto_merl, 2.29, 2.67)]:
        assert fails * memory.GIB < address < runs * memory.GIB
    assert small[1] < merl[1] < auto_merl[1] and small[1] < auto_small[1] < auto_merl[1]


def test_a_machine_without_the_memory_gives_each_input_of_a_batch_an_error_row(tmp_path, monkeypatch, capsys):
    folder = tmp_path / "in"
    folder.mkdir()
    _samples(folder / "a.npz")
    _samples(folder / "b.npz")
    monkeypatch.setattr(memory, "available", lambda: 0.1 * memory.GIB)
    monkeypatch.setattr(memory, "_resident", lambda: 0)     # as a fresh process (this one holds its fits')
    out = tmp_path / "out"
    assert main(["batch", str(folder), "--out", str(out), *FAST]) != 0
    err = capsys.readouterr().err
    assert "Traceback" not in err
    with open(out / "summary.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert sorted(r["file"] for r in rows) == [str(folder / "a.npz"), str(folder / "b.npz")]
    for r in rows:
        assert r["status"].startswith("error: ") and "GiB of memory, and 0.10 GiB is available" in r["status"]
        assert r["result"] == ""


@pytest.mark.parametrize("content, expected", [("max\n", None), ("1073741824\n", 1 << 29)])
def test_the_cgroups_limit_counts(tmp_path, monkeypatch, content, expected):
    """memory.max less memory.current, beside MemAvailable (whichever is less)."""
    group = tmp_path / "sys" / "grp"
    group.mkdir(parents=True)
    (group / "memory.max").write_text(content)
    (group / "memory.current").write_text(str(1 << 29))
    real_open = open

    def fake_open(path, *args, **kwargs):
        path = str(path)
        if path == "/proc/self/cgroup":
            return real_open(tmp_path / "cgroup-file", *args, **kwargs)
        if path.startswith("/sys/fs/cgroup/"):
            return real_open(tmp_path / "sys" / path.removeprefix("/sys/fs/cgroup/"), *args, **kwargs)
        if path == "/proc/meminfo":
            return real_open(tmp_path / "meminfo", *args, **kwargs)
        return real_open(path, *args, **kwargs)
    (tmp_path / "cgroup-file").write_text("0::/grp\n")
    (tmp_path / "meminfo").write_text("MemTotal: 24000000 kB\nMemAvailable: 20000000 kB\n")
    monkeypatch.setattr("builtins.open", fake_open)
    assert memory.available() == (expected if expected is not None else 20000000 * 1024)
