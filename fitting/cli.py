"""The ``brdf-fit`` command line.

Every command prints problems with the input as one line on stderr and exits
with code 2 (never a traceback); results are written atomically.
"""

import argparse
import math
import os
import pathlib
import sys

from .errors import (BAD_INPUT, FAILED, INTERRUPTED, OK, InputError, check_output_file,
                     check_output_folder, fail, os_error_message, warn)
from .interrupt import exit_on_signal


def _package_version():
    """``brdf.__version__`` without importing brdf (which imports JAX): read from
    brdf/__init__.py, else the installed distribution's version."""
    import re
    source = pathlib.Path(__file__).resolve().parent.parent / "brdf" / "__init__.py"
    try:
        found = re.search(r"^__version__ = [\"']([^\"']+)[\"']", source.read_text(), re.M)
    except OSError:
        found = None
    if found:
        return found.group(1)
    try:
        from importlib.metadata import version
        return version("brdf-fit")
    except Exception:  # noqa: BLE001 -- neither: say so rather than fail
        return "unknown"


__version__ = _package_version()


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
    check_output_file(args.out, (".npy",), inputs=(args.file, args.directions))
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
        return fail("eval", err)
    buf = io.BytesIO()
    np.save(buf, evaluate_result(result, wi, wo))
    write_file_atomic(args.out, buf.getvalue())
    return OK


def _cmd_fit(args):
    from data_loaders import load
    from .batch import expand_models, result_path
    from .fit import fit, prepare
    models = expand_models(args.model)
    measured = load(args.file)
    out = check_output_folder(args.out)
    options = _fit_options(args)
    data = prepare(measured, options["max_theta"], options["samples"], options["seed"])
    results = []
    for model in _progress(models, "models", len(models) > 1):
        result = fit(measured, model, data=data, **options)
        result.save(result_path(out, measured.material, model))
        results.append(result)
    results.sort(key=lambda r: r.errors["m1"])
    print(f"{measured.material} ({measured.format}, {args.file}): {len(results)} model(s), "
          f"results in {args.out}/")
    print_table(results)
    return OK


def _progress(items, label, show):
    """Iterate ``items``, drawing batch.Progress on stderr when ``show``."""
    from .batch import Progress
    bar = Progress(len(items), label) if show else None
    for item in items:
        yield item
        if bar:
            bar.step(str(item))


def _cmd_batch(args):
    from .batch import expand_models, run_batch
    models = expand_models(args.models)
    check_output_folder(args.out)
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
    check_output_file(args.out, (".png",), inputs=(args.result, args.measured, args.env))
    from shaders.cli import render_main
    return render_main(args.result, measured_path=args.measured, env_path=args.env,
                       out_path=args.out, size=args.size)


def _cmd_view(args):
    from shaders.viewer import view_main
    return view_main(args.result, measured_path=args.measured, env_path=args.env, size=args.size)


def _cmd_report(args):
    check_output_folder(args.out)
    import shlex
    from .report import report_main
    return report_main(args.results, args.out, measured_path=args.measured,
                       command_line="brdf-fit " + shlex.join(args.argv))


