"""``brdf-fit render RESULT.json [--measured FILE] [--env FILE.hdr] --out x.png``.

fitting/cli.py parses the arguments and calls ``render_main``; this module
reads the fit result (``fitting.result.FitResult.load``, the one validator of
result files), renders, and writes the PNG.  Errors (unreadable result, bad
measured file, missing GL driver) are printed by ``fitting.errors.fail`` as
one line naming the problem, with exit status 2 (3 for a missing driver).
"""

from fitting.errors import BAD_INPUT, NO_GL, OK, fail, os_error_message  # noqa: F401  (OK: the exit codes' one home)


class RenderInputError(ValueError):
    """A result file the renderer cannot use (names the file and the problem)."""


def load_fit_result(path):
    """(ModelSpec, {name: float or [r, g, b]}) from a FitResult JSON.

    A thin wrapper over ``FitResult.load`` (which checks the size, encoding,
    schema_version, model and every parameter); its ResultFileError comes
    out as RenderInputError with the same message.
    """
    from fitting.result import FitResult, ResultFileError
    try:
        result = FitResult.load(path)
    except ResultFileError as exc:
        raise RenderInputError(str(exc)) from None
    return result.model, dict(result.parameters)


def _load_measured(path):
    """data_loaders.load, its errors (which name the file) as RenderInputError."""
    import data_loaders
    try:
        return data_loaders.load(path)
    except Exception as exc:  # MeasuredDataError, OSError...
        raise RenderInputError(str(exc)) from None


def render_main(result_path, measured_path=None, env_path=None, out_path="render.png", size=512,
                mesh="sphere", tonemap="aces"):
    """Render a fit result to a PNG; returns the exit status.

    Without ``measured_path``: the fitted material (split-sum image lighting
    plus the environment's sun).  With it: measured | fitted | difference
    (sampled image lighting, each panel ``size`` / 2 wide, at least 128).
    """
    from .environment import Environment
    from .gl import GLUnavailableError
    from .hdr import HDRFormatError
    from . import render
    try:
        spec, params = load_fit_result(result_path)
        env = Environment.from_file(env_path) if env_path else None
        if measured_path:
            measured = _load_measured(measured_path)
            img = render.render_comparison(spec, params, measured, size=max(128, size // 2), env=env,
                                           tonemap=tonemap, mesh=mesh, labels=True)
        else:
            img = render.render_material(spec, params, size=size, env=env, tonemap=tonemap, mesh=mesh)
        render.save_png(out_path, img)
    except (RenderInputError, HDRFormatError) as exc:
        return fail("render", exc, BAD_INPUT)
    except GLUnavailableError as exc:
        return fail("render", exc, NO_GL)
    except OSError as exc:                 # the PNG cannot be written
        return fail("render", os_error_message(exc, out_path), BAD_INPUT)
    print(f"wrote {out_path} ({img.shape[1]}x{img.shape[0]}, {spec})")
    return OK
