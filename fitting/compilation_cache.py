"""JAX's persistent compilation cache, its files sealed (fitting/cache_files.py).

JAX finds a compiled executable by a file named after a hash and runs whatever
that file holds: its documentation calls the folder trusted.  The fitter's
folder is meant to be shared, so it gives JAX a cache of its own (an
implementation of JAX's cache interface, as JAX's own ``LRUCache`` and
``VerificationCache`` are): each entry is sealed with its key and digest, and
an entry written for another key, truncated or damaged is a miss -- JAX
compiles again and the entry is replaced -- never an executable run in place
of another (wrong numbers) or a failed deserialisation (an exit deep in XLA).
Entries are written atomically, so processes filling one folder at once leave
whole files only.  Files are ``<key>.sealed`` (JAX's own entries, ``<key>-cache``,
are not read).

JAX exposes no public way to supply a cache: :func:`install` sets the module
attributes JAX's ``_initialize_cache`` would; where this JAX lacks them it
returns False and the fitter runs without a persistent cache (slower, never
wrong).
"""

import os
import pathlib

from . import cache_files

SUFFIX = ".sealed"

try:
    from jax._src import compilation_cache as _jax_cache
    from jax._src.compilation_cache_interface import CacheInterface
except ImportError:          # a JAX without these modules: no persistent cache (install says so)
    _jax_cache = None
    CacheInterface = object


class SealedCache(CacheInterface):
    """A folder of sealed entries, one file per key, for JAX's compilation cache."""

    def __init__(self, path: "str | os.PathLike[str]") -> None:
        self._path = pathlib.Path(path)

    def _file(self, key: str) -> pathlib.Path:
        return self._path / f"{key}{SUFFIX}"

    def get(self, key: str) -> bytes | None:
        return cache_files.read(self._file(key), key, "compiled program")

    def put(self, key: str, value: bytes) -> None:
        cache_files.write(self._file(key), key, value)     # JAX puts only after a miss

    def clear(self) -> None:
        pass


def install(path: "str | os.PathLike[str]") -> bool:
    """Make a :class:`SealedCache` at ``path`` JAX's persistent compilation cache, unless JAX
    already made its own; False where this JAX's cache module is not the one expected."""
    needed = ("_cache", "_cache_initialized", "_cache_initialized_mutex")
    if _jax_cache is None or not all(hasattr(_jax_cache, name) for name in needed):
        return False
    with _jax_cache._cache_initialized_mutex:
        if _jax_cache._cache_initialized and not isinstance(_jax_cache._cache, SealedCache):
            return False
        _jax_cache._cache = SealedCache(path)
        _jax_cache._cache_initialized = True
    return True
