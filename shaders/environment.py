"""Environment lighting: equirectangular radiance maps, analytic lights, SH irradiance.

World frame of the renderer: +y up.  An equirectangular (lat-long) map of
H x W pixels covers the sphere with row v (top = +y) and column u:

    theta = (v + 0.5) / H * pi               (polar angle from +y)
    phi   = (u + 0.5) / W * 2 pi - pi         (azimuth, phi = atan2(d.x, -d.z))
    d     = (sin theta sin phi, cos theta, -sin theta cos phi)

``render.glsl``'s ``dir_to_equirect`` uses the same mapping.  A generated
sky keeps its sun out of the map, as a DirectionalLight (a delta light is
exact for every BRDF, and a 0.5 deg disc in a map is undersampled by any
filter); ``Environment.from_file`` can pull a user map's sun out the same way.

User maps are Radiance .hdr (shaders/hdr.py) or OpenEXR .exr (shaders/exr.py)
files, told apart by their first bytes; both give top-row-first linear RGB
with the mapping above, so the same array saved either way lights the same.
"""

import dataclasses
import os

import numpy as np

from .exr import EXR_MAGIC, read_exr
from .hdr import HDRFormatError, read_hdr


@dataclasses.dataclass(frozen=True)
class PointLight:
    """Isotropic point light: radiant intensity ``intensity`` (W/sr, RGB);
    irradiance at distance d facing it is intensity / d^2 (inverse square)."""
    position: tuple
    intensity: tuple


@dataclasses.dataclass(frozen=True)
class DirectionalLight:
    """Distant light arriving from ``direction`` (towards the light, world
    space) with irradiance ``irradiance`` (W/m^2, RGB) on a surface facing it.
    ``angular_radius`` (rad) only sizes the disc drawn in the background."""
    direction: tuple
    irradiance: tuple
    angular_radius: float = 0.0

    @property
    def unit_direction(self):
        d = np.asarray(self.direction, float)
        return d / np.linalg.norm(d)


def equirect_directions(height, width):
    """(H, W, 3) unit directions of the pixel centres, and (H, W) solid angles."""
    theta = (np.arange(height) + 0.5) / height * np.pi
    phi = (np.arange(width) + 0.5) / width * 2.0 * np.pi - np.pi
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    sp, cp = np.sin(phi)[None, :], np.cos(phi)[None, :]
    d = np.stack(np.broadcast_arrays(st * sp, ct, -st * cp), axis=-1)
    omega = np.broadcast_to((2.0 * np.pi / width) * (np.pi / height) * st, (height, width))
    return d, omega


def direction_to_equirect(d, height, width):
    """Continuous pixel coordinates (v, u) of unit directions (..., 3)."""
    d = np.asarray(d, float)
    theta = np.arccos(np.clip(d[..., 1], -1.0, 1.0))
    phi = np.arctan2(d[..., 0], -d[..., 2])
    return theta / np.pi * height, (phi + np.pi) / (2.0 * np.pi) * width


def direction_from_angles(elevation_deg, azimuth_deg):
    """World direction at an elevation above the horizon and an azimuth (deg,
    0 = towards -z, i.e. behind the default camera's target, 90 = +x)."""
    e, a = np.radians(elevation_deg), np.radians(azimuth_deg)
    return np.array([np.cos(e) * np.sin(a), np.sin(e), -np.cos(e) * np.cos(a)])


