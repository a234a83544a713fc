"""What each ``brdf-fit`` command does, given its parsed arguments.

brdf_fit/cli.py parses the command line and maps exceptions to exit codes;
each function here returns an exit code and raises ValueError /
MeasuredDataError / OSError for bad input (never prints its own errors).
With ``args.json`` the command prints one JSON document on stdout and
nothing else there; progress and messages go to stderr through logging.
"""

import json
import logging
import pathlib
import sys

from .errors import (BAD_INPUT, OK, InputError, check_output_file, check_output_folder, fail, is_file_here,
                     printable, shorten_path, warn)
from fitting.ranking import IMAGE_TERM, IMAGE_WEIGHT, ranked, ranking_terms

log = logging.getLogger("brdf_fit")


def _format_value(value):
    if isinstance(value, list):
        return "(" + ", ".join(f"{v:.4g}" for v in value) + ")"
    return f"{value:.4g}"


def print_table(results, stream=None):
    """A short table: model, M1, image error, the exported glTF material's two
    errors, seconds, parameters (``*``: within 1 % of a bound)."""
    stream = stream or sys.stdout
    width = max([len(r.spec) for r in results] + [5])
    print(f"{'model':<{width}}  {'M1':>9}  {'image':>7}  {'glTF M1':>9}  {'glTF image':>10}  "
          f"{'seconds':>7}  parameters", file=stream)
    flagged = False
    for r in results:
        at_bound = r.at_bounds()
        flagged = flagged or bool(at_bound)
        params = "  ".join(f"{k}={_format_value(v)}{'*' if k in at_bound else ''}"
                           for k, v in r.parameters.items())
        seconds = (r.optimizer or {}).get("seconds_total", float("nan"))
        e = r.errors
        print(f"{r.spec:<{width}}  {e['m1']:9.5f}  {_cell(e.get('image'), 7, 4)}  "
              f"{_cell(e.get('exported_m1'), 9, 5)}  {_cell(e.get('exported_image'), 10, 4)}  "
              f"{seconds:7.2f}  {params}", file=stream)
    if flagged:
        print("* within 1 % of a bound of its range (of log x on a log scale): the data may want a value "
              "outside it", file=stream)


def print_best(results, stream=None):
    """The line naming the best of ``results`` (fitting.ranking.ranked order) with its ranking's
    terms: the M1 column alone may favour another model."""
    print(f"ranked by M1 + {IMAGE_WEIGHT:g} x {IMAGE_TERM} (docs/metrics.md); best: {results[0].spec} "
          f"({ranking_terms(results[0].errors)})", file=stream or sys.stdout)


def print_screened(screened, stream=None):
    """The models ``auto`` screened and did not refine, with their screening errors."""
    stream = stream or sys.stdout
    print(f"screened, not refined ({len(screened)} model(s): a screening ranking error above the margin x the "
          "best screened of its group, or not among the group's most refined, as each line says; the errors "
          "are the screening fit's, on a small sample; --keep-all fits them):", file=stream)
    width = max(len(s.model) for s in screened)
    for s in screened:
        e = s.errors
        print(f"  {s.model:<{width}}  M1 {e['m1']:.5f}  image {_cell(e.get('image'), 6, 4)}  "
              f"ranking {e['ranking_error']:.5f}  screened: {s.reason}", file=stream)


def _cell(value, width, digits):
    return f"{value:{width}.{digits}f}" if value is not None else f"{'-':>{width}}"


def print_json(document):
    """One JSON document on stdout (finite numbers only)."""
    print(json.dumps(document, indent=2, allow_nan=False))


def fit_options(args):
    return dict(loss=args.loss, optimizer="crs2" if args.global_search else args.optimizer,
                samples=args.samples, starts=args.starts, seed=args.seed,
                max_theta=args.max_theta, polish=args.polish, image_weight=args.image_weight)


def show_progress():
    """Progress bars only when the log level shows INFO (not with -q)."""
    return log.isEnabledFor(logging.INFO)


# What a first run costs compiling (an empty cache on a 2-core machine, docs/performance.md,
# "A first run": ggx+lambert 44 s against 23 s again; auto 188 s against 69 s again).
FIRST_RUN_ONE, FIRST_RUN_AUTO = "about a minute", "about 3 minutes (more on a busy machine)"


