"""What fitting a library costs (issue 13): N MERL-size tables x ``--models auto``.

Runs ``brdf-fit batch`` over the tables, as a user would:

- locally, ``--jobs 2`` (two worker processes), and again with ``--keep-all``
  (``auto`` refines every model, as before screening; ``--no-keep-all`` skips it);
- on a Dask cluster of one ``dask scheduler`` and two one-thread ``dask
  worker`` processes on 127.0.0.1, started here and stopped at the end, by
  path (the workers read the tables and write the results themselves).

Each run starts with an empty JAX compilation cache of its own (so both pay
for compiling, as a fresh machine would) and is timed end to end (process
start, imports, compiling, loading, fitting, writing).  Printed: the wall
time, seconds per table, the projection for 100 tables (seconds per table x
100: compiling is paid once per worker, so this overestimates), and the
fits' own seconds summed from summary.csv.  The local run is repeated with
the caches it filled (compiled programs, traced programs): 100 tables cost
the compiling once (the two runs' difference) plus 100 x that run's seconds
per table -- the projection the issue's target is read against.

Beside it, a naive reference: the same number of loss+gradient evaluations
the fits reported, each as a naive ``jit(value_and_grad)`` of the M1 loss
over the full valid set of one table (evaluating the model from wi, wo on
every call, ggx+lambert), divided over the same two cores.

Tables: the NBRDF MERL-like tables generated from ../shared into a temporary
folder (never into the repository), else the three demo stand-ins.

    python benchmarks/library_cost.py [--tables K] [--quick] [--models auto]
"""

import argparse
import csv
import json
import os
import pathlib
import signal
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared"
PYTHON = sys.executable
DASK = pathlib.Path(PYTHON).parent / "dask"
WORKERS = 2
LIBRARY = 100          # the projection's library size
TARGET_MINUTES = 20    # issue 13: 100 tables x auto on 2 cores


def make_tables(folder, limit):
    """``limit`` MERL .binary tables from the NBRDF networks (else the demo stand-ins)."""
    tool = SHARED / "tools" / "merl_from_nbrdf.py"
    weights = SHARED / "measured" / "nbrdf-merl" / "merl_nbrdf_dev.npz"
    if not tool.exists() or not weights.exists():
        print("../shared absent: using the three demo stand-ins")
        from brdf_fit.demo import write_standins
        return write_standins(folder)[:limit]
    names = subprocess.run([PYTHON, str(tool), str(weights), "--list"],
                           capture_output=True, text=True, check=True).stdout.split()
    paths = []
    for name in names[:limit]:
        out = folder / f"{name}.binary"
        subprocess.run([PYTHON, str(tool), str(weights), name, str(out)], check=True, capture_output=True)
        paths.append(out)
    return paths


class Cluster:
    """A scheduler and WORKERS one-thread workers on 127.0.0.1 (the real `dask` commands)."""

    def __init__(self, folder, env):
        self.folder, self.env, self.processes = folder, env, []

    def _start(self, *argv):
        log = open(self.folder / f"dask-{len(self.processes)}.log", "w")
        self.processes.append(subprocess.Popen([str(DASK), *argv], cwd=ROOT, env=self.env, stdout=log,
                                               stderr=subprocess.STDOUT, start_new_session=True))

    def __enter__(self):
        scheduler_file = self.folder / "scheduler.json"
        self._start("scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                    "--scheduler-file", str(scheduler_file), "--idle-timeout", "600")
        deadline = time.monotonic() + 60
        while not scheduler_file.exists():
            if time.monotonic() > deadline or self.processes[0].poll() is not None:
                raise RuntimeError(f"the scheduler did not start; see {self.folder}/dask-0.log")
            time.sleep(0.2)
        self.address = json.loads(scheduler_file.read_text())["address"]
        self._start("worker", self.address, "--host", "127.0.0.1", "--nworkers", str(WORKERS),
                    "--nthreads", "1", "--no-dashboard", "--memory-limit", "0",
                    "--local-directory", str(self.folder), "--death-timeout", "60")
        import distributed
        with distributed.Client(self.address, timeout="60s") as client:
            client.wait_for_workers(WORKERS, timeout=120)
        return self

    def __exit__(self, *exc):
        for p in self.processes:
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGTERM)
        for p in self.processes:
            try:
                p.wait(timeout=15)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()
        return False


