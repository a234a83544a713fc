"""The honesty check of an export: the exported material's error against the measurement.

The glTF BRDF a viewer evaluates -- ``brdf.evaluate("gltf+...", exported
values)`` -- is measured against the data with M1 (the fit's own metric, on
the fit's samples) and reported next to the fitted model's M1.
"""

import os
import pathlib
import typing
from collections.abc import Iterable

import numpy as np

from brdf.model import parse_model

from ._jax import float64

if typing.TYPE_CHECKING:
    from data_loaders import MeasuredBRDF

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
    sha = (result.provenance or {}).get("sha256")
    return {
        "measured_file": measured.provenance.path,
        "sha256_matches": (bool(sha) and sha == measured.provenance.sha256) if sha else None,
        "max_theta": max_theta,
        "m1_recorded": float(result.errors.get("m1", float("nan"))),
        "m1_fitted_model": m1_fit,
        "m1_fitted_model_per_channel": ch_fit,
        "m1_exported_gltf": m1_gltf,
        "m1_exported_gltf_per_channel": ch_gltf,
    }
