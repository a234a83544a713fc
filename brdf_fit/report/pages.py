"""HTML reports of fit results (``brdf-fit report RESULT.json [...] --out DIR``).

For every material among the results (result files, or folders of them) the
report writes ``DIR/<material>.html`` and its PNG figures next to it:

- the table of models and errors (M1 per channel, the loss, the optimizer),
  with the M1 of the glTF material each fit exports to (``brdf_fit.export.gltf``'s
  honest re-evaluation) when the measurement is available;
- in-plane lobes, theta_h slices, half/difference error images and the
  directional albedo (``brdf_fit.report.plots``), an M1 bar chart;
- lit spheres measured | fitted | difference from the preview renderer
  (``shaders.render.render_comparison``) when it can run here -- otherwise the
  page says why;
- every fit's exported .glb in a three.js viewer beside the measured sphere
  (``brdf_fit.report.web_viewer``; without node_modules/three one line says why);
- the fitted parameters, the provenance, and the exact command that produced it.

``DIR/index.html`` is the batch overview: M1 of every model on every material
(table and bar chart) with links to the material pages.  Pages reference the
PNGs by relative path, so DIR is self-contained: copy or serve it as a whole.
"""

import contextlib
import errno
import html
import os
import pathlib
import shutil
import sys
import typing
from collections.abc import Callable, Iterable


from brdf_fit.errors import BAD_INPUT  # noqa: F401  (the exit codes' one home)
from brdf.own import OwnModelError, is_own
from brdf_fit.batch.memory import give_back_memory
from brdf_fit.errors import OK, fail, is_file_here, os_error_message, shorten_path, warn
from fitting.result import FitResult, NotAResultError, ResultFileError, atomic_write_text

from .html import index_page, material_page, slug
from .identity import material_groups, report_stems

if typing.TYPE_CHECKING:
    from data_loaders import MeasuredBRDF

RENDER_MODELS = 3        # lit spheres and 3D viewer (exported .glb) for the best few models
IMAGE_MODELS = 4         # half/difference error images for the best few models
RENDER_SIZE = 192

# Errors of a write that the disk refused: these end the report (one line naming the file,
# exit 2) where any other failure of a figure, a render or the viewer only leaves a note.
DISK_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EFBIG, errno.EIO})


def _disk_refused(err):
    """Whether ``err`` is a write the disk refused (a full disk, a read-only one, ...)."""
    return isinstance(err, OSError) and err.errno in DISK_ERRNOS


class ReportError(ValueError):
    """Bad input to a report (named file and problem)."""


# --- inputs ---------------------------------------------------------------------

def collect_results(items: Iterable[str | os.PathLike[str]],
                    command: str = "report") -> list[tuple[pathlib.Path, FitResult]]:
    """Result files and folders -> [(path, FitResult)].

    A file named on the command line must be a valid fit result
    (``FitResult.load``'s ResultFileError propagates); in a folder, JSON
    files that are not fit results at all are skipped silently (a batch
    folder holds summary files too), and broken fit results (NaN, values out
    of bounds, ...) are skipped with a warning on stderr, labelled ``brdf-fit COMMAND``.  Raises
    ReportError when nothing is left.
    """
    found = []
    for item in items:
        p = pathlib.Path(item)
        if p.is_dir():
            for q in sorted(p.glob("*.json")):
                try:
                    found.append((q, FitResult.load(q)))
                except NotAResultError:
                    continue
                except ResultFileError as err:
                    warn(command, f"{err} (skipped)")
        elif p.exists():
            found.append((p, FitResult.load(p)))      # ResultFileError propagates
        else:
            raise ReportError(f"{p}: no such file or folder")
    if not found:
        raise ReportError("no fit results found in " + ", ".join(str(i) for i in items))
    return found


def group_by_material(found: list[tuple[pathlib.Path, FitResult]]) -> dict[str, list[tuple[pathlib.Path, FitResult]]]:
    """{material: [(path, FitResult)] best first (fitting.ranking: M1 + 0.3 x image error)},
    materials in first-seen order.  A material is a measurement (its input's sha256), its
    name told apart from another measurement's of the same name (brdf_fit.report.identity)."""
    return material_groups(found)


def _slug(text):
    return slug(text)


# --- measured data ------------------------------------------------------------------

def _measured_for(results, explicit):
    """(MeasuredBRDF or None, note) for one material's results."""
    from data_loaders import MeasuredDataError, load
    if explicit is not None:
        return explicit, None
    for _, r in results:
        path = (r.provenance or {}).get("file")
        if path and is_file_here(path):
            try:
                return load(path), None
            except MeasuredDataError as err:
                return None, f"the provenance file could not be read: {err}"
    files = sorted({shorten_path((r.provenance or {}).get("file")) for _, r in results})
    return None, ("the measured file of the fits (" + ", ".join(files) + ") is not here; "
                  "pass --measured FILE for the measured curves and errors")


