"""The image error (fitting.image_error) and the hybrid loss built on it."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from brdf import parse_model
from brdf.model import evaluate
from fitting import image_error as ie
from fitting.fit import fit, prepare
from fitting.objective import HYBRID_WEIGHT, HybridSet, _plain_value_and_grad, _value_and_grad
from fitting.ranking import SECOND_WEIGHT
from fitting.synthetic import synthetic_measured
from fitting.transforms import from_params, to_jax

TRUTH = {"albedo": [0.5, 0.3, 0.1], "f0": [0.04, 0.04, 0.04], "roughness": 0.3}
MODEL = {"albedo": [0.45, 0.32, 0.12], "f0": [0.06, 0.05, 0.04], "roughness": 0.25}


def _srgb(x):
    """IEC 61966-2-1, written out for one number."""
    return 12.92 * x if x <= 0.0031308 else 1.055 * x ** (1 / 2.4) - 0.055


def _neutral(rgb, exposure=ie.EXPOSURE):
    """Khronos PBR Neutral, transcribed line by line from its GLSL listing, on one pixel."""
    r, g, b = (max(c * exposure, 0.0) for c in rgb)
    x = min(r, g, b)
    offset = x - 6.25 * x * x if x < 0.08 else 0.04
    r, g, b = r - offset, g - offset, b - offset
    peak = max(r, g, b)
    if peak >= 0.8 - 0.04:
        d = 1.0 - (0.8 - 0.04)
        new_peak = 1.0 - d * d / (peak + d - (0.8 - 0.04))
        r, g, b = (c * new_peak / peak for c in (r, g, b))
        k = 1.0 - 1.0 / (0.15 * (peak - new_peak) + 1.0)
        r, g, b = (c * (1.0 - k) + new_peak * k for c in (r, g, b))
    return [_srgb(min(max(c, 0.0), 1.0)) for c in (r, g, b)]


def _itp(srgb):
    """(I, T, P) of one sRGB pixel on a 100 cd/m^2 display, written out from ITU-R BT.2100 / BT.2124."""
    lin = [c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4 for c in srgb]
    r = 0.6274 * lin[0] + 0.3293 * lin[1] + 0.0433 * lin[2]          # BT.709 -> BT.2020 (BT.2087)
    g = 0.0691 * lin[0] + 0.9195 * lin[1] + 0.0114 * lin[2]
    b = 0.0164 * lin[0] + 0.0880 * lin[1] + 0.8956 * lin[2]
    lms = [(1688 * r + 2146 * g + 262 * b) / 4096, (683 * r + 2951 * g + 462 * b) / 4096,
           (99 * r + 309 * g + 3688 * b) / 4096]
    m1, m2 = 0.1593017578125, 78.84375
    c1, c2, c3 = 0.8359375, 18.8515625, 18.6875
    pq = []
    for x in lms:
        y = max(100.0 * x / 10000.0, 1e-12) ** m1
        pq.append(((c1 + c2 * y) / (1 + c3 * y)) ** m2)
    big_l, big_m, big_s = pq
    i = 0.5 * big_l + 0.5 * big_m
    ct = (6610 * big_l - 13613 * big_m + 7003 * big_s) / 4096
    cp = (17933 * big_l - 17390 * big_m - 543 * big_s) / 4096
    return [i, 0.5 * ct, cp]


def disc_frames(size):
    """The sphere's pixels written out, one by one: (row i from the top, column j, the normal n,
    the tangent t along the azimuth around y, the bitangent b) of each pixel centre of a size x
    size image on the unit disc -- the scene both image errors' references draw."""
    for i in range(size):
        for j in range(size):
            x, y = (j + 0.5) / size * 2 - 1, 1 - (i + 0.5) / size * 2
            if x * x + y * y >= 1.0:
                continue
            n = np.array([x, y, math.sqrt(1 - x * x - y * y)])
            t = np.cross([0.0, 1.0, 0.0], n)
            t /= np.linalg.norm(t)
            yield i, j, n, t, np.cross(n, t)


