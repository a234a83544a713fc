"""The ``brdf-fit`` command line.

Every command prints problems with the input as one line on stderr and exits
with code 2 (never a traceback); results are written atomically.
"""

import argparse
import math
import os
import pathlib
import sys

from .errors import (BAD_INPUT, CWD_GONE, FAILED, INTERRUPTED, cwd_gone, fail, os_error_message, warn)
from . import commands
from .interrupt import exit_on_signal, leave
from .streams import end_quietly, output_closed, prepare_streams
from fitting.screen import SCREEN_MOST


JOBS_HELP = ("files fitted in parallel processes (default: one per CPU, at most one per 4 files and as many "
             "as the memory holds; 1 fits in this process, two fits at once)")


def _package_version():
    """``brdf.__version__`` without importing brdf (numpy, jaxtyping, the models): read from
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
            raise argparse.ArgumentTypeError(
                f"{text!r} is not {'an integer' if kind is int else 'a number'}") from None
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
    from fitting.choices import DEFAULT_OPTIMIZER, HYBRID, LOSSES, OPTIMIZERS
    from fitting.ranking import HYBRID_WEIGHT
    g = p.add_argument_group("fit options")
    g.add_argument("--loss", choices=LOSSES, default=HYBRID,
                   help="what the optimizer minimises: log = M1, the cosine-weighted log error "
                        "(docs/metrics.md); hybrid = M1 + image weight x the image error (a lit "
                        "sphere as a viewer sees it); ngan, relative, cuberoot: other published losses")
    g.add_argument("--image-weight", type=_number(float, 0.0), default=HYBRID_WEIGHT,
                   help="hybrid loss only: the weight of the image error beside M1 (a fit gives "
                        "up at most 15%% of M1 for the picture, at any weight)")
    g.add_argument("--optimizer", choices=OPTIMIZERS, default=DEFAULT_OPTIMIZER,
                   help="nlopt's lbfgs (local, fastest to the same minimum), bobyqa (local, "
                        "derivative-free), crs2 / mlsl (global), or optimistix's optx_bfgs / "
                        "optx_dogleg / optx_lm")
    g.add_argument("--global", dest="global_search", action="store_true",
                   help="global search (nlopt GN_CRS2_LM over the whole parameter box, slower) "
                        "instead of the multi-start local optimizer; same as --optimizer crs2")
    g.add_argument("--samples", type=_number(int, 0), default=100_000,
                   help="size of the stratified subsample the optimizer sees (0: all samples); "
                        "errors are always reported on the full set")
    g.add_argument("--starts", type=_number(int, 1, 64), default=3,
                   help="number of starting points refined after the roughness scan")
    g.add_argument("--seed", type=_number(int, 0), default=0,
                   help="seed of the subsample (fits are deterministic for a seed)")
    g.add_argument("--max-theta", type=_number(float, 0.0, 90.0, low_open=True), default=80.0,
                   help="grazing cut-off: samples with theta_i or theta_o above it (degrees) are left out")
    g.add_argument("--polish", action="store_true",
                   help="finish with an optimisation on the full set (slower, rarely better)")


def _add_refit_stale(p):
    p.add_argument("--refit-stale", action="store_true",
                   help="fit again the results in --out that another version of brdf-fit made "
                        "(default: keep them, and say how many)")


def _add_keep_all(p):
    p.add_argument("--keep-all", action="store_true",
                   help="with 'auto': fit every model fully; by default every model is screened (a "
                        "cheap fit on a small sample) and only those within a margin of the best "
                        f"screened, at most {SCREEN_MOST}, are fitted fully: the others are shown as "
                        "screened (no result)")


def _common(json_output=False):
    """Options every command takes: -q / -v (and --json where there is a document to print)."""
    common = argparse.ArgumentParser(add_help=False)
    g = common.add_argument_group("output")
    g.add_argument("-q", "--quiet", action="store_true", help="only errors and warnings on stderr")
    g.add_argument("-v", "--verbose", action="store_true", help="more detail on stderr (timings, stages)")
    if json_output:
        g.add_argument("--json", action="store_true",
                       help="print one JSON document on stdout instead of text")
    common.add_argument("--model-file", action="append", metavar="PATH.py",
                        help="a file declaring models of your own (brdf.own.OwnModel), imported because "
                             "you name it: its models are own:NAME; needed to read results of them "
                             "(a model list may also name PATH.py:VARIABLE; docs/models.md)")
    return common


class _Help(argparse.HelpFormatter):
    """Help with every option's default shown (flags, off by default, without one)."""

    def _get_help_string(self, action):
        text = action.help or ""
        shown = action.default is not None and action.default is not False and action.default != argparse.SUPPRESS
        if shown and "%(default)" not in text and action.option_strings:
            text += " (default: %(default)s)"
        return text


