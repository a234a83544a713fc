"""The library's analysis page, ``LIB/analysis.html``: brdf_fit.library.analysis's
figures, its table of the models in numbers and the poorly reproduced materials,
with their pictures.  Static HTML (no script, nothing fetched): it works from
``file://`` and offline.
"""

import html
import os
import pathlib
import urllib.parse
from collections.abc import Mapping

from fitting.ranking import IMAGE_WEIGHT
from fitting.result import atomic_write_text

from ..report.plot_base import model_color, save
from .analysis import (IMAGE_ERROR_THRESHOLD, ITP_UNIT, Groups, analysis_table, error_distributions, parameters,
                       poorly_reproduced, wins)

FIGURE_DIR = "analysis"        # the page's PNGs, beside analysis.html
NUMBER_DIGITS = 4              # significant digits shown (the table's data-value keeps all)


def number(x) -> str:
    """A number as the page shows it (NUMBER_DIGITS significant digits; blank for none)."""
    return "" if x is None else f"{float(x):.{NUMBER_DIGITS}g}"


def _e(x):
    return html.escape(str(x), quote=True)


def _url(path):
    """A relative file path as an attribute value: URL-quoted, then HTML-escaped."""
    return _e(urllib.parse.quote(pathlib.PurePath(path).as_posix(), safe="/"))


def _model(name):
    return f'<span class="dot" style="background:{model_color(name)}"></span>{_e(name)}'


TABLE_COLUMNS = (("model", "model"), ("materials", "materials fitted"), ("wins", "wins"),
                 ("median_ranking", "median ranking error"), ("median_m1", "median M1"), ("mean_m1", "mean M1"),
                 ("median_image", "median image error"), ("median_ratio", "median ratio to the winner"))


def _table(rows):
    head = "".join(f"<th>{_e(title)}</th>" for _, title in TABLE_COLUMNS)
    body = []
    for row in rows:
        cells = [f'<td class="model">{_model(row["model"])}</td>']
        for key, _ in TABLE_COLUMNS[1:]:
            v = row[key]
            shown = str(v) if isinstance(v, int) else number(v)
            cells.append(f'<td class="num" data-key="{key}" data-value="{"" if v is None else _e(repr(v))}">'
                         f"{shown}</td>")
        body.append(f"<tr>{''.join(cells)}</tr>")
    return f'<table id="models"><thead><tr>{head}</tr></thead><tbody>{"".join(body)}</tbody></table>'


def _poor(groups, threshold, thumbnails, pages):
    poor = poorly_reproduced(groups, threshold)
    if not poor:
        return f"<p>No material's best fit has an image error above {number(threshold)}.</p>"
    rows = []
    for material, r in poor:
        image = float(r.errors["image"])
        name = _e(material)
        if pages.get(material):
            name = f'<a href="{_url(pages[material])}">{name}</a>'
        picture = (f'<img src="{_url(thumbnails[material])}" alt="{_e(material)}" width="96" height="96">'
                   if thumbnails.get(material) else "")
        lowest = min((x for x in groups[material] if "image" in x.errors), key=lambda x: float(x.errors["image"]))
        rows.append(f'<tr><td>{picture}</td><td class="name">{name}</td><td>{_model(r.spec)}</td>'
                    f'<td class="num">{number(r.errors["m1"])}</td><td class="num">{number(image)}</td>'
                    f'<td class="num">{number(image * ITP_UNIT)}</td>'
                    f'<td class="num">{number(lowest.errors["image"])} ({_e(lowest.spec)})</td></tr>')
    return ('<table id="poor"><thead><tr><th></th><th>material</th><th>best model</th><th>M1</th>'
            '<th>image error</th><th>RMS &Delta;E<sub>ITP</sub></th><th>lowest image error of any fit</th>'
            f'</tr></thead><tbody>{"".join(rows)}</tbody></table>')


