"""The image error: what a viewer sees of a fit, against the measurement.

A unit sphere seen from far away (orthographic camera on +z, image ``SIZE`` x
``SIZE``, x right, y up) under the four directional lights of ``LIGHTS`` and
nothing else (no environment, black background), in linear RGB.  Each pixel's
radiance is

    L = sum over lights of E_l f(wi_l, wo) cos(theta_i,l)        (f in 1/sr)

in the pixel's local frame (normal n, tangent t along the azimuth around the
y axis -- the preview sphere's tangent -- bitangent n x t; wo = +z).  The
measurement's image takes f from the measured table's own interpolating
lookup (MERL: trilinear, UTIA: quadrilinear, otherwise the format's
standard lookup); the model's from the fitted model.  Both images are
exposed by one factor taken from the measured image (``viewer_exposure``: its
99th percentile of luminance over the lit disc brought to ``VIEWER_LEVEL``,
what a viewer's auto exposure does, so a dark material is judged as seen, not
as black), tone-mapped with the Khronos PBR Neutral operator
(what glTF viewers such as three.js and the Khronos sample viewer offer for
product renders) and encoded with the sRGB transfer function, clipped to
[0, 1].  The image error of a channel is the RMS difference over the pixels
of the disc whose normal is within ``VIEW_MAX_THETA`` of the view; the image
error is the mean of the three channels' (as M1 is).  Pixels where the
measurement has no value for a lit light (an unmeasured cell: the lookup
gives exactly 0 in every channel) are left out.

The lights sit at different angles from the view so that their highlights
sample the Fresnel range: a highlight lies where n = h, at theta_d = half the
angle between light and view -- 5, 20, 37.5 and 70 degrees here.

Everything model-side is JAX (``image_channels`` is differentiable and is the
image term of the ``hybrid`` loss); the measured side is numpy, computed once
per measurement (``ImageTarget.from_measured``).  With fitting.ranking.SECOND_WEIGHT
above 0 (1 by default; ``BRDF_SECOND_WEIGHT``) the report and fit scenes carry
issue 59's second image error beside this one (fitting.second_error.Pictures):
the hybrid loss and the ranking weigh both, a result reports both.
"""

import functools
import typing

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from brdf.model import Geometry, ModelSpec, evaluate_geometry

from . import family
from ._jax import float64
from .losses import rms
from .samples import _geometry     # the one jitted brdf.model.geometry
from .stored import SETTINGS, stored_jit

if typing.TYPE_CHECKING:
    from data_loaders import MeasuredBRDF

SIZE = 128               # image side in pixels of the reported image error
FIT_SIZE = 64            # ... and of the hybrid loss's image term (a quarter of the pairs) ...
SMALL_FIT_SIZE = 32      # ... on a small table: fewer than SMALL_TABLE valid pairs (``ImageTargets``) ...
SMALL_TABLE = 10_000     # (fitting/screen.py's small table: 2 x SCREEN_SAMPLES)
TINY_FIT_SIZE = 16       # ... on a tiny one: fewer than TINY_TABLE valid pairs
TINY_TABLE = 2_500
VIEW_MAX_THETA = 80.0    # degrees: pixels whose normal is further from the view are left out
EXPOSURE = 1.0           # the fixed exposure of the second figure (errors["image_fixed"])
PERCENTILE = 99.0        # of the measured image's luminance over the lit disc ...
VIEWER_LEVEL = 0.85      # ... brought here: where a white (albedo 0.8) Lambertian sphere's sits at exposure 1
LUMINANCE = (0.2126, 0.7152, 0.0722)   # Y of linear BT.709 / sRGB RGB
SATURATED = 1e6          # radiance clipped here first: white long before, and no overflow


def _light(angle_from_view_deg, azimuth_deg, irradiance):
    """A directional light ``angle`` degrees from the view axis (+z), its plane at
    ``azimuth`` degrees counter-clockwise from +x (image right); irradiance in W/m^2."""
    a, b = np.radians(angle_from_view_deg), np.radians(azimuth_deg)
    return (np.sin(a) * np.cos(b), np.sin(a) * np.sin(b), np.cos(a)), irradiance


#: (unit direction towards the light, world frame of the image; irradiance E).
#: A white Lambertian sphere of albedo 0.8 peaks near 1.0 before the tone map.
LIGHTS = (
    _light(10.0, 60.0, 1.0),      # beside the camera: highlights near normal incidence
    _light(40.0, 135.0, 2.5),     # key light, upper left
    _light(75.0, -20.0, 1.0),     # side light, right
    _light(140.0, 100.0, 1.5),    # rim light, behind and above: grazing highlights
)


