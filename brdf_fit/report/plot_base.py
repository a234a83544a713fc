"""What every analysis figure of ``brdf_fit.report.plots`` shares: model colours, the
plotted scalar (luminance or one RGB channel), measured and fitted values at
direction pairs, log-axis limits, and PNG output.

Colours: the models of one figure or page get distinct colours (``model_colors``:
each its usual colour, ``model_color``, unless an earlier model of the same list has it),
the measurement is black.
Nothing here selects a matplotlib backend or touches pyplot: figures are
``matplotlib.figure.Figure`` objects, rendered by Agg when saved.
"""

import functools
import io
import os
import typing
import zlib

import numpy as np

if typing.TYPE_CHECKING:
    from matplotlib.figure import Figure

    from brdf.spec import ModelSpec

MEASURED_COLOR = "black"
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])      # Rec. 709 / sRGB primaries
CHANNELS = ("R", "G", "B")
FLOOR = 1e-4                                          # 1/sr: lower edge of log axes
MAX_LABEL = 60                                        # characters of a name in a title (a 255-character
                                                      # material would squeeze the axes to nothing)
CEILING = 1e30                                        # 1/sr: upper edge (a table in wrong units; no overflow)

# Fixed colours for the models the toolkit names (tab10 / tab20 entries), so a
# model keeps its colour across figures, reports and notebooks.
_FIXED = {
    "ggx+lambert": "#1f77b4", "ggx+burley": "#ff7f0e", "ggx+frostbite": "#2ca02c",
    "ggx+cod_wwii": "#d62728", "ggx+oren_nayar": "#9467bd", "gltf": "#8c564b", "gltf+ior": "#a0522d",
    "ggx+lambert+ms": "#17becf", "ggx+lambert+clearcoat": "#e377c2",
    "ggx+lambert+ms+clearcoat": "#7f7f7f", "ggx+burley+ms": "#bcbd22", "ggx+frostbite+ms": "#637939",
    "ggx+cod_wwii+ms": "#843c39", "ggx+cod_wwii+clearcoat": "#7b4173", "gltf+clearcoat": "#393b79",
    "gltf+specular": "#8c6d31", "ggx_aniso+lambert": "#3182bd",
}
_PALETTE = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
            "#7f7f7f", "#bcbd22", "#17becf", "#393b79", "#637939", "#8c6d31", "#843c39",
            "#7b4173", "#3182bd", "#e6550d", "#31a354", "#756bb1", "#636363"]


def model_color(model: "ModelSpec | str") -> str:
    """The usual colour of a model string: fixed for the common ones, else a stable hash
    (two models may share it: a figure takes ``model_colors`` of its models)."""
    key = str(model)
    if key in _FIXED:
        return _FIXED[key]
    return _PALETTE[zlib.crc32(key.encode()) % len(_PALETTE)]


def model_colors(models: "typing.Iterable[ModelSpec | str]") -> dict[str, str]:
    """{model string: colour} for the models of one figure or page, distinct while there are
    no more models than palette colours.  Each model takes its usual colour (``model_color``)
    unless another of the list has it first -- the models of a fixed colour (``_FIXED``)
    before those of a hashed one, each kind in the list's order -- and the others, in order,
    the palette's colours none has.  The same list always gets the same colours;
    ashikhmin_shirley+lambert and ashikhmin_shirley_scaled+lambert hash to one colour, the
    second takes another; ggx+lambert keeps its blue beside a model that hashes to it."""
    keys = list(dict.fromkeys(str(m) for m in models))
    usual: dict[str, str] = {}
    for key in [k for k in keys if k in _FIXED] + [k for k in keys if k not in _FIXED]:
        if model_color(key) not in usual.values():
            usual[key] = model_color(key)
    free = [c for c in _PALETTE if c not in usual.values()]
    return {key: usual.get(key) or (free.pop(0) if free else model_color(key)) for key in keys}


def _label(result):
    return str(result.spec)


def _results(results):
    if results is None:
        return []
    return list(results) if isinstance(results, (list, tuple)) else [results]


def _scalar(rgb, channel):
    """RGB (..., 3) -> the plotted scalar: luminance, or one channel (0, 1, 2 or 'r'...)."""
    rgb = np.asarray(rgb, dtype=np.float64)
    if channel in (None, "luminance", "Y"):
        return rgb @ LUMINANCE
    if isinstance(channel, str):
        channel = "rgb".index(channel.lower())
    return rgb[..., int(channel)]


def _channel_name(channel):
    if channel in (None, "luminance", "Y"):
        return "luminance"
    return CHANNELS[channel if isinstance(channel, int) else "rgb".index(channel.lower())]


