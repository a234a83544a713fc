"""Bounded parameters <-> unconstrained vectors for the optimizers.

Each schema parameter with finite bounds [lo, hi] is written
x = lo + (hi - lo) sigmoid(u), so the optimizer works on an unbounded u and
the model never sees an out-of-range value.  A parameter on a log scale
(``Param.scale`` "log", 0 < lo) is written log x = log lo + L sigmoid(u / s),
L = log(hi / lo), s = L / 4: a step of u multiplies x, so [1, 1e7] is searched as
evenly near 1 as near 1e6, and mid-range a unit step of u multiplies x by e, as it
does for a linear parameter near a bound of 0 (``stretch``; without s a unit step
would be a factor e^(L/4), 316 over [1e-3, 1e7], and a quasi-Newton run's first
steps leap across the range: 4 of 12 synthetic ABC fits recovered, against 11 of 12
with it).  ``Param.position`` / ``Param.at_position`` hold the maps of x.  A periodic
parameter (its ``Param.period`` set: an anisotropic lobe's tangent angle) is left free and
wrapped into its period afterwards.  Parameters of size 3 (RGB) take three
entries of the vector, size 1 one.
"""

import functools
import math
from collections.abc import Mapping

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float
from numpy.typing import DTypeLike

from brdf.declare import LOG
from brdf.model import ModelSpec, Param, parameter_schema
from brdf.specular import ROTATION

from ._jax import float64
from .stored import stored_jit

# Keep initial values off the sigmoid's flat tails (u within +-6).
_EDGE = 0.0025
# A model of one's own: a start strictly inside the bounds is taken as declared (to OWN_EDGE of
# the range, so that u stays finite); only one on a bound is moved _EDGE inside (docs/models.md).
OWN_EDGE = 1e-12


def stretch(p: Param) -> float:
    """u per unit of the sigmoid's argument: 1, or a quarter of the log range for a
    log-scale parameter (the module docstring)."""
    return math.log(p.upper / p.lower) / 4.0 if p.scale == LOG else 1.0


def stretches(spec: ModelSpec) -> Float[np.ndarray, " n"]:
    """``stretch`` of each entry of the vector: an optimizer's box in u is this times its
    box in the sigmoid's argument (fitting/optimizers.py: GLOBAL_BOX)."""
    out = np.ones(vector_size(spec))
    for p, a, b in layout(spec):
        out[a:b] = stretch(p)
    return out


def layout(spec: ModelSpec) -> list[tuple[Param, int, int]]:
    """[(Param, start, stop)] slices of the flat vector, in schema order."""
    out, i = [], 0
    for p in parameter_schema(spec):
        out.append((p, i, i + p.size))
        i += p.size
    return out


def vector_size(spec: ModelSpec) -> int:
    return sum(p.size for p in parameter_schema(spec))


def to_params(spec: ModelSpec, u: Float[ArrayLike, " n"]) -> dict[str, Float[Array, "*channels"]]:
    """Unconstrained vector (n,) -> {name: value} inside the bounds (JAX)."""
    return _mapped(spec, u, jax.nn.sigmoid, jnp)


def to_values(spec: ModelSpec, u: Float[ArrayLike, " n"]) -> dict[str, Float[np.ndarray, "*channels"]]:
    """``to_params`` in numpy, for a look at a vector outside a program (eagerly, JAX
    would compile a kernel per operation and shape: about 1 s in a fresh process)."""
    return _mapped(spec, np.asarray(u, np.float64), _sigmoid, np)


def _sigmoid(x):
    """1 / (1 + exp(-x)) in numpy, to a few ulp on both tails."""
    e = np.exp(-np.abs(x))
    return np.where(x >= 0, 1.0 / (1.0 + e), e / (1.0 + e))


def _mapped(spec, u, sigmoid, xp):
    params = {}
    for p, a, b in layout(spec):
        x = u[a:b]
        if p.scale == LOG:      # exp(log(hi)) may be an ulp beyond hi: kept inside
            x = xp.clip(p.at_position(sigmoid(x / stretch(p)), xp), p.lower, p.upper)
        elif not p.period:
            x = p.at_position(sigmoid(x), xp)
        params[p.name] = x if p.size == 3 else x[0]
    return params


@functools.cache
def to_params_jit(spec):
    """``to_params`` for ``spec`` as one compiled call (eagerly it compiles a kernel per operation)."""
    return stored_jit(lambda u: to_params(spec, u), f"transforms.to_params {spec!r}")


