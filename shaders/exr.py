"""OpenEXR lat-long environment maps: header checks in Python, pixels through the ``OpenEXR`` package.

What is read: a single-part, flat (not deep) scanline or tiled image with
half or float ``R``, ``G``, ``B`` channels (other channels, e.g. ``A``, are
ignored), every channel sampled at every pixel, and a data window equal to
the display window.  Tiled files give their full-resolution level.  Rows run
top to bottom as stored (increasing y), so a map written as .exr and as .hdr
from the same array gives the same Environment: the pixel-to-direction
mapping is the renderer's (shaders/environment.py), whatever the file's
``envmap`` attribute says, and ``chromaticities`` are not applied (pixels
are taken as linear Rec. 709 / sRGB primaries, as for .hdr).

Format facts used (the OpenEXR file layout document, openexr.com): magic
``76 2f 31 01``; a 4-byte version field (byte 0 = 2; flag bits 0x200 single
tiled part, 0x400 long names, 0x800 deep data, 0x1000 multi-part); then
attributes ``name\\0 type\\0 int32 size, value`` up to an empty name.
``chlist`` = channels ``name\\0 int32 pixel_type (0 uint, 1 half, 2 float),
u8 pLinear, 3 reserved, int32 xSampling, int32 ySampling``, then ``\\0``;
``box2i`` = int32 xMin, yMin, xMax, yMax.

Every problem raises :class:`shaders.hdr.HDRFormatError` naming the file
(one line): not EXR, truncated or corrupt, unsupported layout, missing or
non-float R/G/B channels, NaN / infinite or negative pixels.  The checks on
the header, including the image size, come before the library allocates
anything; the library's own messages about corrupt pixel data are caught
and put in that line instead of being printed.
"""

import contextlib
import io
import os
import struct
import tempfile

import numpy as np

from .hdr import HDRFormatError

EXR_MAGIC = b"\x76\x2f\x31\x01"
FLAG_TILED, FLAG_LONG_NAMES, FLAG_DEEP, FLAG_MULTIPART = 0x200, 0x400, 0x800, 0x1000
PIXEL_TYPES = {0: "uint", 1: "half", 2: "float"}
ENVMAP_CUBE = 1

MAX_HEADER_BYTES = 1 << 24               # 16 MiB of attributes (previews included) at most
MAX_SIDE = 1 << 16                       # pixels per side
MAX_PIXELS = 1 << 27                     # 16k x 8k; float32 RGB of that is 1.5 GiB


def is_exr(head):
    """True when ``head`` (the first bytes of a file) starts with the OpenEXR magic number."""
    return bytes(head[:4]) == EXR_MAGIC


def _read_head(path):
    from data_loaders.errors import open_regular
    try:
        with open_regular(path) as f:      # a FIFO must not hang the command
            return f.read(MAX_HEADER_BYTES + 8)
    except OSError as exc:
        raise HDRFormatError(path, f"cannot read the file ({exc.strerror or exc})") from None


