"""``brdf-fit export RESULT.json --out material.mtlx``: a fit as a MaterialX document.

The document comes from brdf.materialx (a ``gltf_pbr`` material with the glTF
conversion's values, and an ``open_pbr_surface`` alternative); this module
adds the fit's provenance, runs the honesty check and writes the file
atomically.  The honesty check is the glTF export's (brdf_fit.export.honesty): the
BRDF of the ``gltf_pbr`` material is glTF's, so its M1 is the exported glTF
BRDF's.  The OpenPBR material of a glTF conversion has no BRDF in the toolkit;
what it approximates is listed in its notes (docs/materialx.md); that of an
``openpbr+metal`` or ``openpbr+nonmetal`` fit (bare or ``+coat``) is the fitted BRDF itself, written 1:1.
"""

import os
import pathlib
import typing

from brdf import gltf_material, parse_model
from brdf.materialx import materialx_document
from brdf.openpbr_coat import OPENPBR_COMPOSITIONS, open_pbr_surface_inputs

from .gltf_file import ExportError
from .honesty import honesty_report
from fitting.result import FitResult, first_non_finite

if typing.TYPE_CHECKING:
    from data_loaders import MeasuredBRDF

SUFFIX = ".mtlx"


def provenance_attributes(result: FitResult, conversion: dict, report: dict) -> dict[str, object]:
    """The ``brdf_fit_*`` attributes of the written materials: the fit, its source, the errors."""
    prov = result.provenance or {}
    return {
        "spec": result.spec,
        "m1": result.errors.get("m1"),
        "source": prov.get("file"),
        "sha256": prov.get("sha256"),
        "material": result.material,
        "gltf_model": conversion["model"],
        "kind": conversion["kind"],
        "lossless": conversion["lossless"],
        "m1_exported_gltf": report.get("m1_exported_gltf"),
        "honesty_measured_file": report.get("measured_file"),
        "toolkit_version": result.toolkit_version,
    }


def export_materialx(result: FitResult | str | os.PathLike[str], path: str | os.PathLike[str],
                     measured: "MeasuredBRDF | str | os.PathLike[str] | None" = None,
                     open_pbr: bool = True, just_fitted: bool = False) -> dict[str, object]:
    """Write ``result`` (FitResult or RESULT.json path) as a MaterialX 1.39 document.

    ``measured`` and ``just_fitted`` as for brdf_fit.export.gltf.export_gltf.  Returns the conversion
    (``model``, ``parameters``, ``kind``, ``lossless``, ``notes``) with
    ``extensions`` (the glTF extensions its values stand for), ``path``,
    ``materials`` ({name: shader category}), ``materialx_inputs`` ({shader
    category: {input: value}}), ``materialx_notes`` ({shader category:
    [sentences]}) and ``honesty`` (M1 of the fitted model and of the glTF BRDF
    of the gltf_pbr material, or a ``reason``).
    """
    if not isinstance(result, FitResult):
        result = FitResult.load(result)
    path = pathlib.Path(path)
    if path.suffix.lower() != SUFFIX:
        raise ExportError(f"{path}: a MaterialX document must end in {SUFFIX}")
    conversion = gltf_material.convert(result.spec, result.parameters)
    if conversion["model"] is None:         # a model of one's own (brdf/own.py)
        raise ExportError(f"{result.spec}: no material: {conversion['notes'][0]}")
    bad = first_non_finite(conversion["parameters"])
    if bad is not None:
        raise ExportError(f"{path}: not written: {bad[0]} would be {bad[1]}; a MaterialX value must be finite")
    report = honesty_report(result, conversion, measured, just_fitted)
    # a fit of OpenPBR's own metal or non-metal, bare or coated: its open_pbr_surface 1:1 (brdf/openpbr_coat.py)
    composition = parse_model(result.spec).composition
    native = open_pbr_surface_inputs(result.parameters, composition) if composition in OPENPBR_COMPOSITIONS else None
    try:
        doc = materialx_document(conversion, name=result.material or "material",
                                 provenance=provenance_attributes(result, conversion, report),
                                 open_pbr=open_pbr, native=native)
    except ValueError as err:
        raise ExportError(f"{path}: not written: {err}") from None
    from data_loaders.measured import write_file_atomic
    write_file_atomic(path, doc["xml"])
    _, used = gltf_material.material_json(conversion)
    inputs = {"gltf_pbr": doc["gltf_pbr"]}
    if doc["open_pbr_surface"] is not None:
        inputs["open_pbr_surface"] = doc["open_pbr_surface"]
    return {**conversion, "extensions": used, "path": str(path), "materials": doc["materials"],
            "materialx_inputs": inputs, "materialx_notes": doc["notes"], "honesty": report}
