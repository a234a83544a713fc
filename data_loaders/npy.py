"""Bounded reading of ``.npy`` arrays from untrusted files and NPZ members.

``np.load`` trusts the header it reads: 12 bytes of header can declare 10^12
rows (an allocation error of tens of TiB), and a version-2 header can declare
a header length of 4 GiB, which numpy reads before checking it. Here the
header length, the dtype and the shape are checked first, and the array's
byte size (Python ints, no overflow) is compared with the bytes the caller
knows are there before anything is allocated. Object dtypes (pickles) are
refused. Every problem is a :class:`MeasuredDataError` naming the file.
"""

import io
import math
import os
import struct
from typing import IO, NamedTuple

import numpy as np
from numpy.lib import format as npformat

from .errors import MeasuredDataError

# numpy's own default limit (``max_header_size``); real headers are about 128 bytes.
MAX_NPY_HEADER_BYTES = 10_000
# numpy arrays have at most 64 dimensions; nothing read here needs more than 2.
MAX_NPY_NDIM = 32

_MAGIC_BYTES = 8                       # b"\x93NUMPY" + major + minor
_LENGTH_FORMATS = {(1, 0): "<H", (2, 0): "<I", (3, 0): "<I"}


class NpyHeader(NamedTuple):
    """A checked ``.npy`` header."""

    shape: tuple           # Python ints >= 0
    fortran_order: bool
    dtype: np.dtype
    header_bytes: int      # bytes from the magic to the first data byte
    count: int             # number of elements (Python int)
    nbytes: int            # count * itemsize (Python int)


def _one_line(err, limit=160):
    text = str(err).strip().splitlines()
    text = text[0] if text else type(err).__name__
    return text if len(text) <= limit else text[:limit] + "..."


def _read_up_to(fp, n):
    """Read up to ``n`` bytes (fewer only at the end of the stream)."""
    parts, got = [], 0
    while got < n:
        chunk = fp.read(n - got)
        if not chunk:
            break
        parts.append(chunk)
        got += len(chunk)
    return parts[0] if len(parts) == 1 else b"".join(parts)


def read_npy_header(fp: IO[bytes], path: str | os.PathLike[str], what: str) -> NpyHeader:
    """Parse and check the ``.npy`` header at the current position of binary stream ``fp``.

    ``what`` names the array in messages (e.g. ``"member 'r.npy'"``). Reads at
    most ``MAX_NPY_HEADER_BYTES`` + 12 bytes. Raises MeasuredDataError for a
    missing magic, an unknown version, an over-long or unparsable header, an
    object, structured or zero-size dtype, or a bad shape.
    """
    def bad(problem):
        return MeasuredDataError(path, f"{what}: {problem}")

    prefix = _read_up_to(fp, _MAGIC_BYTES)
    try:
        version = npformat.read_magic(io.BytesIO(prefix))
    except ValueError:
        raise bad("not an .npy array (the \\x93NUMPY magic is missing)") from None
    length_format = _LENGTH_FORMATS.get(version)
    if length_format is None:
        raise bad(f".npy format version {version[0]}.{version[1]} is not supported")
    length_bytes = _read_up_to(fp, struct.calcsize(length_format))
    if len(length_bytes) != struct.calcsize(length_format):
        raise bad("truncated .npy header")
    (header_length,) = struct.unpack(length_format, length_bytes)
    if header_length > MAX_NPY_HEADER_BYTES:
        raise bad(f".npy header declares {header_length:,} bytes, more than the "
                  f"{MAX_NPY_HEADER_BYTES:,} allowed")
    header = _read_up_to(fp, header_length)
    if len(header) != header_length:
        raise bad("truncated .npy header")
    # Version 3.0 differs from 2.0 only in decoding the header as UTF-8 instead
    # of latin-1, which matters only for non-ASCII field names of structured
    # dtypes (refused below anyway), so numpy's 2.0 parser serves for both.
    parse = npformat.read_array_header_1_0 if version == (1, 0) else npformat.read_array_header_2_0
    try:
        shape, fortran_order, dtype = parse(io.BytesIO(length_bytes + header),
                                            max_header_size=MAX_NPY_HEADER_BYTES)
    except Exception as e:      # numpy's parser of untrusted text: any failure is a bad header
        raise bad(f"unreadable .npy header ({_one_line(e)})") from None
    if dtype.hasobject:
        raise bad(f"holds Python objects (dtype {dtype}); pickles are refused")
    if dtype.names is not None or dtype.subdtype is not None:
        raise bad(f"structured dtype {dtype} is not supported")
    if dtype.itemsize == 0:
        raise bad(f"dtype {dtype} has zero-size elements")
    shape = tuple(int(d) for d in shape)
    if len(shape) > MAX_NPY_NDIM:
        raise bad(f"{len(shape)} dimensions, more than the {MAX_NPY_NDIM} allowed")
    if any(d < 0 for d in shape):
        raise bad(f"negative dimension in shape {shape}")
    count = math.prod(shape)
    return NpyHeader(shape, bool(fortran_order), dtype,
                     _MAGIC_BYTES + len(length_bytes) + header_length, count, count * dtype.itemsize)


def read_npy_data(fp: IO[bytes], header: NpyHeader, path: str | os.PathLike[str], what: str) -> np.ndarray:
    """Read the data of an already checked header from ``fp``: exactly
    ``header.nbytes`` bytes (the caller has compared that with the bytes
    available and with its caps). Returns a read-only array."""
    data = _read_up_to(fp, header.nbytes)
    if len(data) != header.nbytes:
        raise MeasuredDataError(path, f"{what}: truncated: the .npy header declares "
                                      f"{header.nbytes:,} data bytes, only {len(data):,} are there")
    a = np.frombuffer(data, dtype=header.dtype, count=header.count)
    return a.reshape(header.shape, order="F" if header.fortran_order else "C")
