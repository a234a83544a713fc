"""``brdf-fit library DIR... --out LIB``: the command line of brdf_fit.library.build."""

import shlex

from brdf_fit.commands import fit_options, log, print_json, show_progress
from brdf_fit.errors import BAD_INPUT, OK, check_output_folder, printable

from .native import NATIVE_FILES


def library(args):
    from brdf_fit.batch.executors import DaskExecutor, LocalExecutor, default_jobs
    from .build import build_library
    out = check_output_folder(args.out)
    if args.send_data and not args.scheduler:
        raise ValueError("--send-data needs --scheduler (it says how inputs reach Dask workers)")
    jobs = args.jobs or default_jobs(args.inputs)
    executor = (DaskExecutor(args.scheduler, send_data=args.send_data) if args.scheduler
                else LocalExecutor(jobs))
    command_line = "brdf-fit " + shlex.join(args.argv)
    lib = build_library(args.inputs, out, args.models, jobs=jobs, executor=executor,
                        fit_options=fit_options(args), keep_all=args.keep_all, log=log.warning,
                        progress=show_progress(), command_line=command_line, refit_stale=args.refit_stale)
    summary = out / "results" / "summary.csv"
    failed, partly = _failed_inputs(summary, args.inputs)
    native = [out / name for name in NATIVE_FILES if (out / name).is_file()]     # --models ...,openpbr,principled
    if args.json:
        print_json({"library": str(out / "index.html"), "analysis": str(out / "analysis.html"),
                    "materials_glb": str(out / "materials.glb"), "native": [str(path) for path in native],
                    "materials": len(lib.entries), "failed": failed, "failed_fits": partly})
    else:
        print(printable(f"library of {len(lib.entries)} materials: {out / 'index.html'} "
                        f"(analysis: {out / 'analysis.html'}; all materials: {out / 'materials.glb'}"
                        + "".join(f", {path}" for path in native) + ")"
                        + (f"; {len(failed)} input(s) failed, see {summary}" if failed else "")
                        + (f"; {len(partly)} input(s) with a failed fit (their other models are in the "
                           f"library), see {summary}" if partly else "")))
    # as batch: any fit that failed is exit 2, the library written all the same
    return BAD_INPUT if failed or partly or not lib.entries else OK


def _failed_inputs(summary, inputs):
    """(the inputs whose rows in this library's summary.csv are all errors, those with some)."""
    import csv
    try:
        with open(summary, newline="", encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
    except OSError:
        return []
    status = {}
    for row in rows:
        status.setdefault(row.get("file", ""), []).append(row.get("status", ""))
    failed = sorted(f for f, s in status.items() if all(x.startswith("error") for x in s))
    partly = sorted(f for f, s in status.items() if f not in failed and any(x.startswith("error") for x in s))
    return failed, partly
