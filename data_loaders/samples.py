"""Sample lists (users' own gonioreflectometer data): CSV and NPZ, read and write.

Columns (names case-insensitive): ``theta_i, phi_i, theta_o, phi_o, r, g, b``
and optionally ``weight``. theta is the polar angle from the normal (+z),
phi the azimuth from the tangent (+x) towards +y; ``i`` is the direction to
the light, ``o`` to the viewer. r, g, b are BRDF values in 1/sr without the
cosine factor. Other columns are ignored.

The angle unit must be stated:

- CSV: a comment line ``# units: degrees`` (or ``radians``) before the column
  header line. Optional ``# material: NAME`` and ``# isotropic: true|false``
  lines. Blank lines and other ``#`` lines are skipped. Example::

      # units: degrees
      # material: my red paint
      theta_i,phi_i,theta_o,phi_o,r,g,b
      30,0,45,180,0.10,0.02,0.02

- NPZ: 1-D arrays named after the columns, plus a string array ``units``
  ("degrees" or "radians"), optionally ``material`` (string) and
  ``isotropic`` (bool). Object arrays (pickles) are refused, in any member.

Sizes are checked before anything is allocated: at most MAX_SAMPLES rows;
NPZ members are checked by name, declared size and .npy header before any
is decompressed (see ``read_npz``).

theta must lie in [0, 90] deg; negative r, g, b mark a sample invalid
(masked, not clamped); NaN/inf anywhere, a missing column or non-numeric
text are errors. Weights: the ``weight`` column if given (finite, >= 0);
otherwise uniform, (2 pi)^2 / N each, so they sum to the measure of the
pairs of hemispheres like the other formats' weights (right for samples
spread uniformly over direction pairs; give a ``weight`` column otherwise).

``lookup`` on a sample list is nearest neighbour (in (wi, wo) space, after
rotating each pair so that phi_i = 0 when the list is isotropic), by brute
force: fine for lists up to about 10^5 samples.
"""

import io
import os
from array import array

import numpy as np

from ._typing import ArrayLike, Float
from .directions import dir_to_spherical, spherical_to_dir, unit_rows
from .errors import MeasuredDataError
from .measured import HEMISPHERE_PAIR_MEASURE, MeasuredBRDF, Provenance, read_file_bytes, write_file_atomic
from .npz_members import names as _names, read_members

ANGLE_COLUMNS = ("theta_i", "phi_i", "theta_o", "phi_o")
VALUE_COLUMNS = ("r", "g", "b")
REQUIRED_COLUMNS = ANGLE_COLUMNS + VALUE_COLUMNS
UNIT_NAMES = {"degrees": "degrees", "degree": "degrees", "deg": "degrees",
              "radians": "radians", "radian": "radians", "rad": "radians"}
MAX_FILE_BYTES = 2 ** 31          # 2 GiB: a CSV file, or an NPZ file as stored (compressed)
# Caps checked before anything is allocated. A sample list may have up to
# MAX_SAMPLES rows (tens of millions are fine; a MeasuredBRDF takes about 250
# bytes per row, so 50 M rows are already about 12 GB in memory).
MAX_SAMPLES = 50_000_000
META_ARRAYS = ("units", "material", "isotropic")

UNITS_NOTE = "BRDF in 1/sr as given in the file, no cosine; negative values masked invalid"


def _shown(text, limit=40):
    text = str(text)
    return repr(text) if len(text) <= limit else repr(text[:limit]) + "..."


def _parse_bool(path, text, what):
    t = str(text).strip().lower()
    if t in ("true", "yes", "1"):
        return True
    if t in ("false", "no", "0"):
        return False
    raise MeasuredDataError(path, f"{what}: expected true or false, got {_shown(text)}")


def _parse_units(path, text, where):
    units = UNIT_NAMES.get(str(text).strip().lower())
    if units is None:
        raise MeasuredDataError(path, f"{where}: angle units {_shown(text)} must be 'degrees' or 'radians'")
    return units


# ---- nearest-neighbour table -----------------------------------------------------------

