"""Meshes generated in code: a UV sphere and a shader-ball-like object.

Every mesh is a surface of revolution about the world +y axis, so each vertex
has an exact normal and a tangent along the azimuth (the +x axis of the
BRDF's local frame: anisotropic materials show brushed rings; the bitangent
is normal x tangent).  Vertex layout: position, normal, tangent (3 x float32
each), triangles as uint32 indices.

The UV sphere is also the mesh of exported glTF files (brdf_fit/export/gltf_file.py),
so it follows glTF's conventions: +y up, counter-clockwise front faces,
texture coordinates with v pointing down, the tangent along +u.
"""

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class Mesh:
    positions: np.ndarray   # (V, 3) float32
    normals: np.ndarray     # (V, 3) float32, unit
    tangents: np.ndarray    # (V, 3) float32, unit, orthogonal to the normal
    indices: np.ndarray     # (T, 3) uint32
    texcoords: np.ndarray = None   # (V, 2) float32 (u, v), or None

    def interleaved(self):
        return np.ascontiguousarray(
            np.concatenate([self.positions, self.normals, self.tangents], axis=1), dtype=np.float32)

    def __add__(self, other):
        offset = len(self.positions)
        return Mesh(np.concatenate([self.positions, other.positions]),
                    np.concatenate([self.normals, other.normals]),
                    np.concatenate([self.tangents, other.tangents]),
                    np.concatenate([self.indices, other.indices + offset]).astype(np.uint32),
                    None if self.texcoords is None or other.texcoords is None
                    else np.concatenate([self.texcoords, other.texcoords]))

    @property
    def bounds(self):
        return self.positions.min(axis=0), self.positions.max(axis=0)


def lathe(radius, height, normal_r, normal_y, segments=128, flip=False):
    """Revolve a profile (radius[k], height[k]) with profile normals about +y.

    The profile runs from k = 0 to K-1; ``normal_r``, ``normal_y`` are the
    normal's radial and vertical components at each profile point.
    """
    radius, height = np.asarray(radius, float), np.asarray(height, float)
    nr, ny = np.asarray(normal_r, float), np.asarray(normal_y, float)
    norm = np.hypot(nr, ny)
    nr, ny = nr / norm, ny / norm
    k = len(radius)
    phi = np.linspace(0.0, 2.0 * np.pi, segments + 1)
    cp, sp = np.cos(phi)[None, :], np.sin(phi)[None, :]
    pos = np.stack([radius[:, None] * cp, np.broadcast_to(height[:, None], (k, segments + 1)),
                    radius[:, None] * sp], axis=-1)
    nrm = np.stack([nr[:, None] * cp, np.broadcast_to(ny[:, None], (k, segments + 1)),
                    nr[:, None] * sp], axis=-1)
    tan = np.stack([-np.broadcast_to(sp, (k, segments + 1)), np.zeros((k, segments + 1)),
                    np.broadcast_to(cp, (k, segments + 1))], axis=-1)
    i = np.arange(k - 1)[:, None]
    j = np.arange(segments)[None, :]
    a = i * (segments + 1) + j
    b = a + segments + 1
    tris = np.concatenate([np.stack([a, b, a + 1], -1).reshape(-1, 3),
                           np.stack([a + 1, b, b + 1], -1).reshape(-1, 3)])
    if flip:
        tris = tris[:, ::-1]
    return Mesh(pos.reshape(-1, 3).astype(np.float32), nrm.reshape(-1, 3).astype(np.float32),
                tan.reshape(-1, 3).astype(np.float32), tris.astype(np.uint32))


