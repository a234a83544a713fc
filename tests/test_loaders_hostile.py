"""Hostile input for the measured-data readers: every bad file ends in a one-line
MeasuredDataError naming the file (never a numpy/Python exception, never a huge
allocation); implausible but readable files load with a MeasuredDataWarning
naming the file.

Every bad input is made here, in tmp_path: valid files from the writers, then
corrupted (truncated, header fields flipped, huge declared sizes, NaN,
negative, 1e300 values); NPZ bombs and .npy headers are written by hand. A
small seeded fuzz (byte flips and truncations of each format) checks that
nothing but MeasuredDataError escapes (other warnings, e.g. numpy's
RuntimeWarnings, count as failures there).
"""

import io
import os
import struct
import tracemalloc
import warnings
import zipfile
import zlib

import numpy as np
import pytest

import data_loaders as dl
from data_loaders import merl, pairs, rgl, utia
from brdf_fit.cli import main as brdf_fit
from data_loaders.directions import spherical_to_dir

GiB, MiB = 1 << 30, 1 << 20
# bytes a reader may allocate (tracemalloc peak) while refusing a file that
# declares gigabytes or terabytes: the file itself is small
SMALL_ALLOCATION = 16 * MiB


# ---- helpers ------------------------------------------------------------------------------

def _error(path, *phrases, loader=None, **options):
    """The one-line MeasuredDataError of loading ``path``, which names the file."""
    with pytest.raises(dl.MeasuredDataError) as info:
        (loader or dl.load)(path, **options)
    message = str(info.value)
    assert str(path) in message, message
    assert "\n" not in message, message
    for phrase in phrases:
        assert phrase in message, message
    return message


def _warning(path, phrase, loader=None, **options):
    """Load ``path``: it succeeds with a MeasuredDataWarning naming the file."""
    with pytest.warns(dl.MeasuredDataWarning) as record:
        result = (loader or dl.load)(path, **options)
    messages = [str(w.message) for w in record if issubclass(w.category, dl.MeasuredDataWarning)]
    assert any(str(path) in m and phrase in m and "\n" not in m for m in messages), messages
    return result


