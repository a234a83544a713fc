"""Export-first in OpenPBR's own terms: ``brdf-fit export MEASURED --format openpbr``.

The OpenPBR family (fitting.auto.OPENPBR_FAMILY: OpenPBR Surface's metal and its non-metal,
brdf/openpbr.py, bare and under its coat, brdf/openpbr_coat.py, each read with MaterialX's GGX
energy compensation, ``+mx``: the BRDF MaterialX's ``open_pbr_surface`` draws at those inputs)
is fitted to the table and ranked by the fits' own ranking error (M1 + 0.3 x image error,
fitting.ranking): the material is the fitted BRDF itself, so nothing is converted on the way to
the file.  The best is written as a MaterialX document of one ``open_pbr_surface`` (and its
``surfacematerial``), 1:1 (brdf.openpbr_coat.open_pbr_surface_inputs).

The honesty check reads the written document back (``read_open_pbr_surface``), takes the
fit's parameters from its inputs (``parameters_from_inputs``) and
evaluates the model there against the table: its M1 and image error are the material's
as written, beside the fit's own.
"""

import os
import pathlib
import typing
import xml.etree.ElementTree as ET

from brdf.model import parse_model
from brdf.openpbr_coat import MX_TWINS, OPEN_PBR_SURFACE_HELD, OPEN_PBR_SURFACE_INPUTS, OPENPBR_COMPOSITIONS

from .gltf_file import ExportError
from fitting.auto import OPENPBR_FAMILY, expand_models, model_sets

if typing.TYPE_CHECKING:
    from data_loaders import MeasuredBRDF

    from fitting.result import FitResult

#: a written document larger than this is not one this module wrote: not read back
MTLX_MOST_BYTES = 1 << 20


def is_openpbr(spec: str) -> bool:
    """Whether a model string is one of OpenPBR's own models (written 1:1 as open_pbr_surface)."""
    return parse_model(spec).composition in OPENPBR_COMPOSITIONS


def drawn_by_materialx(spec: str) -> bool:
    """Whether a model is one of OpenPBR's read as MaterialX draws it (``+mx``: its GGX energy
    compensation): its written document is drawn as fitted."""
    return parse_model(spec).composition in MX_TWINS


#: what each native format writes: (its named model set, whether a model's fits are written 1:1)
FORMAT_SETS = {"openpbr": "openpbr", "blender": "principled"}


def written_by(fmt: str) -> "typing.Callable[[str], bool]":
    """Whether a model's fits are written 1:1 by a native format: ``openpbr`` any of OpenPBR's
    models, ``blender`` those a Principled BSDF draws (brdf_fit.export.blender_file)."""
    from .blender_file import drawn_by_principled
    return {"openpbr": is_openpbr, "blender": drawn_by_principled}[fmt]


def openpbr_models(asked: str | None, fmt: str = "openpbr") -> list[str]:
    """The models a native format (``openpbr``, ``blender``) fits: its set (FORMAT_SETS: 'openpbr',
    fitting.auto.OPENPBR_FAMILY; 'principled', PRINCIPLED_FAMILY), or the models and sets ``asked``
    (comma-separated), each of which the format must write 1:1 (a ValueError naming the first
    that it does not)."""
    keep, own = written_by(fmt), FORMAT_SETS[fmt]
    items = [m.strip() for m in (asked or own).split(",") if m.strip()]
    for item in items:
        models = model_sets().get(item, (item,))
        if any(not keep(m) for m in models):
            raise ValueError(f"--format {fmt} writes only models it draws 1:1; {item!r} is not one of them "
                             f"(its set, '{own}': {', '.join(model_sets()[own])})")
    return expand_models(",".join(items))


def fit_openpbr(measured: "MeasuredBRDF", models: list[str], fit_options: dict[str, object] | None = None,
                progress: typing.Callable[[str], object] | None = None) -> "list[FitResult]":
    """Fit each of ``models`` to ``measured``; the results best first by their own ranking error."""
    from fitting.fit_models import FIT_THREADS, fit_models
    from fitting.ranking import ranked
    results = []
    for model, outcome in fit_models(measured, models, threads=FIT_THREADS, **(fit_options or {})):
        if isinstance(outcome, Exception):
            raise outcome
        results.append(outcome)
        if progress:
            progress(f"{model}: M1 {outcome.errors['m1']:.4g}")
    return ranked(results)


