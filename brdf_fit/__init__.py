"""The ``brdf-fit`` application, on top of the libraries (``brdf``, ``data_loaders``,
``shaders``, and ``fitting``, the engine).

- ``cli``, ``commands``, ``render`` -- the command line and every command;
  ``errors`` and ``interrupt`` its one error path and its signal handling;
- ``batch/`` -- many files x many models, on local processes or a Dask cluster;
- ``report/`` -- the HTML report, its three.js viewer, and the matplotlib plots;
- ``export/`` -- glTF and MaterialX files, the honesty check, export-first;
- ``notebook/`` -- Jupyter: results with the preview renderer's spheres, the inline
  3D viewer, ``results_table`` (docs/notebooks.md);
- ``demo`` / ``demo_run`` -- ``brdf-fit demo``.

Everything here calls downward; nothing below imports it.  The front door
(each name is imported when first used)::

    from brdf_fit import plots, export_gltf, run_batch
"""

import importlib

_LAZY = {
    "export_gltf": "brdf_fit.export.gltf",
    "run_batch": "brdf_fit.batch.run",
    "plots": None,
}

__all__ = sorted(_LAZY)


def __getattr__(name):
    if name not in _LAZY:
        raise AttributeError(f"module 'brdf_fit' has no attribute {name!r}")
    if _LAZY[name] is None:
        return importlib.import_module("brdf_fit.report.plots")
    return getattr(importlib.import_module(_LAZY[name]), name)


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