def _fitted(result, wi, wo):
    from fitting.fit import evaluate_result
    return evaluate_result(result, wi, wo)


def _evaluate_sets(measured, results, sets, channel):
    """Measured and fitted scalars for several (wi, wo) sets, one model
    evaluation per result (evaluate_result compiles once per call)."""
    sizes = np.cumsum([len(a) for a, _ in sets])[:-1]
    wi = np.concatenate([a for a, _ in sets])
    wo = np.concatenate([b for _, b in sets])
    meas = np.split(_scalar(_measured(measured, wi, wo), channel), sizes) if measured is not None else None
    fits = [np.split(_scalar(_fitted(r, wi, wo), channel), sizes) for r in results]
    return meas, fits


def _measured(measured, wi, wo):
    rgb = np.asarray(measured.lookup(wi, wo), dtype=np.float64)
    if rgb.shape[-1] != 3:        # a channel-selected MeasuredBRDF: repeat its channel
        rgb = np.repeat(rgb[..., :1], 3, axis=-1)
    return rgb


def short_label(text: object, limit: int = MAX_LABEL) -> str:
    """A material name for a title or a tick label, as data: runs of white space (tabs,
    newlines) as one space, a character no installed font draws as "?" (else matplotlib
    warns, and draws a box), at most ``limit`` characters.  Draw it with
    ``parse_math=False``: a name with two ``$`` is no mathtext.  Idempotent."""
    text = "".join(c if _drawable(c) else "?" for c in " ".join(str(text).split()))
    return text if len(text) <= limit else text[:limit - 3] + "..."


@functools.cache
def _drawable(char: str) -> bool:
    """Whether a font of matplotlib's sans-serif list (those installed) has a glyph for ``char``."""
    if " " <= char <= "~":
        return True
    return char.isprintable() and any(font.get_char_index(ord(char)) for font in _fonts())


@functools.cache
def _fonts():
    """The installed fonts of matplotlib's sans-serif list, in its order (its fallback chain)."""
    from matplotlib import font_manager, ft2font, rcParams
    installed = {f.name for f in font_manager.fontManager.ttflist}
    paths = [font_manager.findfont(font_manager.FontProperties(family=name), fallback_to_default=False)
             for name in rcParams["font.sans-serif"] if name in installed]
    paths = paths or [font_manager.findfont(font_manager.FontProperties())]
    return [ft2font.FT2Font(path) for path in dict.fromkeys(paths)]


def _title(measured, results):
    if measured is not None:
        return short_label(measured.material)
    results = _results(results)
    return short_label(results[0].material) if results else ""


def _log_limits(arrays, floor=FLOOR):
    vals = np.concatenate([np.ravel(a) for a in arrays if a is not None and np.size(a)])
    vals = vals[np.isfinite(vals) & (vals > floor)]
    if vals.size == 0:
        return floor, 1.0
    hi = min(float(np.max(vals)) * 1.5, CEILING)
    lo = max(floor, float(np.min(vals)) / 1.5)
    if hi / lo < 10:
        lo = hi / 10
    return lo, hi


def _image_limits(finite):
    """(vmin, vmax) of the log10 BRDF images' colour scale: the 1st percentile of the finite
    values to their largest, at least one decade wide (as ``_log_limits`` keeps the curves'
    axes), widened about its middle.  A nearly constant table (a Lambertian) got a scale of a
    millionth of a decade: its colour bar's ticks needed an offset text ("1e-7-7.98179e-1")
    wider than the panel beside it, and the layout squeezed the images until their own tick
    labels ran together (issue 62)."""
    if not finite.size:
        return -3.0, 1.0
    vmin, vmax = float(np.percentile(finite, 1)), float(np.max(finite))
    widen = max(0.0, 1.0 - (vmax - vmin)) / 2
    return vmin - widen, vmax + widen


def _colour_bar(fig, image, ax, label):
    """``fig.colorbar`` beside ``ax`` with plain tick labels: no offset text above the bar
    (matplotlib's ScalarFormatter adds one for a range narrow against its values)."""
    bar = fig.colorbar(image, ax=ax, label=label)
    bar.ax.yaxis.get_major_formatter().set_useOffset(False)
    return bar


def to_png(fig: "Figure", dpi: int = 100) -> bytes:
    """The figure as PNG bytes (Agg), e.g. for ``IPython.display.Image``."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


def save(fig: "Figure", path: str | os.PathLike[str], dpi: int = 100) -> str | os.PathLike[str]:
    """Write the figure as a PNG file (atomically) and release it; returns the path."""
    from data_loaders.measured import write_file_atomic
    write_file_atomic(path, to_png(fig, dpi))
    fig.clear()
    return path
