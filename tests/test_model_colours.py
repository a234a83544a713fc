"""Distinct colours for the models of one figure or page (issue 60: ashikhmin_shirley+lambert
and ashikhmin_shirley_scaled+lambert, ward+lambert and beckmann+lambert+vgroove+f90 were
drawn in one colour).  The premise is checked first: each pair's usual colours (a hash into
the palette) are equal; then every figure and page that shows both gives them two colours,
the same list always the same ones, and a model keeps its usual colour where nothing before
it collides."""

import re

import pytest
from matplotlib.colors import to_hex

from brdf_fit.library import analysis
from brdf_fit.report import plot_base, plots
from brdf_fit.report.html import index_page
from fitting.result import FitResult

PAIRS = [("ashikhmin_shirley+lambert", "ashikhmin_shirley_scaled+lambert"),
         ("ward+lambert", "beckmann+lambert+vgroove+f90")]


def _result(model, material, m1, image=0.01):
    return FitResult(spec=model, parameters={}, errors={"m1": m1, "image": image}, optimizer={},
                     provenance={"material": material})


@pytest.mark.parametrize("pair", PAIRS)
def test_a_colliding_pair_gets_two_colours(pair):
    a, b = pair
    assert plot_base.model_color(a) == plot_base.model_color(b)      # the premise: one hash colour
    colours = plot_base.model_colors([a, b])
    assert colours[a] == plot_base.model_color(a) and colours[b] != colours[a]
    assert plot_base.model_colors([a, b]) == colours                  # stable
    # a fixed colour later in the list is not taken by the collided model
    with_ggx = plot_base.model_colors([a, b, "ggx+lambert"])
    assert with_ggx["ggx+lambert"] == "#1f77b4" and len(set(with_ggx.values())) == 3


def test_a_fixed_colour_stays_with_its_model():
    """own:wide hashes to ggx+lambert's fixed blue; listed first (the better fit first, as a
    report lists them), it still leaves the blue to ggx+lambert."""
    assert plot_base.model_color("own:wide") == plot_base.model_color("ggx+lambert") == "#1f77b4"
    colours = plot_base.model_colors(["own:wide", "ggx+lambert"])
    assert colours["ggx+lambert"] == "#1f77b4" and colours["own:wide"] != "#1f77b4"


def test_as_many_colours_as_the_palette_holds():
    models = [f"own:m{k}" for k in range(len(plot_base._PALETTE))]
    colours = plot_base.model_colors(models)
    assert len(set(colours.values())) == len(models)
    # past the palette, the colours repeat rather than fail
    more = plot_base.model_colors(models + ["own:extra"])
    assert more["own:extra"] in plot_base._PALETTE


def test_error_bars_draw_each_model_in_its_own_colour():
    results = [_result(m, mat, 0.01 * (k + 1)) for mat in ("red", "blue") for pair in PAIRS for k, m in
               enumerate(pair)]
    fig = plots.error_bars(results)
    drawn = {}
    for patch in fig.axes[0].patches:
        drawn.setdefault(patch.get_label(), set()).add(to_hex(patch.get_facecolor()))
    models = [m for pair in PAIRS for m in pair]
    legend = {t.get_text(): to_hex(h.get_facecolor()) for t, h in
              zip(fig.axes[0].get_legend().get_texts(), fig.axes[0].get_legend().legend_handles)}
    assert set(legend) == set(models) and len(set(legend.values())) == 4
    assert legend == plots.model_colors(models)


def test_the_report_index_swatches_are_the_bars_colours():
    groups = {mat: [(f"{mat}.{m}.json", _result(m, mat, 0.01 * (k + 1))) for k, m in enumerate(PAIRS[0])]
              for mat in ("red", "blue")}
    page = index_page(groups, {"red": "red.html", "blue": "blue.html"}, "index-errors.png", "brdf-fit report")
    swatches = re.findall(r'class="swatch" style="background:(#[0-9a-f]{6})"></span><code>([^<]+)</code>', page)
    assert dict((m, c) for c, m in swatches) == plots.model_colors(r.spec for rows in groups.values()
                                                                    for _, r in rows)
    assert len({c for c, _ in swatches}) == 2


def test_the_library_page_and_its_figures_share_distinct_colours():
    groups = {mat: [_result(m, mat, 0.01 * (k + 1)) for k, m in enumerate(PAIRS[1])] for mat in ("red", "blue")}
    colours = analysis.library_colours(groups)
    assert len(set(colours.values())) == 2
    fig = analysis.wins(groups)
    bars = {p.get_gid()[5:]: to_hex(p.get_facecolor()) for p in fig.axes[0].patches
            if (p.get_gid() or "").startswith("wins ")}
    assert bars == colours