def tone_map(x: Float[Array, "*shape"], xp: typing.Any = jnp,
             exposure: "float | Float[Array, '']" = EXPOSURE) -> Float[Array, "*shape"]:
    """Khronos PBR Neutral tone map (Khronos 3D Commerce, 2024) of linear RGB
    (..., 3) scaled by ``exposure``, then the sRGB transfer function, clipped to [0, 1]."""
    return srgb_encode(displayed(x, xp, exposure), xp)


def displayed(x: Float[Array, "*shape"], xp: typing.Any = jnp,
              exposure: "float | Float[Array, '']" = EXPOSURE) -> Float[Array, "*shape"]:
    """``tone_map`` before the sRGB transfer function: the display's linear values in [0, 1]."""
    start, desaturation = 0.8 - 0.04, 0.15
    x = xp.clip(x * exposure, 0.0, SATURATED)
    low = xp.min(x, axis=-1, keepdims=True)
    offset = xp.where(low < 0.08, low - 6.25 * low * low, 0.04)
    x = x - offset
    peak = xp.max(x, axis=-1, keepdims=True)
    d = 1.0 - start
    pc = xp.maximum(peak, start)          # the compressed branch's peak (finite gradients)
    new_peak = 1.0 - d * d / (pc + d - start)
    scaled = x * (new_peak / pc)
    g = 1.0 - 1.0 / (desaturation * (pc - new_peak) + 1.0)
    compressed = scaled * (1.0 - g) + new_peak * g
    x = xp.where(peak < start, x, compressed)
    return xp.clip(x, 0.0, 1.0)


# The per-pixel difference: Delta E_ITP (ITU-R BT.2124) of the displayed pixels, from ICtCp
# (ITU-R BT.2100): linear sRGB / BT.709 -> BT.2020 -> LMS -> PQ at DISPLAY_WHITE cd/m^2.
DISPLAY_WHITE = 100.0      # cd/m^2 of the display's white (an SDR display)
ITP_UNIT = 325.0           # Delta E_ITP per image-error unit: the dev tables' fits keep the median of the
                           # sRGB per-channel error it replaced (measured: 1.30 x at 250)
_BT709_TO_LMS = (np.array([[1688, 2146, 262], [683, 2951, 462], [99, 309, 3688]]) / 4096
                 @ np.array([[0.6274, 0.3293, 0.0433], [0.0691, 0.9195, 0.0114], [0.0164, 0.0880, 0.8956]]))
_LMS_TO_ITP = np.array([[2048, 2048, 0], [6610 / 2, -13613 / 2, 7003 / 2], [17933, -17390, -543]]) / 4096
DIFFERENCE = "itp"         # or "srgb": per channel in sRGB (the second round's), for comparisons
SETTINGS["image difference"] = lambda: DIFFERENCE     # a stored program is the one of this setting


def itp_linear(linear: Float[Array, "*shape 3"], xp: typing.Any = jnp) -> Float[Array, "*shape 3"]:
    """(I, T, P) of the display's linear values (``displayed``: before the sRGB encoding, which
    the display undoes), T = Ct / 2, so that Delta E_ITP = 720 |ITP_a - ITP_b|."""
    m1, m2, c1, c2, c3 = 2610 / 16384, 2523 / 4096 * 128, 3424 / 4096, 2413 / 4096 * 32, 2392 / 4096 * 32
    lms = linear @ (_BT709_TO_LMS.T * (DISPLAY_WHITE / 10000.0))
    y = _power(xp.maximum(lms, 1e-12), m1, xp)       # PQ; the floor keeps black's gradient finite
    return _power((c1 + c2 * y) / (1.0 + c3 * y), m2, xp) @ _LMS_TO_ITP.T


def _power(x, p, xp):
    """x ** p for x > 0 as exp(p log x): XLA:CPU's float64 pow is a scalar call, about 3x slower."""
    return xp.exp(p * xp.log(x))


def difference(model: Float[Array, "p 3"], target: "ImageTarget") -> Float[Array, "p 3"]:
    """The per-pixel difference of the model's displayed pixels (``displayed``: linear, before
    the sRGB encoding) and the target's image, three components whose squares the error
    averages: Delta E_ITP's (I, T, P) in units of ITP_UNIT (or per channel in sRGB)."""
    if DIFFERENCE == "srgb":
        return srgb_encode(model) - target.target
    return itp_linear(model) * (720.0 / ITP_UNIT) - target.reference


