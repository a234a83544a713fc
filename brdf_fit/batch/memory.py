"""glibc's allocator in a Dask worker: big buffers reused, not mapped anew for every call.

Dask's nanny starts its workers with ``MALLOC_TRIM_THRESHOLD_`` set
(``distributed.nanny.pre-spawn-environ``).  An explicit threshold turns off
glibc's dynamic mmap threshold, so every block above 128 KiB -- each of XLA's
sample-sized buffers -- is mapped fresh and unmapped on every call, and its
pages faulted in again: a warm ``auto`` on a MERL table ran about 2x slower
there (docs/batch.md).  ``reuse_large_blocks`` raises the thresholds to
where the dynamic rule could take them.

``give_back_memory`` hands what a finished step freed back to the system: a
long in-process run (``brdf-fit demo``: fits, renders, exports, report,
library) otherwise keeps every freed page in glibc's arenas, and its resident
set only grows (docs/performance.md, "The test suite's memory").
"""

import ctypes
import functools
import gc
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


def give_back_memory(own_process: bool = False) -> None:
    """Collect the garbage of a step just finished (a file's fits, a material's pages) and
    return the C heap's free pages to the system (glibc's ``malloc_trim``).

    XLA's buffers, a loaded table's arrays and matplotlib's canvases come from the C heap;
    once freed, glibc keeps their pages for reuse, spread over one arena per thread, so a
    process that works on one material after another holds the freed memory of all of them:
    the demo in one process reached 1.75-1.88 GB resident, 1.3 GB with this after each
    step.  Costs about 0.1 s (the collection).  Elsewhere (not glibc) only the collection.

    ``own_process``: the process is the toolkit's own worker (a batch's local worker, which
    does one step after another and nothing else): what survives the collection is frozen
    (``gc.freeze``), so the next collections -- this one after the next file and Python's
    own -- go through what was made since, not through the 420 000 objects a worker holds
    after its first file (JAX's modules, the programs and their caches): 0.25-0.8 s a file
    on tiny tables before (docs/performance.md, *Many tiny tables*).  The survivors are
    never collected as cycles again (reference counting still frees them): in such a worker
    they are what it keeps to the end.  Never in a process that is not the toolkit's own."""
    gc.collect()
    if own_process:
        gc.freeze()
    try:
        ctypes.CDLL(None).malloc_trim(0)
    except (OSError, AttributeError):        # not glibc: nothing to trim
        pass