class SampleListTable:
    """Nearest-neighbour lookup over the valid samples of a list."""

    methods = (None, "nearest")

    def __init__(self, wi: np.ndarray, wo: np.ndarray, values: np.ndarray, isotropic: bool) -> None:
        self.isotropic = isotropic
        self.keys = self._keys(wi, wo)
        self.values = values

    def _keys(self, wi, wo):
        if self.isotropic:      # rotate about z so that phi_i = 0
            phi = np.arctan2(wi[:, 1], wi[:, 0])
            c, s = np.cos(phi), np.sin(phi)
            wi = np.stack([c * wi[:, 0] + s * wi[:, 1], -s * wi[:, 0] + c * wi[:, 1], wi[:, 2]], -1)
            wo = np.stack([c * wo[:, 0] + s * wo[:, 1], -s * wo[:, 0] + c * wo[:, 1], wo[:, 2]], -1)
        return np.concatenate([wi, wo], axis=1)

    def _tree(self):
        """A k-d tree of the 6-D (wi, wo) keys, built on the first lookup: a brute-force
        search of a 100 000-sample list for the image error's 60 000 pairs took 40 s."""
        if getattr(self, "_kd", None) is None:
            from scipy.spatial import cKDTree
            self._kd = cKDTree(self.keys)
        return self._kd

    def lookup(self, wi: Float[ArrayLike, "m 3"], wo: Float[ArrayLike, "m 3"],
               method: str | None = None) -> Float[np.ndarray, "m 3"]:
        """RGB (M, 3) of the nearest sample (Euclidean in the 6-D (wi, wo) keys);
        0 for pairs below the horizon."""
        if method not in self.methods:
            raise ValueError(f"unknown sample-list lookup method {method!r}; use one of {self.methods}")
        q = self._keys(np.asarray(wi, dtype=np.float64), np.asarray(wo, dtype=np.float64))
        _, nearest = self._tree().query(q)
        above = (q[:, 2] > 0.0) & (q[:, 5] > 0.0)
        return np.where(above[:, None], self.values[nearest], 0.0)


# ---- building the MeasuredBRDF ------------------------------------------------------------

def _build(path, sha, fmt, columns, units, material, isotropic, where):
    """columns: {name: float64 (N,)} already numeric; ``where(k)`` names row k for messages."""
    n = columns["theta_i"].shape[0]
    if n == 0:
        raise MeasuredDataError(path, "no samples (the column header is there but no data rows)")
    to_rad = np.pi / 180.0 if units == "degrees" else 1.0
    for name, col in columns.items():
        bad = np.flatnonzero(~np.isfinite(col))
        if bad.size:
            raise MeasuredDataError(path, f"{where(bad[0])}, column {name!r}: value is NaN or inf "
                                          f"({bad.size} such value(s) in that column)")
    for name in ("theta_i", "theta_o"):
        t = columns[name] * to_rad
        bad = np.flatnonzero((t < 0.0) | (t > np.pi / 2 + 1e-9))
        if bad.size:
            limit = "90 degrees" if units == "degrees" else "pi/2 radians"
            raise MeasuredDataError(path, f"{where(bad[0])}, column {name!r}: {columns[name][bad[0]]:g} "
                                          f"is outside [0, {limit}] (units: {units})")
    wi = spherical_to_dir(columns["theta_i"] * to_rad, columns["phi_i"] * to_rad)
    wo = spherical_to_dir(columns["theta_o"] * to_rad, columns["phi_o"] * to_rad)
    values = np.stack([columns[c] for c in VALUE_COLUMNS], axis=1)
    valid = (values >= 0.0).all(axis=1)
    if not valid.any():
        raise MeasuredDataError(path, "all-invalid sample list: every sample has a negative value")
    if "weight" in columns:
        weights = columns["weight"]
        bad = np.flatnonzero(weights < 0.0)
        if bad.size:
            raise MeasuredDataError(path, f"{where(bad[0])}, column 'weight': negative weight {weights[bad[0]]:g}")
        with np.errstate(over="ignore"):
            total = float(np.sum(weights[valid]))
        if total == 0.0:
            raise MeasuredDataError(path, "column 'weight': every valid sample has weight 0 "
                                          "(nothing to average over)")
        if not np.isfinite(total):
            raise MeasuredDataError(path, "column 'weight': the weights sum to more than the largest "
                                          "float (scale them down)")
    else:
        weights = np.full(n, HEMISPHERE_PAIR_MEASURE / n)
    values = np.where(valid[:, None], values, 0.0)
    table = SampleListTable(wi[valid], wo[valid], values[valid], isotropic)
    if material is None:
        material = os.path.splitext(os.path.basename(path))[0]
    weight_note = "weights from the file" if "weight" in columns else "uniform weights (2 pi)^2/N"
    prov = Provenance(path=os.path.abspath(path), format=fmt, material=material, sha256=sha,
                      units=f"{UNITS_NOTE}; angles in {units}; {weight_note}")
    return MeasuredBRDF(wi=wi, wo=wo, values=values, weights=weights, valid=valid,
                        isotropic=isotropic, provenance=prov, table=table)


