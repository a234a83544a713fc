"""Tone mapping, sRGB encoding, false colour and PNG writing (Pillow).

Tone curves (scene-referred linear RGB in, display-referred [0, 1] out):
- ``reinhard``: x / (1 + x) (Reinhard et al. 2002), or the extended form with
  a white point (x (1 + x / w^2) / (1 + x)).
- ``uncharted2``: John Hable's filmic curve (GDC 2010, "Uncharted 2: HDR
  Lighting"), A..F = 0.15, 0.50, 0.10, 0.20, 0.02, 0.30, white 11.2, with his
  exposure bias of 2.
- ``aces``: Stephen Hill's fit of the ACES RRT + sRGB ODT (BakingLab,
  ``ACES.hlsl``): sRGB -> AP1-ish input matrix, rational fit, output matrix.
- ``aces_narkowicz``: Krzysztof Narkowicz's 2015 one-line luminance fit.
- ``pbr_neutral``: the Khronos PBR Neutral tone map (Khronos 3D Commerce, 2024):
  colours below 0.76 pass unchanged, brighter ones are compressed towards white.
  The image error's and the gallery's tone map (fitting.image_error.displayed,
  docs/metrics.md): the report's and ``brdf-fit render``'s pictures use it too, so
  a material looks the same everywhere the toolkit shows it (docs/colour.md).
- ``linear``: clamp only.
"""

import os

import numpy as np

TONEMAPS = ("aces", "aces_narkowicz", "uncharted2", "reinhard", "pbr_neutral", "linear")
# Khronos PBR Neutral: where compression starts, the offset below it and the desaturation of
# compressed colours (the specification's constants)
NEUTRAL_START, NEUTRAL_OFFSET, NEUTRAL_DESATURATION = 0.8 - 0.04, 0.04, 0.15

# Hill's ACES fit (sRGB primaries in, sRGB primaries out).
ACES_INPUT = np.array([[0.59719, 0.35458, 0.04823],
                       [0.07600, 0.90834, 0.01566],
                       [0.02840, 0.13383, 0.83777]])
ACES_OUTPUT = np.array([[1.60475, -0.53108, -0.07367],
                        [-0.10208, 1.10813, -0.00605],
                        [-0.00327, -0.07276, 1.07602]])

# Hable's Uncharted 2 filmic curve.
HABLE_A, HABLE_B, HABLE_C, HABLE_D, HABLE_E, HABLE_F = 0.15, 0.50, 0.10, 0.20, 0.02, 0.30
HABLE_WHITE = 11.2
HABLE_EXPOSURE_BIAS = 2.0
TONEMAP_CAP = 1e30      # radiance held here before tone mapping: display white long before, no overflow

# Rec. 709 luminance weights of linear sRGB.
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def _hable(x):
    a, b, c, d, e, f = HABLE_A, HABLE_B, HABLE_C, HABLE_D, HABLE_E, HABLE_F
    return (x * (a * x + c * b) + d * e) / (x * (a * x + b) + d * f) - e / f


def _pbr_neutral(x):
    """Khronos PBR Neutral of linear RGB (..., 3) >= 0 (the reference GLSL, in numpy)."""
    low = np.min(x, axis=-1, keepdims=True)
    x = x - np.where(low < 2 * NEUTRAL_OFFSET, low - low * low / (4 * NEUTRAL_OFFSET), NEUTRAL_OFFSET)
    peak = np.max(x, axis=-1, keepdims=True)
    d = 1.0 - NEUTRAL_START
    pc = np.maximum(peak, NEUTRAL_START)
    new_peak = 1.0 - d * d / (pc + d - NEUTRAL_START)
    g = 1.0 - 1.0 / (NEUTRAL_DESATURATION * (pc - new_peak) + 1.0)
    compressed = x * (new_peak / pc) * (1.0 - g) + new_peak * g
    return np.where(peak < NEUTRAL_START, x, compressed)