def _sha_note(results, measured):
    shas = {(r.provenance or {}).get("sha256") for _, r in results} - {None, ""}
    if measured is not None and shas and measured.provenance.sha256 not in shas:
        return ("the measured file differs from the one these fits were made on (sha256); "
                "curves and errors below compare against the file given")
    return None


# --- figures and renders ---------------------------------------------------------------

def _figures(material, rows, measured, out_dir, notes, slug):
    """Write the PNGs of one material (named ``slug``-KIND.png); [(file name, title, caption)]."""
    from . import plots
    results = [r for _, r in rows]
    todo = [
        ("lobes", "In-plane lobes", lambda: plots.polar_lobes(measured, results),
         "BRDF luminance in the plane of incidence for five incidence angles (radius: log scale, "
         "1/sr; the light comes from the dotted direction). Black: the measurement."),
        ("slices", "Slices over theta_h", lambda: plots.theta_h_slices(measured, results),
         "BRDF Explorer's view: luminance against the half-vector angle theta_h at fixed "
         "difference angles theta_d (phi_d = 90 deg). Small theta_d is the retro-reflection "
         "direction; the right end is grazing."),
        ("halfdiff", "Half/difference images",
         lambda: plots.half_diff_images(measured, results[:IMAGE_MODELS]),
         "log10 of the BRDF over (theta_h, theta_d) at phi_d = 90 deg, and the log error "
         "log10(fitted / measured): red = the model is too bright, blue = too dark"
         + (f" (best {IMAGE_MODELS} models)." if len(results) > IMAGE_MODELS else ".")),
        ("albedo", "Directional albedo", lambda: plots.directional_albedo(measured, results),
         "Fraction of light reflected for each view angle (integral of BRDF x cos theta_i over "
         "the light hemisphere), per channel."),
        ("errors", "Fit error per model",
         lambda: plots.error_bars(results, title=f"{plots.short_label(material)}: M1 per model"),
         "M1 (Loew et al.'s log-compressed, cosine-weighted RMS error, the fit's own metric; "
         "docs/metrics.md) on every valid sample with theta <= the fit's max_theta."),
    ]
    out = []
    for key, title, make, caption in todo:
        name = f"{slug}-{key}.png"
        try:
            plots.save(make(), out_dir / name)
            out.append((name, title, caption))
        except Exception as err:       # a plot must never sink the report; a full disk must
            if _disk_refused(err):
                raise
            notes.append(f"{title} not drawn: {type(err).__name__}: {err}")
    return out


def _renders(material, rows, measured, out_dir, slug, broken=None):
    """Lit-sphere comparisons for the best models: ([(file, model, stats)], note).  A model of
    one's own that is not drawn (no glsl=, or one that does not compile: its OwnModelError
    appended to ``broken``) leaves the other models' spheres drawn and a note."""
    if measured is None:
        return [], "lit spheres need the measured data"
    try:
        from shaders.render import render_comparison, save_png
        from brdf_fit.render import DISPLAY_TONEMAP, viewer_exposure
    except ImportError as err:
        return [], f"the preview renderer is not available ({err})"
    except Exception as err:           # e.g. a GL library that fails to load
        return [], f"the preview renderer could not be loaded ({type(err).__name__}: {err})"
    out, own_notes = [], []
    for _, r in rows[:RENDER_MODELS]:
        if is_own(r.spec) and r.model.own.glsl is None:     # brdf/own.py: drawn through its glsl= only
            own_notes.append(f"{r.spec} is a model of your own: the preview renderer does not draw it")
            continue
        name = f"{slug}-render-{_slug(r.spec)}.png"
        try:
            img, data = render_comparison(r.spec, r.parameters, measured, size=RENDER_SIZE, return_data=True,
                                          labels=True, tonemap=DISPLAY_TONEMAP, exposure=viewer_exposure)
            save_png(out_dir / name, img)
            out.append((name, r.spec, data))
        except OwnModelError as err:    # its glsl= does not compile: that model only
            own_notes.append(str(err))
            if broken is not None:
                broken.append(err)
        except Exception as err:        # no GL driver, renderer still in progress, ...
            if _disk_refused(err):
                raise
            return out, f"the preview renderer could not run here ({type(err).__name__}: {err})"
    return out, "; ".join(own_notes) or None


