"""Speed of the model family (issue 13): ``brdf-fit fit TABLE --model auto`` (24 models).

For one MERL-size table, twice -- with the family programs (fitting/family.py:
one compiled program per family root) and with one program per model
(``BRDF_FIT_FAMILY=off``: no shared programs, no warm starts, as before) -- prints:

- a fresh process (``python -m brdf_fit.cli fit TABLE --model auto``: imports,
  loading, compiling, 24 fits, writing) with an empty compilation cache, and
  again with the cache that run filled;
- the 24 fits warm, in one process that has fitted them once, as ``fit`` runs
  them (cut, ``FIT_THREADS`` fits at once) and one fit at a time;
- each model's M1 in the two runs, and the largest relative difference.

Beside them, the naive reference pass (benchmarks/fit_speed.py's): the
machine's speed drifts 2-3x within hours, so compare figures of one run.
``--loss`` is the command line's default (hybrid) unless given.

Table: the first NBRDF MERL-like table generated from ../shared into a
temporary folder (never into the repository), else a demo stand-in.

    python benchmarks/family_speed.py [--loss log|hybrid] [--table PATH]
    python benchmarks/family_speed.py --staged TABLE...        (warm auto beside --keep-all)
    python benchmarks/family_speed.py --fresh TABLE... [--runs N]   (fresh processes, empty / filled caches)
"""

import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
PYTHON = sys.executable
sys.path.insert(0, str(ROOT))
from fitting.fit_models import FIT_THREADS  # noqa: E402

TARGETS = {"empty cache": 30.0, "cache filled": 8.0, "warm": 3.0}    # issue 13, seconds
FRESH_TARGETS = {"empty": 30.0, "filled": 12.0}     # issue 26: staged auto in a fresh process, seconds

STAGED = """
import sys, time
import data_loaders
from fitting.auto import AUTO_FAMILY
from fitting.fit import image_targets, prepare
from fitting.fit_models import FIT_THREADS, fit_models
from fitting.screen import ModelScreened
for table in sys.argv[2:]:
    measured = data_loaders.load(table)
    data, image = prepare(measured), image_targets(measured)
    def auto(screen):
        return [o for _, o in fit_models(measured, list(AUTO_FAMILY), screen=screen, threads=FIT_THREADS,
                                         data=data, image=image, loss=sys.argv[1])]
    auto("fit"), auto(None)          # compiled
    t = time.perf_counter(); staged = auto("fit"); t_staged = time.perf_counter() - t
    t = time.perf_counter(); keep = auto(None); t_keep = time.perf_counter() - t
    rank = lambda o: o.errors["m1"] + 0.3 * o.errors.get("image", 0.0)
    best_s = min(rank(o) for o in staged if not isinstance(o, Exception))
    best_k = min(rank(o) for o in keep if not isinstance(o, Exception))
    refined = sum(not isinstance(o, Exception) for o in staged)
    print(measured.material, t_staged, t_keep, refined, best_s / best_k, flush=True)
"""

WARM = """
import json, sys, time
import data_loaders
from fitting.auto import AUTO_FAMILY
from fitting.fit import image_targets, prepare
from fitting.fit_models import fit_models
measured = data_loaders.load(sys.argv[1])
data, image = prepare(measured), image_targets(measured)
def auto(threads):
    for _ in fit_models(measured, list(AUTO_FAMILY), cut=True, threads=threads, data=data, image=image,
                        loss=sys.argv[2]):
        pass
auto(1)
for threads in (1, int(sys.argv[3])):
    t = time.perf_counter()
    auto(threads)
    print(time.perf_counter() - t)
"""


