"""Golden-image tests of the preview renderer, against values derived independently.

- A Lambert sphere under one directional light (and under one point light)
  against the analytic radiance albedo/pi * E * cos, per pixel, with the
  normals of an exact ray-sphere intersection computed here in numpy.
- White furnace: uniform unit environment, GGX with F = 1 plus Kulla-Conty
  compensation and no diffuse must reflect radiance 1 at every view angle
  (within 2 %); without compensation it must not (the test can fail).
- End to end: tone mapping, PNG writing, decoding by an independent reader.
"""

import numpy as np
import pytest

from shaders.gl import gl_available

ok, reason = gl_available()
pytestmark = pytest.mark.skipif(not ok, reason=f"no OpenGL 4.3 context: {reason}")

from shaders import image, render  # noqa: E402
from shaders.environment import DirectionalLight, Environment, PointLight  # noqa: E402
from shaders.mesh import uv_sphere  # noqa: E402

SIZE = 128
# Pure Lambert: Schlick with F0 = F90 = 0 switches the specular lobe off exactly.
LAMBERT = ("ggx+lambert+f90", {"albedo": [0.6, 0.4, 0.2], "roughness": 0.5, "f0": 0.0, "f90": 0.0})


def _sphere_hits(camera, size):
    """Exact unit-sphere hits per pixel: (mask, points, normals, view cosines)."""
    d = camera.rays(size, size)
    o = np.asarray(camera.position, float)
    b = d @ o
    c = o @ o - 1.0
    disc = b * b - c
    hit = disc > 0
    t = -b - np.sqrt(np.where(hit, disc, 0.0))
    p = o + t[..., None] * d
    return hit, p, p, -(d * p).sum(-1)


# Tessellation of the sphere (128 x 64 segments): a facet lies up to
# SAGITTA = delta^2 / 8 inside the sphere (delta = pi / 64), so a camera ray
# meets it up to SAGITTA / (n.v) away from the exact hit, and the interpolated
# normal there is off by about that angle plus SAGITTA.  Per-pixel tolerance
# on a cosine: 3 SAGITTA (1 + 1 / n.v).
SAGITTA = (np.pi / 64) ** 2 / 8


def _cos_tolerance(nv):
    return 3.0 * SAGITTA * (1.0 + 1.0 / nv)


@pytest.fixture(scope="module")
def camera():
    return render.Camera.framing(uv_sphere())


def test_lambert_sphere_directional_light_follows_the_cosine(camera):
    light_dir = np.array([0.4, 0.6, 0.7])
    light_dir /= np.linalg.norm(light_dir)
    irradiance = np.array([2.0, 2.0, 2.0])
    hdr = render.render_hdr(render.Material(*LAMBERT), SIZE, camera=camera, env=None, ibl="none",
                            lights=[DirectionalLight(tuple(light_dir), tuple(irradiance))],
                            background="black", msaa=0)
    hit, _, n, nv = _sphere_hits(camera, SIZE)
    inner = hit & (nv > 0.2) & (hdr[..., 3] > 0.5)
    assert inner.sum() > 0.4 * SIZE * SIZE
    albedo = np.asarray(LAMBERT[1]["albedo"])
    expect = albedo / np.pi * irradiance * np.maximum(n @ light_dir, 0.0)[..., None]
    err = np.abs(hdr[..., :3] - expect)[inner]
    scale = albedo / np.pi * irradiance
    tol = _cos_tolerance(nv[inner])[:, None] * scale + 1e-6
    assert np.all(err <= tol), (err / tol).max()
    # and the falloff is the cosine: regression slope of L on n.l
    lit = inner & ((n @ light_dir) > 0.05)
    slope = np.polyfit((n @ light_dir)[lit], hdr[..., 0][lit], 1)
    assert slope[0] == pytest.approx(scale[0], rel=2e-3) and abs(slope[1]) < 2e-3 * scale[0]
    # the unlit side is black, the background too
    assert np.all(hdr[..., :3][inner & ((n @ light_dir) < -0.05)] == 0.0)
    assert np.all(hdr[~hit & (hdr[..., 3] == 0)][:, :3] == 0.0)


def test_lambert_sphere_point_light_inverse_square(camera):
    pos = np.array([1.5, 1.0, 2.5])
    intensity = np.array([6.0, 6.0, 6.0])
    hdr = render.render_hdr(render.Material(*LAMBERT), SIZE, camera=camera, env=None, ibl="none",
                            lights=[PointLight(tuple(pos), tuple(intensity))], background="black", msaa=0)
    hit, p, n, nv = _sphere_hits(camera, SIZE)
    inner = hit & (nv > 0.2) & (hdr[..., 3] > 0.5)
    to_light = pos - p
    d2 = (to_light ** 2).sum(-1)
    cos = np.maximum((n * to_light).sum(-1) / np.sqrt(d2), 0.0)
    albedo = np.asarray(LAMBERT[1]["albedo"])
    expect = albedo / np.pi * intensity * (cos / d2)[..., None]
    err = np.abs(hdr[..., :3] - expect)[inner]
    # the cosine tolerance, and the hit point moves by SAGITTA / n.v along d2
    scale = (albedo / np.pi * intensity)[None, :] / d2[inner][:, None]
    tol = (_cos_tolerance(nv[inner]) + 2.0 * SAGITTA / nv[inner] / np.sqrt(d2[inner]))[:, None] * scale + 1e-6
    assert np.all(err <= tol), (err / tol).max()