def _quiet(loader, *args, **options):
    """Call a loader that must succeed without any warning."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return loader(*args, **options)


def _peak_allocation(fn):
    tracemalloc.start()
    try:
        fn()
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return peak


def _npy_header(shape, descr="<f8", version=(1, 0), fortran_order=False):
    d = {"descr": descr, "fortran_order": fortran_order, "shape": shape}
    buf = io.BytesIO()
    if version == (1, 0):
        np.lib.format.write_array_header_1_0(buf, d)
    else:
        np.lib.format.write_array_header_2_0(buf, d)
    return buf.getvalue()


def _npy_bytes(a):
    buf = io.BytesIO()
    np.save(buf, a)
    return buf.getvalue()


# ---- zip files by hand (deflate bombs without compressing a GiB) ------------------------------

def _gf2_times(mat, vec):
    out, i = 0, 0
    while vec:
        if vec & 1:
            out ^= mat[i]
        vec >>= 1
        i += 1
    return out


def _crc32_zeros(n, crc=0):
    """zlib.crc32(bytes(n), crc) in O(log n) (the zero-byte operator of zlib's crc32_combine)."""
    op = [0xEDB88320] + [1 << k for k in range(31)]     # one zero bit
    for _ in range(3):                                    # one zero byte
        op = [_gf2_times(op, m) for m in op]
    reg = crc ^ 0xFFFFFFFF
    while n:
        if n & 1:
            reg = _gf2_times(op, reg)
        n >>= 1
        if n:
            op = [_gf2_times(op, m) for m in op]
    return reg ^ 0xFFFFFFFF


def _deflated(data):
    c = zlib.compressobj(6, zlib.DEFLATED, -15)
    return (zipfile.ZIP_DEFLATED, c.compress(data) + c.flush(), zlib.crc32(data), len(data))


def _zero_bomb(head, size):
    """A raw deflate stream of ``head`` followed by zeros up to ``size`` bytes, built
    from one compressed MiB repeated (a full flush resets the compressor)."""
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    first = c.compress(head + bytes(MiB - len(head))) + c.flush(zlib.Z_FULL_FLUSH)
    repeat = c.compress(bytes(MiB)) + c.flush(zlib.Z_FULL_FLUSH)
    assert size % MiB == 0
    stream = first + repeat * (size // MiB - 1) + c.flush()
    crc = _crc32_zeros(size - len(head), zlib.crc32(head))
    return (zipfile.ZIP_DEFLATED, stream, crc, size)


def _zip_bytes(members):
    """A zip file of members {name: (method, stored bytes, crc32, uncompressed size)}."""
    out, central = bytearray(), bytearray()
    for name, (method, stored, crc, size) in members.items():
        name = name.encode()
        fields = (20, 0, method, 0, 0x21, crc, len(stored), size, len(name), 0)
        central += b"PK\x01\x02" + struct.pack("<HHHHHHIIIHHHHHII", 20, *fields, 0, 0, 0, 0, len(out)) + name
        out += b"PK\x03\x04" + struct.pack("<HHHHHIIIHH", *fields) + name + stored
    eocd = struct.pack("<4s4H2LH", b"PK\x05\x06", 0, 0, len(members), len(members),
                       len(central), len(out), 0)
    return bytes(out + central + eocd)


def test_hand_made_zip_is_a_valid_zip():
    assert all(_crc32_zeros(n, c) == zlib.crc32(bytes(n), c) for n in (0, 1, 7, 4097) for c in (0, 99))
    data = _zip_bytes({"a.npy": _deflated(_npy_bytes(np.arange(3.0))),
                       "b.npy": _zero_bomb(_npy_header((MiB // 4 - 16,)), 2 * MiB)})
    with zipfile.ZipFile(io.BytesIO(data)) as zf:
        assert zf.testzip() is None
        assert zf.getinfo("b.npy").file_size == 2 * MiB
    with np.load(io.BytesIO(data)) as npz:
        assert npz["a"].tolist() == [0.0, 1.0, 2.0] and not npz["b"].any()


# ---- valid small files of each format --------------------------------------------------------

def _sample_columns(n=40, seed=0):
    rng = np.random.default_rng(seed)
    wi = spherical_to_dir(rng.uniform(0.1, 1.3, n), rng.uniform(-3, 3, n))
    wo = spherical_to_dir(rng.uniform(0.1, 1.3, n), rng.uniform(-3, 3, n))
    return wi, wo, rng.uniform(0.01, 2.0, (n, 3)), rng.uniform(0.5, 1.5, n)


def _write_samples(path, values=None, weights=None, scale=1.0, **kw):
    wi, wo, v, w = _sample_columns()
    dl.write_samples(path, wi * scale, wo * scale, v if values is None else values,
                     weights=w if weights is None else weights, **kw)
    return path


def _rgl_fields(seed=0):
    """A small synthetic but consistent RGL tensor file (isotropic, 4 theta_i slices)."""
    rng = np.random.default_rng(seed)
    f32 = np.float32
    n_theta, n_vndf, n_rgb = 4, 8, 6
    return {
        "description": np.frombuffer(b"synthetic test material", dtype=np.uint8),
        "phi_i": np.zeros(1, f32),
        "theta_i": np.linspace(0.0, np.pi / 2, n_theta).astype(f32),
        "sigma": rng.uniform(0.5, 1.0, (2, n_vndf)).astype(f32),
        "ndf": rng.uniform(0.1, 1.0, (2, n_vndf)).astype(f32),
        "vndf": rng.uniform(0.1, 1.0, (1, n_theta, n_vndf, n_vndf)).astype(f32),
        "luminance": rng.uniform(0.1, 1.0, (1, n_theta, n_rgb, n_rgb)).astype(f32),
        "rgb": rng.uniform(0.1, 1.0, (1, n_theta, 3, n_rgb, n_rgb)).astype(f32),
        "jacobian": np.ones(1, np.uint8),
    }


RGL_GRID = dict(grid=(8, 8, 16))         # a small sample grid keeps these tests fast


def _field_header_offset(data, name):
    """Offset of the u16 ndim of field ``name`` in a tensor file's header."""
    pos = 18
    for _ in range(struct.unpack_from("<I", data, 14)[0]):
        (n,) = struct.unpack_from("<H", data, pos)
        found = data[pos + 2:pos + 2 + n] == name.encode()
        pos += 2 + n
        if found:
            return pos
        ndim = struct.unpack_from("<H", data, pos)[0]
        pos += 2 + 1 + 8 + 8 * ndim
    raise KeyError(name)


@pytest.fixture
def rgl_file(tmp_path):
    path = tmp_path / "synthetic_rgb.bsdf"
    rgl.write_tensor_file(path, _rgl_fields())
    return path


# ---- MERL -------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def merl_bytes(tmp_path_factory):
    path = tmp_path_factory.mktemp("merl") / "valid.binary"
    rgb = np.random.default_rng(3).uniform(0.01, 1.0, merl.MERL_SHAPE + (3,))
    dl.write_merl(path, rgb)
    return path.read_bytes()


def test_merl_truncated_padded_and_bad_header(tmp_path, merl_bytes):
    path = tmp_path / "bad.binary"
    for cut in (1, 11, 13, len(merl_bytes) // 2, len(merl_bytes) - 1):
        path.write_bytes(merl_bytes[:cut])
        _error(path)
    path.write_bytes(merl_bytes + b"\0" * 8)
    _error(path, "34,992,020 bytes", "34,992,012")
    for dims in ((90, 90, 181), (-90, 90, 180), (2 ** 31 - 1, 90, 180), (0, 0, 0)):
        path.write_bytes(np.array(dims, "<i4").tobytes() + merl_bytes[12:])
        _error(path)


def test_merl_nan_negative_zero_and_huge(tmp_path):
    path = tmp_path / "m.binary"
    rgb = np.full(merl.MERL_SHAPE + (3,), 0.5)
    rgb[3, 4, 5, 1] = np.nan
    dl.write_merl(path, rgb)
    _error(path, "NaN or inf")
    dl.write_merl(path, np.full(merl.MERL_SHAPE + (3,), -1.0))
    _error(path, "all-invalid")
    dl.write_merl(path, np.zeros(merl.MERL_SHAPE + (3,)))
    m = _warning(path, "all values are zero")
    assert m.n_valid > 0
    dl.write_merl(path, np.full(merl.MERL_SHAPE + (3,), 1e300))
    m = _warning(path, "1e+06 1/sr")
    assert np.isfinite(m.values).all()


# ---- UTIA -------------------------------------------------------------------------------------

def test_utia_truncated_and_bad_values(tmp_path):
    path = tmp_path / "m.bin"
    dl.write_utia(path, np.ones(utia.UTIA_SHAPE))
    data = path.read_bytes()
    for cut in (1, 8, 1000, len(data) - 8, len(data) - 1):
        path.write_bytes(data[:cut])
        _error(path, "1,990,656")
    raw = np.ones(utia.UTIA_SHAPE)
    raw[0, 1, 2, 3, 4] = np.inf
    dl.write_utia(path, raw)
    _error(path, "NaN or inf")
    dl.write_utia(path, -np.ones(utia.UTIA_SHAPE))
    _error(path, "all-invalid")
    dl.write_utia(path, np.zeros(utia.UTIA_SHAPE))
    _warning(path, "all values are zero")
    dl.write_utia(path, np.full(utia.UTIA_SHAPE, 1e300))
    _warning(path, "wrong units or scale")
    _error(path, "overflow to infinity", units="dj_brdf")      # the sRGB decoding overflows


# ---- RGL tensor files -----------------------------------------------------------------------

def test_rgl_synthetic_file_loads(rgl_file):
    m = _quiet(dl.load, rgl_file, **RGL_GRID)
    assert m.format == "rgl" and m.n_valid > 0 and np.isfinite(m.values).all()


@pytest.mark.parametrize("ndim", [40, 64, 65, 60000, 65535])
def test_rgl_huge_ndim(tmp_path, rgl_file, ndim):
    data = bytearray(rgl_file.read_bytes())
    pos = _field_header_offset(data, "rgb")
    old_ndim = struct.unpack_from("<H", data, pos)[0]
    rest = data[pos + 11 + 8 * old_ndim:]
    # the shape: all 2s (a product that overflows int64 from ndim 64 on)
    data[pos:] = struct.pack("<HBQ", ndim, 10, 0) + struct.pack(f"<{ndim}Q", *([2] * ndim)) + rest
    path = tmp_path / "ndim.bsdf"
    path.write_bytes(bytes(data))
    _error(path, "'rgb'", **RGL_GRID)
    # padded so that the whole shape fits in the file: still refused by the ndim cap
    path.write_bytes(bytes(data) + bytes(8 * ndim))
    _error(path, "'rgb'", **RGL_GRID)


@pytest.mark.parametrize("shape", [(2 ** 63, 1), (2 ** 64 - 1, 2 ** 64 - 1), (2 ** 32, 2 ** 32),
                                   (0, 2 ** 62), (10 ** 12, 6)])
def test_rgl_huge_declared_shape(tmp_path, rgl_file, shape):
    data = bytearray(rgl_file.read_bytes())
    pos = _field_header_offset(data, "sigma")
    assert struct.unpack_from("<H", data, pos)[0] == 2
    struct.pack_into("<2Q", data, pos + 11, *shape)
    path = tmp_path / "shape.bsdf"
    path.write_bytes(bytes(data))
    peak = _peak_allocation(lambda: _error(path, "'sigma'", **RGL_GRID))
    assert peak < SMALL_ALLOCATION


def test_rgl_header_fields(tmp_path, rgl_file):
    data = rgl_file.read_bytes()
    path = tmp_path / "hdr.bsdf"

    def patched(offset, fmt, value):
        d = bytearray(data)
        struct.pack_into(fmt, d, offset, value)
        path.write_bytes(bytes(d))
        return path

    _error(patched(14, "<I", 2 ** 32 - 1), "fields")                  # n_fields
    _error(patched(12, "<B", 2), "version 2.0")
    pos = _field_header_offset(data, "ndf")
    _error(patched(pos + 2, "<B", 99), "unknown dtype code 99")
    _error(patched(pos + 3, "<Q", 2 ** 64 - 1), "'ndf'")              # offset past the end
    _error(patched(pos + 3, "<Q", len(data) - 8), "'ndf'")            # payload runs past the end
    _error(patched(18, "<H", 65535), "truncated")                      # name length
    d = bytearray(data)
    d[20:20 + 3] = b"\xff\xfe\xfd"
    path.write_bytes(bytes(d))
    _error(path, "not UTF-8", **RGL_GRID)
    for cut in (0, 5, 12, 17, 18, 25, 60, len(data) // 2, len(data) - 1):
        path.write_bytes(data[:cut] if cut else b"")
        _error(path, **RGL_GRID)


def test_rgl_duplicate_field(tmp_path):
    path = tmp_path / "dup.bsdf"
    rgl.write_tensor_file(path, dict(_rgl_fields(), xyz=np.zeros(3, np.float32)))
    data = bytearray(path.read_bytes())
    pos = _field_header_offset(data, "xyz")
    data[pos - 3:pos] = b"rgb"                  # a second field named "rgb"
    path.write_bytes(bytes(data))
    _error(path, "'rgb' appears twice", **RGL_GRID)


def test_rgl_bad_values(tmp_path):
    path = tmp_path / "v.bsdf"
    cases = {
        "NaN": dict(rgb=np.full((1, 4, 3, 6, 6), np.nan, np.float32)),
        "sigma must be positive": dict(sigma=-np.ones((2, 8), np.float32)),
        "increasing": dict(theta_i=np.array([0.0, 0.5, 0.5, 1.0], np.float32)),
        "integrates to zero": dict(vndf=np.zeros((1, 4, 8, 8), np.float32)),
    }
    for phrase, change in cases.items():
        rgl.write_tensor_file(path, dict(_rgl_fields(), **change))
        _error(path, phrase, **RGL_GRID)
    rgl.write_tensor_file(path, dict(_rgl_fields(), rgb=np.zeros((1, 4, 3, 6, 6), np.float32)))
    _warning(path, "all values are zero", **RGL_GRID)
    huge = np.full((1, 4, 3, 6, 6), 3e38, np.float32)
    rgl.write_tensor_file(path, dict(_rgl_fields(), rgb=huge))
    m = _warning(path, "wrong units or scale", **RGL_GRID)
    assert np.isfinite(m.values).all()


# ---- NPZ sample lists --------------------------------------------------------------------------

def _npz_members(n=40, **changes):
    """Deflated members of a valid NPZ sample list, with ``changes`` (name: member or None)."""
    wi, wo, v, w = _sample_columns(n)
    theta = lambda d: np.degrees(np.arccos(d[:, 2]))           # noqa: E731
    phi = lambda d: np.degrees(np.arctan2(d[:, 1], d[:, 0]))   # noqa: E731
    arrays = {"theta_i": theta(wi), "phi_i": phi(wi), "theta_o": theta(wo), "phi_o": phi(wo),
              "r": v[:, 0], "g": v[:, 1], "b": v[:, 2], "weight": w,
              "units": np.array("degrees"), "isotropic": np.array(False)}
    members = {f"{k}.npy": _deflated(_npy_bytes(a)) for k, a in arrays.items()}
    for name, member in changes.items():
        if member is None:
            members.pop(name, None)
        else:
            members[name] = member
    return members


def _write_zip(path, members):
    path.write_bytes(_zip_bytes(members))
    return path


def test_npz_hand_made_list_loads(tmp_path):
    m = _quiet(dl.load, _write_zip(tmp_path / "ok.npz", _npz_members()))
    assert len(m) == 40 and m.format == "npz"


def test_npz_bomb_with_keys_missing_is_not_decompressed(tmp_path, monkeypatch):
    """The reported case: a 1 GiB member of zeros (1 MB compressed) in a file that
    lacks the required arrays. Refused from the member names alone."""
    bomb = _zero_bomb(b"", GiB)
    assert len(bomb[1]) < 2 * MiB
    path = _write_zip(tmp_path / "bomb.npz", {"data.npy": bomb})
    opened = []
    monkeypatch.setattr(zipfile.ZipFile, "open", lambda *a, **k: opened.append(a) or 1 / 0)
    peak = _peak_allocation(lambda: _error(path, "missing array(s) theta_i"))
    assert not opened and peak < SMALL_ALLOCATION


def _count_decompressed(monkeypatch):
    """Total bytes handed out by zip member streams (ZipExtFile.read)."""
    total = [0]
    read = zipfile.ZipExtFile.read

    def counting(self, n=-1):
        data = read(self, n)
        total[0] += len(data)
        return data

    monkeypatch.setattr(zipfile.ZipExtFile, "read", counting)
    return total


@pytest.mark.parametrize("where", ["theta_i.npy", "r.npy", "extra.npy"])
def test_npz_bomb_with_valid_npy_header(tmp_path, monkeypatch, where):
    """A 1 GiB member of zeros behind a valid .npy header declaring 134 M float64
    rows: refused by the declared size before it is decompressed when it is a
    column; only its header is read when it is an array the list does not use."""
    rows = (GiB - 128) // 8
    bomb = _zero_bomb(_npy_header((rows,)), GiB)
    path = _write_zip(tmp_path / "bomb.npz", _npz_members(**{where: bomb}))
    total = _count_decompressed(monkeypatch)
    if where == "extra.npy":
        peak = _peak_allocation(lambda: _quiet(dl.load, path))
    else:
        peak = _peak_allocation(lambda: _error(path, f"{GiB:,} bytes uncompressed"))
    assert total[0] < 64 * 1024 and peak < SMALL_ALLOCATION


def test_npz_member_sizes_against_declared_shape(tmp_path, monkeypatch):
    total = _count_decompressed(monkeypatch)
    cases = {
        # a .npy header declaring 10^12 rows in a small member
        "10^12 rows": _deflated(_npy_header((10 ** 12,)) + bytes(320)),
        # 10^12 rows with the member's declared size to match: the size cap
        "huge declared size": (zipfile.ZIP_DEFLATED, b"\x03\x00", 0, 2 ** 32 - 1),
        "truncated": _deflated(_npy_header((40,)) + bytes(8 * 39)),
        "padded": _deflated(_npy_header((40,)) + bytes(8 * 41)),
        "ndim 40": _deflated(_npy_header((1,) * 40) + bytes(8)),
        "negative": _deflated(_npy_header((-5,)) + bytes(8)),
        "not npy": _deflated(bytes(1000)),
        "version 2 header of 4 GiB": _deflated(b"\x93NUMPY\x02\x00" + struct.pack("<I", 2 ** 32 - 1)
                                               + bytes(100)),
        "version 9": _deflated(b"\x93NUMPY\x09\x00" + bytes(100)),
        "bad header text": _deflated(b"\x93NUMPY\x01\x00" + struct.pack("<H", 17) + b"{'descr': [[[[(,\n"),
        "header not a dict": _deflated(b"\x93NUMPY\x01\x00" + struct.pack("<H", 6) + b"[1, 2]"),
        "object": _deflated(_npy_header((40,), descr="|O") + bytes(320)),
        "complex": _deflated(_npy_bytes(np.ones(40, complex))),
        "2-D": _deflated(_npy_bytes(np.ones((40, 2)))),
        "short column": _deflated(_npy_bytes(np.ones(39))),
        "structured": _deflated(_npy_bytes(np.zeros(40, dtype=[("a", "<f8")]))),
        "zero itemsize": _deflated(_npy_header((40,), descr="|V0")),
    }
    for i, (what, member) in enumerate(cases.items()):
        path = _write_zip(tmp_path / f"case{i}.npz", _npz_members(**{"g.npy": member}))
        peak = _peak_allocation(lambda path=path: _error(path))
        assert peak < SMALL_ALLOCATION, what
    assert total[0] < 64 * 1024
    # a column declared longer than it is (the zip's sizes lie)
    stored = _npy_bytes(np.ones(40))
    liar = (zipfile.ZIP_STORED, stored, zlib.crc32(stored), len(stored) + 8)
    _error(_write_zip(tmp_path / "liar.npz", _npz_members(**{"g.npy": liar})))
    bad_crc = (zipfile.ZIP_STORED, stored, zlib.crc32(stored) ^ 1, len(stored))
    _error(_write_zip(tmp_path / "crc.npz", _npz_members(**{"g.npy": bad_crc})), "CRC")


def test_npz_pickles_clashes_members_and_metadata(tmp_path):
    pickled = io.BytesIO()
    np.save(pickled, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    path = _write_zip(tmp_path / "p.npz", _npz_members(**{"extra.npy": _deflated(pickled.getvalue())}))
    _error(path, "pickles are refused")
    path = _write_zip(tmp_path / "c.npz", _npz_members(**{"R.npy": _deflated(_npy_bytes(np.ones(40)))}))
    _error(path, "case-insensitive")
    path = _write_zip(tmp_path / "u.npz", _npz_members(**{"units.npy": _deflated(_npy_bytes(
        np.array("d" * 100_000)))}))
    _error(path, "'units'", "uncompressed")
    path = _write_zip(tmp_path / "u2.npz", _npz_members(**{"units.npy": _deflated(_npy_bytes(
        np.array(["degrees", "radians"])))}))
    _error(path, "single string")
    many = _npz_members(**{f"x{k}.npy": _deflated(_npy_bytes(np.zeros(1))) for k in range(1100)})
    _error(_write_zip(tmp_path / "m.npz", many), "members")


def test_npz_truncated_and_zero_weights(tmp_path):
    path = tmp_path / "s.npz"
    _write_samples(path)
    data = path.read_bytes()
    for cut in (4, 30, 100, len(data) // 3, len(data) // 2, len(data) - 22, len(data) - 1):
        path.write_bytes(data[:cut])
        _error(path)
    _write_samples(path, weights=np.zeros(40))
    _error(path, "weight 0")
    _write_samples(path, weights=np.full(40, 1e308))
    _error(path, "largest float")
    _write_samples(path, values=np.zeros((40, 3)))
    _warning(path, "all values are zero")


# ---- CSV sample lists --------------------------------------------------------------------------

def test_csv_weights_values_and_text(tmp_path):
    path = tmp_path / "s.csv"
    text = _write_samples(path).read_text()
    _write_samples(path, weights=np.zeros(40))
    _error(path, "weight 0")
    w = np.ones(40)
    w[7] = -1.0
    _write_samples(path, weights=w)
    _error(path, "negative weight")
    _write_samples(path, weights=np.full(40, 1e308))
    _error(path, "largest float")
    v = np.full((40, 3), 0.5)
    v[3, 1] = np.nan
    _write_samples(path, values=v)
    _error(path, "NaN or inf")
    _write_samples(path, values=-np.ones((40, 3)))
    _error(path, "all-invalid")
    _write_samples(path, values=np.zeros((40, 3)))
    _warning(path, "all values are zero")
    _write_samples(path, values=np.full((40, 3), 1e300))
    _warning(path, "wrong units or scale")
    path.write_text(text.replace("# units: degrees\n", "# units: " + "x" * 100_000 + "\n"))
    assert len(_error(path, "units")) < 300
    lines = text.splitlines()
    fields = lines[5].split(",")
    fields[1] = "y" * 100_000
    lines[5] = ",".join(fields)
    path.write_text("\n".join(lines))
    assert len(_error(path, "is not a number")) < 300
    for cut in (3, 20, 40, len(text) // 2, len(text) - 2):
        path.write_text(text[:cut])
        try:
            _quiet(dl.load, path)
        except dl.MeasuredDataError as e:
            assert str(path) in str(e)
    path.write_bytes(b"# units: degrees\n\xff\xfe\x00garbage")
    _error(path)


@pytest.mark.parametrize("fmt", ["csv", "npz"])
def test_sample_directions_scaled_by_1e300(tmp_path, fmt):
    """Directions of any finite scale are written as the same angles: the writer
    normalises without overflowing."""
    ref = _quiet(dl.load, _write_samples(tmp_path / f"ref.{fmt}"))
    for scale in (1e300, 1e-300, 7.0):
        got = _quiet(dl.load, _write_samples(tmp_path / f"s.{fmt}", scale=scale))
        np.testing.assert_allclose(got.wi, ref.wi, atol=1e-12)
        np.testing.assert_allclose(got.wo, ref.wo, atol=1e-12)


def test_lookup_accepts_any_finite_scale(tmp_path):
    m = _quiet(dl.load, _write_samples(tmp_path / "s.npz"))
    wi, wo, _, _ = _sample_columns(5, seed=9)
    ref = m.lookup(wi, wo)
    for scale in (1e300, 1e-300):
        np.testing.assert_array_equal(_quiet(m.lookup, wi * scale, wo * scale), ref)


# ---- eval's DIRECTIONS .npy ---------------------------------------------------------------------

def _read_directions_error(path, *phrases):
    message = _error(path, *phrases, loader=pairs.read_directions)
    with pytest.raises(ValueError):          # what brdf_fit/cli.py catches
        pairs.read_directions(path)
    return message


def test_directions_huge_and_inconsistent_headers(tmp_path):
    path = tmp_path / "dirs.npy"
    cases = {
        "10^12 rows": (_npy_header((10 ** 12, 6)), "rows"),
        "10^12 rows, padded": (_npy_header((10 ** 12, 6)) + bytes(48 * 1000), "rows"),
        "truncated": (_npy_header((1000, 6)) + bytes(48 * 999), "truncated or padded"),
        "padded": (_npy_header((10, 6)) + bytes(48 * 10 + 1), "truncated or padded"),
        "object": (_npy_header((2, 6), descr="|O") + bytes(100), "pickles are refused"),
        "string": (_npy_bytes(np.array([["a"] * 6])), "dtype"),
        "4 GiB header": (b"\x93NUMPY\x02\x00" + struct.pack("<I", 2 ** 32 - 1) + bytes(64), "header"),
        "no magic": (b"PK\x03\x04" + bytes(200), "magic"),
        "negative": (_npy_header((-1, 6)), "negative"),
        "ndim 40": (_npy_header((1,) * 38 + (1, 6)) + bytes(48), "dimensions"),
        "empty": (b"", "magic"),
    }
    for what, (data, phrase) in cases.items():
        path.write_bytes(data)
        peak = _peak_allocation(lambda phrase=phrase: _read_directions_error(path, phrase))
        assert peak < SMALL_ALLOCATION, what
    _read_directions_error(tmp_path / "absent.npy", "no such file")
    _read_directions_error(tmp_path, "directory")


def test_directions_fortran_order_and_ints(tmp_path):
    path = tmp_path / "dirs.npy"
    a = np.asfortranarray(np.tile([0.0, 0.0, 1.0, 0.6, 0.0, 0.8], (5, 1)))
    np.save(path, a)
    wi, wo = _quiet(pairs.read_directions, path)
    np.testing.assert_array_equal(wo, np.tile([0.6, 0.0, 0.8], (5, 1)))
    np.save(path, np.array([[0, 0, 1, 1, 0, 0]], dtype=np.int16))
    wi, wo = _quiet(pairs.read_directions, path)
    assert wi.tolist() == [[0.0, 0.0, 1.0]] and wo.tolist() == [[1.0, 0.0, 0.0]]


@pytest.mark.parametrize("scale", [2.0, 1e300, 1e-300])
def test_directions_not_unit_length_are_normalised_with_a_warning(tmp_path, scale):
    rng = np.random.default_rng(4)
    wi = spherical_to_dir(rng.uniform(0, 1.4, 20), rng.uniform(-3, 3, 20))
    wo = spherical_to_dir(rng.uniform(0, 1.4, 20), rng.uniform(-3, 3, 20))
    path = tmp_path / "dirs.npy"
    np.save(path, np.concatenate([wi * scale, wo], axis=1))
    got = _warning(path, "normalised", loader=pairs.read_directions)
    np.testing.assert_allclose(got[0], wi, atol=1e-15)
    np.testing.assert_allclose(got[1], wo, atol=1e-15)


def test_eval_refuses_huge_directions_cleanly(tmp_path, capsys):
    table = tmp_path / "m.bin"
    dl.write_utia(table, np.ones(utia.UTIA_SHAPE))
    dirs = tmp_path / "dirs.npy"
    dirs.write_bytes(_npy_header((10 ** 12, 6)) + bytes(480))
    out = tmp_path / "out.npy"
    assert brdf_fit(["eval", str(table), str(dirs), str(out)]) == 2
    err = capsys.readouterr().err
    assert str(dirs) in err and "Traceback" not in err and err.count("\n") == 1
    assert not out.exists()


# ---- real files -----------------------------------------------------------------------------------

def test_real_rgl_file_is_plausible(rgl_dir):
    """No warning for a real measurement, even on a sample grid whose cells come
    within 0.01 deg of the horizon, where f = (f cos) / cos is largest."""
    m = _quiet(dl.load, rgl_dir / "cc_ibiza_sunset_rgb.bsdf", grid=(64, 64, 128))
    assert m.values.max() > 10 * dl.measured.MAX_PLAUSIBLE_BRDF


def test_grazing_values_are_held_to_the_projected_threshold(tmp_path):
    wi = spherical_to_dir(np.full(4, np.radians(89.0)), np.zeros(4))
    wo = spherical_to_dir(np.full(4, np.radians(30.0)), np.full(4, np.pi))
    path = tmp_path / "g.csv"
    dl.write_samples(path, wi, wo, np.full((4, 3), 2e7))      # 2e7 x cos 89 deg = 3e5: plausible
    _quiet(dl.load, path)
    dl.write_samples(path, wi, wo, np.full((4, 3), 1e300))
    _warning(path, "near the horizon")


def test_real_rgl_file_truncated(tmp_path, rgl_dir):
    data = (rgl_dir / "paper_white_rgb.bsdf").read_bytes()
    path = tmp_path / "cut.bsdf"
    for cut in np.linspace(18, len(data) - 1, 9).astype(int):
        path.write_bytes(data[:cut])
        _error(path, "truncated", **RGL_GRID)


# ---- fuzz -------------------------------------------------------------------------------------------

FUZZ_CASES = int(os.environ.get("HOSTILE_FUZZ_CASES", "30"))


def _mutations(data, seed, n, header_bytes):
    """n seeded variants of ``data``: truncations, and 1-8 byte changes (half of
    them within the first ``header_bytes`` bytes)."""
    rng = np.random.default_rng(seed)
    for k in range(n):
        if k % 3 == 0:
            yield data[:int(rng.integers(0, len(data)))]
            continue
        d = bytearray(data)
        span = min(header_bytes, len(d)) if k % 3 == 1 else len(d)
        for _ in range(int(rng.integers(1, 9))):
            i = int(rng.integers(0, span))
            d[i] = int(rng.integers(0, 256)) if rng.random() < 0.7 else d[i] ^ 0xFF
        yield bytes(d)


def _fuzz(tmp_path, name, data, seed, n, header_bytes, loader=None, **options):
    path = tmp_path / name
    outcomes = {"loaded": 0, "refused": 0}
    for variant in _mutations(data, seed, n, header_bytes):
        path.write_bytes(variant)
        with warnings.catch_warnings():
            warnings.simplefilter("error")          # numpy RuntimeWarnings etc. are failures
            warnings.simplefilter("ignore", dl.MeasuredDataWarning)
            try:
                (loader or dl.load)(path, **options)
                outcomes["loaded"] += 1
            except dl.MeasuredDataError as e:
                assert str(path) in str(e) and "\n" not in str(e), str(e)
                outcomes["refused"] += 1
    assert outcomes["refused"] > 0
    return outcomes


def test_fuzz_rgl_synthetic(tmp_path, rgl_file):
    data = rgl_file.read_bytes()
    _fuzz(tmp_path, "f_rgb.bsdf", data, 1, FUZZ_CASES, 400, **RGL_GRID)


def test_fuzz_rgl_real(tmp_path, rgl_dir):
    data = (rgl_dir / "paper_white_rgb.bsdf").read_bytes()
    _fuzz(tmp_path, "f_rgb.bsdf", data, 2, FUZZ_CASES, 400, **RGL_GRID)


def test_fuzz_npz(tmp_path):
    data = _write_samples(tmp_path / "s.npz").read_bytes()
    _fuzz(tmp_path, "f.npz", data, 3, FUZZ_CASES, len(data))
    bomb = _zip_bytes(_npz_members(**{"extra.npy": _zero_bomb(_npy_header(((GiB - 128) // 8,)), GiB)}))
    _fuzz(tmp_path, "fb.npz", bomb, 4, FUZZ_CASES, 4096)


def test_fuzz_csv(tmp_path):
    data = _write_samples(tmp_path / "s.csv").read_bytes()
    _fuzz(tmp_path, "f.csv", data, 5, FUZZ_CASES, 200)


def test_fuzz_utia(tmp_path):
    path = tmp_path / "m.bin"
    dl.write_utia(path, np.random.default_rng(6).uniform(0, 1, utia.UTIA_SHAPE))
    _fuzz(tmp_path, "f.bin", path.read_bytes(), 6, FUZZ_CASES, 64)


def test_fuzz_merl(tmp_path, merl_bytes):
    # few cases: a MERL table that survives a byte flip takes 0.3 s to load
    _fuzz(tmp_path, "f.binary", merl_bytes, 7, max(FUZZ_CASES // 4, 3), 16)


def test_fuzz_directions(tmp_path):
    rng = np.random.default_rng(8)
    buf = io.BytesIO()
    np.save(buf, rng.normal(size=(30, 6)))
    _fuzz(tmp_path, "f.npy", buf.getvalue(), 8, FUZZ_CASES, 128, loader=pairs.read_directions)
