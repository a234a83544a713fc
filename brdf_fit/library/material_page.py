"""The HTML of a library material's page, ``LIB/materials/<slug>.html`` (brdf_fit.library.material writes it).

A light page, made in a fraction of a second from what the library has anyway:
the measured and fitted spheres (the gallery's pictures), every fit's errors and
its exported glTF material's, the best fit's parameters, the shipped material in
the three.js viewer (brdf_fit.report.web_viewer) and its files, and the command
that writes the full report (plots, lit-sphere renders, every fit in the viewer).
Numbers are shown to NUMBER_DIGITS significant digits, each cell's ``data-value``
holding every digit; every name is HTML-escaped and every path URL-quoted.
"""

import html
import json
import pathlib
import shlex
import urllib.parse

from brdf import __version__
from brdf_fit.report.html import SCROLL_CSS, scrolling
from fitting.ranking import IMAGE_TERM, IMAGE_WEIGHT, SHIPPED_IMAGE_BAND

from .gallery import number

# (column title, key in FitResult.errors) of the errors table, after the model's name
ERROR_COLUMNS = (("M1", "m1"), ("image error", "image"), ("glTF M1", "exported_m1"),
                 ("glTF image error", "exported_image"))
# ... and where the fits weighed issue 59's second image error (BRDF_SECOND_WEIGHT, docs/metrics.md)
SECOND_COLUMNS = (("second image error", "second_image"), ("glTF second image error", "exported_second_image"))

_CSS = """
body { font-family: system-ui, sans-serif; margin: 1.5em auto; max-width: 1100px; padding: 0 1em; color: #222; }
table { border-collapse: collapse; font-size: 0.9em; margin: 0.6em 0; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; } th { background: #f3f3f3; }
td.num { text-align: right; font-variant-numeric: tabular-nums; } tr.best td { background: #eef8ee; }
.pictures img { image-rendering: auto; border: 1px solid #eee; margin-right: 0.5em; }
figure { margin: 1em 0; } figcaption, .meta { color: #555; font-size: 0.9em; } .note { color: #8a5a00; }
pre { background: #f6f6f6; padding: 0.6em; overflow-x: auto; } h1 { overflow-wrap: anywhere; }
""" + SCROLL_CSS


def _e(x):
    return html.escape(str(x), quote=True)


def _url(path):
    """A relative path as an attribute value: URL-quoted, then HTML-escaped."""
    return _e(urllib.parse.quote(pathlib.PurePath(path).as_posix(), safe="/."))


def _cell(value):
    shown = "" if value is None else number(value)
    return f'<td class="num" data-value="{"" if value is None else _e(repr(float(value)))}">{shown}</td>'


def _errors_table(rows, shipped):
    """Every fit of the material (best first), its errors and its exported material's."""
    columns = ERROR_COLUMNS + (SECOND_COLUMNS if any("second_image" in r.errors for _, r in rows) else ())
    head = "".join(f"<th>{t}</th>" for t in ("model", *(title for title, _ in columns), "glTF model",
                                                "result file"))
    body = []
    for k, (path, r) in enumerate(rows):
        cls = ' class="best"' if k == 0 else ""
        mark = " (shipped)" if r is shipped else ""
        body.append(f'<tr{cls}><td class="model"><code>{_e(r.spec)}</code>{mark}</td>'
                    + "".join(_cell(r.errors.get(key)) for _, key in columns)
                    + f'<td><code>{_e(r.errors.get("exported_model", ""))}</code></td>'
                    f'<td><a href="{_url("../results/" + pathlib.Path(path).name)}">'
                    f"{_e(pathlib.Path(path).name)}</a></td></tr>")
    return f'<table id="fits"><thead><tr>{head}</tr></thead><tbody>{"".join(body)}</tbody></table>'


def _parameter(value):
    """A parameter as the page shows it: NUMBER_DIGITS significant digits, RGB as (r, g, b);
    every digit in the cell's ``data-value`` (the result file's JSON)."""
    shown = "(" + ", ".join(number(v) for v in value) + ")" if isinstance(value, (list, tuple)) else number(value)
    return f'<td class="num" data-value="{_e(json.dumps(value))}">{shown}</td>'


