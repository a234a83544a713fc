"""Which optimizer converges fastest here (issue 4: the fastest is the default).

For each optimizer, ggx+lambert is fitted to every material with the same
pipeline (stratified subsample, candidate scan, multi-start, full-set M1):
the first fit (compilation included), then the median and slowest warm fit
and the M1 each reached, beside the default's.

Materials: the ten NBRDF MERL-like tables generated from ../shared (when
present), else the three demo stand-ins.

    python benchmarks/optimizers.py [--materials N] [--optimizers a,b,...]
"""

import argparse
import pathlib
import statistics
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))      # the sibling script below

from fit_speed import make_tables  # noqa: E402
import data_loaders  # noqa: E402
from fitting.fit import DEFAULT_OPTIMIZER, OPTIMIZERS, fit, prepare  # noqa: E402

LOCAL = ("lbfgs", "bobyqa", "optx_bfgs", "optx_lm", "optx_dogleg")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--materials", type=int, default=10)
    parser.add_argument("--optimizers", default=",".join(LOCAL),
                        help=f"comma-separated, from {', '.join(OPTIMIZERS)}")
    args = parser.parse_args()
    names = args.optimizers.split(",")
    unknown = [n for n in names if n not in OPTIMIZERS]
    if unknown:
        sys.exit(f"unknown optimizer(s) {', '.join(unknown)}; valid: {', '.join(OPTIMIZERS)}")
    with tempfile.TemporaryDirectory() as tmp:
        paths = make_tables(pathlib.Path(tmp), args.materials)
        measured = [data_loaders.load(p) for p in paths]
        data = [prepare(m) for m in measured]
        reference = None
        print(f"ggx+lambert, {len(measured)} materials; M1 ratio against {DEFAULT_OPTIMIZER} "
              "(1.000 = the same fit)")
        for name in [DEFAULT_OPTIMIZER] + [n for n in names if n != DEFAULT_OPTIMIZER]:
            t = time.perf_counter()
            fit(measured[0], "ggx+lambert", optimizer=name, data=data[0])
            first = time.perf_counter() - t
            seconds, m1 = [], []
            for m, d in zip(measured, data):
                t = time.perf_counter()
                r = fit(m, "ggx+lambert", optimizer=name, data=d)
                seconds.append(time.perf_counter() - t)
                m1.append(r.errors["m1"])
            reference = reference or m1
            ratios = [a / b for a, b in zip(m1, reference)]
            print(f"{name:12s} first fit {first:6.2f} s   warm median {statistics.median(seconds):6.3f} s"
                  f"  slowest {max(seconds):6.3f} s   M1 median {statistics.median(m1):.5f}"
                  f"  ratio {min(ratios):.3f}-{max(ratios):.3f}", flush=True)


if __name__ == "__main__":
    main()
