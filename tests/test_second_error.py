"""Issue 59's second image error (fitting.second_error): the judges' numpy form, the fit's JAX
form, and the hybrid loss with it beside the image error (``Pictures``)."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from brdf import parse_model
from brdf.model import evaluate, evaluate_geometry
from fitting import image_error as ie
from fitting import second_error as se
from fitting.objective import HybridSet
from fitting.fit import prepare
from fitting.synthetic import synthetic_measured
from fitting.transforms import to_jax
from test_image_error import check_hybrid_gradient, disc_frames

TRUTH = {"albedo": [0.5, 0.3, 0.1], "f0": [0.04, 0.04, 0.04], "roughness": 0.3}
MODEL = {"albedo": [0.45, 0.32, 0.12], "f0": [0.06, 0.05, 0.04], "roughness": 0.25}


def _displayed(x):
    """Reinhard, then IEC 61966-2-1's sRGB, written out for one number."""
    y = max(x, 0.0) / (1.0 + max(x, 0.0))
    return 12.92 * y if y <= 0.0031308 else 1.055 * y ** (1 / 2.4) - 0.055


def _reference_second_error(spec, params, measured, size):
    """Issue 59's definition pixel by pixel in plain Python: per light from +x at 30, 60 and 85
    degrees, each lit pixel's f cos(theta_i) in its local frame (tangent along the azimuth
    around y), exposure 1 / the 99th percentile of the measured values, Reinhard, sRGB, the
    RMS over the lit pixels and channels; the mean over the lights."""
    errors = []
    for elevation in (30.0, 60.0, 85.0):
        e = math.radians(elevation)
        light = np.array([math.cos(e), 0.0, math.sin(e)])
        wi, wo, cos = [], [], []
        for _, _, n, t, b in disc_frames(size):
            if light @ n <= 0.0:
                continue
            wi.append([light @ t, light @ b, light @ n])
            wo.append([t[2], b[2], n[2]])
            cos.append(light @ n)
        wi, wo, cos = np.array(wi), np.array(wo), np.array(cos)
        with jax.enable_x64(True):
            f_model = np.asarray(evaluate(spec, to_jax(spec, params), jnp.asarray(wi), jnp.asarray(wo)))
        measured_values = measured.lookup(wi, wo) * cos[:, None]
        model_values = f_model * cos[:, None]
        exposure = 1.0 / np.percentile(measured_values, 99)
        d = [_displayed(a * exposure) - _displayed(m * exposure)
             for a, m in zip(model_values.ravel(), measured_values.ravel())]
        errors.append(math.sqrt(np.mean(np.square(d))))
    return float(np.mean(errors))


@pytest.fixture(scope="module")
def measured():
    return synthetic_measured(parse_model("ggx+lambert"), TRUTH, grid=(8, 8, 16, 1))


def test_second_error_equals_a_pixel_by_pixel_computation(measured):
    spec = parse_model("ggx+lambert")
    reference = _reference_second_error(spec, MODEL, measured, 16)
    target = se.SecondTarget.from_measured(measured, 16)
    with jax.enable_x64(True):
        value = float(se.second_value(evaluate_geometry(spec, to_jax(spec, MODEL), target.geo), target))
    assert value == pytest.approx(reference, rel=1e-10)
    assert value > 1e-3           # the two materials differ visibly
    # the judges' numpy form on the images of the same scene
    _, _, wi, wo, cos_i = se.scene_pairs(16)
    meas, valid = se.measured_images(measured, wi, wo, cos_i)
    with jax.enable_x64(True):
        model = np.asarray(evaluate(spec, to_jax(spec, MODEL), jnp.asarray(wi), jnp.asarray(wo))) * cos_i[..., None]
    assert se.judge_error(meas, np.where(valid[..., None], model, 0.0), valid) == pytest.approx(reference, rel=1e-10)