@dataclasses.dataclass(frozen=True, eq=False)
class Environment:
    """Radiance map (H, W, 3) float32 (equirectangular, world +y up) plus
    analytic directional lights that belong to it (the sun)."""
    radiance: np.ndarray
    lights: tuple = ()
    name: str = "environment"

    @property
    def shape(self):
        return self.radiance.shape[:2]

    # --- generated maps --------------------------------------------------------
    @classmethod
    def uniform(cls, value=1.0, height=32):
        """A constant radiance in every direction (the white furnace)."""
        rgb = np.broadcast_to(np.asarray(value, np.float32), (3,))
        return cls(np.ones((height, 2 * height, 3), np.float32) * rgb, (), "uniform")

    @classmethod
    def sky(cls, height=256, sun_elevation=35.0, sun_azimuth=-50.0, sun_irradiance=3.0,
            sun_angular_radius=np.radians(0.53 / 2), turbidity=1.0):
        """A clear-sky gradient (zenith blue, bright horizon, brown ground) and a sun.

        Not a physical sky model: an artist's gradient with a brighter band
        around the sun; ``sun_irradiance`` is relative to the sky's irradiance
        on an upward-facing surface (about 1).
        """
        d, _ = equirect_directions(height, 2 * height)
        y = d[..., 1]
        zenith = np.array([0.18, 0.34, 0.75])
        horizon = np.array([0.75, 0.82, 0.95])
        ground = np.array([0.22, 0.18, 0.14])
        t = np.clip(y, 0.0, 1.0) ** (0.45 * turbidity)
        sky = horizon * (1.0 - t[..., None]) + zenith * t[..., None]
        sun_dir = direction_from_angles(sun_elevation, sun_azimuth)
        glow = np.clip(d @ sun_dir, 0.0, 1.0) ** 24
        sky = sky + glow[..., None] * np.array([0.9, 0.7, 0.45])
        blend = np.clip(y / 0.02 + 0.5, 0.0, 1.0)[..., None]      # soft horizon line
        rad = ground * (1.0 - blend) + sky * blend
        sun = DirectionalLight(tuple(sun_dir), tuple(sun_irradiance * np.array([1.0, 0.92, 0.8])),
                               sun_angular_radius)
        return cls(rad.astype(np.float32), (sun,), "sky")

    @classmethod
    def studio(cls, height=256):
        """A dark studio: grey gradient walls, floor, two large softboxes and a strip light."""
        d, _ = equirect_directions(height, 2 * height)
        _x, y, _z = d[..., 0], d[..., 1], d[..., 2]
        base = 0.04 + 0.08 * np.clip(y + 0.3, 0.0, 1.0)
        rad = np.repeat(base[..., None], 3, axis=-1) * np.array([1.0, 1.0, 1.02])
        floor = np.clip(-y * 4.0, 0.0, 1.0)[..., None]
        rad = rad * (1.0 - floor) + floor * np.array([0.06, 0.06, 0.06])

        def softbox(center, half_width, half_height, value):
            c = np.asarray(center, float)
            c = c / np.linalg.norm(c)
            right = np.cross([0.0, 1.0, 0.0], c)
            right /= np.linalg.norm(right)
            up = np.cross(c, right)
            facing = d @ c
            u = (d @ right) / np.maximum(facing, 1e-6)
            v = (d @ up) / np.maximum(facing, 1e-6)
            edge = np.clip(1.0 - np.maximum(np.abs(u) / half_width, np.abs(v) / half_height), 0.0, 0.08) / 0.08
            return np.where(facing[..., None] > 0, edge[..., None] * np.asarray(value), 0.0)

        rad = rad + softbox([-1.0, 0.6, 0.7], 0.45, 0.35, [9.0, 8.8, 8.5])
        rad = rad + softbox([1.0, 0.3, 0.4], 0.3, 0.5, [3.0, 3.2, 3.5])
        rad = rad + softbox([0.0, 0.4, -1.0], 0.9, 0.06, [5.0, 5.0, 5.0])
        return cls(rad.astype(np.float32), (), "studio")

    # --- user maps ----------------------------------------------------------------
    @classmethod
    def from_array(cls, radiance, extract_sun=False, name="user"):
        """A user lat-long map (H, W, 3), optionally with its sun pulled out."""
        radiance = np.ascontiguousarray(radiance, dtype=np.float32)
        if radiance.ndim != 3 or radiance.shape[2] != 3:
            raise ValueError(f"an environment map is (H, W, 3), got {radiance.shape}")
        lights = ()
        if extract_sun:
            radiance, lights = _extract_sun(radiance)
        return cls(radiance, lights, name)

    @classmethod
    def from_file(cls, path, extract_sun=True):
        """Load a lat-long map (2:1; other ratios are used as they are) from a Radiance
        .hdr or an OpenEXR file, chosen by content (:func:`read_environment_image`).
        Raises HDRFormatError naming the file for anything unreadable."""
        return cls.from_array(read_environment_image(path), extract_sun, os.path.basename(os.fspath(path)))

    @classmethod
    def from_hdr(cls, path, extract_sun=True):
        """The same as :meth:`from_file` (any high-dynamic-range map: .hdr or .exr)."""
        return cls.from_file(path, extract_sun)


