"""Will the fit fit?  The memory a fit needs, estimated from its table's size, against what
the process may use -- checked before a fit starts, so that a limit too small ends in one
line instead of XLA's ``std::bad_alloc`` abort (no error line, no exit code of ours).

Two limits count: the address space (``ulimit -v``, RLIMIT_AS: XLA's CPU runtime maps
far more than it touches -- thread stacks, arenas) and the memory the machine or the
process's cgroup has left (what the fit touches).  The estimates come from the limits
under which ``brdf-fit fit`` failed and ran (2 cores, JAX 0.10.2, caches off,
2026-12-04), each estimate between the two:

=====================================  =============  ==========  =========  =========
table, models                          fails under    runs under  estimate   VmHWM
=====================================  =============  ==========  =========  =========
3 456-cell sample list, ggx+lambert    1.62 GiB       2.00 GiB    1.75 GiB   0.45 GiB
MERL red-plastic (1 458 000 cells)     1.72 GiB       1.91 GiB    1.89 GiB   0.85 GiB
3 456-cell sample list, auto           2.00 GiB       2.29 GiB    2.25 GiB   1.00 GiB
MERL red-plastic, auto                 2.29 GiB       2.67 GiB    2.52 GiB   1.31 GiB
=====================================  =============  ==========  =========  =========

(2026-12-06: since a converted material's exported errors are read as the engines draw it,
+turquin, a fit compiles that program too: the sample list's fit failed under 1.90 GiB in 2 of
6 runs and ran under 2.00 GiB in 6 of 6, where it ran under 1.81 before; the base estimate
went from 1.65 to 1.75 GiB.  The other rows were not measured again.)

so a fit refused for its address space would have failed (XLA aborts with
``std::bad_alloc``, a segmentation fault or a runtime error).  Resident memory is
estimated from the peaks (VmHWM) the same way, a little above them.
"""

import os
import resource

GIB = 1 << 30
BASE_ADDRESS_SPACE = 1.75 * GIB     # a fit of a tiny table: XLA's runtime and the fitter's programs
BASE_RESIDENT = 0.45 * GIB
AUTO_ADDRESS_SPACE = 0.50 * GIB     # auto's screening: more programs, two fits at once
AUTO_RESIDENT = 0.55 * GIB
BYTES_PER_CELL = 100                # address space per cell of the table (its copies: samples, parts)
AUTO_BYTES_PER_CELL = 200
RESIDENT_BYTES_PER_CELL = 300


class NotEnoughMemory(ValueError):
    """The fit would not fit in the memory the process may use."""


def needed(cells: int, auto: bool) -> tuple[float, float]:
    """(address space, resident memory) in bytes a fit of a table of ``cells`` cells needs."""
    if auto:
        return (BASE_ADDRESS_SPACE + AUTO_ADDRESS_SPACE + AUTO_BYTES_PER_CELL * cells,
                BASE_RESIDENT + AUTO_RESIDENT + RESIDENT_BYTES_PER_CELL * cells)
    return BASE_ADDRESS_SPACE + BYTES_PER_CELL * cells, BASE_RESIDENT + RESIDENT_BYTES_PER_CELL * cells


def available() -> float | None:
    """What the machine and this process's cgroup have left, in bytes (None where unknown)."""
    left = []
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    left.append(int(line.split()[1]) * 1024)
    except (OSError, ValueError, IndexError):
        pass
    try:
        with open("/proc/self/cgroup") as f:
            group = f.read().strip().split("::", 1)[-1]
        base = os.path.join("/sys/fs/cgroup", group.lstrip("/"))
        with open(os.path.join(base, "memory.max")) as f:
            limit = f.read().strip()
        if limit != "max":
            with open(os.path.join(base, "memory.current")) as f:
                left.append(int(limit) - int(f.read()))
    except (OSError, ValueError):
        pass
    return min(left) if left else None


def _resident() -> float:
    """This process's resident memory, in bytes (already counted as used by the machine)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0.0


def check(cells: int, auto: bool = False, name: str = "this table") -> None:
    """Raise NotEnoughMemory (one line: what is needed, what the limit is) when a fit of a
    table of ``cells`` cells (``name``: its file) cannot fit in the address space or the memory left."""
    address, resident = needed(cells, auto)
    what = f"a fit{' with auto' if auto else ''} of {name} ({cells:,} cells)"
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft != resource.RLIM_INFINITY and soft < address:
        raise NotEnoughMemory(f"{what} needs about {address / GIB:.1f} GiB of address space, and this "
                              f"process may use {soft / GIB:.2f} GiB (ulimit -v {soft // 1024}): "
                              f"raise the limit")
    left = available()
    if left is not None and left + _resident() < resident:
        raise NotEnoughMemory(f"{what} needs about {resident / GIB:.1f} GiB of memory, and "
                              f"{max(left, 0) / GIB:.2f} GiB is available: close other programs "
                              f"or fit on a larger machine")
