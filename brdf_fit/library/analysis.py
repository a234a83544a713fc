"""The library's analysis page: the models compared across a whole measured database.

Ngan et al. 2005 fitted every model to every MERL material and compared the
models by the distribution of their errors; this module does the same for a
library's fits, with the toolkit's two errors (M1, the table; the image error,
what a viewer sees, docs/metrics.md) and its ranking error (``M1 + 0.3 x image``,
``fitting.ranking.ranking_error``: the one that picks each material's best fit).

Input everywhere: ``groups``, material name -> that material's FitResults (best
first, though nothing here relies on the order: each material's best is the
lowest ranking error, the first on ties).  A model fitted more than once to a
material counts with its best fit.  Figures are ``matplotlib.figure.Figure``
objects (no pyplot, no backend chosen; ``brdf_fit.report.plot_base.save``
writes them), so a notebook can draw them for any subset of a database:
``error_distributions`` (M1 and image error per model), ``wins`` (materials won,
and the ratio to the winner where a model loses), ``parameters`` (the best fits'
roughness against F0, coloured by albedo); ``poorly_reproduced`` lists the materials
whose best fit draws a visibly wrong sphere, ``analysis_table`` holds the numbers
the figures show, and ``write_analysis`` writes ``analysis.html`` and its PNGs.
Models are listed in the order of their median ranking error, best first.
"""

import dataclasses
import html
import math
import os
import pathlib
import statistics
import typing
import urllib.parse
from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

from fitting.ranking import IMAGE_WEIGHT, ranking_error
from fitting.result import atomic_write_text

from ..report.plot_base import LUMINANCE, model_color, save

if typing.TYPE_CHECKING:
    from fitting.result import FitResult

Groups = Mapping[str, Sequence["FitResult"]]

# The image error is the RMS over the sphere's pixels of Delta E_ITP (ITU-R BT.2124) in
# units of ITP_UNIT Delta E_ITP, and Delta E_ITP = 1 is about one just noticeable difference
# (docs/metrics.md, "Image error").  A fit whose pixels differ by ten JNDs in the RMS is
# visibly wrong at a glance: the threshold.  On the ten dev tables (docs/metrics.md, "ABC as
# a reference") the auto winners' median is 0.0150 (4.9 Delta E_ITP), only chrome's 0.063 is
# above it (a sharp core in a wide halo no lobe draws); of ggx+lambert's fits alum-bronze,
# black-oxidized-steel, chrome and gold-metallic-paint are (0.042-0.091), the rest not (<= 0.030).
NOTICEABLE_DELTA_E_ITP = 10.0
ITP_UNIT = 325.0       # = fitting.image_error.ITP_UNIT (not imported: it loads JAX); a test keeps them equal
IMAGE_ERROR_THRESHOLD = NOTICEABLE_DELTA_E_ITP / ITP_UNIT        # ~0.0308
FIGURE_DIR = "analysis"        # the page's PNGs, beside analysis.html
NUMBER_DIGITS = 4              # significant digits shown (the table's data-value keeps all)
SWATCH_ROWS = 25               # albedo swatches per column of the strip
F0_FLOOR = 0.005               # left edge of the log F0 axis (a dielectric of IOR 1.15)


# --- the numbers ----------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class _ModelStats:
    """One model across the materials it was fitted to."""

    model: str
    materials: list[str]
    ranking: list[float]
    m1: list[float]
    image: list[float]            # the fits with an image error only
    wins: int
    ratios: list[float]           # ranking error / the winner's, where it loses


def best_results(groups: Groups) -> dict[str, "FitResult"]:
    """Each material's best result: the lowest ranking error (the first on ties)."""
    return {m: min(rs, key=lambda r: ranking_error(r.errors)) for m, rs in groups.items() if rs}


def _by_model(groups):
    """model -> {material: the model's best result for that material}."""
    out: dict[str, dict[str, FitResult]] = {}
    for material, results in groups.items():
        for r in results:
            fits = out.setdefault(r.spec, {})
            if material not in fits or ranking_error(r.errors) < ranking_error(fits[material].errors):
                fits[material] = r
    return out


def _ratio(error, best):
    return error / best if best > 0 else 1.0 if error == 0 else math.inf


def _stats(groups: Groups) -> list[_ModelStats]:
    """Per model statistics, sorted by median ranking error (then name)."""
    best = best_results(groups)
    out = []
    for model, fits in _by_model(groups).items():
        losses = {m: r for m, r in fits.items() if best[m].spec != model}
        out.append(_ModelStats(
            model=model, materials=list(fits), ranking=[ranking_error(r.errors) for r in fits.values()],
            m1=[float(r.errors["m1"]) for r in fits.values()],
            image=[float(r.errors["image"]) for r in fits.values() if "image" in r.errors],
            wins=len(fits) - len(losses),
            ratios=[_ratio(ranking_error(r.errors), ranking_error(best[m].errors)) for m, r in losses.items()]))
    return sorted(out, key=lambda s: (statistics.median(s.ranking), s.model))


