"""One material of a library: its thumbnails, glTF / MaterialX files and page, from its results.

``write_material`` is the library's per-material work (brdf_fit.library.build runs it
in this process or in ``jobs`` worker processes).  It reads the measured file once
and hands it to everything that needs it (the thumbnails, the exports' honesty
check), and keeps nothing afterwards.  The exports' honesty check costs nothing
when the shipped fit was made on this very file (same sha256) and recorded its
exported material's errors (every fit since the export-first round does): those
numbers are the check's (``brdf_fit.export.honesty.recorded_honesty``); otherwise
the check evaluates both models against the table, as ``brdf-fit export`` does.

A MERL file is read for lookups only (``data_loaders.merl.read_merl_table``: read,
hashed and checked as ``load`` does, its cells converted only where the thumbnails
look them up), since the thumbnails and the recorded check need nothing else: a
tenth of a second instead of ``load``'s conversion of 1.4 million samples and its
plausibility pass (which the fit's own ``load`` made).  The whole table is loaded
only where the honesty check must evaluate against it.
"""

import os
import pathlib

from fitting.result import FitResult, atomic_write_text

from .material_page import material_page

Rows = list[tuple[pathlib.Path, FitResult]]


def library_files(slug: str) -> dict[str, str]:
    """A material's files, relative to the library's folder (``slug``: brdf_fit.library.identity.material_stem)."""
    return {"page": f"materials/{slug}.html", "measured": f"thumbs/{slug}-measured.png",
            "fitted": f"thumbs/{slug}-fitted.png", "shipped": f"thumbs/{slug}-shipped.png",
            "glb": f"gltf/{slug}.glb", "mtlx": f"gltf/{slug}.mtlx"}


def write_material(material: str, rows: Rows, shipped: FitResult, out_dir: str | os.PathLike[str],
                   command_line: str = "", model_files: dict | None = None) -> str | None:
    """Write ``material``'s thumbnails, .glb, .mtlx and page into the library ``out_dir``
    (``rows`` best first, ``shipped`` the fit exported; ``model_files`` {sha256: NAME.py} of
    the own models' files the library copied into models/); returns a note on the
    measured table (absent, unreadable) or None."""
    from brdf_fit.export.export_first import shipped as shipped_summary
    from brdf_fit.export.gltf import export_gltf
    from brdf_fit.report.identity import material_stem
    from .thumbnails import measured_sphere, write_pair, write_shipped
    out_dir = pathlib.Path(out_dir)
    stem = material_stem(r for _, r in rows)
    files = library_files(stem)
    measured, n_valid, note = _measured_for(rows)
    exposure = 1.0
    if measured is not None:
        sphere = measured_sphere(measured)      # the table's side of both pictures, looked up once
        exposure = write_pair(measured, rows[0][1], out_dir / "thumbs", stem, target=sphere)
        write_shipped(measured, shipped, out_dir / "thumbs", stem, target=sphere)
    recorded = _recorded(shipped, measured)
    if measured is not None and not recorded and len(measured) == 0:    # a table for lookups only
        from data_loaders import load
        measured = load(measured.provenance.path)
    export_gltf(shipped, out_dir / files["glb"], measured=measured, just_fitted=recorded)
    export_gltf(shipped, out_dir / files["mtlx"], measured=measured, just_fitted=recorded)
    shown = {k: v for k, v in files.items() if (out_dir / v).is_file()}
    viewer = _viewer(material, shipped, out_dir, files["glb"], stem, exposure)
    atomic_write_text(out_dir / files["page"], material_page(
        material, rows, shipped, shown, viewer, [note] if note else [], _measured_line(measured, n_valid, rows),
        command_line, shipped_summary([r for _, r in rows]).sentences(), _copies(rows, model_files or {})))
    return note


def _copies(rows, model_files):
    """The library's copies (models/NAME.py) of the model files ``rows``' results were fitted
    with, found by the sha256 they record: the name a result holds is data, never a path to give."""
    return sorted({model_files[r.model_file["sha256"]] for _, r in rows
                   if r.model_file and r.model_file["sha256"] in model_files})


def _measured_for(rows):
    """(the measured file of the fits or None, its number of valid samples, a note or None):
    brdf_fit.report.pages' choice of file and notes, a MERL file read for lookups only."""
    from brdf_fit.errors import is_file_here, shorten_path
    from data_loaders import MeasuredDataError
    for _, r in rows:
        path = (r.provenance or {}).get("file")
        if path and is_file_here(path):
            try:
                return (*_read(path), None)
            except MeasuredDataError as err:
                return None, 0, f"the provenance file could not be read: {err}"
    files = sorted({shorten_path((r.provenance or {}).get("file")) for _, r in rows})
    return None, 0, ("the measured file of the fits (" + ", ".join(files) + ") is not here; "
                     "pass --measured FILE for the measured curves and errors")


def _read(path):
    """(MeasuredBRDF, valid samples): a MERL file for lookups only, any other loaded."""
    from data_loaders import detect_format, load
    from data_loaders.merl import read_merl_table
    if detect_format(path) == "merl":
        return read_merl_table(path)
    measured = load(path)
    return measured, measured.n_valid


def _recorded(result, measured):
    """Whether ``result`` was fitted to ``measured`` (same sha256) and recorded its exported
    material's errors: then those are the honesty check's numbers."""
    sha = (result.provenance or {}).get("sha256")
    return (measured is not None and "exported_m1" in result.errors and bool(sha)
            and sha == measured.provenance.sha256)


def _viewer(material, shipped, out_dir, glb, stem, exposure):
    """The three.js viewer of the shipped .glb (the library's own file), or a line saying why not;
    at the gallery's exposure of the material (the two scenes' exposures are close: docs/colour.md)."""
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
    return viewer_section(material, [model], pages, "", stem=stem, exposure=exposure)


def _measured_line(measured, n_valid, rows):
    if measured is None:
        return "measured: " + ", ".join(sorted({str((r.provenance or {}).get("file")) for _, r in rows}))
    p = measured.provenance
    return f"measured: {p.path} ({p.format}, {n_valid:,} valid samples, sha256 {p.sha256[:16]}...)"
