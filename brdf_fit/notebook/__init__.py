"""Notebook analysis: fits and measurements that show themselves, renders and
the 3D viewer inline, many results as a table (docs/notebooks.md).

    %load_ext brdf_fit.notebook          # FitResult displays gain the preview spheres
    from brdf_fit.notebook import comparison_image, show, viewer, results_table

    comparison_image(result, measured)   # PIL image, the pixels of `brdf-fit render --measured`
    show(result, measured)               # a result displayed with spheres against this measurement
    viewer(result, measured)             # the report's three.js viewer, inline and offline
    results_table("results/")            # a pandas DataFrame: one row per fit

Importing this package imports no renderer, IPython, pandas or three.js:
each call imports what it needs, and only ``%load_ext brdf_fit.notebook``
(or ``register()``) changes the running IPython's formatters.
"""

from .display import (DISPLAY_SIZE, ResultView, comparison_image, load_ipython_extension, register, show,
                      unload_ipython_extension, unregister)
from .table import results_table
from .viewer import InlineViewer, viewer

__all__ = ["comparison_image", "show", "ResultView", "viewer", "InlineViewer", "results_table", "register",
           "unregister", "load_ipython_extension", "unload_ipython_extension", "DISPLAY_SIZE"]
