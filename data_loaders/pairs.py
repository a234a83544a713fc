"""DIRECTIONS files: (N, 6) .npy arrays of direction pairs, wi then wo (``brdf-fit eval``).

Checked before anything is allocated: the .npy header first (no pickles,
integer or float dtype, shape (N, 6), the declared size equal to the file's),
then the data.
"""

import os

import numpy as np

from ._typing import Float
from .directions import unit_rows
from .errors import MeasuredDataError, open_regular, require_file, warn_data
from .npy import read_npy_data, read_npy_header


# DIRECTIONS files: at most this many rows (1.2 GB of float64 pairs in memory; a
# lookup needs a few tens of bytes more per row). Split bigger evaluations.
MAX_DIRECTION_ROWS = 25_000_000
# Rows whose wi or wo length differs from 1 by more than this (relative) are
# normalised with a MeasuredDataWarning (float32 unit vectors are within 1e-7).
UNIT_LENGTH_TOLERANCE = 1e-3


class DirectionsFileError(MeasuredDataError, ValueError):
    """A bad DIRECTIONS .npy file. A MeasuredDataError (message: the file and
    the problem) and also a ValueError, for callers that catch ValueError."""


def read_directions(path: str | os.PathLike[str]) -> tuple[Float[np.ndarray, "n 3"], Float[np.ndarray, "n 3"]]:
    """DIRECTIONS .npy: float or int (N, 6), wi then wo; returns (wi, wo) (N, 3) float64 unit vectors.

    The .npy header is parsed and checked first (no pickles, integer or float
    dtype, shape (N, 6) with 1 <= N <= MAX_DIRECTION_ROWS, data size = file
    size - header size, so truncated or padded files are refused); only then
    is the data read. NaN/inf rows and zero vectors are errors; vectors that
    are not unit length (beyond UNIT_LENGTH_TOLERANCE) are normalised with a
    MeasuredDataWarning. Raises DirectionsFileError (a MeasuredDataError and a
    ValueError) naming the file.
    """
    path = os.fspath(path)
    try:
        return _read_directions_checked(path)
    except DirectionsFileError:
        raise
    except MeasuredDataError as e:
        raise DirectionsFileError(path, e.problem) from None


def _read_directions_checked(path):
    what = "DIRECTIONS .npy"
    require_file(path, ".npy array")        # its MeasuredDataError becomes a DirectionsFileError
    try:
        size = os.path.getsize(path)
        with open_regular(path) as f:
            header = read_npy_header(f, path, what)
            if header.dtype.kind not in "iuf":
                raise DirectionsFileError(path, "expected a float array of shape (N, 6), "
                                                f"got dtype {header.dtype}")
            shape = header.shape
            if len(shape) != 2 or shape[1] != 6 or shape[0] == 0:
                raise DirectionsFileError(path, f"expected shape (N, 6) with N >= 1 (wi then wo), got {shape}")
            if shape[0] > MAX_DIRECTION_ROWS:
                raise DirectionsFileError(path, f"{shape[0]:,} rows, more than the {MAX_DIRECTION_ROWS:,} "
                                                "allowed (split the evaluation)")
            data_bytes = size - header.header_bytes
            if header.nbytes != data_bytes:
                raise DirectionsFileError(
                    path, f"the header declares {shape} {header.dtype} ({header.nbytes:,} data bytes) "
                          f"but the file has {data_bytes:,} after the header (truncated or padded?)")
            a = read_npy_data(f, header, path, what)
    except OSError as e:
        raise DirectionsFileError(path, f"cannot read the file ({e.strerror or e})") from None
    a = a.astype(np.float64)
    bad = np.flatnonzero(~np.isfinite(a).all(axis=1))
    if bad.size:
        raise DirectionsFileError(path, f"row {bad[0]} has NaN or inf ({bad.size} such rows)")
    out = []
    off = np.zeros(a.shape[0], dtype=bool)
    for name, w in (("wi", a[:, :3]), ("wo", a[:, 3:])):
        unit, length = unit_rows(w)
        zero = np.flatnonzero(length == 0.0)
        if zero.size:
            raise DirectionsFileError(path, f"row {zero[0]}: {name} is the zero vector")
        off |= ~(np.abs(length - 1.0) <= UNIT_LENGTH_TOLERANCE)
        out.append(unit)
    if off.any():
        warn_data(path, f"{np.count_nonzero(off):,} of {a.shape[0]:,} direction pairs were not unit "
                        "length; they were normalised", stacklevel=3)
    return out[0], out[1]
