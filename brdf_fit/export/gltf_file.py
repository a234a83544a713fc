"""glTF 2.0 files: a material on a mesh, as ``.gltf`` (embedded buffer) or ``.glb``.

The mesh is shaders.mesh's UV sphere, the renderer's own (glTF conventions:
+y up, counter-clockwise front faces, tangents along +u with w = +1); the
material JSON comes from brdf.gltf_material.  Files are written atomically
and hold finite numbers only.
"""

import base64
import json
import os
import pathlib
import struct

import numpy as np

from brdf import __version__
from shaders.mesh import Mesh, uv_sphere

from fitting.result import first_non_finite

SPHERE_SEGMENTS = (32, 64)     # latitude rings, longitude segments of the exported sphere

FLOAT, USHORT, UINT = 5126, 5123, 5125          # accessor component types
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
TRIANGLES = 4


class ExportError(ValueError):
    """An export that cannot be done (bad path suffix, unusable result)."""


def sphere() -> Mesh:
    """The exported sphere (shaders.mesh.uv_sphere at SPHERE_SEGMENTS)."""
    return uv_sphere(rings=SPHERE_SEGMENTS[0], segments=SPHERE_SEGMENTS[1])


def mesh_arrays(mesh: Mesh) -> tuple[np.ndarray, ...]:
    """(positions, normals, tangents (vec4, w = +1), texcoords, indices) of a
    shaders.mesh.Mesh as glTF stores them: float32, indices flat and 16-bit
    when they fit."""
    tangents = np.concatenate([mesh.tangents, np.ones((len(mesh.tangents), 1), np.float32)], axis=1)
    index_type = np.uint16 if len(mesh.positions) <= np.iinfo(np.uint16).max else np.uint32
    return (mesh.positions.astype(np.float32), mesh.normals.astype(np.float32), tangents.astype(np.float32),
            mesh.texcoords.astype(np.float32), mesh.indices.ravel().astype(index_type))


def _pad4(data, fill=b"\0"):
    return data + fill * (-len(data) % 4)


def mesh_buffers(mesh: Mesh | None = None) -> tuple[dict, list[dict], list[dict], bytes]:
    """(primitive, accessors, bufferViews, buffer bytes) of a mesh (default: the sphere) in
    buffer 0; the primitive (attributes, indices, mode) names no material yet, so several
    meshes can share one set of accessors (brdf_fit.library.glb)."""
    pos, normal, tangent, uv, indices = mesh_arrays(mesh or sphere())
    blobs, views, accessors = [], [], []
    offset = 0

    def add(array, gl_type, component, target, minmax=False):
        nonlocal offset
        data = _pad4(array.tobytes())
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": array.nbytes, "target": target})
        acc = {"bufferView": len(views) - 1, "componentType": component,
               "count": int(array.shape[0]), "type": gl_type}
        if minmax:
            acc["min"] = [float(x) for x in array.min(axis=0)]
            acc["max"] = [float(x) for x in array.max(axis=0)]
        accessors.append(acc)
        blobs.append(data)
        offset += len(data)
        return len(accessors) - 1

    attributes = {
        "POSITION": add(pos, "VEC3", FLOAT, ARRAY_BUFFER, minmax=True),
        "NORMAL": add(normal, "VEC3", FLOAT, ARRAY_BUFFER),
        "TANGENT": add(tangent, "VEC4", FLOAT, ARRAY_BUFFER),
        "TEXCOORD_0": add(uv, "VEC2", FLOAT, ARRAY_BUFFER),
    }
    index_accessor = add(indices, "SCALAR", USHORT if indices.dtype == np.uint16 else UINT,
                         ELEMENT_ARRAY_BUFFER)
    primitive = {"attributes": attributes, "indices": index_accessor, "mode": TRIANGLES}
    return primitive, accessors, views, b"".join(blobs)


def with_material(primitive: dict, material: int) -> dict:
    """A copy of a mesh_buffers primitive drawn with material number ``material``."""
    return {"attributes": dict(primitive["attributes"]), "indices": primitive["indices"],
            "material": material, "mode": primitive["mode"]}


def asset(module: str) -> dict:
    """The glTF ``asset`` object naming this toolkit's version and the writing module."""
    return {"version": "2.0", "generator": f"brdf-fit {__version__} ({module})"}


def gltf_document(material: dict, extensions_used: list[str], mesh: Mesh | None = None) -> tuple[dict, bytes]:
    """(glTF JSON dict, binary buffer bytes) of a mesh (default: the sphere) carrying ``material``."""
    primitive, accessors, views, binary = mesh_buffers(mesh)
    doc = {
        "asset": asset("brdf_fit.export.gltf"),
        "scene": 0,
        "scenes": [{"name": "scene", "nodes": [0]}],
        "nodes": [{"name": "sphere", "mesh": 0}],
        "meshes": [{"name": "sphere", "primitives": [with_material(primitive, 0)]}],
        "materials": [material],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(binary)}],
    }
    if extensions_used:
        doc["extensionsUsed"] = list(extensions_used)
    return doc, binary


def write_gltf_file(path: str | os.PathLike[str], doc: dict, binary: bytes) -> pathlib.Path:
    """Write ``.gltf`` (buffer as a base64 data URI) or ``.glb`` atomically."""
    from data_loaders.measured import write_file_atomic
    path = pathlib.Path(path)
    suffix = path.suffix.lower()
    bad = first_non_finite(doc)
    if bad is not None:        # glTF (JSON) has no NaN / Infinity: refuse, write nothing
        where, value = bad
        shown = "NaN" if value != value else ("Infinity" if value > 0 else "-Infinity")
        raise ExportError(f"{path}: not written: {where} would be {shown}; a glTF file holds "
                          "finite numbers only")
    doc = json.loads(json.dumps(doc, allow_nan=False))
    if suffix == ".gltf":
        doc["buffers"][0]["uri"] = ("data:application/octet-stream;base64,"
                                    + base64.b64encode(binary).decode("ascii"))
        data = (json.dumps(doc, indent=1, allow_nan=False) + "\n").encode("utf-8")
    elif suffix == ".glb":
        js = _pad4(json.dumps(doc, separators=(",", ":"), allow_nan=False).encode("utf-8"), b" ")
        bin_chunk = _pad4(binary)
        total = 12 + 8 + len(js) + 8 + len(bin_chunk)
        data = (struct.pack("<4sII", b"glTF", 2, total)
                + struct.pack("<I4s", len(js), b"JSON") + js
                + struct.pack("<I4s", len(bin_chunk), b"BIN\0") + bin_chunk)
    else:
        raise ExportError(f"{path}: the output must end in .gltf or .glb")
    path.parent.mkdir(parents=True, exist_ok=True)
    write_file_atomic(path, data)
    return path
