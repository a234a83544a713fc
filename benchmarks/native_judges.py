"""The OpenPBR and Blender materials as their renderers draw them, against the measured table and ABC (issue 61).

    python benchmarks/native_judges.py TABLE_OR_DIR... [--work DIR] [--json OUT] [--size 128] [--samples 16]

For each measured table (MERL .binary: /tmp/merl80 as ../shared/tools/merl_from_nbrdf.py writes them):

1. the sets ``openpbr`` (fitting.auto.OPENPBR_FAMILY: both bases, bare and coated, read as
   MaterialX draws them, +mx) and ``principled`` (PRINCIPLED_FAMILY: what a Principled BSDF draws)
   fitted as ``brdf-fit export TABLE --format openpbr`` / ``--format blender`` fit them
   (brdf_fit.export.openpbr_first.fit_openpbr; results kept in WORK/fits and reused);
2. the best of ``openpbr`` written as ``--format openpbr`` writes it (one open_pbr_surface, 1:1)
   and drawn by MaterialX's own generated GLSL (shaders/materialx_render.py);
3. the best of ``principled`` written as ``--format blender`` writes it (a Principled BSDF, GGX)
   and drawn by Cycles (benchmarks/engine_blender.py's scene, one Blender run for all);
4. ABC's published fit (Löw et al. 2012; benchmarks/abc_reference.py) beside them.

Judged on the engines issue's lit sphere and its second image error (benchmarks/engine_three.py:
``scene_pairs``, ``judge_error``), on that sphere's in-plane pixels (benchmarks/engine_blender.py's
``in_plane``: the row of normals in the plane of the light and the view, theta_i and theta_o up to
80 degrees; ``--curves DIR`` plots them, a PNG per table), and, for the fitted models themselves and
ABC, the toolkit's own image error and M1 (abc_reference.abc_errors; the fits' recorded errors).
Printed: a row per material, then per MERL category (brdf_fit.library.categories) the medians over
ABC's and how many are at or below ABC, then the in-plane errors.
"""

import argparse
import json
import pathlib
import statistics
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
for _path in (ROOT, ROOT / "benchmarks"):
    if str(_path) not in sys.path:
        sys.path.insert(0, str(_path))

from engine_three import ELEVATIONS, abc_images, judge_error, light_direction, measured_images, scene_pairs  # noqa: E402
from engine_three import measured_tables, spec_images  # noqa: E402

SIZE = 128
SAMPLES = 16            # Cycles samples per pixel (engine_blender.SAMPLES)


def fits_of(table, work):
    """The fits of the sets ``openpbr`` and ``principled`` of ``table`` (FitResults, best first),
    fitted once into WORK/fits."""
    from brdf_fit.export.openpbr_first import fit_openpbr
    from data_loaders import load
    from fitting.auto import OPENPBR_FAMILY, PRINCIPLED_FAMILY
    from fitting.ranking import ranked
    from fitting.result import FitResult
    folder = pathlib.Path(work) / "fits"
    folder.mkdir(parents=True, exist_ok=True)
    stem = pathlib.Path(table).stem
    paths = {m: folder / f"{stem}.{m}.json" for m in OPENPBR_FAMILY + PRINCIPLED_FAMILY}
    missing = [m for m, p in paths.items() if not p.exists()]
    if missing:
        for result in fit_openpbr(load(table), missing, {"loss": "hybrid"}):     # the command line's default loss
            result.save(paths[result.spec])
    return ranked([FitResult.load(p) for p in paths.values()])


def judge(tables, work, size=SIZE, samples=SAMPLES, curves=None):
    """A row per table (module docstring); ``curves``: a folder for the in-plane plots."""
    from abc_reference import abc_errors, abc_parameters
    from brdf_fit.export.blender_file import drawn_by_principled, export_blender
    from brdf_fit.export.openpbr_first import drawn_by_materialx, export_openpbr
    from data_loaders import load
    from engine_blender import blender_images, in_plane, pixels, plot_curves
    from fitting.image_error import ImageTargets
    from fitting.samples import prepare
    from shaders.materialx_render import materialx_radiance
    work = pathlib.Path(work)
    (work / "mtlx").mkdir(parents=True, exist_ok=True)
    (work / "blend").mkdir(parents=True, exist_ok=True)
    abc = abc_parameters()
    index, normals, wi, wo, cos_i = scene_pairs(size, ELEVATIONS)
    lights = [light_direction(e) for e in ELEVATIONS]
    plane = in_plane(size, normals, cos_i)
    rows, blends = [], {}
    for table in tables:
        stem = pathlib.Path(table).stem
        fits = fits_of(table, work)
        best = next(r for r in fits if drawn_by_materialx(r.spec))
        bare = next(r for r in fits if drawn_by_principled(r.spec))
        measured = load(table)
        meas, valid = measured_images(measured, wi, wo, cos_i)
        info = export_openpbr(best, work / "mtlx" / f"{stem}.mtlx", measured=measured)
        (name,) = info["materials"]
        drawn = np.where(cos_i[..., None] > 0.0, materialx_radiance(info["path"], name, normals, lights), 0.0)
        blends[stem] = work / "blend" / f"{stem}.blend"
        export_blender(bare, blends[stem])
        spec = spec_images(best.spec, best.parameters, wi, wo, cos_i)
        spec_bare = spec_images(bare.spec, bare.parameters, wi, wo, cos_i)
        drawn_images = {"measured": meas, "MaterialX": drawn, "Blender (spec)": spec_bare}
        row = {"material": measured.material, "table": str(table), "openpbr": best.spec, "blender": bare.spec,
               "spec": judge_error(meas, spec, valid),
               "materialx": judge_error(meas, drawn, valid),
               "spec_bare": judge_error(meas, spec_bare, valid),
               "in_plane": {"spec": judge_error(meas, spec, valid & plane),
                            "materialx": judge_error(meas, drawn, valid & plane),
                            "spec_bare": judge_error(meas, spec_bare, valid & plane),
                            "pixels": int((valid & plane).sum())},
               "m1": best.errors["m1"], "image": best.errors.get("image"),
               "m1_bare": bare.errors["m1"], "image_bare": bare.errors.get("image"),
               "valid": valid, "images": drawn_images}
        if measured.material in abc:
            p = abc[measured.material]
            drawn_images["ABC"] = abc_images(p, wi, wo, cos_i)
            row["abc"] = judge_error(meas, drawn_images["ABC"], valid)
            row["in_plane"]["abc"] = judge_error(meas, drawn_images["ABC"], valid & plane)
            full, _ = prepare(measured, samples=0)
            row["abc_m1"], row["abc_image"] = abc_errors(p, full, ImageTargets.from_measured(measured))[:2]
        rows.append(row)
        print(f"  {stem}: {best.spec} spec {row['spec']:.4f} MaterialX {row['materialx']:.4f}  "
              f"ABC {row.get('abc', float('nan')):.4f}", file=sys.stderr)
    images, _, _, _ = blender_images(blends, size, ELEVATIONS, work / "cycles", samples=samples, seeds=(0,),
                                     variants=("shipped",))
    for row in rows:
        stem = pathlib.Path(row["table"]).stem
        drawn_images, valid = row.pop("images"), row.pop("valid")
        drawn_images["Cycles"] = pixels(images[stem]["shipped"], index)
        row["cycles"] = judge_error(drawn_images["measured"], drawn_images["Cycles"], valid)
        row["in_plane"]["cycles"] = judge_error(drawn_images["measured"], drawn_images["Cycles"], valid & plane)
        if curves:
            plot_curves(pathlib.Path(curves) / f"{stem}.png", row["material"], normals, cos_i, valid & plane,
                        drawn_images, ELEVATIONS)
    return rows


