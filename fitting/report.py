"""HTML reports of fit results (``brdf-fit report RESULT.json [...] --out DIR``).

For every material among the results (result files, or folders of them) the
report writes ``DIR/<material>.html`` and its PNG figures next to it:

- the table of models and errors (M1 per channel, the loss, the optimizer),
  with the M1 of the glTF material each fit exports to (``fitting.export``'s
  honest re-evaluation) when the measurement is available;
- in-plane lobes, theta_h slices, half/difference error images and the
  directional albedo (``fitting.plots``), an M1 bar chart;
- lit spheres measured | fitted | difference from the preview renderer
  (``shaders.render.render_comparison``) when it can run here -- otherwise the
  page says why;
- every fit's exported .glb in a three.js viewer beside the measured sphere
  (``fitting.web_viewer``; without node_modules/three one line says why);
- the fitted parameters, the provenance, and the exact command that produced it.

``DIR/index.html`` is the batch overview: M1 of every model on every material
(table and bar chart) with links to the material pages.  Pages reference the
PNGs by relative path, so DIR is self-contained: copy or serve it as a whole.
"""

import datetime
import html
import os
import pathlib
import re
import sys
import typing
from collections.abc import Callable, Iterable

from brdf import __version__

from .errors import BAD_INPUT, OK, fail, warn  # noqa: F401  (BAD_INPUT: the exit codes' one home)
from .ranking import ranking_error
from .result import FitResult, NotAResultError, ResultFileError, atomic_write_text

if typing.TYPE_CHECKING:
    from data_loaders import MeasuredBRDF

RENDER_MODELS = 3        # lit spheres and 3D viewer (exported .glb) for the best few models
IMAGE_MODELS = 4         # half/difference error images for the best few models
RENDER_SIZE = 192

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 2em auto;
       max-width: 1400px; padding: 0 1em; color: #222; }
