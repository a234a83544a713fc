"""MERL .binary: index maths (REFERENCE.md s.8 ref values), weights, round trip,
lookups, and tables generated from the NBRDF networks in ../shared."""

import importlib.util
import re

import numpy as np
import pytest

import data_loaders as dl
from data_loaders import merl
from data_loaders.directions import spherical_to_dir

from conftest import MERL_TOOL, NBRDF_NPZ

# REFERENCE.md s.8: (theta_i, phi_i, theta_o, phi_o) deg -> (theta_h, phi_h, theta_d, phi_d) deg,
# (i_th, i_td, i_pd), flat index
REFS = [
    ((30, 0, 45, 90), (28.833235, 54.735610, 26.119378, -111.978376), (50, 26, 68), 814748),
    ((60, 45, 20, 250), (21.755171, 30.428584, 39.190591, 20.169638), (44, 39, 20), 719840),
    ((70, 300, 15, 100), (28.226216, -52.756672, 42.077918, -10.183323), (50, 42, 169), 817729),
]


def _dirs(ti, pi_, to, po):
    return (spherical_to_dir(np.radians(ti), np.radians(pi_)),
            spherical_to_dir(np.radians(to), np.radians(po)))


@pytest.mark.parametrize("angles, half_diff, cell, flat", REFS)
def test_half_diff_reference_values(angles, half_diff, cell, flat):
    wi, wo = _dirs(*angles)
    got = np.degrees(dl.std_to_half_diff(wi, wo))
    np.testing.assert_allclose(got, half_diff, atol=2e-6)
    i_th, i_td, i_pd, i = dl.merl_index(*np.radians([half_diff[0], half_diff[2], half_diff[3]]))
    assert (int(i_th), int(i_td), int(i_pd)) == cell
    assert int(i) == flat
    wi2, wo2 = dl.half_diff_to_std(*np.radians(half_diff))
    np.testing.assert_allclose(wi2, wi, atol=1e-6)
    np.testing.assert_allclose(wo2, wo, atol=1e-6)


def test_half_diff_round_trip_random():
    rng = np.random.default_rng(3)
    wi = spherical_to_dir(rng.uniform(0, np.pi / 2, 1000), rng.uniform(-np.pi, np.pi, 1000))
    wo = spherical_to_dir(rng.uniform(0, np.pi / 2, 1000), rng.uniform(-np.pi, np.pi, 1000))
    wi2, wo2 = dl.half_diff_to_std(*dl.std_to_half_diff(wi, wo))
    np.testing.assert_allclose(wi2, wi, atol=1e-12)
    np.testing.assert_allclose(wo2, wo, atol=1e-12)


def test_cell_weights_sum_to_hemisphere_pair_measure():
    w = merl.cell_weights()
    assert w.shape == (90, 90, 180)
    np.testing.assert_allclose(w.sum(), (2 * np.pi) ** 2, rtol=1e-12)


def test_cell_centres_map_back_to_their_cells():
    th, td, pd = merl.cell_centres()
    cells = np.arange(0, merl.MERL_CELLS, 3)
    i, j, k = np.unravel_index(cells, (90, 90, 180))
    wi, wo = dl.half_diff_to_std(th[i], 0 * th[i], td[j], pd[k])
    theta_h, _, theta_d, phi_d = dl.std_to_half_diff(wi, wo)
    np.testing.assert_array_equal(dl.merl_index(theta_h, theta_d, phi_d)[3], cells)


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    """A random MERL table with some unmeasured cells, written with write_merl."""
    rng = np.random.default_rng(0)
    rgb = rng.uniform(0.0, 5.0, (90, 90, 180, 3))
    valid = rng.random((90, 90, 180)) > 0.1
    path = tmp_path_factory.mktemp("merl") / "synthetic.binary"
    dl.write_merl(path, rgb, valid)
    return path, rgb, valid


def test_the_horizon_mask_alone_is_the_sample_geometrys():
    """merl._above_horizon (a file read for lookups) against the mask of the directions."""
    assert np.array_equal(merl._above_horizon(), merl._sample_geometry()[3])


def test_write_read_round_trip(synthetic):
    path, rgb, valid = synthetic
    assert path.stat().st_size == 34_992_012
    m = dl.read_merl(path)
    above = (m.wi[:, 2] > 0) & (m.wo[:, 2] > 0)
    np.testing.assert_array_equal(m.valid, valid.ravel() & above)
    np.testing.assert_allclose(m.values[m.valid], rgb.reshape(-1, 3)[m.valid], rtol=1e-15)
    assert np.all(m.values[~m.valid] == 0.0)
    assert m.isotropic and m.format == "merl" and m.material == "synthetic"
    # raw layout: channel-planar, scaled by 1/1500, 1.15/1500, 1.66/1500
    raw = np.fromfile(path, dtype="<f8", offset=12).reshape(3, -1)
    k = int(np.flatnonzero(valid.ravel())[123])
    np.testing.assert_allclose(raw[:, k] * np.array([1, 1.15, 1.66]) / 1500, rgb.reshape(-1, 3)[k], rtol=1e-15)
    assert np.all(raw[:, ~valid.ravel()] == -1.0)


