"""The library's analysis page, ``LIB/analysis.html``: brdf_fit.library.analysis's
figures, its table of the models in numbers and the poorly reproduced materials,
with their pictures; and brdf_fit.library.study's sections: per category (when the
materials fall in two or more), GGX against Beckmann, half-vector against
mirror-direction lobes, and per material (its numbers also in ``analysis/study.json``
for scripts).  Static HTML (no script, nothing fetched): it works from ``file://``
and offline.
"""

import html
import json
import math
import os
import pathlib
import re
import urllib.parse
from collections.abc import Mapping

from fitting.ranking import IMAGE_TERM, IMAGE_WEIGHT
from fitting.result import atomic_write_text

from ..report.html import SCROLL_CSS, scrolling
from ..report.plot_base import model_color, save
from .analysis import (IMAGE_ERROR_THRESHOLD, ITP_UNIT, Groups, analysis_table, error_distributions, library_colours,
                       parameters, poorly_reproduced, wins)
from .categories import material_categories
from .study import HALF_VECTOR, category_heatmap, comparison_figure, comparisons, study_numbers

FIGURE_DIR = "analysis"        # the page's PNGs, beside analysis.html
STUDY_JSON = "study.json"      # the study sections' numbers, in FIGURE_DIR
NUMBER_DIGITS = 4              # significant digits shown (the table's data-value keeps all)


def number(x) -> str:
    """A number as the page shows it (NUMBER_DIGITS significant digits; blank for none)."""
    return "" if x is None else f"{float(x):.{NUMBER_DIGITS}g}"


def _e(x):
    return html.escape(str(x), quote=True)


def _url(path):
    """A relative file path as an attribute value: URL-quoted, then HTML-escaped."""
    return _e(urllib.parse.quote(pathlib.PurePath(path).as_posix(), safe="/"))


def _model(name, colours):
    """A model's name after its colour dot (``colours``: analysis.library_colours)."""
    return f'<span class="dot" style="background:{colours.get(name) or model_color(name)}"></span>{_e(name)}'


TABLE_COLUMNS = (("model", "model"), ("materials", "materials fitted"), ("wins", "wins"),
                 ("median_ranking", "median ranking error"), ("median_m1", "median M1"), ("mean_m1", "mean M1"),
                 ("median_image", "median image error"), ("median_ratio", "median ratio to the winner"))


def _cell(key, v):
    """A number's cell: shown with NUMBER_DIGITS digits, exact in data-value."""
    shown = str(v) if isinstance(v, int) else number(v)
    return f'<td class="num" data-key="{key}" data-value="{"" if v is None else _e(repr(v))}">{shown}</td>'


def _name(material, pages):
    name = _e(material)
    return f'<a href="{_url(pages[material])}">{name}</a>' if pages.get(material) else name


def _table(rows, colours):
    head = "".join(f"<th>{_e(title)}</th>" for _, title in TABLE_COLUMNS)
    body = []
    for row in rows:
        cells = [f'<td class="model">{_model(row["model"], colours)}</td>']
        cells += [_cell(key, row[key]) for key, _ in TABLE_COLUMNS[1:]]
        body.append(f"<tr>{''.join(cells)}</tr>")
    return f'<table id="models"><thead><tr>{head}</tr></thead><tbody>{"".join(body)}</tbody></table>'


