"""The HTML of the report's pages (brdf_fit.report.pages writes them): a material's
page and the index, from the results, figures and notes it hands over."""

import datetime
import hashlib
import html
import re

from brdf import __version__
from fitting.ranking import IMAGE_TERM, IMAGE_WEIGHT, ranking_terms

MAX_SLUG = 100      # characters of a material or model name in a file name: the longest file
                    # the report writes ("<material>-render-<model>.png") stays under the 255 of
                    # a file name however long the names in the results (up to 255 each)


def slug(text: object) -> str:
    """``text`` as a file name part: [A-Za-z0-9._-] only, at most MAX_SLUG characters (a
    longer one cut, with 8 hex digits of its SHA-256 so that two long names stay distinct)."""
    out = re.sub(r"[^A-Za-z0-9._-]+", "_", str(text)).strip("_") or "material"
    if len(out) > MAX_SLUG:
        digest = hashlib.sha256(str(text).encode("utf-8", "surrogatepass")).hexdigest()[:8]
        out = out[:MAX_SLUG - 9] + "-" + digest
    return out


# A table wider than its page scrolls inside its own box (the page keeps its width: 1280 px
# screens show the 15 columns of a material's errors without a page-wide scroll bar).
SCROLL_CSS = """
.scroll { overflow-x: auto; max-width: 100%; margin: 0.5em 0; } .scroll > table { margin: 0; }
"""
_TABLE = re.compile(r"<table\b.*?</table>", re.S)