def read_open_pbr_surface(path: str | os.PathLike[str]) -> dict[str, float | list[float]]:
    """The inputs of the one ``open_pbr_surface`` of a MaterialX document: {input: value}."""
    path = pathlib.Path(path)
    if path.stat().st_size > MTLX_MOST_BYTES:
        raise ExportError(f"{path}: {path.stat().st_size} bytes: not a document this toolkit wrote")
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as err:
        raise ExportError(f"{path}: not a MaterialX document: {err}") from None
    shaders = root.findall("open_pbr_surface")
    if len(shaders) != 1:
        raise ExportError(f"{path}: {len(shaders)} open_pbr_surface nodes, expected 1")
    inputs = {}
    for item in shaders[0].findall("input"):
        try:
            values = [float(v) for v in item.get("value", "").split(",")]
        except ValueError:
            raise ExportError(f"{path}: open_pbr_surface's {item.get('name')} is {item.get('value')!r}, "
                              "not a number") from None
        inputs[item.get("name")] = values if item.get("type") == "color3" else values[0]
    return inputs


def parameters_from_inputs(inputs: dict, composition: str) -> dict[str, float | list[float]]:
    """The parameters of an OpenPBR composition's fit from an open_pbr_surface's inputs: the
    inverse of brdf.openpbr_coat.open_pbr_surface_inputs (an ExportError where an input is missing or
    a held one has another value: the document does not draw that model)."""
    for key, value in OPEN_PBR_SURFACE_HELD[composition].items():
        if inputs.get(key) != value:
            raise ExportError(f"open_pbr_surface's {key} is {inputs.get(key)}, not {value}: not the fitted model")
    missing = [key for key in OPEN_PBR_SURFACE_INPUTS[composition].values() if key not in inputs]
    if missing:
        raise ExportError(f"open_pbr_surface has no {', '.join(missing)}: not the fitted model")
    return {name: inputs[key] for name, key in OPEN_PBR_SURFACE_INPUTS[composition].items()}


def native_honesty(result: "FitResult", path: str | os.PathLike[str], measured: "MeasuredBRDF") -> dict[str, object]:
    """The honesty report of a written open_pbr_surface: the fit's M1 and image error against
    ``measured`` beside those of the model at the values read back from ``path``."""
    from .honesty import compared
    written = parameters_from_inputs(read_open_pbr_surface(path), parse_model(result.spec).composition)
    return {"exported_shader": "open_pbr_surface", **compared(result, (result.spec, written), measured)}


def export_openpbr(result: "FitResult | str | os.PathLike[str]", path: str | os.PathLike[str],
                   measured: "MeasuredBRDF | str | os.PathLike[str] | None" = None,
                   candidates: "list[FitResult] | tuple" = ()) -> dict[str, object]:
    """Write a fit of an OpenPBR model (FitResult or RESULT.json path) as a MaterialX document of
    its open_pbr_surface alone, 1:1, then read it back against the measurement (``measured``, a
    MeasuredBRDF or a path; default the result's provenance).  ``candidates``: the other fits of
    the measurement; the best OpenPBR fit of the other kind among them (other_kind.other_kind) is
    named on the material.  Returns {"model", "kind", "path", "materials", "materialx_inputs",
    "materialx_notes", "honesty", "other_kind"}."""
    from data_loaders.measured import write_file_atomic
    from fitting.result import FitResult, first_non_finite

    from .other_kind import other_kind, other_kind_numbers
    from .honesty import load_measured
    if not isinstance(result, FitResult):
        result = FitResult.load(result)
    path = pathlib.Path(path)
    if path.suffix.lower() != ".mtlx":
        raise ExportError(f"{path}: an OpenPBR material is a MaterialX document: the output must end in .mtlx")
    if not is_openpbr(result.spec):
        raise ExportError(f"{result.spec}: --format openpbr writes a fit of OpenPBR's own models 1:1 "
                          f"({', '.join(OPENPBR_FAMILY)}): `brdf-fit export MEASURED_FILE --format openpbr` fits "
                          "them; --format gltf --out X.mtlx writes this fit's glTF material and an OpenPBR "
                          "approximation")
    bad = first_non_finite(result.parameters)
    if bad is not None:
        raise ExportError(f"{path}: not written: {bad[0]} would be {bad[1]}; a MaterialX value must be finite")
    other = other_kind(result, candidates, is_openpbr)
    doc = native_document(result, result.material or "material", other)
    native = doc["open_pbr_surface"]
    write_file_atomic(path, doc["xml"])
    measured_obj, reason = load_measured(measured, result)
    report = native_honesty(result, path, measured_obj) if measured_obj is not None else {"reason": reason}
    kind = ("metal" if native["base_metalness"] == 1.0 else "non-metal") + (" under its coat" if "coat_weight" in native
                                                                            else "")
    return {"model": result.spec, "kind": f"OpenPBR Surface's {kind}", "path": str(path),
            "materials": doc["materials"], "materialx_inputs": {"open_pbr_surface": native},
            "materialx_notes": doc["notes"], "honesty": report,
            "other_kind": other_kind_numbers(result, other) if other is not None else None}


