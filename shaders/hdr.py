"""Radiance ``.hdr`` (RGBE) files: a small reader and writer, numpy only.

Format (Greg Ward, "Real pixels", Graphics Gems II, 1991; the Radiance file
format documentation): text header starting ``#?RADIANCE`` (or ``#?RGBE``),
``FORMAT=32-bit_rle_rgbe``, optional ``EXPOSURE=`` lines, a blank line, then
the resolution string ``-Y H +X W`` (other orientations are handled too) and
H scanlines of W pixels, each pixel 4 bytes (R, G, B mantissas, shared
exponent E): value = mantissa * 2^(E - 136), 0 when E = 0.

Scanlines are stored flat, or run-length encoded ("new" RLE: the line starts
with 2, 2, W >> 8, W & 255, then the four byte planes one after another, each
as runs: a count byte > 128 repeats the next byte count - 128 times, a count
byte <= 128 is followed by that many literal bytes), or with the old RLE
(a pixel 1, 1, 1, n repeats the previous pixel n << shift times).  The reader
handles all three; the writer writes new RLE when 8 <= W < 32768.
"""

import os
import re

import numpy as np


class HDRFormatError(ValueError):
    """A file that is not a readable Radiance HDR image (names the file and the problem)."""

    def __init__(self, path, problem):
        self.path = os.fspath(path) if path is not None else "<memory>"
        super().__init__(f"{self.path}: {problem}")


def float_to_rgbe(rgb):
    """(..., 3) float -> (..., 4) uint8 RGBE (negative and non-finite values become 0)."""
    rgb = np.nan_to_num(np.asarray(rgb, dtype=np.float64), nan=0.0, posinf=0.0, neginf=0.0)
    rgb = np.maximum(rgb, 0.0)
    v = rgb.max(axis=-1)
    mantissa, exponent = np.frexp(v)
    scale = np.where(v > 1e-32, mantissa * 256.0 / np.where(v > 0, v, 1.0), 0.0)
    out = np.zeros(rgb.shape[:-1] + (4,), dtype=np.uint8)
    out[..., :3] = np.clip(np.floor(rgb * scale[..., None]), 0, 255).astype(np.uint8)
    out[..., 3] = np.where(v > 1e-32, np.clip(exponent + 128, 0, 255), 0).astype(np.uint8)
    return out


def rgbe_to_float(rgbe):
    """(..., 4) uint8 RGBE -> (..., 3) float32."""
    rgbe = np.asarray(rgbe, dtype=np.uint8)
    e = rgbe[..., 3].astype(np.int32)
    f = np.where(e > 0, np.ldexp(1.0, e - 136), 0.0)
    return (rgbe[..., :3].astype(np.float64) * f[..., None]).astype(np.float32)


_RESOLUTION = re.compile(rb"^([-+])([XY]) (\d+) ([-+])([XY]) (\d+)$")


def _parse_header(data, path):
    if not (data.startswith(b"#?RADIANCE") or data.startswith(b"#?RGBE")):
        raise HDRFormatError(path, "not a Radiance HDR file (no '#?RADIANCE' / '#?RGBE' signature)")
    pos = 0
    exposure = 1.0
    while True:
        end = data.find(b"\n", pos)
        if end < 0:
            raise HDRFormatError(path, "header has no end (missing blank line)")
        line = data[pos:end].strip()
        pos = end + 1
        if not line:
            break
        if line.startswith(b"FORMAT=") and line[7:] != b"32-bit_rle_rgbe":
            raise HDRFormatError(path, f"unsupported pixel format {line[7:].decode(errors='replace')!r} "
                                       "(only 32-bit_rle_rgbe)")
        if line.startswith(b"EXPOSURE="):
            try:
                exposure *= float(line[9:])
            except ValueError:
                raise HDRFormatError(path, f"bad EXPOSURE line {line.decode(errors='replace')!r}") from None
    end = data.find(b"\n", pos)
    if end < 0:
        raise HDRFormatError(path, "missing resolution line")
    match = _RESOLUTION.match(data[pos:end].strip())
    if not match:
        raise HDRFormatError(path, f"bad resolution line {data[pos:end][:40]!r}")
    s1, a1, n1, s2, a2, n2 = match.groups()
    if a1 == a2:
        raise HDRFormatError(path, "bad resolution line (the same axis twice)")
    return end + 1, (s1.decode(), a1.decode(), int(n1), s2.decode(), a2.decode(), int(n2)), exposure