def scrolling(page: str) -> str:
    """``page`` with each of its tables (none nested) inside a ``<div class="scroll">``
    (SCROLL_CSS: it scrolls sideways inside its box when wider than the page)."""
    return _TABLE.sub(lambda m: f'<div class="scroll">{m.group(0)}</div>', page)


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
""" + SCROLL_CSS


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


def _swatch(model, colours):
    """The colour square of ``model``; ``colours``: ``plots.model_colors`` of the page's models,
    in the order its figures draw them (the same colours as theirs)."""
    return f'<span class="swatch" style="background:{colours[str(model)]}"></span>'


def _colours(models):
    from .plots import model_colors
    return model_colors(models)


def _page(title, body):
    return ("<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{_e(title)}</title><style>{_CSS}</style></head>\n<body>\n{scrolling(body)}\n</body></html>\n")


def _footer(command_line):
    when = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return (f"<h2>Command</h2><pre>{_e(command_line)}</pre>"
            f"<p class=\"meta\">brdf-fit {_e(__version__)}, {when}.</p>")


def material_page(material, rows, measured, figures, renders, render_note, gltf, notes, command_line,
                  viewer=""):
    best = rows[0][1].spec
    colours = _colours(r.spec for _, r in rows)     # as the page's figures draw them (pages._figures)
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
            f"<tr{cls}><td>{_swatch(r.spec, colours)}<code>{_e(r.spec)}</code></td>"
            f"<td class=\"num\">{_num(e.get('m1'))}</td>"
            + "".join(f"<td class=\"num\">{_num(c)}</td>" for c in ch)
            + f"<td class=\"num\">{_num(e.get('image'), 4)}</td>"
            + f"<td class=\"num\">{_e(e.get('loss_name', ''))} {_num(e.get('loss'))}</td>"
            + (f"<td class=\"num\">{_num(g[0])}</td><td class=\"num\">{_num(g[1], 4)}</td>"
               f"<td><code>{_e(g[2])}</code> ({_e(g[3])})</td>" if gltf and g else
               "<td>-</td><td>-</td><td>none (a model of your own)</td>" if gltf else "")
            + f"<td>{_e(o.get('name', ''))}</td><td class=\"num\">{_e(o.get('evaluations', ''))}</td>"
            f"<td>{_e(o.get('converged', ''))}</td><td class=\"num\">{_e(o.get('samples', ''))}</td>"
            f"<td class=\"num\">{_num(o.get('seconds_total'), 3)}</td></tr>")
    parts.append("</table>")
    parts.append("<p class=\"meta\">M1: mean over RGB of the weighted RMS of log(1 + f cos theta_i) "
                 "differences; image error: the RMS over a sphere under four lights of the per-pixel "
                 "&Delta;E<sub>ITP</sub> between the tone-mapped images of model and measurement, at the "
                 "measurement's viewer exposure, in units of 325 &Delta;E<sub>ITP</sub> (both lower is better; "
                 f"docs/metrics.md). Models are ranked by M1 + {IMAGE_WEIGHT:g} x {IMAGE_TERM}; the best is "
                 "highlighted. "
                 + ("The 'as exported glTF' columns re-evaluate the glTF BRDF a viewer would use with "
                    "the values <code>brdf-fit export</code> writes (rules: docs/gltf.md), as the engines "
                    "draw it (their multiple scattering, <code>+turquin</code>), against the same data."
                    if gltf else "") + "</p>")

    parts.append("<h2>Lit spheres</h2>")
    if renders:
        for name, model, data in renders:
            parts.append(f"<figure><img src=\"{_e(name)}\" alt=\"{_e(model)}\"><figcaption>"
                         f"{_swatch(model, colours)}<code>{_e(model)}</code>: measured | fitted | relative "
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
        parts.append(f"<tr><td>{_swatch(r.spec, colours)}<code>{_e(r.spec)}</code></td>"
                     + "".join(f"<td class=\"num\">{c}</td>" for c in cells) + "</tr>")
    parts.append("</table><p class=\"meta\">roughness is perceptual (alpha = roughness^2); RGB as "
                 "(r, g, b); angles in radians; * within 1 % of an end of the parameter's range, of log x "
                 "for a parameter on a log scale (the data may want a value outside it; "
                 "docs/result-format.md).</p>")
    prov = rows[0][1].provenance or {}
    parts.append("<h2>Provenance</h2><table>" + "".join(
        f"<tr><th>{_e(k)}</th><td><code>{_e(v)}</code></td></tr>" for k, v in prov.items()) + "</table>")
    parts.append(_footer(command_line))
    return _page(f"brdf-fit report: {material}", "\n".join(parts))


def index_page(groups, pages, bars, command_line):
    models = list(dict.fromkeys(r.spec for rows in groups.values() for _, r in rows))
    colours = _colours(models)      # as the bars' figure draws them (pages.py: error_bars of every result)
    parts = ["<h1>brdf-fit report</h1>",
             f"<p class=\"meta\">{sum(len(v) for v in groups.values())} fit results, "
             f"{len(groups)} material(s), {len(models)} model(s).</p>",
             "<h2>M1 per material and model</h2>"
             f"<p class=\"meta\">In bold, each material's best model: the lowest M1 + {IMAGE_WEIGHT:g} &times; "
             "image error (fitting/ranking.py, as <code>brdf-fit fit --model auto</code> and the library rank), "
             "not the lowest M1 alone; the last column shows its terms.</p>"
             "<table><tr><th>material</th>"
             + "".join(f"<th>{_swatch(m, colours)}<code>{_e(m)}</code></th>" for m in models)
             + f"<th>best (M1 + {IMAGE_WEIGHT:g} &times; {IMAGE_TERM})</th></tr>"]
    for material, rows in groups.items():      # best first: fitting.ranking.ranked
        cells = {r.spec: r.errors.get("m1") for _, r in rows}
        best = rows[0][1]
        parts.append(f"<tr><td><a href=\"{_e(pages[material])}\">{_e(material)}</a></td>"
                     + "".join(f"<td class=\"num\">{'<b>' if m == best.spec else ''}{_num(cells.get(m))}"
                               f"{'</b>' if m == best.spec else ''}</td>" for m in models)
                     + f"<td class=\"best\"><code>{_e(best.spec)}</code>: {_e(ranking_terms(best.errors))}</td></tr>")
    parts.append("</table>")
    if bars:
        parts.append(f"<figure><img src=\"{_e(bars)}\" alt=\"M1 per material and model\"></figure>")
    parts.append(_footer(command_line))
    return _page("brdf-fit report", "\n".join(parts))