def _poor(groups, threshold, thumbnails, pages, colours):
    poor = poorly_reproduced(groups, threshold)
    if not poor:
        return f"<p>No material's best fit has an image error above {number(threshold)}.</p>"
    rows = []
    for material, r in poor:
        image = float(r.errors["image"])
        picture = (f'<img src="{_url(thumbnails[material])}" alt="{_e(material)}" width="96" height="96">'
                   if thumbnails.get(material) else "")
        lowest = min((x for x in groups[material] if "image" in x.errors), key=lambda x: float(x.errors["image"]))
        rows.append(f'<tr><td>{picture}</td><td class="name">{_name(material, pages)}</td>'
                    f'<td>{_model(r.spec, colours)}</td>'
                    f'<td class="num">{number(r.errors["m1"])}</td><td class="num">{number(image)}</td>'
                    f'<td class="num">{number(image * ITP_UNIT)}</td>'
                    f'<td class="num">{number(lowest.errors["image"])} ({_e(lowest.spec)})</td></tr>')
    return ('<table id="poor"><thead><tr><th></th><th>material</th><th>best model</th><th>M1</th>'
            '<th>image error</th><th>RMS &Delta;E<sub>ITP</sub></th><th>lowest image error of any fit</th>'
            f'</tr></thead><tbody>{"".join(rows)}</tbody></table>')


# --- the study sections (brdf_fit.library.study) -------------------------------------

def _figure(out, key, figure, caption):
    """Save ``figure`` as FIGURE_DIR/KEY.png; its <figure> element."""
    save(figure, out / FIGURE_DIR / f"{key}.png")
    return (f'<figure><img src="{_url(f"{FIGURE_DIR}/{key}.png")}" alt="{_e(key)}">'
            f"<figcaption>{_e(caption)}</figcaption></figure>")


def _materials_table(rows, pages, show_categories, colours):
    classic = any(r["best_classic"] for r in rows)
    head = (["material"] + (["category"] if show_categories else []) + ["best model", "ranking error", "M1",
            "image error"] + (["best classic model", "its ranking error / the best's"] if classic else []))
    body = []
    for r in rows:
        cells = [f'<td class="name">{_name(r["material"], pages)}</td>']
        cells += [f'<td class="category">{_e(r["category"])}</td>'] if show_categories else []
        cells += ([f'<td class="model">{_model(r["best"], colours)}</td>']
                  + [_cell(k, r[k]) for k in ("ranking", "m1", "image")])
        if classic:
            cells += [f'<td class="model">{_model(r["best_classic"], colours) if r["best_classic"] else ""}</td>',
                      _cell("classic_ratio", r["classic_ratio"])]
        body.append(f"<tr>{''.join(cells)}</tr>")
    head = "".join(f"<th>{_e(h)}</th>" for h in head)
    return f'<table id="materials"><thead><tr>{head}</tr></thead><tbody>{"".join(body)}</tbody></table>'


def _categories_table(rows, colours):
    body = []
    for r in rows:
        most = ", ".join(_model(m, colours) for m in r["most_wins"])
        body.append(f'<tr><td class="category">{_e(r["category"])}</td>{_cell("materials", r["materials"])}'
                    f'<td class="model">{most}</td>{_cell("wins", r["wins"])}'
                    f'<td class="model">{_model(r["best_median"], colours)}</td>{_cell("over", r["over"])}'
                    + "".join(_cell(k, r[k]) for k in ("median_ranking", "median_m1", "median_image")) + "</tr>")
    return ('<table id="categories"><thead><tr><th>category</th><th>materials</th><th>wins most</th>'
            '<th>wins</th><th>best by median ranking error</th><th>over materials</th>'
            '<th>its median ranking error</th><th>median M1</th><th>median image error</th>'
            f'</tr></thead><tbody>{"".join(body)}</tbody></table>')


def _counts(key, c):
    ties = f" ({c['ties']} tied)" if c["ties"] else ""
    return (f'<td class="num" data-key="{key}" data-left="{c["left_better"]}" data-right="{c["right_better"]}" '
            f'data-ties="{c["ties"]}">{c["left_better"]} / {c["right_better"]}{ties}</td>')


