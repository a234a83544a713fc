"""Fit speed on MERL-format tables (issue 4's targets).

Prints, for ggx+lambert:
- the naive jit(value_and_grad) of the M1 loss over the full valid set
  (evaluate from wi, wo each call) beside the toolkit's loss+gradient pass
  (precomputed geometry, stratified 100 k subsample);
- the median warm fit (compiled) over the materials;
- the first fit in a fresh process, compilation included, with an empty
  persistent compilation cache and again with the cache that run filled;
- the materials x the four diffuse models as one batch.

Materials: the ten NBRDF MERL-like tables generated from ../shared (when
present) into a temporary folder, else the three demo stand-ins.

    python benchmarks/fit_speed.py [--materials N]
"""

import argparse
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

import jax
import jax.numpy as jnp

import data_loaders
from brdf.model import evaluate, parse_model
from brdf_fit.batch.run import run_batch
from fitting.auto import DIFFUSE_FAMILY
from brdf_fit.demo import write_standins
from fitting.fit import _objective, _value_and_grad, fit, prepare
from fitting.transforms import from_params, to_params

ROOT = pathlib.Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared"


def make_tables(folder, limit):
    tool = SHARED / "tools" / "merl_from_nbrdf.py"
    weights = SHARED / "measured" / "nbrdf-merl" / "merl_nbrdf_dev.npz"
    if not tool.exists():
        print("../shared absent: using the three demo stand-ins")
        return write_standins(folder)[:limit]
    names = subprocess.run([sys.executable, str(tool), str(weights), "--list"],
                           capture_output=True, text=True, check=True).stdout.split()
    paths = []
    for name in names[:limit]:
        out = folder / f"{name}.binary"
        subprocess.run([sys.executable, str(tool), str(weights), name, str(out)],
                       check=True, capture_output=True)
        paths.append(out)
    return paths


def timed(fn, *args, repeat=10):
    jax.block_until_ready(fn(*args))
    t = time.perf_counter()
    for _ in range(repeat):
        jax.block_until_ready(fn(*args))
    return (time.perf_counter() - t) / repeat


def naive_pass(measured, spec):
    sel = measured.select(80.0)
    wi, wo = jnp.asarray(sel.wi), jnp.asarray(sel.wo)
    fhat, w = jnp.asarray(sel.values), jnp.asarray(sel.weights / (2 * sel.weights.sum()))

    def loss(u):
        p = to_params(spec, u)
        total = 0.0
        for a, b in ((wi, wo), (wo, wi)):
            c = a[:, 2:3]
            r = jnp.log1p(evaluate(spec, p, a, b) * c) - jnp.log1p(fhat * c)
            total = total + jnp.sum(w[:, None] * r * r, axis=0)
        return jnp.mean(jnp.sqrt(total))

    u = jnp.asarray(from_params(spec, {"albedo": [0.2] * 3, "roughness": 0.3, "f0": [0.05] * 3}))
    return timed(jax.jit(jax.value_and_grad(loss)), u), sel.wi.shape[0]


def loss_passes(measured, spec):
    """Print the naive and the toolkit's loss+gradient pass times (float64, as fits run)."""
    t_naive, n_full = naive_pass(measured, spec)
    full, sub = prepare(measured)
    u = jnp.asarray(from_params(spec, {"albedo": [0.2] * 3, "roughness": 0.3, "f0": [0.05] * 3}))
    vg = _value_and_grad(spec, "log")
    t_sub = timed(vg, u, sub)
    t_fullpass = timed(vg, u, full)
    plain = jax.jit(jax.value_and_grad(lambda u, data: _objective(spec, "log", data)(u)))
    t_plain = timed(plain, u, sub)
    print(f"loss+grad, naive jit(value_and_grad), full set ({n_full:,} pairs): {t_naive * 1e3:7.1f} ms")
    print(f"loss+grad, toolkit, full set ({full.size:,} pairs):                 {t_fullpass * 1e3:7.1f} ms")
    print(f"loss+grad, toolkit, stratified subsample ({sub.size:,} pairs):      {t_sub * 1e3:7.1f} ms")
    print(f"  (jax.value_and_grad of the plain loss on the same subsample:    {t_plain * 1e3:7.1f} ms)")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--materials", type=int, default=10)
    args = parser.parse_args()
    spec = parse_model("ggx+lambert")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        paths = make_tables(tmp, args.materials)
        measured = [data_loaders.load(p) for p in paths]
        with jax.enable_x64(True):      # the loss passes below run the fitter's programs directly
            loss_passes(measured[0], spec)

        warm = []
        for m in measured:
            data = prepare(m)
            fit(m, spec, data=data)                       # compiled for this shape
            t = time.perf_counter()
            r = fit(m, spec, data=data)
            warm.append(time.perf_counter() - t)
            print(f"  {m.material:26s} warm fit {warm[-1]:6.3f} s  M1 {r.errors['m1']:.5f}  "
                  f"evaluations {r.optimizer['evaluations']}")
        print(f"median warm fit (ggx+lambert, {len(warm)} materials): {statistics.median(warm):.3f} s")

        code = ("import time; t=time.perf_counter();"
                "import data_loaders; from fitting import fit;"
                f"fit(data_loaders.load({str(paths[0])!r}), 'ggx+lambert');"
                "print(time.perf_counter()-t)")
        env = dict(os.environ, BRDF_JAX_CACHE=str(tmp / "jax-cache"))   # starts empty
        for label in ("empty compilation cache", "compilation cache filled by the run before"):
            first = float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                         check=True, cwd=ROOT, env=env).stdout.strip().splitlines()[-1])
            print(f"first fit in a fresh process (imports + load + compile + fit), {label}: {first:.2f} s")

        t = time.perf_counter()
        run_batch(paths, [f"ggx+{d}" for d in DIFFUSE_FAMILY], tmp / "batch", progress=False,
                  log=lambda m: None)
        print(f"batch: {len(paths)} materials x {len(DIFFUSE_FAMILY)} diffuse models: "
              f"{time.perf_counter() - t:.1f} s")


if __name__ == "__main__":
    main()
