"""The test suite's memory, per pytest worker: how much each holds and which modules raise it.

    python benchmarks/test_memory.py                 # runs the suite as `make test` does, logging
    python benchmarks/test_memory.py --log FILE      # summarises a log written before
    BRDF_TEST_MEMORY_LOG=FILE make test              # the log of a `make test` run

tests/conftest.py writes one line per test module when BRDF_TEST_MEMORY_LOG names a file:
the worker, the module, the resident set after the module (its memory given back) and the
worker's peak so far, in MiB.  Printed: each worker's peak and where it was reached, the
modules whose run raised a worker's peak the most, and the wall time of the run.

Running the suite, it also watches the processes (Linux /proc, twice a second): a worker's
own peak is not all it costs, for the tests start processes of their own (a notebook's
kernel, a command line, a batch's workers, Chromium).  Printed: each worker's peak with
everything it started, as proportional set size (PSS: shared pages divided among the
processes sharing them, so the sums add up), the processes it was made of, and the whole
suite's peak.
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


def _children():
    """{parent pid: [child pids]} of every process now."""
    children = collections.defaultdict(list)
    for entry in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{entry}/stat") as stat:
                parent = int(stat.read().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            continue
        children[parent].append(int(entry))
    return children


def _pss_mib(pid):
    """(PSS in MiB, the command line's start) of a process; (0, "") once it has gone."""
    try:
        with open(f"/proc/{pid}/smaps_rollup") as rollup:
            pss = next(int(line.split()[1]) for line in rollup if line.startswith("Pss:"))
        with open(f"/proc/{pid}/cmdline", "rb") as cmdline:
            command = cmdline.read().replace(b"\0", b" ").decode(errors="replace")[:90]
    except (OSError, StopIteration):
        return 0.0, ""
    return pss / 1024, command


def watch(process, every=0.5):
    """Sample the trees under ``process`` (pytest) until it ends: {worker pid: (peak PSS, its
    processes then)} and the suite's peak PSS (pytest, its workers and all they started)."""
    peaks, suite_peak = {}, 0.0
    while process.poll() is None:
        children = _children()
        suite = _pss_mib(process.pid)[0]
        for worker in children.get(process.pid, []):
            tree, stack = [], [worker]
            while stack:
                pid = stack.pop()
                tree.append((*_pss_mib(pid), pid))
                stack += children.get(pid, [])
            total = sum(pss for pss, _, _ in tree)
            suite += total
            if total > peaks.get(worker, (0.0,))[0]:
                peaks[worker] = (total, sorted(tree, reverse=True)[:4])
        suite_peak = max(suite_peak, suite)
        time.sleep(every)
    return peaks, suite_peak


def print_trees(peaks, suite_peak):
    print("\neach worker with the processes it started, at its peak (PSS, MiB):")
    for worker, (total, tree) in sorted(peaks.items()):
        print(f"  worker {worker}: {total:.0f}")
        for pss, command, pid in tree:
            print(f"    {pss:6.0f}  {pid}  {command}")
    print(f"the whole suite's peak (pytest, its workers and all they started): {suite_peak:.0f} MiB PSS")


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
        process = subprocess.Popen([sys.executable, "-m", "pytest", "-q", "-n", "2", "--dist", "loadfile"],
                                   cwd=ROOT, env=dict(os.environ, BRDF_TEST_MEMORY_LOG=str(log)))
        trees = watch(process)
        code = process.returncode
        print(f"\npytest exit {code}, {time.perf_counter() - start:.0f} s wall")
        summarise(read_log(log), args.top)
        print_trees(*trees)
    return code


if __name__ == "__main__":
    sys.exit(main())