def _furnace(model, params, ibl, camera, samples=64):
    hdr = render.render_hdr(render.Material(model, params), SIZE, camera=camera,
                            env=Environment.uniform(1.0), lights=(), ibl=ibl, samples=samples,
                            background="black", msaa=0)
    hit, _, _, nv = _sphere_hits(camera, SIZE)
    inner = hit & (nv > 0.05) & (hdr[..., 3] > 0.5)
    lum = hdr[..., :3].mean(-1)
    # uniformity as a function of the view angle: mean radiance in 10 bins of n.v
    bins = np.clip((nv[inner] * 10).astype(int), 0, 9)
    profile = np.array([lum[inner][bins == k].mean() for k in range(10) if np.any(bins == k)])
    return lum[inner], profile


@pytest.mark.parametrize("roughness", [0.25, 0.6, 1.0])
def test_white_furnace_sampled_kulla_conty_is_uniform(roughness, camera):
    """Monte-Carlo integral of the JAX-twin BRDF (f_ss + f_ms, F = 1) under a
    uniform unit environment: 1 at every view angle, within 2 %."""
    lum, profile = _furnace("ggx+ms", {"roughness": roughness, "f0": 1.0}, "sampled", camera)
    assert abs(lum.mean() - 1.0) < 0.01, lum.mean()
    assert np.all(np.abs(profile - 1.0) < 0.02), profile
    assert np.percentile(np.abs(lum - 1.0), 95) < 0.05      # per-pixel Monte-Carlo noise


@pytest.mark.parametrize("roughness", [0.25, 0.6, 1.0])
def test_white_furnace_split_sum_fdez_aguera_is_uniform(roughness, camera):
    lum, profile = _furnace("ggx+ms", {"roughness": roughness, "f0": 1.0}, "split_sum", camera)
    assert np.all(np.abs(lum - 1.0) < 0.02), (lum.min(), lum.max())


def test_white_furnace_without_compensation_loses_energy(camera):
    """The negative control: single-scattering GGX at roughness 1 reflects
    E(mu) < 1 (REFERENCE.md s.5: E(0.5) = 0.45 at alpha = 1)."""
    lum, profile = _furnace("ggx", {"roughness": 1.0, "f0": 1.0}, "sampled", camera)
    assert lum.mean() < 0.7
    assert profile.min() < 0.5


def test_render_to_png_end_to_end(tmp_path):
    from matplotlib.image import imread
    img = render.render_material("gltf", {"base_color": [0.8, 0.2, 0.1], "metallic": 0.0, "roughness": 0.4},
                                 size=96, tonemap="aces")
    assert img.shape == (96, 96, 3) and img.dtype == np.uint8
    path = render.save_png(tmp_path / "ball.png", img)
    back = imread(path)                                    # an independent PNG decoder
    np.testing.assert_array_equal(np.round(back[..., :3] * 255).astype(np.uint8), img)
    # a lit red object on a sky: red dominates in the middle, the corners are sky
    centre = img[40:56, 40:56].reshape(-1, 3).mean(0)
    assert centre[0] > 1.5 * centre[2]
    assert img[2, 2, 2] > img[2, 2, 0]


def test_tone_maps_differ_and_keep_order():
    hdr = render.render_material("ggx+lambert", {"albedo": 0.5, "roughness": 0.3, "f0": 0.04}, size=64,
                                 linear=True)
    outs = {m: image.finish(hdr, m) for m in image.TONEMAPS}
    assert len({o.tobytes() for o in outs.values()}) == len(outs)
    lum = image.luminance(hdr).ravel()
    order = np.argsort(lum)
    for out in outs.values():
        y = image.luminance(out.astype(float)).ravel()[order]
        assert np.mean(np.diff(y) >= -3) > 0.98          # monotonic up to colour/rounding


def test_sweep_and_comparison_layout():
    sweep = render.render_sweep("gltf", values=(0.1, 0.5, 1.0), rows=("metallic", (0.0, 1.0)), size=48)
    assert sweep.shape == (48 * 2 + 2, 48 * 3 + 4, 3)
    # rougher spheres have dimmer, broader highlights: the max of each panel falls
    peaks = [sweep[:48, k * 50:k * 50 + 48].max() for k in range(3)]
    assert peaks[0] >= peaks[2]

    def measured_lookup(wi, wo):                          # a "measurement" that is Lambert 0.5
        return np.full((len(wi), 3), 0.5 / np.pi)
    params = {"albedo": [0.5, 0.5, 0.5], "roughness": 0.5, "f0": 0.0, "f90": 0.0}
    panel, data = render.render_comparison("ggx+lambert+f90", params, measured_lookup, size=64,
                                           samples=16, return_data=True)
    assert panel.shape == (64, 64 * 3 + 8, 3)
    assert data["median_difference"] < 1e-3               # same BRDF, same samples
    params["albedo"] = [0.25, 0.25, 0.25]
    _, data = render.render_comparison("ggx+lambert+f90", params, measured_lookup, size=64,
                                       samples=16, return_data=True)
    assert data["median_difference"] == pytest.approx(0.5, abs=0.01)


