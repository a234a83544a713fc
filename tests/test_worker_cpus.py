"""Local batch workers each kept to their own share of the CPUs (brdf_fit.batch.executors.worker_cpus).

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
from brdf_fit.batch.executors import worker_cpus

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