def show(rows):
    """Per material, then per category: each judge's error and its ratio to ABC's."""
    from brdf_fit.library.categories import category
    print("| category | material | written (OpenPBR) | spec | MaterialX | ABC | written (Blender) | spec | Cycles | "
          "M1 / ABC | image / ABC |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in sorted(rows, key=lambda r: (category(r["material"]), r["material"])):
        abc = r.get("abc", float("nan"))
        print(f"| {category(r['material'])} | {r['material']} | {r['openpbr']} | {r['spec']:.4f} | "
              f"{r['materialx']:.4f} | {abc:.4f} | {r['blender']} | {r['spec_bare']:.4f} | {r['cycles']:.4f} | "
              f"{r['m1'] / r.get('abc_m1', float('nan')):.2f} | {r['image'] / r.get('abc_image', float('nan')):.2f} |")
    with_abc = [r for r in rows if "abc" in r]
    if not with_abc:
        return
    print("\n| category | n | MaterialX / ABC: median, at or below | Cycles / ABC: median, at or below | "
          "fit's M1 / ABC's: median | fit's image error / ABC's: median |")
    print("|---|---|---|---|---|---|")
    for c in sorted({category(r["material"]) for r in with_abc}) + ["all"]:
        rs = [r for r in with_abc if c in ("all", category(r["material"]))]
        cells = []
        for key in ("materialx", "cycles"):
            ratios = [r[key] / r["abc"] for r in rs]
            cells.append(f"{statistics.median(ratios):.2f}, {sum(x <= 1.0 for x in ratios)} of {len(rs)}")
        cells.append(f"{statistics.median(r['m1'] / r['abc_m1'] for r in rs):.2f}")
        cells.append(f"{statistics.median(r['image'] / r['abc_image'] for r in rs):.2f}")
        print(f"| {c} | {len(rs)} | " + " | ".join(cells) + " |")
    print("\nIn-plane (theta_i, theta_o up to 80 degrees), the same error on the in-plane pixels:\n")
    print("| material | MaterialX | Cycles | ABC | MaterialX / ABC | Cycles / ABC |")
    print("|---|---|---|---|---|---|")
    for r in sorted(with_abc, key=lambda r: (category(r["material"]), r["material"])):
        p = r["in_plane"]
        print(f"| {r['material']} | {p['materialx']:.4f} | {p['cycles']:.4f} | {p['abc']:.4f} | "
              f"{p['materialx'] / p['abc']:.2f} | {p['cycles'] / p['abc']:.2f} |")
    for key in ("materialx", "cycles"):
        ratios = [r["in_plane"][key] / r["in_plane"]["abc"] for r in with_abc]
        print(f"in-plane {key} / ABC: median {statistics.median(ratios):.2f}, at or below ABC on "
              f"{sum(x <= 1.0 for x in ratios)} of {len(ratios)}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("tables", nargs="+", help="measured tables or folders of .binary tables")
    parser.add_argument("--work", default="/tmp/native-judges", help="fits, documents, .blend files, renders")
    parser.add_argument("--json", help="write the rows here")
    parser.add_argument("--size", type=int, default=SIZE)
    parser.add_argument("--samples", type=int, default=SAMPLES)
    parser.add_argument("--curves", help="write the in-plane curves here (a PNG per table)")
    args = parser.parse_args(argv)
    rows = judge(measured_tables(args.tables, parser), args.work, args.size, args.samples, args.curves)
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps(rows, indent=1))
    show(rows)


if __name__ == "__main__":
    main()