def fresh(table, loss, env, out):
    """Wall seconds of one ``fit --model auto`` process, and {model: M1}."""
    argv = [PYTHON, "-m", "brdf_fit.cli", "fit", str(table), "--model", "auto", "--loss", loss,
            "--out", str(out), "--json"]
    t = time.perf_counter()
    res = subprocess.run(argv, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t
    if res.returncode != 0:
        raise RuntimeError(f"exit {res.returncode}: {res.stderr.strip()}")
    return wall, {r["spec"]: r["errors"]["m1"] for r in json.loads(res.stdout)["results"]}


def warm(table, loss, env):
    """Seconds of ``--model auto``'s fits in a process that has run them once: one fit at a
    time, and FIT_THREADS at once (what ``fit`` does)."""
    res = subprocess.run([PYTHON, "-c", WARM, str(table), loss, str(FIT_THREADS)], cwd=ROOT, env=env,
                         capture_output=True, text=True, check=True)
    return [float(x) for x in res.stdout.split()[-2:]]


def table_path(folder):
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from fit_speed import make_tables
    return make_tables(folder, 1)[0]


def naive_reference(table):
    import jax
    import data_loaders
    from brdf.model import parse_model
    from fit_speed import naive_pass
    with jax.enable_x64(True):
        one, pairs = naive_pass(data_loaders.load(table), parse_model("ggx+lambert"))
    return f"naive reference: jit(value_and_grad) of M1, full set ({pairs:,} pairs), ggx+lambert: {one * 1e3:.1f} ms"


def staged(tables, loss):
    """Warm ``--model auto`` (screened, FIT_THREADS fits at once) beside ``--keep-all`` on each
    table, in one process that has run both once; the medians, with the naive reference."""
    import statistics
    res = subprocess.run([PYTHON, "-c", STAGED, loss, *map(str, tables)], cwd=ROOT, capture_output=True,
                         text=True, check=True)
    rows = [line.split() for line in res.stdout.splitlines() if len(line.split()) == 5]
    for name, t_staged, t_keep, refined, ratio in rows:
        print(f"  {name:26s} auto {float(t_staged):7.1f} s ({refined} refined)  --keep-all {float(t_keep):7.1f} s  "
              f"winner's ranking error {float(ratio):.4f} x --keep-all's")
    print(f"warm auto median over {len(rows)} tables: {statistics.median(float(r[1]) for r in rows):.1f} s "
          f"(target 8 s), --keep-all {statistics.median(float(r[2]) for r in rows):.1f} s")
    print(naive_reference(tables[0]))


def fresh_tables(tables, loss, runs):
    """``brdf-fit fit TABLE --model auto`` in fresh processes on each table: once with empty
    caches (compiled and traced programs), then ``runs`` times with the caches that run
    filled; the medians over the tables, with the naive reference before and after."""
    import statistics
    print(naive_reference(tables[0]), flush=True)
    empty, filled = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for table in tables:
            cache = pathlib.Path(tmp) / f"cache-{pathlib.Path(table).stem}"
            env = dict(os.environ, BRDF_JAX_CACHE=str(cache))
            empty.append(fresh(table, loss, env, pathlib.Path(tmp) / "out")[0])
            again = [fresh(table, loss, env, pathlib.Path(tmp) / "out")[0] for _ in range(runs)]
            filled.append(statistics.median(again))
            print(f"  {pathlib.Path(table).stem:26s} empty caches {empty[-1]:6.1f} s   filled "
                  + " ".join(f"{s:6.1f}" for s in again) + " s", flush=True)
    print(f"fresh auto over {len(tables)} tables, median: empty caches {statistics.median(empty):.1f} s "
          f"(target {FRESH_TARGETS['empty']:g}), filled {statistics.median(filled):.1f} s "
          f"(target {FRESH_TARGETS['filled']:g})")
    print(naive_reference(tables[0]))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--loss", default="hybrid")
    parser.add_argument("--table")
    parser.add_argument("--staged", nargs="+", metavar="TABLE",
                        help="only: warm auto (screened) beside --keep-all on these tables")
    parser.add_argument("--fresh", nargs="+", metavar="TABLE",
                        help="only: fresh auto processes on these tables, empty and filled caches")
    parser.add_argument("--runs", type=int, default=2, help="--fresh: runs with the caches filled")
    args = parser.parse_args()
    if args.staged:
        staged(args.staged, args.loss)
        return
    if args.fresh:
        fresh_tables(args.fresh, args.loss, args.runs)
        return
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        table = pathlib.Path(args.table) if args.table else table_path(tmp)
        print(f"table {table.name}, --model auto, --loss {args.loss}")
        print(naive_reference(table))
        m1 = {}
        for label, family in (("family programs", "on"), ("one program per model", "off")):
            env = dict(os.environ, BRDF_JAX_CACHE=str(tmp / f"cache-{family}"), BRDF_FIT_FAMILY=family)
            figures = {}
            for state in ("empty cache", "cache filled"):
                figures[state], m1[label] = fresh(table, args.loss, env, tmp / f"out-{family}")
            one_at_a_time, figures["warm"] = warm(table, args.loss, env)
            print(f"{label:22s} " + "  ".join(
                f"{state} {seconds:6.1f} s (target {TARGETS[state]:g})" for state, seconds in figures.items())
                + f"  (warm, one fit at a time: {one_at_a_time:.1f} s)")
            print("  " + naive_reference(table))
        ours, theirs = m1["family programs"], m1["one program per model"]
        both = [k for k in theirs if k in ours]       # a model cut in a run has no M1 there
        worst = max(ours[k] / theirs[k] - 1 for k in both)
        for model in both:
            print(f"  {model:36s} M1 {ours[model]:.6f}  own programs {theirs[model]:.6f}  "
                  f"{100 * (ours[model] / theirs[model] - 1):+.3f} %")
        cut = sorted(set(ours) ^ set(theirs))
        print(f"largest M1 increase: {100 * worst:+.3f} % (target: at most +0.5 %)"
              + (f"; cut in one run only: {', '.join(cut)}" if cut else ""))


if __name__ == "__main__":
    main()
