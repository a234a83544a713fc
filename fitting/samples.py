"""What the fitter sees of a MeasuredBRDF: ``SampleSet`` and ``prepare``.

``prepare`` keeps the valid samples with theta_i, theta_o <= ``max_theta`` (80
degrees) and draws a stratified, seeded subsample (``samples``, default
100 000) for the optimizer -- the loss and its gradient on ~100 k pairs take a
few ms, and give the same parameters (within ~1 %) as the full 1.1 M MERL
cells.
"""

import functools
import typing
import weakref

import jax
import jax.numpy as jnp
import numpy as np
import numpy.typing as npt
from jaxtyping import Float
from numpy.typing import DTypeLike

from brdf.model import Geometry, geometry
from data_loaders.buffers import aligned_empty

from ._jax import float64

if typing.TYPE_CHECKING:
    from data_loaders import MeasuredBRDF

COARSE_SAMPLES = 20_000  # pairs each start of a fit's multi-start sees (``coarse_step``)


def coarse_step(size: int) -> int:
    """The stride of the coarse part (``SampleSet.every``) of an optimisation set of ``size``
    samples: about COARSE_SAMPLES of them, the set itself when it is smaller than twice that."""
    return max(1, size // COARSE_SAMPLES)


class FitError(ValueError):
    """A fit that cannot run (no usable samples, bad option)."""


class SampleSet(typing.NamedTuple):
    """Direction pairs (as a brdf Geometry), measurements and normalised weights.

    ``weights`` sum to 1/2 so that the two orientations of every pair together
    carry a total weight of 1.  Everything that does not depend on the model
    is computed once: the geometry (an isotropic model's loss reads four
    contiguous cosine arrays) and the log-compressed measurements
    log1p(fhat cos) of both orientations, which the default loss compares with.
    """
    geo: Geometry
    values: jax.Array
    weights: jax.Array
    log_i: jax.Array     # log1p(values * n.l), orientation (wi, wo)
    log_o: jax.Array     # log1p(values * n.v), orientation (wo, wi)

    @classmethod
    @float64
    def from_arrays(cls, wi: Float[npt.ArrayLike, "n 3"], wo: Float[npt.ArrayLike, "n 3"],
                    values: Float[npt.ArrayLike, "n 3"], weights: Float[npt.ArrayLike, " n"],
                    dtype: DTypeLike, owned: bool = False) -> "SampleSet":
        """The set of these samples.  ``owned``: the arrays are the caller's to give away
        (nothing changes them from now on): the set wraps aligned ones instead of copying them."""
        put = _own_device if owned else _device
        w = np.asarray(weights, dtype=np.float64)
        total = w.sum()
        if not np.isfinite(total) or total <= 0:
            raise FitError("no usable samples (all weights zero)")
        wi, wo = np.asarray(wi, np.float64), np.asarray(wo, np.float64)
        geo = jax.tree.map(lambda x: x.astype(dtype), _geometry(wi, wo, put))
        values = np.asarray(values, np.float64)
        # each array made once, in a buffer of its own that the device array wraps (no copies)
        weights, log_i, log_o = aligned_empty(w.shape), aligned_empty(values.shape), aligned_empty(values.shape)
        np.divide(np.multiply(w, 0.5, out=weights), total, out=weights)     # 0.5 w / total
        for log, cos in ((log_i, wi[:, 2:3]), (log_o, wo[:, 2:3])):
            np.log1p(np.multiply(values, cos, out=log), out=log)          # log1p(values cos)
        return cls(geo, put(values, dtype), *(_own_device(x, dtype) for x in (weights, log_i, log_o)))

    @property
    def size(self) -> int:
        return int(self.weights.shape[0])

    @float64
    def every(self, step: int) -> "SampleSet":
        """Every ``step``-th sample, weights renormalised (a coarse copy for multi-start).

        Sliced in numpy: an eager JAX slice would compile a kernel per shape.  Made once
        per set and step while the set lives (every fit on a set starts on it)."""
        def make():
            part = jax.tree.map(lambda x: np.asarray(x)[::step], self)
            weights = part.weights * (0.5 / part.weights.sum())
            return jax.tree.map(lambda x: _device(x, x.dtype), part._replace(weights=weights))
        return kept(self, ("every", step), make)

    @float64
    def parts(self, size: int) -> list["SampleSet"]:
        """The set as consecutive ``size``-sample parts, the last one padded with
        zero-weight copies of its last sample; sliced in numpy (no compiles).
        Made once per set and size while the set lives (a fit takes the full
        set's errors in parts); views of the arrays the set made itself
        (``_own_device``: all but the half vector and the cosines), else copies."""
        if size == self.size:
            return [self]
        return kept(self, ("parts", size), lambda: self._cut(size))

    def _cut(self, size):
        out = []
        for start in range(0, self.size, size):
            part = jax.tree.map(functools.partial(_host_rows, rows=slice(start, start + size)), self)
            extra = size - part.weights.shape[0]
            if extra:      # as ``padded``, in numpy
                weights = np.pad(part.weights, (0, extra))       # the copies weigh nothing
                part = jax.tree.map(functools.partial(_edge_pad, extra=extra), part)._replace(weights=weights)
            out.append(jax.tree.map(lambda x: _own_device(x, x.dtype), part))
        return out

    def padded(self, extra: int) -> "SampleSet":
        """The set with ``extra`` zero-weight copies of its last sample appended
        (used inside the fitter's jitted programs)."""
        pad = lambda x: jnp.pad(x, [(0, extra)] + [(0, 0)] * (x.ndim - 1), mode="edge")
        return jax.tree.map(pad, self)._replace(weights=jnp.pad(self.weights, (0, extra)))


def kept(data: SampleSet, what: typing.Hashable, make: typing.Callable[[], typing.Any]) -> typing.Any:
    """``make()``, something derived from ``data`` alone (its parts, its coarse copy, the
    start rules' estimates), made once and kept while every array of ``data`` lives:
    by ``what`` and the ids of the arrays, forgotten when one of them is."""
    leaves = jax.tree.leaves(data)
    key = (what, *map(id, leaves))
    known = _KEPT.get(key)
    if known is not None and all(ref() is leaf for ref, leaf in zip(known[0], leaves)):
        return known[1]
    out = make()
    try:
        _KEPT[key] = ([weakref.ref(leaf, lambda _, key=key: _KEPT.pop(key, None)) for leaf in leaves], out)
    except TypeError:       # an array that takes no weak reference: not kept
        pass
    return out


_KEPT: dict[tuple, tuple[list, object]] = {}    # ``kept``: by what and the ids of the set's arrays


def _host_rows(x, rows):
    """``rows`` of the JAX array ``x`` in numpy: a view of the buffer it wraps (``_own_device``),
    which does not keep ``x`` alive, else a copy (a view of ``x`` would keep it alive as long
    as the parts made of it are kept)."""
    buffer = _wrapped(x)
    return buffer[rows] if buffer is not None else np.array(np.asarray(x)[rows])


def _edge_pad(x, extra):
    """numpy ``x`` with ``extra`` copies of its last row appended."""
    return np.pad(x, [(0, extra)] + [(0, 0)] * (x.ndim - 1), mode="edge")


def _device(x, dtype):
    """numpy -> a JAX array of its own (a copy: later changes to ``x`` do not reach it), without
    a compile (jnp.asarray compiles a small program per shape)."""
    x = np.asarray(x)
    out = aligned_empty(x.shape, dtype)
    np.copyto(out, x, casting="unsafe")
    return _own_device(out, dtype)


def _own_device(x, dtype):
    """numpy ``x``, which nothing changes from now on, as a JAX array: ``x`` itself when it is
    aligned (data_loaders.buffers; the array then wraps it: ``_wrapped``), else a copy."""
    if x.dtype != np.dtype(dtype):
        return _device(x, dtype)
    out = jax.device_put(x)
    if x.flags.c_contiguous and out.unsafe_buffer_pointer() == x.ctypes.data:
        key = id(out)
        _HOST[key] = (weakref.ref(out, lambda _, key=key: _HOST.pop(key, None)), x)
    return out


def _wrapped(x):
    """The numpy buffer the JAX array ``x`` wraps (``_own_device``), or None."""
    known = _HOST.get(id(x))
    return known[1] if known is not None and known[0]() is x else None


_HOST: dict[int, tuple[weakref.ref, np.ndarray]] = {}     # id of a JAX array -> (a weak reference to it, its buffer)


@jax.jit
def _half_and_cosines(wi, wo):
    """The fields of brdf.model.geometry after wi and wo (one compiled call instead of a dozen eager ops)."""
    return geometry(wi, wo)[2:]


def _geometry(wi, wo, put=_device):
    """brdf.model.geometry of numpy direction pairs, wi and wo made device arrays by ``put``
    (``_device``: copies), not copied again as outputs.  The half vector and the cosines are
    moved into buffers of the set's own (``_device``), so that its parts are views of them, not
    a second copy of the set (a MERL table's: ~100 MB, issue 62)."""
    wi, wo = put(wi, wi.dtype), put(wo, wo.dtype)
    return Geometry(wi, wo, *(_device(x, x.dtype) for x in _half_and_cosines(wi, wo)))


@float64
def prepare(measured: "MeasuredBRDF", max_theta: float = 80.0, samples: int = 100_000, seed: int = 0,
            dtype: DTypeLike = jnp.float64) -> "tuple[SampleSet, SampleSet]":
    """(full SampleSet, optimisation SampleSet) from a MeasuredBRDF."""
    selected = measured.select(max_theta_deg=max_theta)    # valid samples only (and so is its subsample)
    if len(selected.wi) == 0:
        raise FitError(f"{_name(measured)}: no valid samples with theta <= {max_theta} degrees")
    # (the selections' arrays, aligned, are this function's own: wrapped, not copied)
    full = SampleSet.from_arrays(selected.wi, selected.wo, selected.values, selected.weights, dtype, owned=True)
    if samples and samples < len(selected.wi):
        sub = selected.subsample(samples, seed=seed)
        opt = SampleSet.from_arrays(sub.wi, sub.wo, sub.values, sub.weights, dtype, owned=True)
    else:
        opt = full
    return full, opt


def _name(measured):
    prov = getattr(measured, "provenance", None)
    return getattr(prov, "path", None) or getattr(prov, "material", None) or "measured data"
