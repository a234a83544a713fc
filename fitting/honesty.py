"""The honesty check of an export: the exported material's error against the measurement.

The glTF BRDF a viewer evaluates -- ``brdf.evaluate("gltf+...", exported
values)`` -- is measured against the data with M1 (the fit's own metric, on
the fit's samples) and the image error (fitting.image_error), and reported
next to the fitted model's.  ``exported_errors`` gives the same two numbers
inside a fit, from its prepared samples.
"""

import os
import pathlib
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

    from .result import FitResult


@float64
def m1_errors(measured: "MeasuredBRDF", models: Iterable[tuple[str, dict[str, float | list[float]]]],
              max_theta: float = 80.0) -> list[tuple[float, list[float]]]:
    """M1 (the fit's metric, on every valid sample with theta <= max_theta) of
    each (model string, parameters) in ``models`` against ``measured``.

    Returns a list of (M1, [M1_r, M1_g, M1_b]).
    """
    from .fit import full_set_errors, prepare
    from .transforms import to_jax
    full, _ = prepare(measured, max_theta=max_theta, samples=0)
    out = []
    for model, params in models:
        spec = parse_model(model)
        channels = np.sqrt(full_set_errors(spec, "log", to_jax(spec, params), full))
        out.append((float(np.mean(channels)), [float(c) for c in channels]))
    return out


@float64
def exported_errors(spec: "ModelSpec", parameters: dict[str, float | list[float]], full: "SampleSet",
                    image: "ImageTargets | None", fitted: dict[str, object]) -> dict[str, object]:
    """The errors of the glTF material ``brdf-fit export`` writes for a fit:
    {"exported_model", "exported_m1", "exported_image" (with an image target)}.

    ``full`` is the fit's full SampleSet (M1 on the same samples as the fit's);
    ``fitted`` the fit's own errors, reused when the conversion is lossless.
    """
    from brdf import gltf_material

    from .image_error import image_error
    from .objective import full_set_errors
    from .transforms import to_jax
    conversion = gltf_material.convert(spec, parameters)
    out = {"exported_model": conversion["model"]}
    if conversion["lossless"]:
        out["exported_m1"] = fitted["m1"]
        if "image" in fitted:
            out["exported_image"] = fitted["image"]
        return out
    gspec = parse_model(conversion["model"])
    params = to_jax(gspec, conversion["parameters"])
    out["exported_m1"] = float(np.mean(np.sqrt(full_set_errors(gspec, "log", params, full))))
    if image is not None:
        out["exported_image"] = image_error(gspec, params, image.report)[0]
    return out


@float64
def image_errors(measured: "MeasuredBRDF",
                 models: Iterable[tuple[str, dict[str, float | list[float]]]]) -> list[float]:
    """The image error (docs/metrics.md) of each (model string, parameters) against ``measured``."""
    from .image_error import ImageTarget, image_error
    from .transforms import to_jax
    target = ImageTarget.from_measured(measured)
    return [image_error(parse_model(model), to_jax(parse_model(model), params), target)[0]
            for model, params in models]


def load_measured(measured: "MeasuredBRDF | str | os.PathLike[str] | None",
                  result: "FitResult") -> "tuple[MeasuredBRDF | None, str | None]":
    """(MeasuredBRDF or None, note) from an object, a path, or the result's provenance."""
    from data_loaders import MeasuredBRDF, load
    if isinstance(measured, MeasuredBRDF):
        return measured, None
    path = measured or (result.provenance or {}).get("file")
    if not path:
        return None, "no measured file given and none in the result's provenance"
    if measured is None and not pathlib.Path(path).is_file():
        return None, f"the provenance file {path} is not here (pass --measured)"
    return load(path), None


def honesty(result: "FitResult", conversion: dict, measured: "MeasuredBRDF") -> dict[str, object]:
    """{"measured_file", "sha256_matches", "max_theta", "m1_fitted_model",
    "m1_exported_gltf", ...} for a loaded MeasuredBRDF."""
    max_theta = float((result.optimizer or {}).get("max_theta", 80.0))
    (m1_fit, ch_fit), (m1_gltf, ch_gltf) = m1_errors(
        measured, [(result.spec, result.parameters),
                   (conversion["model"], conversion["parameters"])], max_theta)
    image_fit, image_gltf = image_errors(measured, [(result.spec, result.parameters),
                                                    (conversion["model"], conversion["parameters"])])
    sha = (result.provenance or {}).get("sha256")
    return {
        "image_fitted_model": image_fit,
        "image_exported_gltf": image_gltf,
        "measured_file": measured.provenance.path,
        "sha256_matches": (bool(sha) and sha == measured.provenance.sha256) if sha else None,
        "max_theta": max_theta,
        "m1_recorded": float(result.errors.get("m1", float("nan"))),
        "m1_fitted_model": m1_fit,
        "m1_fitted_model_per_channel": ch_fit,
        "m1_exported_gltf": m1_gltf,
        "m1_exported_gltf_per_channel": ch_gltf,
    }


def recorded_honesty(result: "FitResult", measured: "MeasuredBRDF") -> dict[str, object]:
    """``honesty`` from the errors a fit of ``measured`` recorded just now (export-first):
    the same numbers without evaluating both models again."""
    e = result.errors
    lossless = e["exported_m1"] == e["m1"] and e.get("exported_image") == e.get("image")
    return {
        "image_fitted_model": e.get("image"),
        "image_exported_gltf": e.get("exported_image"),
        "measured_file": measured.provenance.path,
        "sha256_matches": True,
        "max_theta": float((result.optimizer or {}).get("max_theta", 80.0)),
        "m1_recorded": e["m1"],
        "m1_fitted_model": e["m1"],
        "m1_fitted_model_per_channel": e["m1_per_channel"],
        "m1_exported_gltf": e["exported_m1"],
        "m1_exported_gltf_per_channel": e["m1_per_channel"] if lossless else None,
    }
