"""OpenEXR environment maps (shaders/exr.py, Environment.from_file): files written
here with the OpenEXR package read back to the written arrays, .hdr and .exr of
the same data give the same Environment (and the same render), and bad files
give one-line HDRFormatErrors naming the file, as bad .hdr files do."""

import struct
import sys

import numpy as np
import pytest

OpenEXR = pytest.importorskip("OpenEXR", reason="the OpenEXR package (a dependency) is not installed")

from shaders import exr  # noqa: E402
from shaders.environment import Environment, read_environment_image  # noqa: E402
from shaders.hdr import HDRFormatError, read_hdr, write_hdr  # noqa: E402


def _image(height=16, width=32, seed=0):
    """A lat-long test map: smooth sky, per-pixel noise, rows and columns all different."""
    rng = np.random.default_rng(seed)
    v = np.linspace(0.0, 1.0, height)[:, None, None]
    u = np.linspace(0.0, 1.0, width)[None, :, None]
    base = 0.2 + 1.5 * v + 0.5 * u * np.array([1.0, 0.8, 0.6])
    return (base * rng.uniform(0.5, 1.5, (height, width, 3))).astype(np.float32)


def _write_with_openexr(path, channels, header=None):
    """Write an EXR with the OpenEXR package itself (not shaders.exr's writer)."""
    header = dict({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}, **(header or {}))
    with OpenEXR.File(header, channels) as f:
        f.write(str(path))
    return path


def _rgb_channels(img, dtype=np.float32):
    return {c: np.ascontiguousarray(img[..., k].astype(dtype)) for k, c in enumerate("RGB")}


# ---- reading what the OpenEXR package wrote -----------------------------------------------

@pytest.mark.parametrize("dtype", [np.float32, np.float16])
@pytest.mark.parametrize("compression", ["NO_COMPRESSION", "ZIP_COMPRESSION", "PIZ_COMPRESSION"])
def test_read_back_separate_channels(tmp_path, dtype, compression):
    img = _image()
    path = _write_with_openexr(tmp_path / "map.exr", _rgb_channels(img, dtype),
                               {"compression": getattr(OpenEXR, compression)})
    got = exr.read_exr(path)
    assert got.dtype == np.float32 and got.shape == img.shape
    np.testing.assert_array_equal(got, img.astype(dtype).astype(np.float32))   # exact, half too


def test_read_back_interleaved_rgb_rgba_and_tiled(tmp_path):
    img = _image(20, 40, seed=1)
    np.testing.assert_array_equal(exr.read_exr(_write_with_openexr(tmp_path / "rgb.exr", {"RGB": img})), img)
    rgba = np.concatenate([img, np.full(img.shape[:2] + (1,), 0.5, np.float32)], axis=-1)
    np.testing.assert_array_equal(exr.read_exr(_write_with_openexr(tmp_path / "rgba.exr", {"RGBA": rgba})), img)
    tiles = OpenEXR.TileDescription()
    tiles.xSize, tiles.ySize, tiles.mode = 16, 8, OpenEXR.ONE_LEVEL
    path = _write_with_openexr(tmp_path / "tiled.exr", _rgb_channels(img),
                               {"type": OpenEXR.tiledimage, "tiles": tiles})
    assert exr.read_exr_header(path)["tiled"]
    np.testing.assert_array_equal(exr.read_exr(path), img)
    path = _write_with_openexr(tmp_path / "latlong.exr", {"RGB": img}, {"envmap": OpenEXR.ENVMAP_LATLONG})
    np.testing.assert_array_equal(Environment.from_file(path, extract_sun=False).radiance, img)


def test_own_writer_round_trip(tmp_path):
    img = _image(8, 16, seed=2)
    exr.write_exr(tmp_path / "f.exr", img)
    np.testing.assert_array_equal(exr.read_exr(tmp_path / "f.exr"), img)
    exr.write_exr(tmp_path / "h.exr", img, half=True)
    with OpenEXR.File(str(tmp_path / "h.exr"), separate_channels=True) as f:
        assert f.channels()["R"].pixels.dtype == np.float16
    np.testing.assert_array_equal(exr.read_exr(tmp_path / "h.exr"), img.astype(np.float16).astype(np.float32))
    assert [p.name for p in tmp_path.iterdir()] and not list(tmp_path.glob("*.tmp"))


