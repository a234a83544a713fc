"""Local batch workers: how many by default (default_jobs), each kept to its own share of the
CPUs (worker_cpus); brdf_fit.batch.executors.

Two workers on two cores, each free to use both, ran their XLA programs on two
threads each and waited on each other: kept to a core each, the same fits ran
8-10 % faster (docs/performance.md).  Tested here: how the CPUs are dealt, and
that a worker started by the initializer is kept to its share before JAX loads.
"""

import os
import subprocess
import sys
import textwrap

import pytest

from brdf_fit.batch import executors
from brdf_fit.batch.executors import FILES_PER_WORKER, MERL_CELLS, default_jobs, worker_cpus
from fitting import memory

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
linux_only = pytest.mark.skipif(not hasattr(os, "sched_setaffinity"), reason="no CPU affinity on this system")


@pytest.mark.parametrize("cpus, jobs", [({0, 1}, 2), ({0, 1, 2, 3}, 2), ({0, 1, 2, 3, 4, 5, 6}, 3),
                                        ({2, 5, 7}, 2), ({0, 1, 2, 3}, 4)])
def test_every_cpu_dealt_once_when_there_are_enough(monkeypatch, cpus, jobs):
    monkeypatch.setattr(executors.os, "sched_getaffinity", lambda pid: set(cpus), raising=False)
    shares = worker_cpus(jobs)
    assert len(shares) == jobs
    assert all(shares), "every worker has a CPU"
    assert set().union(*shares) == cpus
    assert sum(len(s) for s in shares) == len(cpus), "no CPU in two shares"
    assert max(map(len, shares)) - min(map(len, shares)) <= 1, "shares as even as the count allows"


def test_more_workers_than_cpus_share_them_round(monkeypatch):
    monkeypatch.setattr(executors.os, "sched_getaffinity", lambda pid: {3, 8}, raising=False)
    assert worker_cpus(5) == [{3}, {8}, {3}, {8}, {3}]


@pytest.mark.parametrize("cpus, jobs", [({0, 1}, 1), ({4}, 2)])
def test_nothing_to_deal(monkeypatch, cpus, jobs):
    """One worker, or one CPU: every worker may use what this process may."""
    monkeypatch.setattr(executors.os, "sched_getaffinity", lambda pid: set(cpus), raising=False)
    assert worker_cpus(jobs) is None


def test_no_affinity_on_this_system(monkeypatch):
    monkeypatch.delattr(executors.os, "sched_getaffinity", raising=False)
    assert worker_cpus(2) is None


@linux_only
@pytest.mark.skipif(len(os.sched_getaffinity(0)) < 2 if hasattr(os, "sched_getaffinity") else True,
                    reason="one CPU: nothing to deal")
def test_the_kth_worker_started_takes_the_kth_share():
    """The initializer, in a process of its own as a pool starts it: the second worker
    started (the counter at 1) is kept to the second share, before JAX is imported."""
    cpus = sorted(os.sched_getaffinity(0))
    shares = [{cpus[0]}, {cpus[1]}]
    code = textwrap.dedent(f"""
        import multiprocessing, os, sys
        from brdf_fit.batch.executors import _init_worker
        started = multiprocessing.get_context("spawn").Value("i", 1)
        _init_worker({shares!r}, started)
        print(sorted(os.sched_getaffinity(0)), started.value, "jax" in sys.modules)
    """)
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == [f"[{cpus[1]}]", "2", "False"]


def _files(tmp_path, count):
    folder = tmp_path / "tables"
    folder.mkdir()
    for i in range(count):
        (folder / f"m{i}.csv").write_text("x")     # counted by name, never read
    return [str(folder)]


@pytest.mark.parametrize("files, cpus, workers_memory, expected", [
    (100, 2, 10, 2),        # a MERL database on this machine: two workers
    (8, 2, 10, 2),          # FILES_PER_WORKER files a worker
    (7, 2, 10, 1),          # too few files for two: this process
    (1, 2, 10, 1),
    (100, 8, 3, 3),         # the memory holds three
    (100, 8, 0, 1),         # it holds none: this process (the fit's own check says so)
    (20, 8, 10, 5),         # 20 files // 4
])
def test_default_jobs(monkeypatch, tmp_path, files, cpus, workers_memory, expected):
    worker = memory.needed(MERL_CELLS, auto=True)[1]
    monkeypatch.setattr(executors.os, "sched_getaffinity", lambda pid: set(range(cpus)), raising=False)
    monkeypatch.setattr(memory, "available", lambda: (workers_memory + 0.5) * worker)
    assert FILES_PER_WORKER == 4
    assert default_jobs(_files(tmp_path, files)) == expected


def test_default_jobs_without_memory_figures(monkeypatch, tmp_path):
    monkeypatch.setattr(executors.os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)
    monkeypatch.setattr(memory, "available", lambda: None)
    assert default_jobs(_files(tmp_path, 40)) == 2


def test_default_jobs_of_missing_inputs_is_one(tmp_path):
    """The batch itself says what is wrong with the inputs."""
    assert default_jobs([str(tmp_path / "nowhere")]) == 1


def test_cli_leaves_jobs_to_the_default():
    from brdf_fit.cli import build_parser
    parser = build_parser()
    assert parser.parse_args(["library", "x"]).jobs is None
    assert parser.parse_args(["batch", "x", "--jobs", "3"]).jobs == 3
