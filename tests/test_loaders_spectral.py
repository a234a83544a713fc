"""Spectral RGL tensor files (``*_spec.bsdf``): the spectral -> linear sRGB
conversion (data_loaders.spectral, docs/colour.md) against colour-science's
own computation, the CIE tables against colour-science's copy, a synthetic
spectral file read through data_loaders.load against the RGB file that
colour-science's colours give, and the bad-input errors."""

import re
import warnings

import numpy as np
import pytest

import data_loaders as dl
from data_loaders import cie_tables, spectral
from data_loaders.rgl import write_tensor_file

GRID = dict(grid=(8, 8, 16))            # a small sample grid keeps the file tests fast

# Smooth reflectance-like spectra (functions of wavelength in nm).
SPECTRA = {
    "grey": lambda lam: 0.5 + 0.0 * lam,
    "red": lambda lam: 0.05 + 0.8 / (1.0 + np.exp(-(lam - 600.0) / 15.0)),
    "yellow": lambda lam: 0.05 + 0.8 / (1.0 + np.exp(-(lam - 510.0) / 12.0)),
    "green": lambda lam: 0.05 + 0.6 * np.exp(-0.5 * ((lam - 540.0) / 35.0) ** 2),
    "blue": lambda lam: 0.05 + 0.7 * np.exp(-0.5 * ((lam - 450.0) / 30.0) ** 2),
    "purple": lambda lam: 0.1 + 0.5 * np.cos((lam - 360.0) / 470.0 * 2.0 * np.pi) ** 2,
    "ramp": lambda lam: 0.2 + 0.6 * (lam - 360.0) / 470.0,
}
# Wavelength samplings: the 5 nm CIE grid, 10 nm over 380-780, a finer off-grid
# 360-1000 nm sampling, and the narrowest accepted range (400-700 nm at 4 nm).
SAMPLINGS = {
    "5nm": np.arange(360.0, 831.0, 5.0),
    "10nm": np.arange(380.0, 781.0, 10.0),
    "4nm-to-1000": np.linspace(360.0, 1000.0, 161),
    "400-700": np.arange(400.0, 701.0, 4.0),
}
# Measured worst case |ours - colour| / max|colour| over SPECTRA: 9e-5 (5nm),
# 2.3e-4 (10nm), 1.4e-4 (4nm-to-1000), 2.7e-4 (400-700).
TOLERANCE = 1e-3


@pytest.fixture(scope="module")
def colour():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return pytest.importorskip("colour", reason="colour-science (the dev extra) is not installed")


def colour_srgb(colour, fn):
    """colour-science's linear sRGB of a spectrum: its 1 nm CIE 1931 2-degree CMFs and
    D65, the "Integration" method (k = 100 / sum S ybar), its sRGB colourspace (no
    chromatic adaptation: D65 to D65), the spectrum given at every nm, 360-830."""
    lam = np.arange(360.0, 831.0)
    sd = colour.SpectralDistribution(dict(zip(lam, fn(lam))))
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        xyz = colour.sd_to_XYZ(sd, cmfs, colour.SDS_ILLUMINANTS["D65"], method="Integration") / 100.0
        return colour.XYZ_to_sRGB(xyz, apply_cctf_encoding=False)


# ---- the tables and the conversion -------------------------------------------------------

