"""The fitter's JAX settings, applied where the fitter runs, never on import.

float64: the fitter works in float64 (M1 differences between models are in
the 4th digit; float32 sums over 10^5-10^6 samples blur them).  Rather than
flipping JAX's process-wide ``jax_enable_x64`` flag, every public entry point
of the fitter that creates or runs JAX arrays (``fit``, ``prepare``,
``evaluate_result``, ``full_set_errors``, ``synthetic_measured``, the
background compilations, ...) is decorated with :func:`float64`, which runs it
inside ``jax.enable_x64(True)``.  That context is thread-local: it covers the
call and nothing else, so a notebook's or an application's own JAX code keeps
its precision (float32 by default).  Code that jits the fitter's pure
functions itself (``fitting.fit.optx_solve``, ``fitting.fit.channel_errors``)
does so inside ``with jax.enable_x64(True):`` to get the same numbers.

The compilation cache: compiled XLA programs are kept on disk (JAX's
persistent compilation cache) so that a fresh process loads the fitter's
programs instead of compiling them again (a first fit 2.5-3.9 s -> about 2 s);
fitting/stored.py keeps the traced programs beside it (a cache hit still needs
the program traced and lowered).  Both read their files as untrusted input: each
file holds its key and digest and is used only when both match
(fitting/cache_files.py, fitting/compilation_cache.py).
JAX has one cache directory per process, so :func:`use_compilation_cache`
sets JAX's (global) ``jax_compilation_cache_dir`` -- on the fitter's first
use, not on import, once, and only if the process has not chosen a directory
of its own: ``$BRDF_JAX_CACHE``, by default
``$XDG_CACHE_HOME/brdf-toolkit/jax`` (``~/.cache/...``);
``BRDF_JAX_CACHE=off`` leaves JAX's cache settings alone.  The cache is only a
speed-up: a directory that cannot be created or written (``HOME=/dev/null``,
a read-only home) means no cache, silently, and JAX's own warnings about
reading or writing entries of the directory set here (a full disk) are not
shown -- a command's stderr holds the tool's lines only.

Importing this module imports JAX and changes nothing.  It is not imported by
``fitting/__init__.py``, so ``import brdf_fit.cli`` stays light: the command
line installs its Ctrl-C handling (``brdf_fit.interrupt``) before JAX is
imported.
"""

import functools
import os
import pathlib
import threading
import warnings

import jax

from . import compilation_cache

try:
    _enable_x64 = jax.enable_x64
except AttributeError:      # older JAX releases have it in jax.experimental only
    from jax.experimental import enable_x64 as _enable_x64
_CACHE_LOCK = threading.Lock()
_cache_checked = False      # use_compilation_cache has run (it acts at most once per process)


def compilation_cache_dir():
    """The directory the fitter's compiled programs go to, or None (``BRDF_JAX_CACHE=off``)."""
    setting = os.environ.get("BRDF_JAX_CACHE", "")
    if setting.lower() == "off":
        return None
    if setting:
        return setting
    base = os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache"
    return str(pathlib.Path(base) / "brdf-toolkit" / "jax")


def use_compilation_cache():
    """Point JAX's persistent compilation cache at :func:`compilation_cache_dir`,
    unless the process already set a directory or ``BRDF_JAX_CACHE=off``.

    Idempotent and cheap after the first call; the fitter's entry points call
    it (through :func:`float64`), so importing the packages never does.
    """
    global _cache_checked
    if _cache_checked:
        return
    with _CACHE_LOCK:
        if _cache_checked:
            return
        path = compilation_cache_dir()
        if (path and not jax.config.jax_compilation_cache_dir and _writable_folder(path)
                and compilation_cache.install(path)):
            jax.config.update("jax_compilation_cache_dir", path)
            jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.05)
            warnings.filterwarnings("ignore", message=r"Error (reading|writing) persistent compilation cache",
                                    category=UserWarning)
        _cache_checked = True


def _writable_folder(path):
    """True if ``path`` is (or can be made) a folder this process can write into."""
    try:
        os.makedirs(path, exist_ok=True)
    except (OSError, ValueError):
        return False
    return os.path.isdir(path) and os.access(path, os.W_OK | os.X_OK)


def float64(fn):
    """Decorator: run ``fn`` with JAX in 64-bit mode (``jax.enable_x64(True)``, a
    thread-local scope that ends with the call) and the compilation cache set up."""
    @functools.wraps(fn)
    def in_float64(*args, **kwargs):
        use_compilation_cache()
        with _enable_x64(True):
            return fn(*args, **kwargs)
    return in_float64
