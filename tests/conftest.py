"""Shared fixtures: float64 JAX, and the real measured data in ../shared.

Tests that need ../shared skip with a reason when it is absent (a user's
clone has no ../shared).
"""

import pathlib
import signal
import subprocess
import sys

import jax
import pytest

jax.config.update("jax_enable_x64", True)

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
