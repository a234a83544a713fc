"""Screening export-first's glTF family: which shipped materials it keeps, what it saves (issue 52, item 5).

``export`` and ``library`` fit the glTF family (brdf_fit/export/export_first.py)
beside ``auto``'s screened models.  This replays, per table, what screening the
family would change:

1. ``fit_for_export`` as the commands run it (``auto`` screened, its contenders
   fitted; the four models of the glTF family fitted in full), every fit's own
   and exported errors and seconds kept (``--cache DIR``: one JSON per table,
   read back on the next run);
2. the family screened (``fitting.screen.screen_models``, ranked by the exported
   material, in the scene ``auto``'s screening uses), its screening ranking errors
   and seconds.

Then for each (margin, most) the family's contenders (``screen.contenders``:
within margin x the family's best screened, at most ``most``) are the family's fits
kept, the shipped material chosen among them and ``auto``'s fits
(``fitting.ranking.shipped_best``) and compared with the one chosen among them all:
the tables whose shipped material changes, its exported image error and ranking
error over the full choice's (worst and median), and the family's fit seconds kept.
A family member's fit does not depend on the others' (none is another's parent),
so a kept fit is the fit the command would make.

    python benchmarks/family_screen.py TABLES... --cache DIR [--margins 1.1 1.25 1.5] [--most 1 2 3 4]
"""

import argparse
import json
import pathlib
import statistics
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import data_loaders  # noqa: E402
from brdf_fit.export.export_first import family_for, fit_for_export, is_export_first  # noqa: E402
from fitting.fit import image_targets, prepare  # noqa: E402
from fitting.fit_models import FIT_THREADS  # noqa: E402
from fitting.ranking import exported_ranking_error, shipped_best  # noqa: E402
from fitting.result import FitResult  # noqa: E402
from fitting.screen import Screen, ScreenScene, contenders, screen_models  # noqa: E402


def replay_table(path, cache):
    """The table's record: every fit (spec, errors, seconds, family or not) and the family's screens."""
    out = cache / f"{path.stem}.json"
    if out.exists():
        return json.loads(out.read_text())
    measured = data_loaders.load(path)
    options = {"loss": "hybrid", "data": prepare(measured), "image": image_targets(measured)}
    t = time.perf_counter()
    results = fit_for_export(measured, None, dict(options), screen=True)
    wall = time.perf_counter() - t
    family = family_for(measured.isotropic)
    scene = ScreenScene.from_measured(measured, options["data"][1], options["image"])
    t = time.perf_counter()
    screens = screen_models(family, scene, FIT_THREADS, rank="export", loss="hybrid")
    record = {"wall": wall, "screen_wall": time.perf_counter() - t,
              "fits": [{"spec": r.spec, "family": is_export_first(r), "errors": r.errors,
                        "seconds": r.optimizer["seconds_total"]} for r in results],
              "screens": {s.model: {"ranking_error": s.errors["ranking_error"], "seconds": s.seconds}
                          for s in screens},
              "family": family}
    out.write_text(json.dumps(record))
    return record


def stand_in(fit):
    """A FitResult-like object shipped_best reads (its errors)."""
    return FitResult(spec=fit["spec"], parameters={}, errors=fit["errors"], optimizer={}, provenance={})


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("tables", nargs="+", type=pathlib.Path)
    parser.add_argument("--cache", type=pathlib.Path, required=True)
    parser.add_argument("--margins", type=float, nargs="+", default=[1.1, 1.25, 1.5])
    parser.add_argument("--most", type=int, nargs="+", default=[1, 2, 3, 4])
    args = parser.parse_args(argv)
    args.cache.mkdir(parents=True, exist_ok=True)
    records = {}
    for path in args.tables:
        records[path.stem] = r = replay_table(path, args.cache)
        print(f"{path.stem}: {r['wall']:.1f} s, family screened in {r['screen_wall']:.2f} s", file=sys.stderr)
    print(f"{len(records)} tables")
    for margin in args.margins:
        for most in args.most:
            changed, image, ranking, kept, total, screening = [], [], [], 0.0, 0.0, 0.0
            for name, r in records.items():
                fits = {f["spec"]: f for f in r["fits"]}
                family = [m for m in r["family"] if m in fits]
                screens = [Screen(m, {}, r["screens"][m], 0, r["screens"][m]["seconds"]) for m in family]
                keep = set(contenders(family, screens, margin, most))
                full = shipped_best([stand_in(f) for f in r["fits"]])
                some = shipped_best([stand_in(f) for f in r["fits"] if not f["family"] or f["spec"] in keep])
                image.append(some.errors["exported_image"] / full.errors["exported_image"])
                ranking.append(exported_ranking_error(some.errors) / exported_ranking_error(full.errors))
                if some.spec != full.spec:
                    changed.append(f"{name} ({full.spec} -> {some.spec}: image {image[-1]:.3f}x, "
                                   f"ranking {ranking[-1]:.3f}x)")
                kept += sum(fits[m]["seconds"] for m in keep)
                total += sum(fits[m]["seconds"] for m in family)
                screening += sum(s["seconds"] for s in r["screens"].values())
            print_replay(f"margin {margin:g}, most {most}: shipped", len(records), changed, image, ranking, kept,
                         total, screening)
    return 0


def print_replay(head, tables, changed, image, ranking, kept, total, screening):
    """One (margin, most)'s line of a screening replay (this one's, benchmarks/native_screen.py's):
    how many of ``tables`` change, the image and ranking ratios, the fit seconds kept, then the
    lines ``changed`` names."""
    print(f"{head} changes on {len(changed)} of {tables}; image x{max(image):.4f} worst, "
          f"x{statistics.median(image):.4f} median; ranking x{max(ranking):.4f} worst; fit seconds kept "
          f"{kept:.0f} of {total:.0f} (+{screening:.0f} screening)")
    for line in changed:
        print("   ", line)


if __name__ == "__main__":
    sys.exit(main())
