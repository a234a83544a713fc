"""Importing the packages changes nothing global; the fitter still runs in float64.

In a fresh interpreter (tests/conftest.py turns JAX's x64 flag on for this
process, so the checks run in a subprocess): importing every module of brdf,
fitting, data_loaders, shaders and brdf_fit leaves ``jax_enable_x64`` off, JAX's
compilation cache directory unset, matplotlib's backend unchosen, and starts
no thread.  A fit there then returns exactly the float64 numbers of the same
fit in this process (where x64 is on globally), sets the compilation cache up
on that first use, and leaves the user's own JAX code in float32.
"""

import inspect
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from fitting import fit, synthetic_measured
from fitting.fit import evaluate_result

PACKAGES = ("brdf", "fitting", "data_loaders", "shaders", "brdf_fit")
TRUTH = {"albedo": [0.45, 0.2, 0.08], "roughness": 0.35, "f0": [0.06, 0.05, 0.045]}
OPTIONS = dict(samples=20_000, starts=2)
GRID = (24, 24, 48, 1)
DIRECTIONS = [[0.3, 0.1, 0.9], [0.0, 0.6, 0.8], [-0.5, 0.2, 0.7]]

CHILD = r"""
import json, os, sys, threading

def native_threads():
    return len(os.listdir("/proc/self/task")) if os.path.isdir("/proc/self/task") else 0

import numpy, jax, jax.numpy as jnp, matplotlib, matplotlib.figure   # the dependencies
threads = set(threading.enumerate())
native = native_threads()
backend = matplotlib.rcParams._get_backend_or_none()

import importlib, pkgutil
modules = []
for name in PACKAGES:
    package = importlib.import_module(name)
    modules.append(name)
    for info in pkgutil.walk_packages(package.__path__, name + "."):
        importlib.import_module(info.name)
        modules.append(info.name)

state = {
    "modules": modules,
    "x64": bool(jax.config.jax_enable_x64),
    "cache_dir": jax.config.jax_compilation_cache_dir,
    "new_threads": sorted(t.name for t in set(threading.enumerate()) - threads),
    "native_threads": [native, native_threads()],
    "backend_changed": matplotlib.rcParams._get_backend_or_none() != backend,
    "pyplot": "matplotlib.pyplot" in sys.modules,
    "float32_before": str(jnp.ones(3).dtype),
}

import numpy as np
from fitting import fit, synthetic_measured
from fitting.fit import evaluate_result
measured = synthetic_measured("ggx+lambert", TRUTH, grid=GRID, noise=0.02, seed=5)
result = fit(measured, "ggx+lambert", **OPTIONS)
wi = np.asarray(DIRECTIONS); wi /= np.linalg.norm(wi, axis=1, keepdims=True)
values = evaluate_result(result, wi, wi[::-1].copy())
state.update(
    errors=result.errors, parameters=result.parameters,
    evaluated=values.tolist(), evaluated_dtype=str(values.dtype),
    x64_after=bool(jax.config.jax_enable_x64), cache_dir_after=jax.config.jax_compilation_cache_dir,
    float32_after=str(jnp.ones(3).dtype), threads_after=sorted(t.name for t in threading.enumerate()),
)
print(json.dumps(state))
"""


@pytest.fixture(scope="module")
def fresh(tmp_path_factory):
    cache = tmp_path_factory.mktemp("jax-cache")
    env = {k: v for k, v in os.environ.items() if not k.startswith("JAX_")}
    env.update(BRDF_JAX_CACHE=str(cache), PYTHONHASHSEED="0")
    env.pop("MPLBACKEND", None)
    prelude = (f"PACKAGES = {PACKAGES!r}\nTRUTH = {TRUTH!r}\nOPTIONS = {OPTIONS!r}\n"
               f"GRID = {GRID!r}\nDIRECTIONS = {DIRECTIONS!r}\n")
    proc = subprocess.run([sys.executable, "-c", prelude + CHILD], capture_output=True, text=True,
                          env=env, cwd=tmp_path_factory.mktemp("cwd"), timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    state = json.loads(proc.stdout.strip().splitlines()[-1])
    state["cache"] = str(cache)
    return state


def test_imports_change_no_global_state(fresh):
    assert {"fitting.fit", "brdf_fit.report.plots", "brdf_fit.cli", "shaders.render", "brdf.model",
            "data_loaders.merl"} <= set(fresh["modules"])
    assert fresh["x64"] is False                          # JAX's process-wide flag untouched
    assert not fresh["cache_dir"]                         # no compilation cache chosen on import
    assert fresh["new_threads"] == []                     # no Python thread started
    before, after = fresh["native_threads"]
    assert after == before                                # nor a native one
    assert not fresh["backend_changed"] and not fresh["pyplot"]   # matplotlib's backend untouched
    assert fresh["float32_before"] == "float32"


def test_fit_in_fresh_process_is_float64_and_scoped(fresh):
    assert fresh["evaluated_dtype"] == "float64"
    assert fresh["x64_after"] is False                    # the fit's float64 scope ended with it
    assert fresh["float32_after"] == "float32"            # the user's own JAX code keeps float32
    assert fresh["cache_dir_after"] == fresh["cache"]     # the cache is set up on first use
    assert any(name.startswith("brdf-compile") for name in fresh["threads_after"])


def test_fresh_process_fit_equals_in_process_fit(fresh):
    """The same numbers as here, where tests/conftest.py turned x64 on for the whole process."""
    measured = synthetic_measured("ggx+lambert", TRUTH, grid=GRID, noise=0.02, seed=5)
    result = fit(measured, "ggx+lambert", **OPTIONS)
    assert fresh["errors"]["m1"] == pytest.approx(result.errors["m1"], rel=1e-12, abs=0)
    np.testing.assert_allclose(fresh["errors"]["m1_per_channel"], result.errors["m1_per_channel"],
                               rtol=1e-12, atol=0)
    for name, value in result.parameters.items():
        np.testing.assert_allclose(fresh["parameters"][name], value, rtol=1e-12, atol=1e-15)
    wi = np.asarray(DIRECTIONS)
    wi = wi / np.linalg.norm(wi, axis=1, keepdims=True)
    np.testing.assert_allclose(fresh["evaluated"], evaluate_result(result, wi, wi[::-1].copy()),
                               rtol=1e-13, atol=0)
    assert result.errors["m1"] < 0.05          # and it is a real fit of the noisy table


def test_fit_options_are_keywords():
    measured = synthetic_measured("ggx+lambert", TRUTH, grid=(8, 8, 16, 1))
    with pytest.raises(TypeError):
        fit(measured, "ggx+lambert", "log")               # loss must be passed by name


def test_front_door_and_cli_stay_light():
    """``fitting`` and ``brdf_fit.cli`` import no JAX (the CLI installs its signal
    handling first); ``fitting.fit`` is the module and, called, the fitter."""
    code = "import sys, fitting, brdf_fit.cli; print('jax' in sys.modules, 'fitting.fit' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]
    import fitting
    import fitting.fit as module
    from fitting import fit as front
    from fitting.fit import fit as function
    assert front is fitting.fit is module and callable(module)
    assert module.evaluate_result is fitting.evaluate_result and module.prepare is fitting.prepare
    assert inspect.signature(fitting.fit) == inspect.signature(function)
    assert all(p.kind is p.KEYWORD_ONLY for p in list(inspect.signature(function).parameters.values())[2:])
