"""``brdf-fit demo``: the README's main command."""

import os
import pathlib
import sys

from brdf_fit.batch.executors import LocalExecutor
from brdf_fit.batch.folder import expand_inputs
from brdf_fit.batch.run import run_batch
from fitting.auto import DIFFUSE_FAMILY
from fitting.ranking import exported_ranking_error
from fitting.result import FitResult

from .demo import ABC_SOURCE, write_standins

# GGX with each diffuse model, and the glTF BRDF itself (what a viewer renders, exported 1:1)
DEMO_MODELS = tuple(f"ggx+{d}" for d in DIFFUSE_FAMILY) + ("gltf+specular",)


def run_demo(folder: str | os.PathLike[str] | None = None, out: str | os.PathLike[str] = "demo-output",
             samples: int = 100_000) -> int:
    """Fit GGX with each diffuse model and the glTF BRDF to the demo materials; print the
    comparison; render, export and report each material's best exported material; write
    the library of the materials (brdf_fit.library: gallery, analysis, materials.glb)."""
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
    for title, key in (("M1 (lower is better)", lambda e: e["m1"]),
                       ("image error (lower is better)", lambda e: e.get("image", float("nan"))),
                       ("M1 + 0.3 x image error of the exported glTF material", exported_ranking_error)):
        print(f"{title} per material and model:")
        print(f"{'material':<24}" + "".join(f"{m:>16}" for m in DEMO_MODELS))
        for mat in materials:
            cells = {m: key(r.errors) for (mm, m), r in results.items() if mm == mat}
            best = min(cells, key=cells.get)
            line = "".join(f"{cells[m]:>15.5f}{'*' if m == best else ' '}" if m in cells else f"{'-':>16}"
                           for m in DEMO_MODELS)
            print(f"{mat:<24}{line}")
        print("(* best model per material)")
    print(f"results: {out / 'results'}/ (one JSON per fit, summary.csv)")
    for mat in materials:
        here = {m: r for (mm, m), r in results.items() if mm == mat}
        best = min(here, key=lambda m: exported_ranking_error(here[m].errors))
        print(f"{mat}: exporting {best} (the best exported material)")
        _outputs(out, mat, best, str(here[best].provenance.get("file")))
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
