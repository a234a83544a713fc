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
the figures show; brdf_fit.library.analysis_page writes ``analysis.html`` and its PNGs.
Models are listed by the number of materials they were fitted to, most first, then by
their median ranking error, best first: ``auto`` refines a model only where it may win,
so a model fitted to few materials has its median over those alone, which flatters it
(``_order``).
"""

import dataclasses
import math
import statistics
import typing
from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

from fitting.ranking import IMAGE_TERM, IMAGE_WEIGHT, ranking_error, ranking_key

from ..report.plot_base import LUMINANCE, model_colors, short_label

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
SWATCH_ROWS = 25               # albedo swatches per column of the strip
SWATCH_LABEL = 28             # characters of a material's name beside its swatch or point
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
    """Each material's best result: fitting.ranking.ranked's first (the report's and the gallery's best)."""
    return {m: min(rs, key=ranking_key) for m, rs in groups.items() if rs}


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


def _order(stats: _ModelStats) -> tuple:
    """The models' order: fitted to more materials first, then by median ranking error, then name."""
    return -len(stats.materials), statistics.median(stats.ranking), stats.model


def _stats(groups: Groups) -> list[_ModelStats]:
    """Per model statistics, in the models' order (``_order``)."""
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
    return sorted(out, key=_order)


def library_colours(groups: Groups) -> dict[str, str]:
    """{model: colour} on the analysis page and in its figures: ``model_colors`` of the
    models in the page's order (``_stats``), so that no two of them share a colour."""
    return model_colors(s.model for s in _stats(groups))


def _median(values):
    return statistics.median(values) if values else None


def analysis_table(groups: Groups) -> list[dict[str, object]]:
    """One row per model, in the figures' order (``_order``): ``model``, ``materials`` (fitted),
    ``wins`` (materials where it ranks best), ``median_ranking``,
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


def plain_log_ticks(axis):
    """A log axis labelled at 1, 2, 5 x 10^k as plain numbers (0.02, not 2 x 10^-2)."""
    axis.set(major_locator=LogLocator(subs=(1, 2, 5)), major_formatter=FuncFormatter(lambda v, _: f"{v:g}"),
             minor_formatter=NullFormatter())


def _log_if_wide(ax, values):
    values = np.asarray([v for v in values if np.isfinite(v) and v > 0])
    if values.size and values.max() / values.min() > 10:
        ax.set_xscale("log")
        plain_log_ticks(ax.xaxis)


def _boxes(ax, stats, values_of, label):
    """Horizontal box plots, one row per model (best at the top), with every value
    drawn over its box (a deterministic vertical spread, no outlier markers: the
    points are all there).  Boxes carry gid "box MODEL", points "points MODEL"."""
    drawn = []
    colours = model_colors(s.model for s in stats)     # every model of the page: library_colours
    for row, s in enumerate(stats):
        values = [v for v in values_of(s) if np.isfinite(v)]
        if not values:
            continue
        colour = colours[s.model]
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
                 f"M1 + {IMAGE_WEIGHT:g} x {IMAGE_TERM})", fontsize=10)
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
    colours = model_colors(s.model for s in stats)
    for row, s in enumerate(stats):
        left.barh(row, s.wins, color=colours[s.model], gid=f"wins {s.model}")
        left.text(s.wins, row, f" {s.wins}/{len(s.materials)}", va="center", fontsize=7)
    left.set_xlabel("materials won (of those fitted)")
    left.set_xlim(0, max(1, max(s.wins for s in stats)) * 1.25)
    _boxes(right, stats, lambda s: s.ratios, "ranking error / the winner's, where it loses")
    right.axvline(1.0, color="0.4", ls="--", lw=1)
    fig.suptitle(f"wins and losses over {len(groups)} materials "
                 f"(ranking error M1 + {IMAGE_WEIGHT:g} x {IMAGE_TERM})", fontsize=10)
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
            ax.annotate(short_label(m, SWATCH_LABEL), (max(x, F0_FLOOR), y), xytext=(4, 3),
                        textcoords="offset points", fontsize=6, color="0.3", parse_math=False)
    ax.set(xscale="log", xlim=(F0_FLOOR, 1.0), ylim=(0.0, 1.0), xlabel=f"F0 (luminance of f0; below {F0_FLOOR:g} "
           f"drawn at {F0_FLOOR:g})", ylabel="roughness (perceptual; alpha = roughness^2)")
    ax.grid(True, alpha=0.3)
    ax.set_title(f"best fits with roughness and f0: {len(points)} of {len(best)} materials", fontsize=9)
    for k, (m, colour) in enumerate(swatches):
        col, row = divmod(k, SWATCH_ROWS)
        strip.add_patch(Rectangle((col, row + 0.1), 0.18, 0.8, facecolor=colour, edgecolor="0.5", lw=0.5,
                                  gid=f"swatch {m}"))
        strip.text(col + 0.22, row + 0.5, short_label(m, SWATCH_LABEL), va="center", fontsize=7,
                   parse_math=False)
    strip.set(xlim=(0, columns), ylim=(rows, 0))
    strip.axis("off")
    strip.set_title("diffuse albedo (sRGB)", fontsize=9)
    fig.suptitle("the best fit of each material", fontsize=10)
    return fig


__all__ = ["IMAGE_ERROR_THRESHOLD", "ITP_UNIT", "best_results", "analysis_table", "poorly_reproduced",
           "error_distributions", "wins", "parameters", "srgb"]
