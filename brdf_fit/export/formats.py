"""``brdf-fit export --format``: what each format writes, its file names and its writer.

gltf      the glTF family's material (brdf_fit.export.gltf; .mtlx: as MaterialX's gltf_pbr
          and an OpenPBR approximation)
openpbr   OpenPBR's own models, the best as one open_pbr_surface, 1:1 (openpbr_first)
blender   the same fit as a Principled BSDF: a .blend, or the script that writes one (blender_file)
"""

import typing

FORMATS = {"gltf": (".gltf", ".glb", ".mtlx"), "openpbr": (".mtlx",), "blender": (".blend", ".py")}


def default_out(fmt: str) -> str:
    """``--out``'s default: material.gltf, material.mtlx, and for Blender material.blend where a
    Python with bpy is found (blender_file.blender_python), else the script, material.py."""
    if fmt == "blender":
        from .blender_file import blender_python
        return "material.blend" if blender_python() else "material.py"
    return {"gltf": "material.gltf", "openpbr": "material.mtlx"}[fmt]


def writer(fmt: str) -> tuple[typing.Callable[..., dict], typing.Callable[..., None]]:
    """(write(result, path, measured=...) -> info, describe(info, stream)) of a format; the native
    formats' write also takes ``candidates=`` (the other fits: the best of the other kind is named)."""
    if fmt == "blender":
        from .blender_file import describe_blender, export_blender
        return export_blender, describe_blender
    if fmt == "openpbr":
        from .openpbr_first import describe_openpbr, export_openpbr
        return export_openpbr, describe_openpbr
    from .gltf import describe_export, export_gltf
    return export_gltf, describe_export