def _reference_image_error(spec, model_params, measured, size, exposure=None):
    """The scene of docs/metrics.md computed pixel by pixel in plain Python, at
    ``exposure`` (None: the viewer's, from the measured pixels' luminance)."""
    pairs, owners = [], []
    for i, j, n, t, b in disc_frames(size):
        if n[2] < math.cos(math.radians(ie.VIEW_MAX_THETA)):
            continue
        view = np.array([t[2], b[2], n[2]])
        for light, irradiance in ie.LIGHTS:
            light = np.asarray(light)
            if light @ n > 0:
                pairs.append((np.array([light @ t, light @ b, light @ n]), view, irradiance * (light @ n)))
                owners.append((i, j))
    wi = np.array([p[0] for p in pairs])
    wo = np.array([p[1] for p in pairs])
    with jax.enable_x64(True):
        f_model = np.asarray(evaluate(spec, to_jax(spec, model_params), jnp.asarray(wi), jnp.asarray(wo)))
    f_meas = measured.lookup(wi, wo)
    radiance = {"model": {}, "measured": {}}
    for (i, j), (_, _, e), fm, fd in zip(owners, pairs, f_model, f_meas):
        for name, f in (("model", fm), ("measured", fd)):
            radiance[name].setdefault((i, j), np.zeros(3))
            radiance[name][(i, j)] += e * f
    pixels = sorted(radiance["model"])
    if exposure is None:      # the 99th percentile of the measured pixels' BT.709 luminance -> 0.85
        luminance = [0.2126 * r + 0.7152 * g + 0.0722 * b for r, g, b in (radiance["measured"][p] for p in pixels)]
        exposure = 0.85 / np.percentile(luminance, 99)
    diff = np.array([np.subtract(_itp(_neutral(radiance["model"][p], exposure)),
                                 _itp(_neutral(radiance["measured"][p], exposure))) for p in pixels])
    diff *= 720.0 / ie.ITP_UNIT           # Delta E_ITP = 720 |ITP_a - ITP_b| (BT.2124)
    channels = np.sqrt(np.mean(diff ** 2, axis=0))
    return float(np.sqrt(np.sum(channels ** 2))), channels, len(pixels)


def test_image_error_equals_a_pixel_by_pixel_computation():
    spec = parse_model("ggx+lambert")
    measured = synthetic_measured(spec, TRUTH, grid=(8, 8, 16, 1))
    target = ie.ImageTarget.from_measured(measured, size=12)
    value, channels = ie.image_error(spec, to_jax(spec, MODEL), target)
    ref_value, ref_channels, ref_pixels = _reference_image_error(spec, MODEL, measured, 12)
    # every pixel with a lit light is in the reference; ImageTarget keeps the disc within 80 degrees
    assert target.pixels >= ref_pixels > 50
    np.testing.assert_allclose(channels, ref_channels, rtol=1e-10)
    assert value == pytest.approx(ref_value, rel=1e-10)
    assert value > 1e-3           # the two materials differ visibly


def test_the_truth_has_no_image_error_and_a_wrong_roughness_has_some():
    spec = parse_model("ggx+lambert")
    measured = synthetic_measured(spec, TRUTH, grid=(8, 8, 16, 1))
    target = ie.ImageTarget.from_measured(measured, size=32)
    assert ie.image_error(spec, to_jax(spec, TRUTH), target)[0] < 1e-12
    rougher = dict(TRUTH, roughness=0.35)
    assert ie.image_error(spec, to_jax(spec, rougher), target)[0] > 1e-3


def test_images_are_black_outside_the_disc_and_match_the_target():
    spec = parse_model("ggx+lambert")
    measured = synthetic_measured(spec, TRUTH, grid=(8, 8, 16, 1))
    target = ie.ImageTarget.from_measured(measured, size=32)
    meas, model = ie.images(spec, to_jax(spec, TRUTH), target, size=32)
    assert meas.shape == model.shape == (32, 32, 3)
    assert meas[0, 0].tolist() == [0.0, 0.0, 0.0]
    np.testing.assert_allclose(meas, model, atol=1e-12)
    assert meas.max() > 0.5


def test_tone_map_matches_the_scalar_listing():
    rng = np.random.default_rng(3)
    rgb = np.concatenate([rng.uniform(0, 0.1, (50, 3)), rng.uniform(0, 3, (50, 3)), rng.lognormal(0, 2, (50, 3))])
    ours = np.asarray(ie.tone_map(rgb, np))
    ref = np.array([_neutral(c) for c in rgb])
    np.testing.assert_allclose(ours, ref, atol=1e-12)


def _hybrid_data(model, params, size=24):
    spec = parse_model(model)
    measured = synthetic_measured(spec, params, noise=0.05, grid=(12, 12, 24, 1) if not spec.anisotropic
                                  else (8, 8, 16, 8))
    _, opt = prepare(measured, samples=0)
    return spec, HybridSet(opt, ie.ImageTarget.from_measured(measured, size=size), np.float64(HYBRID_WEIGHT))


@pytest.mark.parametrize("model,params", [
    ("ggx+lambert", TRUTH),
    ("ggx+lambert+clearcoat+f90", dict(TRUTH, f90=0.8, clearcoat=0.5, clearcoat_roughness=0.1)),
    ("ggx+burley+ms+clearcoat", dict(TRUTH, clearcoat=0.3, clearcoat_roughness=0.2)),
    ("ggx+frostbite+separable", TRUTH),
    ("gltf+specular+clearcoat", {"base_color": [0.5, 0.3, 0.2], "metallic": 0.3, "roughness": 0.4,
                                 "specular": 0.8, "specular_color": [1.2, 1.0, 0.9], "clearcoat": 0.4,
                                 "clearcoat_roughness": 0.2}),
    ("ggx_aniso+lambert", dict(TRUTH, anisotropy=0.5, rotation=0.3)),
])
def test_hybrid_gradient_matches_finite_differences(model, params):
    check_hybrid_gradient(*_hybrid_data(model, params), params)