h1 { margin-bottom: 0.2em; } h2 { margin-top: 1.6em; border-bottom: 1px solid #ddd; }
table { border-collapse: collapse; font-size: 0.9em; margin: 0.5em 0; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
th { background: #f3f3f3; } td.num { text-align: right; font-variant-numeric: tabular-nums; }
tr.best td { background: #eef8ee; }
.swatch { display: inline-block; width: 0.9em; height: 0.9em; margin-right: 0.4em;
          vertical-align: -0.1em; border-radius: 2px; }
figure { margin: 1em 0; } figure img { max-width: 100%; border: 1px solid #eee; }
figcaption { font-size: 0.85em; color: #555; max-width: 1100px; }
pre { background: #f6f6f6; padding: 0.6em; overflow-x: auto; }
.meta { color: #555; font-size: 0.9em; } .note { color: #8a5a00; }
"""


class ReportError(ValueError):
    """Bad input to a report (named file and problem)."""


# --- inputs ---------------------------------------------------------------------

def collect_results(items: Iterable[str | os.PathLike[str]]) -> list[tuple[pathlib.Path, FitResult]]:
    """Result files and folders -> [(path, FitResult)].

    A file named on the command line must be a valid fit result
    (``FitResult.load``'s ResultFileError propagates); in a folder, JSON
    files that are not fit results at all are skipped silently (a batch
    folder holds summary files too), and broken fit results (NaN, values out
    of bounds, ...) are skipped with a warning on stderr.  Raises
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
                    warn("report", f"{err} (skipped)")
        elif p.exists():
            found.append((p, FitResult.load(p)))      # ResultFileError propagates
        else:
            raise ReportError(f"{p}: no such file or folder")
    if not found:
        raise ReportError("no fit results found in " + ", ".join(str(i) for i in items))
    return found


def group_by_material(found: list[tuple[pathlib.Path, FitResult]]) -> dict[str, list[tuple[pathlib.Path, FitResult]]]:
    """{material: [(path, FitResult)] best first (fitting.ranking: M1 + 0.3 x image error)},
    materials in first-seen order."""
    groups = {}
    for path, result in found:
        groups.setdefault(result.material, []).append((path, result))
    for rows in groups.values():
        rows.sort(key=lambda pr: ranking_error(pr[1].errors))
    return groups


def _slug(text):
    return re.sub(r"[^A-Za-z0-9._-]+", "_", str(text)).strip("_") or "material"


# --- measured data ------------------------------------------------------------------

def _measured_for(results, explicit):
    """(MeasuredBRDF or None, note) for one material's results."""
    from data_loaders import MeasuredDataError, load
    if explicit is not None:
        return explicit, None
    for _, r in results:
        path = (r.provenance or {}).get("file")
        if path and pathlib.Path(path).is_file():
            try:
                return load(path), None
            except MeasuredDataError as err:
                return None, f"the provenance file could not be read: {err}"
    files = sorted({str((r.provenance or {}).get("file")) for _, r in results})
    return None, ("the measured file of the fits (" + ", ".join(files) + ") is not here; "
                  "pass --measured FILE for the measured curves and errors")


def _sha_note(results, measured):
    shas = {(r.provenance or {}).get("sha256") for _, r in results} - {None, ""}
    if measured is not None and shas and measured.provenance.sha256 not in shas:
        return ("the measured file differs from the one these fits were made on (sha256); "
                "curves and errors below compare against the file given")
    return None


# --- figures and renders ---------------------------------------------------------------

def _figures(material, rows, measured, out_dir, notes):
    """Write the PNGs of one material; [(file name, title, caption)]."""
    from . import plots
    results = [r for _, r in rows]
    slug = _slug(material)
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
        ("errors", "Fit error per model", lambda: plots.error_bars(results, title=f"{material}: M1 per model"),
         "M1 (Loew et al.'s log-compressed, cosine-weighted RMS error, the fit's own metric; "
         "docs/metrics.md) on every valid sample with theta <= the fit's max_theta."),
    ]
    out = []
    for key, title, make, caption in todo:
        name = f"{slug}-{key}.png"
        try:
            plots.save(make(), out_dir / name)
            out.append((name, title, caption))
        except Exception as err:       # a plot must never sink the report
            notes.append(f"{title} not drawn: {type(err).__name__}: {err}")
    return out


def _renders(material, rows, measured, out_dir):
    """Lit-sphere comparisons for the best models: ([(file, model, stats)], note)."""
    if measured is None:
        return [], "lit spheres need the measured data"
    try:
        from shaders.render import render_comparison, save_png
    except ImportError as err:
        return [], f"the preview renderer is not available ({err})"
    except Exception as err:           # e.g. a GL library that fails to load
        return [], f"the preview renderer could not be loaded ({type(err).__name__}: {err})"
    out = []
    for _, r in rows[:RENDER_MODELS]:
        name = f"{_slug(material)}-render-{_slug(r.spec)}.png"
        try:
            img, data = render_comparison(r.spec, r.parameters, measured, size=RENDER_SIZE, return_data=True,
                                          labels=True)
            save_png(out_dir / name, img)
            out.append((name, r.spec, data))
        except Exception as err:        # no GL driver, renderer still in progress, ...
            return out, f"the preview renderer could not run here ({type(err).__name__}: {err})"
    return out, None


def _gltf_errors(rows, measured):
    """{spec: (M1, image error of the exported glTF material, its model string, kind)}:
    from the results (fits record them) or, for older results, computed from the data."""
    from .export import convert, m1_errors
    from .honesty import image_errors
    convs = [convert(r) for _, r in rows]
    if all("exported_m1" in r.errors for _, r in rows):
        return {r.spec: (r.errors["exported_m1"], r.errors.get("exported_image"), c["model"], c["kind"])
                for (_, r), c in zip(rows, convs)}
    if measured is None:
        return {}
    max_theta = float((rows[0][1].optimizer or {}).get("max_theta", 80.0))
    models = [(c["model"], c["parameters"]) for c in convs]
    m1s, images = m1_errors(measured, models, max_theta), image_errors(measured, models)
    return {r.spec: (e[0], i, c["model"], c["kind"]) for (_, r), c, e, i in zip(rows, convs, m1s, images)}


def _viewer(material, rows, measured, rendered, render_note, out_dir):
    """The 3D viewer's section (fitting.web_viewer), or one line saying why it is absent."""
    from .web_viewer import ViewerUnavailable, write_viewer
    try:
        return write_viewer(material, rows, measured, rendered, out_dir, render_note)
    except ViewerUnavailable as err:
        reason = str(err)
    except Exception as err:            # the viewer must never sink the report
        reason = f"{type(err).__name__}: {err}"
    return f"<h2>3D viewer</h2><p class=\"note\">3D viewer not shown: {_e(reason)}.</p>"


# --- HTML -----------------------------------------------------------------------------------

def _e(x):
    return html.escape(str(x))


def _num(x, digits=5):
    try:
        return f"{float(x):.{digits}g}"
    except (TypeError, ValueError):
        return ""


def _fmt_param(v):
    if isinstance(v, (list, tuple)):
        return "(" + ", ".join(f"{x:.4g}" for x in v) + ")"
    return f"{v:.4g}"


def _swatch(model):
    from .plots import model_color
    return f'<span class="swatch" style="background:{model_color(model)}"></span>'


def _page(title, body):
    return ("<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{_e(title)}</title><style>{_CSS}</style></head>\n<body>\n{body}\n</body></html>\n")


def _footer(command_line):
    when = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return (f"<h2>Command</h2><pre>{_e(command_line)}</pre>"
            f"<p class=\"meta\">brdf-fit {_e(__version__)}, {when}.</p>")


def material_page(material, rows, measured, figures, renders, render_note, gltf, notes, command_line,
                  viewer=""):
    best = rows[0][1].spec
    parts = [f"<h1>{_e(material)}</h1>"]
    if measured is not None:
        p = measured.provenance
        parts.append(f"<p class=\"meta\">measured: <code>{_e(p.path)}</code> ({_e(p.format)}, "
                     f"{measured.n_valid:,} valid samples, sha256 {_e(p.sha256[:16])}...)"
                     f"{'<br>' + _e(p.units) if p.units else ''}</p>")
    parts.append("<p class=\"meta\">results: " + ", ".join(f"<code>{_e(path)}</code>" for path, _ in rows)
                 + "</p>")
    for note in notes:
        parts.append(f"<p class=\"note\">Note: {_e(note)}</p>")

    parts.append("<h2>Models and errors</h2><table><tr><th>model</th><th>M1</th><th>M1 R</th>"
                 "<th>M1 G</th><th>M1 B</th><th>image error</th><th>loss</th>"
                 + ("<th>M1 as exported glTF</th><th>image error as exported glTF</th>"
                    "<th>glTF material</th>" if gltf else "")
                 + "<th>optimizer</th><th>evaluations</th><th>converged</th><th>samples</th>"
                 "<th>seconds</th></tr>")
    for _, r in rows:
        e, o = r.errors, r.optimizer or {}
        ch = e.get("m1_per_channel") or [None] * 3
        g = gltf.get(r.spec)
        cls = ' class="best"' if r.spec == best else ""
        parts.append(
            f"<tr{cls}><td>{_swatch(r.spec)}<code>{_e(r.spec)}</code></td>"
            f"<td class=\"num\">{_num(e.get('m1'))}</td>"
            + "".join(f"<td class=\"num\">{_num(c)}</td>" for c in ch)
            + f"<td class=\"num\">{_num(e.get('image'), 4)}</td>"
            + f"<td class=\"num\">{_e(e.get('loss_name', ''))} {_num(e.get('loss'))}</td>"
            + (f"<td class=\"num\">{_num(g[0])}</td><td class=\"num\">{_num(g[1], 4)}</td>"
               f"<td><code>{_e(g[2])}</code> ({_e(g[3])})</td>" if gltf and g else "")
            + f"<td>{_e(o.get('name', ''))}</td><td class=\"num\">{_e(o.get('evaluations', ''))}</td>"
            f"<td>{_e(o.get('converged', ''))}</td><td class=\"num\">{_e(o.get('samples', ''))}</td>"
            f"<td class=\"num\">{_num(o.get('seconds_total'), 3)}</td></tr>")
    parts.append("</table>")
    parts.append("<p class=\"meta\">M1: mean over RGB of the weighted RMS of log(1 + f cos theta_i) "
                 "differences; image error: mean over RGB of the RMS difference of tone-mapped sRGB "
                 "images of a sphere under four lights, model vs measurement (both lower is better; "
                 "docs/metrics.md). Models are ranked by M1 + 0.3 x image error; the best is "
                 "highlighted. "
                 + ("The 'as exported glTF' columns re-evaluate the glTF BRDF a viewer would use with "
                    "the values <code>brdf-fit export</code> writes (rules: docs/gltf.md), against the "
                    "same data." if gltf else "") + "</p>")

    parts.append("<h2>Lit spheres</h2>")
    if renders:
        for name, model, data in renders:
            parts.append(f"<figure><img src=\"{_e(name)}\" alt=\"{_e(model)}\"><figcaption>"
                         f"{_swatch(model)}<code>{_e(model)}</code>: measured | fitted | relative "
                         f"difference (median {100 * data.get('median_difference', float('nan')):.1f} %), "
                         "same environment lighting.</figcaption></figure>")
    if render_note:
        parts.append(f"<p class=\"note\">Lit-sphere comparison not shown: {_e(render_note)}.</p>")
    parts.append(viewer)

    for name, title, caption in figures:
        parts.append(f"<h2>{_e(title)}</h2><figure><img src=\"{_e(name)}\" alt=\"{_e(title)}\">"
                     f"<figcaption>{_e(caption)}</figcaption></figure>")

    names = list(dict.fromkeys(k for _, r in rows for k in r.parameters))
    parts.append("<h2>Parameters</h2><table><tr><th>model</th>"
                 + "".join(f"<th>{_e(n)}</th>" for n in names) + "</tr>")
    for _, r in rows:
        flags = r.at_bounds()
        cells = [(_e(_fmt_param(r.parameters[n])) + ("*" if n in flags else "")) if n in r.parameters else ""
                 for n in names]
        parts.append(f"<tr><td>{_swatch(r.spec)}<code>{_e(r.spec)}</code></td>"
                     + "".join(f"<td class=\"num\">{c}</td>" for c in cells) + "</tr>")
    parts.append("</table><p class=\"meta\">roughness is perceptual (alpha = roughness^2); RGB as "
                 "(r, g, b); angles in radians; * within 1 % of an end of the parameter's range "
                 "(the data may want a value outside it; docs/result-format.md).</p>")
    prov = rows[0][1].provenance or {}
    parts.append("<h2>Provenance</h2><table>" + "".join(
        f"<tr><th>{_e(k)}</th><td><code>{_e(v)}</code></td></tr>" for k, v in prov.items()) + "</table>")
    parts.append(_footer(command_line))
    return _page(f"brdf-fit report: {material}", "\n".join(parts))


def index_page(groups, pages, bars, command_line):
    models = list(dict.fromkeys(r.spec for rows in groups.values() for _, r in rows))
    parts = ["<h1>brdf-fit report</h1>",
             f"<p class=\"meta\">{sum(len(v) for v in groups.values())} fit results, "
             f"{len(groups)} material(s), {len(models)} model(s).</p>",
             "<h2>M1 per material and model</h2><table><tr><th>material</th>"
             + "".join(f"<th>{_swatch(m)}<code>{_e(m)}</code></th>" for m in models) + "<th>best</th></tr>"]
    for material, rows in groups.items():
        cells = {r.spec: r.errors.get("m1") for _, r in rows}
        best = rows[0][1].spec
        parts.append(f"<tr><td><a href=\"{_e(pages[material])}\">{_e(material)}</a></td>"
                     + "".join(f"<td class=\"num\">{'<b>' if m == best else ''}{_num(cells.get(m))}"
                               f"{'</b>' if m == best else ''}</td>" for m in models)
                     + f"<td><code>{_e(best)}</code></td></tr>")
    parts.append("</table>")
    if bars:
        parts.append(f"<figure><img src=\"{_e(bars)}\" alt=\"M1 per material and model\"></figure>")
    parts.append(_footer(command_line))
    return _page("brdf-fit report", "\n".join(parts))


# --- the report ------------------------------------------------------------------------------

def write_report(found: list[tuple[pathlib.Path, FitResult]], out_dir: str | os.PathLike[str],
                 measured: "MeasuredBRDF | None" = None, command_line: str = "", renders: bool = True,
                 log: Callable[[str], object] | None = None) -> list[pathlib.Path]:
    """Write the pages for [(path, FitResult)] into ``out_dir``; returns the page paths.

    ``measured``: a MeasuredBRDF used for the material it belongs to (or for
    the only material), else each material's provenance file is loaded.
    """
    from . import plots
    log = log or (lambda m: None)
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    groups = group_by_material(found)
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
        figures = _figures(material, rows, meas, out_dir, notes)
        log(f"{material}: M1 of the exported glTF materials")
        try:
            gltf = _gltf_errors(rows, meas)
        except Exception as err:
            gltf = {}
            notes.append(f"glTF export errors not computed: {type(err).__name__}: {err}")
        if renders:
            log(f"{material}: lit-sphere renders")
        rendered, render_note = _renders(material, rows, meas, out_dir) if renders else ([], "disabled")
        log(f"{material}: 3D viewer")
        viewer = _viewer(material, rows[:RENDER_MODELS], meas, rendered, render_note, out_dir)
        name = f"{_slug(material)}.html"
        atomic_write_text(out_dir / name, material_page(material, rows, meas, figures, rendered, render_note,
                                                        gltf, notes, command_line, viewer))
        pages[material] = name
        written.append(out_dir / name)
    all_results = [r for rows in groups.values() for _, r in rows]
    bars = "index-errors.png"
    try:
        plots.save(plots.error_bars(all_results), out_dir / bars)
    except Exception:
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
    try:
        written = write_report(found, out_dir, measured, command_line,
                               log=lambda m: print(m, file=sys.stderr))
    except OSError as err:
        return fail("report", f"{out_dir}: cannot write ({err.strerror or err})")
    print(f"report: {written[0]} ({len(written) - 1} material page(s)) in {out_dir}/")
    for path in written[1:]:
        print(f"  {path}")
    return OK


__all__ = ["report_main", "write_report", "collect_results", "group_by_material", "ReportError"]