def tonemap(rgb, method="aces", exposure=1.0, white=None):
    """Linear HDR (..., 3) -> display-linear (..., 3) in [0, 1]."""
    x = np.asarray(rgb, dtype=np.float64)
    if not np.isfinite(x).all():        # an overflowed render (a table in wrong units): inf is white
        x = np.nan_to_num(x, nan=0.0, posinf=TONEMAP_CAP, neginf=0.0)
    x = np.clip(x * exposure, 0.0, TONEMAP_CAP)
    if method == "linear":
        y = x
    elif method == "reinhard":
        y = x / (1.0 + x) if white is None else x * (1.0 + x / (white * white)) / (1.0 + x)
    elif method == "uncharted2":
        y = _hable(HABLE_EXPOSURE_BIAS * x) / _hable(HABLE_WHITE)
    elif method == "aces":
        v = x @ ACES_INPUT.T
        v = (v * (v + 0.0245786) - 0.000090537) / (v * (0.983729 * v + 0.4329510) + 0.238081)
        y = v @ ACES_OUTPUT.T
    elif method == "aces_narkowicz":
        y = (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)
    elif method == "pbr_neutral":
        y = _pbr_neutral(x)
    else:
        raise ValueError(f"unknown tone map {method!r}; use one of {', '.join(TONEMAPS)}")
    return np.clip(y, 0.0, 1.0)


def srgb_encode(linear):
    """IEC 61966-2-1 transfer function: linear [0, 1] -> encoded [0, 1]."""
    x = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def srgb_decode(encoded):
    """Inverse of srgb_encode."""
    x = np.clip(np.asarray(encoded, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def to_uint8(display_linear):
    """Display-linear [0, 1] -> sRGB-encoded uint8."""
    return np.round(srgb_encode(display_linear) * 255.0).astype(np.uint8)


def finish(rgb, tonemap_method="aces", exposure=1.0):
    """Linear HDR -> tone-mapped sRGB uint8 (H, W, 3).

    A render with its coverage in a fourth channel (shaders.render.render_hdr) is exposed by
    ``exposure`` on the object and at 1 on the background, blended by the coverage along the
    silhouette: a dark material brought up by the viewer's exposure leaves the sky behind it
    as every other preview shows it (docs/colour.md, "One colour path")."""
    rgb = np.asarray(rgb)
    if rgb.shape[-1] == 4 and exposure != 1.0:
        cover = np.clip(np.nan_to_num(rgb[..., 3:4].astype(np.float64)), 0.0, 1.0)
        # an overflowed render (inf: tonemap draws it white) exposed by a factor near 0 must not become nan
        colour = np.nan_to_num(rgb[..., :3].astype(np.float64), nan=0.0, posinf=TONEMAP_CAP, neginf=0.0)
        return to_uint8(tonemap(colour * (1.0 + (exposure - 1.0) * cover), tonemap_method))
    return to_uint8(tonemap(rgb[..., :3], tonemap_method, exposure))


def luminance(rgb):
    return np.asarray(rgb, dtype=np.float64)[..., :3] @ LUMINANCE


def false_colour(values, vmax=1.0, cmap="inferno", mask=None):
    """Scalar map -> uint8 RGB through a matplotlib colour map; masked-out pixels black."""
    from matplotlib import colormaps
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):    # inf / huge: the top colour
        t = np.clip(np.nan_to_num(np.asarray(values, dtype=np.float64) / vmax, nan=0.0), 0.0, 1.0)
    rgb = colormaps[cmap](t)[..., :3]
    if mask is not None:
        rgb = np.where(np.asarray(mask)[..., None], rgb, 0.0)
    return np.round(rgb * 255.0).astype(np.uint8)


def png_bytes(image):
    """uint8 (H, W, 3) or (H, W, 4) or (H, W) -> PNG file bytes (8-bit, Pillow's encoder)."""
    import io
    from PIL import Image
    img = np.asarray(image)
    if img.dtype != np.uint8:
        raise ValueError(f"PNG writer wants uint8, got {img.dtype}")
    if img.ndim == 3 and img.shape[2] == 1:
        img = img[..., 0]
    if not (img.ndim == 2 or (img.ndim == 3 and img.shape[2] in (3, 4))):
        raise ValueError(f"PNG writer wants 1, 3 or 4 channels, got shape {img.shape}")
    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(img)).save(buf, format="PNG", compress_level=6)
    return buf.getvalue()


def write_png(path, image):
    """Write uint8 (H, W, 3|4) as PNG, atomically (temporary file + rename)."""
    from data_loaders.measured import write_file_atomic
    path = os.fspath(path)
    write_file_atomic(path, png_bytes(image))
    return path
