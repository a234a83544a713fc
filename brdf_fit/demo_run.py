"""``brdf-fit demo``: the README's main command."""

import os
import pathlib
import sys

from brdf_fit.batch.executors import LocalExecutor
from brdf_fit.batch.folder import expand_inputs
from brdf_fit.batch.memory import give_back_memory
from brdf_fit.batch.run import run_batch
from fitting.auto import DIFFUSE_FAMILY
from fitting.ranking import IMAGE_TERM, IMAGE_WEIGHT, exported_ranking_error, ranked, ranking_error, shipped_best
from fitting.result import FitResult

from .demo import ABC_SOURCE, write_standins

# GGX with each diffuse model, and the glTF BRDF itself (what a viewer renders, exported 1:1) as the
# portable material export-first ships by default, in the engines' reading (docs/gltf.md)
DEMO_MODELS = tuple(f"ggx+{d}" for d in DIFFUSE_FAMILY) + ("gltf+nonmetal+ior+turquin",)


def run_demo(folder: str | os.PathLike[str] | None = None, out: str | os.PathLike[str] = "demo-output",
             samples: int = 100_000) -> int:
    """Fit GGX with each diffuse model and the glTF BRDF to the demo materials; print the
    comparison; render, export and report each material's shipped material
    (fitting.ranking.shipped_best, as export and the library); write the library of the
    materials (brdf_fit.library: gallery, analysis, materials.glb)."""
    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    if folder is None:
        data_dir = out / "data"
        data_dir.mkdir(exist_ok=True)
        print(f"writing MERL-format stand-ins ({ABC_SOURCE}) to {data_dir}/")
        inputs = write_standins(data_dir)
    else:
        inputs = expand_inputs([folder])
        if not inputs:
            print(f"brdf-fit demo: error: no measured files in {folder}", file=sys.stderr)
            return 2
    total = len(inputs) * len(DEMO_MODELS)
    print(f"fitting {len(DEMO_MODELS)} models to {len(inputs)} materials ({total} fits; the first compiles, "
          "about a minute in all)", file=sys.stderr)
    done = []

    def show(row):
        done.append(row)
        m1 = f"M1 {float(row['m1']):.4f}, {float(row['seconds']):.1f} s" if row["m1"] else row["status"]
        print(f"[{len(done)}/{total}] {row['material'] or row['file']}: {row['model']} ({m1})", file=sys.stderr)

    rows = run_batch(inputs, DEMO_MODELS, out / "results", fit_options={"samples": samples, "loss": "hybrid"},
                     log=lambda m: print(m, file=sys.stderr), progress=False, executor=LocalExecutor(1, show))
    fitted = [r for r in rows if not r["status"].startswith("error")]
    materials = list(dict.fromkeys(r["material"] for r in fitted))
    print()
    results = {(r["material"], r["model"]): FitResult.load(out / "results" / r["result"]) for r in fitted}
    print_summary(results, materials)
    print(f"results: {out / 'results'}/ (one JSON per fit, summary.csv)")
    for mat in materials:
        here = {m: r for (mm, m), r in results.items() if mm == mat}
        best = shipped_best(list(here.values())).spec
        print(f"{mat}: exporting {best} (the material export and the library ship: fitting.ranking.shipped_best)")
        _outputs(out, mat, best, str(here[best].provenance.get("file")))
        give_back_memory()      # its table, render and export buffers (brdf_fit/batch/memory.py)
    from brdf_fit.library import write_library
    from brdf_fit.report.pages import report_main
    command_line = "brdf-fit demo" + (f" {folder}" if folder else "") + f" --out {out}"
    report_main([str(out / "results")], str(out / "report"), command_line=command_line)
    print(f"report with plots: {out / 'report' / 'index.html'}")
    write_library([out / "results"], out / "library", log=lambda m: None, command_line=command_line)
    print(f"library (gallery, models compared, all materials in one .glb): {out / 'library' / 'index.html'}")
    return 0 if fitted else 2


def _outputs(out, material, model, measured_file):
    """Preview image (measured | fitted | difference) and glTF of a material's best fit."""
    from brdf_fit.render import render_main
    from brdf_fit.export.gltf import export_main
    result_file = out / "results" / f"{material}.{model}.json"
    for sub in ("preview", "gltf"):
        (out / sub).mkdir(exist_ok=True)
    render_main(result_file, measured_path=measured_file, out_path=out / "preview" / f"{material}.png",
                size=384)
    export_main(result_file, out / "gltf" / f"{material}.glb", measured_path=measured_file)


def print_summary(results, materials, models=DEMO_MODELS, stream=None):
    """The demo's tables per material and model, ``results`` {(material, model): FitResult}:
    the ranking error (M1 + 0.3 x image error), M1 and the image error, each material's best
    (fitting.ranking.ranked: the report's and the library's best) starred in all three; then the
    exported glTF materials' ranking error, the one exported starred (fitting.ranking.shipped_best,
    what ``export`` and the library ship)."""
    stream = stream or sys.stdout
    best = {mat: ranked(r for (mm, _), r in results.items() if mm == mat)[0].spec for mat in materials}
    exported = {mat: shipped_best(r for (mm, _), r in results.items() if mm == mat).spec for mat in materials}
    for title, key, starred in (
            (f"M1 + {IMAGE_WEIGHT:g} x {IMAGE_TERM} (the ranking)", ranking_error, best),
            ("M1", lambda e: e["m1"], best), ("image error", lambda e: e.get("image", float("nan")), best),
            (f"M1 + {IMAGE_WEIGHT:g} x {IMAGE_TERM} of the exported glTF material", exported_ranking_error, exported)):
        print(f"{title} (lower is better) per material and model:", file=stream)
        print(f"{'material':<24}" + "".join(f"{m:>16}" for m in models), file=stream)
        for mat in materials:
            cells = {m: key(r.errors) for (mm, m), r in results.items() if mm == mat}
            line = "".join(f"{cells[m]:>15.5f}{'*' if m == starred[mat] else ' '}" if m in cells else f"{'-':>16}"
                           for m in models)
            print(f"{mat:<24}{line}", file=stream)
        print("(* the best model per material by the ranking: the report's and the library's best)" if starred is best
              else "(* the exported material: what export and the library ship)", file=stream)
