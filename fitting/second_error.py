"""Issue 59's second image error: the sphere under one light at a time, as the engines' judges see it.

A unit sphere seen orthographically along +z, ``size`` x ``size`` pixel centres (x right, y up),
one white directional light at a time from +x at ``ELEVATIONS`` degrees above the image plane,
towards the viewer (direction (cos e, 0, sin e), irradiance 1); per pixel the radiance
f(wi, wo) cos(theta_i) in the pixel's local frame (fitting.image_error's tangent, along the
azimuth around y).  Per light: exposure 1 / the ``PERCENTILE`` of the measured image's values (R,
G and B pooled) on its lit valid pixels (on the disc, cos theta_i > 0, the table has a value
there); Reinhard x / (1 + x); the sRGB transfer function; the RMS difference over those pixels
and the three channels.  The error is the mean over the lights.

Beside the toolkit's image error (fitting.image_error: four lights at once, a viewer's exposure,
the PBR Neutral tone map, Delta E_ITP) it judges each light's picture on its own, its highlight
at the exposure's top: on dark glossy materials the two disagree (docs/performance.md, *Dark
glossy materials in the second image error*).  ``judge_error`` is the judges' numpy form
(benchmarks/engine_three.py, engine_blender.py, native_judges.py); ``SecondTarget`` and
``second_value`` the same error of a model in JAX, differentiable: the hybrid loss adds it to
its image term, weighed by fitting.ranking.SECOND_WEIGHT (1 by default; docs/metrics.md).
"""

import typing

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from brdf.model import Geometry, ModelSpec

from . import ranking
from ._jax import float64
from .image_error import (SIZE as IMAGE_SIZE, ImageTarget, ImageTargets, _image_program, _measured_lookup,
                          _three_channels, fit_size, image_term, program_errors, srgb_encode)
from .samples import _geometry

if typing.TYPE_CHECKING:
    from data_loaders import MeasuredBRDF

SIZE = 128
FIT_SIZE = 32        # the second scene's side in the hybrid loss: 2 176 pairs, a quarter of 64 pixels'
ELEVATIONS = (30.0, 60.0, 85.0)      # degrees above the image plane, from +x towards the viewer
PERCENTILE = 99.0


def displayed(x: Float[ArrayLike, "*shape"], xp: typing.Any = np) -> Float[ArrayLike, "*shape"]:
    """Reinhard x / (1 + x) of exposed linear values, then the sRGB transfer function."""
    x = xp.maximum(x, 0.0)
    return srgb_encode(x / (1.0 + x), xp)


def judge_error(measured: Float[ArrayLike, "l p 3"], model: Float[ArrayLike, "l p 3"],
                valid: ArrayLike) -> float:
    """The error of ``model`` against ``measured`` radiance images (L, P, 3) on the pixels
    ``valid`` (L, P), as the module's docstring defines it."""
    errors = []
    for meas, mod, ok in zip(np.asarray(measured, np.float64), np.asarray(model, np.float64),
                             np.asarray(valid, bool)):
        if not ok.any():
            errors.append(0.0)
            continue
        d = displayed(mod[ok] * exposure(meas[ok])) - displayed(meas[ok] * exposure(meas[ok]))
        errors.append(float(np.sqrt(np.mean(d * d))))
    return float(np.mean(errors))


def exposure(lit_values: ArrayLike) -> float:
    """1 / the PERCENTILE of one light's measured values on its lit valid pixels (1 for a black image)."""
    level = float(np.percentile(lit_values, PERCENTILE)) if np.size(lit_values) else 0.0
    return 1.0 / level if level > 0.0 else 1.0


def light_direction(elevation_deg: float) -> np.ndarray:
    e = np.radians(elevation_deg)
    return np.array([np.cos(e), 0.0, np.sin(e)])


def scene_pairs(size: int = SIZE, elevations: tuple = ELEVATIONS) -> tuple[np.ndarray, ...]:
    """(disc pixel index (P,) into the size x size image (row 0 at the top), normals (P, 3),
    wi (L, P, 3) and wo (L, P, 3) in each pixel's local frame, cos theta_i (L, P))."""
    c = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    x, y = np.meshgrid(c, -c)
    r2 = x * x + y * y
    keep = r2 < 1.0
    n = np.stack([x[keep], y[keep], np.sqrt(1.0 - r2[keep])], axis=-1)
    t = np.stack([n[:, 2], np.zeros(len(n)), -n[:, 0]], axis=-1)       # fitting.image_error's tangent
    t /= np.linalg.norm(t, axis=-1, keepdims=True)
    frame = np.stack([t, np.cross(n, t), n], axis=1)                    # rows: local x, y, z
    lights = np.array([light_direction(e) for e in elevations])
    wi = np.einsum("pij,lj->lpi", frame, lights)
    wo = np.broadcast_to(frame[None, :, :, 2], wi.shape).copy()          # the view, +z
    cos_i = wi[..., 2].copy()
    wi[..., 2] = np.maximum(cos_i, 1e-6)         # unlit pairs kept above the horizon (masked out)
    wi /= np.linalg.norm(wi, axis=-1, keepdims=True)
    return np.flatnonzero(keep), n, wi, wo, cos_i