def _comparisons_table(summaries, table_id, colours):
    left, right = _e(summaries[0]["left"]), _e(summaries[0]["right"])
    body = []
    for s in summaries:
        sides = [_model(s[k][0], colours) if len(s[k]) == 1 else "the best of " + ", ".join(map(_e, s[k]))
                 for k in ("left_models", "right_models")]
        cells = ([_cell("materials", s["materials"])] + [_counts(k, s[k]) for k in ("ranking", "m1", "image")]
                 + [_cell(k, s[k]) for k in ("median_ratio_m1", "median_ratio_image")])
        body.append(f'<tr><td class="model">{sides[0]}</td><td class="model">{sides[1]}</td>{"".join(cells)}</tr>')
    return (f'<table id="{table_id}"><thead><tr><th>{left}</th><th>{right}</th><th>materials (both fitted)</th>'
            f'<th>ranking error: {left} / {right} better</th><th>M1: {left} / {right} better</th>'
            f'<th>image error: {left} / {right} better</th><th>median M1 ratio {right} / {left}</th>'
            f'<th>median image error ratio {right} / {left}</th></tr></thead><tbody>{"".join(body)}</tbody></table>')


def _finite(x):
    """Numbers for JSON: non-finite ones (a ratio over a zero error) as None."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_finite(v) for v in x]
    return x


def _study(groups, out, pages, colours):
    """The study's sections (HTML), its figures and analysis/study.json; ``colours``: the
    page's model colours (analysis.library_colours)."""
    categories = material_categories(groups)
    numbers = study_numbers(groups, categories)
    atomic_write_text(out / FIGURE_DIR / STUDY_JSON, json.dumps(_finite(numbers), indent=1) + "\n")
    show_categories = len({r["category"] for r in numbers["materials"]}) >= 2
    parts = []
    if show_categories:
        parts.append(f"""<h2>Per category</h2>
<p class="meta">A material's category is its MERL category by name (Ngan et al. 2005; Matusik et al. 2003), or,
for a name that is not MERL's, the folder its file sat in when the files sit in several; "other" otherwise.
The best model of a category is the one of lowest median ranking error among the models fitted to the most of its
materials (<code>auto</code> refines a model only where it may win, and a median over those alone would flatter it).
</p>
{_categories_table(numbers["categories"], colours)}
{_figure(out, "categories", category_heatmap(groups, categories), "Median ranking error of each model over each "
         "category's materials (k/n: fitted to k of its n materials); the darker, the further above the category's "
         "best median (white: the best; darkest: 3 times it or more).")}""")
    found = {c.key: c for c in comparisons(groups)}
    by_key = {s["key"]: s for s in numbers["comparisons"]}
    for title, table_id, keys, intro in (
            ("GGX against Beckmann", "ggx-beckmann", [k for k in found if k.startswith("ggx-beckmann")],
             "Models that differ only in their microfacet distribution, over the materials both were fitted to."),
            ("Half vector against mirror direction", "half-mirror", [k for k in found if k.startswith("half-mirror")],
             f"Lobes around the half vector against lobes around the mirror direction: normalised Blinn-Phong "
             f"against modified Phong (the same cosine lobe and exponent; also both with the microfacet "
             f"factor 1 / (4 (wi.h) max(n.wi, n.wo)) where blinn_phong_mf and phong_mf were fitted), and "
             f"the best {HALF_VECTOR} classic model (Blinn-Phong, Ward, Ward-Duer, Ashikhmin-Shirley, "
             f"Cook-Torrance, Beckmann) against the best mirror-direction one (modified Phong, Lafortune) "
             f"of each material.")):
        if not keys:
            continue
        figures = "".join(_figure(out, k, comparison_figure(found[k], colours), f"{found[k].title}: each material's "
                                  "errors, one side across and the other up (log-log); on the dashed diagonal the "
                                  "two are equal, above it the side across is better.") for k in keys)
        parts.append(f"""<h2>{_e(title)}</h2>
<p class="meta">{_e(intro)} The counts are materials where each side's error is lower; a ratio above 1
means the second side's error is the larger.</p>
{_comparisons_table([by_key[k] for k in keys], table_id, colours)}
{figures}""")
    materials = f"""<h2>Per material</h2>
<p class="meta">Each material's best model (lowest ranking error) and its errors{
    ", its category" if show_categories else ""}, and the best of Ngan et al.'s classic models where any was fitted,
with its ranking error over the best's (1: a classic model is the best).</p>
{_materials_table(numbers["materials"], pages, show_categories, colours)}"""
    return "\n".join(parts), materials