def test_pictures_weigh_the_second_error_into_the_image_term_and_report_both(measured):
    spec = parse_model("ggx+lambert")
    image = ie.ImageTarget.from_measured(measured, size=16)
    both = se.Pictures.of(image, measured, 16, 2.0)
    params = to_jax(spec, MODEL)
    alone, channels = ie.image_error(spec, params, image)
    with jax.enable_x64(True):
        second = float(se.second_value(evaluate_geometry(spec, params, both.second.geo), both.second))
        term = float(ie.image_channels(spec, params, both)[0])
    assert term == pytest.approx(alone + 2.0 * second, rel=1e-12)        # what the hybrid loss minimises
    reported = se.picture_errors(spec, params, both)
    assert reported["image"] == pytest.approx(alone, rel=1e-12)
    assert reported["image_per_channel"] == pytest.approx(channels, rel=1e-12)
    assert reported["second_image"] == pytest.approx(second, rel=1e-12)
    assert "second_image" not in se.picture_errors(spec, params, image)


@pytest.mark.parametrize("model,params", [
    ("ggx+lambert+clearcoat+f90", dict(TRUTH, f90=0.8, clearcoat=0.5, clearcoat_roughness=0.1)),   # the fused sums
    ("ggx_aniso+lambert", dict(TRUTH, anisotropy=0.5, rotation=0.3)),                              # jax.grad
])
def test_the_hybrid_gradient_with_the_second_error_matches_finite_differences(model, params):
    spec = parse_model(model)
    table = synthetic_measured(spec, params, noise=0.05, grid=(12, 12, 24, 1) if not spec.anisotropic
                               else (8, 8, 16, 8))
    _, opt = prepare(table, samples=0)
    scene = se.Pictures.of(ie.ImageTarget.from_measured(table, size=24), table, 24, 1.0)
    data = HybridSet(opt, scene, np.float64(0.5))
    u, vg, value = check_hybrid_gradient(spec, data, params)
    with jax.enable_x64(True):
        # the second error is in the loss: its weight changes the value
        lighter = float(vg(u, data._replace(image=scene._replace(weight=jnp.asarray(0.0))))[0])
        assert value - lighter > 1e-4


def test_a_fit_weighing_the_second_error_reports_it_and_ranks_by_both(monkeypatch):
    """BRDF_SECOND_WEIGHT (ranking.SECOND_WEIGHT): the fit records the second image error of its
    parameters (an independent evaluation on the 128-pixel scene), its loss and ranking error weigh it."""
    from fitting import ranking
    from fitting.fit import fit
    monkeypatch.setattr(ranking, "SECOND_WEIGHT", 1.0)
    spec = parse_model("ggx+lambert")
    table = synthetic_measured(spec, TRUTH, noise=0.05, grid=(12, 12, 24, 1))
    result = fit(table, spec, loss="hybrid", samples=0)
    errors = result.errors
    target = se.SecondTarget.from_measured(table, 128)
    with jax.enable_x64(True):
        second = float(se.second_value(evaluate_geometry(spec, to_jax(spec, result.parameters), target.geo), target))
    assert errors["second_image"] == pytest.approx(second, rel=1e-9) and second > 0.0
    assert errors["loss"] == pytest.approx(
        errors["m1"] + 0.5 * (errors["image"] + errors["second_image"]), rel=1e-12)
    assert ranking.ranking_error(errors) == pytest.approx(
        errors["m1"] + ranking.IMAGE_WEIGHT * (errors["image"] + errors["second_image"]), rel=1e-12)
    assert "(image" in ranking.ranking_terms(errors) and "second" in ranking.ranking_terms(errors)
    assert result.optimizer["options"]["second_weight"] == 1.0


