"""One material of a library: its thumbnails, glTF / MaterialX files and page, from its results.

``write_material`` is the library's per-material work (brdf_fit.library.build runs it
in this process or in ``jobs`` worker processes).  It loads the measured table once
and hands it to everything that needs it (the thumbnails, the exports' honesty
check), and keeps nothing afterwards.  The exports' honesty check costs nothing
when the shipped fit was made on this very file (same sha256) and recorded its
exported material's errors (every fit since the export-first round does): those
numbers are the check's (``brdf_fit.export.honesty.recorded_honesty``); otherwise
the check evaluates both models against the table, as ``brdf-fit export`` does.
"""

import os
import pathlib

from fitting.result import FitResult, atomic_write_text

from .material_page import material_page

Rows = list[tuple[pathlib.Path, FitResult]]


def library_files(slug: str) -> dict[str, str]:
    """A material's files, relative to the library's folder."""
    return {"page": f"materials/{slug}.html", "measured": f"thumbs/{slug}-measured.png",
            "fitted": f"thumbs/{slug}-fitted.png", "glb": f"gltf/{slug}.glb", "mtlx": f"gltf/{slug}.mtlx"}


def write_material(material: str, rows: Rows, shipped: FitResult, out_dir: str | os.PathLike[str],
                   command_line: str = "") -> str | None:
    """Write ``material``'s thumbnails, .glb, .mtlx and page into the library ``out_dir``
    (``rows`` best first, ``shipped`` the fit exported); returns a note on the
    measured table (absent, unreadable) or None."""
    from brdf_fit.export.gltf import export_gltf
    from brdf_fit.report.html import slug as make_slug
    from brdf_fit.report.pages import _measured_for
    from .thumbnails import write_pair
    out_dir = pathlib.Path(out_dir)
    slug = make_slug(material)
    files = library_files(slug)
    measured, note = _measured_for(rows, None)
    if measured is not None:
        write_pair(measured, rows[0][1], out_dir / "thumbs", slug)
    recorded = _recorded(shipped, measured)
    export_gltf(shipped, out_dir / files["glb"], measured=measured, just_fitted=recorded)
    export_gltf(shipped, out_dir / files["mtlx"], measured=measured, just_fitted=recorded)
    shown = {k: v for k, v in files.items() if (out_dir / v).is_file()}
    viewer = _viewer(material, shipped, out_dir, files["glb"])
    atomic_write_text(out_dir / files["page"], material_page(
        material, rows, shipped, shown, viewer, [note] if note else [], _measured_line(measured, rows),
        command_line))
    return note


def _recorded(result, measured):
    """Whether ``result`` was fitted to ``measured`` (same sha256) and recorded its exported
    material's errors: then those are the honesty check's numbers."""
    sha = (result.provenance or {}).get("sha256")
    return (measured is not None and "exported_m1" in result.errors and bool(sha)
            and sha == measured.provenance.sha256)


def _viewer(material, shipped, out_dir, glb):
    """The three.js viewer of the shipped .glb (the library's own file), or a line saying why not."""
    import html

    from brdf_fit.export.gltf import convert
    from brdf_fit.report.web_viewer import ViewerUnavailable, viewer_section, write_viewer_files
    pages = out_dir / "materials"
    try:
        write_viewer_files(pages)
    except ViewerUnavailable as err:
        return f'<p class="note">3D viewer not shown: {html.escape(str(err))}.</p>'
    conversion = convert(shipped)
    model = {"spec": shipped.spec, "gltf_model": conversion["model"], "kind": conversion["kind"],
             "file": f"../{glb}"}
    return viewer_section(material, [model], pages, "")


def _measured_line(measured, rows):
    if measured is None:
        return "measured: " + ", ".join(sorted({str((r.provenance or {}).get("file")) for _, r in rows}))
    p = measured.provenance
    return f"measured: {p.path} ({p.format}, {measured.n_valid:,} valid samples, sha256 {p.sha256[:16]}...)"
