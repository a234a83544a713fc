"""``brdf_fit.notebook.viewer``: the report's three.js viewer inline in a notebook.

Its HTML, put into a page as a notebook front end puts an output, draws in
the headless Chromium of the cross-renderer tests (tests/headless_chromium.py)
from disk, with no network and no console error; two viewers on one page
draw side by side (each in its own iframe); the measured still is the
preview renderer's measured panel; without three.js one line says why.
"""

import base64
import io
import json
import re

import numpy as np
import pytest

from fitting.result import FitResult

from headless_chromium import HeadlessChromium, find_chromium

ALBEDO = np.array([0.5, 0.25, 0.1])


@pytest.fixture(scope="module")
def fits(tmp_path_factory):
    """A Lambertian MERL file, a ggx+lambert and a gltf result naming it."""
    from data_loaders.merl import MERL_SHAPE, write_merl
    folder = tmp_path_factory.mktemp("notebook-viewer")
    path = folder / "matte.binary"
    write_merl(path, np.broadcast_to(ALBEDO / np.pi, MERL_SHAPE + (3,)), np.ones(MERL_SHAPE, bool))
    prov = {"file": str(path), "sha256": None, "format": "merl", "material": "matte"}
    results = [FitResult(spec="ggx+lambert", parameters={"albedo": ALBEDO.tolist(), "roughness": 0.5,
                                                         "f0": [0.04, 0.04, 0.04]},
                         errors={"m1": 0.01}, optimizer={"max_theta": 80.0}, provenance=prov),
               FitResult(spec="gltf", parameters={"base_color": [0.9, 0.6, 0.5], "metallic": 1.0, "roughness": 0.3},
                         errors={"m1": 0.02}, optimizer={"max_theta": 80.0}, provenance=prov)]
    return path, results


def _need_three():
    from brdf_fit.report.web_viewer import three_dir
    if three_dir() is None:
        pytest.skip("three.js is not installed (node_modules/three; make test runs npm ci)")


def _gl():
    try:
        from shaders.gl import gl_available
    except ImportError:
        return False
    return gl_available()[0]


def test_the_inline_viewer_is_self_contained(fits):
    _need_three()
    from brdf_fit.notebook import viewer
    path, results = fits
    shown = viewer(results[0], path)
    out = shown._repr_html_()
    assert out.startswith("<iframe class=\"brdf-viewer\" srcdoc=\"") and out.count("<iframe") == 1
    page = shown.page
    # offline: every script inline, nothing loaded from a URL
    assert "<script src" not in page and not re.search(r'(src|href)="(https?:)?//', page)
    assert "window.BRDF_THREE = " in page and "window.BRDF_VIEWER_ENVIRONMENT = " in page
    data = json.loads(re.search(r"window\.BRDF_VIEWER_DATA = (\{.*?\});</script>", page).group(1))
    assert [m["spec"] for m in data["models"]] == ["ggx+lambert"]
    glb = base64.b64decode(data["models"][0]["glb_base64"])
    assert glb[:4] == b"glTF"
    if _gl():        # the still is the preview renderer's measured panel, as in the report
        from PIL import Image

        from brdf_fit.notebook.viewer import STILL_SIZE
        from brdf_fit.render import DISPLAY_TONEMAP, viewer_exposure
        from shaders.image import finish
        from shaders.render import render_comparison
        still = re.search(r'<img src="data:image/png;base64,([^"]+)" alt="measured sphere"', page).group(1)
        _, frames = render_comparison(results[0].spec, results[0].parameters, path and _load(path),
                                      size=STILL_SIZE, return_data=True)
        exposure = viewer_exposure(frames["measured"], frames["mask"])     # the report's colour path
        assert data["tone_mapping"] == "pbr_neutral" and data["exposure"] == pytest.approx(exposure, rel=1e-12)
        np.testing.assert_array_equal(np.asarray(Image.open(io.BytesIO(base64.b64decode(still))).convert("RGB")),
                                      finish(frames["measured"], DISPLAY_TONEMAP, exposure))
    else:
        assert "No still of the measured sphere: " in page


def _load(path):
    from data_loaders import load
    return load(path)


def test_the_inline_viewer_draws_in_chromium(fits, tmp_path):
    _need_three()
    if find_chromium() is None:
        pytest.skip("chromium is not installed (Debian package chromium; make test installs it)")
    from brdf_fit.notebook import viewer
    path, results = fits
    cells = [viewer(results[0], path, still=False), viewer(results[1], path, still=False)]
    # as a notebook front end puts two outputs on its page
    (tmp_path / "notebook.html").write_text(
        "<!doctype html><html><head><meta charset=\"utf-8\"><link rel=\"icon\" href=\"data:,\"></head><body>"
        + "".join(f"<div class=\"output\">{c._repr_html_()}</div>" for c in cells) + "</body></html>")
    frame = "document.querySelectorAll('iframe.brdf-viewer')[{}].contentWindow"
    with HeadlessChromium(tmp_path, 900, 1000, timeout=240) as browser:
        browser.open((tmp_path / "notebook.html").as_uri())
        for i in range(2):
            w = frame.format(i)
            browser.wait_for(f"(() => {{ try {{ return {w}.brdfViewerRendered === true || !!{w}.brdfViewerError; }}"
                             " catch (e) { return false; } })()")
            assert browser.evaluate(f"{w}.brdfViewerError || null") is None
        models = [browser.evaluate(frame.format(i) + ".brdfViewerModel") for i in range(2)]
        status = browser.evaluate(frame.format(0) + ".document.getElementById('brdf-viewer-status').textContent")
        rect = json.loads(browser.evaluate(
            "(() => { const f = document.querySelectorAll('iframe.brdf-viewer')[0].getBoundingClientRect();"
            " const c = " + frame.format(0) + ".document.getElementById('brdf-viewer').getBoundingClientRect();"
            " return JSON.stringify({x: f.x + c.x + 1, y: f.y + c.y + 1}); })()"))
        png = browser.screenshot({"x": rect["x"], "y": rect["y"], "width": 318, "height": 318})
        assert not browser.errors, browser.errors
    from PIL import Image
    shot = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(float)
    assert models == ["ggx+lambert", "gltf"]                # each iframe its own viewer
    assert "ggx+lambert exported as gltf" in status
    centre = shot[151:167, 151:167].reshape(-1, 3).mean(0)
    corner = shot[-16:, :16].reshape(-1, 3).mean(0)
    assert np.abs(centre - corner).max() > 8, (centre, corner)      # the sphere is drawn over the ground
    assert centre[0] > centre[1] > centre[2]                          # the albedo's order: red > green > blue


def test_without_three_one_line_says_why(fits, monkeypatch, tmp_path):
    from brdf_fit.notebook import viewer
    from brdf_fit.report.web_viewer import THREE_DIR_VARIABLE
    monkeypatch.setenv(THREE_DIR_VARIABLE, str(tmp_path / "no-three-here"))
    out = viewer(fits[1][1])._repr_html_()
    assert re.fullmatch(r"<p class=\"brdf-viewer-note\">3D viewer not shown: three\.js is not installed[^<]*</p>",
                        out)
    assert THREE_DIR_VARIABLE in out
