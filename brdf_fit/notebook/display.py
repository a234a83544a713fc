"""A FitResult shown with the preview renderer's spheres, and the comparison render as a picture.

``comparison_image(result, measured)`` is ``brdf-fit render RESULT --measured
FILE``'s image (``brdf_fit.render.comparison_pixels``, the same call) as a
PIL image.  ``show(result, measured)`` wraps a result in an object whose
HTML is the engine's (``fitting.result_display``) with the measured | fitted |
difference spheres added at ``DISPLAY_SIZE`` (each panel half of it), and
whose PNG is those spheres; ``%load_ext brdf_fit.notebook`` (``register``)
makes every FitResult display that way.

Measurements default to the result's provenance file when it is on this
machine.  Loaded measurements and renders are cached (a few of each), so a
result displays again at once.  Without OpenGL, or without the measured
file, the spheres are replaced by one line saying so; the rest shows.
"""

import base64
import collections
import html
import json
import os
import pathlib

DISPLAY_SIZE = 256             # `render --size` of the displayed spheres: 128-pixel panels
MEASURED_CACHE = 2             # loaded measurements kept (a MERL table is ~120 MB in memory)
RENDER_CACHE = 32              # rendered comparisons kept (PNG bytes, ~30 kB each)

_measured = collections.OrderedDict()
_renders = collections.OrderedDict()
_gl_problem: list[str] = []    # why OpenGL failed in this process (it will not start working later)


def _remember(cache, key, value, limit):
    cache[key] = value
    cache.move_to_end(key)
    while len(cache) > limit:
        cache.popitem(last=False)
    return value


def as_result(result):
    """A FitResult from a FitResult or a result file's path."""
    from fitting.result import FitResult
    return result if isinstance(result, FitResult) else FitResult.load(result)


def load_measured(path):
    """data_loaders.load, cached by (path, size, modification time)."""
    from data_loaders import load
    st = os.stat(path)
    key = (os.path.realpath(path), st.st_size, st.st_mtime_ns)
    if key in _measured:
        _measured.move_to_end(key)
        return _measured[key]
    return _remember(_measured, key, load(path), MEASURED_CACHE)


def measured_for(result, measured=None):
    """(MeasuredBRDF, None), or (None, why there is none): ``measured`` (object or
    path), else the result's provenance file when it is on this machine."""
    if measured is not None and not isinstance(measured, (str, os.PathLike)):
        return measured, None
    path = measured if measured is not None else (result.provenance or {}).get("file")
    if not path or not pathlib.Path(path).is_file():
        where = f"the measured file {path}" if path else "no measured file is recorded and none"
        return None, f"{where} is not on this machine; show(result, measured) takes one"
    try:
        return load_measured(path), None
    except Exception as err:            # MeasuredDataError, OSError: the message names the file
        return None, str(err)


def comparison_image(result, measured=None, size: int = 512, *, env=None, tonemap: str = "pbr_neutral",
                     mesh: str = "sphere"):
    """The labelled measured | fitted | difference render of ``result`` as a PIL image:
    the pixels ``brdf-fit render RESULT --measured FILE --size SIZE`` writes (the viewer's
    exposure of the measured picture, PBR Neutral: the gallery's colour path, docs/colour.md).

    ``result``: a FitResult or a result file; ``measured``: a MeasuredBRDF or a
    file (default: the result's provenance file); ``env``: an Environment or a
    .hdr / .exr path.  Raises ValueError without measured data and
    shaders.gl.GLUnavailableError without OpenGL.
    """
    from PIL import Image

    from brdf_fit.render import comparison_pixels
    result = as_result(result)
    data, why = measured_for(result, measured)
    if data is None:
        raise ValueError(f"no measured data for {result.spec} on {result.material}: {why}")
    if isinstance(env, (str, os.PathLike)):
        from shaders.environment import Environment
        env = Environment.from_file(env)
    return Image.fromarray(comparison_pixels(result.spec, result.parameters, data, size, env, tonemap, mesh))


