"""The members of an NPZ sample list, checked before anything is decompressed.

The member names first (required columns present, no case-insensitive
clashes), then the .npy header of every member (read from the stream: no
object dtypes, i.e. no pickles, anywhere), then, for the members used, the
declared uncompressed size against the caps below, and shape x itemsize
against that size (exactly: truncated or padded members are refused) and the
caller's sample cap.  Only then are the used members read, one at a time.
"""

import io
import lzma
import struct
import zipfile
import zlib

import numpy as np

from .errors import MeasuredDataError
from .npy import read_npy_data, read_npy_header

# The declared uncompressed size of a metadata member (units, material,
# isotropic: one short string or bool); a column member may hold one float64
# column of the caller's sample cap plus its .npy header.
MAX_NPZ_META_BYTES = 65_536
MAX_NPZ_MEMBERS = 1024            # np.savez of a sample list writes about 10
HEADER_BYTES = 65_536


def names(items: "list[str] | tuple[str, ...]", limit: int = 20) -> str:
    """Comma-separated names for a message, at most ``limit`` of them, each shortened."""
    shown = [n if len(n) <= 40 else n[:40] + "..." for n in list(items)[:limit]]
    more = f", ... ({len(items) - limit} more)" if len(items) > limit else ""
    return ", ".join(shown) + more


# what zipfile and its decompressors raise for a damaged archive (RuntimeError:
# an encrypted member; NotImplementedError: an unknown compression method)
_ZIP_ERRORS = (zipfile.BadZipFile, zlib.error, lzma.LZMAError, struct.error, EOFError, OSError,
               RuntimeError, NotImplementedError, ValueError, OverflowError)


def read_members(path: str, data: bytes, required: tuple[str, ...], optional: tuple[str, ...],
                 meta: tuple[str, ...], max_samples: int) -> dict[str, np.ndarray]:
    """{lower-case array name: array} of the members ``required`` (1-D numeric columns,
    all present), ``optional`` (columns) and ``meta`` (one string or bool each), checked
    before reading; raises MeasuredDataError naming ``path``."""
    unreadable = "not a readable NPZ sample list"
    # Every central-directory entry starts with this signature, so the count
    # bounds the number of members before zipfile builds its list of them.
    if data.count(b"PK\x01\x02") > MAX_NPZ_MEMBERS:
        raise MeasuredDataError(path, f"{unreadable}: more than {MAX_NPZ_MEMBERS:,} members")
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            infos = zf.infolist()
            by_key = {}
            for info in infos:
                key = info.filename[:-4] if info.filename.endswith(".npy") else info.filename
                by_key.setdefault(key.lower(), []).append(info)
            wanted = required + optional + meta
            missing = [c for c in required if c not in by_key]
            if missing:
                raise MeasuredDataError(path, f"missing array(s) {', '.join(missing)} "
                                              f"(has {names(sorted(by_key))})")
            for key in wanted:
                if len(by_key.get(key, ())) > 1:
                    clash = names([repr(i.filename) for i in by_key[key]])
                    raise MeasuredDataError(path, f"members {clash} clash (array names are "
                                                  "case-insensitive)")
            # The .npy header of every member, from the stream (a few hundred
            # bytes each): pickles are refused even in members not used.
            headers = {}
            for info in infos:
                what = f"{unreadable}: member {names([info.filename])!r}"
                with zf.open(info) as fp:
                    header = read_npy_header(fp, path, what)
                key = (info.filename[:-4] if info.filename.endswith(".npy") else info.filename).lower()
                if key in wanted:
                    headers[key] = (info, header, what)
            _check_headers(path, headers, required[0], meta, max_samples)
            arrays = {}
            for key, (info, header, what) in headers.items():
                with zf.open(info) as fp:
                    read_npy_header(fp, path, what)
                    arrays[key] = read_npy_data(fp, header, path, what)
                    if fp.read(1):       # also makes zipfile check the CRC
                        raise MeasuredDataError(path, f"{what}: longer than its header says")
            return arrays
    except MeasuredDataError:
        raise
    except _ZIP_ERRORS as e:
        text = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise MeasuredDataError(path, f"{unreadable} ({text[:160]})") from None


def _check_headers(path, headers, first, meta_names, max_samples):
    """Sizes, dtypes and shapes of the used members, before any is read."""
    for key, (info, header, _what) in headers.items():
        meta = key in meta_names
        cap = MAX_NPZ_META_BYTES if meta else 8 * max_samples + HEADER_BYTES
        if info.file_size > cap:
            raise MeasuredDataError(path, f"array {key!r}: member is {info.file_size:,} bytes uncompressed, "
                                          f"more than the {cap:,} allowed")
        data_bytes = info.file_size - header.header_bytes
        if header.nbytes != data_bytes:
            raise MeasuredDataError(path, f"array {key!r}: the .npy header declares {header.dtype}{list(header.shape)} "
                                    f"({header.nbytes:,} data bytes) but the member holds {data_bytes:,} "
                                    "(truncated or padded?)")
        if not meta and header.dtype.kind not in "biuf":
            raise MeasuredDataError(path, f"array {key!r} is not numeric ({header.dtype})")
    shape = headers[first][1].shape
    if len(shape) != 1:
        raise MeasuredDataError(path, f"array {first!r} has shape {shape}; columns must be 1-D")
    n = shape[0]
    if n > max_samples:
        raise MeasuredDataError(path, f"{n:,} samples, more than the {max_samples:,} allowed")
    for key, (_info, header, _what) in headers.items():
        if key not in meta_names and header.shape != (n,):
            raise MeasuredDataError(path, f"array {key!r} has shape {header.shape}; all columns must be "
                                          f"1-D of the same length as {first} ({n})")
