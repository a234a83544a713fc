"""A library of many tiny tables (issue 60, item 7: 300 within 3 minutes on this machine).

    python benchmarks/library_tiny.py [--tables 300] [--cells 8] [--beside]

Writes N small sample lists (CSV, the plain format a lab's own gonioreflectometer gives): each
a ``synthetic_measured`` table of a random ``ggx+lambert`` material (albedo, F0, roughness drawn
from a fixed seed) on a grid of CELLS x CELLS x 2 CELLS x 1 cells (8: 1 024 cells, about 500
valid samples), with 2 % multiplicative noise.  Then, as a user would:

1. ``brdf-fit library TABLES --out LIB --jobs 2`` on 4 of them, to fill the compilation caches
   (a first run on a machine pays for compiling once: docs/performance.md, *Fresh process*);
2. the library of all N, from those caches: the figure the target is read against;
3. with ``--beside``: the same library again while a second process keeps one core busy
   (a fit of a MERL-size table in a loop: "beside other work").

Printed: each run's wall seconds, seconds per table and the projection to 300 tables.
"""

import argparse
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks")]

import library_scale  # noqa: E402  (benchmarks/: its library run, timed)

PYTHON = sys.executable
TARGET_TABLES, TARGET_SECONDS = 300, 180.0
BUSY = ("import numpy as np, time\n"
        "a = np.random.default_rng(0).random((400, 400))\n"
        "while True:\n"
        "    a = np.tanh(a @ a.T / 400.0)\n")


def make_tables(folder, n, cells, seed=0):
    """N CSV sample lists of random ggx+lambert materials on a tiny grid; their paths."""
    from data_loaders.samples import write_samples
    from fitting.synthetic import synthetic_measured
    rng = np.random.default_rng(seed)
    paths = []
    for i in range(n):
        params = {"albedo": list(rng.uniform(0.02, 0.6, 3)), "f0": [float(rng.uniform(0.02, 0.08))] * 3,
                  "roughness": float(rng.uniform(0.15, 0.8))}
        m = synthetic_measured("ggx+lambert", params, noise=0.02, seed=i, grid=(cells, cells, 2 * cells, 1),
                               material=f"tiny-{i:03d}")
        keep = m.valid
        path = folder / f"tiny-{i:03d}.csv"
        write_samples(path, m.wi[keep], m.wo[keep], m.values[keep], material=f"tiny-{i:03d}", isotropic=True)
        paths.append(path)
    return paths


def library(label, tables, out, env):
    """``brdf-fit library TABLES --out OUT --jobs 2`` in a fresh process (library_scale.library, which
    prints its wall time); its wall seconds, projected to TARGET_TABLES tables."""
    wall = library_scale.library(label, tables, out, env, "--jobs", "2")
    print(f"{'':44s} {TARGET_TABLES} tables: {wall * TARGET_TABLES / len(tables):6.1f} s, "
          f"target {TARGET_SECONDS:.0f} s", flush=True)
    return wall


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tables", type=int, default=TARGET_TABLES)
    parser.add_argument("--cells", type=int, default=8, help="theta_h and theta_d cells (phi_d: twice)")
    parser.add_argument("--beside", action="store_true", help="again, beside a process keeping one core busy")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="library-tiny-") as tmp:
        tmp = pathlib.Path(tmp)
        (tmp / "tables").mkdir()
        t = time.perf_counter()
        tables = make_tables(tmp / "tables", args.tables, args.cells)
        size = sum(p.stat().st_size for p in tables) / len(tables) / 1e3
        print(f"{len(tables)} tables ({size:.0f} kB each) in {time.perf_counter() - t:.0f} s; {os.cpu_count()} cores, "
              f"load average {os.getloadavg()[0]:.1f}", flush=True)
        env = dict(os.environ, BRDF_JAX_CACHE=str(tmp / "jax-cache"))
        library("filling the caches (4 tables)", tables[:4], tmp / "warm", env)
        library(f"library of {len(tables)}", tables, tmp / "lib", env)
        if args.beside:
            busy = subprocess.Popen([PYTHON, "-c", BUSY], env=dict(os.environ, OMP_NUM_THREADS="1",
                                                                     OPENBLAS_NUM_THREADS="1"))
            try:
                library(f"library of {len(tables)}, one core busy beside", tables, tmp / "beside", env)
            finally:
                busy.kill()
                busy.wait()


if __name__ == "__main__":
    main()
