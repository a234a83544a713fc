"""The interactive viewer's state (headless) and the frames it renders."""

import json

import numpy as np
import pytest

from shaders import image, viewer
from shaders.gl import gl_available
from shaders.viewer import ViewState

LAMBERT = ("ggx+lambert+f90", {"albedo": [0.6, 0.4, 0.2], "roughness": 0.5, "f0": 0.0, "f90": 0.0})


def test_drag_orbits_and_clamps_the_elevation():
    s = ViewState()
    s.drag(100, 0)
    assert s.azimuth == pytest.approx(360.0 - 100 * viewer.ORBIT_DEGREES_PER_PIXEL)
    s.drag(0, -10_000)
    assert s.elevation == viewer.ELEVATION_LIMIT
    s.drag(0, 10_000)
    assert s.elevation == -viewer.ELEVATION_LIMIT


def test_scroll_zooms_within_range():
    s = ViewState()
    d = s.distance
    s.scroll(1)
    assert s.distance == pytest.approx(d / viewer.ZOOM_FACTOR)
    s.scroll(-1000)
    assert s.distance == viewer.DISTANCE_RANGE[1]


def test_keys_change_exposure_tonemap_mode_and_reset():
    s = ViewState()
    assert s.key("PLUS") and s.exposure == pytest.approx(2 ** viewer.EXPOSURE_STEP)
    assert s.key("MINUS") and s.key("MINUS") and s.exposure == pytest.approx(2 ** -viewer.EXPOSURE_STEP)
    seen = [s.tonemap]
    for _ in image.TONEMAPS:
        s.key("T")
        seen.append(s.tonemap)
    assert sorted(set(seen)) == sorted(image.TONEMAPS) and seen[-1] == seen[0]
    assert not s.key("M") and s.mode == "fitted"          # nothing measured to show
    with_table = ViewState(has_measured=True)
    assert [with_table.key("M") and with_table.mode for _ in range(3)] == ["measured", "comparison", "fitted"]
    s.key("LEFT"), s.drag(30, 30), s.scroll(2)
    assert s.key("R")
    assert (s.azimuth, s.elevation, s.distance, s.light_azimuth, s.exposure_stops) == \
        (0.0, 10.0, 4.25, 45.0, 0.0)
    assert not s.key("F13")


def test_key_light_direction_follows_its_angles():
    s = ViewState(light_azimuth=0.0, light_elevation=0.0)
    np.testing.assert_allclose(s.key_light().unit_direction, [0.0, 0.0, 1.0], atol=1e-12)
    s.key("RIGHT")
    a = np.radians(viewer.LIGHT_STEP)
    np.testing.assert_allclose(s.key_light().unit_direction, [np.sin(a), 0.0, np.cos(a)], atol=1e-12)
    s.key("UP")
    assert s.key_light().unit_direction[1] == pytest.approx(np.sin(a))


def test_view_without_display_fails_clearly(tmp_path, monkeypatch, capsys):
    from brdf_fit.cli import main
    path = tmp_path / "r.json"
    path.write_text(json.dumps({"spec": LAMBERT[0], "parameters": dict(LAMBERT[1], f0=[0.0] * 3),
                                "errors": {}, "schema_version": 1}))
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(viewer.sys, "platform", "linux")
    assert main(["view", str(path)]) == 3
    assert "brdf-fit render" in capsys.readouterr().err
    assert main(["view", str(tmp_path / "missing.json")]) == 2


ok, reason = gl_available()


@pytest.mark.skipif(not ok, reason=f"no OpenGL 4.3 context: {reason}")
def test_frame_follows_exposure_and_the_key_light():
    from shaders.render import Material
    material = Material(*LAMBERT)
    s = ViewState(environment=False, tonemap="linear", light_elevation=0.0, light_azimuth=90.0)
    base = image.srgb_decode(viewer.frame(s, material, size=96) / 255.0)
    s.key("PLUS"), s.key("PLUS")                   # +1 stop: linear radiance x 2
    brighter = image.srgb_decode(viewer.frame(s, material, size=96) / 255.0)
    lit = (base > 0.02) & (base < 0.4)           # away from black and from clipping
    assert lit.sum() > 500
    np.testing.assert_allclose(np.median(brighter[lit] / base[lit]), 2.0, rtol=0.03)
    # the light from +x lights the right half (the camera looks down -z, +x to the right)
    half = base.shape[1] // 2
    assert base[:, half:].mean() > 5 * base[:, :half].mean()
    s.light_azimuth = 270.0
    flipped = image.srgb_decode(viewer.frame(s, material, size=96) / 255.0)
    assert flipped[:, :half].mean() > 5 * flipped[:, half:].mean()


@pytest.mark.skipif(not ok, reason=f"no OpenGL 4.3 context: {reason}")
def test_window_shows_the_rendered_frame(tmp_path):
    """A real window on a virtual X server: events change the view, and the
    window's framebuffer holds exactly the frame the viewer rendered."""
    import shutil
    import subprocess
    import sys
    import matplotlib.image as mpimg
    pytest.importorskip("pyglet")
    if not shutil.which("xvfb-run"):
        pytest.skip("xvfb-run not installed (make sysdeps installs it)")
    driver = __import__("pathlib").Path(__file__).with_name("viewer_window_driver.py")
    run = subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 640x480x24", sys.executable, str(driver),
                          str(tmp_path)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    caption = (tmp_path / "caption.txt").read_text()
    assert "exposure +0.5 EV" in caption and "fitted" in caption
    shot = mpimg.imread(tmp_path / "brdf-view-000.png")          # the frame, written by the viewer
    window = mpimg.imread(tmp_path / "window.png")[..., :3]       # what the window shows
    assert shot.shape == window.shape and shot.mean() > 0.05
    np.testing.assert_allclose(window, shot, atol=1.5 / 255)
