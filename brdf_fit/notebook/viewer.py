"""The report's three.js viewer inline in a notebook, working offline.

``viewer(result, measured)`` returns an ``InlineViewer``; Jupyter shows its
``_repr_html_``: an ``<iframe srcdoc>`` holding one self-contained page with
the report's scene (brdf_fit/report/web/viewer.js: the preview camera, the
generated sky and its sun, PBR Neutral at the still's exposure), three.js bundled into an inline classic
script (``brdf_fit.report.web_viewer.bundle_three``), the exported ``.glb``
of each result and the sky's ``.hdr`` as base64, and beside the canvas the
preview renderer's still of the measured sphere (the measured panel of the
lit-sphere comparison, as in the report).  Nothing is fetched: the page
works without a network and without a server, and the iframe keeps each
viewer's scripts and ids apart from the notebook's and from other viewers'.

Without three.js (``node_modules/three`` or ``$BRDF_FIT_THREE_DIR``) the
HTML is one line saying why; without OpenGL or the measured data, the still
is replaced by one line.
"""

import base64
import functools
import html
import json
import pathlib
import tempfile

CANVAS = 320                    # CSS pixels, as in the report
STILL_SIZE = 192                # the report's lit-sphere panels (brdf_fit.report.pages.RENDER_SIZE)


class InlineViewer:
    """The viewer as HTML: ``page`` (a whole document), ``_repr_html_`` (the iframe)."""

    def __init__(self, page: str | None, note: str | None = None, height: int = CANVAS + 90):
        self.page, self.note, self.height = page, note, height

    def __repr__(self) -> str:
        what = self.note or f"{len(self.page or ''):,} bytes of HTML"
        return f"<InlineViewer: {what}>"

    def _repr_html_(self) -> str:
        if self.page is None:
            return f"<p class=\"brdf-viewer-note\">3D viewer not shown: {html.escape(self.note or '?')}</p>"
        return (f"<iframe class=\"brdf-viewer\" srcdoc=\"{html.escape(self.page, quote=True)}\" "
                f"style=\"width:100%;max-width:{2 * CANVAS + 60}px;height:{self.height}px;border:0\" "
                "title=\"3D viewer of the exported material\"></iframe>")

    def save(self, path) -> pathlib.Path:
        """Write the page as a standalone HTML file (opens from disk, offline)."""
        from fitting.result import atomic_write_text
        if self.page is None:
            raise ValueError(f"no viewer to save: {self.note}")
        atomic_write_text(path, self.page)
        return pathlib.Path(path)


@functools.lru_cache(maxsize=2)
def _bundle(folder: str, version: str) -> str:
    from brdf_fit.report.web_viewer import bundle_three
    return bundle_three(pathlib.Path(folder)).replace("</script", "<\\/script")


@functools.lru_cache(maxsize=1)
def _environment() -> str:
    from brdf_fit.report.web_viewer import write_environment
    with tempfile.TemporaryDirectory(prefix="brdf-viewer-") as tmp:
        return json.dumps(write_environment(pathlib.Path(tmp)))


def _recorded(result, measured) -> bool:
    """The result's recorded errors are the export's check against ``measured``: it holds
    them and was fitted on the same file (sha256); otherwise the check is evaluated."""
    e, sha = result.errors or {}, (result.provenance or {}).get("sha256")
    return (measured is not None and "exported_m1" in e and "m1_per_channel" in e and bool(sha)
            and getattr(measured.provenance, "sha256", None) == sha)


def _models(results, measured) -> list[dict[str, object]]:
    """Each result's exported .glb (brdf_fit.export.gltf.export_gltf) as base64."""
    from brdf_fit.export.gltf import export_gltf
    out = []
    with tempfile.TemporaryDirectory(prefix="brdf-viewer-") as tmp:
        for i, r in enumerate(results):
            path = pathlib.Path(tmp) / f"model-{i}.glb"
            info = export_gltf(r, path, measured=measured, just_fitted=_recorded(r, measured))
            out.append({"spec": r.spec, "gltf_model": info["model"], "kind": info["kind"],
                        "file": f"{r.material}-{r.spec}.glb",
                        "glb_base64": base64.b64encode(path.read_bytes()).decode("ascii")})
    return out


