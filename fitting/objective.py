"""The fit's objective on a SampleSet: per-channel errors, the loss, its gradient.

Every table loss is the mean over RGB of a per-channel root-mean-square error
over both orientations of every pair (``fitting.losses``).  The ``hybrid``
loss adds the image error (``fitting.image_error``) to M1:

    hybrid = M1 + image_weight * image error      (fitting.ranking.HYBRID_WEIGHT by default)

and sees its data as a ``HybridSet`` (the table's SampleSet and the
measurement's ImageTarget).  The compiled programs are cached per (spec,
loss, ...) with ``functools.cache``; a model of a family (fitting/family.py)
runs its root's programs, compiled once for the family.
"""

import functools
import typing

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from brdf.model import ModelSpec, evaluate_geometry, parameter_schema, terms

from . import family, fused
from ._jax import float64
from .image_error import ImageTarget, image_channels
from .losses import HYBRID, channel_mse, compress, log1p, rms
from .ranking import HYBRID_WEIGHT  # noqa: F401 (the default weight, re-exported)
from .samples import FitError, SampleSet, coarse_step
from .stored import stored_jit
from .transforms import to_params, to_values

CHUNK = 1 << 17         # samples per jitted chunk when evaluating the full set
COLLAPSED = 1e-5        # of a parameter's range above its lower bound: a colour channel driven there by
REACHED = 1e-4          # the image term, where the log fit kept it further than this, is a collapse


class HybridSet(typing.NamedTuple):
    """What the hybrid loss sees: the table's samples, the image target and
    the image term's weight (an array: another weight compiles nothing new)."""
    samples: SampleSet
    image: ImageTarget
    weight: jax.Array

    @property
    def size(self) -> int:
        return self.samples.size

    @property
    def weights(self) -> jax.Array:
        return self.samples.weights


def is_reciprocal(spec: ModelSpec) -> bool:
    """True when f(wi, wo) == f(wo, wi) for the spec: every term of it is (``Term.reciprocal``;
    not the clearcoat, Turquin's compensation, OpenPBR's non-metal, coats and ``+mx``, a model
    of one's own found or declared otherwise).  Else each pair is evaluated in both orientations."""
    return all(term.reciprocal for term in terms(spec))


def _both_orientations(spec, params, data):
    f = evaluate_geometry(spec, params, data.geo)
    fr = f if is_reciprocal(spec) else evaluate_geometry(spec, params, data.geo.reversed())
    return f, fr


def channel_errors(spec: ModelSpec, loss: str, params: dict[str, Float[Array, "*channels"]],
                   data: SampleSet) -> Float[Array, "3"]:
    """Per-channel weighted mean square error over both orientations: (3,)."""
    f, fr = _both_orientations(spec, params, data)
    if loss == "log":
        r1 = log1p(f * data.geo.n_dot_l[:, None]) - data.log_i
        r2 = log1p(fr * data.geo.n_dot_v[:, None]) - data.log_o
        return jnp.dot(data.weights, r1 * r1 + r2 * r2)
    return (channel_mse(loss, f, data.values, data.geo.n_dot_l, data.weights)
            + channel_mse(loss, fr, data.values, data.geo.n_dot_v, data.weights))


def loss_and_errors(spec: ModelSpec, loss: str, params: dict[str, Float[Array, "*channels"]],
                    data: "SampleSet | HybridSet") -> tuple[Float[Array, ""], Float[Array, "3"]]:
    """(the loss, the per-channel mean square errors of its table part)."""
    if loss == HYBRID:
        errors = channel_errors(spec, "log", params, data.samples)
        image = image_channels(spec, params, data.image)[0]
        return jnp.mean(rms(errors)) + data.weight * image, errors
    errors = channel_errors(spec, loss, params, data)
    return jnp.mean(rms(errors)), errors


def _objective(spec, loss, data):
    """u -> loss, a pure function for jit."""
    def objective(u):
        return loss_and_errors(spec, loss, to_params(spec, u), data)[0]
    return objective


def _params(spec, u, switches):
    """The parameters a u-program evaluates: ``to_params``, or a family root's switched ones."""
    return to_params(spec, u) if switches is None else family.switched_params(spec, u, switches)


