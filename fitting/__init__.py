"""Fitting brdf models to measured data: losses, optimizers, results, command line.

The front door (each name is imported when first used)::

    from fitting import fit, plots, synthetic_measured
    result = fit(measured, "ggx+lambert", loss="log", samples=100_000)

``fit``, ``prepare``, ``evaluate_result``, ``FitError`` (``fitting.fit``),
``FitResult`` (``fitting.result``), ``synthetic_measured``
(``fitting.synthetic``), ``export_gltf`` (``fitting.export``) and the
modules ``plots``, ``export``, ``report``, ``batch``.  ``fitting.fit`` is the
module ``fitting/fit.py`` and, called, its ``fit`` function.

Importing this package imports nothing heavy (no JAX), so ``brdf-fit`` can
install its Ctrl-C handling first, and importing any of its modules changes
no global state: the fitter runs in float64 inside its own calls
(``jax.enable_x64``, thread-local) without turning on JAX's process-wide
``jax_enable_x64``, and points JAX's persistent compilation cache at
``~/.cache/brdf-toolkit/jax`` on its first use, unless the process chose a
directory itself (``BRDF_JAX_CACHE``; ``=off`` leaves it alone; see
``fitting/_jax.py``).
"""

import importlib

_LAZY = {
    "fit": None,                  # the module fitting.fit (callable)
    "prepare": "fit", "evaluate_result": "fit", "FitError": "fit",
    "FitResult": "result",
    "synthetic_measured": "synthetic",
    "export_gltf": "export",
    "plots": None, "export": None, "report": None, "batch": None,
}

__all__ = sorted(_LAZY)


def __getattr__(name):
    if name not in _LAZY:
        raise AttributeError(f"module 'fitting' has no attribute {name!r}")
    if _LAZY[name] is None:
        return importlib.import_module(f".{name}", __name__)
    return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