# ---- .hdr and .exr of the same data --------------------------------------------------------

def _sun_map(tmp_path):
    """A sky with a small very bright sun: Environment pulls it out as a DirectionalLight.
    Returned as RGBE-quantised values, so the .hdr and the .exr hold the same numbers."""
    img = _image(32, 64, seed=3)
    img[9:11, 40:42] = [4000.0, 3600.0, 3000.0]
    write_hdr(tmp_path / "sky.hdr", img)
    quantised = read_hdr(tmp_path / "sky.hdr")
    _write_with_openexr(tmp_path / "sky.exr", _rgb_channels(quantised))
    return quantised


def test_hdr_and_exr_give_the_same_environment(tmp_path):
    quantised = _sun_map(tmp_path)
    np.testing.assert_array_equal(read_environment_image(tmp_path / "sky.exr"), quantised)
    for extract_sun in (True, False):
        a = Environment.from_file(tmp_path / "sky.hdr", extract_sun=extract_sun)
        b = Environment.from_file(tmp_path / "sky.exr", extract_sun=extract_sun)
        np.testing.assert_array_equal(a.radiance, b.radiance)
        assert a.lights == b.lights and len(a.lights) == int(extract_sun)
    # from_hdr (what shaders.render uses for a path) takes .exr too; the name does not matter
    (tmp_path / "renamed.hdr").write_bytes((tmp_path / "sky.exr").read_bytes())
    np.testing.assert_array_equal(Environment.from_hdr(tmp_path / "renamed.hdr").radiance,
                                  Environment.from_file(tmp_path / "sky.hdr").radiance)


def test_render_main_same_image_from_hdr_and_exr(tmp_path):
    from shaders.gl import gl_available
    ok, reason = gl_available()
    if not ok:
        pytest.skip(f"no OpenGL 4.3 context: {reason}")
    import json
    from brdf_fit import render as cli
    from matplotlib.image import imread
    _sun_map(tmp_path)
    result = tmp_path / "result.json"
    result.write_text(json.dumps({"spec": "ggx+lambert", "schema_version": 1, "errors": {},
                                  "parameters": {"albedo": [0.6, 0.3, 0.2], "roughness": 0.35,
                                                 "f0": [0.04, 0.04, 0.04]}}))
    images = {}
    for ext in ("hdr", "exr"):
        out = tmp_path / f"{ext}.png"
        assert cli.render_main(result, env_path=tmp_path / f"sky.{ext}", out_path=out, size=48) == cli.OK
        images[ext] = imread(out)
    assert images["hdr"].std() > 0
    np.testing.assert_array_equal(images["hdr"], images["exr"])


# ---- bad files: one-line HDRFormatErrors naming the file -------------------------------------

def _expect_error(path, message):
    with pytest.raises(HDRFormatError, match=message) as info:
        Environment.from_file(path)
    text = str(info.value)
    assert text.startswith(f"{path}: ") and "\n" not in text
    return text


def test_truncated_files(tmp_path, capfd):
    path = _write_with_openexr(tmp_path / "full.exr", _rgb_channels(_image()))
    data = path.read_bytes()
    cut = tmp_path / "cut.exr"
    for n in sorted(set(range(4, len(data), 53)) | {8, len(data) - 1}):
        cut.write_bytes(data[:n])
        _expect_error(cut, "truncated|corrupt")
    out, err = capfd.readouterr()
    assert out == "" and err == ""                 # the library's own messages were caught


