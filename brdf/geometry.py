"""Vector helpers in the local shading frame: n = +z, t = +x, b = +y.

All directions point away from the surface and have the vector in the last
axis, so every function broadcasts over leading batch dimensions.
"""

import jax.numpy as jnp

from .constants import COS_EPS


def dot(a, b):
    """Dot product over the last axis."""
    return jnp.sum(a * b, axis=-1)


def normalize(v, eps=1e-20):
    """v / |v|, with a tiny floor inside the root so the gradient stays finite."""
    return v * jnp.reciprocal(jnp.sqrt(jnp.sum(v * v, axis=-1, keepdims=True) + eps))


def half_vector(wi, wo):
    """Half vector h = normalize(wi + wo)."""
    return normalize(wi + wo)


def clamp_cos(c):
    """A cosine clamped to [COS_EPS, 1] before it is used in a division."""
    return jnp.clip(c, COS_EPS, 1.0)


def rotate_tangent(v, angle):
    """Express v in a tangent frame rotated by ``angle`` (radians, CCW about n).

    With t' = (cos a, sin a, 0) and b' = (-sin a, cos a, 0) this returns
    (t'.v, b'.v, n.v): the coordinates an anisotropic lobe whose tangent is
    rotated by ``angle`` reads.
    """
    c, s = jnp.cos(angle), jnp.sin(angle)
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    return jnp.stack(jnp.broadcast_arrays(c * x + s * y, -s * x + c * y, z), axis=-1)
