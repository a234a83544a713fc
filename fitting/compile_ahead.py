"""The fit's programs compiled ahead, on two background threads.

A fresh process spends most of its first fit compiling, and XLA compiles
without holding the GIL, so on two cores the compilations overlap each other
and the candidate scan's set-up.  ``lower().compile()`` fills the same cache
the calls use; each (function, shapes) key is sent once per process.
"""

import concurrent.futures
import functools
import os
import threading
import typing

import jax

from . import family
from ._jax import float64
from .image_error import _image_program
from .losses import HYBRID
from .objective import CHUNK, PartedHybrid, _part_errors, _value_and_grad
from .transforms import to_params, to_params_jit, vector_size

if typing.TYPE_CHECKING:
    from brdf.model import ModelSpec

    from .image_error import ImageTargets
    from .objective import HybridSet
    from .samples import SampleSet


class _Compiler:
    """Compiles programs on two background threads ("brdf-compile"), created on
    first use (and again in a forked child, which has none of its parent's
    threads); each (function, shapes) key is sent once per process."""

    def __init__(self, workers=2):
        self._workers = workers
        self._pool, self._pid = None, None
        self._sent = set()
        self._lock = threading.Lock()

    def submit(self, key, fn, args):
        """A future of ``fn.lower(*args).compile()`` in float64, or None when ``key`` was sent before."""
        with self._lock:
            if key in self._sent:
                return None
            self._sent.add(key)
            if self._pool is None or self._pid != os.getpid():
                self._pool = concurrent.futures.ThreadPoolExecutor(
                    max_workers=self._workers, thread_name_prefix="brdf-compile")
                self._pid = os.getpid()
        return self._pool.submit(_compile, fn, args)


@float64          # jax.enable_x64 is thread-local: each compile thread enters it itself
def _compile(fn, args):
    return fn.lower(*args).compile()


_COMPILER = _Compiler()


class _Ahead:
    """Compilations running in the background, by name; ``wait`` joins some or all."""

    def __init__(self, futures):
        self.futures = futures

    def wait(self, *names):
        for name in names or list(self.futures):
            future = self.futures.pop(name, None)
            try:
                future and future.result()
            except Exception:      # the call itself will raise it, with its context
                pass


@functools.cache
def _params_shapes(spec, u):
    """The shapes of ``to_params(spec, u)``, no compile (traced once per spec: ~4 ms a fit)."""
    return jax.eval_shape(lambda u: to_params(spec, u), u)


def compile_ahead(spec: "ModelSpec", runs: "list[tuple[str, SampleSet | HybridSet, str]]", u: jax.Array,
                  full: "SampleSet", image: "ImageTargets | None") -> _Ahead:
    """Compile the fit's programs on two background threads: the loss+gradient
    of each of ``runs`` ((name, data, loss) of the fit's stages: the coarse
    starts, the subsample...), the parameter map, the image error, and the
    full-set errors' part program (M1's, and the table loss's when it is another).

    A fresh process spends most of its first fit compiling, and XLA compiles
    without holding the GIL, so on two cores the compilations overlap each
    other and the candidate scan's set-up.  ``lower().compile()`` fills the
    same cache the calls use.  Each (function, shapes) is sent once per process.
    """
    v = family.variant(spec)
    root = v.root if v else spec       # a model of a family compiles its root's programs, once
    jobs = []
    for name, data, stage_loss in runs:
        fn = _value_and_grad(spec, stage_loss)
        programs = fn.runs(u, data) if isinstance(fn, PartedHybrid) else [(stage_loss, fn, (u, data))]
        jobs += [(name if i == 0 else f"{name} {i}", ("vg", root, loss, args[1].size, u.dtype), program, args)
                 for i, (loss, program, args) in enumerate(programs)]     # a part's program: sent once
    loss = runs[-1][2]
    jobs.append(("params", ("params", root, u.dtype), to_params_jit(root), (v.embed(u) if v else u,)))
    params = _params_shapes(spec, jax.ShapeDtypeStruct(u.shape, u.dtype))
    table_losses = ["log"] + ([loss] if loss not in ("log", HYBRID) else [])    # M1, the table loss
    jobs += _error_jobs(spec, root, params, full, image, u.dtype, table_losses)
    return _Ahead(_submit(jobs))


def _submit(jobs):
    futures = {}
    for name, key, fn, args in jobs:
        future = _COMPILER.submit(key, fn, args)
        if future is not None:
            futures[name] = future
    return futures


def _error_jobs(spec, root, params, full, image, dtype, table_losses=("log",)):
    """The jobs of the full-set errors' part program for each of ``table_losses`` on ``full``
    (the shape of one of its ``SampleSet.parts``) and of the image error's on ``image.report``."""
    part = jax.tree.map(lambda x: jax.ShapeDtypeStruct((min(CHUNK, full.size),) + x.shape[1:], x.dtype), full)
    jobs = [(f"errors {loss}", ("errors", root, loss, part.weights.shape, dtype), _part_errors(spec, loss),
             (params, part)) for loss in table_losses]
    if image is not None:
        jobs.append(("image", ("image", root, image.report.pixels, dtype), _image_program(spec),
                     (params, image.report)))
    return jobs


def compile_exported(ahead: _Ahead, spec: "ModelSpec", parameters: dict, full: "SampleSet",
                     image: "ImageTargets | None", dtype: object) -> None:
    """Add to ``ahead`` the compilation of the error programs of the glTF material a fit of
    ``spec`` at ``parameters`` exports (``material_errors.exported_errors``): given early
    parameters (the starts' best optimum), the material's extensions, and so its programs, are
    those the fit ends with unless it moves far; else the errors compile their own, as without."""
    from brdf import gltf_material
    from brdf.model import parse_model
    conversion = gltf_material.convert(spec, parameters)
    if conversion["lossless"] or conversion["model"] is None:    # the fit's own errors, or no material
        return
    gspec = parse_model(conversion["model"])
    v = family.variant(gspec)
    params = _params_shapes(gspec, jax.ShapeDtypeStruct((vector_size(gspec),), dtype))
    jobs = _error_jobs(gspec, v.root if v else gspec, params, full, image, dtype)
    ahead.futures.update({f"exported {name}": future for name, future in _submit(jobs).items()})
