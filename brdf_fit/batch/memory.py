"""glibc's allocator in a Dask worker: big buffers reused, not mapped anew for every call.

Dask's nanny starts its workers with ``MALLOC_TRIM_THRESHOLD_`` set
(``distributed.nanny.pre-spawn-environ``).  An explicit threshold turns off
glibc's dynamic mmap threshold, so every block above 128 KiB -- each of XLA's
sample-sized buffers -- is mapped fresh and unmapped on every call, and its
pages faulted in again: a warm ``auto`` on a MERL table ran about 2x slower
there (docs/batch.md).  ``reuse_large_blocks`` raises the thresholds to
where the dynamic rule could take them.
"""

import ctypes
import functools
import os

M_TRIM_THRESHOLD = -1     # mallopt's parameters (malloc.h)
M_MMAP_THRESHOLD = -3
MMAP_THRESHOLD = 32 << 20                 # glibc's largest (DEFAULT_MMAP_THRESHOLD_MAX, 64-bit)
TRIM_THRESHOLD = 2 * MMAP_THRESHOLD       # as the dynamic rule sets it


@functools.cache
def reuse_large_blocks() -> bool:
    """Raise glibc's mmap and trim thresholds when the environment fixed the trim
    threshold (``MALLOC_TRIM_THRESHOLD_``, as Dask's workers have it); True when
    they were raised.  Elsewhere (no such variable, another C library) nothing changes."""
    if "MALLOC_TRIM_THRESHOLD_" not in os.environ:
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return False
    return bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD))