def native_document(result: "FitResult", name: str, other: "FitResult | None" = None) -> dict[str, object]:
    """brdf.materialx.materialx_document of a fit of an OpenPBR model: its open_pbr_surface alone, 1:1,
    named ``name``, with the fit's provenance; ``other``: the best fit of the other kind
    (other_kind.other_kind), its model and both ranking errors as attributes too."""
    from brdf.materialx import materialx_document
    from brdf.openpbr_coat import open_pbr_surface_inputs

    from .other_kind import other_kind_numbers
    prov = result.provenance or {}
    provenance = {"spec": result.spec, "m1": result.errors.get("m1"), "image": result.errors.get("image"),
                  "source": prov.get("file"), "sha256": prov.get("sha256"), "material": result.material,
                  "toolkit_version": result.toolkit_version}
    if other is not None:
        numbers = other_kind_numbers(result, other)
        provenance.update({"ranking_error": numbers["written_ranking_error"], "other_kind": other.spec,
                           "other_kind_ranking_error": numbers["ranking_error"]})
    native = open_pbr_surface_inputs(result.parameters, parse_model(result.spec).composition)
    return materialx_document({}, name=name, provenance=provenance, native=native, gltf_pbr=False)


def materialx_library(results: "list[FitResult]", others: list | None = None) -> str:
    """One MaterialX document of fits of OpenPBR's models (``brdf-fit library``'s materials.mtlx):
    each fit's open_pbr_surface and material as ``native_document`` writes them (``others``: each
    one's best fit of the other kind or None), the names made unique (a second "a-b" beside "a_b"
    is "a_b_2"), each attribute declared once."""
    from brdf.materialx import valid_name
    root, declared, used = None, set(), set()
    for result, other in zip(results, others or [None] * len(results)):
        name = base = valid_name(result.material or "material")
        count = 1
        while name in used:
            count += 1
            name = f"{base}_{count}"
        used.add(name)
        doc = ET.fromstring(native_document(result, name, other)["xml"])
        if root is None:
            root = ET.Element(doc.tag, doc.attrib)
        for element in doc:
            if element.tag == "attributedef":
                if element.get("name") in declared:
                    continue
                declared.add(element.get("name"))
                root.insert(len(declared) - 1, element)
            else:
                root.append(element)
    ET.indent(root, space="  ")
    return '<?xml version="1.0"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def describe_openpbr(info: dict[str, object], stream: typing.TextIO) -> None:
    """Print what ``export_openpbr`` wrote and the fit's errors beside the written material's."""
    print(f"wrote {info['path']}: {info['model']} ({info['kind']}), open_pbr_surface 1:1", file=stream)
    for note in info["materialx_notes"]["open_pbr_surface"]:
        print(f"  note: {note}", file=stream)
    if info.get("other_kind"):
        from .other_kind import other_kind_line
        metal = info["materialx_inputs"]["open_pbr_surface"]["base_metalness"] == 1.0
        print("  " + other_kind_line(metal, info["other_kind"]), file=stream)
    h = info["honesty"]
    if "reason" in h:
        print(f"errors of the written material not computed: {h['reason']}", file=stream)
        return
    print(f"errors against {h['measured_file']} (theta <= {h['max_theta']:g} deg for M1), the fit and the "
          "material read back from the file:", file=stream)
    for name, fitted, written in (("M1", h["m1_fitted_model"], h["m1_exported_gltf"]),
                                  ("image error", h["image_fitted_model"], h["image_exported_gltf"])):
        print(f"  {name:<11} fitted model {fitted:.6g}, written material {written:.6g}", file=stream)
    if h["sha256_matches"] is False:
        print("  warning: the measured file differs from the one the fit was made on (sha256)", file=stream)
