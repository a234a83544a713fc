"""The honesty check of an export: the exported material's error against the measurement.

The glTF BRDF a viewer evaluates -- ``brdf.evaluate("gltf+...", exported
values)`` -- is measured against the data with M1 (the fit's own metric, on
the fit's samples) and the image error (fitting.image_error), and reported
next to the fitted model's (``fitting.material_errors``).
"""

import os
import pathlib
import typing

from brdf.gltf_material import engines_reading
from fitting.material_errors import image_errors, m1_errors

if typing.TYPE_CHECKING:
    from data_loaders import MeasuredBRDF

    from fitting.result import FitResult


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


def honesty_report(result: "FitResult", conversion: dict, measured: "MeasuredBRDF | str | os.PathLike[str] | None",
                   just_fitted: bool = False) -> dict[str, object]:
    """The honesty report an export writes: ``honesty`` against the measured table
    (``load_measured``'s), the errors the fit recorded when ``just_fitted`` (it was fitted
    to that table in this process or on the same file) and it recorded them, or
    {"reason"} why there is no table."""
    measured_obj, reason = load_measured(measured, result)
    if measured_obj is None:
        return {"reason": reason}
    if just_fitted and "exported_m1" in result.errors:
        return recorded_honesty(result, measured_obj)
    return honesty(result, conversion, measured_obj)


def honesty(result: "FitResult", conversion: dict, measured: "MeasuredBRDF") -> dict[str, object]:
    """{"measured_file", "sha256_matches", "max_theta", "m1_fitted_model",
    "m1_exported_gltf", ...} for a loaded MeasuredBRDF."""
    conversion = engines_reading(conversion)       # a converted material as the engines draw it
    return compared(result, (conversion["model"], conversion["parameters"]), measured)


def compared(result: "FitResult", exported: tuple[str, dict], measured: "MeasuredBRDF") -> dict[str, object]:
    """The honesty report of the material ``exported`` ((model string, parameters): what the
    file draws) against the fit, both measured against ``measured``."""
    max_theta = float((result.optimizer or {}).get("max_theta", 80.0))
    pairs = [(result.spec, result.parameters), exported]
    (m1_fit, ch_fit), (m1_gltf, ch_gltf) = m1_errors(measured, pairs, max_theta)
    image_fit, image_gltf = image_errors(measured, pairs)
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
