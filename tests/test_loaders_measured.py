"""MeasuredBRDF helpers (select, subsample, channel, summary) and load()'s
content-based format detection."""

import numpy as np
import pytest

import data_loaders as dl
from data_loaders import utia
from data_loaders.directions import row_norms, spherical_to_dir, std_to_half_diff


@pytest.fixture(scope="module")
def merl_file(tmp_path_factory):
    """A MERL table whose value is a known function of the cell, some cells unmeasured."""
    i, j, k = np.meshgrid(np.arange(90), np.arange(90), np.arange(180), indexing="ij")
    f = 0.1 + 0.01 * i + 0.001 * j
    valid = (k % 17) != 3
    path = tmp_path_factory.mktemp("m") / "table.dat"      # no .binary: detected by content
    dl.write_merl(path, np.stack([f, 2 * f, 3 * f], -1), valid)
    return path


@pytest.fixture(scope="module")
def merl(merl_file):
    return dl.load(merl_file)


def test_row_norms_equal_numpy_norm_bit_for_bit():
    """row_norms (the directions' normalisation) against np.linalg.norm along the last axis:
    the same numbers exactly, for rows of very different magnitudes and a batch of them."""
    rng = np.random.default_rng(4)
    v = rng.normal(size=(5000, 3)) * 10.0 ** rng.uniform(-150, 150, size=(5000, 1))
    v[:3] = [[0.0, 0.0, 0.0], [3.0, 4.0, 12.0], [-0.0, 2.0, 0.0]]
    assert np.array_equal(row_norms(v), np.linalg.norm(v, axis=-1))
    assert row_norms(v[1]) == 13.0
    batch = v[:4000].reshape(2, 2000, 3)
    assert np.array_equal(row_norms(batch), np.linalg.norm(batch, axis=-1))


def test_select_grazing_cut_off(merl):
    s = merl.select(80.0)
    limit = np.radians(80.0)
    expected = merl.valid & (merl.theta_i <= limit + 1e-9) & (merl.theta_o <= limit + 1e-9)
    assert len(s) == np.count_nonzero(expected)
    assert s.valid.all() and np.all(s.theta_i <= limit + 1e-9) and np.all(s.theta_o <= limit + 1e-9)
    np.testing.assert_allclose(s.weights.sum(), merl.weights[expected].sum(), rtol=1e-12)
    kept_invalid = merl.select(80.0, valid_only=False)
    assert len(kept_invalid) > len(s) and not kept_invalid.valid.all()
    assert s.provenance.history == ("select(max_theta_deg=80, valid_only=True)",)
    assert s.table is merl.table


def test_subsample_is_stratified_seeded_and_preserves_weights(merl):
    s = merl.select(80.0)
    sub = s.subsample(5000, seed=3)
    assert len(sub) == 5000 and sub.valid.all()
    np.testing.assert_allclose(sub.weights.sum(), s.weights.sum(), rtol=1e-12)
    again = s.subsample(5000, seed=3)
    np.testing.assert_array_equal(again.wi, sub.wi)
    other = s.subsample(5000, seed=4)
    assert not np.array_equal(other.wi, sub.wi)
    # weighted sum preserved per (theta_h, theta_d) stratum, recomputed independently here
    def strata(m):
        th, _, td, _ = std_to_half_diff(m.wi, m.wo)
        bh = np.minimum((np.sqrt(th / (np.pi / 2)) * 16).astype(int), 15)
        bd = np.minimum((td / (np.pi / 2) * 16).astype(int), 15)
        return np.bincount(bh * 16 + bd, weights=m.weights, minlength=256)
    np.testing.assert_allclose(strata(sub), strata(s), rtol=1e-9, atol=1e-15)
    # the subsample's samples are samples of the original (values match the lookup)
    np.testing.assert_allclose(sub.values, s.lookup(sub.wi, sub.wo), rtol=1e-12)
    # asking for more than there is returns every valid sample
    assert len(s.subsample(10 ** 7)) == len(s)


