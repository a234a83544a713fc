"""Start selection of a fit: data-driven start candidates and the starts chosen among them.

Everything model-specific is read from the declarations (brdf.declare): each
parameter's ``Param.start`` (a scan, a probe value, a rule from the data) and
each term's ``Term.variants``; nothing here names a parameter or a term.

1. From the data: the diffuse estimate ``albedo`` = pi x the 25th percentile
   of the measurement away from the specular peak (theta_h > 35 deg), and the
   peak = the median measurement where theta_h < 3 deg, less what the
   parameters with a ``peak`` share (the diffuse lobe) put there.
2. For each value of the scanned parameters (the roughness), the model is
   evaluated with every ``probe`` value set (F0 = 1, albedo = 0, ...), all
   the values in one batched call;
   ``scale`` = measured peak / model peak; each parameter with a ``rule``
   takes its value from (albedo, scale).
3. Each term's ``variants`` multiply the candidates (coat on / sharp / wide,
   anisotropy and rotation).
"""

import functools
import itertools
import operator
import typing

import jax
import numpy as np
import numpy.typing as npt
from jaxtyping import Array, Float

from brdf.model import ModelSpec, all_terms, evaluate_geometry, parameter_schema, terms

from . import family
from .objective import loss_and_errors
from .samples import SampleSet, kept
from .stored import stored_jit
from .transforms import from_params, to_params, to_values


PROBE_ROWS = 2048      # pairs per call of the peak probes' program (a quarter of MERL pairs is near the peak)
BATCHED_SCAN = 4096    # pairs: a set no larger is scanned in one call (``scan_losses``): only a small table's,
                       # as a larger table's screening part has SCREEN_SAMPLES pairs or more, its coarse part more


class Estimate(typing.NamedTuple):
    """What the start rules read: ``albedo`` (RGB in [0, 1]) and ``scale`` (RGB in [0, 1], or None
    before the peak is probed)."""
    albedo: np.ndarray
    scale: typing.Optional[np.ndarray] = None


def _theta_h(data):
    return np.degrees(np.arccos(np.clip(np.asarray(data.geo.n_dot_h, np.float64), -1.0, 1.0)))


def _value(param, x):
    return np.full(param.size, x) if param.size == 3 else x


class _Measured(typing.NamedTuple):
    """What the start rules read of a set, whatever the model (``_measured``)."""
    albedo: np.ndarray          # the diffuse estimate, in [0, 1]
    peak_value: np.ndarray      # the median measurement near the specular peak
    peak_count: int             # the pairs near the peak ...
    peak_rows: list             # ... in parts of PROBE_ROWS on the device (``_rows``)


def _measured(data: SampleSet) -> _Measured:
    """The diffuse estimate and the specular peak of ``data`` (step 1 of the module's
    docstring), made once per set (``samples.kept``: every fit on a set starts from it)."""
    def make():
        values = np.asarray(data.values, dtype=np.float64)
        th = _theta_h(data)
        off = th > 35.0
        albedo = np.pi * (np.percentile(values[off], 25, axis=0) if off.sum() > 10
                          else np.percentile(values, 5, axis=0))
        peak = th < max(3.0, float(np.percentile(th, 0.5)))
        return _Measured(np.clip(albedo, 0.0, 1.0), np.median(values[peak], axis=0), int(np.count_nonzero(peak)),
                         _rows(data.geo, np.flatnonzero(peak)))
    return kept(data, ("start estimate", PROBE_ROWS), make)