def _gltf_errors(rows, measured):
    """{spec: (M1, image error of the exported glTF material, its model string, kind)}:
    from the results (fits record them) or, for older results, computed from the data."""
    from brdf.gltf_material import engines_reading
    from brdf_fit.export.gltf import convert
    from fitting.material_errors import image_errors, m1_errors
    rows = [row for row in rows if not is_own(row[1].spec)]     # no glTF material (brdf/own.py)
    convs = [engines_reading(convert(r)) for _, r in rows]      # a converted material as the engines draw it
    if all("exported_m1" in r.errors for _, r in rows):
        return {r.spec: (r.errors["exported_m1"], r.errors.get("exported_image"), c["model"], c["kind"])
                for (_, r), c in zip(rows, convs)}
    if measured is None:
        return {}
    max_theta = float((rows[0][1].optimizer or {}).get("max_theta", 80.0))
    models = [(c["model"], c["parameters"]) for c in convs]
    m1s, images = m1_errors(measured, models, max_theta), image_errors(measured, models)
    return {r.spec: (e[0], i, c["model"], c["kind"]) for (_, r), c, e, i in zip(rows, convs, m1s, images)}


def _lossy_exports(rows, gltf):
    """A note naming each fit whose glTF material draws its picture worse than the shipped
    rule lets a material lose (``fitting.ranking.SHIPPED_IMAGE_BAND``), and what to run
    instead: export-first fits the glTF family to the table itself.  None when none does."""
    from fitting.ranking import SHIPPED_IMAGE_BAND
    lossy = []
    for _, r in rows:
        exported, fitted = gltf.get(r.spec, (None, None))[1], r.errors.get("image")
        if exported is not None and fitted and exported > SHIPPED_IMAGE_BAND * fitted:
            lossy.append(f"{r.spec}'s glTF material draws {exported / fitted:.2f}x its fit's image error")
    if not lossy:
        return None
    return ("; ".join(lossy) + f", more than the {SHIPPED_IMAGE_BAND:g}x a shipped material may lose: "
            "`brdf-fit export MEASURED_FILE --out material.glb` fits the glTF family to the table itself "
            "and writes the best material (docs/gltf.md, export-first)")


def _viewer(material, rows, measured, rendered, render_note, out_dir, slug):
    """(the 3D viewer's section (brdf_fit.report.web_viewer) of the glTF materials of ``rows``,
    None), or (one line saying why it is absent, that reason)."""
    from .web_viewer import ViewerUnavailable, write_viewer
    if not rows:            # models of one's own only: no glTF material for the viewer to load
        reason = "no glTF material to show (a model of your own has none)"
    else:
        try:
            return write_viewer(material, rows, measured, rendered, out_dir, render_note, stem=slug), None
        except ViewerUnavailable as err:
            reason = str(err)
        except Exception as err:            # the viewer must never sink the report; a full disk must
            if _disk_refused(err):
                raise
            reason = f"{type(err).__name__}: {err}"
    return f"<h2>3D viewer</h2><p class=\"note\">3D viewer not shown: {html.escape(reason)}.</p>", reason


# --- the report ------------------------------------------------------------------------------

