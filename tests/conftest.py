"""Shared fixtures: float64 JAX, and the real measured data in ../shared.

Tests that need ../shared skip with a reason when it is absent (a user's
clone has no ../shared).
"""

import ctypes
import os
import pathlib
import resource
import signal
import subprocess
import sys

import jax
import pytest

jax.config.update("jax_enable_x64", True)

# glibc's allocator: two arenas, not one per thread (up to 8 a core).  XLA's threads each
# allocate in an arena of their own, and what one frees the others cannot reuse, so a worker's
# transient peaks were 90-130 MiB higher: test_export_first then test_demo in one process
# 1221 / 1423 -> 1128 / 1290 MiB, resident after them 430 / 585 -> 313 / 475, in the same time
# (54.5 / 54.3 s; issue 62).  Set here, before JAX starts its threads; in the environment for the
# pytest workers and the commands the tests start.
M_ARENA_MAX = -8          # mallopt's parameter (malloc.h)
os.environ.setdefault("MALLOC_ARENA_MAX", "2")
try:
    ctypes.CDLL(None).mallopt(M_ARENA_MAX, int(os.environ["MALLOC_ARENA_MAX"]))
except (OSError, AttributeError, ValueError):     # not glibc, or a value that is not a number
    pass

# A suite started in the background by a non-interactive shell (`make test &`,
# nohup) has SIGINT ignored, and an ignored signal stays ignored in every
# process it starts, so the Ctrl-C tests (the command line's and its batch
# workers') could not interrupt anything.  Python's own handler instead: the
# suite is interruptible, and the commands it starts get the default again.
if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

ROOT = pathlib.Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared"
MEASURED = SHARED / "measured"
RGL_DIR = MEASURED / "rgl-epfl-isotropic-rgb"
NBRDF_NPZ = MEASURED / "nbrdf-merl" / "merl_nbrdf_dev.npz"
MERL_TOOL = SHARED / "tools" / "merl_from_nbrdf.py"

MERL_MATERIALS = [
    "alum-bronze", "black-oxidized-steel", "blue-acrylic", "chrome",
    "gold-metallic-paint", "green-fabric", "pink-felt", "red-plastic",
    "specular-violet-phenolic", "white-paint",
]


def _need(path):
    if not path.exists():
        pytest.skip(f"{path} is absent (needs ../shared next to the project)")


@pytest.fixture(scope="session")
def rgl_dir():
    _need(RGL_DIR)
    return RGL_DIR


@pytest.fixture(scope="session")
def merl_tables(tmp_path_factory):
    """A function material -> path of a MERL .binary generated from the NBRDF
    network by ../shared/tools/merl_from_nbrdf.py (once per session)."""
    _need(NBRDF_NPZ)
    _need(MERL_TOOL)
    folder = tmp_path_factory.mktemp("merl")
    made = {}

    def make(material):
        if material not in made:
            out = folder / f"{material}.binary"
            res = subprocess.run(
                [sys.executable, str(MERL_TOOL), str(NBRDF_NPZ), material, str(out)],
                capture_output=True, text=True, check=True)
            made[material] = (out, res.stdout)
        return made[material][0]

    make.report = lambda material: made[material][1]
    return make


@pytest.fixture(scope="module", autouse=True)
def _own_models_forgotten():
    """Models of one's own registered by a test module (brdf.own's registry is the process's, as a
    user's session has it) are forgotten after the module: test modules share worker processes,
    and ``brdf-fit models`` lists what is registered."""
    yield
    own = sys.modules.get("brdf.own")
    if own is not None:
        own._REGISTRY.clear()
        own._FILES.clear()


def _rss_mib():
    """This process's resident set now (Linux /proc), in MiB; None elsewhere."""
    try:
        with open("/proc/self/status") as status:
            line = next(line for line in status if line.startswith("VmRSS:"))
        return int(line.split()[1]) / 1024
    except (OSError, StopIteration):
        return None