def _still(result, measured) -> tuple[str | None, str | None, float]:
    """(data URI of the measured sphere's still, None, its exposure) or (None, why there is
    none, 1.0).  The still is exposed and tone-mapped as the report's (docs/colour.md)."""
    from .display import measured_for
    data, why = measured_for(result, measured)
    if data is None:
        return None, why, 1.0
    try:
        from brdf_fit.render import DISPLAY_TONEMAP, viewer_exposure
        from shaders.image import finish, png_bytes
        from shaders.render import render_comparison
        _, frames = render_comparison(result.spec, result.parameters, data, size=STILL_SIZE, return_data=True,
                                      tonemap=DISPLAY_TONEMAP, exposure=viewer_exposure)
    except Exception as err:           # no OpenGL (GLUnavailableError), no moderngl...
        return None, f"{type(err).__name__}: " + " ".join(str(err).split()), 1.0
    png = png_bytes(finish(frames["measured"], DISPLAY_TONEMAP, frames["exposure"]))
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii"), None, frames["exposure"]


def _script(code: str) -> str:
    return "<script>" + code.replace("</script", "<\\/script") + "</script>"


def viewer(results, measured=None, *, still: bool = True) -> InlineViewer:
    """The report's 3D viewer of ``results`` (a FitResult, a result file, or a list:
    one button each, the first shown) beside the measured sphere's still.

    ``measured``: a MeasuredBRDF or a file (default: the first result's
    provenance file when it is here), for the still and the export's check.
    """
    from brdf_fit.report.web_viewer import (VIEWER_JS, ViewerUnavailable, preview_camera, three_dir,
                                            three_version, write_three_bundle)

    from .display import as_result, measured_for
    items = results if isinstance(results, (list, tuple)) else [results]
    results = [as_result(r) for r in items]
    if not results:
        raise ValueError("viewer() needs at least one fit result")
    folder = three_dir()
    try:
        if folder is None:
            write_three_bundle(pathlib.Path(tempfile.gettempdir()))   # raises, naming the fix
        bundle = _bundle(str(folder), three_version(folder))
    except ViewerUnavailable as err:
        return InlineViewer(None, str(err))
    data, _ = measured_for(results[0], measured)
    models = _models(results, data)
    material = results[0].material
    uri, why, exposure = _still(results[0], data) if still else (None, "not asked for", 1.0)
    payload = {"material": material, "models": models, "camera": preview_camera(),
               "tone_mapping": "pbr_neutral", "exposure": exposure}
    e = html.escape
    still_html = (f"<figure style=\"margin:0\"><img src=\"{uri}\" alt=\"measured sphere\" "
                  f"width=\"{CANVAS}\" height=\"{CANVAS}\">"
                  "<figcaption>measured: the preview renderer's still</figcaption></figure>" if uri else
                  f"<p class=\"note\">No still of the measured sphere: {e(why)}.</p>")
    buttons = "".join(f"<button type=\"button\" data-model=\"{i}\">{e(m['spec'])}</button> "
                      for i, m in enumerate(models))
    page = (
        "<!doctype html><html><head><meta charset=\"utf-8\"><title>3D viewer</title></head>"
        "<body style=\"margin:8px;font:13px sans-serif\">"
        "<div style=\"display:flex;gap:1em;flex-wrap:wrap;align-items:flex-start\">"
        f"<figure style=\"margin:0\"><canvas id=\"brdf-viewer\" width=\"{CANVAS}\" height=\"{CANVAS}\" "
        f"style=\"width:{CANVAS}px;height:{CANVAS}px;border:1px solid #eee;touch-action:none\"></canvas>"
        f"<figcaption><span id=\"brdf-viewer-status\">loading the viewer...</span><br>{buttons}</figcaption>"
        f"</figure>{still_html}</div>"
        + _script(bundle)
        + _script("window.BRDF_VIEWER_ENVIRONMENT = " + _environment() + ";")
        + _script("window.BRDF_VIEWER_DATA = " + json.dumps(payload) + ";")
        + _script(VIEWER_JS.read_text(encoding="utf-8"))
        + "</body></html>")
    return InlineViewer(page)