def image_value(mse: Float[Array, "3"]) -> Float[Array, ""]:
    """The image error from the three components' mean squares over the pixels: the RMS over
    the pixels of Delta E_ITP / ITP_UNIT (or the mean over R, G, B of each channel's RMS)."""
    if DIFFERENCE == "srgb":
        return jnp.mean(rms(mse))
    return rms(jnp.sum(mse))


def srgb_encode(x: Float[Array, "*shape"], xp: typing.Any = jnp) -> Float[Array, "*shape"]:
    """The sRGB transfer function (IEC 61966-2-1) of linear values in [0, 1]."""
    safe = xp.maximum(x, 0.0031308)      # keeps the unused branch's gradient finite
    return xp.where(x <= 0.0031308, 12.92 * x, 1.055 * safe ** (1.0 / 2.4) - 0.055)


def sphere_pixels(size: int = SIZE) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(pixel index (P,) into the size x size image, normals (P, 3), tangents (P, 3))
    of the pixels whose normal is within VIEW_MAX_THETA of the view (world frame)."""
    c = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    x, y = np.meshgrid(c, -c)
    r2 = x * x + y * y
    z = np.sqrt(np.clip(1.0 - r2, 0.0, None))
    keep = (r2 < 1.0) & (z >= np.cos(np.radians(VIEW_MAX_THETA)))
    n = np.stack([x[keep], y[keep], z[keep]], axis=-1)
    t = np.stack([n[:, 2], np.zeros(len(n)), -n[:, 0]], axis=-1)
    t /= np.linalg.norm(t, axis=-1, keepdims=True)
    return np.flatnonzero(keep), n, t


@functools.lru_cache(maxsize=8)
def light_pairs(size: int = SIZE) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The scene's direction pairs in each pixel's local frame: (pixel index (P,),
    wi (P, L, 3), wo (P, L, 3), E cos(theta_i) (P, L), 0 where the light is below).
    Made once per size and process (read-only arrays: a table's fit asks for three sizes,
    a library's thumbnails for one per picture)."""
    out = _light_pairs(size)
    for a in out:
        a.flags.writeable = False
    return out


def _light_pairs(size):
    index, n, t = sphere_pixels(size)
    b = np.cross(n, t)
    frame = np.stack([t, b, n], axis=1)                       # rows: local x, y, z
    light_dirs = np.array([d for d, _ in LIGHTS])
    irradiance = np.array([e for _, e in LIGHTS])
    wi = np.einsum("pij,lj->pli", frame, light_dirs)
    wo = np.broadcast_to(frame[:, :, 2][:, None, :], wi.shape).copy()  # view = +z world
    cos_i = wi[..., 2]
    lit = np.where(cos_i > 0.0, irradiance * cos_i, 0.0)
    wi[..., 2] = np.maximum(cos_i, 1e-6)     # unlit pairs stay above the horizon (weight 0)
    wi /= np.linalg.norm(wi, axis=-1, keepdims=True)
    return index, wi, wo, lit


def viewer_exposure(radiance: Float[np.ndarray, "p 3"], lit: Float[np.ndarray, "p l"],
                    mask: Float[np.ndarray, " p"]) -> float:
    """The exposure a viewer would choose for the measured image: ``VIEWER_LEVEL``
    / the ``PERCENTILE`` of the luminance of its lit pixels (some light reaches
    them and the measurement has a value there); EXPOSURE for a black image."""
    y = np.asarray(radiance, np.float64) @ np.asarray(LUMINANCE)
    y = y[(np.sum(lit, axis=-1) > 0.0) & (np.asarray(mask) > 0.0)]
    level = float(np.percentile(y, PERCENTILE)) if y.size else 0.0
    return VIEWER_LEVEL / level if np.isfinite(level) and level > 0.0 else EXPOSURE


