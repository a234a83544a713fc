"""The margin of ``auto``'s screening, chosen from measurement (issue 26).

For each table: the 24 models of ``--model auto`` fitted fully as ``--keep-all``
does (the true winner: the lowest ranking error), and every model screened
(fitting/screen.py) with each configuration given.  Printed per table and
configuration: the winner, the ratio of its screening ranking error to the
best screened one (the margin that keeps it among the refined: it must be
<= SCREEN_MARGIN), how many models each margin refines (with their parents),
the screening seconds (warm) and the refined models' own seconds in the
``--keep-all`` run beside the whole run's.  Beside them, the naive reference
pass (benchmarks/fit_speed.py): the machine's speed drifts, compare within a run.

Tables: paths given, else the ten NBRDF MERL-like tables generated from
../shared into a temporary folder.  ``--cache DIR`` keeps the ``--keep-all``
results per table (JSON), so other configurations can be replayed without
fitting them again.

    python benchmarks/screen_margin.py [TABLES...] [--cache DIR] [--configs 5000:32:30 ...]
        [--margins 1.1 1.2 1.3] [--loss hybrid] [--json OUT]
"""

import argparse
import json
import pathlib
import statistics
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import data_loaders  # noqa: E402
from brdf.model import parse_model  # noqa: E402
from fitting.auto import AUTO_FAMILY  # noqa: E402
from fitting.fit import image_targets, prepare  # noqa: E402
from fitting.fit_models import fit_models  # noqa: E402
from fitting.ranking import ranking_error  # noqa: E402
from fitting.screen import (SCREEN_EVALS, SCREEN_IMAGE, SCREEN_MARGIN, SCREEN_MOST, SCREEN_SAMPLES, SCREEN_TOL,  # noqa: E402
                            ScreenScene, contenders, screen_models)


def keep_all(measured, data, image, loss, cache):
    """{model: {"ranking", "m1", "seconds"}} of the 24 full fits (read from ``cache`` when there)."""
    path = cache / f"{measured.material}.{loss}.json" if cache else None
    if path and path.exists():
        return json.loads(path.read_text())
    out = {}
    for model, r in fit_models(measured, list(AUTO_FAMILY), data=data, image=image, loss=loss):
        if isinstance(r, Exception):
            raise r
        out[model] = {"ranking": ranking_error(r.errors), "m1": r.errors["m1"],
                      "seconds": r.optimizer["seconds_total"]}
    if path:
        path.write_text(json.dumps(out))
    return out


def replay(measured, data, image, full, config, margins, loss, caps=()):
    """Screen the family with ``config`` (samples, image side, evaluations); the figures of one table."""
    samples, side, evals, tol = config
    scene = ScreenScene.from_measured(measured, data[1], image, samples, side)
    models = list(AUTO_FAMILY)
    screen_models(models, scene, loss=loss, max_evals=evals, tol=tol)          # compiled
    t = time.perf_counter()
    screens = screen_models(models, scene, loss=loss, max_evals=evals, tol=tol)
    seconds = time.perf_counter() - t
    winner = min(full, key=lambda m: full[m]["ranking"])
    rank = {s.model: s.errors["ranking_error"] for s in screens}
    best = min(rank.values())
    order = sorted(rank, key=rank.get)
    row = {"winner": winner, "ratio": rank[winner] / best, "rank": order.index(winner) + 1, "screen_seconds": seconds,
           "keep_all_seconds": sum(f["seconds"] for f in full.values())}

    def figures(refined):       # what refining ``refined`` costs and gives (its best over the winner)
        chosen = min(refined, key=lambda m: full[m]["ranking"])
        return {"count": len(refined), "seconds": sum(full[m]["seconds"] for m in refined),
                "winner_ratio": full[chosen]["ranking"] / full[winner]["ranking"]}
    row["refined"] = {margin: figures(contenders(models, screens, margin, len(models)))   # the margin alone
                      for margin in margins}
    row["most"] = {most: figures(contenders(models, screens, SCREEN_MARGIN, most)) for most in caps}
    row["screens"] = {s.model: dict(s.errors, evaluations=s.evaluations) for s in screens}
    return row


