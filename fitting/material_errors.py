"""The errors of a material against a measurement: M1 and the image error of
fitted models, and of the glTF material ``brdf-fit export`` writes for a fit.

``exported_errors`` gives the exported material's two numbers inside a fit,
from its prepared samples; ``m1_errors`` and ``image_errors`` measure any
(model, parameters) against a MeasuredBRDF (the export's honesty check, the report).
"""

import typing
from collections.abc import Iterable

import numpy as np

from brdf.model import parse_model

from ._jax import float64

if typing.TYPE_CHECKING:
    from brdf.model import ModelSpec
    from data_loaders import MeasuredBRDF

    from .image_error import ImageTargets
    from .samples import SampleSet


@float64
def m1_errors(measured: "MeasuredBRDF", models: Iterable[tuple[str, dict[str, float | list[float]]]],
              max_theta: float = 80.0, loss: str = "log") -> list[tuple[float, list[float]]]:
    """M1 (the fit's metric, on every valid sample with theta <= max_theta) of
    each (model string, parameters) in ``models`` against ``measured`` -- or the
    table error of another ``loss`` (fitting.losses: "ngan" is Ngan et al. 2005's L2).

    Returns a list of (M1, [M1_r, M1_g, M1_b]).
    """
    from .objective import full_set_errors
    from .samples import prepare
    from .transforms import to_jax
    full, _ = prepare(measured, max_theta=max_theta, samples=0)
    out = []
    for model, params in models:
        spec = parse_model(model)
        channels = np.sqrt(full_set_errors(spec, loss, to_jax(spec, params), full))
        out.append((float(np.mean(channels)), [float(c) for c in channels]))
    return out


@float64
def exported_errors(spec: "ModelSpec", parameters: dict[str, float | list[float]], full: "SampleSet | list[SampleSet]",
                    image: "ImageTargets | None", fitted: dict[str, object],
                    readings: bool = False) -> dict[str, object]:
    """The errors of the glTF material ``brdf-fit export`` writes for a fit:
    {"exported_model", "exported_m1", "exported_image" (with an image target)}, a converted
    material read as the engines draw it (brdf.gltf_material.engines_reading); with
    ``readings``, for a material that is not portable, those of it as Blender reads it
    too ("blender_m1", "blender_image": brdf.gltf_material.blender_reading), which the
    pages show beside a spec-only corner the shipped rule passed over
    (brdf_fit.export.export_first.Shipped).

    ``full`` is the fit's full SampleSet, or its parts (M1 on the same samples as the fit's);
    ``fitted`` the fit's own errors, reused when the conversion is lossless.
    """
    from brdf import gltf_material
    conversion = gltf_material.convert(spec, parameters)
    if conversion["model"] is None:         # no glTF material (a model of one's own): no exported errors
        return {}
    conversion = gltf_material.engines_reading(conversion)     # a converted material as the engines draw it
    out = {"exported_model": conversion["model"]}
    if conversion["lossless"]:
        out["exported_m1"] = fitted["m1"]
        pictures = {k: fitted[k] for k in ("image", "second_image") if k in fitted}
    else:
        out["exported_m1"], pictures = _material_errors(conversion, full, image)
    out.update({f"exported_{k}": v for k, v in pictures.items()})
    if readings and not gltf_material.portable(conversion):
        out["blender_m1"], pictures = _material_errors(gltf_material.blender_reading(conversion), full, image)
        if "image" in pictures:
            out["blender_image"] = pictures["image"]
    return out


def _material_errors(conversion, full, image):
    """(M1, {"image": image error, "second_image": ...} as the image target gives them, {} without one)
    of a glTF material (a conversion) on the fit's samples and image target."""
    from .second_error import picture_errors
    from .objective import full_set_errors
    from .transforms import to_jax
    gspec = parse_model(conversion["model"])
    params = to_jax(gspec, conversion["parameters"])
    m1 = float(np.mean(np.sqrt(full_set_errors(gspec, "log", params, full))))
    if image is None:
        return m1, {}
    pictures = picture_errors(gspec, params, image.report)
    return m1, {k: v for k, v in pictures.items() if k in ("image", "second_image")}


@float64
def image_errors(measured: "MeasuredBRDF",
                 models: Iterable[tuple[str, dict[str, float | list[float]]]]) -> list[float]:
    """The image error (docs/metrics.md) of each (model string, parameters) against ``measured``."""
    from .image_error import ImageTarget, image_error
    from .transforms import to_jax
    target = ImageTarget.from_measured(measured)
    return [image_error(parse_model(model), to_jax(parse_model(model), params), target)[0]
            for model, params in models]
