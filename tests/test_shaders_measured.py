"""GPU lookups of measured tables (measured.glsl) against numpy references
written here from REFERENCE.md s.8 (MERL floor index with reciprocity, UTIA
quadrilinear after Filip), independent of data_loaders."""

import numpy as np
import pytest

from shaders.gl import gl_available

ok, reason = gl_available()
pytestmark = pytest.mark.skipif(not ok, reason=f"no OpenGL 4.3 context: {reason}")

from shaders import parity  # noqa: E402
from shaders.measured import MERL_SCALES, MeasuredTable, evaluate_measured, merl_cell_directions  # noqa: E402

N = 10_000


# --- numpy references (float64) --------------------------------------------------

def unit(w):
    """References normalise first, as data_loaders' lookups do (float32 inputs
    are only unit to ~1e-7; acos(z) of z = 1.0 would hide a 0.01 deg tilt)."""
    return w / np.linalg.norm(w, axis=-1, keepdims=True)


def half_diff(wi, wo):
    wi, wo = unit(wi), unit(wo)
    h = wi + wo
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    theta_h = np.arccos(np.clip(h[:, 2], -1, 1))
    phi_h = np.arctan2(h[:, 1], h[:, 0])
    cp, sp, ct, st = np.cos(phi_h), np.sin(phi_h), np.cos(theta_h), np.sin(theta_h)
    x = cp * wi[:, 0] + sp * wi[:, 1]
    y = -sp * wi[:, 0] + cp * wi[:, 1]
    z = wi[:, 2]
    dx, dz = ct * x - st * z, st * x + ct * z
    return theta_h, phi_h, np.arccos(np.clip(dz, -1, 1)), np.arctan2(y, dx)


def merl_coords(wi, wo):
    """Continuous MERL index coordinates (before floor)."""
    th, _, td, pd = half_diff(wi, wo)
    pd = np.where(pd < 0, pd + np.pi, pd)
    return np.sqrt(np.maximum(th, 0) / (np.pi / 2)) * 90, td / (np.pi / 2) * 90, pd / np.pi * 180


def merl_reference(rgb, wi, wo):
    x, y, z = merl_coords(wi, wo)
    i = np.clip(np.floor(x), 0, 89).astype(int)
    j = np.clip(np.floor(y), 0, 89).astype(int)
    k = np.clip(np.floor(z), 0, 179).astype(int)
    out = rgb[i, j, k]
    return np.where(((wi[:, 2] > 0) & (wo[:, 2] > 0))[:, None], out, 0.0)


def utia_reference(data, wi, wo, magnitude=False):
    """Filip's quadrilinear lookup; with ``magnitude`` also the sum of the 16
    corner values |v| (the scale that float32 weight errors multiply)."""
    wi, wo = unit(wi), unit(wo)

    def angles(w):
        return np.degrees(np.arccos(np.clip(w[:, 2], -1, 1))), np.mod(np.degrees(np.arctan2(w[:, 1], w[:, 0])), 360.0)
    ti, pi_ = angles(wi)
    tv, pv = angles(wo)
    axes = []
    for x, step, n, periodic in ((ti, 15.0, 6, False), (pi_, 7.5, 48, True), (tv, 15.0, 6, False), (pv, 7.5, 48, True)):
        i0 = np.floor(x / step).astype(int)
        i0 = np.clip(i0, 0, n - 1) if periodic else np.minimum(i0, n - 2)
        w1 = (x - step * i0) / step
        i1 = (i0 + 1) % n if periodic else i0 + 1
        axes.append(((i0, 1 - w1), (i1, w1)))
    out = np.zeros((len(wi), 3))
    scale = np.zeros((len(wi), 3))
    for a, wa in axes[0]:
        for b, wb in axes[1]:
            for c, wc in axes[2]:
                for d, wd in axes[3]:
                    term = (wa * wb * wc * wd)[:, None] * data[:, a, b, c, d].T
                    out += term
                    scale += np.abs(data[:, a, b, c, d].T)
    above = ((wi[:, 2] >= 0) & (wo[:, 2] >= 0))[:, None]
    out = np.where(above, out, 0.0)
    return (out, np.where(above, scale, 0.0)) if magnitude else out


@pytest.fixture(scope="module")
def pairs():
    wi, wo = parity.random_pairs(N, 11, below=0.02)
    return wi, wo