def announce(path, n_models, screened):
    """Before a fit's first second is over: what the command is about to do, and -- when no
    program of this version is stored yet -- that JAX compiles first, and about how long.
    On a terminal only, as the progress bar: a log or a script's stderr keeps one line per
    error or warning."""
    if not show_progress() or not sys.stderr.isatty():
        return
    from fitting.stored import folder, stored_count
    where = folder()
    what = (f"screening {n_models} models, then fitting the contenders" if screened
            else f"fitting {n_models} model{'s' if n_models > 1 else ''}")
    note = ""
    if stored_count() == 0:
        cost = FIRST_RUN_AUTO if screened or n_models > 4 else FIRST_RUN_ONE
        note = (f"; no compiled programs of this version yet "
                f"({shorten_path(where) if where else 'BRDF_JAX_CACHE=off'}): "
                f"JAX compiles them first, {cost} on 2 cores, and stores them for later runs")
    log.info(printable(f"{path}: {what}{note}"))


def models(args):
    from brdf.model import DIFFUSES, MODEL_EXAMPLES, NDFS, describe_tokens
    from brdf.own import registered
    from fitting.auto import model_sets
    if args.json:
        print_json({"examples": list(MODEL_EXAMPLES), "ndfs": list(NDFS) + ["gltf"],
                    "diffuse": [d for d in DIFFUSES if d != "none"],
                    **{name: list(models) for name, models in model_sets().items()},
                    "own": [m.model_string for m in registered()]})
        return OK
    print("model strings: NDF[+diffuse][+options], e.g.")
    for name in MODEL_EXAMPLES:
        print(f"  {name}")
    print(describe_tokens())
    for name, models in model_sets().items():
        print(f"{name}: " + ", ".join(models))
    print("a model of your own: PATH.py:NAME in a model list (brdf.own.OwnModel; docs/models.md)")
    for model in registered():          # --model-file PATH.py
        print(f"  {model.model_string}  ({model.source[0] if model.source else 'Python'}) {model.description}")
    return OK


def info(args):
    from data_loaders import load
    measured = load(args.file)
    if args.json:
        print_json(measured.summary_dict())
    else:
        print(measured.summary())
    return OK


def evaluate(args):
    """Measured file (its own lookup) or RESULT.json (the fitted model) at DIRECTIONS."""
    import io
    import numpy as np
    from data_loaders import load, read_directions
    from data_loaders.measured import write_file_atomic
    check_output_file(args.out, (".npy",), inputs=(args.file, args.directions), option="OUT")
    if str(args.file).lower().endswith(".json"):
        from brdf.own_guard import running
        from fitting.fit import evaluate_result
        from fitting.result import FitResult
        result = FitResult.load(args.file)
        wi, wo = read_directions(args.directions)
        with running(result.model.own, "its evaluation"):     # a model of one's own: its failure is one line
            rgb = evaluate_result(result, wi, wo)
    else:
        measured = load(args.file)
        wi, wo = read_directions(args.directions)
        rgb = measured.lookup(wi, wo)
    buf = io.BytesIO()
    np.save(buf, np.asarray(rgb, dtype=np.float64))
    write_file_atomic(args.out, buf.getvalue())
    log.info("wrote %s (%d x 3 RGB, 1/sr)", args.out, len(wi))
    return OK


