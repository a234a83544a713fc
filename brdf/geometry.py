"""Vector helpers in the local shading frame: n = +z, t = +x, b = +y.

All directions point away from the surface and have the vector in the last
axis, so every function broadcasts over leading batch dimensions.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from jaxtyping import Float

from ._lazy import jnp
from .constants import COS_EPS

if TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import Array, ArrayLike


def dot(a: Float[ArrayLike, "*batch 3"], b: Float[ArrayLike, "*batch 3"]) -> Float[Array, "*batch"]:
    """Dot product over the last axis."""
    return jnp.sum(a * b, axis=-1)


def normalize(v: Float[ArrayLike, "*batch 3"], eps: float = 1e-20) -> Float[Array, "*batch 3"]:
    """v / |v|, with a tiny floor inside the root so the gradient stays finite."""
    return v * jnp.reciprocal(jnp.sqrt(jnp.sum(v * v, axis=-1, keepdims=True) + eps))


def half_vector(wi: Float[ArrayLike, "*batch 3"], wo: Float[ArrayLike, "*batch 3"]) -> Float[Array, "*batch 3"]:
    """Half vector h = normalize(wi + wo)."""
    return normalize(wi + wo)


def clamp_cos(c: Float[ArrayLike, "*batch"]) -> Float[Array, "*batch"]:
    """A cosine clamped to [COS_EPS, 1] before it is used in a division."""
    return jnp.clip(c, COS_EPS, 1.0)


def rotate_tangent(v: Float[ArrayLike, "*batch 3"], angle: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch 3"]:
    """Express v in a tangent frame rotated by ``angle`` (radians, CCW about n).

    With t' = (cos a, sin a, 0) and b' = (-sin a, cos a, 0) this returns
    (t'.v, b'.v, n.v): the coordinates an anisotropic lobe whose tangent is
    rotated by ``angle`` reads.
    """
    c, s = jnp.cos(angle), jnp.sin(angle)
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    return jnp.stack(jnp.broadcast_arrays(c * x + s * y, -s * x + c * y, z), axis=-1)
