"""Bad input: each case raises MeasuredDataError naming the file and the problem;
``brdf-fit info`` / ``eval`` print the message and exit 2 without a traceback."""

import os
import subprocess
import sys

import numpy as np
import pytest

import data_loaders as dl
from data_loaders import merl, utia
from data_loaders.directions import spherical_to_dir
from brdf_fit.cli import main as brdf_fit

from conftest import ROOT


def _merl_bytes(dims=(90, 90, 180), raw=None):
    if raw is None:
        raw = np.full(3 * merl.MERL_CELLS, 100.0)
    return np.array(dims, dtype="<i4").tobytes() + np.asarray(raw, dtype="<f8").tobytes()


def _expect(path, *phrases, **options):
    with pytest.raises(dl.MeasuredDataError) as info:
        dl.load(path, **options)
    message = str(info.value)
    assert str(path) in message
    for phrase in phrases:
        assert phrase in message, message
    return message


def test_missing_file(tmp_path):
    _expect(tmp_path / "nope.binary", "no such file")


def test_empty_file(tmp_path):
    path = tmp_path / "empty.binary"
    path.write_bytes(b"")
    _expect(path, "empty file")


def test_directory(tmp_path):
    _expect(tmp_path, "directory")


def test_truncated_merl(tmp_path):
    path = tmp_path / "short.binary"
    path.write_bytes(_merl_bytes()[:-8000])
    _expect(path, "34,984,012 bytes", "34,992,012")


def test_merl_header_with_wrong_dims(tmp_path):
    path = tmp_path / "dims.binary"
    path.write_bytes(_merl_bytes(dims=(90, 90, 360), raw=np.zeros(10)))
    _expect(path, "header dims are (90, 90, 360)")


def test_merl_nan_and_inf(tmp_path):
    raw = np.full(3 * merl.MERL_CELLS, 100.0)
    raw[[5, 77]] = np.nan
    raw[1000] = np.inf
    path = tmp_path / "nan.binary"
    path.write_bytes(_merl_bytes(raw=raw))
    _expect(path, "3 values are NaN or inf")


def test_merl_all_invalid(tmp_path):
    path = tmp_path / "invalid.binary"
    path.write_bytes(_merl_bytes(raw=np.full(3 * merl.MERL_CELLS, -1.0)))
    _expect(path, "all-invalid")


def test_utia_wrong_size(tmp_path):
    path = tmp_path / "m001.bin"
    path.write_bytes(np.zeros(1000).tobytes())
    _expect(path, "8,000 bytes", "1,990,656")


def test_utia_nan_and_all_invalid(tmp_path):
    data = np.ones(utia.UTIA_SHAPE)
    data[1, 2, 3, 4, 5] = np.nan
    path = tmp_path / "nan.bin"
    dl.write_utia(path, data)
    _expect(path, "1 values are NaN or inf")
    dl.write_utia(path, -np.ones(utia.UTIA_SHAPE))
    _expect(path, "all-invalid")
    with pytest.warns(dl.MeasuredDataWarning, match="all values are zero"):
        assert dl.load(path, units="dj_brdf").valid.all()      # dj_brdf clamps negatives to 0


@pytest.fixture
def tensor_fields(rgl_dir):
    fields, _ = dl.read_tensor_file(rgl_dir / "paper_white_rgb.bsdf")
    return dict(fields)


def test_tensor_wrong_magic(tmp_path, rgl_dir):
    data = bytearray((rgl_dir / "paper_white_rgb.bsdf").read_bytes())
    data[:12] = b"tensor_fill\0"
    path = tmp_path / "magic.bsdf"
    path.write_bytes(bytes(data))
    _expect(path, "magic")


def test_tensor_missing_field(tmp_path, tensor_fields):
    del tensor_fields["ndf"]
    path = tmp_path / "nondf.bsdf"
    dl.write_tensor_file(path, tensor_fields)
    _expect(path, "lacks the field(s) ndf")


def test_tensor_truncated(tmp_path, rgl_dir):
    data = (rgl_dir / "paper_white_rgb.bsdf").read_bytes()
    path = tmp_path / "cut.bsdf"
    path.write_bytes(data[:-500])
    _expect(path, "truncated", "'valid'")
    path.write_bytes(data[:100])
    _expect(path, "truncated")


def test_tensor_nan_and_bad_shape(tmp_path, tensor_fields):
    rgb = tensor_fields["rgb"].copy()
    rgb[0, 3, 1, 5, 5] = np.nan
    path = tmp_path / "nan.bsdf"
    dl.write_tensor_file(path, dict(tensor_fields, rgb=rgb))
    _expect(path, "field 'rgb' has 1 NaN or inf")
    dl.write_tensor_file(path, dict(tensor_fields, rgb=rgb[:, :, :2]))
    _expect(path, "inconsistent", "rgb must be")


def _write_csv(path, text):
    path.write_text(text)
    return path


def test_csv_missing_column(tmp_path):
    path = _write_csv(tmp_path / "cols.csv", "# units: degrees\ntheta_i,phi_i,theta_o,phi_o,r,g\n1,2,3,4,5,6\n")
    _expect(path, "missing column(s) b")


def test_csv_non_numeric_text(tmp_path):
    path = _write_csv(tmp_path / "text.csv",
                      "# units: degrees\ntheta_i,phi_i,theta_o,phi_o,r,g,b\n10,0,20,0,0.1,0.2,0.3\n"
                      "10,0,20,0,0.1,abc,0.3\n")
    _expect(path, "line 4, column 'g'", "'abc' is not a number")