def build_parser():
    parser = _Parser(
        prog="brdf-fit", formatter_class=_Help,
        description="Fit analytic BRDF models to measured reflectance data, render them, export glTF.",
        epilog="Exit codes: 0 done, 1 internal error, 2 bad input or options, 3 no OpenGL / display, "
               "130 interrupted (Ctrl-C), 141 the reader of the output went away (`| head`; no message), "
               "143 terminated (SIGTERM); finished results stay on disk. A closed stdout (>&-) "
               "is taken as >/dev/null. "
               "`brdf-fit COMMAND --help` describes each command.")
    parser.add_argument("--version", action="version", version=f"brdf-fit {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    def command(name, func, help, json_output=False):
        p = sub.add_parser(name, help=help, description=help, formatter_class=_Help,
                           parents=[_common(json_output)])
        p.set_defaults(func=func, json=False)
        return p

    command("models", commands.models, "list the model strings", json_output=True)

    p = command("info", commands.info, "summarise a measured BRDF file: format, samples, value ranges",
                json_output=True)
    p.add_argument("file", help="measured file: MERL .binary, UTIA .bin, RGL .bsdf, .csv / .npz samples")

    p = command("eval", commands.evaluate, "evaluate a measured file or a fit result at direction pairs")
    p.add_argument("file", help="measured BRDF file or RESULT.json")
    p.add_argument("directions", help=".npy float array N x 6: wi then wo, local frame (normalised)")
    p.add_argument("out", help=".npy output, N x 3 RGB BRDF in 1/sr (float64)")

    p = command("fit", commands.fit, "fit one or more models to a measured file", json_output=True)
    p.add_argument("file", help="measured file (any format `info` reads)")
    p.add_argument("--model", default="ggx+lambert",
                   help="model string, comma-separated list, 'auto' (the engine-ready family), 'classic' "
                        "(Ngan et al. 2005's models) or 'openpbr' (OpenPBR's bases; `brdf-fit models` lists them)")
    p.add_argument("--out", default="results", help="folder for the MATERIAL.MODEL.json results")
    _add_keep_all(p)
    _add_fit_options(p)

    p = command("batch", commands.batch, "fit models to many files (resumable; a bad file is skipped)",
                json_output=True)
    p.add_argument("inputs", nargs="+", help="measured files or folders of them")
    p.add_argument("--models", default="ggx+lambert", help="comma-separated model strings, 'auto', 'classic' or "
                   "'openpbr' (named sets, docs/models.md)")
    p.add_argument("--jobs", type=_number(int, 1, 256), help=JOBS_HELP)
    p.add_argument("--out", default="results", help="folder for the results and summary.csv")
    _add_keep_all(p)
    _add_refit_stale(p)
    g = p.add_argument_group("Dask cluster (docs/batch.md)")
    g.add_argument("--scheduler", metavar="ADDRESS",
                   help="fit the files on the Dask distributed cluster whose scheduler is at ADDRESS "
                        "(e.g. tcp://10.0.0.5:8786; start it with `dask scheduler` and `dask worker "
                        "ADDRESS`) instead of local processes; --jobs is then ignored. By default "
                        "the workers read the inputs and write the results themselves: the inputs "
                        "and --out must be on a filesystem they share at the same paths")
    g.add_argument("--send-data", action="store_true",
                   help="with --scheduler: send each input's bytes to the workers and write the "
                        "results they send back here (no shared filesystem needed)")
    _add_fit_options(p)

    p = command("library", _library, "fit a measured database and write its library: a gallery of "
                "every material, the models compared across it, one glTF of all materials (docs/library.md)",
                json_output=True)
    p.add_argument("inputs", nargs="+", help="measured files or folders of them")
    p.add_argument("--out", default="library", help="the library's folder (index.html, analysis.html, "
                                                    "materials.glb, results/, materials/, gltf/)")
    p.add_argument("--models", default="auto", help="comma-separated model strings, 'auto', 'classic' or "
                   "'openpbr' (named sets, docs/models.md; with openpbr also materials.mtlx and .blend)")
    p.add_argument("--jobs", type=_number(int, 1, 256), help=JOBS_HELP)
    _add_keep_all(p)
    _add_refit_stale(p)
    g = p.add_argument_group("Dask cluster (docs/batch.md)")
    g.add_argument("--scheduler", metavar="ADDRESS", help="fit the files on the Dask cluster at ADDRESS, as batch")
    g.add_argument("--send-data", action="store_true", help="with --scheduler: send the inputs' bytes, as batch")
    _add_fit_options(p)

    p = command("render", commands.render, "render a fit result: fitted sphere, or measured | fitted | "
                "difference with --measured")
    p.add_argument("result", help="RESULT.json")
    p.add_argument("--measured", help="the measured file, for the side-by-side comparison "
                                      "(default: the result's provenance file, when it is here)")
    p.add_argument("--env", help="environment map, lat-long (.hdr or .exr); default: a generated studio sky")
    p.add_argument("--size", type=_number(int, 64, 4096), default=512, help="image size in pixels")
    p.add_argument("--out", default="render.png", help="output PNG")

    p = command("view", commands.view, "interactive window: orbit, key light, exposure (needs a display)")
    p.add_argument("result", help="RESULT.json")
    p.add_argument("--measured", help="the measured file, for the measured and comparison modes")
    p.add_argument("--env", help="environment map, lat-long (.hdr or .exr); default: a generated studio sky")
    p.add_argument("--size", type=_number(int, 64, 4096), default=512, help="window size in pixels")

    p = command("report", commands.report, "HTML report (tables, plots, renders) of fit results")
    p.add_argument("results", nargs="+", help="RESULT.json files or folders of them")
    p.add_argument("--measured", help="the measured file (default: the results' provenance)")
    p.add_argument("--out", default="report", help="output folder (index.html and one page per material)")

    p = command("export", commands.export, "export a fit result, or the best fit of a measured file, as a glTF "
                "material (.gltf or .glb), a MaterialX document (.mtlx) or an OpenPBR material", json_output=True)
    p.add_argument("result", help="RESULT.json, or a measured file: fits the models (--model) and the glTF "
                                  "family and writes the material whose export ranks best, as the library ships it")
    p.add_argument("--measured", help="RESULT.json only: measured file to report the exported material's "
                                      "error against (default: the result's provenance, when it is here)")
    p.add_argument("--format", choices=("gltf", "openpbr", "blender"), default="gltf", help="gltf: the glTF "
                   "family's material; openpbr, blender: OpenPBR's own models fitted, the best written 1:1 as an "
                   "open_pbr_surface (.mtlx) or a Principled BSDF (.blend, or a .py script that writes one)")
    p.add_argument("--out", help="output file (default material.gltf, .mtlx; .blend with bpy, else .py)")
    p.add_argument("--model", help="measured file only: models to fit beside the glTF family (default: auto); "
                                   "--format openpbr: the OpenPBR models to fit (default: openpbr+metal,nonmetal)")
    _add_keep_all(p)
    _add_fit_options(p)

    command("schema", commands.schema, "print the JSON Schema of the result files")

    p = command("demo", commands.demo, "fit the demo materials (no download needed)")
    p.add_argument("folder", nargs="?", help="folder of measured files (default: built-in ABC stand-ins)")
    p.add_argument("--out", default="demo-output", help="output folder")
    p.add_argument("--samples", type=_number(int, 0), default=100_000,
                   help="stratified subsample the optimizer sees")
    return parser


def _library(args):
    from .library.command import library
    return library(args)


def _setup_logging(args):
    """Messages on stderr through the ``brdf_fit`` logger: -q errors and warnings, -v debug."""
    import logging
    logger = logging.getLogger("brdf_fit")
    level = (logging.WARNING if getattr(args, "quiet", False) else
             logging.DEBUG if getattr(args, "verbose", False) else logging.INFO)
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter("%(message)s"))
    logger.handlers[:] = [handler]
    logger.setLevel(level)
    logger.propagate = False
    cache = logging.getLogger("fitting.cache")     # -v: cache files not used, and why
    cache.handlers[:] = [handler]
    cache.setLevel(logging.DEBUG if level == logging.DEBUG else logging.WARNING)
    cache.propagate = False


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
        if category.__module__.split(".")[0] in ("brdf", "brdf_fit", "data_loaders", "fitting", "shaders"):
            warn(command, message)
        elif issubclass(category, RuntimeWarning):     # numpy's overflow / invalid value: one line too
            where = "/".join(pathlib.PurePath(filename).parts[-2:])
            warn(command, f"numerical warning in {where}: {message} (extreme values in the input?)")
        else:
            shown(message, category, filename, lineno, file, line)

    warnings.showwarning = one_line_warning
    _setup_logging(args)
    try:
        lists = f"{getattr(args, 'model', None)},{getattr(args, 'models', None)}"
        if getattr(args, "model_file", None) or ".py:" in lists:    # models of one's own (brdf/own.py)
            from .own_models import load_named
            load_named(args)
        return args.func(args)
    except (ValueError, MeasuredDataError) as err:
        return fail(command, err)
    except OSError as err:
        if output_closed(err):      # `| head` stopped reading: end quietly, as coreutils do
            return end_quietly()
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


