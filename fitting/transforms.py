"""Bounded parameters <-> unconstrained vectors for the optimizers.

Each schema parameter with finite bounds [lo, hi] is written
x = lo + (hi - lo) sigmoid(u), so the optimizer works on an unbounded u and
the model never sees an out-of-range value.  ``rotation`` (an anisotropic
lobe's tangent angle, period pi) is left free and wrapped afterwards.
Parameters of size 3 (RGB) take three entries of the vector, size 1 one.
"""

import math

from . import _jax  # noqa: F401 -- float64 and the compilation cache, before any JAX array
import jax
import jax.numpy as jnp
import numpy as np

from brdf.model import parameter_schema

FREE_PARAMETERS = ("rotation",)
# Keep initial values off the sigmoid's flat tails (u within +-6).
_EDGE = 0.0025


def layout(spec):
    """[(Param, start, stop)] slices of the flat vector, in schema order."""
    out, i = [], 0
    for p in parameter_schema(spec):
        out.append((p, i, i + p.size))
        i += p.size
    return out


def vector_size(spec):
    return sum(p.size for p in parameter_schema(spec))


def to_params(spec, u):
    """Unconstrained vector (n,) -> {name: value} inside the bounds (JAX)."""
    params = {}
    for p, a, b in layout(spec):
        x = u[a:b]
        if p.name not in FREE_PARAMETERS:
            x = p.lower + (p.upper - p.lower) * jax.nn.sigmoid(x)
        params[p.name] = x if p.size == 3 else x[0]
    return params


_TO_PARAMS_JIT = {}


def to_params_jit(spec):
    """``to_params`` for ``spec`` as one compiled call (eagerly it compiles a kernel per operation)."""
    if spec not in _TO_PARAMS_JIT:
        _TO_PARAMS_JIT[spec] = jax.jit(lambda u: to_params(spec, u))
    return _TO_PARAMS_JIT[spec]


def from_params(spec, params):
    """{name: value} -> unconstrained vector (numpy float64), clipping to the bounds."""
    u = np.zeros(vector_size(spec))
    for p, a, b in layout(spec):
        x = np.broadcast_to(np.asarray(params[p.name], dtype=float), (p.size,))
        if p.name in FREE_PARAMETERS:
            u[a:b] = x
            continue
        t = np.clip((x - p.lower) / (p.upper - p.lower), _EDGE, 1.0 - _EDGE)
        u[a:b] = np.log(t) - np.log1p(-t)
    return u


def wrap_rotation(angle):
    """Map an anisotropy rotation to [-pi/2, pi/2) (an anisotropic lobe has period pi)."""
    return (angle + math.pi / 2) % math.pi - math.pi / 2


def to_python(spec, params):
    """{name: float or [r, g, b]} (plain Python numbers, rotation wrapped)."""
    out = {}
    for p in parameter_schema(spec):
        x = np.asarray(params[p.name], dtype=float)
        if p.name in FREE_PARAMETERS:
            x = wrap_rotation(x)
        out[p.name] = [float(v) for v in x.reshape(3)] if p.size == 3 else float(x.reshape(()))
    return out


def to_jax(spec, values, dtype=jnp.float64):
    """{name: float or list} -> {name: jnp array} (shape () or (3,))."""
    return {p.name: jnp.asarray(values[p.name], dtype=dtype) for p in parameter_schema(spec)}