def read_exr_header(path):
    """The header attributes the reader needs, checked: {"channels": {name: (type, xs, ys)},
    "dataWindow": (x0, y0, x1, y1), "displayWindow": ..., "envmap": int or None, "tiled": bool}."""
    path = os.fspath(path)
    data = _read_head(path)
    if not is_exr(data):
        raise HDRFormatError(path, "not an OpenEXR file (the magic number 76 2f 31 01 is missing)")
    if len(data) < 8:
        raise HDRFormatError(path, "truncated OpenEXR file (ends inside the version field)")
    (version,) = struct.unpack_from("<I", data, 4)
    if version & 0xFF != 2:
        raise HDRFormatError(path, f"OpenEXR version {version & 0xFF}; only version 2 files are read")
    if version & FLAG_MULTIPART:
        raise HDRFormatError(path, "multi-part OpenEXR file; only single-part images are supported")
    if version & FLAG_DEEP:
        raise HDRFormatError(path, "deep-data OpenEXR file; an environment map must be a flat image")
    max_name = 255 if version & FLAG_LONG_NAMES else 31
    pos = 8
    attrs = {}

    def cstring(what):
        nonlocal pos
        end = data.find(b"\0", pos, pos + max_name + 1)
        if end < 0:
            raise HDRFormatError(path, f"truncated or corrupt OpenEXR header (in {what})")
        text = data[pos:end].decode("latin-1")
        pos = end + 1
        return text

    while True:
        name = cstring("an attribute name")
        if not name:
            break
        kind = cstring(f"the type of attribute {name!r}")
        if pos + 4 > len(data):
            raise HDRFormatError(path, f"truncated OpenEXR header (in attribute {name!r})")
        (n,) = struct.unpack_from("<i", data, pos)
        pos += 4
        if n < 0 or pos + n > len(data):
            too_big = pos + n > MAX_HEADER_BYTES
            raise HDRFormatError(path, f"{'corrupt' if n < 0 or too_big else 'truncated'} OpenEXR header: "
                                       f"attribute {name!r} claims {n:,} bytes")
        attrs[name] = (kind, bytes(data[pos:pos + n]))
        pos += n
    header = {"tiled": bool(version & FLAG_TILED), "envmap": None}
    for need in ("channels", "dataWindow", "displayWindow"):
        if need not in attrs:
            raise HDRFormatError(path, f"OpenEXR header lacks the required attribute {need!r}")
    header["channels"] = _parse_chlist(path, attrs["channels"][1])
    for key in ("dataWindow", "displayWindow"):
        kind, raw = attrs[key]
        if kind != "box2i" or len(raw) != 16:
            raise HDRFormatError(path, f"OpenEXR attribute {key!r} is not a box2i")
        header[key] = struct.unpack("<4i", raw)
    if "envmap" in attrs and len(attrs["envmap"][1]) == 1:
        header["envmap"] = attrs["envmap"][1][0]
    return header


def _parse_chlist(path, raw):
    channels, pos = {}, 0
    while pos < len(raw) and raw[pos] != 0:
        end = raw.find(b"\0", pos)
        if end < 0 or end + 17 > len(raw):
            raise HDRFormatError(path, "corrupt OpenEXR channel list")
        name = raw[pos:end].decode("latin-1")
        ptype, _, xs, ys = struct.unpack_from("<iB3xii", raw, end + 1)
        channels[name] = (ptype, xs, ys)
        pos = end + 17
    return channels


def _check_layout(path, header):
    ch = header["channels"]
    missing = [c for c in "RGB" if c not in ch]
    if missing:
        found = ", ".join(sorted(ch)[:8]) + (", ..." if len(ch) > 8 else "") or "none"
        raise HDRFormatError(path, f"OpenEXR file has no {'/'.join(missing)} channel (channels: {found}); "
                                   "an environment map needs R, G and B")
    for c in "RGB":
        ptype, xs, ys = ch[c]
        if ptype not in (1, 2):
            raise HDRFormatError(path, f"OpenEXR channel {c} is {PIXEL_TYPES.get(ptype, f'type {ptype}')}; "
                                       "only half and float channels are read")
        if (xs, ys) != (1, 1):
            raise HDRFormatError(path, f"OpenEXR channel {c} is subsampled ({xs} x {ys}); not supported")
    if header["envmap"] == ENVMAP_CUBE:
        raise HDRFormatError(path, "OpenEXR cube map; only lat-long (equirectangular) maps are supported")
    x0, y0, x1, y1 = header["dataWindow"]
    width, height = x1 - x0 + 1, y1 - y0 + 1
    if width <= 0 or height <= 0:
        raise HDRFormatError(path, "empty OpenEXR image (empty data window)")
    if width > MAX_SIDE or height > MAX_SIDE or width * height > MAX_PIXELS:
        raise HDRFormatError(path, f"OpenEXR image of {width:,} x {height:,} pixels is larger than "
                                   f"supported ({MAX_SIDE:,} per side, {MAX_PIXELS:,} pixels)")
    if header["dataWindow"] != header["displayWindow"]:
        raise HDRFormatError(path, f"OpenEXR data window {header['dataWindow']} differs from the display "
                                   f"window {header['displayWindow']}; a lat-long map must fill it")
    return height, width


