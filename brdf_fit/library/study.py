"""The analysis page's study (issue 54): which model reproduces each material and each
category, GGX against Beckmann, and half-vector against mirror-direction lobes.

Ngan et al. 2005 answered three questions of the classic models over MERL: which model
fits which kind of material, whether the microfacet distribution matters, and whether a
lobe around the half vector beats one around the mirror direction.  This module asks
them of a library's fits, with the toolkit's errors (M1, the image error and the ranking
error ``M1 + 0.3 x image``, brdf_fit.library.analysis).  Input is ``groups`` as there,
and optionally ``categories`` (material -> category; brdf_fit.library.categories by
default).  A paired comparison takes only the materials where both sides were fitted:
a model screened out by ``auto`` on a material is not a loss there.

Numbers: ``material_rows`` (per material), ``category_rows`` (per category),
``comparisons`` / ``comparison_summary`` (the pairs); ``study_numbers`` gathers them for
``analysis/study.json``.  Figures (matplotlib Figures, no pyplot): ``category_heatmap``
and ``comparison_figure``.
"""

import collections
import dataclasses
import math
import statistics
import typing

import numpy as np
from matplotlib.figure import Figure

from brdf.model import UnknownModelError, model_string, parse_model
from fitting.auto import CLASSIC_FAMILY
from fitting.ranking import ranking_error

from ..report.plot_base import model_color, model_colors, short_label
from .analysis import Groups, _by_model, _empty, _median, _ratio, _stats, best_results, plain_log_ticks
from .categories import OTHER, material_categories

if typing.TYPE_CHECKING:
    from fitting.result import FitResult

# Where a specular lobe peaks, by the ModelSpec's ndf field (brdf/specular.py, beckmann.py,
# lobes.py): around the half vector h -- the microfacet NDFs and the lobes written in n.h
# (Blinn-Phong, Ward, Ward-Duer, Ashikhmin-Shirley; Blinn-Phong with the microfacet factor) -- or
# around the mirror direction of wi: modified Phong (r.wo, also with the factor) and Lafortune's
# generalised cosine (the mirror lobe at Cz = 1/sqrt(3)).
# The lobe declarations do not say it, so it is said here, once.
HALF_VECTOR, MIRROR = "half-vector", "mirror-direction"
LOBE_DIRECTION = {**dict.fromkeys(("ggx", "ggx_aniso", "beckmann", "beckmann_aniso", "blinn_phong", "ward",
                                   "ward_aniso", "ward_duer", "ward_duer_aniso", "ashikhmin_shirley",
                                   "ashikhmin_shirley_aniso", "ashikhmin_shirley_scaled", "blinn_phong_mf"),
                                  HALF_VECTOR),
                  **dict.fromkeys(("phong", "phong_mf", "lafortune", "lafortune2", "lafortune3"), MIRROR)}
# The direct pair: the same (n + 2)/(2 pi) cos^n lobe and exponent, around h or around r
DIRECT_PAIR = ("blinn_phong+lambert", "phong+lambert")
# ... and the same pair with the microfacet factor 1 / (4 (wi.h) max(n.wi, n.wo)) (brdf/lobes.py)
MICROFACET_PAIR = ("blinn_phong_mf+lambert", "phong_mf+lambert")
HEAT_RATIO_MAX = 3.0       # the heat map's colours run from a category's best median (1x) to 3x it
LABELLED_POINTS = 25       # a comparison's points carry material names up to this many
LABEL_CHARS = 20


def _rank(r):
    return ranking_error(r.errors)


def _m1(r):
    return float(r.errors["m1"])


def _image(r):
    return float(r.errors["image"]) if "image" in r.errors else None


def lobe_direction(model: str) -> str | None:
    """HALF_VECTOR or MIRROR for a model string's specular lobe (None for a model of
    one's own, or a string this toolkit does not know)."""
    try:
        spec = parse_model(model)
    except UnknownModelError:
        return None
    return None if spec.own is not None else LOBE_DIRECTION.get(spec.ndf)


def _categories(groups, categories):
    return dict(categories) if categories is not None else material_categories(groups)


def category_order(categories: typing.Mapping[str, str]) -> list[str]:
    """The categories present, by name, OTHER last."""
    return sorted(set(categories.values()), key=lambda c: (c == OTHER, c))


# --- per material and per category -------------------------------------------------------

