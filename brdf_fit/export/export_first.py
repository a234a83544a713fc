"""Export-first: a measured file in, the best glTF material out.

``brdf-fit export MEASURED_FILE --out material.glb`` fits the glTF family --
models whose glTF material is the fitted BRDF itself, so nothing is lost on
the way to the file -- and writes the one whose *exported* material ranks
best (``fitting.ranking``: M1 + 0.3 x the image error, both of the material
as a viewer evaluates it).  ``--model`` fits other models instead (``auto``:
the engine family); the ranking is then by each fit's exported material, so
a model that glTF cannot represent only wins if its export still does.
"""

import typing

from brdf.model import model_string, parse_model

from fitting.ranking import exported_ranking_error

if typing.TYPE_CHECKING:
    from data_loaders import MeasuredBRDF

    from fitting.result import FitResult

#: The glTF BRDF with and without KHR_materials_specular and _clearcoat;
#: anisotropic measurements add KHR_materials_anisotropy (``family_for``).
#: KHR_materials_ior is left out: with specular, its F0 = ((ior-1)/(ior+1))^2
#: x specularColor can already be any value, so +ior fits the same BRDF again.
GLTF_FAMILY = tuple(model_string(parse_model(m)) for m in (
    "gltf", "gltf+specular", "gltf+clearcoat", "gltf+specular+clearcoat"))
GLTF_ANISO_FAMILY = tuple(model_string(parse_model(m)) for m in (
    "gltf+aniso", "gltf+aniso+specular", "gltf+aniso+specular+clearcoat"))


def family_for(isotropic: bool) -> list[str]:
    """The glTF family for a measurement (with the anisotropic variants when it is not isotropic)."""
    return list(GLTF_FAMILY) + ([] if isotropic else list(GLTF_ANISO_FAMILY))


def fit_for_export(measured: "MeasuredBRDF", models: list[str] | None = None,
                   fit_options: dict[str, object] | None = None,
                   progress: typing.Callable[[str], object] | None = None, screen: bool = False,
                   screened: list | None = None) -> "list[FitResult]":
    """Fit ``models`` (default: the glTF family) to a measurement; the results
    sorted by their exported ranking error, best first.  ``screen`` (``--model
    auto``): every model screened by its exported material, only the contenders
    fitted (fitting/screen.py); the screened ones' ``ModelScreened`` go to ``screened``."""
    from fitting.fit_models import FIT_THREADS, fit_models
    from fitting.screen import ModelScreened
    results = []
    for model, outcome in fit_models(measured, models or family_for(measured.isotropic), threads=FIT_THREADS,
                                     screen="export" if screen else None, **(fit_options or {})):
        if isinstance(outcome, ModelScreened):
            if screened is not None:
                screened.append(outcome)
            if progress:
                progress(f"{model}: screened")
            continue
        if isinstance(outcome, Exception):
            raise outcome
        results.append(outcome)
        if progress:
            progress(f"{model}: exported M1 {outcome.errors['exported_m1']:.4g}")
    results.sort(key=lambda r: exported_ranking_error(r.errors))
    return results


def describe_candidates(results: "list[FitResult]", stream: typing.TextIO) -> None:
    """The fitted models with their own and their exported errors (best export first)."""
    width = max(len(r.spec) for r in results)
    print(f"{'model':<{width}}  {'M1':>9}  {'image':>7}  {'glTF M1':>9}  {'glTF image':>10}", file=stream)
    for i, r in enumerate(results):
        e = r.errors
        print(f"{r.spec:<{width}}  {e['m1']:9.5f}  {e.get('image', float('nan')):7.4f}  "
              f"{e['exported_m1']:9.5f}  {e.get('exported_image', float('nan')):10.4f}"
              + ("  <- written" if i == 0 else ""), file=stream)