# ---- CSV -------------------------------------------------------------------------------

def read_csv(path: str | os.PathLike[str], units: str | None = None, isotropic: bool | None = None) -> MeasuredBRDF:
    """Read a CSV sample list (format: module docstring). ``units`` / ``isotropic``
    override the file's header lines (``units`` is needed if the file has none)."""
    path = os.fspath(path)
    data, sha = read_file_bytes(path, max_bytes=MAX_FILE_BYTES)
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise MeasuredDataError(path, f"not UTF-8 text (byte {e.start}); expected a CSV sample list") from None
    del data
    meta = {}
    header = None
    header_line = 0
    columns = {}        # name -> (index in the header, array of float64)
    row_lines = array("q")
    for lineno, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            key, sep, value = s[1:].partition(":")
            if sep and header is None:
                meta[key.strip().lower()] = value.strip()
            continue
        fields = s.split(",")
        if header is None:
            header = [f.strip().lower() for f in fields]
            header_line = lineno
            _check_csv_header(path, header, header_line)
            columns = {name: (header.index(name), array("d"))
                       for name in REQUIRED_COLUMNS + ("weight",) if name in header}
            continue
        if len(fields) != len(header):
            raise MeasuredDataError(path, f"line {lineno}: {len(fields)} fields, the header "
                                          f"(line {header_line}) has {len(header)}")
        if len(row_lines) >= MAX_SAMPLES:
            raise MeasuredDataError(path, f"more than {MAX_SAMPLES:,} samples (line {lineno}); "
                                          "split the list")
        for name, (j, column) in columns.items():
            item = fields[j]
            try:
                column.append(float(item))
            except ValueError:
                raise MeasuredDataError(path, f"line {lineno}, column {name!r}: {_shown(item.strip())} "
                                              "is not a number") from None
        row_lines.append(lineno)
    if header is None:
        raise MeasuredDataError(path, "no column header line (expected "
                                      f"{','.join(REQUIRED_COLUMNS)}) — not a CSV sample list")
    if units is None:
        if "units" not in meta:
            raise MeasuredDataError(path, "the angle units are not stated: add a line "
                                          "'# units: degrees' or '# units: radians' before the header")
        units = meta["units"]
    units = _parse_units(path, units, "units")
    if isotropic is None:
        isotropic = _parse_bool(path, meta["isotropic"], "'# isotropic:' line") if "isotropic" in meta else False
    columns = {name: np.array(column, dtype=np.float64) for name, (_, column) in columns.items()}
    return _build(path, sha, "csv", columns, units, meta.get("material"), isotropic, lambda k: f"line {row_lines[k]}")


def _check_csv_header(path, header, header_line):
    dup = sorted({h for h in header if header.count(h) > 1})
    if dup:
        raise MeasuredDataError(path, f"line {header_line}: duplicate column(s) {_names(dup)}")
    missing = [c for c in REQUIRED_COLUMNS if c not in header]
    if missing:
        raise MeasuredDataError(path, f"line {header_line}: missing column(s) {', '.join(missing)} "
                                      f"(header has {_names(header)})")


# ---- NPZ -------------------------------------------------------------------------------