def batch(label, tables, out, models, extra, env):
    """Run ``brdf-fit batch`` over ``tables``; print and return (wall seconds, summary rows)."""
    argv = [PYTHON, "-m", "brdf_fit.cli", "batch", *map(str, tables), "--models", models,
            "--out", str(out), "-q", *extra]
    t = time.perf_counter()
    res = subprocess.run(argv, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t
    if res.returncode != 0:
        raise RuntimeError(f"{label}: exit {res.returncode}: {res.stderr.strip()}")
    with open(out / "summary.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    per_table = wall / len(tables)
    fit_seconds = sum(float(r["seconds"]) for r in rows if r["seconds"])
    projected = per_table * LIBRARY / 60
    print(f"{label:34s} {len(rows):4d} fits  wall {wall:8.1f} s  {per_table:7.1f} s/table  "
          f"fits' own {fit_seconds / len(tables):7.1f} s/table  -> {LIBRARY} tables: {projected:6.1f} min "
          f"({'within' if projected <= TARGET_MINUTES else 'over'} the {TARGET_MINUTES} min target)")
    return wall, rows


def naive_reference(table, evaluations, cores=WORKERS):
    """Seconds for ``evaluations`` naive full-set loss+gradient passes (ggx+lambert) over ``cores``:
    fit_speed.py's naive pass, in float64 as fits run."""
    import jax
    import data_loaders
    from brdf.model import parse_model
    from fit_speed import naive_pass      # benchmarks/ is on sys.path when this script runs

    with jax.enable_x64(True):
        one, pairs = naive_pass(data_loaders.load(table), parse_model("ggx+lambert"))
    print(f"naive reference: jit(value_and_grad) of M1 over the full valid set ({pairs:,} pairs), "
          f"ggx+lambert: {one * 1e3:.1f} ms per pass")
    return one * evaluations / cores


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tables", type=int, help="number of MERL-size tables (default 10; --quick: 2)")
    parser.add_argument("--quick", action="store_true", help="a smoke run: 2 tables unless --tables says")
    parser.add_argument("--models", default="auto", help="models to fit (default: auto, the engine family)")
    parser.add_argument("--no-keep-all", action="store_true",
                        help="skip the local run with --keep-all (every model refined) beside auto's")
    args = parser.parse_args()
    count = args.tables or (2 if args.quick else 10)
    with tempfile.TemporaryDirectory(prefix="library-cost-") as tmp:
        tmp = pathlib.Path(tmp)
        (tmp / "tables").mkdir()
        tables = make_tables(tmp / "tables", count)
        print(f"{len(tables)} table(s) x --models {args.models}, {os.cpu_count()} cores, "
              f"load average {os.getloadavg()[0]:.1f} at the start")

        def env(name):          # an empty compilation cache per run
            return dict(os.environ, BRDF_JAX_CACHE=str(tmp / f"jax-cache-{name}"))

        wall, rows = batch("local, --jobs 2", tables, tmp / "local", args.models, ["--jobs", str(WORKERS)],
                           env("local"))
        # again with the caches that run filled: what every table costs once the programs are
        # compiled; 100 tables then cost the compiling once (the difference) and that per table
        warm, _ = batch("local, --jobs 2, caches filled", tables, tmp / "local-filled", args.models,
                        ["--jobs", str(WORKERS)], env("local"))
        projected = (max(0.0, wall - warm) + warm * LIBRARY / len(tables)) / 60
        print(f"{'':34s} compiling paid once: {wall - warm:6.1f} s + {LIBRARY} x {warm / len(tables):.1f} s/table "
              f"-> {LIBRARY} tables: {projected:6.1f} min")
        if not args.no_keep_all:       # auto screens and refines the contenders; --keep-all refines all 24
            batch("local, --jobs 2, --keep-all", tables, tmp / "local-keep-all", args.models,
                  ["--jobs", str(WORKERS), "--keep-all"], env("local-keep-all"))
        with Cluster(tmp, env("dask")) as cluster:
            batch("dask, 2 workers, by path", tables, tmp / "dask", args.models,
                  ["--scheduler", cluster.address], env("dask"))

        evaluations = 0
        for r in rows:
            if r["result"]:
                with open(tmp / "local" / r["result"]) as f:
                    evaluations += int(json.load(f)["optimizer"].get("evaluations", 0))
        naive = naive_reference(tables[0], evaluations)
        per_table = naive / len(tables)
        print(f"naive reference: the local run's {evaluations:,} evaluations as naive passes on "
              f"{WORKERS} cores: {per_table:7.1f} s/table -> {LIBRARY} tables: {per_table * LIBRARY / 60:6.1f} min")


if __name__ == "__main__":
    main()
