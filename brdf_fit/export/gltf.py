"""``brdf-fit export``: a fit as a glTF 2.0 material on a UV sphere.

The pieces: brdf.gltf_material converts the fit (docs/gltf.md) and
writes the material JSON; brdf_fit.export.honesty measures the exported material's
M1 against the data next to the fitted model's; brdf_fit.export.gltf_file writes the
sphere and the material as ``.gltf`` (embedded base64 buffer) or ``.glb``.
The fit (spec, parameters, errors, provenance, optimizer) and the conversion
go in the material's ``extras``.
"""

import os
import pathlib
import sys
import typing
from typing import TextIO

from brdf import gltf_material
from brdf.gltf_material import GltfConversion, anisotropy_to_gltf, material_json, parameters_from_material  # noqa: F401

from brdf_fit.errors import BAD_INPUT, OK, fail, warn  # noqa: F401  (BAD_INPUT: the exit codes' one home)
from .gltf_file import ExportError, gltf_document, write_gltf_file  # noqa: F401
from .honesty import honesty_report
from fitting.ranking import EXPORT_LOSS_WARN
from fitting.result import FitResult, ResultFileError

if typing.TYPE_CHECKING:
    from data_loaders import MeasuredBRDF


def convert(result: FitResult | dict) -> GltfConversion:
    """A FitResult (or {"spec", "parameters"}) -> brdf.gltf_material.GltfConversion."""
    if isinstance(result, FitResult):
        return gltf_material.convert(result.spec, result.parameters)
    return gltf_material.convert(result["spec"], result["parameters"])


def export_gltf(result: FitResult | str | os.PathLike[str], path: str | os.PathLike[str],
                measured: "MeasuredBRDF | str | os.PathLike[str] | None" = None,
                just_fitted: bool = False) -> dict[str, object]:
    """Write ``result`` (FitResult or RESULT.json path) as a glTF material on a sphere
    (a ``path`` ending in .mtlx: a MaterialX document, brdf_fit.export.materialx_file).

    ``measured``: a MeasuredBRDF, a measured file path, or None (then the
    provenance file, when it exists); ``just_fitted``: the result was fitted to
    that MeasuredBRDF in this process, so its recorded errors are the honesty
    check's numbers (export-first).  Returns a dict with the conversion
    (``model``, ``parameters``, ``kind``, ``lossless``, ``notes``), the
    ``material`` JSON, ``extensions``, ``path`` and ``honesty`` (M1 of the
    fitted model and of the exported glTF BRDF against the measurement, or a
    ``reason`` why there is none).
    """
    if not isinstance(result, FitResult):
        result = FitResult.load(result)
    path = pathlib.Path(path)
    if path.suffix.lower() == ".mtlx":          # a MaterialX document instead (docs/materialx.md)
        from .materialx_file import export_materialx
        return export_materialx(result, path, measured=measured, just_fitted=just_fitted)
    if path.suffix.lower() not in (".gltf", ".glb"):
        raise ExportError(f"{path}: the output must end in .gltf, .glb or .mtlx")
    material, used, conversion, report = exported_material(result, measured, just_fitted)
    doc, binary = gltf_document(material, used)
    write_gltf_file(path, doc, binary)
    return {**conversion, "spec": result.spec, "material": material, "extensions": used, "path": str(path),
            "honesty": report}


def exported_material(result: FitResult, measured: "MeasuredBRDF | str | os.PathLike[str] | None" = None,
                      just_fitted: bool = False) -> tuple[dict, list[str], GltfConversion, dict[str, object]]:
    """(material JSON, its KHR extensions, conversion, honesty report) of the glTF material
    ``export_gltf`` writes for ``result`` (same arguments): one home for that material,
    shared with the library's all-materials file (brdf_fit.library.glb)."""
    conversion = convert(result)
    if conversion["model"] is None:         # a model of one's own (brdf/own.py)
        raise ExportError(f"{result.spec}: no glTF material: {conversion['notes'][0]}")
    report = honesty_report(result, conversion, measured, just_fitted)
    extras = {"brdf_fit": {
        "toolkit_version": result.toolkit_version,
        "schema_version": result.schema_version,
        "spec": result.spec,
        "parameters": result.parameters,
        "errors": result.errors,
        "provenance": result.provenance,
        "optimizer": {k: result.optimizer.get(k) for k in
                      ("name", "samples", "samples_full", "max_theta", "seed", "converged", "seconds_total")
                      if k in (result.optimizer or {})},
        "gltf_model": conversion["model"],
        "gltf_parameters": conversion["parameters"],
        "conversion": {"kind": conversion["kind"], "lossless": conversion["lossless"],
                       "notes": conversion["notes"], "rules": "docs/gltf.md of brdf-fit"},
        "honesty": report,
    }}
    material, used = material_json(conversion, name=result.material, extras=extras)
    return material, used, conversion, report


def describe_export(info: dict[str, object], stream: TextIO | None = None) -> None:
    """Print what an export wrote and the two errors side by side."""
    stream = stream or sys.stdout
    h = info["honesty"]
    exts = ", ".join(info["extensions"]) or "core only"
    print(f"wrote {info['path']}: {info['model']} ({info['kind']}; {exts})", file=stream)
    for note in info["notes"]:
        print(f"  note: {note}", file=stream)
    for name, shader in info.get("materials", {}).items():      # .mtlx: its materials and their notes
        print(f"  material {name} ({shader})", file=stream)
        for note in info["materialx_notes"][shader]:
            print(f"    {shader} note: {note}", file=stream)
    if "m1_exported_gltf" in h:
        print(f"errors against {h['measured_file']} (theta <= {h['max_theta']:g} deg for M1):", file=stream)
        for name, fitted, exported in (("M1", h["m1_fitted_model"], h["m1_exported_gltf"]),
                                       ("image error", h.get("image_fitted_model"),
                                        h.get("image_exported_gltf"))):
            if fitted is None:
                continue
            change = exported / fitted - 1.0 if fitted > 0 else 0.0
            print(f"  {name:<11} fitted model {fitted:.6g}, exported material {exported:.6g} "
                  f"({change * 100:+.1f} %)", file=stream)
            if change > EXPORT_LOSS_WARN:
                warn("export", f"the exported material's {name} is {change * 100:.0f} % above the fit's: glTF "
                     f"cannot represent {info.get('spec') or 'this model'} exactly (notes above); "
                     "`brdf-fit export MEASURED_FILE` fits the glTF family instead")
        if h["sha256_matches"] is False:
            print("  warning: the measured file differs from the one the fit was made on (sha256)",
                  file=stream)
    else:
        print(f"M1 of the exported material not computed: {h['reason']}", file=stream)


def export_main(result_path: str | os.PathLike[str], out_path: str | os.PathLike[str],
                measured_path: str | os.PathLike[str] | None = None) -> int:
    """``brdf-fit export``: 0 on success, 2 with one line on stderr for bad input."""
    from data_loaders import MeasuredDataError
    try:
        result = FitResult.load(result_path)
        info = export_gltf(result, out_path, measured=measured_path)
    except (ResultFileError, MeasuredDataError, ExportError, ValueError) as err:
        return fail("export", err)
    except OSError as err:
        return fail("export", f"{out_path}: cannot write ({err.strerror or err})")
    describe_export(info)
    return OK