def _give_back_memory(gl=False):
    """Drop the module's compiled programs, collect its garbage and hand the C heap's free
    pages back to the system; with ``gl`` its OpenGL programs and textures too (at a module's
    end, and before a ``whole_table`` test: no such module's fixtures hold one).

    A worker runs some fifty test modules; JAX keeps every program it compiled, and glibc
    keeps what was freed in its arenas, so a worker's resident set only grew: 0.89, 1.58,
    2.17 GB after the first three heavy modules (test_fitting_merl, test_export_first,
    test_fitting_engine), 5-5.6 GB by the end of a run (issue 62).  With malloc_trim alone,
    0.44 and 0.80 GB after the first two; with the programs dropped too, 0.34, 0.41, 0.49 GB
    (benchmarks/test_memory.py).  A later module traces again what it uses (the stored
    programs of fitting.stored spare it the tracing of most).  The collection and the trim are
    the application's own step (brdf_fit.batch.memory.give_back_memory, which the demo, a
    batch and a report run between their steps)."""
    from brdf_fit.batch.memory import give_back_memory
    from data_loaders import merl
    jax.clear_caches()
    merl._sample_geometry.cache_clear()       # the MERL grid's directions: 80 MB a worker kept (issue 62)
    merl._above_horizon.cache_clear()
    if gl and "shaders.gl" in sys.modules:      # llvmpipe's programs, the tables' textures: 274 MiB
        sys.modules["shaders.gl"].release_cached()      # after four modules
    give_back_memory()


# A worker's resident set above which a test's programs are dropped at once, not at the
# module's end: a module of many compiled programs (test_fitting_fused: ~150 MB a model's
# jax.grad) reached 2.5 GB by its end; with a ceiling of 1.6 GB, 1.6 GB in the same time.
# 1.3 GB since the OpenGL programs are released at each module's end (a worker holds
# 0.7-0.8 GB after a module, 1.1-1.3 GB before): the suite's CPU time the same (1359 s
# against 1347 s; 1.2 GB cost test_fitting_fused 45 % when a worker held more).
MEMORY_CEILING_MIB = 1300


# A test marked ``whole_table`` runs a command on a whole MERL-size table in this process (a fit
# and its export: the table, its directions and the fit's programs, 0.7-1.0 GB at once); it
# starts from a worker given back down to this, so its peak stays within 2 GB (issue 62: the
# suite's peaks above 2 GB were such tests: test_portable, test_export_first, test_demo).
WHOLE_TABLE_START_MIB = 900


def pytest_configure(config):
    config.addinivalue_line("markers", "whole_table: fits a whole MERL-size table in this process "
                                       "(started from memory given back, conftest.WHOLE_TABLE_START_MIB)")


def _whole_table_start():
    rss = _rss_mib()
    if rss is not None and rss > WHOLE_TABLE_START_MIB:
        _give_back_memory(gl=True)


@pytest.fixture(scope="module")
def whole_table_module():
    """For a module-scoped fixture that fits a whole MERL-size table (it runs before the
    tests' own fixtures): started from memory given back, as a ``whole_table`` test is."""
    _whole_table_start()


@pytest.fixture(autouse=True)
def _memory_ceiling(request):
    if request.node.get_closest_marker("whole_table") is not None:
        _whole_table_start()
    yield
    rss = _rss_mib()
    if rss is not None and rss > MEMORY_CEILING_MIB:
        _give_back_memory()


@pytest.fixture(scope="module", autouse=True)
def _module_memory(request):
    """After each test module: its memory given back (``_give_back_memory``); with
    BRDF_TEST_MEMORY_LOG=FILE, one line: the worker, the module, the resident set after it
    and the peak so far (MiB), what benchmarks/test_memory.py reads."""
    yield
    _give_back_memory(gl=True)
    path = os.environ.get("BRDF_TEST_MEMORY_LOG")
    if path:
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
        with open(path, "a") as log:
            log.write(f"{worker}\t{request.module.__name__}\t{_rss_mib():.0f}\t{peak:.0f}\n")
