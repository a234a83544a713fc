"""Warm fit time and M1 of the classic models beside ggx+lambert (issue 54).

Prints, per MERL-format table, the warm (compiled) fit time and M1 of each
model, and the median time ratio to ggx+lambert -- the issue asks for a warm
fit of each classic model within 3x of ggx+lambert's.  ggx+lambert takes the
closed-form gradient of fitting/fused.py; the classic models take jax.grad.

Materials: the first N NBRDF MERL-like tables of ../shared (fit_speed.py's
make_tables), else the three demo stand-ins.

    python benchmarks/classic_speed.py [--materials N] [--models M1,M2,...]
"""

import argparse
import pathlib
import statistics
import sys
import tempfile
import time

import data_loaders
from fitting.fit import fit

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from fit_speed import make_tables  # noqa: E402

MODELS = ("ggx+lambert", "beckmann+lambert", "beckmann+lambert+separable", "beckmann+lambert+vgroove",
          "blinn_phong+lambert", "phong+lambert", "ward+lambert", "ward_duer+lambert", "ashikhmin_shirley+lambert",
          "ashikhmin_shirley_scaled+lambert", "lafortune+lambert", "beckmann+lambert+vgroove+f90")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--materials", type=int, default=3)
    parser.add_argument("--models", default=",".join(MODELS))
    args = parser.parse_args()
    models = args.models.split(",")
    with tempfile.TemporaryDirectory() as tmp:
        paths = make_tables(pathlib.Path(tmp), args.materials)
        times = {m: [] for m in models}
        for path in paths:
            measured = data_loaders.load(path)
            row = []
            for model in models:
                fit(measured, model)                      # compiles
                t0 = time.perf_counter()
                result = fit(measured, model)
                dt = time.perf_counter() - t0
                times[model].append(dt)
                row.append(f"{model} {dt:5.2f} s M1 {result.errors['m1']:.4f}")
            print(f"{path.stem:28s} " + " | ".join(row), flush=True)
    base = statistics.median(times[models[0]])
    for model in models:
        med = statistics.median(times[model])
        print(f"{model:30s} median warm fit {med:5.2f} s  ({med / base:.2f} x {models[0]})")


if __name__ == "__main__":
    main()