def initial_candidates(spec: ModelSpec, data: SampleSet) -> list[dict[str, Float[Array, "*channels"]]]:
    """Data-driven starting parameter sets ({name: value}), roughly best first."""
    schema = parameter_schema(spec)
    measured = _measured(data)
    estimate = Estimate(measured.albedo.copy())
    peak_value = measured.peak_value - sum(p.start.peak(estimate) for p in schema if p.start.peak)

    base = {p.name: _value(p, p.default) for p in schema}
    scanned = [p for p in schema if p.start.scan]
    points = list(itertools.product(*(p.start.scan for p in scanned)))
    # every point of the scan probed at once: the probe values over the base, the scanned
    # parameters (those without a probe value) batched
    probe = _float64(dict(base, **{p.name: _value(p, p.start.probe) for p in schema if p.start.probe is not None}))
    batch = _float64({p.name: [point[i] for point in points] for i, p in enumerate(scanned)
                      if p.start.probe is None})
    model = np.concatenate([np.asarray(_scan_jit(spec)(probe, batch, rows)) for rows in measured.peak_rows],
                           axis=1)
    model_peaks = np.median(model[:, :measured.peak_count], axis=1)
    out = []
    for point, model_peak in zip(points, model_peaks):
        cand = dict(base, **{p.name: float(x) for p, x in zip(scanned, point)})
        found = estimate._replace(scale=np.clip(peak_value / np.maximum(model_peak, 1e-12), 0.0, 1.0))
        cand.update({p.name: p.start.rule(found) for p in schema if p.start.rule})
        out.append(cand)
    bounds = {p.name: p for p in schema}
    for term in terms(spec):
        if term.variants:
            names, rows = term.variants
            rows = [[float(np.clip(x, bounds[n].lower, bounds[n].upper)) for n, x in zip(names, row)]
                    for row in rows]
            out = [dict(c, **dict(zip(names, row))) for c in out for row in rows]
    return out


def scan_losses(spec: ModelSpec, value_and_grad: typing.Callable, candidates: list[dict], data: SampleSet,
                dtype: npt.DTypeLike, loss: str | None = None) -> list[float]:
    """The loss of each of ``candidates`` (``initial_candidates(spec, data)``) on ``data`` by the
    fit's loss and gradient program ``value_and_grad``: the start scan.  Kept with the set
    (``samples.kept``, by the program and the spec): a table no larger than the screening part
    is screened and fitted on one set with the same programs (fitting/screen.py), and its
    contenders' fits take the screening's scan, the same numbers, instead of scanning again.

    With the name of the program's ``loss``, a set of at most BATCHED_SCAN pairs (a small
    table's) is scanned in one call of a program that takes every candidate at once
    (``_batched_loss``): there an evaluation is mostly XLA's fixed cost per call, and the
    44 candidates of a model cost about what two single evaluations do.  The losses are the
    program's to rounding (its sums in another order); a larger set is scanned as before."""
    batched = loss is not None and data.size <= BATCHED_SCAN

    def make():
        if batched:
            u = np.asarray([np.asarray(from_params(spec, c), dtype) for c in candidates])
            return [float(x) for x in np.asarray(_batched_loss(spec, loss)(u, data))]
        return [float(value_and_grad(np.asarray(from_params(spec, c), dtype), data)[0]) for c in candidates]
    return kept(data, ("start scan", spec, value_and_grad, np.dtype(dtype).str, len(candidates), batched), make)


def warm_candidates(spec: ModelSpec, candidates: list[dict[str, Float[Array, "*channels"]]],
                    warm: dict[str, object]) -> list[dict[str, Float[Array, "*channels"]]]:
    """Start candidates from a parent model's optimum ``warm`` (fitting.fit.warm_start):
    for each start variant of ``candidates`` (coat on / sharp / wide), the
    variant with ``warm``'s values for every other parameter, and ``warm`` itself."""
    names = {p.name for p in parameter_schema(spec)}
    shared = {k: v for k, v in warm.items() if k in names}
    variant_names = _declared("variants")
    keep = {k: v for k, v in shared.items() if k not in variant_names}
    out, seen = [], set()
    for c in candidates:
        if _variant(c, variant_names) not in seen:
            seen.add(_variant(c, variant_names))
            out.append(dict(c, **keep))
    if len(keep) < len(shared):
        out.append(dict(out[0], **shared))
    return out


def reseeded(spec: ModelSpec, u: Float[npt.ArrayLike, " n"]) -> np.ndarray | None:
    """The multi-start stage's best optimum ``u`` with each term's ``reseed`` values (a lobe
    it may have dropped, put back in a weak form: ``Term.reseed``), or None when no term
    of ``spec`` declares one."""
    rows = {name: value for term in terms(spec) if term.reseed
            for name, value in zip(term.variants[0], term.reseed)}
    if not rows:
        return None
    return from_params(spec, {**to_values(spec, u), **rows})


