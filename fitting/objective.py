"""The fit's objective on a SampleSet: per-channel errors, the loss, its gradient.

Every loss is the mean over RGB of a per-channel root-mean-square error over
both orientations of every pair (``fitting.losses``).  The compiled programs
are cached per (spec, loss, ...) with ``functools.cache``.
"""

import functools

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from brdf.model import ModelSpec, evaluate_geometry

from . import fused
from ._jax import float64
from .losses import channel_mse, compress, log1p
from .samples import FitError, SampleSet
from .transforms import to_params

CHUNK = 1 << 17         # samples per jitted chunk when evaluating the full set


def is_reciprocal(spec: ModelSpec) -> bool:
    """True when f(wi, wo) == f(wo, wi) for the spec (clearcoat and Turquin are not)."""
    return not spec.clearcoat and spec.energy != "turquin"


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


def _objective(spec, loss, data):
    """u -> loss (mean over RGB of per-channel RMS), a pure function for jit."""
    def objective(u):
        return jnp.mean(jnp.sqrt(channel_errors(spec, loss, to_params(spec, u), data)))
    return objective


def _plain_value_and_grad(spec, loss):
    """(u, data) -> (loss, gradient, per-channel errors) by jax.value_and_grad."""
    def objective(u, data):
        errors = channel_errors(spec, loss, to_params(spec, u), data)
        return jnp.mean(jnp.sqrt(errors)), errors

    def value_and_grad(u, data):
        (value, errors), grad = jax.value_and_grad(objective, has_aux=True)(u, data)
        return value, grad, errors
    return jax.jit(value_and_grad)


@functools.cache
def _value_and_grad(spec, loss):
    """Jitted (u, data) -> (loss, gradient, per-channel errors): the fused sums of
    fitting.fused where they apply (the same numbers, about twice as fast), else
    jax.value_and_grad."""
    return (fused.value_and_grad(spec) if fused.supports(spec, loss) else
            _plain_value_and_grad(spec, loss))


def _residuals(spec, loss, data):
    """u -> residual vector whose sum of squares is sum over channels of the MSE."""
    if loss == "relative":
        raise FitError("least-squares optimizers support the log, ngan and cuberoot losses")
    sw = jnp.sqrt(data.weights)[:, None]

    def residuals(u, _args=None):
        f, fr = _both_orientations(spec, to_params(spec, u), data)
        ci, co = data.geo.n_dot_l[:, None], data.geo.n_dot_v[:, None]
        r1 = compress(loss, f, ci) - compress(loss, data.values, ci)
        r2 = compress(loss, fr, co) - compress(loss, data.values, co)
        return jnp.concatenate([(sw * r1).ravel(), (sw * r2).ravel()])
    return residuals


@float64
def full_set_errors(spec: ModelSpec, loss: str, params: dict[str, Float[Array, "*channels"]], data: SampleSet,
                    chunk: int = CHUNK) -> Float[np.ndarray, "3"]:
    """Per-channel MSE on a large set: one jitted pass over fixed-size chunks (bounded memory)."""
    return np.asarray(_full_errors(spec, loss, min(chunk, data.size))(params, data), np.float64)


@functools.cache
def _full_errors(spec, loss, chunk):
    def errors(params, data):
        parts = jax.tree.map(lambda x: x.reshape((-1, chunk) + x.shape[1:]),
                             data.padded(-data.size % chunk))
        per_chunk = jax.lax.map(lambda part: channel_errors(spec, loss, params, part), parts)
        return jnp.sum(per_chunk, axis=0)
    return jax.jit(errors)


def _errors_by_parts(spec, loss, u, data, size):
    """Per-channel errors of a large set from the loss+gradient program compiled
    for ``size`` samples, run part by part: no program of its own to compile."""
    vg = _value_and_grad(spec, loss)
    per_part = [vg(u, part)[2] for part in data.parts(size)]    # dispatched before any is read
    return np.sum([np.asarray(e, np.float64) for e in per_part], axis=0)