def check_hybrid_gradient(spec, data, params):
    """The hybrid loss's gradient on ``data`` at 1.1 x ``params``: against central finite
    differences, and the fused path (where it applies) against jax.value_and_grad of the plain
    loss; returns (u, the loss's value_and_grad, its value at u)."""
    start = {k: (np.asarray(v) * 1.1).tolist() if k != "rotation" else v + 0.1 for k, v in params.items()}
    with jax.enable_x64(True):
        u = np.asarray(from_params(spec, start), np.float64)
        vg = _value_and_grad(spec, "hybrid")
        value, grad, _ = vg(u, data)
        h = 1e-6
        numeric = [(float(vg(u + h * e, data)[0]) - float(vg(u - h * e, data)[0])) / (2 * h)
                   for e in np.eye(u.size)]
        np.testing.assert_allclose(np.asarray(grad), numeric, rtol=2e-5, atol=1e-9)
        plain_value, plain_grad, _ = _plain_value_and_grad(spec, "hybrid")(u, data)
        np.testing.assert_allclose(float(value), float(plain_value), rtol=1e-12)
        np.testing.assert_allclose(np.asarray(grad), np.asarray(plain_grad), rtol=1e-9, atol=1e-14)
    return u, vg, float(value)


def test_hybrid_fit_recovers_the_model_and_reports_both_errors():
    spec = parse_model("ggx+lambert")
    measured = synthetic_measured(spec, TRUTH, grid=(24, 24, 48, 1))
    result = fit(measured, spec, loss="hybrid", samples=0)
    assert result.parameters["roughness"] == pytest.approx(TRUTH["roughness"], rel=0.02)
    np.testing.assert_allclose(result.parameters["albedo"], TRUTH["albedo"], rtol=0.01)
    errors = result.errors
    assert errors["loss_name"] == "hybrid"
    image_term = errors["image"] + SECOND_WEIGHT * errors["second_image"]      # docs/metrics.md
    assert errors["loss"] == pytest.approx(errors["m1"] + HYBRID_WEIGHT * image_term, rel=1e-12)
    again = ie.image_error(spec, to_jax(spec, result.parameters), ie.ImageTarget.from_measured(measured))
    assert errors["image"] == pytest.approx(again[0], rel=1e-9)
    assert errors["image_per_channel"] == pytest.approx(again[1], rel=1e-9)


def test_every_fit_reports_the_image_error():
    spec = parse_model("ggx+lambert")
    measured = synthetic_measured(spec, TRUTH, noise=0.05, grid=(12, 12, 24, 1))
    result = fit(measured, spec, samples=0)
    assert result.errors["loss_name"] == "log"
    again = ie.image_error(spec, to_jax(spec, result.parameters), ie.ImageTarget.from_measured(measured))
    assert result.errors["image"] == pytest.approx(again[0], rel=1e-9)


def test_light_pairs_are_made_once_per_size_and_read_only():
    """``light_pairs`` is kept per size (a table's fit asks for three sizes, a library's pictures
    for one each): the same arrays again, equal to a fresh computation, and read-only."""
    from fitting.image_error import _light_pairs, light_pairs
    first = light_pairs(24)
    assert all(a is b for a, b in zip(first, light_pairs(24)))
    for kept, fresh in zip(first, _light_pairs(24)):
        np.testing.assert_array_equal(kept, fresh)
        assert not kept.flags.writeable


def test_the_scene_looks_up_only_lit_pairs(monkeypatch, tmp_path):
    """``_scene`` looks the table up at the lit pairs only: the radiance and the pixel mask are
    those of every pair looked up (each unlit pair weighed by 0), bit for bit for a sample
    list (its nearest sample does not depend on the other pairs asked)."""
    from data_loaders import load
    from data_loaders.samples import write_samples
    table = synthetic_measured("ggx+lambert", {"albedo": [0.5, 0.3, 0.1], "roughness": 0.4,
                                               "f0": [0.04, 0.04, 0.04]}, grid=(8, 8, 16, 1), noise=0.02)
    keep = table.valid
    write_samples(tmp_path / "t.csv", table.wi[keep], table.wo[keep], table.values[keep], material="t",
                  isotropic=True)
    measured = load(tmp_path / "t.csv")
    index, wi, wo, lit = ie.light_pairs(24)
    every = ie._measured_lookup(measured, wi.reshape(-1, 3), wo.reshape(-1, 3)).reshape(wi.shape[:2] + (-1,))
    radiance = np.einsum("pl,plc->pc", lit, every)
    mask = (~np.any((lit > 0.0) & np.all(every == 0.0, axis=-1), axis=-1)).astype(np.float64)
    asked = []
    lookup = ie._measured_lookup
    monkeypatch.setattr(ie, "_measured_lookup", lambda m, a, b: asked.append(len(a)) or lookup(m, a, b))
    _, scene_lit, scene_radiance, scene_mask = ie._scene(measured, 24)
    assert asked == [int(np.sum(lit > 0.0))] and asked[0] < lit.size
    np.testing.assert_array_equal(scene_radiance, radiance)
    np.testing.assert_array_equal(scene_mask, mask)