def _declared(attribute):
    """The names of the parameters any term varies between start families
    (``variants``) or any model scans (``scan``), from every declared term."""
    if attribute == "variants":
        names = (n for term in all_terms() if term.variants for n in term.variants[0])
    else:
        names = (p.name for term in all_terms() for p in term.params if p.start.scan)
    return tuple(dict.fromkeys(names))


def _variant(candidate, names=None):
    """What distinguishes a candidate besides the scan and the peak-matched values."""
    return tuple(candidate.get(k) for k in names or _declared("variants"))


def choose_starts(candidates: list[dict[str, Float[Array, "*channels"]]], losses: Float[npt.ArrayLike, " k"],
                  starts: int) -> list[dict[str, Float[Array, "*channels"]]]:
    """Starting points: the local minima of the scan (one per basin),
    the best of every variant (coat on/off, anisotropy...) first, then the
    other basins by loss, at most max(``starts``, number of variants).
    Neighbours of a minimum on the scan would only descend into the same basin."""
    order = sorted(range(len(candidates)), key=lambda i: (not np.isfinite(losses[i]), losses[i]))
    variant_names, scan_names = _declared("variants"), _declared("scan")
    variants = [_variant(c, variant_names) for c in candidates]
    groups = {}
    for i, v in enumerate(variants):
        groups.setdefault(v, []).append(i)
    minima = set()
    for members in groups.values():
        members = sorted(members, key=lambda i: tuple(candidates[i].get(n) for n in scan_names))
        for k, i in enumerate(members):
            left = losses[members[k - 1]] if k > 0 else np.inf
            right = losses[members[k + 1]] if k + 1 < len(members) else np.inf
            if np.isfinite(losses[i]) and losses[i] <= left and losses[i] <= right:
                minima.add(i)
    limit = max(1, starts, len(groups))
    chosen, seen = [], set()
    for i in order:                      # the best basin of each variant
        if i in minima and variants[i] not in seen:
            seen.add(variants[i])
            chosen.append(i)
    chosen += [i for i in order if i in minima and i not in chosen]
    chosen = chosen[:limit] or order[:1]
    return [candidates[i] for i in chosen]


@family.shared
def _scan_jit(spec):
    """(params, batch, geo) -> the model (k, pairs, 3) at the k parameter sets of ``params``
    with each ``batch`` entry's (k,) values in turn: the scan's probes in one call (16 calls
    of a one-set program cost the single fit's start scan 12 ms)."""
    def scan(params, batch, geo):
        if not batch:       # nothing scanned (no declared model is so): the one set
            return evaluate_geometry(spec, params, geo)[None]
        return jax.vmap(lambda values: evaluate_geometry(spec, dict(params, **values), geo))(batch)
    return stored_jit(scan, f"starts.scan {spec!r}")


@functools.cache
def _batched_loss(spec, loss):
    """(u (k, n), SampleSet) -> the table loss ``loss`` (objective.loss_and_errors) at each of the
    k parameter vectors, in one call: ``scan_losses`` on a small set."""
    def losses(u, data):
        return jax.vmap(lambda one: loss_and_errors(spec, loss, to_params(spec, one), data)[0])(u)
    return stored_jit(losses, f"starts.batched_loss {spec!r} {loss}")


def _rows(geo, index):
    """The pairs ``index`` of ``geo`` in parts of PROBE_ROWS pairs (the last padded with copies
    of its last pair), on the device: the probes' program has one shape whatever the data's size."""
    index = index if len(index) else np.zeros(1, int)
    index = np.concatenate([index, np.full(-len(index) % PROBE_ROWS, index[-1])])
    host = jax.tree.map(np.asarray, geo)
    return [jax.device_put(jax.tree.map(operator.itemgetter(part), host))
            for part in np.split(index, len(index) // PROBE_ROWS)]


def _float64(values):
    """numpy arrays: a jitted call takes them in its own fast path (about 5x faster a probe than
    jax.device_put of the dict first)."""
    return {k: np.asarray(v, np.float64) for k, v in values.items()}
