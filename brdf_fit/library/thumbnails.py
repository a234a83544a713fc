"""The gallery's pictures: a material's measured and fitted spheres as the image error sees them.

The pictures are the image error's own scene (fitting/image_error.py, docs/metrics.md):
the sphere under its lights, tone-mapped at the viewer's exposure taken from the
measured image (one exposure for both, so a dark material is shown as a viewer would
set it, and the two spheres compare).  They need no OpenGL (numpy and the model's
JAX evaluation), so a library builds anywhere; THUMB_SIZE keeps a hundred cards light.

The fitted model is evaluated by ``fitting.fit.evaluate_result``'s program (``jax.jit``
of ``brdf.model.evaluate``: the same numbers) kept on disk (``fitting.stored``), so a
fresh worker process reads each model's traced program instead of tracing it again
(and computing the energy tables of the multiple-scattering terms: a second or more);
one program per model, whatever the number of materials.
"""

import functools
import os
import pathlib
import typing

import numpy as np

if typing.TYPE_CHECKING:
    from data_loaders import MeasuredBRDF
    from fitting.image_error import ImageTarget
    from fitting.result import FitResult

THUMB_SIZE = 96              # pixels; the image error's scene at any size is the same scene
BACKGROUND = 0.93            # a light grey behind the sphere (display value)
# Each thumbnail pixel is the mean of SUPERSAMPLE x SUPERSAMPLE pixel centres: the sphere's
# silhouette is smooth, not the staircase of a pixel in or out (issue 62).
SUPERSAMPLE = 2


def sphere_pair(measured: "MeasuredBRDF", result: "FitResult", size: int = THUMB_SIZE,
                supersample: int = SUPERSAMPLE, target: "ImageTarget | None" = None) -> tuple[np.ndarray, np.ndarray]:
    """(measured, fitted) sRGB uint8 images (size, size, 3) of the image error's scene.
    ``target``: ``measured_sphere(measured, size, supersample)``, made already (a material's pictures
    share it: its lookups in the table are most of a picture's time)."""
    return _exposed_pair(measured, result, size, supersample, target)[:2]


def measured_sphere(measured: "MeasuredBRDF", size: int = THUMB_SIZE, supersample: int = SUPERSAMPLE) -> "ImageTarget":
    """The measured side of a material's pictures: the image error's scene of ``measured`` at
    ``size`` x ``supersample`` pixels (``ImageTarget.from_measured``), at its viewer's exposure."""
    from fitting.image_error import ImageTarget
    return ImageTarget.from_measured(measured, size * supersample)


def _exposed_pair(measured, result, size=THUMB_SIZE, supersample=SUPERSAMPLE, target=None):
    """sphere_pair's two images and the exposure both are shown at."""
    from fitting._jax import float64
    return float64(_pair)(measured, result, size, supersample, target)


def _pair(measured, result, size, supersample, target):
    from fitting.image_error import displayed, light_pairs, srgb_encode
    size, out_size = size * supersample, size
    target = measured_sphere(measured, out_size, supersample) if target is None else target
    index, wi, wo, lit = light_pairs(size)
    if target.pixels != len(index):
        raise ValueError(f"a measured sphere of {target.pixels} pixels given for pictures of {len(index)}")
    f = _evaluate(result, wi.reshape(-1, 3), wo.reshape(-1, 3)).reshape(wi.shape[:2] + (-1,))
    f = np.broadcast_to(f, wi.shape[:2] + (3,))
    fitted = srgb_encode(displayed(np.einsum("pl,plc->pc", lit, f), np, float(target.exposure)), np)
    return (_image(np.asarray(target.target), index, size, out_size), _image(fitted, index, size, out_size),
            float(target.exposure))


def _evaluate(result, wi, wo):
    """``fitting.fit.evaluate_result(result, wi, wo)`` (inside float64), by the stored program."""
    import jax.numpy as jnp

    from brdf.model import parse_model
    from fitting.transforms import to_jax
    spec = parse_model(result.spec)
    f = _model_program(spec)(to_jax(spec, result.parameters), jnp.asarray(wi, jnp.float64),
                             jnp.asarray(wo, jnp.float64))
    return np.asarray(f, dtype=np.float64)


@functools.cache
def _model_program(spec):
    from brdf.model import evaluate
    from fitting.stored import stored_jit
    return stored_jit(lambda p, a, b: evaluate(spec, p, a, b), f"library.thumbnails.evaluate {spec!r}")


def _image(pixels, index, size, out_size):
    """The sphere's pixels (P, 3) in [0, 1] placed on a size x size background, averaged
    over blocks down to out_size x out_size, as uint8."""
    out = np.full((size * size, 3), BACKGROUND)
    out[index] = np.clip(pixels, 0.0, 1.0)
    k = size // out_size
    blocks = out.reshape(out_size, k, out_size, k, 3).mean(axis=(1, 3))
    return np.round(blocks * 255.0).astype(np.uint8)


def write_pair(measured: "MeasuredBRDF", result: "FitResult", folder: str | os.PathLike[str],
               stem: str, target: "ImageTarget | None" = None) -> float:
    """Write ``stem``-measured.png and ``stem``-fitted.png into ``folder`` (atomically);
    returns the exposure both are shown at (the viewer's rule on the measured picture).
    ``target``: ``measured_sphere(measured)``, made already."""
    from data_loaders.atomic import write_file_atomic
    from shaders.image import png_bytes
    folder = pathlib.Path(folder)
    measured_img, fitted_img, exposure = _exposed_pair(measured, result, target=target)
    write_file_atomic(folder / f"{stem}-measured.png", png_bytes(measured_img))
    write_file_atomic(folder / f"{stem}-fitted.png", png_bytes(fitted_img))
    return exposure


def write_shipped(measured: "MeasuredBRDF", result: "FitResult", folder: str | os.PathLike[str],
                  stem: str, target: "ImageTarget | None" = None) -> pathlib.Path:
    """Write ``stem``-shipped.png into ``folder``: the sphere of the glTF material ``result``
    exports (brdf.gltf_material.convert; the fit itself for the glTF family), as the pair's
    (``target``: ``measured_sphere(measured)``, made already)."""
    import types

    from brdf.gltf_material import convert
    from data_loaders.atomic import write_file_atomic
    from shaders.image import png_bytes
    conversion = convert(result.spec, result.parameters)
    exported = types.SimpleNamespace(spec=conversion["model"], parameters=conversion["parameters"])
    path = pathlib.Path(folder) / f"{stem}-shipped.png"
    write_file_atomic(path, png_bytes(sphere_pair(measured, exported, target=target)[1]))
    return path