def read_environment_image(path):
    """float32 (H, W, 3) linear RGB, top row first, from a Radiance .hdr (``#?``
    signature) or OpenEXR (magic ``76 2f 31 01``) file, whatever its name."""
    from data_loaders.errors import open_regular
    path = os.fspath(path)
    try:
        with open_regular(path) as f:      # a FIFO must not hang the command
            head = f.read(4)
    except OSError as exc:
        raise HDRFormatError(path, f"cannot read the file ({exc.strerror or exc})") from None
    if head == EXR_MAGIC:
        return read_exr(path)
    if head.startswith(b"#?"):
        return read_hdr(path)
    raise HDRFormatError(path, "not an environment map: neither a Radiance .hdr ('#?RADIANCE' "
                               "signature) nor an OpenEXR file (magic number 76 2f 31 01)")


def _extract_sun(radiance, fraction=0.5, threshold_sigma=50.0):
    """Move a compact very bright region of the map into a DirectionalLight.

    Pixels brighter than ``threshold_sigma`` times the median luminance are
    clamped to that level; their excess energy becomes a directional light at
    the energy-weighted centroid, if it carries at least ``fraction`` of the
    excess of the brightest pixel's neighbourhood (i.e. it is one compact source).
    """
    h, w, _ = radiance.shape
    lum = radiance @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    level = float(np.median(lum)) * threshold_sigma
    if level <= 0.0 or lum.max() <= level:
        return radiance, ()
    d, omega = equirect_directions(h, w)
    hot = lum > level
    scale = np.where(hot, level / np.maximum(lum, 1e-30), 1.0)[..., None]
    excess = radiance * (1.0 - scale)
    energy = (excess * omega[..., None])                     # irradiance-like weights
    e_lum = energy @ np.array([0.2126, 0.7152, 0.0722])
    centroid = (d * e_lum[..., None]).sum(axis=(0, 1))
    if np.linalg.norm(centroid) < fraction * e_lum.sum():
        return radiance, ()                                  # bright pixels are spread out
    direction = centroid / np.linalg.norm(centroid)
    irradiance = energy.sum(axis=(0, 1))
    spread = np.arccos(np.clip(d[hot] @ direction, -1.0, 1.0)).max()
    light = DirectionalLight(tuple(direction), tuple(irradiance), float(spread))
    return (radiance * scale).astype(np.float32), (light,)


# --- spherical harmonics irradiance (Ramamoorthi & Hanrahan 2001) -------------------

# Y_lm normalisation constants of the real SH basis, bands 0-2.
SH_C0 = 0.282095
SH_C1 = 0.488603
SH_C2 = 1.092548
SH_C3 = 0.315392
SH_C4 = 0.546274
# Cosine-lobe convolution: A_0 = pi, A_1 = 2 pi / 3, A_2 = pi / 4.
SH_BAND_FACTORS = np.array([np.pi] + [2.0 * np.pi / 3.0] * 3 + [np.pi / 4.0] * 5)


def sh_basis(d):
    """(..., 9) real SH basis at unit directions (..., 3) (x, y, z in the world)."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([np.full_like(x, SH_C0), SH_C1 * y, SH_C1 * z, SH_C1 * x,
                     SH_C2 * x * y, SH_C2 * y * z, SH_C3 * (3.0 * z * z - 1.0),
                     SH_C2 * x * z, SH_C4 * (x * x - y * y)], axis=-1)


def sh_project(radiance):
    """(9, 3) SH coefficients of an equirectangular map (solid-angle weighted)."""
    h, w, _ = radiance.shape
    d, omega = equirect_directions(h, w)
    basis = sh_basis(d) * omega[..., None]
    return np.einsum("hwk,hwc->kc", basis, radiance.astype(np.float64))


def sh_irradiance_coefficients(radiance):
    """(9, 3) coefficients whose SH expansion is the irradiance E(n) (W/m^2) of the map."""
    return sh_project(radiance) * SH_BAND_FACTORS[:, None]


def sh_evaluate(coefficients, d):
    """Evaluate an SH expansion (9, 3) at directions (..., 3)."""
    return sh_basis(np.asarray(d, float)) @ coefficients