def material_rows(groups: Groups, categories: typing.Mapping[str, str] | None = None) -> list[dict]:
    """One row per material, by category then name: ``material``, ``category``, ``best``
    (the model of lowest ranking error), its ``ranking``, ``m1`` and ``image`` (None
    without), ``best_classic`` (the best of fitting.auto.CLASSIC_FAMILY; None where none
    was fitted) and ``classic_ratio`` (its ranking error over the best's; 1 where it is
    the best)."""
    categories = _categories(groups, categories)
    rows = []
    for material, r in best_results(groups).items():
        classic = [x for x in groups[material] if x.spec in CLASSIC_FAMILY]
        c = min(classic, key=_rank) if classic else None
        rows.append({"material": material, "category": categories.get(material, OTHER), "best": r.spec,
                     "ranking": _rank(r), "m1": _m1(r), "image": _image(r), "best_classic": c.spec if c else None,
                     "classic_ratio": _ratio(_rank(c), _rank(r)) if c else None})
    return sorted(rows, key=lambda row: (row["category"] == OTHER, row["category"], row["material"]))


def _category_fits(groups, categories):
    """category -> (its materials, {model: [the model's best fit on each material fitted]})."""
    by_model, best = _by_model(groups), best_results(groups)
    out = {}
    for cat in category_order({m: categories.get(m, OTHER) for m in best}):
        materials = [m for m in best if categories.get(m, OTHER) == cat]
        fits = {model: [f[m] for m in materials if m in f] for model, f in by_model.items()}
        out[cat] = materials, {model: rs for model, rs in fits.items() if rs}
    return out


def category_rows(groups: Groups, categories: typing.Mapping[str, str] | None = None) -> list[dict]:
    """One row per category (by name, OTHER last): ``category``, ``materials``,
    ``most_wins`` (the models winning most of its materials, several on a tie) with
    ``wins``; ``best_median``, the model of lowest median ranking error over the
    category's materials among the models fitted to the most of them (all, where any
    model was: ``auto`` refines a model only where it may win, so a median over fewer
    materials is a flattering one), ``over`` (that many), and its ``median_ranking``,
    ``median_m1`` and ``median_image`` (None without image errors)."""
    categories = _categories(groups, categories)
    best = best_results(groups)
    rows = []
    for cat, (materials, fits) in _category_fits(groups, categories).items():
        wins = collections.Counter(best[m].spec for m in materials)
        top = max(wins.values())
        most = max(len(rs) for rs in fits.values())
        model, rs = min(((k, rs) for k, rs in fits.items() if len(rs) == most),
                        key=lambda kv: (statistics.median(_rank(r) for r in kv[1]), kv[0]))
        rows.append({"category": cat, "materials": len(materials),
                     "most_wins": sorted(k for k, n in wins.items() if n == top), "wins": top,
                     "best_median": model, "over": most,
                     "median_ranking": statistics.median(_rank(r) for r in rs),
                     "median_m1": statistics.median(_m1(r) for r in rs),
                     "median_image": _median([_image(r) for r in rs if _image(r) is not None])})
    return rows


def category_medians(groups: Groups, categories: typing.Mapping[str, str] | None = None):
    """(models in the analysis page's order, categories in category_order, medians, fitted):
    ``medians[i, j]`` is model i's median ranking error over the materials of category j
    it was fitted to (NaN for none), ``fitted[i, j]`` how many those are."""
    categories = _categories(groups, categories)
    models = [s.model for s in _stats(groups)]
    fits = _category_fits(groups, categories)
    medians = np.array([[statistics.median(_rank(r) for r in fits[c][1][m]) if m in fits[c][1] else np.nan
                         for c in fits] for m in models]).reshape(len(models), len(fits))
    fitted = np.array([[len(fits[c][1].get(m, ())) for c in fits] for m in models], dtype=int).reshape(medians.shape)
    return models, list(fits), medians, fitted