def _decode_scanline(data, pos, width, prev, path):
    """One scanline -> (uint8 (width, 4), new position)."""
    n = len(data)
    if (8 <= width < 32768 and pos + 4 <= n and data[pos] == 2 and data[pos + 1] == 2
            and data[pos + 2] < 128):
        if (data[pos + 2] << 8 | data[pos + 3]) != width:
            raise HDRFormatError(path, "run-length scanline of the wrong width")
        pos += 4
        line = np.empty((4, width), dtype=np.uint8)
        for c in range(4):
            x = 0
            while x < width:
                if pos >= n:
                    raise HDRFormatError(path, "file ends inside a scanline")
                count = data[pos]
                pos += 1
                if count > 128:
                    count -= 128
                    if x + count > width or pos >= n:
                        raise HDRFormatError(path, "bad run length in a scanline")
                    line[c, x:x + count] = data[pos]
                    pos += 1
                else:
                    if count == 0 or x + count > width or pos + count > n:
                        raise HDRFormatError(path, "bad literal run in a scanline")
                    line[c, x:x + count] = np.frombuffer(data, np.uint8, count, pos)
                    pos += count
                x += count
        return line.T, pos
    # flat or old-style RLE
    out = np.empty((width, 4), dtype=np.uint8)
    x, shift = 0, 0
    while x < width:
        if pos + 4 > n:
            raise HDRFormatError(path, "file ends inside a scanline")
        px = data[pos:pos + 4]
        pos += 4
        if px[0] == 1 and px[1] == 1 and px[2] == 1:
            count = px[3] << shift
            last = out[x - 1] if x > 0 else prev
            if last is None or x + count > width:
                raise HDRFormatError(path, "bad old-style run in a scanline")
            out[x:x + count] = last
            x += count
            shift += 8
        else:
            out[x] = np.frombuffer(px, np.uint8)
            x += 1
            shift = 0
    return out, pos


def read_hdr(path):
    """Read a Radiance .hdr file -> float32 (H, W, 3), top row first, linear RGB.

    EXPOSURE lines are undone (pixel values / exposure), as the format asks.
    Raises HDRFormatError naming the file for anything unreadable.
    """
    from data_loaders.errors import open_regular
    path = os.fspath(path)
    try:
        with open_regular(path) as f:      # a FIFO must not hang the command
            data = f.read()
    except OSError as exc:
        raise HDRFormatError(path, f"cannot read the file ({exc.strerror or exc})") from None
    pos, (s1, a1, n1, s2, a2, n2), exposure = _parse_header(data, path)
    height, width = n1, n2          # the first axis runs over scanlines
    if height <= 0 or width <= 0:
        raise HDRFormatError(path, "empty image")
    rows = np.empty((height, width, 4), dtype=np.uint8)
    prev = None
    for y in range(height):
        rows[y], pos = _decode_scanline(data, pos, width, prev, path)
        prev = rows[y, -1]
    img = rgbe_to_float(rows)
    # orient to (rows top to bottom = -Y .. ; columns left to right = +X)
    if a1 == "Y":
        if s1 == "+":
            img = img[::-1]
        if s2 == "-":
            img = img[:, ::-1]
    else:  # scanlines are columns
        img = np.transpose(img, (1, 0, 2))
        if s1 == "-":
            img = img[:, ::-1]
        if s2 == "+":
            img = img[::-1]
    if exposure != 1.0 and exposure > 0:
        img = img / np.float32(exposure)
    return np.ascontiguousarray(img, dtype=np.float32)


def _encode_plane(plane):
    """Run-length encode one byte plane of a scanline (new RLE)."""
    out = bytearray()
    n = len(plane)
    x = 0
    while x < n:
        # length of the run starting at x
        run = 1
        while x + run < n and run < 127 and plane[x + run] == plane[x]:
            run += 1
        if run >= 4:
            out += bytes((128 + run, plane[x]))
            x += run
            continue
        # literal chunk up to the next run of >= 4 (max 128 bytes)
        start = x
        while x < n and x - start < 128:
            if x + 3 < n and plane[x] == plane[x + 1] == plane[x + 2] == plane[x + 3]:
                break
            x += 1
        out += bytes((x - start,)) + bytes(plane[start:x])
    return bytes(out)


def write_hdr(path, image, rle=True):
    """Write float (H, W, 3) linear RGB as a Radiance .hdr (new RLE when possible), atomically."""
    image = np.asarray(image, dtype=np.float32)
    if image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"image must be (H, W, 3), got {image.shape}")
    height, width = image.shape[:2]
    rgbe = float_to_rgbe(image)
    parts = [b"#?RADIANCE\n# written by brdf-fit shaders.hdr\nFORMAT=32-bit_rle_rgbe\n\n",
             f"-Y {height} +X {width}\n".encode()]
    if rle and 8 <= width < 32768:
        head = bytes((2, 2, width >> 8, width & 255))
        for y in range(height):
            parts.append(head)
            for c in range(4):
                parts.append(_encode_plane(rgbe[y, :, c].tobytes()))
    else:
        parts.append(rgbe.tobytes())
    from data_loaders.measured import write_file_atomic
    path = os.fspath(path)
    write_file_atomic(path, b"".join(parts))