def from_params(spec: ModelSpec, params: Mapping[str, ArrayLike]) -> Float[np.ndarray, " n"]:
    """{name: value} -> unconstrained vector (numpy float64), clipping to the bounds: a value
    within _EDGE (0.25 %) of the range from a bound is moved there, off the sigmoid's flat
    tail; for a model of one's own only a value on a bound (or beyond) is, and one inside is
    kept (to OWN_EDGE of the range: a start at 100 in [0, 1e7] stays at 100).  The range is
    on the parameter's scale (``Param.position``): of log(x) for a log-scale parameter, whose
    value at or below 0 counts as on its lower bound."""
    u = np.zeros(vector_size(spec))
    own = spec.own is not None
    for p, a, b in layout(spec):
        x = np.broadcast_to(np.asarray(params[p.name], dtype=float), (p.size,))
        if p.period:
            u[a:b] = x
            continue
        if p.scale == LOG:
            with np.errstate(divide="ignore", invalid="ignore"):
                t = p.position(np.maximum(x, 0.0), np)      # log(0) = -inf: on the lower bound
        else:
            t = p.position(x, np)
        inside = (t > 0.0) & (t < 1.0) & own
        t = np.where(inside, np.clip(t, OWN_EDGE, 1.0 - OWN_EDGE), np.clip(t, _EDGE, 1.0 - _EDGE))
        u[a:b] = (np.log(t) - np.log1p(-t)) * stretch(p)
    return u


def released(spec: ModelSpec, u: Float[ArrayLike, " n"]) -> Float[np.ndarray, " n"] | None:
    """``u`` with every parameter pinned on a flat tail of its sigmoid (beyond a start's
    _EDGE) moved back to _EDGE inside its bound, or None when none is.  There the
    gradient vanishes (x - bound ~ exp(-|u|)), so an optimizer cannot leave a bound
    even where the loss falls away from it (``fitting.fit``: M1's optima of the
    multi-start stage, the hybrid refinement's best end)."""
    u = np.array(u, dtype=np.float64)
    pinned = False
    for p, a, b in layout(spec):
        edge = (np.log1p(-_EDGE) - np.log(_EDGE)) * stretch(p)
        if not p.period and np.any(np.abs(u[a:b]) > edge):
            pinned = True
            u[a:b] = np.clip(u[a:b], -edge, edge)
    return u if pinned else None


def wrap_rotation(angle: Float[ArrayLike, "*#batch"]) -> Float[ArrayLike, "*#batch"]:
    """Map an anisotropy rotation to [-pi/2, pi/2) (an anisotropic lobe has period pi)."""
    return ROTATION.wrap(angle)


def to_python(spec: ModelSpec, params: Mapping[str, ArrayLike]) -> dict[str, float | list[float]]:
    """{name: float or [r, g, b]} (plain Python numbers, periodic parameters wrapped)."""
    out = {}
    for p in parameter_schema(spec):
        x = p.wrap(np.asarray(params[p.name], dtype=float))
        out[p.name] = [float(v) for v in x.reshape(3)] if p.size == 3 else float(x.reshape(()))
    return out


@float64
def to_jax(spec: ModelSpec, values: Mapping[str, float | list[float] | ArrayLike],
           dtype: DTypeLike = jnp.float64) -> dict[str, Float[Array, "*channels"]]:
    """{name: float or list} -> {name: jnp array} (shape () or (3,)), float64 by default."""
    return {p.name: jnp.asarray(values[p.name], dtype=dtype) for p in parameter_schema(spec)}


def own_file(spec: ModelSpec) -> str:
    """' (model file FILE)' for a model of one's own loaded from a file, else ''."""
    return f" (model file {spec.own.source[0]})" if spec.own is not None and spec.own.source else ""


def non_finite(spec: ModelSpec, u: Float[ArrayLike, " n"]) -> str:
    """What of a fit's end ``u`` is not finite, for a message: 'non-finite parameters (k = nan)',
    or 'non-finite errors at a = [0.5, 0.5, 0.5], k = 3' when the parameters are finite (the model
    is not finite on some measured pairs there: for a model of one's own, said)."""
    values = to_values(spec, np.asarray(u, np.float64))
    bad = [name for name, v in values.items() if not np.all(np.isfinite(v))]
    shown = ", ".join(f"{name} = {np.round(v, 6).tolist()}" for name, v in values.items()
                      if not bad or name in bad)
    if bad:
        return f"non-finite parameters ({shown})"
    if spec.own is not None:        # the user's formula, not the data
        return f"non-finite errors at {shown}: its evaluate is NaN or infinite at some measured direction pairs there"
    return f"non-finite errors at {shown}"