def fit(args):
    from brdf.own import OwnModelError
    from data_loaders import load
    from brdf_fit.batch.folder import result_path
    from brdf_fit.progress import Progress
    from fitting.auto import expand_models, fitted_fully, uses_auto
    from fitting.file_names import describe_renaming, safe_stem
    from fitting.fit import CUT_MARGIN, ModelCut
    from fitting.fit_models import FIT_THREADS, fit_models
    from fitting.screen import ModelScreened
    models_ = expand_models(args.model)
    measured = load(args.file)
    out = check_output_folder(args.out)
    announce(args.file, len(models_), uses_auto(args.model) and not args.keep_all)
    stem = safe_stem(measured.material)      # the name comes from the file: it is data
    if stem != measured.material:
        warn("fit", describe_renaming(measured.material, stem))
    options = fit_options(args)
    log.debug("preparing %s: max_theta %g, %d samples", args.file, options["max_theta"], options["samples"])
    bar = Progress(len(models_), "models") if len(models_) > 1 and show_progress() else None
    results, paths, cuts, screened, failed = [], {}, [], [], []
    auto = uses_auto(args.model) and not args.keep_all
    for model, outcome in fit_models(measured, models_, cut=auto, screen="fit" if auto else None,
                                     unscreened=fitted_fully(args.model) if auto else (), threads=FIT_THREADS,
                                     **options):
        if isinstance(outcome, ModelScreened):
            screened.append(outcome)
            if bar:
                bar.step(f"{model} screened")
            continue
        if isinstance(outcome, ModelCut):
            cuts.append(outcome)
            if bar:
                bar.step(f"{model} cut")
            continue
        if isinstance(outcome, OwnModelError):     # a model of one's own: the other models go on
            failed.append((model, outcome))
            if bar:
                bar.step(f"{model} failed")
            continue
        if isinstance(outcome, Exception):
            raise outcome
        paths[model] = outcome.save(result_path(out, stem, model))
        results.append(outcome)
        if bar:
            bar.step(f"{model} M1 {outcome.errors['m1']:.4g}")
    results = ranked(results)
    if args.json:
        print_json({"material": measured.material, "file": str(args.file), "format": measured.format,
                    "results": [dict(r.to_dict(), path=str(paths[r.spec])) for r in results],
                    "cut": [{"model": c.model, "coarse_m1": c.coarse_m1, "best_ranking_error": c.bound}
                            for c in cuts],
                    "screened": [s.to_dict() for s in screened],
                    **({"failed": [{"model": m, "error": str(err)} for m, err in failed]} if failed else {})})
        return _own_failed(failed, len(results))
    print(printable(f"{measured.material} ({measured.format}, {args.file}): {len(results)} model(s), "
                    f"results in {args.out}/"))
    print_table(results)
    if screened:
        print_screened(screened)
    if len(results) > 1:
        print_best(results)
    if cuts:
        print(f"cut after the coarse stage, {len(cuts)} model(s) whose M1 there exceeded {CUT_MARGIN:g} x "
              f"the best ranking error so far (they cannot win; --keep-all fits them fully): "
              + ", ".join(f"{c.model} ({c.coarse_m1:.4g})" for c in cuts))
    return _own_failed(failed, len(results))


def _own_failed(failed, written):
    """OK, or (a model of one's own failed: the ``written`` results of the others are on disk)
    its one error line and BAD_INPUT (the first failure, and how many more)."""
    if not failed:
        return OK
    more = f" (and {len(failed) - 1} more model(s) failed)" if len(failed) > 1 else ""
    return fail("fit", f"{failed[0][1]}{more}" + ("; the other models' results are written" if written else ""))


def batch(args):
    from brdf_fit.batch.run import run_batch
    from fitting.auto import expand_models, fitted_fully, uses_auto
    from brdf_fit.batch.executors import DaskExecutor, LocalExecutor, default_jobs
    models_ = expand_models(args.models)
    check_output_folder(args.out)
    if args.send_data and not args.scheduler:
        raise ValueError("--send-data needs --scheduler (it says how inputs reach Dask workers)")
    executor = (DaskExecutor(args.scheduler, send_data=args.send_data) if args.scheduler
                else LocalExecutor(args.jobs or default_jobs(args.inputs)))
    rows = run_batch(args.inputs, models_, args.out, fit_options=fit_options(args), executor=executor,
                     log=log.warning, progress=show_progress(),
                     cut=uses_auto(args.models) and not args.keep_all, unscreened=fitted_fully(args.models),
                     refit_stale=args.refit_stale)
    failed = [r for r in rows if r["status"].startswith("error")]
    cut = [r for r in rows if r["status"].startswith("cut")]
    screened = [r for r in rows if r["status"].startswith("screened")]
    done = len(rows) - len(failed) - len(cut) - len(screened)
    summary = pathlib.Path(args.out) / "summary.csv"
    if args.json:
        print_json({"done": done, "cut": len(cut), "screened": len(screened), "failed": len(failed),
                    "summary": str(summary), "rows": rows})
    else:
        cut_note = f", {len(cut)} cut (cannot win; --keep-all fits them)" if cut else ""
        cut_note += f", {len(screened)} screened (not refined; --keep-all fits them)" if screened else ""
        print(f"{done} fit(s) done{cut_note}, {len(failed)} failed; summary in {summary}")
    return OK if rows and not failed else BAD_INPUT


def demo(args):
    check_output_folder(args.out)
    from .demo_run import run_demo
    return run_demo(args.folder, args.out, samples=args.samples)


def measured_from_provenance(result_path):
    """The measured file a result was fitted to, when it is here (else None, with a note)."""
    from fitting.result import FitResult
    file = (FitResult.load(result_path).provenance or {}).get("file")
    if file and is_file_here(file):
        log.info("measured: %s (from the result's provenance; --measured overrides)", file)
        return file
    log.info("measured: none (the result's provenance file %s is not here); rendering the fit alone",
             shorten_path(file) if file else "-")
    return None


