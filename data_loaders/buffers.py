"""Arrays at cache-line aligned addresses.

numpy aligns its own arrays to 16 bytes.  At 64 (a cache line, the widest SIMD
load) ``jax.device_put`` on the CPU wraps an array as it is instead of copying
it: the fitter's sample sets (~0.3 GB for a MERL table, each byte of which a
fresh process pays for in page faults) are then made once, not twice.
"""

import numpy as np

from ._typing import ArrayLike

ALIGN = 64      # bytes


def aligned_empty(shape: int | tuple[int, ...], dtype: object = np.float64) -> np.ndarray:
    """An uninitialised C-contiguous array of ``shape`` at an ALIGN-byte aligned address."""
    dtype = np.dtype(dtype)
    shape = (shape,) if isinstance(shape, int) else tuple(shape)
    raw = np.empty(int(np.prod(shape)) * dtype.itemsize + ALIGN, np.uint8)
    start = -raw.ctypes.data % ALIGN
    return raw[start:start + raw.size - ALIGN].view(dtype).reshape(shape)


def take_rows(a: ArrayLike, index: ArrayLike) -> np.ndarray:
    """``a[index]`` (rows of ``a`` by an integer index array) in a new aligned array."""
    a = np.asarray(a)
    index = np.asarray(index)
    if index.size and (index.min() < -len(a) or index.max() >= len(a)):
        raise IndexError(f"row index out of range for {len(a)} rows")
    out = aligned_empty((index.size,) + a.shape[1:], a.dtype)
    np.take(a, index, axis=0, out=out, mode="wrap")    # in range; "raise" would copy through a buffer
    return out
