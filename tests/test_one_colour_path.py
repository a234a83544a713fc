"""One colour path (issue 62): a material looks the same in the gallery and in the report.

blue-acrylic was bright blue in the library's gallery and dark navy on its report page: the
gallery's spheres (brdf_fit.library.thumbnails, the image error's scene) are exposed by the
viewer's rule (fitting.image_error.viewer_exposure) and tone-mapped by Khronos PBR Neutral,
the report's lit spheres were ACES at exposure 1.  Now both take the rule and PBR Neutral.

The two scenes keep their own lights (four white lights; the sky and its sun), so their
pictures are not the same pixels.  What must be the same is the colour the rule brings a
material to: the rule sets the 99th percentile of the measured picture's luminance to 0.85,
and a Lambertian surface under white light has one chromaticity everywhere, so the pixel at
that percentile is 0.85 x albedo / Y(albedo) through the tone map in either picture.
"""

import types

import numpy as np
import pytest

from brdf_fit.demo import abc_brdf
from brdf_fit.library.thumbnails import sphere_pair
from brdf_fit.render import DISPLAY_TONEMAP, viewer_exposure
from data_loaders import load
from data_loaders.merl import MERL_SHAPE, write_merl
from fitting.image_error import VIEWER_LEVEL, displayed, srgb_encode
from fitting.synthetic import half_diff_grid
from shaders import image

ALBEDO = (0.011106, 0.035057, 0.104254)   # blue-acrylic's diffuse (brdf_fit.demo.ABC_FITS): dark blue
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
# sRGB levels of 255 the colours at the reference level may differ from the expected one by:
# the pictures are rounded to 8 bits (half a level), and the pixel nearest the percentile sits
# within a pixel's luminance step of it (measured: both within 0.3 of a level here)
TOLERANCE = 1


@pytest.fixture(scope="module")
def lambertian(tmp_path_factory):
    """A MERL table of a Lambertian surface of ALBEDO (the demo's ABC model without its lobe)."""
    wi, wo, _ = half_diff_grid(*MERL_SHAPE, 1)
    valid = (wi[:, 2] > 0) & (wo[:, 2] > 0)
    rgb = abc_brdf(wi, wo, kd=ALBEDO, a=(0.0, 0.0, 0.0), b=1.0, c=1.0, ior=1.5)
    path = tmp_path_factory.mktemp("colour") / "blue-lambert.binary"
    write_merl(path, rgb.reshape(MERL_SHAPE + (3,)), valid.reshape(MERL_SHAPE))
    return load(path)


def _at_reference_level(pixels):
    """The sRGB colour (0-255) of the pixel whose luminance is the 99th percentile's."""
    pixels = np.asarray(pixels, np.float64).reshape(-1, 3)
    y = image.srgb_decode(pixels / 255.0) @ LUMINANCE
    return pixels[np.argmin(np.abs(y - np.percentile(y, 99.0)))]


def test_the_preview_tone_map_is_the_image_errors():
    """shaders.image's pbr_neutral is fitting.image_error's tone map (a twin, as the GLSL is)."""
    x = np.random.default_rng(0).lognormal(-1.0, 2.0, (4000, 3))
    x[:20] = 0.0
    for exposure in (1.0, 9.5):
        np.testing.assert_allclose(image.tonemap(x, "pbr_neutral", exposure), displayed(x, np, exposure),
                                   atol=1e-12)


def test_gallery_and_report_show_one_colour(lambertian):
    from shaders.environment import Environment
    from shaders.render import render_comparison
    result = types.SimpleNamespace(spec="gltf", parameters={"base_color": list(ALBEDO), "metallic": 0.0,
                                                            "roughness": 1.0})
    gallery, _ = sphere_pair(lambertian, result, size=64, supersample=1)     # no edge blended with the grey
    inside = np.any(gallery != gallery[0, 0], axis=-1)
    size = 96
    panels, data = render_comparison("gltf", result.parameters, lambertian, size=size, env=Environment.uniform(1.0),
                                     tonemap=DISPLAY_TONEMAP, exposure=viewer_exposure, return_data=True)
    report = panels[:, :size][data["mask"]]
    expected = 255 * srgb_encode(displayed(VIEWER_LEVEL * np.array(ALBEDO) / (LUMINANCE @ ALBEDO), np), np)
    np.testing.assert_allclose(_at_reference_level(gallery[inside]), expected, atol=TOLERANCE)
    np.testing.assert_allclose(_at_reference_level(report), expected, atol=TOLERANCE)
    # at exposure 1 and ACES (the report's pictures before) the same surface was dark navy
    before = 255 * image.srgb_encode(image.tonemap(data["measured"][..., :3][data["mask"]], "aces", 1.0))
    assert np.max(_at_reference_level(before)) < 0.5 * np.max(expected)


def test_the_reports_spheres_take_the_rule(lambertian, tmp_path):
    """The report's lit spheres (the default sky) are exposed by the rule on their measured
    picture and tone-mapped by PBR Neutral: the PNG's measured panel is exactly that."""
    from brdf_fit.report.pages import RENDER_SIZE, _renders
    from fitting.result import FitResult
    from shaders.annotate import HEADER
    from PIL import Image
    result = FitResult(spec="gltf", parameters={"base_color": list(ALBEDO), "metallic": 0.0, "roughness": 1.0},
                       errors={"m1": 0.0}, optimizer={"max_theta": 80.0},
                       provenance={"file": None, "sha256": None, "format": None, "material": "t"})
    out, note = _renders("t", [(None, result)], lambertian, tmp_path, "t")
    assert note is None and len(out) == 1
    name, _, data = out[0]
    assert data["exposure"] == pytest.approx(viewer_exposure(data["measured"], data["mask"]), rel=1e-12)
    assert data["exposure"] > 5.0           # a dark material brought up, as the gallery brings it
    panel = np.asarray(Image.open(tmp_path / name).convert("RGB"))[HEADER:HEADER + RENDER_SIZE, :RENDER_SIZE, :3]
    np.testing.assert_array_equal(panel, image.finish(data["measured"], DISPLAY_TONEMAP, data["exposure"]))


def test_the_sky_behind_a_brought_up_material_stays_at_exposure_1():
    """A render with its coverage (shaders.render.render_hdr's fourth channel): the object is
    exposed, the background is not, a silhouette pixel half covered halfway between."""
    rng = np.random.default_rng(1)
    hdr = np.concatenate([rng.lognormal(-2.0, 1.0, (6, 6, 3)), np.zeros((6, 6, 1))], axis=-1)
    hdr[:2, :, 3] = 1.0                     # the object
    hdr[2, :, 3] = 0.5                      # its silhouette
    exposure = 7.2                          # blue-acrylic's
    out = image.finish(hdr, DISPLAY_TONEMAP, exposure)
    rgb = hdr[..., :3]
    np.testing.assert_array_equal(out[:2], image.to_uint8(displayed(rgb[:2], np, exposure)))
    np.testing.assert_array_equal(out[3:], image.to_uint8(displayed(rgb[3:], np, 1.0)))
    np.testing.assert_array_equal(out[2], image.to_uint8(displayed(rgb[2], np, (1.0 + exposure) / 2)))
    # a picture without coverage is exposed as a whole, as before
    np.testing.assert_array_equal(image.finish(rgb, DISPLAY_TONEMAP, exposure),
                                  image.to_uint8(displayed(rgb, np, exposure)))
