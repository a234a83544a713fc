"""UTIA .bin: index ref value, layout, round trip, Filip's quadrilinear lookup, units."""

import numpy as np
import pytest

import data_loaders as dl
from data_loaders import utia
from data_loaders.directions import spherical_to_dir


def _deg_dirs(theta, phi):
    return spherical_to_dir(np.radians(theta), np.radians(phi))


@pytest.fixture(scope="module")
def table(tmp_path_factory):
    rng = np.random.default_rng(0)
    data = rng.uniform(0.0, 10.0, utia.UTIA_SHAPE)
    path = tmp_path_factory.mktemp("utia") / "m000_random.bin"
    dl.write_utia(path, data)
    return path, data


def test_index_reference_value():
    # REFERENCE.md s.8: index(theta_i=30, phi_i=37.5, theta_v=45, phi_v=300, channel G) = 112216
    assert dl.utia_index(*np.radians([30, 37.5, 45, 300]), 1) == 112216


def test_round_trip_and_layout(table):
    path, data = table
    assert path.stat().st_size == 1_990_656
    m = dl.load(path)
    assert m.format == "utia" and not m.isotropic and len(m) == 6 * 48 * 6 * 48
    np.testing.assert_array_equal(m.values, data.reshape(3, -1).T)
    assert m.valid.all()
    # sample k is the node of flat index k: check one through the index function
    flat = np.fromfile(path, dtype="<f8")
    k = dl.utia_index(*np.radians([30, 37.5, 45, 300]), 1) - 82944
    np.testing.assert_allclose(m.wi[k], _deg_dirs(30, 37.5), atol=1e-15)
    np.testing.assert_allclose(m.wo[k], _deg_dirs(45, 300), atol=1e-15)
    assert m.values[k, 1] == flat[112216]


def test_weights_sum_to_hemisphere_pair_measure(table):
    m = dl.read_utia(table[0])
    np.testing.assert_allclose(m.weights.sum(), (2 * np.pi) ** 2, rtol=1e-12)
    np.testing.assert_allclose(utia.node_solid_angles().sum(), 2 * np.pi, rtol=1e-12)


def test_lookup_at_nodes_is_the_node_value(table):
    path, data = table
    m = dl.read_utia(path)
    # (at theta = 0 the 48 phi nodes are one direction, so phi cannot be recovered: skip them)
    idx = np.arange(0, len(m), 37)
    idx = idx[(m.theta_i[idx] > 0) & (m.theta_o[idx] > 0)]
    np.testing.assert_allclose(m.lookup(m.wi[idx], m.wo[idx]), m.values[idx], rtol=1e-9)


def _filip(data, ti, pi_, tv, pv):
    """Filip's scheme written out for one direction pair (degrees)."""
    def axis(x, step, n, periodic):
        i0 = int(np.floor(x / step))
        if not periodic:
            i0 = min(i0, n - 2)
        w1 = (x - step * i0) / step
        return [(i0, 1 - w1), ((i0 + 1) % n if periodic else i0 + 1, w1)]
    out = np.zeros(3)
    for a, wa in axis(ti, 15, 6, False):
        for b, wb in axis(pi_ % 360, 7.5, 48, True):
            for c, wc in axis(tv, 15, 6, False):
                for d, wd in axis(pv % 360, 7.5, 48, True):
                    out += wa * wb * wc * wd * data[:, a, b, c, d]
    return out


@pytest.mark.parametrize("angles", [
    (20.0, 10.0, 50.0, 200.0),
    (85.0, 100.0, 40.0, 30.0),      # theta_i > 75: extrapolation (weights -2/3, 5/3)
    (10.0, 356.0, 80.0, -3.0),      # phi wrap-around and a negative (atan2) azimuth
    (0.0, 0.0, 90.0, 45.0),
])
def test_quadrilinear_matches_filip(table, angles):
    path, data = table
    m = dl.read_utia(path)
    ti, pi_, tv, pv = angles
    got = m.lookup(_deg_dirs(ti, pi_), _deg_dirs(tv, pv))[0]
    np.testing.assert_allclose(got, _filip(data, ti, pi_, tv, pv), rtol=1e-9)


def test_extrapolation_of_a_linear_table_and_horizon(tmp_path):
    ti = np.arange(6)[None, :, None, None, None] * 15.0
    tv = np.arange(6)[None, None, None, :, None] * 15.0
    data = np.broadcast_to(1.0 + 0.1 * ti + 0.01 * tv, utia.UTIA_SHAPE)
    path = tmp_path / "linear.bin"
    dl.write_utia(path, data)
    m = dl.read_utia(path)
    np.testing.assert_allclose(m.lookup(_deg_dirs(85, 0), _deg_dirs(88, 0))[0], 1 + 8.5 + 0.88, rtol=1e-9)
    # theta > 90 deg -> 0
    assert np.all(m.lookup([0.0, 0.6, -0.8], [0, 0, 1.0]) == 0)


def test_anisotropic_azimuth_sign(tmp_path):
    """phi is measured from the tangent with atan2: -37.5 deg is node 322.5 deg, not 37.5."""
    data = np.zeros(utia.UTIA_SHAPE)
    data[:, 2, 43, 2, 0] = 5.0        # theta_i 30, phi_i 322.5, theta_v 30, phi_v 0
    path = tmp_path / "aniso.bin"
    dl.write_utia(path, data)
    m = dl.read_utia(path)
    np.testing.assert_allclose(m.lookup(_deg_dirs(30, -37.5), _deg_dirs(30, 0))[0], 5.0, rtol=1e-9)
    assert np.all(m.lookup(_deg_dirs(30, 37.5), _deg_dirs(30, 0))[0] == 0.0)


def test_units_raw_and_dj_brdf(tmp_path):
    data = np.full(utia.UTIA_SHAPE, 14.0)
    data[:, 0, 0, 0, 0] = (2.8, -5.0, 14.0)
    path = tmp_path / "units.bin"
    dl.write_utia(path, data)
    raw = dl.read_utia(path)
    assert not raw.valid[0] and raw.valid[1:].all()         # negative raw value masked, not clamped
    assert np.all(raw.values[0] == 0) and raw.values[1, 0] == 14.0
    dj = dl.read_utia(path, units="dj_brdf")
    high = ((14.0 / 140 + 0.055) / 1.055) ** 2.4 * 100      # 0.1 > 0.0375: inverse sRGB power branch
    low = 2.8 / 140 / 12.92 * 100                           # 0.02 <= 0.0375: linear branch
    np.testing.assert_allclose(dj.values[0], [low, 0.0, high], rtol=1e-12)
    np.testing.assert_allclose(dj.values[1], [high] * 3, rtol=1e-12)
    assert dj.valid.all()
    # dj_brdf lookups interpolate the encoded table, then decode
    np.testing.assert_allclose(dj.lookup(_deg_dirs(40, 10), _deg_dirs(50, 100))[0], [high] * 3, rtol=1e-12)
    assert "dj_brdf" in dj.provenance.units and "raw" in raw.provenance.units