class ImageTarget(typing.NamedTuple):
    """The scene's pairs (as a brdf Geometry, (P*L,) flat), their E cos weights
    (P, L), the measurement's tone-mapped sRGB image (P, 3), the pixel mask (P,),
    the exposure (a scalar) both images are tone-mapped at, and ``reference``: the
    measured image's ITP (P, 3) in units of ITP_UNIT (``difference``, made once)."""
    geo: Geometry
    lit: jax.Array
    target: jax.Array
    mask: jax.Array
    exposure: jax.Array
    reference: jax.Array

    @classmethod
    @float64
    def from_measured(cls, measured: "MeasuredBRDF", size: int = SIZE,
                      exposure: float | None = None) -> "ImageTarget":
        """The measurement's image and the pairs the model's image needs, at
        ``exposure`` (None: the measured image's own, ``viewer_exposure``)."""
        return cls.from_scene(_scene(measured, size), exposure)

    @classmethod
    @float64
    def from_scene(cls, scene: tuple, exposure: float | None = None) -> "ImageTarget":
        """From ``_scene``'s (geo, lit, radiance, mask)."""
        geo, lit, radiance, mask = scene
        if exposure is None:
            exposure = viewer_exposure(radiance, lit, mask)
        shown = displayed(radiance, np, exposure)
        return cls(geo, jnp.asarray(lit), jnp.asarray(srgb_encode(shown, np)), jnp.asarray(mask),
                   jnp.asarray(exposure, jnp.float64), jnp.asarray(itp_linear(shown, np) * (720.0 / ITP_UNIT)))

    @property
    def pixels(self) -> int:
        return int(self.mask.shape[0])

    def term(self, f: Float[Array, "pl c"]) -> tuple[Float[Array, ""], Float[Array, "3"], Float[Array, ""]]:
        """``image_term`` on this target: (the image error, its components' mean squares, 0)."""
        mse = pixel_errors(pixel_radiance(f, self), self)
        return image_value(mse), mse, jnp.zeros((), mse.dtype)


@float64
def _scene(measured, size):
    """(pairs as a Geometry, E cos (P, L), the measured linear radiance (P, 3), pixel mask (P,))."""
    index, wi, wo, lit = light_pairs(size)
    flat_wi, flat_wo = wi.reshape(-1, 3), wo.reshape(-1, 3)
    # only the lit pairs are looked up (two in three): an unlit pair's value is weighed by 0
    # and never makes a pixel missing, so 0 there gives the same radiance and mask (bit for bit
    # for a sample list's nearest sample; a table a model evaluates may differ in the 14th digit),
    # in the lookup's own memory layout (einsum's sums follow it: another gives other last bits)
    on = lit.reshape(-1) > 0.0
    f_lit = _measured_lookup(measured, flat_wi[on], flat_wo[on])
    f = np.zeros_like(f_lit, shape=(len(on),) + f_lit.shape[1:])
    f[on] = f_lit
    f = _three_channels(f.reshape(wi.shape[:2] + (-1,)))
    missing = np.any((lit > 0.0) & np.all(f == 0.0, axis=-1), axis=-1)
    if np.all(missing):          # a black measurement, not a missing one
        missing[:] = False
    radiance = np.einsum("pl,plc->pc", lit, f)
    geo = _geometry(flat_wi, flat_wo)
    return geo, lit, radiance, (~missing).astype(np.float64)


class ImageTargets(typing.NamedTuple):
    """The scene of a measurement: ``report`` (SIZE, the image error every result
    reports), ``fit`` (FIT_SIZE, the hybrid loss's term), both at the report
    image's viewer exposure, and ``fixed`` (SIZE at EXPOSURE: the second figure,
    errors["image_fixed"]).  On a small table (fewer than SMALL_TABLE valid pairs) the
    hybrid term is SMALL_FIT_SIZE pixels wide, the screening's: at 64 pixels its pairs
    outnumber a 636-pair table's several times and an evaluation of the hybrid loss cost
    8 x one of M1 (2.2 ms), two fifths of such a table's work (docs/performance.md, *Many
    tiny tables*); a table that small draws no finer sphere than 32 pixels show.  On a
    tiny table (fewer than TINY_TABLE valid pairs) it is TINY_FIT_SIZE wide: 768 pairs for
    the four lights, about as many as such a table has."""
    report: ImageTarget
    fit: ImageTarget
    fixed: ImageTarget

    @classmethod
    @float64
    def from_measured(cls, measured: "MeasuredBRDF") -> "ImageTargets":
        scene = _scene(measured, SIZE)
        report = ImageTarget.from_scene(scene)
        fit = ImageTarget.from_measured(measured, fit_size(measured), float(report.exposure))
        return cls(report, fit, ImageTarget.from_scene(scene, EXPOSURE))


def fit_size(measured: "MeasuredBRDF") -> int:
    """The hybrid term's image size for ``measured``: FIT_SIZE, SMALL_FIT_SIZE on a small table,
    TINY_FIT_SIZE on a tiny one."""
    pairs = np.count_nonzero(measured.valid)
    return FIT_SIZE if pairs >= SMALL_TABLE else SMALL_FIT_SIZE if pairs >= TINY_TABLE else TINY_FIT_SIZE


