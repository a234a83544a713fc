"""The image error at the viewer's exposure (fitting.image_error.viewer_exposure):
one factor from the measured image, shared by the measured and the model image."""

import numpy as np
import pytest

from brdf import parse_model
from fitting import image_error as ie
from fitting.synthetic import synthetic_measured
from fitting.transforms import to_jax

SPEC = parse_model("ggx+lambert+f90")      # f is linear in (albedo, f0, f90): a darker copy scales them
TRUTH = {"albedo": [0.5, 0.3, 0.1], "f0": [0.04, 0.04, 0.04], "f90": 1.0, "roughness": 0.3}
MODEL = {"albedo": [0.45, 0.32, 0.12], "f0": [0.06, 0.05, 0.04], "f90": 0.9, "roughness": 0.25}


def _darker(params, k):
    return {n: (np.asarray(v) * k).tolist() if n in ("albedo", "f0", "f90") else v for n, v in params.items()}


def _errors(truth, model, exposure=None):
    measured = synthetic_measured(SPEC, truth, grid=(8, 8, 16, 1))
    target = ie.ImageTarget.from_measured(measured, size=32, exposure=exposure)
    return ie.image_error(SPEC, to_jax(SPEC, model), target)[0], float(target.exposure)


def test_a_material_and_a_copy_ten_times_darker_have_the_same_image_error():
    bright, exposure_bright = _errors(TRUTH, MODEL)
    dark, exposure_dark = _errors(_darker(TRUTH, 0.1), _darker(MODEL, 0.1))
    assert exposure_dark == pytest.approx(10 * exposure_bright, rel=1e-9)
    assert dark == pytest.approx(bright, rel=1e-9)
    assert bright > 1e-3
    # at one fixed exposure the darker copy's error is not the same
    fixed_bright = _errors(TRUTH, MODEL, ie.EXPOSURE)[0]
    fixed_dark = _errors(_darker(TRUTH, 0.1), _darker(MODEL, 0.1), ie.EXPOSURE)[0]
    assert abs(fixed_dark / fixed_bright - 1) > 0.2


def test_the_viewer_level_is_where_a_white_lambertian_sphere_sits_at_exposure_one():
    white = {"albedo": [0.8, 0.8, 0.8], "f0": [0.0, 0.0, 0.0], "f90": 0.0, "roughness": 0.5}   # Lambert only
    measured = synthetic_measured(SPEC, white, grid=(8, 8, 16, 1))
    target = ie.ImageTarget.from_measured(measured, size=ie.SIZE)
    assert float(target.exposure) == pytest.approx(1.0, abs=0.01)


def test_the_exposure_is_the_measured_images_and_the_models_image_shares_it():
    measured = synthetic_measured(SPEC, TRUTH, grid=(8, 8, 16, 1))
    target = ie.ImageTarget.from_measured(measured, size=32)
    brighter = _darker(MODEL, 3.0)          # a model 3x brighter does not bring its own exposure
    assert ie.image_error(SPEC, to_jax(SPEC, brighter), target)[0] > 5 * ie.image_error(
        SPEC, to_jax(SPEC, MODEL), target)[0] > 0


def test_image_targets_share_one_exposure_and_keep_the_fixed_one():
    measured = synthetic_measured(SPEC, _darker(TRUTH, 0.05), grid=(8, 8, 16, 1))
    targets = ie.ImageTargets.from_measured(measured)
    assert float(targets.fit.exposure) == float(targets.report.exposure) > 5.0
    assert float(targets.fixed.exposure) == ie.EXPOSURE
    np.testing.assert_array_equal(np.asarray(targets.fixed.lit), np.asarray(targets.report.lit))


def test_a_small_tables_hybrid_term_is_smaller():
    """Under SMALL_TABLE valid pairs the hybrid loss's image term is SMALL_FIT_SIZE wide (a quarter
    of FIT_SIZE's pairs: on a 636-pair table an evaluation of the hybrid loss 2.2 -> 0.7-0.95 ms,
    docs/performance.md, *Many tiny tables*), under TINY_TABLE TINY_FIT_SIZE wide (a sixteenth),
    at the report's exposure; a larger table keeps FIT_SIZE."""
    tiny = synthetic_measured(SPEC, TRUTH, grid=(8, 8, 16, 1))
    small = synthetic_measured(SPEC, TRUTH, grid=(16, 16, 32, 1))
    larger = synthetic_measured(SPEC, TRUTH, grid=(32, 32, 64, 1))
    pairs = [np.count_nonzero(m.valid) for m in (tiny, small, larger)]
    assert pairs[0] < ie.TINY_TABLE <= pairs[1] < ie.SMALL_TABLE <= pairs[2]
    assert (ie.TINY_FIT_SIZE, ie.SMALL_FIT_SIZE, ie.FIT_SIZE, ie.TINY_TABLE, ie.SMALL_TABLE) == (16, 32, 64, 2_500, 10_000)
    pixels = []
    for measured, size in ((tiny, ie.TINY_FIT_SIZE), (small, ie.SMALL_FIT_SIZE), (larger, ie.FIT_SIZE)):
        targets = ie.ImageTargets.from_measured(measured)
        same = ie.ImageTarget.from_measured(measured, size, float(targets.report.exposure))
        assert targets.fit.pixels == same.pixels and float(targets.fit.exposure) == float(targets.report.exposure)
        np.testing.assert_array_equal(np.asarray(targets.fit.target), np.asarray(same.target))
        pixels.append(targets.fit.pixels)
    assert 3.5 < ie.ImageTarget.from_measured(tiny, ie.SMALL_FIT_SIZE).pixels / pixels[0] < 4.5
    assert 3.5 < ie.ImageTarget.from_measured(small, ie.FIT_SIZE).pixels / pixels[1] < 4.5
