"""``brdf-fit render RESULT.json [--measured FILE] [--env FILE.hdr] --out x.png``.

fitting/cli.py parses the arguments and calls ``render_main``; this module
reads the fit result, renders, and writes the PNG.  Errors (unreadable result,
bad measured file, missing GL driver) are printed as one line naming the
problem and give exit status 2 (3 for a missing driver).
"""

import json
import os
import sys

OK, BAD_INPUT, NO_GL = 0, 2, 3


class RenderInputError(ValueError):
    """A result file the renderer cannot use (names the file and the problem)."""


def load_fit_result(path):
    """(ModelSpec, {name: float or [r, g, b]}) from a FitResult JSON.

    Reads {"spec": "<model string>", "parameters": {...}} (other keys are
    ignored); the one place that knows the result file's layout.
    """
    from brdf.model import parameter_schema, parse_model
    path = os.fspath(path)
    try:
        with open(path) as f:
            data = json.load(f)
    except OSError as exc:
        raise RenderInputError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except json.JSONDecodeError as exc:
        raise RenderInputError(f"{path}: not valid JSON ({exc.msg}, line {exc.lineno})") from None
    if not isinstance(data, dict) or "spec" not in data or "parameters" not in data:
        raise RenderInputError(f"{path}: not a fit result (needs 'spec' and 'parameters')")
    try:
        spec = parse_model(data["spec"])
    except ValueError as exc:
        raise RenderInputError(f"{path}: {exc}") from None
    params = data["parameters"]
    if not isinstance(params, dict):
        raise RenderInputError(f"{path}: 'parameters' must be an object")
    out = {}
    for p in parameter_schema(spec):
        value = params.get(p.name)
        ok = (isinstance(value, (int, float)) if p.size == 1 else
              isinstance(value, list) and len(value) == 3 and all(isinstance(v, (int, float)) for v in value))
        if not ok:
            raise RenderInputError(f"{path}: parameter {p.name!r} of {spec} missing or malformed "
                                   f"(expected {'a number' if p.size == 1 else '[r, g, b]'})")
        out[p.name] = value
    return spec, out


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
        env = Environment.from_hdr(env_path) if env_path else None
        if measured_path:
            measured = _load_measured(measured_path)
            img = render.render_comparison(spec, params, measured, size=max(128, size // 2), env=env,
                                           tonemap=tonemap, mesh=mesh)
        else:
            img = render.render_material(spec, params, size=size, env=env, tonemap=tonemap, mesh=mesh)
        render.save_png(out_path, img)
    except (RenderInputError, HDRFormatError) as exc:
        print(f"brdf-fit render: {exc}", file=sys.stderr)
        return BAD_INPUT
    except GLUnavailableError as exc:
        print(f"brdf-fit render: {exc}", file=sys.stderr)
        return NO_GL
    print(f"wrote {out_path} ({img.shape[1]}x{img.shape[0]}, {spec})")
    return OK