def uv_sphere(radius=1.0, center=(0.0, 0.0, 0.0), segments=128, rings=64):
    """A UV sphere with exact normals, in glTF's conventions.

    P(theta, phi) = (sin theta sin phi, cos theta, sin theta cos phi) (+y up)
    with u = phi / 2 pi, v = theta / pi (glTF's v points down).  The tangent
    is dP/dphi normalised (the +u direction; bitangent = n x t), defined at
    the poles too.  Front faces are counter-clockwise seen from outside; the
    quads at the poles are single triangles (no degenerate triangle).
    """
    theta = np.linspace(0.0, np.pi, rings + 1)
    phi = np.linspace(0.0, 2.0 * np.pi, segments + 1)
    T, P = np.meshgrid(theta, phi, indexing="ij")
    st, ct, sp, cp = np.sin(T), np.cos(T), np.sin(P), np.cos(P)
    unit = np.stack([st * sp, ct, st * cp], axis=-1).reshape(-1, 3)
    unit[np.abs(unit) < 1e-15] = 0.0
    normal = unit / np.linalg.norm(unit, axis=1, keepdims=True)
    tangent = np.stack([cp, np.zeros_like(cp), -sp], axis=-1).reshape(-1, 3)
    uv = np.stack([P / (2 * np.pi), T / np.pi], axis=-1).reshape(-1, 2)
    i, j = np.arange(rings)[:, None], np.arange(segments)[None, :]
    a = i * (segments + 1) + j                      # this ring; b: the next one down
    b = a + segments + 1
    quads = np.stack([np.stack([a, b, b + 1], -1), np.stack([a, b + 1, a + 1], -1)], axis=2)
    keep = np.stack([i != rings - 1, i != 0], axis=-1)          # no sliver triangles at the poles
    indices = quads[np.broadcast_to(keep, quads.shape[:3])]
    return Mesh((radius * unit + np.asarray(center, np.float64)).astype(np.float32), normal.astype(np.float32),
                tangent.astype(np.float32), indices.astype(np.uint32), uv.astype(np.float32))


def _arc(center_r, center_y, r, a0, a1, n):
    """Profile of a circular arc (angles from +r towards +y) with outward normals."""
    a = np.linspace(a0, a1, n)
    return center_r + r * np.cos(a), center_y + r * np.sin(a), np.cos(a), np.sin(a)


def shader_ball(segments=128):
    """A shader-ball-like object (about 2 units tall, centred near the origin).

    A sphere on a neck and a stepped pedestal, with a torus ring around the
    sphere's equator - enough curvature variety (convex, concave, flat, rims)
    to judge a material, all generated here.
    """
    parts = []
    # main sphere, radius 0.8, centre at y = 0.2
    t = np.linspace(0.0, np.pi, 65)
    parts.append(lathe(0.8 * np.sin(t), 0.2 + 0.8 * np.cos(t), np.sin(t), np.cos(t), segments))
    # ring: torus of tube radius 0.06 around the equator at radius 0.84
    r_, y_, nr_, ny_ = _arc(0.84, 0.2, 0.06, -np.pi, np.pi, 33)
    parts.append(lathe(r_, y_, nr_, ny_, segments))
    # neck: a concave flare from the sphere down to the pedestal top
    s = np.linspace(0.0, 1.0, 17)
    neck_r = 0.22 + 0.18 * s ** 2
    neck_y = -0.55 - 0.25 * s
    dr, dy = np.gradient(neck_r), np.gradient(neck_y)
    parts.append(lathe(neck_r, neck_y, -dy, dr, segments, flip=False))
    # pedestal: top disc, rounded rim, side, bottom step
    parts.append(lathe([0.0, 0.55], [-0.8, -0.8], [0.0, 0.0], [1.0, 1.0], segments))
    r_, y_, nr_, ny_ = _arc(0.55, -0.85, 0.05, np.pi / 2, 0.0, 9)
    parts.append(lathe(r_, y_, nr_, ny_, segments))
    parts.append(lathe([0.6, 0.6], [-0.85, -0.95], [1.0, 1.0], [0.0, 0.0], segments))
    parts.append(lathe([0.6, 0.7], [-0.95, -0.95], [0.0, 0.0], [1.0, 1.0], segments))
    parts.append(lathe([0.7, 0.7], [-0.95, -1.05], [1.0, 1.0], [0.0, 0.0], segments))
    mesh = parts[0]
    for p in parts[1:]:
        mesh = mesh + p
    return mesh


MESHES = {"sphere": uv_sphere, "shader_ball": shader_ball}
