"""batch --scheduler when the cluster's processes die under it: every input gets a
result or an error row, the summary lists them all, no temporary copy is left,
no traceback, and the exit code says whether anything failed.

Each test starts its own cluster with the real ``dask scheduler`` / ``dask
worker --no-nanny`` commands on 127.0.0.1 (a worker is then one process, its
pid the Popen's) and runs ``brdf-fit batch`` as a subprocess (its whole
stderr, at exit too, is read).  A process is killed with SIGKILL on an
observable event, never after a sleep: by bytes, the private copy of an input
appearing in the workers' TMPDIR (its folder name carries the worker's pid,
its file the input's name); by path, the scheduler listing a batch task as
processing on a worker (a one-thread worker runs the first task it holds).
"""

import csv
import os
import pathlib
import signal
import subprocess
import sys
import time

import pytest

distributed = pytest.importorskip("distributed", reason="dask[distributed] is not installed")

from brdf_fit.batch.task import COPY_PREFIX  # noqa: E402
from fitting.result import FitResult  # noqa: E402

from dask_scheduler import scheduler_address  # noqa: E402
from test_batch_dask import DASK, FAST, ROOT, START_TIMEOUT, _write_sample_file  # noqa: E402

EVENT_TIMEOUT = 120.0       # seconds to wait for an observable event (a loaded machine); never reached normally
NO_WORKER = 3.0             # executors.NO_WORKER_TIMEOUT in these tests
MATERIALS = {"mat_a": 0.45, "mat_b": 0.3, "mat_c": 0.6}


@pytest.fixture
def inputs(tmp_path):
    folder = tmp_path / "inputs"
    folder.mkdir()
    for name, roughness in MATERIALS.items():
        _write_sample_file(folder / f"{name}.npz", name, roughness)
    return folder


class Cluster:
    """A scheduler and ``workers`` one-thread workers without nannies, all with
    TMPDIR = ``tmp`` (where by-bytes copies go)."""

    def __init__(self, folder, workers, scheduler_env=None):
        if not DASK.exists():
            pytest.skip(f"{DASK} is absent (dask's command line is not installed)")
        self.folder, self.tmp, self.logs, self.processes = folder, folder / "tmp", [], []
        self.tmp.mkdir(parents=True)
        scheduler_file = folder / "scheduler.json"
        self.scheduler = self._start(["scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                                      "--scheduler-file", str(scheduler_file), "--idle-timeout", "300"],
                                     scheduler_env)
        deadline = time.monotonic() + START_TIMEOUT
        self.address = scheduler_address(scheduler_file, self.scheduler, deadline, folder / "0.log")
        self.workers = [self._start(["worker", self.address, "--host", "127.0.0.1", "--no-nanny",
                                     "--nthreads", "1", "--no-dashboard", "--memory-limit", "0",
                                     "--local-directory", str(folder), "--death-timeout", "30"])
                        for _ in range(workers)]
        self.client = distributed.Client(self.address, timeout="30s", set_as_default=False)
        self.client.wait_for_workers(workers, timeout=max(1.0, deadline - time.monotonic()))
        self.pids = self.client.run(os.getpid)      # {worker address: pid}
        assert sorted(self.pids.values()) == sorted(w.pid for w in self.workers)

    def _start(self, argv, extra_env=None):
        log = open(self.folder / f"{len(self.logs)}.log", "w")
        self.logs.append(log)
        env = dict(os.environ, TMPDIR=str(self.tmp), **(extra_env or {}))
        process = subprocess.Popen([str(DASK), *argv], cwd=ROOT, stdout=log, stderr=subprocess.STDOUT,
                                   env=env, start_new_session=True)
        self.processes.append(process)
        return process

    def copy_being_fitted(self):
        """(pid, input name) of the first private copy a worker is fitting, when one appears."""
        def found():
            for folder in self.tmp.glob(COPY_PREFIX + "*"):
                try:
                    names = [p.name for p in folder.iterdir()]
                except OSError:         # removed meanwhile: that fit is over
                    continue
                if names:
                    return int(folder.name.rpartition(".")[0].rpartition("-")[2]), names[0]
            return None
        return wait_for(found, "a worker's private copy of an input")

    def worker_fitting(self):
        """The pid of a worker the scheduler lists as processing a batch task."""
        def found():
            for address, keys in self.client.processing().items():
                if any(str(k).startswith("fit_task") for k in keys):
                    return self.pids[address]
            return None
        return wait_for(found, "a worker processing a batch task")

    def kill(self, pid):
        """SIGKILL the worker ``pid`` and reap it (as its nanny would: a zombie counts as alive)."""
        os.kill(pid, signal.SIGKILL)
        assert next(w for w in self.workers if w.pid == pid).wait(timeout=30) == -signal.SIGKILL

    def close(self):
        try:
            self.client.close(timeout=5)
        except Exception:  # noqa: BLE001 -- its scheduler killed by the test
            pass
        for process in self.processes:         # nothing to keep: each process group killed at once
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)
            process.wait(timeout=30)
        for log in self.logs:
            log.close()