def test_take_rows_is_fancy_indexing_into_an_aligned_array():
    """data_loaders.buffers.take_rows: a[index] (negative indices too), at an ALIGN-byte
    aligned address; an index out of range is an IndexError, as numpy's own."""
    from data_loaders.buffers import ALIGN, aligned_empty, take_rows
    rng = np.random.default_rng(5)
    a = rng.random((1000, 3))
    index = np.concatenate([rng.integers(0, 1000, 500), [-1, -1000, 0, 999]])
    out = take_rows(a, index)
    np.testing.assert_array_equal(out, a[index])
    assert out.ctypes.data % ALIGN == 0 and out.flags.c_contiguous
    np.testing.assert_array_equal(take_rows(a[:, 0] > 0.5, index), (a[:, 0] > 0.5)[index])
    for bad in ([1000], [-1001]):
        with pytest.raises(IndexError):
            take_rows(a, np.array(bad))
    for shape in (7, (3, 5)):
        empty = aligned_empty(shape)
        assert empty.shape == ((shape,) if isinstance(shape, int) else shape) and empty.ctypes.data % ALIGN == 0
    assert aligned_empty((0, 3)).shape == (0, 3)


def test_subsample_strata_in_steps_are_those_of_the_whole_set(merl, monkeypatch):
    """subsample takes its strata in steps of STRATA_ROWS rows (small temporaries): any step
    gives the subsample of one step over the whole set, bit for bit."""
    from data_loaders import measured as measured_module
    s = merl.select(80.0)
    monkeypatch.setattr(measured_module, "STRATA_ROWS", len(s))
    whole = s.subsample(5000, seed=3)
    for step in (7, 4096):
        monkeypatch.setattr(measured_module, "STRATA_ROWS", step)
        stepped = s.subsample(5000, seed=3)
        for name in ("wi", "wo", "values", "weights"):
            np.testing.assert_array_equal(getattr(stepped, name), getattr(whole, name))


def test_channel_selection(merl):
    g = merl.channel("g")
    assert g.channels == ("g",) and g.values.shape == (len(merl), 1)
    np.testing.assert_array_equal(g.values[:, 0], merl.values[:, 1])
    rb = merl.channel([0, 2])
    wi, wo = merl.wi[merl.valid][:10], merl.wo[merl.valid][:10]
    np.testing.assert_array_equal(rb.lookup(wi, wo), merl.lookup(wi, wo)[:, [0, 2]])
    with pytest.raises(ValueError):
        merl.channel("x")


def test_summary_and_properties(merl, merl_file):
    text = merl.summary()
    assert "merl" in text and "table" in text and str(merl_file) in text
    assert f"{len(merl):,}" in text and f"{merl.n_valid:,}" in text
    np.testing.assert_allclose(merl.theta_i, np.arccos(merl.wi[:, 2]))
    assert merl.values.flags.writeable is False
    assert len(merl.provenance.sha256) == 64


def test_lookup_input_checks(merl):
    with pytest.raises(ValueError):
        merl.lookup(np.zeros((3, 2)), np.zeros((3, 2)))
    with pytest.raises(ValueError):
        merl.lookup([0, 0, np.nan], [0, 0, 1])
    with pytest.raises(ValueError):
        merl.lookup([0, 0, 1], [0, 0, 1], method="cubic")
    # unnormalised directions are normalised
    np.testing.assert_allclose(merl.lookup([0, 0, 2], [0.1, 0, 3]), merl.lookup([0, 0, 1], [0.1 / np.sqrt(9.01), 0, 3 / np.sqrt(9.01)]))


def test_detection_by_content(tmp_path, merl_file):
    assert dl.detect_format(merl_file) == "merl"
    data = np.random.default_rng(0).uniform(0, 1, utia.UTIA_SHAPE)
    dl.write_utia(tmp_path / "utia.data", data)
    assert dl.detect_format(tmp_path / "utia.data") == "utia"
    wi = spherical_to_dir([0.1, 0.2], [0, 1])
    dl.write_samples(tmp_path / "a.npz", wi, wi, np.ones((2, 3)))
    (tmp_path / "a.npz").rename(tmp_path / "samples.bin.gz")
    assert dl.detect_format(tmp_path / "samples.bin.gz") == "npz"
    dl.write_samples(tmp_path / "b.csv", wi, wi, np.ones((2, 3)))
    (tmp_path / "b.csv").rename(tmp_path / "samples.txt")
    m = dl.load(tmp_path / "samples.txt")
    assert m.format == "csv" and len(m) == 2
