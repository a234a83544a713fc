"""brdf-fit batch --scheduler: the per-file fits on a real Dask cluster.

A scheduler and two workers are started with the real ``dask scheduler`` /
``dask worker`` commands on 127.0.0.1 (their port read from a scheduler
file) and stopped, process group and all, when the module's tests end.
Every expected number comes from a local run of the same batch: a Dask run,
by path or by bytes, must give the same results, provenance and summary.
"""

import csv
import os
import pathlib
import shutil
import signal
import socket
import subprocess
import sys
import time
import types

import numpy as np
import pytest

from data_loaders import write_samples
from brdf_fit.batch import executors
from brdf_fit.batch.run import run_batch
from brdf_fit.cli import main
from fitting.result import FitResult
from fitting.synthetic import synthetic_measured

from dask_scheduler import scheduler_address

distributed = pytest.importorskip("distributed", reason="dask[distributed] is not installed")

ROOT = pathlib.Path(__file__).resolve().parent.parent
DASK = pathlib.Path(sys.executable).parent / "dask"
TRUTH = {"albedo": [0.4, 0.25, 0.1], "roughness": 0.45, "f0": [0.05, 0.05, 0.05]}
FAST = ["--models", "ggx+lambert", "--samples", "3000", "--starts", "1"]
START_TIMEOUT = 90.0        # seconds for the scheduler and both workers to come up (a loaded machine)
WORKERS = 2


def _write_sample_file(path, material, roughness):
    m = synthetic_measured("ggx+lambert", dict(TRUTH, roughness=roughness), grid=(12, 12, 24, 1))
    keep = m.valid
    write_samples(path, m.wi[keep], m.wo[keep], m.values[keep], weights=m.weights[keep],
                  material=material, isotropic=True)


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """Two synthetic measured files and a corrupt one (a truncated MERL table)."""
    folder = tmp_path_factory.mktemp("dask-inputs")
    _write_sample_file(folder / "mat_a.npz", "mat_a", 0.45)
    _write_sample_file(folder / "mat_b.npz", "mat_b", 0.3)
    (folder / "broken.binary").write_bytes(np.array([90, 90, 180], "<i4").tobytes() + b"\x00" * 100)
    return folder