def measured_images(measured: "MeasuredBRDF", wi: np.ndarray, wo: np.ndarray,
                    cos_i: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(radiance (L, P, 3), valid (L, P)) of the table's own interpolating lookup."""
    f = _three_channels(_measured_lookup(measured, wi.reshape(-1, 3), wo.reshape(-1, 3)))
    f = f.reshape(wi.shape[:2] + (3,))
    lit = cos_i > 0.0
    valid = lit & ~np.all(f == 0.0, axis=-1)
    return np.where(lit[..., None], f * cos_i[..., None], 0.0), valid


class SecondTarget(typing.NamedTuple):
    """The scene's lit valid pairs, flat (Q,): as a brdf Geometry, cos theta_i (Q,), the exposure
    of each pair's light (Q,), the measured displayed values (Q, 3), and ``weights`` (Q, L): 1 /
    (3 x its light's valid pixels) in its light's column, so that each light's mean square is
    ``weights.T @ (sum over channels of d^2)``."""
    geo: Geometry
    cos: jax.Array
    exposure: jax.Array
    reference: jax.Array
    weights: jax.Array

    @classmethod
    @float64
    def from_measured(cls, measured: "MeasuredBRDF", size: int = SIZE) -> "SecondTarget":
        _, _, wi, wo, cos_i = scene_pairs(size)
        meas, valid = measured_images(measured, wi, wo, cos_i)
        lights = len(cos_i)
        per_light = np.array([exposure(meas[light][valid[light]]) for light in range(lights)])
        light_of = np.broadcast_to(np.arange(lights)[:, None], valid.shape)[valid]
        count = np.maximum(valid.sum(axis=1), 1)
        weights = np.zeros((len(light_of), lights))
        weights[np.arange(len(light_of)), light_of] = 1.0 / (3.0 * count[light_of])
        shown = per_light[light_of]
        return cls(_geometry(wi[valid], wo[valid]), jnp.asarray(cos_i[valid]), jnp.asarray(shown),
                   jnp.asarray(displayed(meas[valid] * shown[:, None])), jnp.asarray(weights))


def second_value(f: Float[Array, "q c"], target: SecondTarget) -> Float[Array, ""]:
    """The second image error of a model whose f (RGB, or one channel) at the target's pairs is ``f``."""
    x = f * (target.cos * target.exposure)[:, None]
    d = displayed(x, jnp) - target.reference
    mean_square = target.weights.T @ jnp.sum(d * d, axis=-1)
    return jnp.mean(jnp.sqrt(jnp.maximum(mean_square, jnp.finfo(mean_square.dtype).tiny)))


class Pictures(typing.NamedTuple):
    """The image error's scene and the second one's, as one target of the hybrid loss and of the
    reported image error (``image_error.image_term``): the image error + ``weight`` x the second
    image error.  ``geo``: the image's pairs, then the second scene's (one evaluation of a
    model's f serves both)."""
    image: ImageTarget
    second: SecondTarget
    geo: Geometry
    weight: jax.Array

    @classmethod
    @float64
    def of(cls, image: ImageTarget, measured: "MeasuredBRDF", size: int, weight: float) -> "Pictures":
        """The image error's ``image`` with the second scene ``size`` pixels wide."""
        second = SecondTarget.from_measured(measured, size)
        geo = jax.tree.map(lambda a, b: jnp.concatenate([a, b]), image.geo, second.geo)
        return cls(image, second, geo, jnp.asarray(weight, jnp.float64))

    @property
    def exposure(self) -> jax.Array:
        return self.image.exposure

    @property
    def pixels(self) -> int:
        return self.image.pixels

    def term(self, f: Float[Array, "q c"]) -> tuple[Float[Array, ""], Float[Array, "3"], Float[Array, ""]]:
        """``image_error.image_term`` on both scenes: (image error + weight x second image error,
        the image error's components' mean squares, the second image error)."""
        n = self.image.lit.size
        value, mse, _ = image_term(f[:n], self.image)
        second = second_value(f[n:], self.second)
        return value + self.weight * second, mse, second


def with_second(image: ImageTargets, measured: "MeasuredBRDF", weight: float) -> ImageTargets:
    """A measurement's ImageTargets with the second scene beside the report and fit targets
    (``Pictures`` of ``weight``): what every fit of it weighs with BRDF_SECOND_WEIGHT.  The fit's
    second scene is FIT_SIZE pixels wide, or the image term's size where that is smaller (a tiny
    table's, ``image_error.fit_size``): at 64 pixels its 8 652 pairs made the library's fits 1.55x
    as long (docs/performance.md, *The second image error in the fit*); on a tiny table both
    scenes are 16 pixels wide (*Many tiny tables*)."""
    return image._replace(report=Pictures.of(image.report, measured, IMAGE_SIZE, weight),
                          fit=Pictures.of(image.fit, measured, min(FIT_SIZE, fit_size(measured)), weight))


@float64
def picture_errors(spec: ModelSpec, params: dict[str, Float[Array, "*channels"]],
                   target: ImageTarget) -> dict[str, float | list[float]]:
    """{"image": the image error, "image_per_channel": its components' RMS}, and on ``Pictures``
    "second_image": the second image error -- a result's errors."""
    value, channels, second = program_errors(_image_program(spec)(params, target))
    out = {"image": value, "image_per_channel": channels}
    if isinstance(target, Pictures):
        out["second_image"] = second
    return out


def picture_error(spec: ModelSpec, params: dict[str, Float[Array, "*channels"]], target: ImageTarget) -> float:
    """The image term the hybrid loss and the ranking weigh: the image error, plus SECOND_WEIGHT x
    the second image error on ``Pictures`` (``ranking.image_term``)."""
    return ranking.image_term(picture_errors(spec, params, target))