_CSS = """
body { font-family: system-ui, sans-serif; margin: 1.5em auto; max-width: 1200px; padding: 0 1em; color: #222; }
table { border-collapse: collapse; font-size: 0.9em; margin: 1em 0; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; } th { background: #f3f3f3; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
.dot { display: inline-block; width: 0.7em; height: 0.7em; border-radius: 50%; margin-right: 0.4em; }
figure { margin: 1.5em 0; } figure img { max-width: 100%; } figcaption, .meta { color: #555; font-size: 0.9em; }
"""

_FIGURES = (
    ("errors", error_distributions, "M1 and image error of each model over the materials it was fitted to: "
     "a box (quartiles, whiskers to 1.5 times the interquartile range) and every material as a point. "
     "The dashed line is the poorly-reproduced threshold."),
    ("wins", wins, "Left: the materials each model wins (lowest ranking error). Right: where it loses, its "
     "ranking error divided by the winner's (1 = as good as the winner)."),
    ("parameters", parameters, "Each material's best fit: perceptual roughness against F0 (luminance of f0), "
     "coloured by the diffuse albedo, and the albedo colours by material. Fits without roughness and f0 "
     "(the glTF family) are not in the scatter."),
)


def write_analysis(groups: Groups, out_dir: str | os.PathLike[str], thumbnails: Mapping[str, str] | None = None,
                   pages: Mapping[str, str] | None = None, *, index: str | None = None,
                   threshold: float = IMAGE_ERROR_THRESHOLD) -> pathlib.Path:
    """Write ``out_dir/analysis.html`` and its PNGs (``out_dir/analysis/``), atomically;
    returns the page's path.  ``thumbnails`` maps a material to a picture and
    ``pages`` to its page, both relative to ``out_dir``; ``index`` is a link back to
    the gallery.  The page is static HTML (no script, nothing fetched): it works
    from file:// and offline.  Every name is HTML-escaped, every path URL-quoted."""
    out = pathlib.Path(out_dir)
    thumbnails, pages = dict(thumbnails or {}), dict(pages or {})
    figures = []
    for name, draw, caption in _FIGURES:
        save(draw(groups), out / FIGURE_DIR / f"{name}.png")
        figures.append(f'<figure><img src="{_url(f"{FIGURE_DIR}/{name}.png")}" alt="{_e(name)}">'
                       f"<figcaption>{_e(caption)}</figcaption></figure>")
    rows = analysis_table(groups)
    nav = f'<nav><a href="{_url(index)}">all materials</a></nav>' if index else ""
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>Analysis: models across the library</title>
<style>{_CSS}</style></head><body>
{nav}<h1>Models across the library</h1>
<p class="meta">{len(groups)} materials, {len(rows)} models. Each material's best fit is the one of lowest
ranking error, M1 + {IMAGE_WEIGHT:g} &times; image error (fitting/ranking.py); models are listed by their
median ranking error. M1 is the table error, the image error what a viewer sees of a lit sphere
(docs/metrics.md); both are lower for better fits.</p>
{figures[0]}{figures[1]}
<h2>The models in numbers</h2>
<p class="meta">Medians and means over the materials each model was fitted to; the ratio to the winner is
taken over the materials it does not win.</p>
{_table(rows)}
{figures[2]}
<h2>Poorly reproduced materials</h2>
<p class="meta">Materials whose best fit has an image error above {number(threshold)}, worst first.
The image error is the RMS over the sphere of &Delta;E<sub>ITP</sub> (ITU-R BT.2124) in units of
{ITP_UNIT:g} &Delta;E<sub>ITP</sub>, and &Delta;E<sub>ITP</sub> = 1 is about one just noticeable
difference (docs/metrics.md): the threshold is an RMS of {number(threshold * ITP_UNIT)} just noticeable
differences, a sphere visibly unlike the measured one.</p>
{_poor(groups, threshold, thumbnails, pages)}
</body></html>
"""
    path = out / "analysis.html"
    atomic_write_text(path, page)
    return path


__all__ = ["TABLE_COLUMNS", "number", "write_analysis"]