def _stop(processes):
    """End each process group: SIGTERM, then SIGKILL what is left after a few seconds."""
    for p in processes:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGTERM)
    for p in processes:
        try:
            p.wait(timeout=10)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait(timeout=10)


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """The address of a scheduler with two one-thread workers (real `dask` commands)."""
    if not DASK.exists():
        pytest.skip(f"{DASK} is absent (dask's command line is not installed)")
    folder = tmp_path_factory.mktemp("dask-cluster")
    scheduler_file = folder / "scheduler.json"
    logs = []

    def start(*argv):
        log = open(folder / f"{len(logs)}.log", "w")
        logs.append(log)
        return subprocess.Popen([str(DASK), *argv], cwd=ROOT, stdout=log, stderr=subprocess.STDOUT,
                                start_new_session=True)     # its own process group, killed whole

    processes = [start("scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                       "--scheduler-file", str(scheduler_file), "--idle-timeout", "300")]
    try:
        deadline = time.monotonic() + START_TIMEOUT
        address = scheduler_address(scheduler_file, processes[0], deadline, folder / "0.log")
        for _ in range(WORKERS):
            processes.append(start("worker", address, "--host", "127.0.0.1", "--nworkers", "1",
                                   "--nthreads", "1", "--no-dashboard", "--memory-limit", "0",
                                   "--local-directory", str(folder), "--death-timeout", "60"))
        with distributed.Client(address, timeout="30s") as client:
            client.wait_for_workers(WORKERS, timeout=max(1.0, deadline - time.monotonic()))
        yield address
    finally:
        _stop(processes)
        for log in logs:
            log.close()


@pytest.fixture(scope="module")
def local_run(inputs, tmp_path_factory):
    """The same batch run locally: the reference every Dask run is held to."""
    out = tmp_path_factory.mktemp("local") / "out"
    assert main(["batch", str(inputs), *FAST, "--out", str(out)]) == 2     # the corrupt file
    return out


def _summary(out):
    with open(out / "summary.csv", newline="") as f:
        return list(csv.DictReader(f))


def _key(row):
    return row["material"], row["file"], row["model"], row["status"], row["result"]


def assert_same_results(out, reference):
    """The same result files as the reference run, with equal parameters, M1 and provenance."""
    names = sorted(p.name for p in reference.glob("*.json"))
    assert names and sorted(p.name for p in out.glob("*.json")) == names
    for name in names:
        got, want = FitResult.load(out / name), FitResult.load(reference / name)
        assert got.parameters.keys() == want.parameters.keys()
        for k in want.parameters:
            np.testing.assert_allclose(got.parameters[k], want.parameters[k], rtol=1e-9, err_msg=k)
        assert got.errors["m1"] == pytest.approx(want.errors["m1"], rel=1e-9)
        assert got.provenance == want.provenance        # the real input path and sha256
        assert got.optimizer["options"] == want.optimizer["options"]
    assert sorted(map(_key, _summary(out))) == sorted(map(_key, _summary(reference)))


@pytest.mark.parametrize("mode", ["by-path", "by-bytes"])
def test_dask_batch_equals_a_local_run_and_resumes(mode, inputs, cluster, local_run, tmp_path, capsys):
    out = tmp_path / "out"
    argv = ["batch", str(inputs), *FAST, "--out", str(out), "--scheduler", cluster]
    argv += ["--send-data"] if mode == "by-bytes" else []
    assert main(argv) == 2                          # the corrupt file fails; the rest is done
    assert_same_results(out, local_run)
    rows = _summary(out)
    errors = [r for r in rows if r["status"].startswith("error")]
    assert len(errors) == 1 and errors[0]["file"] == str(inputs / "broken.binary")
    assert errors[0]["status"] == next(r["status"] for r in _summary(local_run) if r["status"].startswith("error"))
    assert "broken.binary" in capsys.readouterr().err
    assert not list(out.glob(".*.tmp"))

    # Re-running resumes: nothing is refitted, no result file is rewritten.
    stamps = {p.name: p.stat().st_mtime_ns for p in out.glob("*.json")}
    assert main(argv) == 2
    fits = [r for r in _summary(out) if not r["status"].startswith("error")]
    assert len(fits) == len(stamps) and {r["status"] for r in fits} == {"resumed"}
    assert {p.name: p.stat().st_mtime_ns for p in out.glob("*.json")} == stamps


def test_send_data_resumes_results_of_a_run_by_path(inputs, cluster, local_run, tmp_path):
    """Results on disk from a local run are resumed by a --send-data run (the workers
    see them through the client's snapshot of the output folder)."""
    out = tmp_path / "out"
    shutil.copytree(local_run, out)
    assert main(["batch", str(inputs), *FAST, "--out", str(out), "--scheduler", cluster,
                 "--send-data"]) == 2
    fits = [r for r in _summary(out) if not r["status"].startswith("error")]
    assert fits and {r["status"] for r in fits} == {"resumed"}


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_unreachable_scheduler_is_one_line_and_exit_2(inputs, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(executors, "CONNECT_TIMEOUT", 2.0)
    address = f"tcp://127.0.0.1:{_free_port()}"
    t = time.monotonic()
    assert main(["batch", str(inputs), *FAST, "--out", str(tmp_path / "out"), "--scheduler", address]) == 2
    assert time.monotonic() - t < 2.0 + 15.0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert f"cannot reach the Dask scheduler at {address} within 2 s" in err
    assert not list((tmp_path / "out").glob("*.json"))


def test_send_data_without_scheduler_is_refused(inputs, tmp_path, capsys):
    assert main(["batch", str(inputs), "--out", str(tmp_path), "--send-data"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--send-data needs --scheduler" in err


def test_a_failed_task_becomes_its_files_rows(inputs, tmp_path):
    """An executor reporting a task's exception (a worker that died: Dask's
    KilledWorker) gives that file's error rows; the other files are done as usual."""
    from brdf_fit.batch.task import fit_task

    class OneWorkerDies:
        def run(self, tasks, out_dir, results):
            for task in tasks:
                if task.path.endswith("mat_b.npz"):
                    lost = types.SimpleNamespace(address="tcp://127.0.0.1:1")
                    yield task, distributed.KilledWorker("fit_task-mat_b", lost, 3)
                else:
                    yield task, fit_task(task, str(out_dir))

    out = tmp_path / "out"
    files = [inputs / "broken.binary", inputs / "mat_b.npz"]
    rows = run_batch(files, ["ggx+lambert", "ggx+burley"], out, fit_options={"samples": 2000, "starts": 1},
                     executor=OneWorkerDies(), progress=False, log=lambda m: None)
    status = {(pathlib.Path(r["file"]).name, r["model"]): r["status"] for r in rows}
    assert len(status) == 4
    for model in ("ggx+lambert", "ggx+burley"):
        assert status["mat_b.npz", model].startswith("error: worker failed (KilledWorker")
        assert status["broken.binary", model].startswith("error: file is 112 bytes")   # its own error
    assert sorted(map(_key, _summary(out))) == sorted(map(_key, rows))


def test_importing_the_command_line_imports_no_dask():
    code = "import sys, brdf_fit.cli; print(sorted(m for m in ('dask', 'distributed') if m in sys.modules))"
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True)
    assert res.stdout.strip() == "[]"


def test_ctrl_c_ends_the_client_cleanly(inputs, cluster, tmp_path):
    """SIGINT while the cluster fits: one line, exit 130, no partial result file.
    (Last in the module: the workers finish the fits already running, then the
    cluster is stopped.)"""
    out = tmp_path / "out"
    argv = [sys.executable, "-m", "brdf_fit.cli", "batch", str(inputs), "--models", "auto",
            "--samples", "3000", "--starts", "1", "--out", str(out), "--scheduler", cluster]
    proc = subprocess.Popen(argv, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        for line in proc.stderr:                # until the first file is done (the corrupt one)
            if "broken.binary" in line:
                break
        assert proc.poll() is None, "the batch ended before it could be interrupted"
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130, stderr
    assert stderr.strip().splitlines()[-1] == "brdf-fit batch: interrupted; finished results are on disk"
    assert "Traceback" not in stderr and stdout == ""
    for result in out.glob("*.json"):
        FitResult.load(result)                  # whatever is there is complete


def test_own_model_file_travels_with_send_data(cluster, tmp_path):
    """A model of one's own (brdf/own.py) on the cluster by bytes: the workers never read the
    model file; the task carries its bytes and path, and the result records its name, sha256
    (hashlib's of examples/own_model.py) and the path as given.  The table is the example's at TRUTH_OWN, noiseless:
    recovered within the 3 % of tests/test_own_model.py."""
    from brdf import own
    example = ROOT / "examples" / "own_model.py"
    model = own.load_file(example, "BLINN_PHONG_LAMBERT")
    truth = {"diffuse_albedo": [0.3, 0.2, 0.1], "specular": [0.1, 0.12, 0.15], "exponent": 300.0}
    m = synthetic_measured(model, truth, grid=(24, 24, 48, 1))
    write_samples(tmp_path / "own_a.npz", m.wi[m.valid], m.wo[m.valid], m.values[m.valid],
                  weights=m.weights[m.valid], material="own_a", isotropic=True)
    assert main(["batch", str(tmp_path / "own_a.npz"), "--models", f"{example}:BLINN_PHONG_LAMBERT",
                 "--samples", "3000", "--out", str(tmp_path / "out"), "--scheduler", cluster, "--send-data"]) == 0
    result = FitResult.load(tmp_path / "out" / "own_a.own:blinn_phong_lambert.json")
    for name, value in truth.items():
        np.testing.assert_allclose(result.parameters[name], value, rtol=0.03, err_msg=name)
    assert result.model_file == {"name": "own_model.py", "sha256": model.source[1], "path": str(example)}
