"""The ``brdf-fit`` command line.

Every command prints problems with the input as one line on stderr and exits
with code 2 (never a traceback); results are written atomically.
"""

import argparse
import pathlib
import sys

from brdf import __version__

OK, BAD_INPUT = 0, 2


def _fail(command, message):
    print(f"brdf-fit {command}: error: {message}", file=sys.stderr)
    return BAD_INPUT


def _format_value(value):
    if isinstance(value, list):
        return "(" + ", ".join(f"{v:.4g}" for v in value) + ")"
    return f"{value:.4g}"


def print_table(results, stream=None):
    """A short table: model, M1, loss, seconds, parameters."""
    stream = stream or sys.stdout
    width = max([len(r.spec) for r in results] + [5])
    print(f"{'model':<{width}}  {'M1':>9}  {'seconds':>7}  parameters", file=stream)
    for r in results:
        params = "  ".join(f"{k}={_format_value(v)}" for k, v in r.parameters.items())
        print(f"{r.spec:<{width}}  {r.errors['m1']:9.5f}  {r.optimizer['seconds_total']:7.2f}  {params}",
              file=stream)


def _fit_options(args):
    return dict(loss=args.loss, optimizer="crs2" if args.global_search else args.optimizer,
                samples=args.samples, starts=args.starts, seed=args.seed,
                max_theta=args.max_theta, polish=args.polish)


def _cmd_models(args):
    from brdf.model import MODEL_EXAMPLES, describe_tokens
    from .batch import AUTO_FAMILY
    print("model strings: NDF[+diffuse][+options], e.g.")
    for name in MODEL_EXAMPLES:
        print(f"  {name}")
    print(describe_tokens())
    print("auto: " + ", ".join(AUTO_FAMILY))
    return OK


def _cmd_info(args):
    from data_loaders.cli import info_main
    return info_main(args.file)


def _cmd_eval(args):
    if not str(args.file).lower().endswith(".json"):
        from data_loaders.cli import eval_main
        return eval_main(args.file, args.directions, args.out)
    import io
    import numpy as np
    from data_loaders.cli import read_directions
    from data_loaders.directions import as_directions
    from data_loaders.measured import write_file_atomic
    from .fit import evaluate_result
    from .result import FitResult, ResultFileError
    try:
        result = FitResult.load(args.file)
        wi, wo = (as_directions(w) for w in read_directions(args.directions))
    except (ResultFileError, ValueError) as err:
        return _fail("eval", err)
    buf = io.BytesIO()
    np.save(buf, evaluate_result(result, wi, wo))
    write_file_atomic(args.out, buf.getvalue())
    return OK


def _cmd_fit(args):
    from data_loaders import MeasuredDataError, load
    from .batch import expand_models, result_path
    from .fit import fit, prepare
    try:
        models = expand_models(args.model)
    except ValueError as err:
        return _fail("fit", err)
    try:
        measured = load(args.file)
    except MeasuredDataError as err:
        return _fail("fit", err)
    options = _fit_options(args)
    try:
        data = prepare(measured, options["max_theta"], options["samples"], options["seed"])
        results = []
        for model in models:
            result = fit(measured, model, data=data, **options)
            result.save(result_path(args.out, measured.material, model))
            results.append(result)
    except ValueError as err:
        return _fail("fit", err)
    results.sort(key=lambda r: r.errors["m1"])
    print(f"{measured.material} ({measured.format}, {args.file}): {len(results)} model(s), "
          f"results in {args.out}/")
    print_table(results)
    return OK


def _cmd_batch(args):
    from .batch import expand_models, run_batch
    try:
        models = expand_models(args.models)
    except ValueError as err:
        return _fail("batch", err)
    rows = run_batch(args.inputs, models, args.out, jobs=args.jobs, fit_options=_fit_options(args),
                     log=lambda m: print(m, file=sys.stderr))
    failed = [r for r in rows if r["status"].startswith("error")]
    done = len(rows) - len(failed)
    print(f"{done} fit(s) done, {len(failed)} failed; summary in {pathlib.Path(args.out) / 'summary.csv'}")
    return OK if rows and not failed else BAD_INPUT


def _cmd_demo(args):
    from .demo_run import run_demo
    return run_demo(args.folder, args.out, samples=args.samples)


def _cmd_render(args):
    from shaders.cli import render_main
    return render_main(args.result, measured_path=args.measured, env_path=args.env,
                       out_path=args.out, size=args.size)


def _cmd_view(args):
    from shaders.viewer import view_main
    return view_main(args.result, measured_path=args.measured, env_path=args.env, size=args.size)


def _cmd_report(args):
    import shlex
    from .report import report_main
    return report_main(args.results, args.out, measured_path=args.measured,
                       command_line="brdf-fit " + shlex.join(args.argv))


