"""A sample list whose values are 1e300 times a plausible BRDF is odd but readable:
every command that reads it goes on with the loader's one warning line, and
no raw numpy RuntimeWarning.  ``render --measured`` used to stop with "the
merl table has NaN or inf values" (the GPU's float32 table overflowed) where
``fit``, ``info`` and ``export`` accept the file; now the measured panel is
white (display white) and the difference 100 %.
"""

import numpy as np
import pytest

from brdf_fit.cli import main
from shaders import image
from shaders.measured import FLOAT32_MAX, MeasuredTable
from shaders.render import relative_difference

from test_cli_corpus import FAST, _samples

SCALE = 1e300       # the case: finite in float64, far beyond float32 (3.4e38)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    root = tmp_path_factory.mktemp("extreme")
    good = _samples(root / "good.npz")
    assert main(["fit", str(good), "--out", str(root / "results"), *FAST]) == 0
    return dict(root=root, result=root / "results" / "good.ggx+lambert.json",
                big=_samples(root / "big.csv", scale=SCALE))


def _argv(command, f, out):
    return {
        "info": ["info", f["big"]],
        "fit": ["fit", f["big"], "--out", out / "fits", *FAST],
        "export": ["export", f["result"], "--measured", f["big"], "--out", out / "x.glb"],
        "render": ["render", "-q", f["result"], "--measured", f["big"], "--out", out / "x.png", "--size", "128"],
    }[command]


@pytest.mark.parametrize("command", ["info", "fit", "export", "render"])
def test_values_1e300_warn_once_and_go_on(files, tmp_path, capfd, command):
    if command == "render":
        from shaders.gl import gl_available
        if not gl_available():
            pytest.skip("no OpenGL here")
    code = main([str(a) for a in _argv(command, files, tmp_path)])
    err = capfd.readouterr().err
    assert code == 0, err
    assert "RuntimeWarning" not in err and "Traceback" not in err, err
    lines = err.strip().splitlines()
    if command == "render":                 # compared against another file than the fitted one: said
        assert lines.pop() == (f"brdf-fit render: warning: {files['big']}: the measured file differs from "
                               "the one the fit was made on (sha256); the comparison shows another measurement")
    assert len(lines) == 1, err             # the loader's warning, nothing else
    assert lines[0].startswith(f"brdf-fit {command}: warning: {files['big']}: values up to "), err
    assert lines[0].endswith("1/sr of any measured BRDF (wrong units or scale?)"), err
    if command == "render":
        assert (tmp_path / "x.png").stat().st_size > 0


def test_the_gpu_table_holds_huge_finite_values_at_float32s_largest():
    values = np.zeros((90 * 90 * 180, 3))
    values[0] = [SCALE, 1.0, -SCALE]
    with np.errstate(all="raise"):           # no overflow in the cast
        table = MeasuredTable("merl", values)
    assert table.values.dtype == np.float32
    assert table.values[0].tolist() == [FLOAT32_MAX, 1.0, -FLOAT32_MAX]
    values[1, 1] = np.inf
    with pytest.raises(ValueError, match="NaN or inf"):       # non-finite input is still refused
        MeasuredTable("merl", values)


def test_an_overflowed_render_is_display_white_and_100_percent_off():
    hdr = np.ones((2, 2, 4), np.float32)
    hdr[0, 0, :3] = np.inf
    hdr[0, 1, :3] = np.nan
    with np.errstate(all="raise"):
        out = image.finish(hdr)
        diff, mask = relative_difference(hdr, np.ones((2, 2, 4), np.float32))
    assert out[0, 0].tolist() == [255, 255, 255]        # inf: white
    assert out[0, 1].tolist() == [0, 0, 0]              # NaN: black
    assert out[1, 1].tolist() == image.finish(np.ones((1, 1, 4)))[0, 0].tolist()
    assert diff[0, 0] == 1.0 and diff[1, 1] == 0.0
