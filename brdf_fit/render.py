"""``brdf-fit render`` and ``brdf-fit view``: the preview renderer's two commands.

brdf_fit/cli.py parses the arguments and calls ``render_main`` / ``view_main``; this module
reads the fit result (``fitting.result.FitResult.load``, the one validator of
result files), renders, and writes the PNG.  Errors (unreadable result, bad
measured file, missing GL driver) are printed by ``brdf_fit.errors.fail`` as
one line naming the problem, with exit status 2 (3 for a missing driver).
"""

from .errors import BAD_INPUT, NO_GL, OK, fail, os_error_message, warn  # noqa: F401  (OK: the exit codes' one home)


class RenderInputError(ValueError):
    """A result file the renderer cannot use (names the file and the problem)."""


def _load_result(path):
    """``FitResult.load`` (which checks the size, encoding, schema_version, model and
    every parameter); its ResultFileError comes out as RenderInputError with the same message."""
    from fitting.result import FitResult, ResultFileError
    try:
        return FitResult.load(path)
    except ResultFileError as exc:
        raise RenderInputError(str(exc)) from None


def _load_measured(path, result, command):
    """data_loaders.load, its errors (which name the file) as RenderInputError; a warning
    when the file is not the one ``result`` was fitted to (its sha256), as export and
    report say."""
    import data_loaders
    try:
        measured = data_loaders.load(path)
    except Exception as exc:  # MeasuredDataError, OSError...
        raise RenderInputError(str(exc)) from None
    fitted_sha = (result.provenance or {}).get("sha256")
    if fitted_sha and fitted_sha != measured.provenance.sha256:
        warn(command, f"{path}: the measured file differs from the one the fit was made on (sha256); "
                      "the comparison shows another measurement")
    return measured


# A material is shown as the image error and the gallery show it (docs/colour.md, "One colour
# path"): exposed by the viewer's rule on its measured picture, tone-mapped by PBR Neutral.
DISPLAY_TONEMAP = "pbr_neutral"


def viewer_exposure(measured_hdr, mask):
    """The exposure of a preview whose measured picture is ``measured_hdr`` (H, W, 4 linear) on
    the object pixels ``mask``: the image error's rule (fitting.image_error.viewer_exposure:
    0.85 / the 99th percentile of their luminance), so a dark material is brought to the
    brightness the gallery shows it at, and its fit is shown at the same factor.  An overflowed
    render (a table in wrong units) counts its infinite pixels at the tone map's cap, as
    shaders.image.tonemap draws them (white), not as a percentile of inf."""
    import numpy as np

    from fitting.image_error import viewer_exposure as rule
    from shaders.image import TONEMAP_CAP
    pixels = np.nan_to_num(np.asarray(measured_hdr, np.float64)[..., :3][mask], nan=0.0, posinf=TONEMAP_CAP,
                           neginf=0.0)
    return rule(pixels, np.ones((len(pixels), 1)), np.ones(len(pixels)))


def comparison_pixels(spec, params, measured, size=512, env=None, tonemap=DISPLAY_TONEMAP, mesh="sphere",
                      exposure=viewer_exposure):
    """The labelled measured | fitted | difference image (uint8) of ``render --measured``
    (each panel ``size`` / 2 wide, at least 128), at the viewer's exposure of its measured
    picture by default; brdf_fit.notebook shows the same."""
    from shaders import render
    return render.render_comparison(spec, params, measured, size=max(128, size // 2), env=env,
                                    tonemap=tonemap, mesh=mesh, labels=True, exposure=exposure)


def render_main(result_path, measured_path=None, env_path=None, out_path="render.png", size=512,
                mesh="sphere", tonemap=DISPLAY_TONEMAP):
    """Render a fit result to a PNG; returns the exit status.

    Without ``measured_path``: the fitted material (split-sum image lighting
    plus the environment's sun).  With it: measured | fitted | difference
    (sampled image lighting, each panel ``size`` / 2 wide, at least 128).
    """
    from shaders.environment import Environment
    from shaders.gl import GLUnavailableError
    from shaders.hdr import HDRFormatError
    from shaders import render
    try:
        result = _load_result(result_path)
        spec, params = result.model, dict(result.parameters)
        env = Environment.from_file(env_path) if env_path else None
        if measured_path:
            img = comparison_pixels(spec, params, _load_measured(measured_path, result, "render"), size, env,
                                    tonemap, mesh)
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


def view_main(result_path, measured_path=None, env_path=None, size=512):
    """``brdf-fit view``: returns the exit status (2 bad input, 3 no display / GL)."""
    from shaders import viewer
    from shaders.environment import Environment
    from shaders.gl import GLUnavailableError
    from shaders.hdr import HDRFormatError
    from shaders.measured import MeasuredTable
    from shaders.render import Material
    try:
        result = _load_result(result_path)
        spec, params = result.model, dict(result.parameters)
        env = Environment.from_file(env_path) if env_path else None
        table = None
        if measured_path:
            table = MeasuredTable.from_measured(_load_measured(measured_path, result, "view"))
        viewer.load_pyglet()                  # fail before any rendering when there is no display
        viewer.run(Material(spec, params), table, env, size)
    except (RenderInputError, HDRFormatError) as exc:
        return fail("view", exc, BAD_INPUT)
    except (viewer.ViewerUnavailableError, GLUnavailableError) as exc:
        return fail("view", exc, NO_GL)
    return OK