_PATH_ARGUMENTS = ("file", "directions", "out", "inputs", "results", "result", "measured", "env", "folder")


def _relative_paths(args):
    """Whether the command would use a path relative to the working directory."""
    for name in _PATH_ARGUMENTS:
        value = getattr(args, name, None)
        for item in value if isinstance(value, list) else [value]:
            if isinstance(item, str) and item and not os.path.isabs(item):
                return True
    return False


def main(argv=None):
    """The command line (exit code returned); streams as brdf_fit.streams describes."""
    prepare_streams()
    try:
        try:
            return _main(argv)
        finally:
            sys.stdout.flush()      # a reader gone by now is seen here, not at exit
    except OSError as err:
        if output_closed(err):
            return end_quietly()
        first = next((str(a) for a in (sys.argv[1:] if argv is None else argv) if not str(a).startswith("-")), "")
        code = fail(first if first.isalpha() and len(first) < 20 else "",
                    f"cannot write the standard output ({err.strerror or err})")
        end_quietly(everything=True)        # what is still buffered cannot be written either
        return code


def _main(argv):
    argv = list(sys.argv[1:] if argv is None else argv)
    # Ctrl-C / SIGTERM: one line and exit 130 / 143 within a fraction of a second, in
    # any phase (imports, loading, XLA compiling, nlopt, writing): see brdf_fit.interrupt.
    # Installed first, before any command imports JAX.
    first = next((a for a in argv if not a.startswith("-")), "")
    with exit_on_signal("brdf-fit " + first if first.isalpha() and len(first) < 20 else "brdf-fit") \
            as on_signal:
        parser = build_parser()
        args = parser.parse_args(argv)
        args.argv = argv
        if not getattr(args, "func", None):
            parser.print_help(sys.stderr)      # no command: a usage error, like any other
            print("brdf-fit: error: no command given (see --help)", file=sys.stderr)
            return BAD_INPUT
        on_signal.prog = f"brdf-fit {args.command}"
        if _relative_paths(args) and cwd_gone():
            return fail(args.command, CWD_GONE)
        try:
            return run_command(args)
        except KeyboardInterrupt:       # only if the handler could not be installed
            print(f"brdf-fit {args.command}: interrupted; finished results are on disk",
                  file=sys.stderr)
            return INTERRUPTED


def run() -> None:
    """The ``brdf-fit`` program (its console script, ``python -m brdf_fit``): ``main``,
    then a prompt end of the process (``interrupt.leave``)."""
    leave(main())


if __name__ == "__main__":
    run()