def test_a_batch_resumes_only_results_fitted_with_the_same_weight(monkeypatch):
    """The weight is one of the fit options a batch or library compares before it resumes a
    result (brdf_fit.batch.folder.finished): results fitted without the second error (older ones,
    BRDF_SECOND_WEIGHT=0) are fitted again rather than ranked beside those that weigh it."""
    import types
    from brdf_fit.batch.folder import finished
    from brdf_fit.batch.task import _options
    from fitting import ranking
    monkeypatch.setattr(ranking, "SECOND_WEIGHT", 0.0)
    plain = _options({})
    monkeypatch.setattr(ranking, "SECOND_WEIGHT", 1.0)
    weighed = _options({})
    assert "second_weight" not in plain and weighed == {**plain, "second_weight": 1.0}
    older = types.SimpleNamespace(provenance={"sha256": "abc"}, optimizer={"options": plain})
    assert finished(older, "abc", weighed) is None and finished(older, "abc", plain) is older


def test_the_material_page_shows_the_second_error_where_the_fits_weighed_it():
    from brdf_fit.library.material_page import _errors_table
    from fitting.result import FitResult

    def result(errors):
        return FitResult(spec="gltf", parameters={"base_color": [0.5, 0.5, 0.5], "metallic": 0.0, "roughness": 0.5},
                         errors={"m1": 0.01, "image": 0.02, "exported_m1": 0.01, "exported_image": 0.02, **errors},
                         optimizer={"max_theta": 80.0}, provenance={"file": None, "sha256": None, "format": None,
                                                                     "material": "m"})
    plain = result({})
    assert "second image error" not in _errors_table([("a.json", plain)], plain)
    weighed = result({"second_image": 0.0123, "exported_second_image": 0.0456})
    page = _errors_table([("a.json", weighed)], weighed)
    assert "<th>second image error</th><th>glTF second image error</th>" in page
    assert 'data-value="0.0123"' in page and 'data-value="0.0456"' in page


@pytest.mark.parametrize("value", ["heavy", "-1"])
def test_a_weight_that_is_not_a_number_at_least_0_is_one_line(value):
    """BRDF_SECOND_WEIGHT set to anything but a finite number >= 0: one line naming the variable
    and its value, exit 1, no traceback (any program importing the toolkit)."""
    import os
    import subprocess
    import sys
    res = subprocess.run([sys.executable, "-c", "import fitting.ranking"], capture_output=True, text=True,
                         env={**os.environ, "BRDF_SECOND_WEIGHT": value}, timeout=120)
    assert res.returncode == 1
    assert res.stderr.strip().splitlines() == [
        f"error: BRDF_SECOND_WEIGHT={value!r}: the second image error's weight must be a number at least 0 "
        "(1 by default, 0 turns it off; docs/metrics.md)"]


def test_the_fits_second_scene_is_no_wider_than_its_image_term():
    """with_second: the fit's second scene FIT_SIZE (32) pixels wide, a tiny table's as its image
    term (image_error.TINY_FIT_SIZE, 16); the screening of a small table takes the fit's own
    term, the one object (fitting.screen.ScreenScene), a larger table's its own 32-pixel scenes."""
    from fitting.screen import SCREEN_IMAGE, ScreenScene
    spec = parse_model("ggx+lambert")
    for grid, size in (((8, 8, 16, 1), ie.TINY_FIT_SIZE), ((16, 16, 32, 1), se.FIT_SIZE),
                       ((32, 32, 64, 1), se.FIT_SIZE)):
        table = synthetic_measured(spec, TRUTH, grid=grid)
        image = se.with_second(ie.ImageTargets.from_measured(table), table, 1.0)
        alone = se.SecondTarget.from_measured(table, size)
        np.testing.assert_array_equal(np.asarray(image.fit.second.cos), np.asarray(alone.cos))
        np.testing.assert_array_equal(np.asarray(image.fit.second.reference), np.asarray(alone.reference))
        scene = ScreenScene.from_measured(table, prepare(table)[1], image)
        if ie.fit_size(table) <= SCREEN_IMAGE:
            assert scene.fit_image is image.fit
        else:
            assert scene.fit_image.pixels == ie.ImageTarget.from_measured(table, SCREEN_IMAGE).pixels
            np.testing.assert_array_equal(np.asarray(scene.fit_image.second.cos),
                                          np.asarray(se.SecondTarget.from_measured(table, SCREEN_IMAGE).cos))
