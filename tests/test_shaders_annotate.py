"""Titles and the colour bar on comparison images (no GL needed)."""

import numpy as np

from shaders import annotate, image


def _panels(h=96, w=128):
    rng = np.random.default_rng(0)
    return [rng.integers(0, 256, (h, w, 3), dtype=np.uint8) for _ in range(3)]


def test_layout_keeps_the_panels_and_adds_titles_and_the_scale():
    panels, gap, h, w = _panels(), 4, 96, 128
    out = annotate.labelled_comparison(panels, ["measured", "fitted: ggx+lambert+clearcoat+f90", "difference"],
                                       diff_scale=0.5, gap=gap)
    assert out.shape == (annotate.HEADER + h + annotate.FOOTER, 3 * w + 2 * gap, 3) and out.dtype == np.uint8
    for k, panel in enumerate(panels):               # the renders themselves are untouched
        x = k * (w + gap)
        np.testing.assert_array_equal(out[annotate.HEADER:annotate.HEADER + h, x:x + w], panel)
    header = out[:annotate.HEADER]
    for k in range(3):                               # a title (dark text) over every panel ...
        assert (header[:, k * (w + gap):k * (w + gap) + w] < 100).any(), k
    for k in (1, 2):                                 # ... that stays inside its panel's width
        assert (header[:, k * (w + gap) - gap:k * (w + gap)] == annotate.BACKGROUND).all()


def test_colour_bar_is_the_difference_colour_map_from_zero_to_the_scale():
    panels, gap, h, w = _panels(), 4, 96, 128
    out = annotate.labelled_comparison(panels, ["a", "b", "c"], diff_scale=0.5, gap=gap)
    y = annotate.HEADER + h + 3
    bar_x, bar_w = 2 * (w + gap) + 4, w - 8
    bar = out[y:y + annotate.BAR_HEIGHT, bar_x:bar_x + bar_w]
    np.testing.assert_array_equal(bar, annotate.colour_bar(bar_w, 0.5))
    np.testing.assert_array_equal(bar[0, 0], image.false_colour(np.array([0.0]), 0.5)[0])
    np.testing.assert_array_equal(bar[0, -1], image.false_colour(np.array([0.5]), 0.5)[0])
    ticks = out[y + annotate.BAR_HEIGHT + 1:, bar_x - 4:bar_x + bar_w + 4]
    assert (ticks < 100).any()                       # the tick labels are drawn
    # nothing under the measured and fitted panels
    assert (out[annotate.HEADER + h:, :2 * (w + gap) - gap] == annotate.BACKGROUND).all()