def naive_reference(measured):
    import jax
    from fit_speed import naive_pass
    with jax.enable_x64(True):
        one, pairs = naive_pass(measured, parse_model("ggx+lambert"))
    return one


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("tables", nargs="*")
    parser.add_argument("--cache", type=pathlib.Path)
    parser.add_argument("--configs", nargs="+",
                        default=[f"{SCREEN_SAMPLES}:{SCREEN_IMAGE}:{SCREEN_EVALS}:{SCREEN_TOL:g}"],
                        help="screening configurations SAMPLES:IMAGE_SIDE:EVALUATIONS:TOLERANCE")
    parser.add_argument("--margins", nargs="+", type=float, default=[1.05, 1.1, 1.15, 1.2, 1.25, 1.3, 1.4, 1.5])
    parser.add_argument("--loss", default="hybrid")
    parser.add_argument("--most", nargs="+", type=int, default=[4, 5, 6, 8, 24],
                        help="caps on the contenders' count (SCREEN_MOST) replayed at SCREEN_MARGIN")
    parser.add_argument("--json", type=pathlib.Path, help="write every figure here")
    args = parser.parse_args()
    if args.cache:
        args.cache.mkdir(parents=True, exist_ok=True)
    configs = [tuple(int(x) for x in c.split(":")[:3]) + (float(c.split(":")[3]),) for c in args.configs]
    with tempfile.TemporaryDirectory() as tmp:
        if args.tables:
            tables = [pathlib.Path(t) for t in args.tables]
        else:
            from fit_speed import make_tables
            tables = make_tables(pathlib.Path(tmp), 10)
        rows = {c: {} for c in configs}
        for table in tables:
            measured = data_loaders.load(table)
            data, image = prepare(measured), image_targets(measured)
            full = keep_all(measured, data, image, args.loss, args.cache)
            for config in configs:
                rows[config][measured.material] = row = replay(measured, data, image, full, config,
                                                               args.margins, args.loss, args.most)
                print(f"{measured.material:26s} {config}: winner {row['winner']:30s} ratio {row['ratio']:.3f} "
                      f"rank {row['rank']:2d}  "
                      f"screen {row['screen_seconds']:5.1f} s  keep-all {row['keep_all_seconds']:6.1f} s  "
                      + "  ".join(f"{m:g}: {r['count']} ({r['seconds']:.1f} s)" for m, r in row["refined"].items()),
                      flush=True)
        reference = naive_reference(measured)
    print(f"\nnaive reference pass (ggx+lambert, full set, {measured.material}): {reference * 1e3:.1f} ms")
    for config, by_table in rows.items():
        ratios = [r["ratio"] for r in by_table.values()]
        print(f"\nconfig samples {config[0]}, image {config[1]}, evaluations {config[2]}, tolerance {config[3]:g}: "
              "the winner's screening "
              f"ratio, worst {max(ratios):.3f}, median {statistics.median(ratios):.3f}; "
              f"screening median {statistics.median(r['screen_seconds'] for r in by_table.values()):.1f} s")
        print(f"{'margin':>7} {'winner kept':>12} {'refined (median, max)':>22} {'refined s (median)':>19} "
              f"{'+ screening':>12} {'keep-all s (median)':>20}")
        for margin in args.margins:
            kept = sum(r["refined"][margin]["winner_ratio"] == 1.0 for r in by_table.values())
            counts = [r["refined"][margin]["count"] for r in by_table.values()]
            secs = [r["refined"][margin]["seconds"] for r in by_table.values()]
            total = [r["refined"][margin]["seconds"] + r["screen_seconds"] for r in by_table.values()]
            print(f"{margin:7.2f} {kept:>7d}/{len(by_table):<4d} {statistics.median(counts):>11g} {max(counts):>10d} "
                  f"{statistics.median(secs):19.1f} {statistics.median(total):12.1f} "
                  f"{statistics.median(r['keep_all_seconds'] for r in by_table.values()):20.1f}"
                  + ("   <- SCREEN_MARGIN" if margin == SCREEN_MARGIN else ""))
        print(f"\n{'most':>5} {'winner kept':>12} {'refined (total, max)':>21} {'refined s (total)':>18} "
              f"{'worst ranking / winner':>23}  (at margin {SCREEN_MARGIN:g})")
        for most in args.most:
            caps = [r["most"][most] for r in by_table.values()]
            kept = sum(c["winner_ratio"] == 1.0 for c in caps)
            print(f"{most:5d} {kept:>7d}/{len(by_table):<4d} {sum(c['count'] for c in caps):>12d} "
                  f"{max(c['count'] for c in caps):>8d} {sum(c['seconds'] for c in caps):18.1f} "
                  f"{max(c['winner_ratio'] for c in caps):23.4f}"
                  + ("   <- SCREEN_MOST" if most == SCREEN_MOST else ""))
    if args.json:
        args.json.write_text(json.dumps({":".join(f"{x:g}" for x in c): t for c, t in rows.items()}, indent=1))


if __name__ == "__main__":
    main()
