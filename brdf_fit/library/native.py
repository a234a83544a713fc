"""The library's materials in OpenPBR's and Blender's own terms (issue 61).

Where a library's fits include OpenPBR's own models (``brdf-fit library DIR --models
auto,openpbr,principled``: fitted fully beside ``auto``'s), each material's best of them (by its own ranking
error, fitting.ranking: the material is the fitted BRDF itself) is written beside materials.glb:

- ``materials.mtlx``: one MaterialX document, each material's open_pbr_surface 1:1
  (brdf_fit.export.openpbr_first.materialx_library), the best of its fits read as MaterialX draws
  them (the ``openpbr`` set, ``+mx``; where the library has none, of any OpenPBR fit);
- ``materials.blend``: one Blender file, each material a Principled BSDF marked as an asset
  (brdf_fit.export.blender_file), the best of its fits a Principled BSDF draws as fitted (the
  ``principled`` set), when a Python with bpy is found; else ``materials_blender.py``, the script
  that writes it (``blender --background --python materials_blender.py -- OUT.blend``).

A library without such fits has neither (files of an earlier run are removed: the library's
folder says what its fits are).
"""

import pathlib
import typing

NATIVE_FILES = ("materials.mtlx", "materials.blend", "materials_blender.py")

if typing.TYPE_CHECKING:
    from fitting.result import FitResult


def best_of(by_material: "dict[str, list[FitResult]]", keep: "typing.Callable[[str], bool]"
            ) -> "tuple[list[FitResult], list[FitResult | None]]":
    """Each material's best fit (fitting.ranking.ranked) among those whose model ``keep`` takes, in
    the materials' order, and beside each the best of them of the other kind (a metal where it is
    a non-metal, or the reverse: brdf_fit.export.other_kind; None where there is none),
    which the written files name: why a material is the kind it is, in numbers."""
    from brdf_fit.export.other_kind import other_kind
    from fitting.ranking import ranked
    best, others = [], []
    for results in by_material.values():
        kept = [r for r in results if keep(r.spec)]
        if kept:
            best.append(ranked(kept)[0])
            others.append(other_kind(best[-1], kept, keep))
    return best, others


def write_native(by_material: "dict[str, list[FitResult]]", out_dir: pathlib.Path,
                 log: typing.Callable[[str], object]) -> list[tuple[str, str]]:
    """Write materials.mtlx and the Blender file (module docstring); the gallery's links to them."""
    from brdf_fit.export.blender_file import blender_python, drawn_by_principled, write_blender
    from brdf_fit.export.gltf_file import ExportError
    from brdf_fit.export.openpbr_first import drawn_by_materialx, is_openpbr, materialx_library
    from data_loaders.measured import write_file_atomic
    for name in NATIVE_FILES:
        (out_dir / name).unlink(missing_ok=True)
    links = []
    # the fits read as MaterialX draws them (+mx) where the library has any, else any OpenPBR fit
    mx = any(drawn_by_materialx(r.spec) for results in by_material.values() for r in results)
    best, others = best_of(by_material, drawn_by_materialx if mx else is_openpbr)
    if best:
        write_file_atomic(out_dir / "materials.mtlx", materialx_library(best, others))
        links.append(("materials.mtlx", f"OpenPBR materials (.mtlx, {len(best)})"))
    bare, others = best_of(by_material, drawn_by_principled)
    if not bare:
        return links
    blend = out_dir / ("materials.blend" if blender_python() else "materials_blender.py")
    try:
        write_blender(bare, blend, others)
    except ExportError as err:          # Blender found but failing: the rest of the library stands
        log(f"library: {err}")
        return links
    return links + [(blend.name, f"Blender materials ({'.blend' if blend.suffix == '.blend' else 'script'}, "
                                 f"{len(bare)})")]
