"""The fitting engine: samples, losses (table and image), fused gradients, the
model family, starts, optimizers, ranking, ``fit`` and ``FitResult``.

A library: no command line, no progress bars, no Dask, no files but the
result JSON (the application on top of it is ``brdf_fit``).  The front door
(each name is imported when first used)::

    from fitting import fit, synthetic_measured
    result = fit(measured, "ggx+lambert", loss="log", samples=100_000)

``fit``, ``prepare``, ``evaluate_result``, ``FitError`` (``fitting.fit``),
``FitResult`` (``fitting.result``) and ``synthetic_measured``
(``fitting.synthetic``).  ``fitting.fit`` is the module ``fitting/fit.py``
and, called, its ``fit`` function.

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
