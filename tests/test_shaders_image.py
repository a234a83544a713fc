"""Image plumbing of the renderer (no GL needed): Radiance HDR files, tone
curves, sRGB, PNG, environments and SH irradiance, meshes."""

import io

import numpy as np
import pytest

from shaders import environment, hdr, image, mesh


# --- Radiance HDR -------------------------------------------------------------------

def _rng_image(h, w, seed=0):
    rng = np.random.default_rng(seed)
    img = np.exp(rng.normal(0.0, 2.0, (h, w, 3))).astype(np.float32)
    img[0, :5] = 0.0                        # zeros
    img[1, :20] = [3.0, 2.0, 1.0]           # a run (RLE)
    return img


@pytest.mark.parametrize("rle", [True, False])
def test_hdr_round_trip(tmp_path, rle):
    img = _rng_image(17, 40)
    path = tmp_path / "x.hdr"
    hdr.write_hdr(path, img, rle=rle)
    back = hdr.read_hdr(path)
    assert back.shape == img.shape
    # RGBE keeps 8 mantissa bits of the largest channel
    err = np.abs(back - img).max(axis=-1)
    assert np.all(err <= img.max(axis=-1) / 128 + 1e-30)
    if rle:
        assert path.stat().st_size < 17 * 40 * 4 + 200 + 17 * 4 * 4


def test_hdr_rle_bytes_by_hand(tmp_path):
    """A new-RLE scanline written byte by byte: runs and literals per channel."""
    width = 8
    line = bytes([2, 2, 0, width])
    line += bytes([128 + 8, 128])                     # R: run of 8 x 128
    line += bytes([4, 0, 64, 128, 255, 128 + 4, 32])  # G: 4 literals, run of 4
    line += bytes([128 + 8, 0])                       # B: 0
    line += bytes([128 + 8, 129])                     # E: 129 -> scale 2^(129-136)
    data = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 8\n" + line
    path = tmp_path / "hand.hdr"
    path.write_bytes(data)
    img = hdr.read_hdr(path)
    scale = 2.0 ** (129 - 136)
    np.testing.assert_allclose(img[0, :, 0], 128 * scale)
    np.testing.assert_allclose(img[0, :, 1], np.array([0, 64, 128, 255, 32, 32, 32, 32]) * scale)
    assert np.all(img[0, :, 2] == 0)


def test_hdr_flat_old_rle_orientation_and_exposure(tmp_path):
    px = lambda r, g, b, e: bytes([r, g, b, e])
    # 2 x 3 image stored bottom-up (+Y), flat pixels, an old-style repeat, EXPOSURE=2
    rows = [px(10, 0, 0, 128) + px(1, 1, 1, 2),           # row 0 of file: 10 then repeat x2
            px(0, 20, 0, 128) + px(0, 30, 0, 128) + px(0, 40, 0, 128)]
    data = b"#?RADIANCE\nEXPOSURE=2\n\n+Y 2 +X 3\n" + b"".join(rows)
    path = tmp_path / "old.hdr"
    path.write_bytes(data)
    img = hdr.read_hdr(path)
    s = 2.0 ** (128 - 136) / 2.0
    np.testing.assert_allclose(img[1, :, 0], [10 * s] * 3)       # +Y: the first stored row is the bottom
    np.testing.assert_allclose(img[0, :, 1], [20 * s, 30 * s, 40 * s])


