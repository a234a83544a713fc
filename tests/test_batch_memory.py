"""brdf_fit.batch.memory: in a process started as Dask starts its workers, big blocks come from the heap."""

import ctypes
import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# glibc's mallinfo2 counts the blocks it mapped with mmap (hblks): a 1 MiB malloc is one of them
# while the mmap threshold is fixed at its 128 KiB default, none once it is raised
PROBE = """
import ctypes
class Info(ctypes.Structure):
    _fields_ = [(name, ctypes.c_size_t) for name in ("arena", "ordblks", "smblks", "hblks", "hblkhd",
                                                      "usmblks", "fsmblks", "uordblks", "fordblks", "keepcost")]
libc = ctypes.CDLL(None)
libc.mallinfo2.restype = Info
def mapped_by_a_1_mib_block():
    before = libc.mallinfo2().hblks
    block = ctypes.create_string_buffer(1 << 20)
    return libc.mallinfo2().hblks - before
from brdf_fit.batch.memory import reuse_large_blocks
print(mapped_by_a_1_mib_block(), reuse_large_blocks(), mapped_by_a_1_mib_block())
"""


def _probe(**env):
    base = {k: v for k, v in os.environ.items() if k != "MALLOC_TRIM_THRESHOLD_"}
    res = subprocess.run([sys.executable, "-c", PROBE], cwd=ROOT, env=dict(base, **env),
                         capture_output=True, text=True, check=True)
    return res.stdout.split()


@pytest.mark.skipif(not hasattr(ctypes.CDLL(None), "mallinfo2"), reason="glibc >= 2.33 only")
def test_a_fixed_trim_threshold_no_longer_maps_every_big_block():
    assert _probe(MALLOC_TRIM_THRESHOLD_="65536") == ["1", "True", "0"]     # as a Dask worker starts
    assert _probe()[1] == "False"           # without it, glibc's own dynamic thresholds are left alone
