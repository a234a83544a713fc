"""Issue 59's second image error (benchmarks/engine_three.py's ``judge_error``), worked by hand
on a tiny image: per light exposure 1 / p99 of the measured values on the valid pixels, Reinhard
x / (1 + x), the sRGB transfer function, RMS over the valid pixels and channels, mean over lights."""

import pathlib
import sys

import numpy as np
import pytest

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "benchmarks"))

from engine_three import displayed, judge_error  # noqa: E402

# sRGB(0.5) = 1.055 * 0.5 ** (1 / 2.4) - 0.055 and sRGB(0.75): Reinhard of 1 and of 3
SRGB_HALF = 0.7353569830524495
SRGB_THREE_QUARTERS = 0.8808250210902997


def test_reinhard_then_srgb():
    x = np.array([0.0, 1.0, 3.0, 0.002])
    # 0.002 / 1.002 is below 0.0031308: the linear branch, 12.92 x
    want = [0.0, SRGB_HALF, SRGB_THREE_QUARTERS, 12.92 * 0.002 / 1.002]
    assert displayed(x) == pytest.approx(want, abs=1e-12)


def test_tiny_image_by_hand():
    # two lights, three pixels; pixel 2 is invalid under light 0 (its 1000 must change nothing)
    measured = np.array([[[1, 1, 1], [1, 1, 1], [1000, 1000, 1000]],
                         [[2, 2, 2], [2, 2, 2], [2, 2, 2]]], float)
    model = np.array([[[1, 1, 1], [1, 1, 3], [0, 0, 0]],
                      [[0, 0, 0], [0, 0, 0], [0, 0, 0]]], float)
    valid = np.array([[True, True, False], [True, True, True]])
    # light 0: exposure 1 / p99(all ones) = 1; one of 2 x 3 values differs, by sRGB(0.75) - sRGB(0.5)
    light0 = np.sqrt((SRGB_THREE_QUARTERS - SRGB_HALF) ** 2 / 6)       # 0.059387
    # light 1: exposure 1 / 2; measured Reinhard(1) everywhere, the model black
    light1 = SRGB_HALF
    assert judge_error(measured, model, valid) == pytest.approx((light0 + light1) / 2, abs=1e-12)
    assert judge_error(measured, model, valid) == pytest.approx(0.3973720, abs=1e-7)


def test_same_image_is_zero_and_exposure_follows_the_measurement():
    rng = np.random.default_rng(0)
    measured = rng.uniform(0.0, 5.0, (3, 40, 3))
    model = measured * rng.uniform(0.8, 1.25, measured.shape)
    valid = rng.uniform(size=(3, 40)) > 0.2
    assert judge_error(measured, measured, valid) == 0.0
    # a material and a copy 10x darker (both images) have the same error
    assert judge_error(measured / 10, model / 10, valid) == pytest.approx(judge_error(measured, model, valid), rel=1e-12)
    # a model twice too bright is judged too bright
    assert judge_error(measured, 2 * measured, valid) > 0.05
