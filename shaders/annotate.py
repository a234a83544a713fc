"""Labels and a colour bar on comparison images (Pillow), so a saved preview explains itself.

``labelled_comparison`` takes the three panels of ``render_comparison``
(measured | fitted | difference) and returns one image with a title above
each panel and, under the difference panel, the colour bar of its scale: the
colour map from 0 to ``diff_scale`` with ticks in percent of the measured
luminance.
"""

import numpy as np

from . import image

HEADER = 16          # pixels of title above the panels
FOOTER = 30          # pixels under the panels: colour bar and its ticks
BAR_HEIGHT = 8
TEXT = (20, 20, 20)
BACKGROUND = 255


def _font(size):
    from PIL import ImageFont
    try:
        return ImageFont.load_default(size=size)
    except TypeError:                  # Pillow < 10.1: the fixed bitmap font
        return ImageFont.load_default()


def _fit_text(draw, text, width, font):
    """``text``, cut with an ellipsis until it fits in ``width`` pixels."""
    if draw.textlength(text, font=font) <= width:
        return text
    while text and draw.textlength(text + "...", font=font) > width:
        text = text[:-1]
    return text + "..."


def colour_bar(width, vmax, cmap="inferno"):
    """uint8 (BAR_HEIGHT, width, 3): the false-colour map from 0 (left) to ``vmax`` (right)."""
    ramp = np.linspace(0.0, vmax, width)[None, :].repeat(BAR_HEIGHT, axis=0)
    return image.false_colour(ramp, vmax, cmap)


def labelled_comparison(panels, titles, diff_scale, gap=4, cmap="inferno"):
    """Three uint8 (H, W, 3) panels -> one uint8 image with titles and the difference's colour bar."""
    from PIL import Image, ImageDraw
    h, w = panels[0].shape[:2]
    width = len(panels) * w + (len(panels) - 1) * gap
    canvas = np.full((HEADER + h + FOOTER, width, 3), BACKGROUND, np.uint8)
    for k, panel in enumerate(panels):
        x = k * (w + gap)
        canvas[HEADER:HEADER + h, x:x + w] = panel
    bar_x = (len(panels) - 1) * (w + gap) + 4
    bar_w = w - 8
    canvas[HEADER + h + 3:HEADER + h + 3 + BAR_HEIGHT, bar_x:bar_x + bar_w] = colour_bar(bar_w, diff_scale, cmap)
    picture = Image.fromarray(canvas)
    draw = ImageDraw.Draw(picture)
    font = _font(11)
    for k, title in enumerate(titles):
        text = _fit_text(draw, title, w - 4, font)
        x = k * (w + gap) + (w - draw.textlength(text, font=font)) / 2
        draw.text((x, 2), text, fill=TEXT, font=font)
    tick_y = HEADER + h + 3 + BAR_HEIGHT + 2
    for frac in (0.0, 0.5, 1.0):
        label = f"{100 * frac * diff_scale:.0f} %"
        tx = bar_x + frac * (bar_w - 1) - frac * draw.textlength(label, font=font)
        draw.text((tx, tick_y), label, fill=TEXT, font=font)
    return np.asarray(picture)
