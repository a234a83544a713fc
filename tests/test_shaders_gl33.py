"""The preview renderer on an OpenGL 3.3 core context (docs/renderer.md).

A subprocess makes Mesa create a real 3.3 context (MESA_GL_VERSION_OVERRIDE=3.3,
MESA_GLSL_VERSION_OVERRIDE=330: a ``#version 430`` shader or a compute shader
fails to compile there) and renders a fit under point lights, a fit under
split-sum image lighting, MERL and UTIA tables under sampled image lighting,
and ``brdf-fit render``'s PNG.  This process renders the same on its 4.3
context (compute prefilter, ``#version 430``); the two must agree within the
tolerances below, measured on Mesa 22.3 llvmpipe:

- HDR renders (linear radiance, 96 x 96 and 64 x 64): the sun's disc in the
  split-sum background differs in one MSAA sample of one pixel (its edge test
  rounds differently under GLSL 3.30): largest difference 3.0e-4 of that
  pixel, relative RMSE 2.9e-4 of that image.  Elsewhere the largest
  difference was 6.2e-6 of the value (sampled MERL), relative RMSE <= 1.5e-7.
  Bounds: relative RMSE 5e-4, largest relative difference 5e-4, and 1e-5
  for the 99.9th percentile of the relative difference.
- 8-bit sRGB (ACES tone map) and brdf-fit render's PNG: identical.  Bound:
  at most 1 level, on at most 0.1 % of the pixels.
- The prefiltered environment mips of the fragment path (3.3) and the
  compute path (4.3), both made on this context: bit-identical.
"""

import json
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

from shaders import gl
from shaders.gl import gl_available

ok, reason = gl_available()
pytestmark = pytest.mark.skipif(not ok, reason=f"no OpenGL context: {reason}")

#: Environment of the 3.3 subprocess: Mesa's own 3.3 core context and GLSL 3.30.
FORCE_33 = {"MESA_GL_VERSION_OVERRIDE": "3.3", "MESA_GLSL_VERSION_OVERRIDE": "330", gl.VERSION_ENV: "330"}
SIZE = 96
HDR_RMSE = 5e-4          # relative: RMSE / RMS of the image
HDR_MAX_REL = 5e-4       # largest |difference| / max(|value|, 1e-3 of the image's peak)
HDR_P999_REL = 1e-5      # 99.9th percentile of the same
SRGB_MAX_LEVELS = 1
SRGB_FRACTION = 1e-3

FIT = ("ggx+burley+ms", {"albedo": [0.6, 0.4, 0.2], "roughness": 0.8, "f0": [0.04, 0.04, 0.04]})
GLTF = ("gltf+clearcoat", {"base_color": [0.8, 0.3, 0.1], "metallic": 0.0, "roughness": 0.35,
                           "clearcoat": 0.5, "clearcoat_roughness": 0.1})


def _merl_table():
    """A deterministic MERL-shaped table: a sharp lobe in theta_h on a coloured floor."""
    from shaders.measured import MeasuredTable
    th, td, pd = np.meshgrid(np.arange(90), np.arange(90), np.arange(180), indexing="ij")
    lobe = 3.0 * np.exp(-(th / 12.0) ** 2) * (1.0 + 0.2 * np.cos(np.radians(pd)))
    floor = 0.05 + 0.02 * td / 90.0
    rgb = np.stack([floor * 3.0, floor * 2.0, floor], axis=-1) + lobe[..., None]
    return MeasuredTable.from_merl_rgb(rgb, name="synthetic-merl")


def _utia_table():
    from shaders.measured import MeasuredTable
    return MeasuredTable.from_utia(np.random.default_rng(7).uniform(0.0, 0.5, (3, 6, 48, 6, 48)), name="random-utia")