def _parameters(result):
    rows = "".join(f"<tr><td><code>{_e(k)}</code></td>{_parameter(v)}</tr>" for k, v in result.parameters.items())
    return ('<table id="parameters"><thead><tr><th>parameter</th><th>value</th></tr></thead>'
            f"<tbody>{rows}</tbody></table>")


def _pictures(files):
    shown = [f'<img src="{_url("../" + files[k])}" alt="{k}" width="192" height="192">'
             for k in ("measured", "fitted", "shipped") if files.get(k)]
    if not shown:
        return '<p class="note">No pictures: the measured table is not here.</p>'
    return (f'<figure class="pictures">{"".join(shown)}<figcaption>measured | fitted (the best fit) | shipped (the '
            "glTF material in the library's files): the image error's sphere under its four lights, one exposure "
            "for all, set from the measured image (docs/metrics.md).</figcaption></figure>")


def material_page(material, rows, shipped, files, viewer, notes, measured_line, command_line, why_shipped=(),
                  model_files=()):
    """A material's page: ``rows`` [(result path, FitResult)] best first, ``shipped`` the
    fit exported to glTF, ``files`` the library's files of the material (relative to
    the library: "measured", "fitted", "glb", "mtlx"), ``viewer`` the viewer's HTML
    section, ``notes`` lines to show, ``measured_line`` what the measured table is,
    ``why_shipped`` the sentences on the path that won (brdf_fit.export.export_first.Shipped),
    ``model_files`` the names of the own models' files the library keeps in models/
    (build._model_files: its copies, by sha256; never a name or path read from a result)."""
    best = rows[0][1]
    report = shlex.join(["brdf-fit", "report", *(f"results/{pathlib.Path(p).name}" for p, _ in rows),
                         *(arg for name in model_files for arg in ("--model-file", f"models/{name}")),
                         "--out", "report"])
    links = " · ".join(f'<a href="{_url("../" + files[k])}">{label}</a>'
                       for k, label in (("glb", ".glb"), ("mtlx", ".mtlx")) if files.get(k))
    parts = [
        '<nav><a href="../index.html">all materials</a> · <a href="../analysis.html">analysis</a></nav>',
        f"<h1>{_e(material)}</h1>",
        f'<p class="meta">{_e(measured_line)}</p>',
        *(f'<p class="note">Note: {_e(n)}</p>' for n in notes),
        _pictures(files),
        "<h2>Fits</h2>", _errors_table(rows, shipped),
        f'<p class="meta">Best first, by M1 + {IMAGE_WEIGHT:g} &times; {IMAGE_TERM} (fitting/ranking.py); the best '
        "is highlighted. The glTF columns are the errors of the material each fit exports to (brdf-fit "
        "export), measured against the same table; the shipped one (the best of those by the same ranking, among "
        f"those within {SHIPPED_IMAGE_BAND:g} &times; the lowest glTF image error) is in the library's files. "
        "M1 and the image error: docs/metrics.md.</p>",
        f"<h2>The best fit's parameters: <code>{_e(best.spec)}</code></h2>", _parameters(best),
        f"<h2>The shipped material: <code>{_e(shipped.spec)}</code></h2>",
        '<div id="shipped">' + "".join(f"<p>{_e(line)}</p>" for line in why_shipped) + f"</div><p>{links}</p>",
        viewer,
        "<h2>The full report</h2><p>Plots (in-plane lobes, theta_h slices, half/difference images, "
        "albedo), lit-sphere renders and every fit in the viewer, run in the library's folder:</p>"
        f"<pre>{_e(report)}</pre>",
        f"<h2>Command</h2><pre>{_e(command_line)}</pre><p class=\"meta\">brdf-fit {_e(__version__)}</p>",
    ]
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>{_e(material)}</title>'
            f"<style>{_CSS}</style></head><body>\n" + scrolling("\n".join(parts)) + "\n</body></html>\n")