def test_floor_lookup_and_reciprocity(synthetic):
    path, rgb, valid = synthetic
    m = dl.read_merl(path)
    idx = np.flatnonzero(m.valid)[::97]
    np.testing.assert_allclose(m.lookup(m.wi[idx], m.wo[idx]), rgb.reshape(-1, 3)[idx], rtol=1e-15)
    # invalid cells look up as 0, and swapping wi and wo gives the same cell
    rng = np.random.default_rng(1)
    wi = spherical_to_dir(rng.uniform(0, 1.5, 5000), rng.uniform(-np.pi, np.pi, 5000))
    wo = spherical_to_dir(rng.uniform(0, 1.5, 5000), rng.uniform(-np.pi, np.pi, 5000))
    a, b = m.lookup(wi, wo), m.lookup(wo, wi)
    assert np.mean(np.all(a == b, axis=1)) > 0.999
    th, _, td, pd = dl.std_to_half_diff(wi, wo)
    i, j, k, _ = dl.merl_index(th, td, pd)
    expected = np.where(valid[i, j, k][:, None], rgb[i, j, k], 0.0)
    np.testing.assert_allclose(a, expected, rtol=1e-15)
    # below the horizon -> 0
    assert np.all(m.lookup([0, 0.6, -0.8], [0, 0, 1]) == 0)


def test_trilinear_reproduces_a_linear_table(tmp_path):
    """A table linear in the continuous cell coordinates is reproduced exactly
    by trilinear interpolation away from the clamped/wrapped edges."""
    i, j, k = np.meshgrid(np.arange(90), np.arange(90), np.arange(180), indexing="ij")
    f = 1.0 + 0.01 * i + 0.02 * j + 0.003 * k
    path = tmp_path / "linear.binary"
    dl.write_merl(path, np.stack([f, 2 * f, 3 * f], -1))
    m = dl.read_merl(path)
    rng = np.random.default_rng(2)
    x, y, z = rng.uniform(1, 88, 500), rng.uniform(1, 88, 500), rng.uniform(1, 178, 500)
    th = ((x + 0.5) / 90) ** 2 * np.pi / 2
    td = (y + 0.5) / 90 * np.pi / 2
    pd = (z + 0.5) / 180 * np.pi
    wi, wo = dl.half_diff_to_std(th, 0 * th, td, pd)
    ok = (wi[:, 2] > 0) & (wo[:, 2] > 0)
    got = m.lookup(wi[ok], wo[ok], method="trilinear")
    expected = 1.0 + 0.01 * x + 0.02 * y + 0.003 * z
    np.testing.assert_allclose(got, expected[ok, None] * [1, 2, 3], rtol=1e-9)
    # floor lookup: the value of the containing cell
    got = m.lookup(wi[ok], wo[ok])
    expected = 1.0 + 0.01 * np.floor(x + 0.5) + 0.02 * np.floor(y + 0.5) + 0.003 * np.floor(z + 0.5)
    np.testing.assert_allclose(got[:, 0], expected[ok], rtol=1e-9)


# ---- real data: MERL-like tables from the NBRDF networks ---------------------------------------

def _tool():
    spec = importlib.util.spec_from_file_location("merl_from_nbrdf", MERL_TOOL)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("material", ["blue-acrylic", "gold-metallic-paint"])
def test_nbrdf_tables(merl_tables, material):
    path = merl_tables(material)
    m = dl.load(path)
    report = re.search(r"(\d+) valid cells of (\d+)", merl_tables.report(material))
    assert m.n_valid == int(report.group(1))
    assert len(m) == int(report.group(2)) == 1_458_000
    # the network evaluated here, with the tool's own functions, at every 5th cell centre
    tool = _tool()
    weights = np.load(NBRDF_NPZ)
    cells = np.arange(0, 1_458_000, 5)
    th, td, pd = (a.ravel()[cells] for a in tool.grid_angles())
    wi, wo, h, d = tool.half_diff_to_in_out(th, td, pd)
    net = tool.nbrdf_eval(weights, material, h, d)
    ok = (wi[:, 2] > 0) & (wo[:, 2] > 0)
    np.testing.assert_array_equal(ok, m.valid[cells])
    # the network runs in float32: the tool's one product over 1.46 M rows and this one
    # over every 5th row may take different BLAS blockings (seen: 7e-7 relative after exp,
    # and 2.4e-7 absolute where exp(y) - 1 subtracts near 1, two float32 steps of 1.0)
    float32 = dict(rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(m.lookup(wi[ok], wo[ok]), net[ok], **float32)
    np.testing.assert_allclose(m.values[cells], np.where(ok[:, None], net, 0.0), **float32)
    np.testing.assert_allclose(m.wi[cells], wi, atol=1e-12)
    np.testing.assert_allclose(m.wo[cells], wo, atol=1e-12)