def test_cie_tables_against_colour_science(colour):
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    assert (cmfs.wavelengths[0], cmfs.wavelengths[-1]) == (360, 830)
    ours = np.stack([cie_tables.CIE1931_X, cie_tables.CIE1931_Y, cie_tables.CIE1931_Z], axis=1)
    np.testing.assert_allclose(ours, cmfs.values, rtol=1e-7, atol=0)
    d65 = colour.SDS_ILLUMINANTS["D65"]                   # colour-science's copy stops at 780 nm
    start = int((d65.wavelengths[0] - cie_tables.D65_START_NM) / cie_tables.D65_STEP_NM)
    np.testing.assert_allclose(cie_tables.CIE_D65[start:start + len(d65.values)], d65.values, rtol=1e-9)
    assert cie_tables.CIE_D65[(560 - cie_tables.D65_START_NM) // 5] == 100.0
    # 785-830 nm too: the CIE daylight formula (colour-science's basis functions at the
    # D65 CCT, 6504 K on today's c2), scaled to 100 at 560 nm
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        xy = colour.temperature.CCT_to_xy_CIE_D(6500.0 * 1.4388 / 1.4380)
        daylight = colour.sd_CIE_illuminant_D_series(xy)
    lam = np.arange(400, 831, 5)
    formula = np.array([daylight[x] for x in lam]) * 100.0 / daylight[560]
    ours = np.asarray(cie_tables.CIE_D65)[(lam - cie_tables.D65_START_NM) // 5]
    np.testing.assert_allclose(ours, formula, rtol=1e-3)


def test_d65_odd_entries_are_midpoints():
    """CIE's 5 nm D65 values between the 10 nm ones are linear interpolations (to
    the table's 6 significant digits): what justifies interpolating it linearly, and a
    check on the 785-830 nm values, which colour-science's copy lacks."""
    d = np.asarray(cie_tables.CIE_D65)
    np.testing.assert_allclose(d[1:-1:2], 0.5 * (d[0:-2:2] + d[2::2]), rtol=5e-6, atol=6e-5)


def test_white_reflector_and_white_point(colour):
    white = spectral.white_point()
    assert white[1] == 1.0
    xy = white[:2] / white.sum()
    np.testing.assert_allclose(xy, colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"],
                               atol=5e-5)
    for wl in SAMPLINGS.values():                         # Y = 1 and the white point, any sampling
        np.testing.assert_allclose(spectral.xyz_matrix(wl).sum(axis=1), white, rtol=1e-12)
        rgb = spectral.spectrum_to_srgb(wl, np.ones_like(wl))
        np.testing.assert_allclose(rgb, [1.00000524, 1.00007553, 0.99983148], rtol=1e-7)
    np.testing.assert_allclose(spectral.SRGB_FROM_XYZ,
                               colour.RGB_COLOURSPACES["sRGB"].matrix_XYZ_to_RGB, rtol=0, atol=0)


@pytest.mark.parametrize("sampling", sorted(SAMPLINGS))
@pytest.mark.parametrize("name", sorted(SPECTRA))
def test_conversion_matches_colour_science(colour, name, sampling):
    wl = SAMPLINGS[sampling]
    fn = SPECTRA[name]
    ours = spectral.spectrum_to_srgb(wl, fn(wl))
    ref = colour_srgb(colour, fn)
    assert np.abs(ours - ref).max() <= TOLERANCE * np.abs(ref).max(), (ours, ref)


def test_conversion_is_linear_and_batched():
    wl = SAMPLINGS["5nm"]
    a, b = SPECTRA["red"](wl), SPECTRA["blue"](wl)
    both = spectral.spectrum_to_srgb(wl, np.stack([a, b, 2 * a - 0.5 * b]))
    ra, rb = spectral.spectrum_to_srgb(wl, a), spectral.spectrum_to_srgb(wl, b)
    np.testing.assert_allclose(both, [ra, rb, 2 * ra - 0.5 * rb], rtol=1e-12, atol=1e-15)
    # samples outside 360-830 nm do not count; the CMF range ends are interpolated
    inside = np.arange(360.0, 831.0, 2.0)
    wide = np.concatenate([[300.0, 340.0], inside, [900.0, 1000.0]])
    vals = SPECTRA["purple"](inside)
    np.testing.assert_allclose(spectral.spectrum_to_srgb(wide, np.r_[7.0, 7.0, vals, 9.0, 9.0]),
                               spectral.spectrum_to_srgb(inside, vals), rtol=2e-3)


# ---- spectral tensor files ---------------------------------------------------------------

def _fields(wavelengths, spectra_fn=None, seed=0, n_theta=4, n_vndf=8, n=6):
    """A small synthetic spectral RGL file: spectra = A s1(l) + B s2(l), A, B >= 0."""
    rng = np.random.default_rng(seed)
    f32 = np.float32
    wl = np.asarray(wavelengths, f32)
    a = rng.uniform(0.1, 1.0, (1, n_theta, 1, n, n))
    b = rng.uniform(0.1, 1.0, (1, n_theta, 1, n, n))
    s1, s2 = SPECTRA["red"](wl.astype(float)), SPECTRA["ramp"](wl.astype(float))
    spectra = a * s1[None, None, :, None, None] + b * s2[None, None, :, None, None]
    fields = {
        "description": np.frombuffer(b"synthetic spectral material", dtype=np.uint8),
        "phi_i": np.zeros(1, f32),
        "theta_i": np.linspace(0.0, np.pi / 2, n_theta).astype(f32),
        "sigma": rng.uniform(0.5, 1.0, (2, n_vndf)).astype(f32),
        "ndf": rng.uniform(0.1, 1.0, (2, n_vndf)).astype(f32),
        "vndf": rng.uniform(0.1, 1.0, (1, n_theta, n_vndf, n_vndf)).astype(f32),
        "luminance": rng.uniform(0.1, 1.0, (1, n_theta, n, n)).astype(f32),
        "wavelengths": wl,
        "spectra": spectra.astype(f32),
        "jacobian": np.ones(1, np.uint8),
    }
    return fields, (a, b)


def test_spectral_file_reads_like_the_rgb_file_colour_science_gives(tmp_path, colour):
    wl = np.arange(360.0, 831.0, 5.0)
    fields, (a, b) = _fields(wl)
    spec_path = tmp_path / "synthetic_spec.bsdf"
    write_tensor_file(spec_path, fields)
    assert dl.detect_format(spec_path) == "rgl"
    m = dl.load(spec_path, **GRID)

    # The same material as an RGB file, its colours computed by colour-science.
    rgb1, rgb2 = colour_srgb(colour, SPECTRA["red"]), colour_srgb(colour, SPECTRA["ramp"])
    rgb_fields = {k: v for k, v in fields.items() if k not in ("spectra", "wavelengths")}
    rgb_fields["rgb"] = (a * rgb1[None, None, :, None, None]
                         + b * rgb2[None, None, :, None, None]).astype(np.float32)
    rgb_path = tmp_path / "synthetic_rgb.bsdf"
    write_tensor_file(rgb_path, rgb_fields)
    r = dl.load(rgb_path, **GRID)

    np.testing.assert_array_equal(m.wi, r.wi)
    assert m.n_valid > 0 and np.array_equal(m.valid, r.valid)
    scale = np.abs(r.values).max(axis=1, keepdims=True)
    assert np.all(np.abs(m.values - r.values) <= TOLERANCE * scale)
    assert np.all(m.values >= 0.0) and np.isfinite(m.values).all()

    prov = m.provenance
    assert prov.format == "rgl" and prov.material == "synthetic"
    assert prov.description == "synthetic spectral material"
    assert "converted from spectral (95 wavelengths, 360-830 nm)" in prov.units
    assert "CIE 1931 2-degree" in prov.units and "D65" in prov.units
    assert "spectral" not in r.provenance.units


def test_spectral_table_is_the_converted_rgb_table(tmp_path):
    """The wavelength axis is axis 2 of ``spectra``: the table holds srgb_matrix @ spectra there."""
    wl = np.linspace(380.0, 780.0, 81)
    fields, _ = _fields(wl, seed=3)
    path = tmp_path / "axis_spec.bsdf"
    write_tensor_file(path, fields)
    m = dl.read_rgl(path, **GRID)
    expected = np.einsum("ck,ptkij->ptcij", spectral.srgb_matrix(wl.astype(np.float32)),
                         fields["spectra"].astype(np.float64))
    np.testing.assert_allclose(m.table.rgb.reshape(expected.shape), expected, rtol=1e-6)


def _write(tmp_path, fields, name="bad_spec.bsdf"):
    path = tmp_path / name
    write_tensor_file(path, fields)
    return path


WL5 = np.arange(360.0, 831.0, 5.0)


@pytest.mark.parametrize("change, message", [
    (lambda f: f.pop("wavelengths"), "lacks the field(s) wavelengths"),
    (lambda f: f.pop("spectra"), "lacks the field(s) spectra"),
    (lambda f: f.update(wavelengths=f["wavelengths"].astype(np.float64)), "wavelengths must be f32[n]"),
    (lambda f: f.update(wavelengths=f["wavelengths"][::-1].copy()), "strictly increasing"),
    (lambda f: f.update(wavelengths=np.where(np.arange(95) == 40, np.nan, f["wavelengths"]).astype(np.float32)),
     "'wavelengths' has NaN"),
    (lambda f: f.update(wavelengths=(f["wavelengths"] + 60.0).astype(np.float32)), "covers 420-890 nm"),
    (lambda f: f.update(wavelengths=np.where(np.arange(95) == 40, 555.0, f["wavelengths"]).astype(np.float32)),
     "strictly increasing"),
    (lambda f: f.update(wavelengths=f["wavelengths"][:94].copy()), "f32[1, 4, 94, N, N]"),
    (lambda f: f.update(spectra=f["spectra"][:, :, :, :5, :5].copy()), "differ in their last two"),
    (lambda f: f.update(spectra=f["spectra"].astype(np.float64)), "spectra must be f32"),
    (lambda f: f["spectra"].__setitem__((0, 1, 2, 3, 4), np.inf), "'spectra' has 1 NaN or inf"),
])
def test_bad_spectral_files_name_the_problem(tmp_path, change, message):
    fields, _ = _fields(WL5)
    change(fields)
    path = _write(tmp_path, fields)
    with pytest.raises(dl.MeasuredDataError, match=re.escape(message)) as info:
        dl.load(path, **GRID)
    assert str(path) in str(info.value)


def test_sparse_wavelengths_are_refused(tmp_path):
    wl = np.r_[np.arange(380.0, 500.0, 5.0), np.arange(520.0, 781.0, 5.0)]
    fields, _ = _fields(wl)
    with pytest.raises(dl.MeasuredDataError, match="no sample between 495 and 520 nm"):
        dl.load(_write(tmp_path, fields), **GRID)


def test_truncated_spectral_file(tmp_path):
    fields, _ = _fields(WL5)
    data = _write(tmp_path, fields, "full_spec.bsdf").read_bytes()
    path = tmp_path / "cut_spec.bsdf"
    path.write_bytes(data[:len(data) - 100])       # spectra is the last big field
    with pytest.raises(dl.MeasuredDataError, match="truncated or corrupt tensor file"):
        dl.load(path, **GRID)