def _key(result, data, size):
    sha = getattr(data.provenance, "sha256", "") or f"object {id(data)}"
    return (result.spec, json.dumps(result.parameters, sort_keys=True), sha, size)


def spheres_png(result, measured=None, size: int = DISPLAY_SIZE) -> tuple[bytes | None, str | None]:
    """(PNG bytes of the comparison at ``size``, None) or (None, one line saying why not); cached."""
    data, why = measured_for(result, measured)
    if data is None:
        return None, why
    if _gl_problem:
        return None, _gl_problem[0]
    key = _key(result, data, size)
    if key in _renders:
        _renders.move_to_end(key)
        return _renders[key], None
    try:
        from shaders.gl import GLUnavailableError
    except ImportError as err:           # moderngl missing
        _gl_problem.append(f"no OpenGL here ({err})")
        return None, _gl_problem[0]
    try:
        image = comparison_image(result, data, size)
    except GLUnavailableError as err:
        _gl_problem.append("no OpenGL here: " + " ".join(str(err).split()))
        return None, _gl_problem[0]
    except Exception as err:             # a display never raises
        return None, f"{type(err).__name__}: " + " ".join(str(err).split())
    import io
    buf = io.BytesIO()
    image.save(buf, format="PNG")
    return _remember(_renders, key, buf.getvalue(), RENDER_CACHE), None


class ResultView:
    """A FitResult displayed with the preview renderer's spheres (``show``)."""

    def __init__(self, result, measured=None, size: int = DISPLAY_SIZE):
        self.result = as_result(result)
        self.measured = measured
        self.size = size

    def __repr__(self) -> str:
        return repr(self.result)

    def spheres(self) -> tuple[bytes | None, str | None]:
        return spheres_png(self.result, self.measured, self.size)

    def _repr_png_(self) -> bytes | None:
        return self.spheres()[0]

    def _repr_html_(self) -> str:
        from fitting.result_display import result_html
        png, why = self.spheres()
        if png is None:
            extra = f"<p style=\"font-size:smaller\">spheres not shown: {html.escape(why)}</p>"
        else:
            extra = ("<img alt=\"measured | fitted | difference\" src=\"data:image/png;base64,"
                     f"{base64.b64encode(png).decode('ascii')}\">")
        return result_html(self.result, extra)


def show(result, measured=None, size: int = DISPLAY_SIZE) -> ResultView:
    """``result`` (FitResult or file) displayed with spheres against ``measured``."""
    return ResultView(result, measured, size)


# --- IPython's display hook -------------------------------------------------------------

_TYPE = ("fitting.result", "FitResult")


def register(ip=None) -> None:
    """Make every FitResult in this IPython display with its spheres (HTML and PNG).

    IPython's formatters are told the type by name, so nothing is imported
    here and the engine never imports the application.
    """
    if ip is None:
        from IPython import get_ipython
        ip = get_ipython()
        if ip is None:
            raise RuntimeError("register() needs a running IPython (a notebook or the IPython shell)")
    formatters = ip.display_formatter.formatters
    formatters["text/html"].for_type_by_name(*_TYPE, lambda r: ResultView(r)._repr_html_())
    formatters["image/png"].for_type_by_name(*_TYPE, lambda r: ResultView(r)._repr_png_())


def unregister(ip=None) -> None:
    """Undo ``register``: FitResult displays the engine's HTML again."""
    if ip is None:
        from IPython import get_ipython
        ip = get_ipython()
    for mime in ("text/html", "image/png"):
        ip.display_formatter.formatters[mime].pop(".".join(_TYPE), None)


def load_ipython_extension(ip) -> None:
    """``%load_ext brdf_fit.notebook``."""
    register(ip)


def unload_ipython_extension(ip) -> None:
    """``%unload_ext brdf_fit.notebook``."""
    unregister(ip)