def test_merl_lookup_matches_the_reference_floor_index(pairs):
    rng = np.random.default_rng(0)
    rgb = rng.uniform(0.0, 5.0, (90, 90, 180, 3))
    rgb[rng.uniform(size=(90, 90, 180)) < 0.05] = 0.0         # a few invalid cells
    table = MeasuredTable.from_merl_rgb(rgb)
    wi, wo = pairs
    gl = evaluate_measured(table, wi, wo)
    w64i, w64o = wi.astype(np.float64), wo.astype(np.float64)
    ref = merl_reference(rgb.astype(np.float32), w64i, w64o)
    differ = np.any(gl != ref, axis=1)
    # Admissible disagreements: (a) phi_d is undefined at theta_h = 0 (mirror)
    # and theta_d = 0 (retro), where float32 and float64 pick different phi_d
    # cells of the same (theta_h, theta_d) row; (b) float32 angles on the other
    # side of a cell edge, within 2e-3 cells of it.
    th, _, td, _ = half_diff(w64i, w64o)
    degenerate = (th < 1e-3) | (td < 1e-3)
    x, y, z = merl_coords(w64i, w64o)
    dist = np.min(np.stack([np.abs(c - np.round(c)) for c in (x, y, z)]), axis=0)
    plain = differ & ~degenerate
    assert plain.mean() < 0.002, f"{plain.sum()} of {N} regular lookups differ"
    assert np.all(dist[plain] < 2e-3), f"differing lookups away from cell edges: {np.sort(dist[plain])[-5:]}"
    i = np.clip(np.floor(x), 0, 89).astype(int)
    j = np.clip(np.floor(y), 0, 89).astype(int)
    for n in np.nonzero(differ & degenerate)[0]:                  # same row, some phi_d cell
        row = rgb.astype(np.float32)[i[n], j[n]]
        assert np.any(np.all(row == gl[n], axis=1)), (n, gl[n])


def test_merl_reciprocity_and_reference_index():
    """REFERENCE.md s.8: (30, 0, 45, 90) deg -> cell (50, 26, 68); swapping wi and wo
    reads the same cell (phi_d -> phi_d + pi)."""
    def d(t, p):
        t, p = np.radians(t), np.radians(p)
        return np.array([[np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)]], np.float32)
    rgb = np.zeros((90, 90, 180, 3))
    for (a, b, c), v in (((50, 26, 68), 1.0), ((44, 39, 20), 2.0), ((50, 42, 169), 3.0)):
        rgb[a, b, c] = v
    table = MeasuredTable.from_merl_rgb(rgb)
    for (ti, pi_, to, po), v in (((30, 0, 45, 90), 1.0), ((60, 45, 20, 250), 2.0), ((70, 300, 15, 100), 3.0)):
        wi, wo = d(ti, pi_), d(to, po)
        assert evaluate_measured(table, wi, wo)[0, 0] == v
        assert evaluate_measured(table, wo, wi)[0, 0] == v


def test_merl_raw_scaling_and_invalid_cells():
    raw = np.full((3, 90 * 90 * 180), 1500.0)
    raw[:, 0] = -1.0                                        # unmeasured cell
    table = MeasuredTable.from_merl_raw(raw)
    np.testing.assert_allclose(table.values[1], MERL_SCALES * 1500.0, rtol=1e-6)
    assert np.all(table.values[0] == 0.0)


def test_utia_lookup_matches_filip_quadrilinear(pairs):
    rng = np.random.default_rng(1)
    data = rng.uniform(0.0, 2.0, (3, 6, 48, 6, 48))
    table = MeasuredTable.from_utia(data)
    wi, wo = pairs
    gl = evaluate_measured(table, wi, wo)
    ref, scale = utia_reference(data.astype(np.float32).astype(np.float64), wi.astype(np.float64),
                                wo.astype(np.float64), magnitude=True)
    # Up to 75 deg every weight is in [0, 1]: the plain parity criterion.
    inside = (wi[:, 2] >= np.cos(np.radians(75.0))) & (wo[:, 2] >= np.cos(np.radians(75.0)))
    r = parity.compare(gl[inside], ref[inside])
    assert r["max_rel"] < 1e-4 and r["max_abs"] < 1e-6, r
    # Beyond 75 deg Filip's scheme extrapolates (weights up to 1.67 and -0.67)
    # and random tables then cancel to near 0.  The weights come from float32
    # angles (an azimuth near 360 deg has an ulp of 3e-5 deg, 4e-6 of a cell),
    # so the error is bounded by the corner values, not by the result.
    err = np.abs(gl - ref)
    assert np.all(err <= 2e-6 * scale + 1e-7), np.max(err / (scale + 1e-30))


def test_utia_azimuth_keeps_its_sign():
    """phi = +30 and -30 deg must read different table columns (an acos-based
    azimuth would fold them together)."""
    data = np.zeros((3, 6, 48, 6, 48))
    data[:, 2, 4, 2, 4] = 1.0        # theta 30, phi +30 for both
    table = MeasuredTable.from_utia(data)
    t, p = np.radians(30.0), np.radians(30.0)
    plus = np.array([[np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)]], np.float32)
    minus = plus * np.array([1, -1, 1], np.float32)
    assert evaluate_measured(table, plus, plus)[0, 0] == pytest.approx(1.0, abs=1e-5)
    assert evaluate_measured(table, minus, minus)[0, 0] == pytest.approx(0.0, abs=1e-6)


def test_resampled_lookup_round_trips_on_cell_centres():
    """A callable resampled at the cell centres reads back at those centres."""
    def lookup(wi, wo):
        return np.stack([wi[:, 2], wo[:, 2], wi[:, 2] * wo[:, 2]], axis=1)
    table = MeasuredTable.resample(lookup)
    wi, wo = merl_cell_directions()
    rng = np.random.default_rng(2)
    idx = rng.choice(len(wi), 5000, replace=False)
    idx = idx[(wi[idx, 2] > 0.01) & (wo[idx, 2] > 0.01)]
    gl = evaluate_measured(table, wi[idx], wo[idx])
    np.testing.assert_allclose(gl, lookup(wi[idx], wo[idx]), rtol=1e-5, atol=1e-6)