def test_csv_nan_inf_and_ranges(tmp_path):
    head = "# units: degrees\ntheta_i,phi_i,theta_o,phi_o,r,g,b\n"
    path = _write_csv(tmp_path / "nan.csv", head + "10,0,20,0,0.1,0.2,0.3\n10,0,20,0,nan,0.2,0.3\n")
    _expect(path, "line 4, column 'r'", "NaN or inf")
    path = _write_csv(tmp_path / "inf.csv", head + "10,0,20,inf,0.1,0.2,0.3\n")
    _expect(path, "column 'phi_o'", "NaN or inf")
    path = _write_csv(tmp_path / "range.csv", head + "95,0,20,0,0.1,0.2,0.3\n")
    _expect(path, "line 3, column 'theta_i'", "outside [0, 90 degrees]")
    path = _write_csv(tmp_path / "ragged.csv", head + "10,0,20,0,0.1,0.2\n")
    _expect(path, "line 3: 6 fields")
    path = _write_csv(tmp_path / "allbad.csv", head + "10,0,20,0,-0.1,0.2,0.3\n")
    _expect(path, "all-invalid")
    path = _write_csv(tmp_path / "units.csv", "# units: furlongs\n" + head[17:] + "10,0,20,0,1,1,1\n")
    _expect(path, "'furlongs'")


def test_npz_problems(tmp_path):
    n = 4
    cols = {k: np.full(n, 0.3) for k in ("theta_i", "phi_i", "theta_o", "phi_o", "r", "g", "b")}
    path = tmp_path / "s.npz"
    np.savez(path, **{k: v for k, v in cols.items() if k != "b"}, units=np.array("radians"))
    _expect(path, "missing array(s) b")
    np.savez(path, **dict(cols, g=np.array(["a", "b", "c", "d"])), units=np.array("radians"))
    _expect(path, "'g' is not numeric")
    np.savez(path, **dict(cols, r=np.array([0.1, np.nan, 0.2, 0.3])), units=np.array("radians"))
    _expect(path, "sample 1, column 'r'", "NaN")
    np.savez(path, **cols)
    _expect(path, "units are not stated")
    np.savez(path, **cols, units=np.array("radians"), extra=np.array([{"a": 1}], dtype=object))
    _expect(path, "not a readable NPZ")                      # pickles are refused


def test_unknown_binary(tmp_path):
    path = tmp_path / "mystery.dat"
    path.write_bytes(bytes(range(256)) * 10)
    _expect(path, "unrecognised file")


# ---- the command line --------------------------------------------------------------------

def test_info_error_exit_code(tmp_path, capsys):
    path = tmp_path / "short.binary"
    path.write_bytes(_merl_bytes()[:1000])
    assert brdf_fit(["info", str(path)]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and "1,000 bytes" in err and "Traceback" not in err


def test_info_subprocess_no_traceback(tmp_path):
    path = tmp_path / "empty.bin"
    path.write_bytes(b"")
    res = subprocess.run([sys.executable, "-m", "brdf_fit.cli", "info", str(path)],
                         capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert res.returncode == 2
    assert f"{path}: empty file" in res.stderr and "Traceback" not in res.stderr


def test_info_and_eval_success(tmp_path, capsys):
    data = np.random.default_rng(0).uniform(0, 1, utia.UTIA_SHAPE)
    table = tmp_path / "m.bin"
    dl.write_utia(table, data)
    assert brdf_fit(["info", str(table)]) == 0
    out = capsys.readouterr().out
    assert "utia" in out and "82,944" in out
    rng = np.random.default_rng(1)
    wi = spherical_to_dir(rng.uniform(0, 1.4, 50), rng.uniform(-3, 3, 50))
    wo = spherical_to_dir(rng.uniform(0, 1.4, 50), rng.uniform(-3, 3, 50))
    dirs = tmp_path / "dirs.npy"
    np.save(dirs, np.concatenate([wi, wo], axis=1).astype(np.float32))
    result = tmp_path / "out.npy"
    assert brdf_fit(["eval", str(table), str(dirs), str(result)]) == 0
    got = np.load(result)
    assert got.dtype == np.float64 and got.shape == (50, 3)
    np.testing.assert_allclose(got, dl.load(table).lookup(wi.astype(np.float32), wo.astype(np.float32)))


def test_eval_bad_arrays(tmp_path, capsys):
    table = tmp_path / "m.bin"
    dl.write_utia(table, np.ones(utia.UTIA_SHAPE))
    out = tmp_path / "out.npy"
    cases = {"shape": np.zeros((4, 5)), "nan": np.array([[0, 0, 1, 0, 0, np.nan]]),
             "zero": np.array([[0, 0, 0, 0, 0, 1.0]]), "text": np.array(["a", "b"])}
    for name, array in cases.items():
        path = tmp_path / f"{name}.npy"
        np.save(path, array)
        assert brdf_fit(["eval", str(table), str(path), str(out)]) == 2, name
        err = capsys.readouterr().err
        assert str(path) in err and "Traceback" not in err
    assert not out.exists()
    assert brdf_fit(["eval", str(tmp_path / "fit.json"), str(path), str(out)]) == 2
    assert f"{tmp_path / 'fit.json'}: cannot read" in capsys.readouterr().err
    assert brdf_fit(["eval", str(tmp_path / "missing.bin"), str(tmp_path / "shape.npy"), str(out)]) == 2
    assert "no such file" in capsys.readouterr().err
    assert not os.path.exists(out)