def _cmd_export(args):
    check_output_file(args.out, (".gltf", ".glb"), inputs=(args.result, args.measured))
    from .export import export_main
    return export_main(args.result, args.out, measured_path=args.measured)


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors: ``brdf-fit COMMAND: error: ...``, exit 2."""

    def error(self, message):
        command = self.prog.split()[-1] if " " in self.prog else "brdf-fit"
        prefix = "" if command == "brdf-fit" else f" {command}"
        print(f"brdf-fit{prefix}: error: {message} (see --help)", file=sys.stderr)
        raise SystemExit(BAD_INPUT)


def _number(kind, low=None, high=None, low_open=False):
    """An argparse type: ``kind`` (int or float), finite, within [low, high] (or (low, high])."""
    def parse(text):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {'an integer' if kind is int else 'a number'}")
        bad = (not math.isfinite(value) or (low is not None and (value <= low if low_open else value < low))
               or (high is not None and value > high))
        if bad:
            where = (f"{'above' if low_open else 'at least'} {low:g}" if high is None else
                     f"in {'(' if low_open else '['}{low:g}, {high:g}]")
            raise argparse.ArgumentTypeError(f"must be {where}, got {text}")
        return value
    parse.__name__ = kind.__name__
    return parse


def _add_fit_options(p):
    from .fit import OPTIMIZERS, DEFAULT_OPTIMIZER
    from .losses import LOSSES
    p.add_argument("--loss", choices=LOSSES, default="log", help="fit loss (default: log = M1)")
    p.add_argument("--optimizer", choices=OPTIMIZERS, default=DEFAULT_OPTIMIZER)
    p.add_argument("--global", dest="global_search", action="store_true",
                   help="global search (nlopt GN_CRS2_LM) instead of the local optimizer")
    p.add_argument("--samples", type=_number(int, 0), default=100_000,
                   help="stratified subsample the optimizer sees (0: all samples)")
    p.add_argument("--starts", type=_number(int, 1, 64), default=3, help="number of starting points")
    p.add_argument("--seed", type=_number(int, 0), default=0)
    p.add_argument("--max-theta", type=_number(float, 0.0, 90.0, low_open=True), default=80.0,
                   help="grazing cut-off in degrees, in (0, 90]")
    p.add_argument("--polish", action="store_true", help="finish with a full-set optimisation")


def build_parser():
    parser = _Parser(
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
    p.add_argument("--jobs", type=_number(int, 1, 256), default=1, help="files fitted in parallel processes")
    p.add_argument("--out", default="results")
    _add_fit_options(p)
    p.set_defaults(func=_cmd_batch)

    p = sub.add_parser("render", help="render a fit result (measured | fitted | difference)")
    p.add_argument("result", help="RESULT.json")
    p.add_argument("--measured", help="the measured file, for the side-by-side comparison")
    p.add_argument("--env", help="environment map (.hdr); default: a generated studio sky")
    p.add_argument("--size", type=_number(int, 64, 4096), default=512, help="image size in pixels")
    p.add_argument("--out", default="render.png")
    p.set_defaults(func=_cmd_render)

    p = sub.add_parser("view", help="interactive window: orbit, key light, exposure (needs a display)")
    p.add_argument("result", help="RESULT.json")
    p.add_argument("--measured", help="the measured file, for the measured and comparison modes")
    p.add_argument("--env", help="environment map (.hdr); default: a generated studio sky")
    p.add_argument("--size", type=_number(int, 64, 4096), default=512, help="image size in pixels")
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
    p.add_argument("--samples", type=_number(int, 0), default=100_000)
    p.set_defaults(func=_cmd_demo)
    return parser


def run_command(args):
    """Run a parsed command; the one place where exceptions become exit codes.

    Bad input or options (the loaders', the result validator's and the
    commands' own errors, all ValueError or MeasuredDataError) and unwritable
    outputs (OSError) print one line and give BAD_INPUT; anything else is a
    bug: one line and FAILED (``BRDF_DEBUG=1`` shows the traceback).
    Warnings from the toolkit are printed as one line each.
    """
    import warnings
    from data_loaders import MeasuredDataError
    command = args.command
    shown = warnings.showwarning

    def one_line_warning(message, category, filename, lineno, file=None, line=None):
        if category.__module__.split(".")[0] in ("brdf", "data_loaders", "fitting", "shaders"):
            warn(command, message)
        else:
            shown(message, category, filename, lineno, file, line)

    warnings.showwarning = one_line_warning
    try:
        return args.func(args)
    except (ValueError, MeasuredDataError) as err:
        return fail(command, err)
    except OSError as err:
        return fail(command, os_error_message(err))
    except MemoryError:
        return fail(command, "out of memory")
    except Exception as err:  # noqa: BLE001 -- a bug: say so in one line, not a traceback
        if os.environ.get("BRDF_DEBUG"):
            raise
        return fail(command, f"internal error ({type(err).__name__}: {err}); "
                             "BRDF_DEBUG=1 shows the traceback", FAILED)
    finally:
        warnings.showwarning = shown


def main(argv=None):
    argv = list(sys.argv[1:] if argv is None else argv)
    # Ctrl-C / SIGTERM: one line and exit 130 / 143 within a fraction of a second, in
    # any phase (imports, loading, XLA compiling, nlopt, writing): see fitting.interrupt.
    # Installed first, before build_parser imports JAX.
    first = next((a for a in argv if not a.startswith("-")), "")
    with exit_on_signal("brdf-fit " + first if first.isalpha() and len(first) < 20 else "brdf-fit") \
            as on_signal:
        parser = build_parser()
        args = parser.parse_args(argv)
        args.argv = argv
        if not getattr(args, "func", None):
            parser.print_help()
            return OK
        on_signal.prog = f"brdf-fit {args.command}"
        try:
            return run_command(args)
        except KeyboardInterrupt:       # only if the handler could not be installed
            print(f"brdf-fit {args.command}: interrupted; finished results are on disk",
                  file=sys.stderr)
            return INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