def read_npz(path: str | os.PathLike[str], units: str | None = None, isotropic: bool | None = None) -> MeasuredBRDF:
    """Read an NPZ sample list (format: module docstring); no pickles.

    Nothing is decompressed before it is checked: the member names first
    (required columns present, no case-insensitive clashes), then the .npy
    header of every member (read from the stream: no object dtypes anywhere),
    then, for the members used, the declared uncompressed size against
    the caps of ``data_loaders.npz_members``, and shape x itemsize against
    that size (exactly: truncated or padded members are refused) and
    MAX_SAMPLES. Only then are the used members read, one at a time.
    """
    path = os.fspath(path)
    data, sha = read_file_bytes(path, max_bytes=MAX_FILE_BYTES)
    arrays = read_members(path, data, REQUIRED_COLUMNS, ("weight",), META_ARRAYS, MAX_SAMPLES)
    del data

    def scalar_text(name):
        a = arrays[name]
        if a.size != 1 or a.dtype.kind not in "US":
            raise MeasuredDataError(path, f"array {name!r} must hold a single string, got {a.dtype}{list(a.shape)}")
        return _as_text(a.ravel()[0])

    if units is None:
        if "units" not in arrays:
            raise MeasuredDataError(path, "the angle units are not stated: add a string array "
                                          "'units' = 'degrees' or 'radians'")
        units = scalar_text("units")
    units = _parse_units(path, units, "array 'units'")
    if isotropic is None:
        isotropic = False
        if "isotropic" in arrays:
            a = arrays["isotropic"]
            if a.size != 1 or a.dtype.kind not in "biuUS":
                raise MeasuredDataError(path, "array 'isotropic' must hold a single bool")
            isotropic = _parse_bool(path, _as_text(a.ravel()[0]), "array 'isotropic'")
    material = scalar_text("material") if "material" in arrays else None
    columns = {name: arrays[name].astype(np.float64)
               for name in REQUIRED_COLUMNS + ("weight",) if name in arrays}
    return _build(path, sha, "npz", columns, units, material, isotropic, lambda k: f"sample {k}")


def _as_text(item):
    return item.decode("latin-1") if isinstance(item, bytes) else str(item)


# ---- writer ----------------------------------------------------------------------------

def _as_unit(w):
    """Rows not already of unit length are normalised (any finite scale, no
    overflow); unit rows are kept bit for bit. The angles need unit vectors."""
    w = np.asarray(w, dtype=np.float64)
    unit, length = unit_rows(w)
    return np.where((np.abs(length - 1.0) <= 1e-12)[..., None], w, unit)


def write_samples(path: str | os.PathLike[str], wi: Float[ArrayLike, "n 3"], wo: Float[ArrayLike, "n 3"],
                  values: Float[ArrayLike, "n 3"], weights: Float[ArrayLike, " n"] | None = None,
                  units: str = "degrees", material: str | None = None, isotropic: bool = False,
                  fmt: str | None = None) -> None:
    """Write a sample list as CSV or NPZ (by ``fmt`` or the path's suffix).

    ``wi``, ``wo``: (N, 3) directions (normalised here); ``values``: (N, 3) RGB; optional
    ``weights`` (N,) become a ``weight`` column. Angles are written in
    ``units`` ("degrees" or "radians"), CSV numbers with 17 significant
    digits (exact round trip). Written atomically.
    """
    path = os.fspath(path)
    fmt = fmt or os.path.splitext(path)[1].lstrip(".").lower()
    if fmt not in ("csv", "npz"):
        raise ValueError(f"unknown sample-list format {fmt!r}; use 'csv' or 'npz'")
    units = UNIT_NAMES.get(units)
    if units is None:
        raise ValueError("units must be 'degrees' or 'radians'")
    wi, wo = _as_unit(wi), _as_unit(wo)
    values = np.asarray(values, dtype=np.float64)
    ti, pi_ = dir_to_spherical(wi)
    to, po = dir_to_spherical(wo)
    cols = {"theta_i": ti, "phi_i": pi_, "theta_o": to, "phi_o": po}
    if units == "degrees":
        cols = {k: np.degrees(v) for k, v in cols.items()}
    cols.update(r=values[:, 0], g=values[:, 1], b=values[:, 2])
    if weights is not None:
        cols["weight"] = np.asarray(weights, dtype=np.float64)
    if fmt == "npz":
        extra = {"units": np.array(units), "isotropic": np.array(bool(isotropic))}
        if material is not None:
            extra["material"] = np.array(material)
        buf = io.BytesIO()
        np.savez(buf, **cols, **extra)
        write_file_atomic(path, buf.getvalue())
        return
    lines = [f"# units: {units}", f"# isotropic: {'true' if isotropic else 'false'}"]
    if material is not None:
        lines.append(f"# material: {material}")
    lines.append(",".join(cols))
    table = np.stack(list(cols.values()), axis=1)
    lines.extend(",".join(f"{x:.17g}" for x in row) for row in table)
    write_file_atomic(path, ("\n".join(lines) + "\n").encode("utf-8"))
