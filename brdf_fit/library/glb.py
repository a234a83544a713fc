"""The library's ``materials.glb``: every material's exported glTF material on its own sphere, in one file.

Each material is exactly the material ``brdf-fit export RESULT x.glb`` writes for
its result (brdf_fit.export.gltf.exported_material: the same conversion, extras and
honesty report, the measured file taken from the result's provenance), except that
its ``name`` is the library's name for it.  Each sits on its own copy of the
exported sphere (brdf_fit.export.gltf_file.sphere, radius SPHERE_RADIUS), laid out
in a grid read like text: entry i in row i // columns (top first, +y up) and column
i % columns (left first, +x), ``columns = ceil(sqrt(n))``, SPACING apart centre to
centre, the grid's rectangle centred at the origin in the plane z = 0 (a viewer
looks along -z, as the preview camera does).

Labels: node name = mesh name = material name = the entry's name; each node's
``extras.brdf_fit`` holds the name, the fitted model, the exported glTF model, its
grid cell and, when known, the exported material's M1 and image error
(``exported_m1``, ``exported_image`` as FitResult.errors names them).

Sharing: a glTF primitive names its material, so there is one mesh per material,
but every mesh's primitive uses the same accessors: the sphere's buffer is stored
once whatever the number of materials (KHR_materials_anisotropy's tangents are part
of it).  ``extensionsUsed`` is the union of the materials' extensions in order of
first use.  Names must be unique (a duplicate is an ExportError, not a silent
suffix: the names are how a user finds a material in the file, and the library's
materials are unique by construction).  Written atomically, finite numbers only
(brdf_fit.export.gltf_file.write_gltf_file).
"""

import json
import math
import os
import pathlib
import struct
from collections.abc import Mapping, Sequence

from brdf_fit.export.gltf import exported_material
from brdf_fit.export.gltf_file import ExportError, asset, mesh_buffers, sphere, with_material, write_gltf_file
from fitting.result import FitResult

SPHERE_RADIUS = 1.0          # radius of the exported sphere (shaders.mesh.uv_sphere's default)
SPACING = 2.5                # centre-to-centre distance of neighbouring spheres: a gap of half a radius
GENERATOR = "brdf_fit.library.glb"


def grid_columns(n: int) -> int:
    """Columns of the grid of ``n`` spheres: ceil(sqrt(n)), so the grid is about square."""
    return max(1, math.ceil(math.sqrt(n)))


def grid_positions(n: int) -> list[tuple[int, int, list[float]]]:
    """(row, column, [x, y, z] centre) of each of ``n`` spheres, in entry order (see the module doc)."""
    columns = grid_columns(n)
    rows = math.ceil(n / columns)
    out = []
    for i in range(n):
        row, column = divmod(i, columns)
        x = (column - (columns - 1) / 2.0) * SPACING
        y = ((rows - 1) / 2.0 - row) * SPACING
        out.append((row, column, [float(x), float(y), 0.0]))
    return out


def _check(entries: Sequence[tuple[str, FitResult]], path: pathlib.Path) -> None:
    if path.suffix.lower() != ".glb":
        raise ExportError(f"{path}: the library's file of all materials must end in .glb")
    if not entries:
        raise ExportError(f"{path}: not written: no materials to write")
    seen = set()
    for name, result in entries:
        if not isinstance(name, str) or not name:
            raise ExportError(f"{path}: not written: a material name must be a non-empty string, not {name!r}")
        if name in seen:
            raise ExportError(f"{path}: not written: the material name {name!r} is given twice "
                              "(names label the nodes and materials, so they must be unique)")
        if not isinstance(result, FitResult):
            raise ExportError(f"{path}: not written: {name!r} has a {type(result).__name__}, not a FitResult")
        seen.add(name)


def exported_errors(result: FitResult, conversion: dict, report: dict) -> dict[str, float]:
    """{"exported_m1", "exported_image"} of the written material, where known: recorded by
    the fit (export-first), else measured by the export's honesty check, else -- for a
    lossless conversion, where the material is the fit -- the fit's own "m1" / "image"."""
    e = result.errors or {}
    sources = (("exported_m1", "m1_exported_gltf", "m1"), ("exported_image", "image_exported_gltf", "image"))
    out = {}
    for key, honest, own in sources:
        value = e.get(key)
        if value is None:
            value = report.get(honest)
        if value is None and conversion["lossless"]:
            value = e.get(own)
        if value is not None:
            out[key] = float(value)
    return out


def read_exported(result: FitResult, glb: str | os.PathLike[str]) -> tuple[dict, list[str], dict, dict] | None:
    """(material JSON, its extensions, {"model", "lossless"}, honesty report) of the material
    ``brdf-fit export`` wrote for ``result`` into the .glb file ``glb`` (its first material),
    or None where that file is missing, unreadable or of another fit."""
    try:
        data = pathlib.Path(glb).read_bytes()
        length = struct.unpack_from("<I", data, 12)[0]
        doc = json.loads(data[20:20 + length])
        material = doc["materials"][0]
        extras = material["extras"]["brdf_fit"]
        if extras["spec"] != result.spec or extras["parameters"] != json.loads(json.dumps(result.parameters)):
            return None
        conversion = {"model": extras["gltf_model"], "lossless": extras["conversion"]["lossless"]}
        return material, list(doc.get("extensionsUsed", [])), conversion, extras["honesty"]
    except (OSError, ValueError, KeyError, IndexError, TypeError, struct.error):
        return None


def write_materials_glb(entries: Sequence[tuple[str, FitResult]], path: str | os.PathLike[str],
                        exported: Mapping[str, str | os.PathLike[str]] | None = None) -> pathlib.Path:
    """Write ``entries`` [(material name, FitResult to export)] as one binary glTF file at
    ``path`` (.glb): each exported material on its own sphere, in a labelled grid
    centred at the origin (module doc).  ``exported``: {name: the .glb ``brdf-fit export``
    wrote for that entry's result}, whose material is taken as it is (``read_exported``:
    no second honesty check) where it is that result's.  Returns the path; ExportError
    (a ValueError) for an empty list, a duplicate or empty name, a non-FitResult, another
    suffix or a non-finite number, and then nothing is written."""
    path = pathlib.Path(path)
    entries = list(entries)
    _check(entries, path)
    primitive, accessors, views, binary = mesh_buffers(sphere())
    nodes, meshes, materials, used = [], [], [], []
    for i, ((name, result), (row, column, centre)) in enumerate(zip(entries, grid_positions(len(entries)))):
        known = read_exported(result, exported[name]) if exported and name in exported else None
        material, extensions, conversion, report = known or exported_material(result)
        materials.append({**material, "name": name})
        used += [e for e in extensions if e not in used]
        meshes.append({"name": name, "primitives": [with_material(primitive, i)]})
        label = {"material": name, "model": result.spec, "exported_model": conversion["model"],
                 "row": row, "column": column, **exported_errors(result, conversion, report)}
        nodes.append({"name": name, "mesh": i, "translation": centre, "extras": {"brdf_fit": label}})
    doc = {
        "asset": asset(GENERATOR),
        "scene": 0,
        "scenes": [{"name": "materials", "nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(binary)}],
    }
    if used:
        doc["extensionsUsed"] = used
    return write_gltf_file(path, doc, binary)
