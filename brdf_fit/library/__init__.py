"""The library: a measured database fitted, browsed and exported as one (``brdf-fit library``).

``build_library(inputs, out_dir)`` fits every measured file (``auto`` by default)
and writes the gallery, the analysis page, every material's page and glTF files
and one ``materials.glb``; ``write_library(results, out_dir)`` writes the same from
results already fitted (files, folders, or FitResults).  brdf_fit.library.analysis
holds the analysis figures as functions for notebooks.  docs/library.md.
"""

from .build import Library, build_library, write_library

__all__ = ["Library", "build_library", "write_library"]
