"""Entry points of ``brdf-fit info`` and ``brdf-fit eval`` for measured files.

Both print problems as one line on stderr and return exit code 2 (no traceback).
"""

import io
import os
import sys

import numpy as np

from . import load
from .errors import MeasuredDataError
from .measured import write_file_atomic


def _fail(command, message):
    print(f"brdf-fit {command}: error: {message}", file=sys.stderr)
    return 2


def info_main(path):
    """Print the summary of a measured file; 0 on success, 2 (message on stderr) on error."""
    try:
        measured = load(path)
    except MeasuredDataError as e:
        return _fail("info", e)
    print(measured.summary())
    return 0


def read_directions(path):
    """DIRECTIONS .npy: float (N, 6), wi then wo. Returns (wi, wo) normalised, or raises ValueError."""
    try:
        a = np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise ValueError(f"{path}: no such file") from None
    except (ValueError, OSError, EOFError) as e:
        raise ValueError(f"{path}: not a readable .npy array ({e})") from None
    if not isinstance(a, np.ndarray) or a.dtype.kind not in "iuf":
        raise ValueError(f"{path}: expected a float array of shape (N, 6), got {getattr(a, 'dtype', type(a))}")
    if a.ndim != 2 or a.shape[1] != 6 or a.shape[0] == 0:
        raise ValueError(f"{path}: expected shape (N, 6) with N >= 1 (wi then wo), got {a.shape}")
    a = a.astype(np.float64)
    bad = np.flatnonzero(~np.isfinite(a).all(axis=1))
    if bad.size:
        raise ValueError(f"{path}: row {bad[0]} has NaN or inf ({bad.size} such rows)")
    wi, wo = a[:, :3], a[:, 3:]
    for name, w in (("wi", wi), ("wo", wo)):
        zero = np.flatnonzero(np.linalg.norm(w, axis=1) == 0.0)
        if zero.size:
            raise ValueError(f"{path}: row {zero[0]}: {name} is the zero vector")
    return wi, wo


_read_directions = read_directions     # the name fitting/cli.py imports


def eval_main(path, directions_npy, out_npy):
    """Evaluate a measured file at direction pairs with the format's own lookup.

    DIRECTIONS: .npy float (N, 6), wi then wo in the local frame (normalised
    here). OUT: .npy float64 (N, 3) RGB BRDF in 1/sr, written atomically.
    Returns 0, or 2 with a message on stderr.
    """
    if os.fspath(path).lower().endswith(".json"):
        return _fail("eval", f"{path}: a .json file is not a measured file "
                             "(evaluating fit results is not supported here)")
    try:
        measured = load(path)
    except MeasuredDataError as e:
        return _fail("eval", e)
    try:
        wi, wo = read_directions(directions_npy)
    except ValueError as e:
        return _fail("eval", e)
    rgb = measured.lookup(wi, wo).astype(np.float64)
    buf = io.BytesIO()
    np.save(buf, rgb)
    try:
        write_file_atomic(out_npy, buf.getvalue())
    except OSError as e:
        return _fail("eval", f"{out_npy}: cannot write ({e.strerror or e})")
    return 0