@pytest.fixture
def start_cluster(tmp_path):
    made = []

    def start(workers, scheduler_env=None):
        made.append(Cluster(tmp_path / f"cluster{len(made)}", workers, scheduler_env))
        return made[-1]
    yield start
    for cluster in made:
        cluster.close()


def wait_for(probe, what):
    deadline = time.monotonic() + EVENT_TIMEOUT
    while time.monotonic() < deadline:
        value = probe()
        if value:
            return value
        time.sleep(0.05)
    raise AssertionError(f"no {what} within {EVENT_TIMEOUT:g} s")


def start_batch(inputs, out, cluster, send_data, no_worker=60.0):
    """``brdf-fit batch`` in a process of its own, executors.NO_WORKER_TIMEOUT = ``no_worker``."""
    code = ("import sys; from brdf_fit.batch import executors; executors.NO_WORKER_TIMEOUT = float(sys.argv[1]); "
            "from brdf_fit.cli import run; sys.argv[1:] = sys.argv[2:]; run()")
    argv = [sys.executable, "-c", code, str(no_worker), "batch", str(inputs), *FAST, "--out", str(out),
            "--scheduler", cluster.address] + (["--send-data"] if send_data else [])
    env = dict(os.environ, TMPDIR=str(cluster.tmp))
    return subprocess.Popen(argv, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def finish(proc, limit=EVENT_TIMEOUT):
    try:
        stdout, stderr = proc.communicate(timeout=limit)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert "Traceback" not in stderr and "Error:" not in stderr, stderr
    return proc.returncode, stdout, stderr


def summary(out):
    with open(out / "summary.csv", newline="") as f:
        return {pathlib.Path(r["file"]).stem: r for r in csv.DictReader(f)}


def assert_clean(out, cluster):
    assert not list(out.glob(".*.tmp"))
    assert not list(cluster.tmp.glob(COPY_PREFIX + "*")), "a private copy was left behind"


def assert_fitted(out, rows, names):
    for name in names:
        assert rows[name]["status"] == "fitted", rows[name]
        assert FitResult.load(out / rows[name]["result"]).provenance["file"].endswith(f"{name}.npz")


@pytest.mark.parametrize("send_data", [False, True], ids=["by-path", "by-bytes"])
def test_a_killed_workers_task_runs_again_on_another(send_data, inputs, start_cluster, tmp_path):
    cluster = start_cluster(workers=2)
    out = tmp_path / "out"
    proc = start_batch(inputs, out, cluster, send_data)
    pid = cluster.copy_being_fitted()[0] if send_data else cluster.worker_fitting()
    cluster.kill(pid)
    code, stdout, stderr = finish(proc)
    assert code == 0, stderr
    assert stdout.strip().startswith("3 fit(s) done") and "0 failed" in stdout
    rows = summary(out)
    assert sorted(rows) == sorted(MATERIALS)
    assert_fitted(out, rows, MATERIALS)
    assert_clean(out, cluster)


def test_a_task_the_cluster_gives_up_on_is_an_error_row(inputs, start_cluster, tmp_path):
    """With allowed-failures 0 the scheduler gives up at a worker's first death on the
    tasks it held (KilledWorker: the one it fitted, and those queued behind it, which may
    be every task when the scheduler placed them all there): their inputs' rows say so,
    the others are fitted, exit 2."""
    cluster = start_cluster(workers=2, scheduler_env={"DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES": "0"})
    out = tmp_path / "out"
    proc = start_batch(inputs, out, cluster, send_data=True)
    pid, name = cluster.copy_being_fitted()
    cluster.kill(pid)
    code, stdout, stderr = finish(proc)
    assert code == 2, stderr
    rows = summary(out)
    assert sorted(rows) == sorted(MATERIALS)
    lost = {stem for stem, row in rows.items() if row["status"] != "fitted"}
    assert pathlib.Path(name).stem in lost, rows
    killed = next(address for address, p in cluster.pids.items() if p == pid)
    for stem in lost:
        assert rows[stem]["status"] == ("error: worker failed (KilledWorker: the workers that ran it died "
                                        f"1 time(s), the last {killed})"), rows[stem]
        assert rows[stem]["result"] == "" and f"skipped {inputs / stem}.npz: error: worker failed" in stderr
    assert_fitted(out, rows, set(MATERIALS) - lost)
    assert_clean(out, cluster)


@pytest.mark.parametrize("send_data", [False, True], ids=["by-path", "by-bytes"])
def test_no_worker_left_ends_the_batch_in_bounded_time(send_data, inputs, start_cluster, tmp_path):
    cluster = start_cluster(workers=1)
    out = tmp_path / "out"
    proc = start_batch(inputs, out, cluster, send_data, no_worker=NO_WORKER)
    pid = cluster.copy_being_fitted()[0] if send_data else cluster.worker_fitting()
    cluster.kill(pid)
    killed = time.monotonic()
    code, stdout, stderr = finish(proc)
    assert time.monotonic() - killed < NO_WORKER + 30.0
    assert code == 2, stderr
    reason = f"no Dask worker at {cluster.address} for {NO_WORKER:g} s"
    assert [line for line in stderr.splitlines() if "Dask" in line] == \
        [f"stopped: {reason} (start some with: dask worker {cluster.address}); "
         "the results written so far are kept"], stderr
    rows = summary(out)
    assert sorted(rows) == sorted(MATERIALS)
    for row in rows.values():     # the first may have been fitted before the kill
        assert row["status"] == "fitted" or row["status"].startswith(f"error: not fitted ({reason}"), row
    assert any(row["status"].startswith("error") for row in rows.values())
    assert_fitted(out, rows, [stem for stem, row in rows.items() if row["status"] == "fitted"])     # kept
    assert_clean(out, cluster)


def test_a_dead_scheduler_ends_the_batch_without_a_traceback(inputs, start_cluster, tmp_path):
    cluster = start_cluster(workers=1)
    out = tmp_path / "out"
    proc = start_batch(inputs, out, cluster, send_data=False)
    cluster.worker_fitting()
    os.killpg(cluster.scheduler.pid, signal.SIGKILL)
    code, stdout, stderr = finish(proc)
    assert code == 2, stderr
    reason = f"the Dask scheduler at {cluster.address} is gone"
    assert f"stopped: {reason}; the results written so far are kept" in stderr
    rows = summary(out)
    assert sorted(rows) == sorted(MATERIALS)
    for row in rows.values():
        assert row["status"] == "fitted" or row["status"] == f"error: not fitted ({reason})", row