def _cmd_export(args):
    from .export import export_main
    return export_main(args.result, args.out, measured_path=args.measured)


def _add_fit_options(p):
    from .fit import OPTIMIZERS, DEFAULT_OPTIMIZER
    from .losses import LOSSES
    p.add_argument("--loss", choices=LOSSES, default="log", help="fit loss (default: log = M1)")
    p.add_argument("--optimizer", choices=OPTIMIZERS, default=DEFAULT_OPTIMIZER)
    p.add_argument("--global", dest="global_search", action="store_true",
                   help="global search (nlopt GN_CRS2_LM) instead of the local optimizer")
    p.add_argument("--samples", type=int, default=100_000,
                   help="stratified subsample the optimizer sees (0: all samples)")
    p.add_argument("--starts", type=int, default=3, help="number of starting points")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--max-theta", type=float, default=80.0, help="grazing cut-off in degrees")
    p.add_argument("--polish", action="store_true", help="finish with a full-set optimisation")


def build_parser():
    parser = argparse.ArgumentParser(
        prog="brdf-fit",
        description="Fit analytic BRDF models to measured reflectance data.")
    parser.add_argument("--version", action="version", version=f"brdf-fit {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("models", help="list the model strings")
    p.set_defaults(func=_cmd_models)

    p = sub.add_parser("info", help="summarise a measured BRDF file")
    p.add_argument("file")
    p.set_defaults(func=_cmd_info)

    p = sub.add_parser("eval", help="evaluate a measured file or a fit result at direction pairs")
    p.add_argument("file", help="measured BRDF file or RESULT.json")
    p.add_argument("directions", help=".npy float array N x 6: wi then wo, local frame")
    p.add_argument("out", help=".npy output, N x 3 RGB in 1/sr (float64)")
    p.set_defaults(func=_cmd_eval)

    p = sub.add_parser("fit", help="fit one or more models to a measured file")
    p.add_argument("file")
    p.add_argument("--model", default="ggx+lambert",
                   help="model string, comma-separated list, or 'auto' (default ggx+lambert)")
    p.add_argument("--out", default="results", help="output folder (default: results)")
    _add_fit_options(p)
    p.set_defaults(func=_cmd_fit)

    p = sub.add_parser("batch", help="fit models to many files (resumable)")
    p.add_argument("inputs", nargs="+", help="files or folders of measured data")
    p.add_argument("--models", default="ggx+lambert", help="comma-separated model strings or 'auto'")
    p.add_argument("--jobs", type=int, default=1, help="files fitted in parallel processes")
    p.add_argument("--out", default="results")
    _add_fit_options(p)
    p.set_defaults(func=_cmd_batch)

    p = sub.add_parser("render", help="render a fit result (measured | fitted | difference)")
    p.add_argument("result", help="RESULT.json")
    p.add_argument("--measured", help="the measured file, for the side-by-side comparison")
    p.add_argument("--env", help="environment map (.hdr); default: a generated studio sky")
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--out", default="render.png")
    p.set_defaults(func=_cmd_render)

    p = sub.add_parser("view", help="interactive window: orbit, key light, exposure (needs a display)")
    p.add_argument("result", help="RESULT.json")
    p.add_argument("--measured", help="the measured file, for the measured and comparison modes")
    p.add_argument("--env", help="environment map (.hdr); default: a generated studio sky")
    p.add_argument("--size", type=int, default=512)
    p.set_defaults(func=_cmd_view)

    p = sub.add_parser("report", help="HTML report (tables, plots, renders) of fit results")
    p.add_argument("results", nargs="+", help="RESULT.json files or folders of them")
    p.add_argument("--measured", help="the measured file (default: the results' provenance)")
    p.add_argument("--out", default="report")
    p.set_defaults(func=_cmd_report)

    p = sub.add_parser("export", help="export a fit result as a glTF material (.gltf or .glb)")
    p.add_argument("result", help="RESULT.json")
    p.add_argument("--measured", help="measured file to report the exported material's error against")
    p.add_argument("--out", default="material.gltf")
    p.set_defaults(func=_cmd_export)

    p = sub.add_parser("demo", help="fit the demo materials (no download needed)")
    p.add_argument("folder", nargs="?", help="folder of measured files (default: built-in ABC stand-ins)")
    p.add_argument("--out", default="demo-output")
    p.add_argument("--samples", type=int, default=100_000)
    p.set_defaults(func=_cmd_demo)
    return parser


def main(argv=None):
    parser = build_parser()
    args = parser.parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return OK
    try:
        return args.func(args)
    except KeyboardInterrupt:
        print("interrupted; finished results are on disk", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