@contextlib.contextmanager
def _captured_output():
    """Collect what the OpenEXR library prints while reading: its Python-level warnings
    and the C library's messages on file descriptor 2. Yields a list that receives the text."""
    text = []
    py = io.StringIO()
    try:
        saved = os.dup(2)
    except OSError:                       # no stderr descriptor to borrow
        saved = None
    with tempfile.TemporaryFile() as tmp:
        try:
            if saved is not None:
                os.dup2(tmp.fileno(), 2)
            with contextlib.redirect_stdout(py), contextlib.redirect_stderr(py):
                yield text
        finally:
            if saved is not None:
                os.dup2(saved, 2)
                os.close(saved)
            tmp.seek(0)
            text += [tmp.read().decode("utf-8", "replace"), py.getvalue()]


def _library_problem(path, exc, output):
    """One line from the library's messages (its C messages first), without the path prefix."""
    lines = [line.strip() for chunk in output for line in chunk.splitlines() if line.strip()]
    lines.append(str(exc).strip() or type(exc).__name__)
    line = lines[0]
    if line.startswith(f"{path}: "):
        line = line[len(path) + 2:]
    if " - " in line and line.startswith("Warning:"):
        line = line.split(" - ", 1)[1]
    return line if len(line) <= 200 else line[:197] + "..."


def _openexr(path):
    try:
        import OpenEXR
    except ImportError:
        raise HDRFormatError(path, "reading OpenEXR files needs the OpenEXR package "
                                   "(pip install OpenEXR)") from None
    return OpenEXR


def read_exr(path):
    """Read an OpenEXR lat-long map -> float32 (H, W, 3), top row first, linear RGB.

    Raises HDRFormatError naming the file for anything unreadable or
    unusable (see the module docstring), including NaN, infinite or
    negative pixel values.
    """
    path = os.fspath(path)
    height, width = _check_layout(path, read_exr_header(path))
    OpenEXR = _openexr(path)
    rgb = error = None
    with _captured_output() as output:
        try:
            with OpenEXR.File(path, separate_channels=True) as f:
                channels = f.channels()
                rgb = np.stack([np.asarray(channels[c].pixels, dtype=np.float32) for c in "RGB"], axis=-1)
        except Exception as exc:          # the bindings raise RuntimeError / ValueError / KeyError
            error = exc
    if rgb is None:
        raise HDRFormatError(path, f"corrupt or truncated OpenEXR file: {_library_problem(path, error, output)}")
    if rgb.shape != (height, width, 3):
        raise HDRFormatError(path, f"OpenEXR pixels came back as {rgb.shape[:2]}, not the header's "
                                   f"{height} x {width}")
    finite = np.isfinite(rgb)
    if not finite.all():
        raise HDRFormatError(path, f"{rgb.size - int(np.count_nonzero(finite)):,} NaN or infinite pixel "
                                   "values; an environment map must be finite")
    negative = rgb < 0.0
    if negative.any():
        raise HDRFormatError(path, f"{int(np.count_nonzero(negative)):,} negative pixel values (down to "
                                   f"{float(rgb.min()):.3g}); radiance cannot be negative")
    return np.ascontiguousarray(rgb)


def write_exr(path, image, half=False):
    """Write float (H, W, 3) linear RGB as a single-part scanline OpenEXR (ZIP
    compression; half or float channels R, G, B), atomically."""
    image = np.asarray(image, dtype=np.float16 if half else np.float32)
    if image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"image must be (H, W, 3), got {image.shape}")
    path = os.fspath(path)
    OpenEXR = _openexr(path)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    pixels = {c: np.ascontiguousarray(image[..., k]) for k, c in enumerate("RGB")}
    from data_loaders.measured import write_file_atomic
    with tempfile.TemporaryDirectory() as folder:
        tmp = os.path.join(folder, "image.exr")
        with OpenEXR.File(header, pixels) as f:
            f.write(tmp)
        with open(tmp, "rb") as f:
            data = f.read()
    write_file_atomic(path, data)