def category_heatmap(groups: Groups, categories: typing.Mapping[str, str] | None = None) -> Figure:
    """Median ranking error of each model (rows, the analysis page's order) over each
    category's materials (columns; category_medians), as text in each cell ("k/n" below
    it where the model was fitted to k of the n materials); the colour is the median over
    the column's lowest (white 1x to dark HEAT_RATIO_MAX x, log scale; gid "heatmap")."""
    categories = _categories(groups, categories)
    models, cats, medians, fitted = category_medians(groups, categories)
    sizes = collections.Counter(categories.get(m, OTHER) for m in best_results(groups))
    fig = Figure(figsize=(2.2 + 1.05 * max(len(cats), 2), 1.4 + 0.36 * max(len(models), 2)), layout="constrained")
    if not models:
        return _empty(fig)
    with np.errstate(invalid="ignore", divide="ignore"):
        shade = np.log(medians / np.nanmin(medians, axis=0)) / math.log(HEAT_RATIO_MAX)
    ax = fig.subplots()
    image = ax.imshow(np.clip(shade, 0.0, 1.0), cmap="Reds", vmin=0.0, vmax=1.25, aspect="auto")
    image.set_gid("heatmap")
    for (i, j), median in np.ndenumerate(medians):
        if np.isfinite(median):
            k, n = fitted[i, j], sizes[cats[j]]
            ax.text(j, i, f"{median:.3g}" + ("" if k == n else f"\n{k}/{n}"), ha="center", va="center", fontsize=7,
                    gid=f"cell {i} {j}")
    ax.set_xticks(range(len(cats)), [f"{short_label(c, LABEL_CHARS)} ({sizes[c]})" for c in cats],
                  rotation=30, ha="right", fontsize=8, parse_math=False)
    ax.set_yticks(range(len(models)), models, fontsize=8)
    colours = model_colors(models)      # the analysis page's (analysis.library_colours)
    for label, m in zip(ax.get_yticklabels(), models):
        label.set_color(colours[m])
    ax.set_title(f"median ranking error per category (colour: over the category's lowest, 1x to "
                 f"{HEAT_RATIO_MAX:g}x)", fontsize=9)
    return fig


# --- paired comparisons --------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class Comparison:
    """Two sides, each one model or a group of models (a material's best fit among the
    group's stands for it), over the materials where both were fitted."""

    key: str                       # a file name's stem and the JSON's key
    title: str
    left: str                      # the sides' labels
    right: str
    left_models: tuple[str, ...]
    right_models: tuple[str, ...]
    pairs: tuple[tuple[str, "FitResult", "FitResult"], ...]      # (material, left's fit, right's fit)


def _side(results, models):
    fits = [r for r in results if r.spec in models]
    return min(fits, key=_rank) if fits else None


def compare(groups: Groups, key: str, title: str, left: tuple[str, str | tuple[str, ...]],
            right: tuple[str, str | tuple[str, ...]]) -> Comparison:
    """A Comparison of ``left`` = (label, a model or models) against ``right`` over ``groups``."""
    (left_label, lm), (right_label, rm) = left, right
    lm, rm = (lm,) if isinstance(lm, str) else tuple(lm), (rm,) if isinstance(rm, str) else tuple(rm)
    pairs = tuple((m, a, b) for m, rs in groups.items()
                  if (a := _side(rs, lm)) is not None and (b := _side(rs, rm)) is not None)
    return Comparison(key, title, left_label, right_label, lm, rm, pairs)


def ndf_pairs(groups: Groups) -> list[tuple[str, str]]:
    """(GGX model, Beckmann model) for every model string of ``groups`` whose NDF is GGX
    and whose twin with Beckmann's NDF (everything else equal) is also in ``groups``."""
    present = {r.spec for rs in groups.values() for r in rs}
    pairs = []
    for model in sorted(present):
        try:
            spec = parse_model(model)
            if spec.own is None and spec.ndf.startswith("ggx"):
                twin = model_string(dataclasses.replace(spec, ndf=spec.ndf.replace("ggx", "beckmann", 1)))
                if twin in present:
                    pairs.append((model, twin))
        except UnknownModelError:      # a model of one's own not registered here, gltf, +ms: no twin
            continue
    return pairs


def comparisons(groups: Groups) -> list[Comparison]:
    """The page's comparisons that have at least one material: GGX against Beckmann per
    ndf_pairs pair; the direct half-vector / mirror pair (DIRECT_PAIR) and the same with the
    microfacet factor (MICROFACET_PAIR); the best
    half-vector classic model against the best mirror-direction one (CLASSIC_FAMILY)."""
    out = [compare(groups, f"ggx-beckmann-{k}", f"GGX against Beckmann: {g} and {b}", ("GGX", g), ("Beckmann", b))
           for k, (g, b) in enumerate(ndf_pairs(groups), 1)]
    for key, (half, mirror) in (("half-mirror-pair", DIRECT_PAIR), ("half-mirror-mf-pair", MICROFACET_PAIR)):
        out.append(compare(groups, key, f"Half vector against mirror direction: {half} and {mirror}",
                           (HALF_VECTOR, half), (MIRROR, mirror)))
    sides = {d: [m for m in CLASSIC_FAMILY if lobe_direction(m) == d] for d in (HALF_VECTOR, MIRROR)}
    out.append(compare(groups, "half-mirror-best", "Half vector against mirror direction: the best classic "
                       "model of each", (HALF_VECTOR, sides[HALF_VECTOR]), (MIRROR, sides[MIRROR])))
    return [c for c in out if c.pairs]