def render_set(tmp):
    """The renders both contexts make: {name: float32 HDR or uint8 image}."""
    from brdf_fit import render as cli
    from shaders import render
    from shaders.environment import PointLight
    fit = render.Material(*FIT)
    out = {
        "fit_point_lights": render.render_hdr(fit, SIZE, ibl="none", env=None, background="black",
                                              lights=[PointLight((1.5, 1.0, 2.5), (6.0, 6.0, 6.0)),
                                                      PointLight((-2.0, 0.5, 1.0), (2.0, 3.0, 4.0))]),
        "fit_split_sum": render.render_hdr(fit, SIZE),
        "gltf_split_sum": render.render_hdr(render.Material(*GLTF), SIZE),
        "merl_sampled": render.render_hdr(_merl_table(), 64, samples=8, alpha_hint=0.1, msaa=0),
        "utia_sampled": render.render_hdr(_utia_table(), 64, samples=8, alpha_hint=0.3, msaa=0),
    }
    result = pathlib.Path(tmp) / "result.json"
    result.write_text(json.dumps({"spec": FIT[0], "parameters": FIT[1], "errors": {}, "schema_version": 1}))
    png = pathlib.Path(tmp) / "cli.png"
    assert cli.render_main(result, out_path=png, size=SIZE) == cli.OK
    from matplotlib.image import imread
    out["cli_png"] = np.round(imread(png)[..., :3] * 255).astype(np.uint8)
    return out


def _subprocess_main(tmp):
    """Run in the forced 3.3 process: the renders and what the context was."""
    ctx = gl.get_context()
    out = render_set(tmp)
    np.savez(pathlib.Path(tmp) / "gl33.npz", **out)
    info = {"version_code": ctx.version_code, "gl_version": gl.gl_version(),
            "glsl_version": gl.glsl_version(), "programs": gl.PROGRAM_COUNTS,
            "renderer": ctx.info["GL_RENDERER"], "version": ctx.info["GL_VERSION"]}
    (pathlib.Path(tmp) / "gl33.json").write_text(json.dumps(info))


@pytest.fixture(scope="module")
def forced_33(tmp_path_factory):
    """(info, renders) of the subprocess on Mesa's 3.3 core context."""
    tmp = tmp_path_factory.mktemp("gl33")
    here = pathlib.Path(__file__).resolve()
    code = (f"import sys; sys.path[:0] = [{str(here.parent.parent)!r}, {str(here.parent)!r}]; "
            f"import test_shaders_gl33 as t; t._subprocess_main({str(tmp)!r})")
    env = dict(os.environ, **FORCE_33)
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    info = json.loads((tmp / "gl33.json").read_text())
    with np.load(tmp / "gl33.npz") as data:
        renders = {k: data[k] for k in data.files}
    return info, renders


@pytest.fixture(scope="module")
def reference_43(tmp_path_factory):
    """The same renders on this process's 4.3 context (compute prefilter, GLSL 4.30)."""
    if not gl.compute_available():
        pytest.skip("this process has no OpenGL 4.3 context to compare with")
    return render_set(tmp_path_factory.mktemp("gl43"))


def test_the_forced_context_is_33_and_made_no_compute_shader(forced_33):
    info, _ = forced_33
    assert info["version_code"] == 330 and info["gl_version"] == 330, info
    assert info["glsl_version"] == 330
    assert info["programs"]["compute"] == 0 and info["programs"]["render"] > 0, info


@pytest.mark.parametrize("name", ["fit_point_lights", "fit_split_sum", "gltf_split_sum",
                                  "merl_sampled", "utia_sampled"])
def test_hdr_renders_equal_the_43_path(forced_33, reference_43, name):
    from shaders import image
    a, b = reference_43[name].astype(np.float64), forced_33[1][name].astype(np.float64)
    assert a.shape == b.shape
    np.testing.assert_array_equal(a[..., 3], b[..., 3])             # the same coverage
    diff = a[..., :3] - b[..., :3]
    rmse = np.sqrt(np.mean(diff ** 2)) / np.sqrt(np.mean(a[..., :3] ** 2))
    floor = 1e-3 * np.abs(a[..., :3]).max()
    rel = np.abs(diff) / np.maximum(np.abs(a[..., :3]), floor)
    assert rmse < HDR_RMSE and rel.max() < HDR_MAX_REL, (rmse, rel.max())
    assert np.percentile(rel, 99.9) < HDR_P999_REL
    levels = np.abs(image.finish(a.astype(np.float32), "aces").astype(int)
                    - image.finish(b.astype(np.float32), "aces").astype(int))
    assert levels.max() <= SRGB_MAX_LEVELS and (levels > 0).mean() <= SRGB_FRACTION