def _measured_lookup(measured, wi, wo):
    """f of the measurement with its table's interpolating lookup where it has one."""
    methods = getattr(getattr(measured, "table", None), "methods", (None,))
    method = next((m for m in ("trilinear", "quadrilinear") if m in methods), None)
    return np.asarray(measured.lookup(wi, wo, method=method), np.float64)


def _three_channels(f):
    return np.repeat(f, 3, axis=-1) if f.shape[-1] == 1 else f


def pixel_radiance(f: Float[Array, "pl 3"], target: ImageTarget) -> Float[Array, "p 3"]:
    """Each pixel's radiance (P, 3) from f (RGB, or one channel) at the target's pairs (P*L, ...)."""
    f = f.reshape(target.lit.shape + (-1,))
    f = jnp.broadcast_to(f, target.lit.shape + (3,))
    return jnp.einsum("pl,plc->pc", target.lit, f)


def model_image(spec: ModelSpec, params: dict[str, Float[Array, "*channels"]],
                target: ImageTarget) -> Float[Array, "p 3"]:
    """The model's tone-mapped image (P, 3) on the target's pixels (JAX, differentiable)."""
    return tone_map(pixel_radiance(evaluate_geometry(spec, params, target.geo), target), jnp, target.exposure)


def pixel_errors(radiance: Float[Array, "p 3"], target: ImageTarget) -> Float[Array, "3"]:
    """Per-component mean square difference (``difference``) of the tone-mapped ``radiance`` and the
    target's image (3,)."""
    d = difference(displayed(radiance, jnp, target.exposure), target)
    return jnp.dot(target.mask, d * d) / jnp.sum(target.mask)


def image_term(f: Float[Array, "pl c"], target: ImageTarget
               ) -> tuple[Float[Array, ""], Float[Array, "3"], Float[Array, ""]]:
    """(the image term, the image error's three components' mean squares, the second image error)
    of a model whose f (RGB, or one channel) at the target's pairs is ``f``: ``target.term``.  On an
    ImageTarget the term is the image error and the second error 0; on fitting.second_error's
    ``Pictures``, the image error + its weight x the second image error."""
    return target.term(f)


def image_channels(spec: ModelSpec, params: dict[str, Float[Array, "*channels"]], target: ImageTarget
                   ) -> tuple[Float[Array, ""], Float[Array, "3"], Float[Array, ""]]:
    """``image_term`` of the model's f on the target's pairs (JAX, differentiable)."""
    return image_term(evaluate_geometry(spec, params, target.geo), target)


@family.shared
def _image_program(spec):
    return stored_jit(lambda params, target: image_channels(spec, params, target),
                      f"image_error.image_channels {spec!r}")


@float64
def image_error(spec: ModelSpec, params: dict[str, Float[Array, "*channels"]],
                target: ImageTarget) -> tuple[float, list[float]]:
    """(image error, [its three components' RMS]): ``image_value`` (RMS Delta E_ITP / ITP_UNIT)
    and the RMS of the I, T and P differences in the same unit (on ``Pictures``, of its image)."""
    return program_errors(_image_program(spec)(params, target))[:2]


def program_errors(outputs: tuple) -> tuple[float, list[float], float]:
    """(image error, its components' RMS, the second image error) of ``_image_program``'s outputs."""
    _, mse, second = outputs
    mse = np.asarray(mse, np.float64)
    return float(image_value(mse)), [float(c) for c in np.sqrt(mse)], float(second)


@float64
def images(spec: ModelSpec, params: dict[str, Float[Array, "*channels"]], target: ImageTarget,
           size: int = SIZE) -> tuple[np.ndarray, np.ndarray]:
    """(measured, model) tone-mapped sRGB images (size, size, 3), black outside the
    disc and where the measurement has no value -- for plots and the report."""
    return (disc_image(target.target, target, size),
            disc_image(_image_program_images(spec)(params, target), target, size))


def disc_image(pixels: Float[ArrayLike, "p 3"], target: ImageTarget, size: int = SIZE) -> np.ndarray:
    """The target's pixels (P, 3) as a (size, size, 3) image, black outside the disc and
    where the measurement has no value (the pixels the image error leaves out)."""
    img = np.zeros((size * size, 3))
    img[sphere_pixels(size)[0]] = np.asarray(pixels) * np.asarray(target.mask)[:, None]
    return img.reshape(size, size, 3)


@family.shared
def _image_program_images(spec):
    return jax.jit(lambda params, target: model_image(spec, params, target))
