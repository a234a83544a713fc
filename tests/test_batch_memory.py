"""brdf_fit.batch.memory: in a process started as Dask starts its workers, big blocks come from the
heap; freed heap pages go back to the system when a step is done."""

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


GIVE_BACK = """
import gc
from brdf_fit.batch.memory import give_back_memory
def rss_mib():
    with open("/proc/self/status") as status:
        return int(next(l for l in status if l.startswith("VmRSS:")).split()[1]) / 1024
blocks, pins = [], []
for _ in range(3000):                   # 64 KiB blocks (from the heap, not mapped), each followed
    blocks.append(bytearray(65536))     # by a small block that stays: glibc cannot give the
    pins.append(bytearray(1000))        # freed ones back from the heap's top by itself
del blocks
gc.collect()
held = rss_mib()
give_back_memory()
print(held - rss_mib())
"""


@pytest.mark.skipif(not os.path.exists("/proc/self/status") or not hasattr(ctypes.CDLL(None), "malloc_trim"),
                    reason="Linux with glibc only")
def test_give_back_memory_returns_freed_heap_pages():
    """The demo, batch and report call it between steps (brdf_fit/batch/memory.py): 3000 freed
    64 KiB blocks held between live ones (~188 MiB) go back to the system."""
    res = subprocess.run([sys.executable, "-c", GIVE_BACK], cwd=ROOT, capture_output=True, text=True, check=True)
    assert float(res.stdout) > 150.0



FREEZE = """
import gc
from brdf_fit.batch.memory import give_back_memory
class Node:
    pass
def cycle():
    a, b = Node(), Node()
    a.other, b.other = b, a
give_back_memory()
print(gc.get_freeze_count())
give_back_memory(own_process=True)
frozen = gc.get_freeze_count()
cycle()                                 # made after the freeze: still collected as a cycle
print(frozen > 0, gc.get_freeze_count() == frozen, gc.collect() >= 2)
"""


def test_a_worker_freezes_what_survives_a_step():
    """In the toolkit's own worker (``own_process``), what survives the collection is frozen
    (later collections skip it), and garbage made afterwards is still collected; elsewhere
    nothing is frozen."""
    res = subprocess.run([sys.executable, "-c", FREEZE], cwd=ROOT, capture_output=True, text=True, check=True)
    assert res.stdout.split() == ["0", "True", "True", "True"]