def test_cli_png_equals_the_43_path(forced_33, reference_43):
    a, b = reference_43["cli_png"].astype(int), forced_33[1]["cli_png"].astype(int)
    levels = np.abs(a - b)
    assert a.shape == b.shape == (SIZE, SIZE, 3)
    assert levels.max() <= SRGB_MAX_LEVELS and (levels > 0).mean() <= SRGB_FRACTION


def test_fragment_prefilter_equals_the_compute_prefilter():
    """Both prefilter paths on this (4.3) context: the same texels, bit for bit."""
    from shaders import scene
    if not gl.compute_available():
        pytest.skip("no compute shaders on this context")
    env = scene.default_environment()
    a, b = scene.EnvironmentGPU(env, "compute"), scene.EnvironmentGPU(env, "fragment")
    assert a.levels == b.levels >= 4
    for level in range(a.levels):
        ta = np.frombuffer(a.prefiltered.read(level=level), np.float32)
        tb = np.frombuffer(b.prefiltered.read(level=level), np.float32)
        np.testing.assert_array_equal(ta, tb, err_msg=f"level {level}")


def test_version_cap_from_the_environment(monkeypatch):
    for text, code in (("330", 330), ("3.3", 330), ("4.3", 430), ("", None)):
        monkeypatch.setenv(gl.VERSION_ENV, text)
        assert gl.version_cap() == code
    for bad in ("2.1", "three"):
        monkeypatch.setenv(gl.VERSION_ENV, bad)
        with pytest.raises(gl.GLUnavailableError, match=gl.VERSION_ENV):
            gl.version_cap()


def test_capped_context_refuses_compute_shaders(monkeypatch):
    """BRDF_GL_VERSION=330 on a 4.x context: the 3.3 path, and no compute shader."""
    monkeypatch.setenv(gl.VERSION_ENV, "330")
    assert gl.gl_version() == 330 and not gl.compute_available() and gl.glsl_version() == 330
    before = dict(gl.PROGRAM_COUNTS)
    with pytest.raises(gl.GLUnavailableError, match="compute shaders need OpenGL 4.3"):
        gl.compute_program("#version 430\nlayout(local_size_x = 1) in;\nvoid main() { /* capped */ }")
    assert gl.PROGRAM_COUNTS == before


def test_view_runs_in_a_33_window(tmp_path):
    """``brdf-fit view``'s window on Mesa's 3.3 core context (virtual X server):
    the window asks for 4.3, falls back to 3.3, renders without compute
    shaders, and shows exactly the frame it renders (tests/viewer_window_driver.py)."""
    import shutil
    from matplotlib.image import imread
    pytest.importorskip("pyglet")
    if not shutil.which("xvfb-run"):
        pytest.skip("xvfb-run not installed (make sysdeps installs it)")
    here = pathlib.Path(__file__).resolve()
    driver = here.with_name("viewer_window_driver.py")
    code = (f"import json, runpy, sys; sys.argv = [{str(driver)!r}, {str(tmp_path)!r}]; "
            f"runpy.run_path({str(driver)!r}, run_name='__main__'); "
            "from shaders import gl; ctx = gl.get_context(); "
            f"open({str(tmp_path / 'gl.json')!r}, 'w').write(json.dumps("
            "{'version_code': ctx.version_code, 'programs': gl.PROGRAM_COUNTS}))")
    run = subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 640x480x24", sys.executable, "-c", code],
                         env=dict(os.environ, **FORCE_33), capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    info = json.loads((tmp_path / "gl.json").read_text())
    assert info["version_code"] == 330 and info["programs"]["compute"] == 0, info
    shot = imread(tmp_path / "brdf-view-000.png")
    window = imread(tmp_path / "window.png")[..., :3]
    assert shot.shape == window.shape and shot.mean() > 0.05
    np.testing.assert_allclose(window, shot, atol=1.5 / 255)     # measured: identical (as on 4.x)