def render(args):
    check_output_file(args.out, (".png",), inputs=(args.result, args.measured, args.env))
    from brdf_fit.render import render_main
    measured = args.measured or measured_from_provenance(args.result)
    return render_main(args.result, measured_path=measured, env_path=args.env,
                       out_path=args.out, size=args.size)


def view(args):
    from brdf_fit.render import view_main
    return view_main(args.result, measured_path=args.measured, env_path=args.env, size=args.size)


def report(args):
    check_output_folder(args.out)
    import shlex
    from brdf_fit.report.pages import report_main
    return report_main(args.results, args.out, measured_path=args.measured,
                       command_line="brdf-fit " + shlex.join(args.argv))


def export(args):
    from brdf_fit.export.formats import FORMATS, default_out, writer
    native = args.format != "gltf"          # openpbr, blender: OpenPBR's own models, written 1:1
    args.out = args.out or default_out(args.format)
    check_output_file(args.out, FORMATS[args.format], inputs=(args.result, args.measured))
    if not str(args.result).lower().endswith(".json"):
        return export_native_first(args) if native else export_first(args)
    if args.model:
        raise InputError("--model is for a measured file (export-first); a RESULT.json holds one model")
    write, describe = writer(args.format)
    info = write(args.result, args.out, measured=args.measured)
    if args.json:
        print_json(info)
    else:
        describe(info, sys.stdout)
    return OK


def export_first(args):
    """``export MEASURED_FILE``: fit --model (auto) and the glTF family, write the best exported
    material: what ``library`` ships for the same table (brdf_fit.export.export_first)."""
    if args.measured:
        raise InputError("--measured is for a RESULT.json input; a measured file is its own measurement")
    from data_loaders import load
    from brdf_fit.progress import Progress
    from fitting.auto import expand_models, fitted_fully, uses_auto
    from brdf_fit.export.gltf import describe_export, export_gltf
    from brdf_fit.export.export_first import candidates, describe_candidates, fit_for_export
    asked = args.model or "auto"
    models_ = expand_models(asked)
    measured = load(args.result)
    announce(args.result, len(models_), uses_auto(asked) and not args.keep_all)
    bar = Progress(len(candidates(models_, measured.isotropic)[0]), "models") if show_progress() else None
    screened = []
    results = fit_for_export(measured, models_, fit_options(args), progress=bar.step if bar else None,
                             screen=uses_auto(asked) and not args.keep_all, screened=screened,
                             unscreened=fitted_fully(asked))
    info = export_gltf(results[0], args.out, measured=measured, just_fitted=True)
    if args.json:
        print_json({"written": info, "candidates": [r.to_dict() for r in results],
                    "screened": [s.to_dict() for s in screened]})
        return OK
    print(f"{measured.material} ({measured.format}, {args.result}): {len(results)} model(s) fitted; "
          f"ranked by their exported material's M1 + {IMAGE_WEIGHT:g} x {IMAGE_TERM}")
    describe_candidates(results, sys.stdout)
    if screened:
        print_screened(screened)
    describe_export(info)
    return OK


def export_native_first(args):
    """``export MEASURED_FILE --format openpbr|blender``: fit OpenPBR's own models, write the best
    as an open_pbr_surface or a Principled BSDF, 1:1 (brdf_fit.export.openpbr_first)."""
    if args.measured:
        raise InputError("--measured is for a RESULT.json input; a measured file is its own measurement")
    from data_loaders import load
    from brdf_fit.progress import Progress
    from brdf_fit.export.formats import writer
    from brdf_fit.export.openpbr_first import fit_openpbr, openpbr_models
    models_, measured = openpbr_models(args.model, args.format), load(args.result)
    announce(args.result, len(models_), False)
    bar = Progress(len(models_), "models") if show_progress() else None
    results = fit_openpbr(measured, models_, fit_options(args), progress=bar.step if bar else None)
    write, describe = writer(args.format)
    info = write(results[0], args.out, measured=measured, candidates=results)
    if args.json:
        print_json({"written": info, "candidates": [r.to_dict() for r in results]})
        return OK
    print(f"{measured.material} ({measured.format}, {args.result}): {len(results)} OpenPBR model(s) fitted; "
          f"ranked by M1 + {IMAGE_WEIGHT:g} x {IMAGE_TERM}")
    print_table(results)
    describe(info, sys.stdout)
    return OK


def schema(args):
    from fitting.result_schema import result_schema
    print_json(result_schema())
    return OK
