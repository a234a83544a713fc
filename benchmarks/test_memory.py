"""The test suite's memory, per pytest worker: how much each holds and which modules raise it.

    python benchmarks/test_memory.py                 # runs the suite as `make test` does, logging
    python benchmarks/test_memory.py --log FILE      # summarises a log written before
    BRDF_TEST_MEMORY_LOG=FILE make test              # the log of a `make test` run

tests/conftest.py writes one line per test module when BRDF_TEST_MEMORY_LOG names a file:
the worker, the module, the resident set after the module (its memory given back) and the
worker's peak so far, in MiB.  Printed: each worker's peak and where it was reached, the
modules whose run raised a worker's peak the most, and the wall time of the run.
"""

import argparse
import collections
import os
import pathlib
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent


def read_log(path):
    """[(worker, module, rss MiB, peak MiB)] in the order written."""
    rows = []
    for line in pathlib.Path(path).read_text().splitlines():
        worker, module, rss, peak = line.split("\t")
        rows.append((worker, module, float(rss), float(peak)))
    return rows


def summarise(rows, top=8):
    by_worker = collections.defaultdict(list)
    for worker, module, rss, peak in rows:
        by_worker[worker].append((module, rss, peak))
    raises = []
    print("| worker | modules | peak (MiB) | reached in | resident after its last module (MiB) |")
    print("|---|---|---|---|---|")
    for worker, runs in sorted(by_worker.items()):
        peak_module, _, peak = max(runs, key=lambda r: r[2])
        print(f"| {worker} | {len(runs)} | {peak:.0f} | {peak_module} | {runs[-1][1]:.0f} |")
        before = 0.0
        for module, _, module_peak in runs:
            raises.append((module_peak - before, module, worker))
            before = max(before, module_peak)
    print(f"\nthe {top} modules that raised a worker's peak most (MiB):")
    for rise, module, worker in sorted(raises, reverse=True)[:top]:
        if rise > 0:
            print(f"  {module:40s} +{rise:6.0f}  ({worker})")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--log", help="a log written before (BRDF_TEST_MEMORY_LOG); default: run the suite")
    parser.add_argument("--top", type=int, default=8)
    args = parser.parse_args(argv)
    if args.log:
        summarise(read_log(args.log), args.top)
        return 0
    with tempfile.TemporaryDirectory() as folder:
        log = pathlib.Path(folder) / "memory.log"
        start = time.perf_counter()
        code = subprocess.call([sys.executable, "-m", "pytest", "-q", "-n", "2", "--dist", "loadfile"], cwd=ROOT,
                               env=dict(os.environ, BRDF_TEST_MEMORY_LOG=str(log)))
        print(f"\npytest exit {code}, {time.perf_counter() - start:.0f} s wall")
        summarise(read_log(log), args.top)
    return code


if __name__ == "__main__":
    sys.exit(main())