@pytest.mark.parametrize("make, message", [
    (lambda p: p.write_bytes(b"nope, not an image"), "neither a Radiance .hdr"),
    (lambda p: p.write_bytes(b"v/1"), "neither"),
    (lambda p: _write_with_openexr(p, {"Y": np.ones((4, 8), np.float32)}), r"no R/G/B channel \(channels: Y\)"),
    (lambda p: _write_with_openexr(p, {"R": np.ones((4, 8), np.float32), "G": np.ones((4, 8), np.float32)}),
     "no B channel"),
    (lambda p: _write_with_openexr(p, _rgb_channels(np.ones((4, 8, 3)), np.uint32)), "channel R is uint"),
    (lambda p: _write_with_openexr(p, {"RGB": np.ones((4, 8, 3), np.float32)}, {"envmap": OpenEXR.ENVMAP_CUBE}),
     "cube map"),
    (lambda p: _write_with_openexr(
        p, {"RGB": np.ones((4, 8, 3), np.float32)},
        {"dataWindow": (np.array([2, 0], np.int32), np.array([9, 3], np.int32)),
         "displayWindow": (np.array([0, 0], np.int32), np.array([9, 3], np.int32))}), "differs from the display"),
    (lambda p: OpenEXR.File([OpenEXR.Part({"type": OpenEXR.scanlineimage}, {"RGB": np.ones((4, 8, 3), np.float32)},
                                          name=n) for n in "ab"]).write(str(p)), "multi-part"),
])
def test_unusable_files(tmp_path, make, message):
    path = tmp_path / "bad.exr"
    make(path)
    _expect_error(path, message)


@pytest.mark.parametrize("value, dtype, message", [
    (np.nan, np.float32, "1 NaN or infinite pixel values"),
    (np.inf, np.float16, "1 NaN or infinite pixel values"),
    (-0.25, np.float32, r"1 negative pixel values \(down to -0.25\)"),
    (-2.0, np.float16, r"negative pixel values \(down to -2\)"),
])
def test_non_finite_and_negative_pixels(tmp_path, value, dtype, message):
    img = _image(8, 16)
    img[3, 5, 1] = value
    path = _write_with_openexr(tmp_path / "bad.exr", _rgb_channels(img, dtype))
    _expect_error(path, message)


def test_huge_declared_size_is_refused_before_reading(tmp_path):
    data = bytearray(_write_with_openexr(tmp_path / "ok.exr", {"RGB": np.ones((4, 8, 3), np.float32)}).read_bytes())
    for name in (b"dataWindow\0box2i\0", b"displayWindow\0box2i\0"):
        at = data.index(name) + len(name) + 4
        struct.pack_into("<4i", data, at, 0, 0, 99_999, 49_999)
    path = tmp_path / "huge.exr"
    path.write_bytes(bytes(data))
    _expect_error(path, "100,000 x 50,000 pixels is larger than supported")


def test_missing_file_and_missing_package(tmp_path, monkeypatch):
    _expect_error(tmp_path / "absent.exr", "cannot read the file")
    path = _write_with_openexr(tmp_path / "ok.exr", {"RGB": np.ones((4, 8, 3), np.float32)})
    monkeypatch.setitem(sys.modules, "OpenEXR", None)          # import OpenEXR now fails
    _expect_error(path, r"needs the OpenEXR package \(pip install OpenEXR\)")


def test_render_main_bad_exr_is_one_line(tmp_path, capfd):
    from brdf_fit import render as cli
    path = _write_with_openexr(tmp_path / "env.exr", _rgb_channels(_image()))
    (tmp_path / "cut.exr").write_bytes(path.read_bytes()[:-200])
    result = tmp_path / "result.json"
    result.write_text('{"spec": "ggx+lambert", "schema_version": 1, "errors": {}, "parameters": '
                      '{"albedo": [0.5, 0.5, 0.5], "roughness": 0.5, "f0": [0.04, 0.04, 0.04]}}')
    status = cli.render_main(result, env_path=tmp_path / "cut.exr", out_path=tmp_path / "x.png", size=32)
    out, err = capfd.readouterr()
    assert status == cli.BAD_INPUT and not (tmp_path / "x.png").exists()
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "cut.exr" in lines[0] and "corrupt or truncated OpenEXR" in lines[0]
    assert "Traceback" not in err and "Warning" not in out