def _median(values):
    return statistics.median(values) if values else None


def analysis_table(groups: Groups) -> list[dict[str, object]]:
    """One row per model, in the figures' order: ``model``, ``materials`` (fitted),
    ``wins`` (materials where it ranks best), ``median_ranking`` (the sort key),
    ``median_m1``, ``mean_m1``, ``median_image`` (over fits with an image error;
    None without) and ``median_ratio`` (its ranking error over the winner's, over
    the materials it loses; None if it loses none)."""
    return [{"model": s.model, "materials": len(s.materials), "wins": s.wins,
             "median_ranking": statistics.median(s.ranking), "median_m1": statistics.median(s.m1),
             "mean_m1": statistics.fmean(s.m1), "median_image": _median(s.image),
             "median_ratio": _median(s.ratios)} for s in _stats(groups)]


def poorly_reproduced(groups: Groups, threshold: float = IMAGE_ERROR_THRESHOLD) -> list[tuple[str, "FitResult"]]:
    """(material, its best result) for every material whose best fit's image error
    is above ``threshold``, worst first.  The default, IMAGE_ERROR_THRESHOLD, is an
    RMS Delta E_ITP of 10 over the sphere (image error 10 / 325): ten just noticeable
    differences, a sphere visibly unlike the measured one (docs/metrics.md).  Best
    fits without an image error are not judged."""
    best = best_results(groups)
    bad = [(m, r) for m, r in best.items() if float(r.errors.get("image", -math.inf)) > threshold]
    return sorted(bad, key=lambda item: -float(item[1].errors["image"]))


# --- the figures ----------------------------------------------------------------------

def _empty(fig, message="no results"):
    fig.subplots().text(0.5, 0.5, message, ha="center", va="center")
    return fig


def _height(n):
    return 1.6 + 0.32 * max(n, 2)


def _log_if_wide(ax, values):
    values = np.asarray([v for v in values if np.isfinite(v) and v > 0])
    if values.size and values.max() / values.min() > 10:
        ax.set_xscale("log")           # labelled at 1, 2, 5 x 10^k as plain numbers
        ax.xaxis.set(major_locator=LogLocator(subs=(1, 2, 5)), major_formatter=FuncFormatter(lambda v, _: f"{v:g}"),
                     minor_formatter=NullFormatter())


def _boxes(ax, stats, values_of, label):
    """Horizontal box plots, one row per model (best at the top), with every value
    drawn over its box (a deterministic vertical spread, no outlier markers: the
    points are all there).  Boxes carry gid "box MODEL", points "points MODEL"."""
    drawn = []
    for row, s in enumerate(stats):
        values = [v for v in values_of(s) if np.isfinite(v)]
        if not values:
            continue
        colour = model_color(s.model)
        box = ax.boxplot([values], positions=[row], orientation="horizontal", widths=0.6, patch_artist=True,
                         showfliers=False, manage_ticks=False, medianprops={"color": colour, "lw": 2})
        box["boxes"][0].set(facecolor=colour + "33", edgecolor=colour, gid=f"box {s.model}")
        spread = np.linspace(-0.2, 0.2, len(values)) if len(values) > 1 else np.zeros(1)
        ax.scatter(values, row + spread, s=10, color=colour, edgecolors="none", zorder=3, gid=f"points {s.model}")
        drawn += values
    ax.set_yticks(range(len(stats)), [s.model for s in stats], fontsize=8)
    ax.set_ylim(len(stats) - 0.5, -0.5)
    _log_if_wide(ax, drawn)
    ax.set_xlabel(label)
    ax.grid(True, axis="x", which="both", alpha=0.3)


def error_distributions(groups: Groups, threshold: float = IMAGE_ERROR_THRESHOLD) -> Figure:
    """Per model, the distribution over materials of M1 (left) and of the image
    error (right): a box (quartiles, whiskers to 1.5 IQR) with every material's
    value as a point.  The dashed line is the poorly-reproduced threshold."""
    stats = _stats(groups)
    fig = Figure(figsize=(11, _height(len(stats))), layout="constrained")
    if not stats:
        return _empty(fig)
    left, right = fig.subplots(1, 2, sharey=True)
    _boxes(left, stats, lambda s: s.m1, "M1 (lower is better)")
    _boxes(right, stats, lambda s: s.image, "image error (RMS Delta E_ITP / 325, lower is better)")
    right.axvline(threshold, color="0.4", ls="--", lw=1)
    fig.suptitle(f"errors of each model over {len(groups)} materials (models by median "
                 f"M1 + {IMAGE_WEIGHT:g} x image error)", fontsize=10)
    return fig


