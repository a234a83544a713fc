"""Screening the native sets: which written materials it keeps, what it saves (issue 61, item 4).

``brdf-fit export --format openpbr|blender`` and ``brdf-fit library --models auto,openpbr,principled``
fit a native set (fitting.auto.OPENPBR_FAMILY, PRINCIPLED_FAMILY) to write its best fit 1:1.  This
replays, per table, what screening each set as a group of its own would change:

1. every model of both sets fitted in full as ``fit_openpbr`` fits them (WORK/fits/STEM.MODEL.json,
   benchmarks/native_judges.py's layout: its fits are read, missing ones fitted), each fit's
   errors and seconds;
2. each set screened (``fitting.screen.screen_models``, the fit's own ranking: the material is the
   fit), its screening ranking errors and seconds (WORK/screens/STEM.json, read back next time).

Then for each (margin, most) a set's contenders (``screen.contenders``) are the fits kept, and the
written material (the best kept by ``fitting.ranking``) is compared with the best of all: the tables
whose written material changes, its ranking error and image error over the full choice's, and the
fit seconds kept.  No model of a set starts from another (``fit.is_parent``), so a kept fit is the
fit the command would make.

    python benchmarks/native_screen.py TABLE_OR_DIR... --work DIR [--margins 1.1 1.25 1.5] [--most 1 2 3 4] [--each]
"""

import argparse
import json
import pathlib
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
for _path in (ROOT, ROOT / "benchmarks"):
    if str(_path) not in sys.path:
        sys.path.insert(0, str(_path))

from engine_three import measured_tables  # noqa: E402
from family_screen import print_replay  # noqa: E402
from native_judges import fits_of  # noqa: E402

SETS = ("openpbr", "principled")


def replay_table(path, work, each=False):
    """The table's record: {set: {"fits": {model: {errors, seconds}}, "screens": {model: {ranking_error,
    seconds}}, "screen_wall": s}}; ``each``: every start's M1 optimum refined with the image term
    (``screen.screen_model(each=True)``; kept in WORK/screens-each)."""
    out = pathlib.Path(work) / ("screens-each" if each else "screens") / f"{path.stem}.json"
    if out.exists():
        return json.loads(out.read_text())
    import data_loaders
    from fitting.auto import model_sets
    from fitting.fit import image_targets, prepare
    from fitting.fit_models import FIT_THREADS
    from fitting.screen import ScreenScene, screen_models
    fits = {r.spec: r for r in fits_of(path, work)}
    measured = data_loaders.load(path)
    data, image = prepare(measured), image_targets(measured)
    scene = ScreenScene.from_measured(measured, data[1], image)
    record = {}
    for name in SETS:
        models = list(model_sets()[name])
        t = time.perf_counter()
        screens = screen_models(models, scene, FIT_THREADS, rank="fit", loss="hybrid", each=each)
        record[name] = {"screen_wall": time.perf_counter() - t,
                        "fits": {m: {"errors": fits[m].errors, "seconds": fits[m].optimizer["seconds_total"]}
                                 for m in models},
                        "screens": {s.model: {"ranking_error": s.errors["ranking_error"], "seconds": s.seconds}
                                    for s in screens}}
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(record))
    return record


def replay(records, margin, most):
    """Per set: (lines naming the tables whose written material changes, ranking ratios, image ratios,
    fit seconds kept, fit seconds in all, screening seconds)."""
    from fitting.ranking import ranking_error
    from fitting.screen import Screen, contenders
    out = {}
    for name in SETS:
        changed, ranking, image, kept, total, screening = [], [], [], 0.0, 0.0, 0.0
        for table, record in records.items():
            r = record[name]
            models = list(r["fits"])
            screens = [Screen(m, {}, r["screens"][m], 0, r["screens"][m]["seconds"]) for m in models]
            keep = contenders(models, screens, margin, most)
            full = min(models, key=lambda m: (ranking_error(r["fits"][m]["errors"]), m))
            some = min(keep, key=lambda m: (ranking_error(r["fits"][m]["errors"]), m))
            ranking.append(ranking_error(r["fits"][some]["errors"]) / ranking_error(r["fits"][full]["errors"]))
            image.append(r["fits"][some]["errors"]["image"] / r["fits"][full]["errors"]["image"])
            if some != full:
                changed.append(f"{table} ({full} -> {some}: ranking {ranking[-1]:.3f}x, image {image[-1]:.3f}x)")
            kept += sum(r["fits"][m]["seconds"] for m in keep)
            total += sum(f["seconds"] for f in r["fits"].values())
            screening += r["screen_wall"]
        out[name] = (changed, ranking, image, kept, total, screening)
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("tables", nargs="+", help="measured tables or folders of .binary tables")
    parser.add_argument("--work", type=pathlib.Path, default=pathlib.Path("/tmp/native-judges"),
                        help="native_judges.py's work folder (its fits are read and added to)")
    parser.add_argument("--margins", type=float, nargs="+", default=[1.1, 1.25, 1.5])
    parser.add_argument("--most", type=int, nargs="+", default=[1, 2, 3, 4])
    parser.add_argument("--each", action="store_true",
                        help="screen with every start's M1 optimum refined with the image term (screen_model's each)")
    args = parser.parse_args(argv)
    records = {}
    for path in measured_tables(args.tables, parser):
        records[path.stem] = r = replay_table(path, args.work, args.each)
        print(f"{path.stem}: screened in " + ", ".join(f"{s} {r[s]['screen_wall']:.1f} s" for s in SETS),
              file=sys.stderr)
    print(f"{len(records)} tables")
    for margin in args.margins:
        for most in args.most:
            for name, (changed, ranking, image, kept, total, screening) in replay(records, margin, most).items():
                print_replay(f"margin {margin:g}, most {most}, {name}: written", len(records), changed, image,
                             ranking, kept, total, screening)
    return 0


if __name__ == "__main__":
    sys.exit(main())