def write_report(found: list[tuple[pathlib.Path, FitResult]], out_dir: str | os.PathLike[str],
                 measured: "MeasuredBRDF | None" = None, command_line: str = "", renders: bool = True,
                 log: Callable[[str], object] | None = None, index: bool = True,
                 broken: list | None = None) -> list[pathlib.Path]:
    """Write the pages for [(path, FitResult)] into ``out_dir``; returns the page paths.

    ``measured``: a MeasuredBRDF used for the material it belongs to (or for
    the only material), else each material's provenance file is loaded.
    ``index``: also write ``index.html`` (the library writes its own gallery instead).
    ``broken``: a list given gets the OwnModelError of each own model's glsl= that did not
    compile (its sphere left out, the others drawn).
    """
    from . import plots
    log = log or (lambda m: None)
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    groups = group_by_material(found)
    stems = report_stems(groups)
    pages, written = {}, []
    for material, rows in groups.items():
        notes = []
        explicit = measured if measured is not None and (
            len(groups) == 1 or measured.material == material) else None
        meas, note = _measured_for(rows, explicit)
        if note:
            notes.append(note)
        sha = _sha_note(rows, meas)
        if sha:
            notes.append(sha)
        log(f"{material}: {len(rows)} model(s): plots")
        figures = _figures(material, rows, meas, out_dir, notes, stems[material])
        log(f"{material}: M1 of the exported glTF materials")
        try:
            gltf = _gltf_errors(rows, meas)
        except Exception as err:
            gltf = {}
            notes.append(f"glTF export errors not computed: {type(err).__name__}: {err}")
        lossy = _lossy_exports(rows, gltf)
        if lossy:
            notes.append(lossy)
        if renders:
            log(f"{material}: lit-sphere renders")
        rendered, render_note = _renders(material, rows, meas, out_dir, stems[material], broken) if renders else \
            ([], "disabled")
        shown = [row for row in rows if not is_own(row[1].spec)][:RENDER_MODELS]   # glTF materials only
        viewer, reason = _viewer(material, shown, meas, rendered, render_note, out_dir, stems[material])
        log(f"{material}: 3D viewer not shown: {reason}" if reason else f"{material}: 3D viewer (three.js)")
        name = f"{stems[material]}.html"
        atomic_write_text(out_dir / name, material_page(material, rows, meas, figures, rendered, render_note,
                                                        gltf, notes, command_line, viewer))
        pages[material] = name
        written.append(out_dir / name)
        del meas                # before the next material's table is loaded, not after
        give_back_memory()      # (brdf_fit/batch/memory.py) its plots', renders' and viewer's buffers
    if not index:
        return written
    all_results = [r for rows in groups.values() for _, r in rows]
    bars = "index-errors.png"
    try:
        plots.save(plots.error_bars(all_results), out_dir / bars)
    except Exception as err:
        if _disk_refused(err):
            raise
        bars = None
    atomic_write_text(out_dir / "index.html", index_page(groups, pages, bars, command_line))
    written.insert(0, out_dir / "index.html")
    return written


def report_main(results: Iterable[str | os.PathLike[str]], out_dir: str | os.PathLike[str],
                measured_path: str | os.PathLike[str] | None = None, command_line: str = "") -> int:
    """``brdf-fit report``: 0 on success, 2 with one line on stderr for bad input."""
    from data_loaders import MeasuredDataError, load
    command_line = command_line or ("brdf-fit report " + " ".join(
        [str(r) for r in results] + (["--measured", str(measured_path)] if measured_path else [])
        + ["--out", str(out_dir)]))
    try:
        found = collect_results(results)
        measured = load(measured_path) if measured_path else None
    except (ResultFileError, ReportError, MeasuredDataError) as err:
        return fail("report", err)
    from data_loaders.atomic import owner_gone, owner_tag
    out_dir = pathlib.Path(out_dir)
    missing = [p for p in [out_dir, *out_dir.parents] if not p.exists()]
    for left in out_dir.glob(f"{STAGING_PREFIX}*"):      # of a report killed (kill -9) while writing
        if owner_gone(left.name[len(STAGING_PREFIX):]):
            shutil.rmtree(left, ignore_errors=True)
    staging = out_dir / f"{STAGING_PREFIX}{owner_tag()}"
    broken = []     # own models whose glsl= does not compile: the report is written, then exit 2
    try:
        written = write_report(found, staging, measured, command_line,
                               log=lambda m: print(m, file=sys.stderr), broken=broken)
        written = _publish(staging, out_dir, written)
    except OSError as err:
        shutil.rmtree(staging, ignore_errors=True)
        for folder in missing:              # folders this run made, if nothing else is in them
            with contextlib.suppress(OSError):
                folder.rmdir()
        message = os_error_message(err) if err.filename else f"{out_dir}: cannot write ({err.strerror or err})"
        return fail("report", message.replace(str(staging), str(out_dir)))
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    print(f"report: {written[0]} ({len(written) - 1} material page(s)) in {out_dir}/")
    for path in written[1:]:
        print(f"  {path}")
    if broken:
        more = f" (and {len(broken) - 1} more)" if len(broken) > 1 else ""
        return fail("report", f"{broken[0]}{more}; the report is written without its lit sphere")
    return OK


STAGING_PREFIX = ".report-staging-"     # + HOST-PID: where a report is written before it is moved into place


def _publish(staging, out_dir, written):
    """Move the report written into ``staging`` into ``out_dir`` (renames: no space needed),
    the index last, so that a report that failed half-way leaves no page behind and
    never an index whose pages are missing.  Returns ``written`` as moved."""
    files = sorted((p for p in staging.rglob("*") if p.is_file()), key=lambda p: p.name == "index.html")
    for path in files:
        target = out_dir / path.relative_to(staging)
        target.parent.mkdir(parents=True, exist_ok=True)
        os.replace(path, target)
    return [out_dir / pathlib.Path(p).relative_to(staging) for p in written]


__all__ = ["report_main", "write_report", "collect_results", "group_by_material", "ReportError"]