def _plain_value_and_grad(spec, loss, switched=False):
    """(u, data) -> (loss, gradient, per-channel errors) by jax.value_and_grad
    (``switched``: (u, switches, data) for a family root)."""
    def objective(u, switches, data):
        return loss_and_errors(spec, loss, _params(spec, u, switches), data)

    def value_and_grad(u, switches, data):
        (value, errors), grad = jax.value_and_grad(objective, has_aux=True)(u, switches, data)
        return value, grad, errors
    return family.jit_u_program(value_and_grad, switched, f"objective.value_and_grad {spec!r} {loss}")


def _value_and_grad(spec, loss):
    """(u, data) -> (loss, gradient, per-channel errors), compiled: the fused sums
    of fitting.fused where they apply (the same numbers, about twice as fast;
    the hybrid loss through ``PartedHybrid``), else jax.value_and_grad; a model
    of a shared family runs its root's program."""
    if loss == HYBRID and fused.supports(spec, "log"):
        return PartedHybrid(_program(spec, HYBRID), _program(spec, "log"))
    return _program(spec, loss)


def _program(spec, loss):
    v = family.variant(spec)
    return _own_value_and_grad(spec, loss, False) if v is None else _variant_value_and_grad(v, loss)


class PartedHybrid:
    """The fused hybrid loss, (u, HybridSet) -> (loss, gradient, S), on a set larger than
    its coarse part (a fit's subsample: ``samples.coarse_step``) run in parts of the coarse
    part's size, through the programs the coarse stages compiled (a fresh process compiles
    one program less per model family root and sample count: 2-4 s of an empty-cache
    ``auto``).  The log program gives each part's S_p and dS_p/du, the hybrid program the
    first part's loss with the image term, which is that less the first part's M1:

        M1 = mean_c sqrt(S_c),  S_c = sum_p S_pc,   dM1/du = sum_c (sum_p dS_pc/du) / (6 sqrt(S_c))

    The same numbers as the hybrid program on the whole set but for the order of the sums.
    A set no larger than its coarse part (the coarse stage's, the screening's) runs the
    hybrid program as it is."""

    def __init__(self, hybrid: typing.Callable, log: typing.Callable) -> None:
        self.hybrid, self.log = hybrid, log

    def runs(self, u: Float[Array, " n"], data: HybridSet) -> list[tuple[str, typing.Callable, tuple]]:
        """[(loss, program, arguments)] of an evaluation on ``data``: the hybrid program's on
        the whole set, or on the first part followed by the log program's on every part."""
        size = data.samples.size
        step = coarse_step(size)
        if step == 1:
            return [(HYBRID, self.hybrid, (u, data))]
        parts = data.samples.parts(-(-size // step))     # the size of SampleSet.every(step)
        return [(HYBRID, self.hybrid, (u, data._replace(samples=parts[0])))] + [("log", self.log, (u, p))
                                                                                 for p in parts]

    def __call__(self, u, data):
        runs = self.runs(u, data)
        if len(runs) == 1:
            return self.hybrid(u, data)
        (value, grad, _), *parts = [program(*args) for _, program, args in runs]
        s = np.sum([np.asarray(p[2]) for p in parts], axis=0)
        jac = np.sum([np.asarray(p[3]) for p in parts], axis=0)
        root = np.sqrt(s)
        image = float(value) - float(parts[0][0])           # the weight x the image error, and its gradient
        image_grad = np.asarray(grad) - np.asarray(parts[0][1])
        return float(np.mean(root)) + image, (0.5 / root / 3.0) @ jac + image_grad, s


@functools.cache
def _variant_value_and_grad(variant, loss):
    return family.VariantProgram(_own_value_and_grad(variant.root, loss, True), variant)


@functools.cache
def _own_value_and_grad(spec, loss, switched):
    """The program of ``spec`` itself; ``switched``: a family root's (u, switches, data)."""
    if loss == HYBRID and fused.supports(spec, "log"):    # the table's and the image's fused sums
        return fused.value_and_grad(spec, switched, hybrid=True)
    return (fused.value_and_grad(spec, switched) if fused.supports(spec, loss) else
            _plain_value_and_grad(spec, loss, switched))


def _residuals(spec, loss, data):
    """u -> residual vector whose sum of squares is sum over channels of the MSE."""
    if loss in ("relative", HYBRID):
        raise FitError(f"least-squares optimizers support the log, ngan and cuberoot losses, not {loss} "
                       "(choose --loss log)")
    sw = jnp.sqrt(data.weights)[:, None]

    def residuals(u, _args=None):
        f, fr = _both_orientations(spec, to_params(spec, u), data)
        ci, co = data.geo.n_dot_l[:, None], data.geo.n_dot_v[:, None]
        r1 = compress(loss, f, ci) - compress(loss, data.values, ci)
        r2 = compress(loss, fr, co) - compress(loss, data.values, co)
        return jnp.concatenate([(sw * r1).ravel(), (sw * r2).ravel()])
    return residuals


@float64
def full_set_errors(spec: ModelSpec, loss: str, params: dict[str, Float[Array, "*channels"]],
                    data: "SampleSet | list[SampleSet]", chunk: int = CHUNK) -> Float[np.ndarray, "3"]:
    """Per-channel MSE on a large set (or on its ``parts``, when several errors are taken
    on one set), run part by part through one program per spec and part size: bounded
    memory, and no compile per set size."""
    parts = data if isinstance(data, list) else data.parts(min(chunk, data.size))
    program = _part_errors(spec, loss)
    per_part = [program(params, part) for part in parts]     # dispatched before any is read
    return np.sum([np.asarray(e, np.float64) for e in per_part], axis=0)


@family.shared
def _part_errors(spec, loss):
    """(params, SampleSet) -> per-channel errors: for M1 the fused sums' forward part
    where they apply (fitting.fused.errors, about twice as fast), else channel_errors."""
    if loss == "log" and fused.supports(spec, "log"):
        return fused.errors(spec)
    return stored_jit(lambda params, data: channel_errors(spec, loss, params, data),
                      f"objective.channel_errors {spec!r} {loss}")


def collapsed(spec: ModelSpec, u: Float[Array, " n"], u_log: Float[Array, " n"]) -> list[str]:
    """The RGB parameters that ``u`` (a hybrid fit) has at their lower bound (a channel
    gone to 0) in a channel where ``u_log`` (the log fit it started from) is not: a colour
    the image term collapsed.  (An upper bound reached -- glTF's specular colour at 10 --
    takes no colour away.)"""
    params, reference = to_values(spec, u), to_values(spec, u_log)
    out = []
    for p in parameter_schema(spec):
        if p.size != 3 or p.period:
            continue
        span = p.upper - p.lower
        a, b = np.asarray(params[p.name]), np.asarray(reference[p.name])
        if p.scale == "log":        # the shares are of its range of log(x) (Param.position)
            gone, kept = p.position(a, np) <= COLLAPSED, p.position(b, np) >= REACHED
        else:
            gone, kept = a <= p.lower + COLLAPSED * span, b >= p.lower + REACHED * span
        if np.any(gone & kept):
            out.append(p.name)
    return out


def chroma_error(spec: ModelSpec, u: Float[Array, " n"], target: ImageTarget) -> float:
    """The mean square of the image error's colour components (T, P of Delta E_ITP) for ``u``."""
    from .image_error import _image_program
    return float(np.sum(np.asarray(_image_program(spec)(to_values(spec, u), target)[1])[1:]))


def keep_colours(spec: ModelSpec, best: tuple, log_best: tuple, data: HybridSet, refine: typing.Callable,
                 runs: list, stage: int, chroma: typing.Callable | None = None) -> tuple:
    """A hybrid refinement ``best`` = (u, loss, converged) whose colour did not collapse:
    ``best`` itself unless it has a channel at its lower bound (``collapsed``) that the log
    start ``log_best`` (coarse) keeps off it, and so does M1 alone refined from that start on
    ``data``, and the image's colour (``chroma``: u -> the T, P part of the image error;
    ``chroma_error`` by default) is worse than that M1 fit's: then the hybrid refinement from
    the start again with the image weight halved, then quartered, else the M1 fit.
    ``refine(data, u0)`` -> (u, loss, evaluations, converged); each run is added to ``runs``."""
    if not collapsed(spec, best[0], log_best[0]):
        return best
    chroma = chroma or (lambda u: chroma_error(spec, u, data.image))
    weight = np.asarray(data.weight)

    def run(factor):
        u, val, evals, ok = refine(data._replace(weight=(weight * factor).astype(weight.dtype)), log_best[0])
        runs.append({"stage": stage, "samples": data.size, "loss": val, "evaluations": evals, "converged": ok})
        return u, val, ok
    m1_only = run(0.0)          # the coarse start may not have converged: the log fit on these samples
    limit = chroma(m1_only[0])

    def kept(candidate):
        return not collapsed(spec, candidate[0], m1_only[0]) or chroma(candidate[0]) <= limit
    for factor in (0.5, 0.25):
        if kept(best):
            return best
        best = run(factor)
    return best if kept(best) else m1_only