def test_missing_driver_message_names_the_fix(monkeypatch):
    import moderngl
    from shaders import gl

    def no_egl(**kw):
        raise Exception("libEGL.so.1: cannot open shared object file")
    monkeypatch.setattr(moderngl, "create_standalone_context", no_egl)
    with pytest.raises(gl.GLUnavailableError) as info:
        gl.create_context()
    message = str(info.value)
    assert "libEGL.so.1" in message and "apt-get install libegl1 libgl1-mesa-dri" in message


def test_measured_path_agrees_with_the_model_it_tabulates():
    """A MERL table filled (on the GPU, through the parity harness) with a model's
    own values at the cell centres, rendered as 'measured' beside the model:
    only the MERL binning separates them.  A rougher fit must stand out."""
    from shaders import parity
    from shaders.measured import MeasuredTable, merl_cell_directions
    spec, p = "ggx+lambert", {"albedo": [0.5, 0.15, 0.05], "roughness": 0.3, "f0": [0.04] * 3}
    wi, wo = merl_cell_directions()
    table = MeasuredTable.from_merl_rgb(
        parity.evaluate_model(spec, p, wi.astype(np.float32), wo.astype(np.float32)).reshape(90, 90, 180, 3))
    _, same = render.render_comparison(spec, p, table, size=96, mesh="shader_ball", samples=16, return_data=True)
    assert same["median_difference"] < 0.005 and same["mean_difference"] < 0.01
    _, off = render.render_comparison(spec, dict(p, roughness=0.45), table, size=96, mesh="shader_ball",
                                      samples=16, return_data=True)
    assert off["mean_difference"] > 5 * same["mean_difference"] and off["mean_difference"] > 0.03


@pytest.mark.parametrize("model, params", [
    ("gltf", {"base_color": [0.8, 0.3, 0.1], "metallic": 0.0, "roughness": 0.5}),
    ("gltf", {"base_color": [0.9, 0.7, 0.4], "metallic": 1.0, "roughness": 0.3}),
    ("gltf+clearcoat", {"base_color": [0.8, 0.3, 0.1], "metallic": 0.0, "roughness": 0.6,
                        "clearcoat": 1.0, "clearcoat_roughness": 0.1}),
])
def test_split_sum_agrees_with_monte_carlo_under_the_sky(model, params):
    """Two independent integrations of the same environment: the split sum
    (prefiltered mips, SH irradiance, DFG table) and Monte-Carlo sampling of
    brdf_evaluate.  A wrong lat-long mapping, prefilter or LUT orientation
    shows up as a mismatch of several ten per cent."""
    sky = Environment.sky(128)
    m = render.Material(model, params)
    a = render.render_hdr(m, 96, env=sky, lights=(), ibl="split_sum", msaa=0)
    b = render.render_hdr(m, 96, env=sky, lights=(), ibl="sampled", samples=128, msaa=0)
    mask = a[..., 3] > 0.5
    la, lb = image.luminance(a)[mask], image.luminance(b)[mask]
    assert la.mean() == pytest.approx(lb.mean(), rel=0.03)
    assert np.median(np.abs(la - lb) / lb) < 0.05


def test_released_programs_and_textures_are_made_again():
    """shaders.gl.release_cached frees every program and texture the renderer keeps (what the
    test suite does between modules: llvmpipe holds them in the process's memory); the next
    render makes them again and draws the same picture, to the bit."""
    from shaders import gl
    from shaders.measured import MeasuredTable
    sky = Environment.sky(32)
    m = render.Material("gltf", {"base_color": [0.8, 0.3, 0.1], "metallic": 0.0, "roughness": 0.5})
    table = MeasuredTable.from_merl_rgb(np.full((90, 90, 180, 3), 0.2, np.float32))
    before = render.render_hdr(m, 48, env=sky, ibl="split_sum", msaa=0)
    pair = render.render_comparison("gltf", m.params, table, size=48, samples=4)
    kept = [obj for cache in gl._CACHES for value in cache.values()
            for item in (value if isinstance(value, tuple) else (value,))
            for obj in ((item.texture, item.prefiltered) if hasattr(item, "prefiltered") else (item,))
            if hasattr(obj, "mglo")]                                        # moderngl's objects
    assert len(gl._PROGRAMS) >= 2 and len(kept) > len(gl._PROGRAMS) + 2    # programs and textures
    gl.release_cached()
    assert not any(gl._CACHES)
    assert all(type(obj.mglo).__name__ == "InvalidObject" for obj in kept)
    np.testing.assert_array_equal(render.render_hdr(m, 48, env=sky, ibl="split_sum", msaa=0), before)
    np.testing.assert_array_equal(render.render_comparison("gltf", m.params, table, size=48, samples=4), pair)