_CSS = """
body { font-family: system-ui, sans-serif; margin: 1.5em auto; max-width: 1200px; padding: 0 1em; color: #222; }
table { border-collapse: collapse; font-size: 0.9em; margin: 1em 0; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; } th { background: #f3f3f3; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
.dot { display: inline-block; width: 0.7em; height: 0.7em; border-radius: 50%; margin-right: 0.4em; }
figure { margin: 1.5em 0; } figure img { max-width: 100%; } figcaption, .meta { color: #555; font-size: 0.9em; }
""" + SCROLL_CSS

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
    the gallery.  ``out_dir/analysis/study.json`` holds the study sections' numbers
    (brdf_fit.library.study.study_numbers).  The page is static HTML (no script, nothing fetched): it works
    from file:// and offline.  Every name is HTML-escaped, every path URL-quoted."""
    out = pathlib.Path(out_dir)
    thumbnails, pages = dict(thumbnails or {}), dict(pages or {})
    figures = [_figure(out, name, draw(groups), caption) for name, draw, caption in _FIGURES]
    rows = analysis_table(groups)
    colours = library_colours(groups)       # one colour per model, as the figures draw them
    study, materials = _study(groups, out, pages, colours)
    nav = f'<nav><a href="{_url(index)}">all materials</a></nav>' if index else ""
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>Analysis: models across the library</title>
<style>{_CSS}</style></head><body>
{nav}<h1>Models across the library</h1>
<p class="meta">{len(groups)} materials, {len(rows)} models. Each material's best fit is the one of lowest
ranking error, M1 + {IMAGE_WEIGHT:g} &times; {IMAGE_TERM} (fitting/ranking.py); models are listed by the number
of materials they were fitted to, then by their median ranking error (<code>auto</code> refines a model only where
it may win, and a median over those materials alone would flatter it). M1 is the table error, the image error
what a viewer sees of a lit sphere
(docs/metrics.md); both are lower for better fits.</p>
{figures[0]}{figures[1]}
<h2>The models in numbers</h2>
<p class="meta">Medians and means over the materials each model was fitted to; the ratio to the winner is
taken over the materials it does not win.</p>
{_table(rows, colours)}
{figures[2]}
{study}
<h2>Poorly reproduced materials</h2>
<p class="meta">Materials whose best fit has an image error above {number(threshold)}, worst first.
The image error is the RMS over the sphere of &Delta;E<sub>ITP</sub> (ITU-R BT.2124) in units of
{ITP_UNIT:g} &Delta;E<sub>ITP</sub>, and &Delta;E<sub>ITP</sub> = 1 is about one just noticeable
difference (docs/metrics.md): the threshold is an RMS of {number(threshold * ITP_UNIT)} just noticeable
differences, a sphere visibly unlike the measured one.</p>
{_poor(groups, threshold, thumbnails, pages, colours)}
{materials}
</body></html>
"""
    path = out / "analysis.html"
    atomic_write_text(path, scrolling(page))
    _remove_unshown_figures(out / FIGURE_DIR, page)
    return path


def _remove_unshown_figures(folder, page):
    """Remove the PNGs of ``folder`` (FIGURE_DIR) the page does not show: an earlier page's
    figures (a category section or a comparison the library no longer has)."""
    prefix = _url(FIGURE_DIR) + "/"
    shown = {urllib.parse.unquote(src[len(prefix):]) for src in re.findall(r'<img src="([^"]+)"', page)
             if src.startswith(prefix)}
    for png in folder.glob("*.png"):
        if png.name not in shown:
            png.unlink(missing_ok=True)


__all__ = ["TABLE_COLUMNS", "number", "write_analysis"]