ERRORS = (("ranking", _rank), ("m1", _m1), ("image", _image))


def comparison_summary(c: Comparison) -> dict:
    """``materials`` (paired); per error ("ranking", "m1", "image": over the pairs where
    both have it) ``materials``, ``left_better``, ``right_better``, ``ties``;
    ``median_ratio_m1`` and ``median_ratio_image``, right's error over left's (None
    without pairs); ``rows``: each material's models and errors."""
    out = {"key": c.key, "title": c.title, "left": c.left, "right": c.right, "left_models": list(c.left_models),
           "right_models": list(c.right_models), "materials": len(c.pairs)}
    for name, error in ERRORS:
        both = [(error(a), error(b)) for _, a, b in c.pairs if error(a) is not None and error(b) is not None]
        out[name] = {"materials": len(both), "left_better": sum(x < y for x, y in both),
                     "right_better": sum(y < x for x, y in both), "ties": sum(x == y for x, y in both)}
        if name != "ranking":
            out[f"median_ratio_{name}"] = _median([_ratio(y, x) for x, y in both])
    out["rows"] = [{"material": m, "left_model": a.spec, "right_model": b.spec,
                    **{f"{side}_{name}": error(r) for name, error in ERRORS for side, r in (("left", a), ("right", b))}}
                   for m, a, b in c.pairs]
    return out


def comparison_figure(c: Comparison, colours: typing.Mapping[str, str] | None = None) -> Figure:
    """Each paired material as a point, left's error across, right's up (log-log), M1
    on the left and the image error on the right (gids "pairs m1", "pairs image"); the
    diagonal is a tie, points above it are materials the left side reproduces better.
    The points take the left model's colour (of ``colours``, the page's, when given)."""
    fig = Figure(figsize=(10, 4.6), layout="constrained")
    colour = ((colours or {}).get(c.left_models[0]) or model_color(c.left_models[0])
              if len(c.left_models) == 1 else "0.3")
    for ax, (name, error), label in zip(fig.subplots(1, 2), ERRORS[1:], ("M1", "image error")):
        points = [(m, error(a), error(b)) for m, a, b in c.pairs if error(a) is not None and error(b) is not None]
        points = [p for p in points if p[1] > 0 and p[2] > 0 and math.isfinite(p[1]) and math.isfinite(p[2])]
        ax.set(xscale="log", yscale="log", xlabel=f"{label}: {c.left}", ylabel=f"{label}: {c.right}")
        if not points:
            ax.text(0.5, 0.5, f"no pair with both {label}s", ha="center", va="center", transform=ax.transAxes)
            continue
        x, y = np.array([p[1] for p in points]), np.array([p[2] for p in points])
        ax.scatter(x, y, s=18, color=colour, edgecolors="none", zorder=3, gid=f"pairs {name}")
        lo, hi = min(x.min(), y.min()) / 1.3, max(x.max(), y.max()) * 1.3
        ax.plot([lo, hi], [lo, hi], color="0.5", ls="--", lw=1)
        ax.set(xlim=(lo, hi), ylim=(lo, hi), aspect="equal")
        plain_log_ticks(ax.xaxis)
        plain_log_ticks(ax.yaxis)
        for m, px, py in points if len(points) <= LABELLED_POINTS else ():
            ax.annotate(short_label(m, LABEL_CHARS), (px, py), xytext=(3, 2), textcoords="offset points",
                        fontsize=6, color="0.35", parse_math=False)
        above = int(np.sum(y > x))
        ax.set_title(f"{label}: {c.left} better on {above}, {c.right} on {int(np.sum(y < x))} "
                     f"of {len(points)}", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle(c.title, fontsize=10)
    return fig


def study_numbers(groups: Groups, categories: typing.Mapping[str, str] | None = None) -> dict:
    """What the study sections show, for a script (``analysis/study.json``): ``materials``
    (material_rows), ``categories`` (category_rows), ``comparisons`` (comparison_summary
    of each of comparisons)."""
    categories = _categories(groups, categories)
    return {"materials": material_rows(groups, categories), "categories": category_rows(groups, categories),
            "comparisons": [comparison_summary(c) for c in comparisons(groups)]}


__all__ = ["HALF_VECTOR", "MIRROR", "LOBE_DIRECTION", "DIRECT_PAIR", "MICROFACET_PAIR", "Comparison", "lobe_direction",
           "category_order", "material_rows", "category_rows", "category_medians", "category_heatmap", "compare",
           "ndf_pairs", "comparisons", "comparison_summary", "comparison_figure", "study_numbers"]
