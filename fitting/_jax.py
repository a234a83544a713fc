"""JAX settings of the fitter, applied when a fitting module that uses JAX is imported.

The fitter works in float64 (M1 differences between models are in the 4th
digit; float32 sums over 10^5-10^6 samples blur them), so importing
``fitting.fit`` (or any other fitting module that uses JAX: ``fused``,
``losses``, ``synthetic``, ``transforms``) enables JAX's 64-bit mode.

Compiled XLA programs are kept on disk (JAX's persistent compilation cache)
in ``$BRDF_JAX_CACHE``, by default ``$XDG_CACHE_HOME/brdf-toolkit/jax``
(``~/.cache/...``): a fresh process then loads the fitter's programs instead
of compiling them again.  ``BRDF_JAX_CACHE=off`` turns this off.

This lives here and not in ``fitting/__init__.py`` so that ``import
fitting.cli`` stays light: the command line installs its Ctrl-C handling
(``fitting.interrupt``) before JAX is imported.
"""

import os
import pathlib

import jax

jax.config.update("jax_enable_x64", True)


def _compilation_cache():
    setting = os.environ.get("BRDF_JAX_CACHE", "")
    if setting.lower() == "off":
        return None
    if setting:
        return setting
    base = os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache"
    return str(pathlib.Path(base) / "brdf-toolkit" / "jax")


if _compilation_cache() and not jax.config.jax_compilation_cache_dir:
    jax.config.update("jax_compilation_cache_dir", _compilation_cache())
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.05)
