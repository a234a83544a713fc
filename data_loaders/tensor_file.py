"""Mitsuba's ``tensor_file`` v1.0, the container of RGL-EPFL ``.bsdf`` files: read and write.

File format (little-endian): ``b"tensor_file\\0"``, u8 major, u8 minor,
u32 n_fields; per field: u16 name_len, name, u16 ndim, u8 dtype (1 = u8 ...
10 = f32, 11 = f64), u64 offset, u64 shape[ndim]; payload at the absolute
offset, C order.  Every size is checked against the file before an array is made.
"""

import math
import os
import struct

import numpy as np

from ._typing import ArrayLike
from .errors import MeasuredDataError
from .measured import read_file_bytes, write_file_atomic

MAGIC = b"tensor_file\0"

# dtype codes of Mitsuba's tensor_file
DTYPES = {1: "u1", 2: "i1", 3: "<u2", 4: "<i2", 5: "<u4", 6: "<i4", 7: "<u8", 8: "<i8",
          9: "<f2", 10: "<f4", 11: "<f8"}
DTYPE_CODES = {np.dtype(v).newbyteorder("<").str: k for k, v in DTYPES.items()}

# Sanity limits, checked before allocating: the RGL files are about 1 MB
# (isotropic) to tens of MB (anisotropic); the reader holds a few float64
# copies of the tables, so this cap keeps its memory to a few GB.
MAX_FILE_BYTES = 2 ** 28                 # 256 MiB
MAX_TENSOR_FIELDS = 1024                 # an RGL file has 10
MAX_TENSOR_NDIM = 32                     # RGL fields have at most 5; numpy allows 64


def read_tensor_file(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """Parse a Mitsuba tensor_file v1.0: returns {name: numpy array} (C order).

    Raises MeasuredDataError for a wrong magic, an unknown version or dtype,
    a duplicate field, more than MAX_TENSOR_FIELDS fields or MAX_TENSOR_NDIM
    dimensions, a header or payload running past the end of the file (sizes
    are Python ints, checked before any array is made).
    """
    path = os.fspath(path)
    data, sha = read_file_bytes(path, max_bytes=MAX_FILE_BYTES)
    return _parse_tensor_bytes(path, data), sha


def _parse_tensor_bytes(path, data):
    size = len(data)
    if size < 18 or data[:12] != MAGIC:
        raise MeasuredDataError(path, "not a Mitsuba tensor file (the magic b'tensor_file\\0' is missing)")
    major, minor = data[12], data[13]
    if (major, minor) != (1, 0):
        raise MeasuredDataError(path, f"tensor_file version {major}.{minor}; only 1.0 is supported")
    (n_fields,) = struct.unpack_from("<I", data, 14)
    if n_fields > MAX_TENSOR_FIELDS or 18 + n_fields * 13 > size:
        raise MeasuredDataError(path, f"header claims {n_fields:,} fields, more than a {size:,}-byte "
                                      f"file can hold (at most {MAX_TENSOR_FIELDS} allowed)")
    pos = 18
    fields = {}

    def take(fmt, what):
        nonlocal pos
        n = struct.calcsize(fmt)
        if pos + n > size:
            raise MeasuredDataError(path, f"truncated tensor file: header ends inside {what}")
        out = struct.unpack_from(fmt, data, pos)
        pos += n
        return out

    for k in range(n_fields):
        (name_len,) = take("<H", f"field {k}")
        if pos + name_len > size:
            raise MeasuredDataError(path, f"truncated tensor file: header ends inside the name of field {k}")
        try:
            name = data[pos:pos + name_len].decode("utf-8")
        except UnicodeDecodeError:
            raise MeasuredDataError(path, f"field {k} has a name that is not UTF-8") from None
        pos += name_len
        label = repr(name) if len(name) <= 40 else repr(name[:40] + "...")
        if name in fields:
            raise MeasuredDataError(path, f"field {label} appears twice")
        ndim, dtype_code, offset = take("<HBQ", f"field {label}")
        if ndim > MAX_TENSOR_NDIM:
            raise MeasuredDataError(path, f"field {label} declares {ndim} dimensions, more than the "
                                          f"{MAX_TENSOR_NDIM} allowed")
        shape = take(f"<{ndim}Q", f"the shape of field {label}") if ndim else ()
        if dtype_code not in DTYPES:
            raise MeasuredDataError(path, f"field {label} has unknown dtype code {dtype_code}")
        dtype = np.dtype(DTYPES[dtype_code])
        # Python ints: no overflow. Zero-length axes count as 1 here, so no axis
        # can be larger than the file either (numpy refuses such shapes).
        count = math.prod(shape)
        bound = math.prod(max(d, 1) for d in shape) * dtype.itemsize
        if offset > size or bound > size - offset:
            need = f"{count:,} x {dtype.itemsize} bytes" if bound.bit_length() < 200 else "far more bytes"
            raise MeasuredDataError(
                path, f"truncated or corrupt tensor file: field {label} (shape {_shape_text(shape)}, "
                      f"{dtype}) needs {need} at offset {offset:,}, past the end of the {size:,}-byte file")
        fields[name] = np.frombuffer(data, dtype=dtype, count=count, offset=offset).reshape(shape)
    return fields


def _shape_text(shape):
    text = "x".join(str(d) for d in shape[:8]) + ("x..." if len(shape) > 8 else "")
    return f"[{text}]" if len(text) <= 80 else f"[{len(shape)} dims]"


def write_tensor_file(path: str | os.PathLike[str], fields: dict[str, ArrayLike]) -> None:
    """Write {name: array} as a Mitsuba tensor_file v1.0 (C order, little-endian), atomically."""
    arrays = []
    for name, a in fields.items():
        a = np.ascontiguousarray(a)
        a = a.astype(a.dtype.newbyteorder("<"))
        code = DTYPE_CODES.get(a.dtype.str)
        if code is None:
            raise ValueError(f"field {name!r}: dtype {a.dtype} has no tensor_file code")
        arrays.append((name.encode("utf-8"), a, code))
    header_size = 18 + sum(2 + len(n) + 2 + 1 + 8 + 8 * a.ndim for n, a, _ in arrays)
    header = bytearray(MAGIC + bytes([1, 0]) + struct.pack("<I", len(arrays)))
    payload = bytearray()
    offset = header_size
    for name, a, code in arrays:
        offset += (-offset) % 8          # 8-byte alignment
        pad = offset - header_size - len(payload)
        payload += b"\0" * pad
        header += struct.pack("<H", len(name)) + name + struct.pack("<HBQ", a.ndim, code, offset)
        header += struct.pack(f"<{a.ndim}Q", *a.shape)
        payload += a.tobytes()
        offset += a.nbytes
    write_file_atomic(path, bytes(header) + bytes(payload))