def wins(groups: Groups) -> Figure:
    """Per model: how many materials it wins (lowest ranking error; bars, gid
    "wins MODEL"), and where it loses, its ranking error over the winner's
    (box and points, 1 = as good as the winner)."""
    stats = _stats(groups)
    fig = Figure(figsize=(11, _height(len(stats))), layout="constrained")
    if not stats:
        return _empty(fig)
    left, right = fig.subplots(1, 2, sharey=True, width_ratios=(1, 2))
    for row, s in enumerate(stats):
        left.barh(row, s.wins, color=model_color(s.model), gid=f"wins {s.model}")
        left.text(s.wins, row, f" {s.wins}/{len(s.materials)}", va="center", fontsize=7)
    left.set_xlabel("materials won (of those fitted)")
    left.set_xlim(0, max(1, max(s.wins for s in stats)) * 1.25)
    _boxes(right, stats, lambda s: s.ratios, "ranking error / the winner's, where it loses")
    right.axvline(1.0, color="0.4", ls="--", lw=1)
    fig.suptitle(f"wins and losses over {len(groups)} materials "
                 f"(ranking error M1 + {IMAGE_WEIGHT:g} x image error)", fontsize=10)
    return fig


def _scalar(value):
    """A parameter as one number: the luminance of [r, g, b], the value itself otherwise."""
    v = np.asarray(value, dtype=np.float64)
    return float(v @ LUMINANCE) if v.shape == (3,) else float(v)


def srgb(linear) -> np.ndarray:
    """Linear RGB (an albedo) -> clipped sRGB-encoded colour in [0, 1] (IEC 61966-2-1)."""
    x = np.clip(np.broadcast_to(np.asarray(linear, dtype=np.float64), (3,)), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


def parameters(groups: Groups) -> Figure:
    """Each material's best fit: roughness (perceptual) against F0 (the luminance of
    f0), points coloured by the diffuse albedo (clipped sRGB; grey without one),
    and a strip of the albedo colours labelled by material.  Fits without
    ``roughness`` and ``f0`` (the glTF family's metallic/base colour) are not drawn
    in the scatter (gid "best fits"); swatches (gid "swatch MATERIAL") show every
    best fit with an ``albedo``."""
    best = best_results(groups)
    points = [(m, _scalar(r.parameters["f0"]), _scalar(r.parameters["roughness"]),
               srgb(r.parameters["albedo"]) if "albedo" in r.parameters else np.full(3, 0.6))
              for m, r in best.items() if "f0" in r.parameters and "roughness" in r.parameters]
    swatches = [(m, srgb(r.parameters["albedo"])) for m, r in best.items() if "albedo" in r.parameters]
    columns, rows = max(1, math.ceil(len(swatches) / SWATCH_ROWS)), max(12, min(len(swatches), SWATCH_ROWS))
    fig = Figure(figsize=(6.5 + 2.4 * columns, 0.2 * rows + 1.5), layout="constrained")
    ax, strip = fig.subplots(1, 2, width_ratios=(6.5, 2.4 * columns))
    if points:
        f0 = np.maximum([p[1] for p in points], F0_FLOOR)
        ax.scatter(f0, [p[2] for p in points], c=np.array([p[3] for p in points]), s=40, edgecolors="0.2",
                   linewidths=0.6, zorder=3, gid="best fits")
        for m, x, y, _ in points if len(points) <= 25 else ():
            ax.annotate(m, (max(x, F0_FLOOR), y), xytext=(4, 3), textcoords="offset points", fontsize=6, color="0.3")
    ax.set(xscale="log", xlim=(F0_FLOOR, 1.0), ylim=(0.0, 1.0), xlabel=f"F0 (luminance of f0; below {F0_FLOOR:g} "
           f"drawn at {F0_FLOOR:g})", ylabel="roughness (perceptual; alpha = roughness^2)")
    ax.grid(True, alpha=0.3)
    ax.set_title(f"best fits with roughness and f0: {len(points)} of {len(best)} materials", fontsize=9)
    for k, (m, colour) in enumerate(swatches):
        col, row = divmod(k, SWATCH_ROWS)
        strip.add_patch(Rectangle((col, row + 0.1), 0.18, 0.8, facecolor=colour, edgecolor="0.5", lw=0.5,
                                  gid=f"swatch {m}"))
        strip.text(col + 0.22, row + 0.5, m if len(m) <= 28 else m[:27] + "...", va="center", fontsize=7)
    strip.set(xlim=(0, columns), ylim=(rows, 0))
    strip.axis("off")
    strip.set_title("diffuse albedo (sRGB)", fontsize=9)
    fig.suptitle("the best fit of each material", fontsize=10)
    return fig


# --- the page -------------------------------------------------------------------------

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


__all__ = ["IMAGE_ERROR_THRESHOLD", "best_results", "analysis_table", "poorly_reproduced", "error_distributions",
           "wins", "parameters", "srgb", "write_analysis"]
