"""The gallery's spheres: smooth silhouettes (issue 62: jagged edges), the same scene.

The reference is the same picture computed at many more pixel centres and averaged
down: a thumbnail that averages 2 x 2 centres per pixel is much nearer to it along
the silhouette than one centre per pixel (RMS 8 against 37 levels of 255 here)."""

import numpy as np
import pytest

from brdf_fit.library.thumbnails import SUPERSAMPLE, sphere_pair
from fitting.result import FitResult
from fitting.synthetic import synthetic_measured

PARAMS = {"albedo": [0.5, 0.3, 0.1], "roughness": 0.4, "f0": [0.04, 0.04, 0.04]}
SIZE = 24


@pytest.fixture(scope="module")
def pictures():
    measured = synthetic_measured("ggx+lambert", PARAMS, grid=(32, 32, 64, 1))
    result = FitResult(spec="ggx+lambert", parameters=PARAMS, errors={"m1": 0.0}, optimizer={"max_theta": 80.0},
                       provenance={"file": None, "sha256": None, "format": None, "material": "t"})
    return {k: sphere_pair(measured, result, SIZE, supersample=k) for k in (1, SUPERSAMPLE, 12)}


def _error(image, reference, where):
    return float(np.sqrt(np.mean((image[where].astype(float) - reference[where].astype(float)) ** 2)))


def test_silhouettes_are_smooth(pictures):
    for which in (0, 1):                         # measured, fitted
        plain, smooth, reference = (pictures[k][which] for k in (1, SUPERSAMPLE, 12))
        background = np.all(plain == plain[0, 0], axis=-1)
        inside = ~background
        # the silhouette: the sphere's pixels with a background pixel beside them, and back
        ring = np.zeros_like(background)
        for axis in (0, 1):
            for shift in (1, -1):
                ring |= inside & np.roll(background, shift, axis)
                ring |= background & np.roll(inside, shift, axis)
        assert ring.sum() > 2 * SIZE                 # a ring of pixels round the sphere
        assert _error(smooth, reference, ring) < 0.5 * _error(plain, reference, ring)


def test_the_picture_keeps_its_light(pictures):
    """Averaging moves no light: the picture's mean is nearer the finely sampled one's than
    one centre per pixel gets (measured here: 154.8 and 145.8 against 152.2 of 255)."""
    for which in (0, 1):
        plain, smooth, reference = (pictures[k][which].astype(float).mean() for k in (1, SUPERSAMPLE, 12))
        assert abs(smooth - reference) < 0.5 * abs(plain - reference)


def test_a_material_shares_its_measured_sphere(pictures):
    """A library's pictures of one material share the table's side (``measured_sphere``, looked
    up once): the same pixels, bit for bit, as each picture making its own; one of another
    size is refused."""
    from brdf_fit.library.thumbnails import measured_sphere
    measured = synthetic_measured("ggx+lambert", PARAMS, grid=(32, 32, 64, 1))
    result = FitResult(spec="ggx+lambert", parameters=PARAMS, errors={"m1": 0.0}, optimizer={"max_theta": 80.0},
                       provenance={"file": None, "sha256": None, "format": None, "material": "t"})
    shared = measured_sphere(measured, SIZE, SUPERSAMPLE)
    for given, own in zip(sphere_pair(measured, result, SIZE, SUPERSAMPLE, target=shared),
                          pictures[SUPERSAMPLE]):
        np.testing.assert_array_equal(given, own)
    with pytest.raises(ValueError, match="pixels"):
        sphere_pair(measured, result, SIZE, SUPERSAMPLE, target=measured_sphere(measured, SIZE, 1))
