"""The fitter's traced programs kept on disk, so that a fresh process does not trace them again.

JAX's persistent compilation cache (fitting/_jax.py) keeps the compiled
executables, but a cache hit still needs the program traced and lowered to
find its key: for ``--model auto`` in a fresh process, about 8 s of the
fused loss+gradient programs' Python (the 24 models run on four family
roots, each at a few sample counts).  ``stored_jit(fn, name)`` is
``jax.jit(fn)`` whose traced and lowered program (``jax.export``, StableHLO)
is written next to the compilation cache the first time a process traces it
for some argument shapes, and read back by every later process: tracing then
costs a file read, and the executable comes from the compilation cache as
before.  The numbers are those of ``jax.jit(fn)``: the same program.

A stored program is only used where it is the program this code would trace:
its file name is a hash of its whole key -- ``name`` (the program and its static
arguments: the spec, the loss...), the arguments' tree, shapes and dtypes, the
settings that change what the code traces (``fitting.image_error.DIFFERENCE``),
the versions of JAX and jaxlib, and the source of every module of ``brdf`` and
``fitting`` -- and the file itself holds that key and its content's digest
(fitting/cache_files.py): a file written for another key (another model's
program copied onto the name), truncated or with a flipped bit is not used but
traced again and replaced, and says so at DEBUG level (``brdf-fit -v``).  Any
change to the sources gives new files (the old ones are removed when a process
first writes one).  Like the compilation cache it is only a speed-up:
``BRDF_JAX_CACHE=off``, a folder that cannot be written (read-only, full) or JAX
without its serialisation (the ``flatbuffers`` package) mean tracing as usual.
"""

import functools
import hashlib
import pathlib
import threading
from collections.abc import Callable

import jax

from brdf.own import NOT_STORED

from . import cache_files
from ._jax import compilation_cache_dir

SUFFIX = ".jaxexport"
_PACKAGES = ("brdf", "fitting")
_LOCK = threading.Lock()
_pruned = False            # the folder has been cleared of other sources' programs (once per process)


@functools.cache
def source_key() -> str:
    """A hash of the versions of JAX and jaxlib and the source of the modules traced programs run."""
    import jaxlib
    digest = hashlib.sha256(f"jax {jax.__version__} jaxlib {jaxlib.__version__}".encode())
    root = pathlib.Path(__file__).resolve().parent.parent
    for package in _PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:24]


def folder() -> pathlib.Path | None:
    """Where stored programs go (``programs`` in the compilation cache's folder), or None."""
    base = compilation_cache_dir()
    return None if base is None else pathlib.Path(base) / "programs"


#: Module settings that change what the fitter's code traces, read when a program is traced:
#: {name: () -> value}; a module registers its own (fitting.image_error: DIFFERENCE).
SETTINGS: dict[str, Callable[[], object]] = {}


def _settings() -> str:
    return " ".join(f"{k}={read()!r}" for k, read in sorted(SETTINGS.items()))


def stored_jit(fn: Callable, name: str) -> Callable:
    """``jax.jit(fn)``, its traced program read from disk when a process traced it before
    (see the module's docstring); ``name`` says which program ``fn`` is, with its static arguments.

    Every argument goes to the default device as a committed array (``in_shardings``): a
    stored program's outputs are committed (``exported.call`` places them), and JAX
    would compile a program again for each mix of committed and uncommitted arguments
    it is given -- a parameter held at its neutral value (a numpy array) beside fitted
    ones, the shapes a compilation ahead lowers for: 6 of a fresh ``auto``'s 53
    compilations were such repeats before."""
    def traced(*args):
        leaves, tree = jax.tree.flatten(args)
        shapes = [jax.ShapeDtypeStruct(leaf.shape, leaf.dtype) for leaf in leaves]
        exported = _exported(fn, name, tree, shapes)
        return fn(*args) if exported is None else exported.call(*leaves)
    return jax.jit(traced, in_shardings=jax.sharding.SingleDeviceSharding(jax.devices()[0]))


def _exported(fn, name, tree, shapes):
    """The stored program for these arguments (exported and written when missing), or None."""
    where = folder()
    if where is None or NOT_STORED in name:     # a model of one's own: not among the sources keyed
        return None
    try:
        from jax._src.export import serialization  # noqa: F401 -- needs flatbuffers
    except ImportError:
        return None
    key = "\n".join([f"sources {source_key()}", name, str(tree), _settings(), *map(str, shapes)])
    path = where / f"{source_key()}-{hashlib.sha256(key.encode()).hexdigest()[:32]}{SUFFIX}"
    content = cache_files.read(path, key, "stored program")
    if content is not None:
        try:
            exported = jax.export.deserialize(bytearray(content))
            if [(a.shape, a.dtype) for a in exported.in_avals] == [(s.shape, s.dtype) for s in shapes]:
                return exported
        except Exception as err:  # noqa: BLE001 -- sealed for this key yet not a program: traced again
            cache_files.log.debug("stored program %s not used (%s): traced again", path, err)
    exported = jax.export.export(jax.jit(lambda *leaves: fn(*jax.tree.unflatten(tree, leaves))))(*shapes)
    _prune(where)
    cache_files.write(path, key, exported.serialize())
    return exported


def stored_count() -> int:
    """How many programs of this version of the sources are stored (0: a process compiles every
    program it runs, the minutes of a first run; also 0 with BRDF_JAX_CACHE=off)."""
    where = folder()
    try:
        return sum(1 for _ in where.glob(f"{source_key()}-*{SUFFIX}")) if where is not None else 0
    except OSError:
        return 0


def _prune(where):
    """Remove the programs of other sources (they can never be read again), once per process."""
    global _pruned
    with _LOCK:
        if _pruned:
            return
        _pruned = True
        try:
            for old in where.glob(f"*{SUFFIX}"):
                if not old.name.startswith(source_key()):
                    old.unlink(missing_ok=True)
        except OSError:
            pass
