"""Sample lists (CSV, NPZ): round trips, units, weights, nearest-neighbour lookup."""

import numpy as np
import pytest

import data_loaders as dl
from data_loaders.directions import spherical_to_dir


def _random_samples(n=200, seed=0):
    rng = np.random.default_rng(seed)
    wi = spherical_to_dir(rng.uniform(0, np.pi / 2, n), rng.uniform(-np.pi, np.pi, n))
    wo = spherical_to_dir(rng.uniform(0, np.pi / 2, n), rng.uniform(-np.pi, np.pi, n))
    values = rng.uniform(0, 3, (n, 3))
    return wi, wo, values


@pytest.mark.parametrize("suffix", ["csv", "npz"])
@pytest.mark.parametrize("units", ["degrees", "radians"])
def test_round_trip(tmp_path, suffix, units):
    wi, wo, values = _random_samples()
    weights = np.linspace(0.1, 2.0, len(wi))
    path = tmp_path / f"list.{suffix}"
    dl.write_samples(path, wi, wo, values, weights=weights, units=units, material="test paint")
    m = dl.load(path)
    assert m.format == suffix and m.material == "test paint" and not m.isotropic
    np.testing.assert_allclose(m.wi, wi, atol=1e-14)
    np.testing.assert_allclose(m.wo, wo, atol=1e-14)
    np.testing.assert_array_equal(m.values, values)
    np.testing.assert_array_equal(m.weights, weights)
    assert m.valid.all()
    assert units in m.provenance.units


def test_csv_by_hand_degrees_and_uniform_weights(tmp_path):
    path = tmp_path / "hand.csv"
    path.write_text("# units: degrees\n# material: red paint\n# isotropic: true\n"
                    "theta_i, phi_i, theta_o, phi_o, r, g, b, notes\n"
                    "0, 0, 0, 0, 0.3, 0.1, 0.1, 5\n"
                    "\n"
                    "# a comment between rows\n"
                    "60, 90, 30, 270, 0.2, -0.1, 0.1, 6\n"
                    "45, 0, 45, 180, 1.5, 1.0, 0.9, 7\n")
    m = dl.load(path)
    assert m.material == "red paint" and m.isotropic and len(m) == 3
    np.testing.assert_allclose(m.wi[1], [0.0, np.sin(np.pi / 3), 0.5], atol=1e-15)
    np.testing.assert_allclose(m.wo[1], [0.0, -0.5, np.cos(np.pi / 6)], atol=1e-15)
    # a negative value masks the sample (values 0), it is not clamped
    np.testing.assert_array_equal(m.valid, [True, False, True])
    np.testing.assert_array_equal(m.values[1], [0, 0, 0])
    # uniform weights: (2 pi)^2 / N each
    np.testing.assert_allclose(m.weights, (2 * np.pi) ** 2 / 3)


def test_nearest_neighbour_lookup(tmp_path):
    wi, wo, values = _random_samples(300, seed=1)
    path = tmp_path / "nn.npz"
    dl.write_samples(path, wi, wo, values)
    m = dl.load(path)
    np.testing.assert_array_equal(m.lookup(wi, wo), values)
    # a slightly perturbed query still finds the sample
    q_wi = wi[:20] + 1e-4
    q_wo = wo[:20] - 1e-4
    np.testing.assert_array_equal(m.lookup(q_wi, q_wo), values[:20])


def test_isotropic_lookup_rotates_phi(tmp_path):
    wi, wo, values = _random_samples(100, seed=2)
    path = tmp_path / "iso.csv"
    dl.write_samples(path, wi, wo, values, isotropic=True)
    m = dl.load(path)
    assert m.isotropic
    c, s = np.cos(0.7), np.sin(0.7)
    rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    np.testing.assert_array_equal(m.lookup(wi @ rot.T, wo @ rot.T), values)


def test_units_option_overrides_missing_header(tmp_path):
    path = tmp_path / "nounits.csv"
    path.write_text("theta_i,phi_i,theta_o,phi_o,r,g,b\n0.5,0,0.5,3.14159,1,1,1\n")
    with pytest.raises(dl.MeasuredDataError, match="units"):
        dl.load(path)
    m = dl.load(path, units="radians")
    np.testing.assert_allclose(m.theta_i, [0.5])