@pytest.mark.parametrize("content, message", [
    (b"P6\n", "signature"),
    (b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n\0\0\0\0", "xyze"),
    (b"#?RADIANCE\n\n-Y 2 +X 8\n" + bytes([2, 2, 0, 8, 136, 1]), "ends inside"),
    (b"#?RADIANCE\n\nbogus\n", "resolution"),
])
def test_hdr_bad_files_name_the_problem(tmp_path, content, message):
    path = tmp_path / "bad.hdr"
    path.write_bytes(content)
    with pytest.raises(hdr.HDRFormatError, match=message) as info:
        hdr.read_hdr(path)
    assert str(path) in str(info.value)


def test_hdr_missing_file():
    with pytest.raises(hdr.HDRFormatError, match="cannot read"):
        hdr.read_hdr("/nonexistent/env.hdr")


# --- tone mapping, sRGB, PNG ----------------------------------------------------------

def test_tone_curves_reference_points():
    assert image.tonemap(np.array([1.0, 1.0, 1.0]), "reinhard")[0] == pytest.approx(0.5)
    assert image.tonemap(np.array([4.0] * 3), "reinhard", white=4.0)[0] == pytest.approx(1.0)
    # Hable: the white point maps to 1 (x * exposure bias 2 = W)
    assert image.tonemap(np.array([image.HABLE_WHITE / 2] * 3), "uncharted2")[0] == pytest.approx(1.0)
    # Narkowicz ACES at 1: 2.54 / 3.16
    assert image.tonemap(np.array([1.0] * 3), "aces_narkowicz")[0] == pytest.approx(2.54 / 3.16)
    # Hill's fit: grey stays grey (matrices nearly row-normalised), 0 -> ~0, saturates below 1
    aces = image.tonemap(np.array([[0.0] * 3, [0.18] * 3, [1.0] * 3, [100.0] * 3]), "aces")
    assert aces[0].max() < 1e-3 and np.ptp(aces[1]) < 2e-3 and np.all(np.diff(aces[:, 0]) > 0)
    assert 0.95 < aces[3, 0] <= 1.0
    with pytest.raises(ValueError, match="unknown tone map"):
        image.tonemap(np.zeros(3), "filmic")


def test_srgb_transfer_function():
    assert image.srgb_encode(0.0031308) == pytest.approx(0.04045, abs=1e-5)
    assert image.srgb_encode(1.0) == pytest.approx(1.0)
    assert image.srgb_encode(0.18) == pytest.approx(0.46135, abs=1e-4)
    x = np.linspace(0, 1, 101)
    np.testing.assert_allclose(image.srgb_decode(image.srgb_encode(x)), x, atol=1e-12)


def test_png_writer(tmp_path):
    from PIL import Image
    img = np.random.default_rng(0).integers(0, 256, (7, 11, 3), dtype=np.uint8)
    data = image.png_bytes(img)
    assert data.startswith(b"\x89PNG\r\n\x1a\n")
    np.testing.assert_array_equal(np.asarray(Image.open(io.BytesIO(data))), img)
    path = image.write_png(tmp_path / "x.png", img)
    np.testing.assert_array_equal(np.asarray(Image.open(path)), img)
    grey = img[..., 0]
    np.testing.assert_array_equal(np.asarray(Image.open(io.BytesIO(image.png_bytes(grey)))), grey)
    with pytest.raises(ValueError, match="uint8"):
        image.png_bytes(img.astype(float))


def test_false_colour_masks_background():
    out = image.false_colour(np.array([[0.0, 1.0], [0.5, 2.0]]), 1.0, mask=np.array([[True, True], [True, False]]))
    assert out.shape == (2, 2, 3) and np.all(out[1, 1] == 0) and out[0, 1].sum() > out[0, 0].sum()


# --- environments, SH ---------------------------------------------------------------------

def test_equirect_mapping_round_trip():
    d, omega = environment.equirect_directions(32, 64)
    assert omega.sum() == pytest.approx(4 * np.pi, rel=2e-3)
    v, u = environment.direction_to_equirect(d, 32, 64)
    np.testing.assert_allclose(v, np.arange(32)[:, None] + 0.5 + 0 * u, atol=1e-9)
    np.testing.assert_allclose(u, np.arange(64)[None, :] + 0.5 + 0 * v, atol=1e-9)
    assert d[0, 0, 1] > 0.99                      # top row looks up (+y)


def test_sh_irradiance_of_uniform_and_cosine_skies():
    env = environment.Environment.uniform(1.0, height=64)
    coeffs = environment.sh_irradiance_coefficients(env.radiance)
    for n in ([0, 1, 0], [1, 0, 0], [0, 0.6, -0.8]):
        np.testing.assert_allclose(environment.sh_evaluate(coeffs, np.array(n, float)), np.pi, rtol=2e-3)
    # L = max(0, d.y): E(up) = 2 pi / 3, E(down) = 0 up to the band limit
    d, _ = environment.equirect_directions(128, 256)
    rad = np.repeat(np.maximum(d[..., 1], 0.0)[..., None], 3, axis=-1)
    coeffs = environment.sh_irradiance_coefficients(rad)
    assert environment.sh_evaluate(coeffs, np.array([0.0, 1.0, 0.0]))[0] == pytest.approx(2 * np.pi / 3, rel=0.03)
    assert abs(environment.sh_evaluate(coeffs, np.array([0.0, -1.0, 0.0]))[0]) < 0.1


def test_sun_extraction_keeps_the_energy():
    h, w = 64, 128
    env = environment.Environment.uniform(0.2, height=h).radiance.copy()
    d, omega = environment.equirect_directions(h, w)
    sun = environment.direction_from_angles(40.0, 30.0)
    spot = (d @ sun) > np.cos(np.radians(4.0))
    env[spot] = 500.0
    total = (env * omega[..., None]).sum(axis=(0, 1))
    out = environment.Environment.from_array(env, extract_sun=True)
    assert len(out.lights) == 1
    light = out.lights[0]
    assert np.degrees(np.arccos(np.clip(light.unit_direction @ sun, -1, 1))) < 1.0
    kept = (out.radiance * omega[..., None]).sum(axis=(0, 1))
    np.testing.assert_allclose(kept + np.asarray(light.irradiance), total, rtol=1e-5)
    assert environment.Environment.from_array(environment.Environment.uniform().radiance,
                                              extract_sun=True).lights == ()


def test_generated_environments_are_finite_and_lit():
    for env in (environment.Environment.sky(64), environment.Environment.studio(64)):
        assert env.radiance.shape == (64, 128, 3) and np.all(np.isfinite(env.radiance))
        assert env.radiance.min() >= 0 and env.radiance.max() > 0.5
    sky = environment.Environment.sky(64)
    assert sky.lights and sky.lights[0].unit_direction[1] > 0        # the sun is above the horizon


# --- meshes ----------------------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(mesh.MESHES))
def test_meshes_have_unit_orthogonal_frames(name):
    m = mesh.MESHES[name]()
    np.testing.assert_allclose(np.linalg.norm(m.normals, axis=1), 1.0, atol=1e-5)
    np.testing.assert_allclose(np.linalg.norm(m.tangents, axis=1), 1.0, atol=1e-5)
    assert np.abs((m.normals * m.tangents).sum(1)).max() < 1e-5
    assert m.indices.max() < len(m.positions)
    if name == "sphere":
        np.testing.assert_allclose(m.normals, m.positions, atol=1e-5)   # exact sphere normals
