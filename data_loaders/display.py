"""A measurement in a notebook: its facts as HTML and a lit sphere from its own table.

The sphere needs no renderer and no model: every pixel's BRDF comes from the
measurement's own lookup (``MeasuredBRDF.lookup``, the format's
interpolation), evaluated with numpy.  The scene, exactly:

- an orthographic view of a unit sphere along -z (viewer at +z, world +y up),
  ``size`` x ``size`` pixels, one sample at each pixel centre, no
  anti-aliasing; pixels whose centre lies outside the disc are transparent;
- the local frame of a pixel: normal n = (x, y, sqrt(1 - x^2 - y^2)), tangent
  t = normalize(+y x n), bitangent n x t (the convention of docs/models.md:
  n = +z, t = +x locally);
- the lights of ``LIGHTS``: directional, irradiance E (RGB) from direction l;
  radiance L = sum over lights of f(wi = l, wo = +z) E max(n . l, 0), in the
  local frame; negative or non-finite lookups count as 0;
- display: ``exposure`` x L, Reinhard's x / (1 + x) per channel, then the
  sRGB transfer function, rounded to 8 bits.  The exposure is a viewer's
  automatic one unless given (``viewer_exposure``): VIEWER_LEVEL over the
  99th percentile of the lit pixels' brightest channel, so a dark material
  is seen, not black (as the image error's viewer exposure, docs/metrics.md,
  but on the brightest channel rather than luminance: a saturated colour
  then keeps its hue through the per-channel curve).  A white (albedo 0.8)
  Lambertian sphere gets an exposure near 1.

``lit_sphere(measured, linear=True)`` returns L itself (float64, H x W x 3)
and the coverage mask, for checks against a closed form.
"""

import base64
import html
import typing
import weakref

import numpy as np

from jaxtyping import UInt8

from ._typing import ArrayLike, Bool, Float



class _Measured(typing.Protocol):
    """What the display reads of a data_loaders.MeasuredBRDF (not imported: it imports this module)."""

    def lookup(self, wi: Float[ArrayLike, "m 3"], wo: Float[ArrayLike, "m 3"]) -> Float[np.ndarray, "m c"]: ...

    def summary_dict(self) -> dict[str, object]: ...

#: a directional light: (direction towards the light, irradiance RGB)
Light = tuple[tuple[float, float, float], tuple[float, float, float]]

#: directional lights (direction towards the light, world frame; irradiance RGB):
#: a key light above left in front, and a dim fill from the right
LIGHTS = (((-0.45, 0.55, 0.70), (np.pi, np.pi, np.pi)),
          ((0.75, -0.15, 0.65), (0.25 * np.pi, 0.25 * np.pi, 0.25 * np.pi)))
SPHERE_SIZE = 160          # pixels, the notebook's sphere
PERCENTILE = 99.0          # of the lit pixels' brightest channel ...
VIEWER_LEVEL = 0.85        # ... brought here by the automatic exposure
_CACHE: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()   # measurement -> {size: PNG bytes}


def sphere_geometry(size: int) -> tuple[Float[np.ndarray, "h w 3"], Bool[np.ndarray, "h w"]]:
    """(normals (H, W, 3) in the world frame, mask (H, W)) of the pixel centres."""
    c = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    x, y = np.meshgrid(c, -c)                    # image rows run down, world +y up
    r2 = x * x + y * y
    mask = r2 < 1.0
    z = np.sqrt(np.clip(1.0 - r2, 0.0, None))
    return np.stack([x, y, z], axis=-1), mask


def _local(vectors, t, b, n):
    """World directions -> the pixels' local frames (rows of ``t``, ``b``, ``n``)."""
    return np.stack([np.sum(vectors * t, -1), np.sum(vectors * b, -1), np.sum(vectors * n, -1)], axis=-1)


def lit_sphere(measured: "_Measured", size: int = SPHERE_SIZE, *, lights: typing.Sequence[Light] = LIGHTS,
               exposure: float | None = None, linear: bool = False
               ) -> UInt8[np.ndarray, "h w 4"] | tuple[Float[np.ndarray, "h w 3"], Bool[np.ndarray, "h w"]]:
    """The measurement's lit sphere: uint8 RGBA (H, W, 4) after the display curve,
    or with ``linear`` (radiance float64 (H, W, 3), mask (H, W)) (module docstring)."""
    normals, mask = sphere_geometry(int(size))
    n = normals[mask]
    up = np.broadcast_to([0.0, 1.0, 0.0], n.shape)
    t = np.cross(up, n)
    t /= np.maximum(np.linalg.norm(t, axis=-1, keepdims=True), 1e-12)
    b = np.cross(n, t)
    wo = _local(np.broadcast_to([0.0, 0.0, 1.0], n.shape), t, b, n)
    radiance = np.zeros((n.shape[0], 3))
    for direction, irradiance in lights:
        l = np.asarray(direction, np.float64)
        l = l / np.linalg.norm(l)
        cos = n @ l
        lit = cos > 0.0
        if not lit.any():
            continue
        wi = _local(np.broadcast_to(l, n.shape)[lit], t[lit], b[lit], n[lit])
        f = np.asarray(measured.lookup(wi, wo[lit]), np.float64)
        if f.shape[1] != 3:                       # a channel selection: shown grey
            f = np.repeat(f.mean(axis=1, keepdims=True), 3, axis=1)
        f = np.where(np.isfinite(f) & (f > 0.0), f, 0.0)
        radiance[lit] += f * np.asarray(irradiance, np.float64) * cos[lit, None]
    out = np.zeros(mask.shape + (3,))
    out[mask] = radiance
    if linear:
        return out, mask
    if exposure is None:
        exposure = viewer_exposure(out[mask])
    return np.dstack([display_curve(out, exposure), np.where(mask, 255, 0).astype(np.uint8)])


def viewer_exposure(radiance: Float[ArrayLike, "p 3"]) -> float:
    """VIEWER_LEVEL / the PERCENTILE of the brightest channel of the lit pixels (> 0); 1 if none is lit."""
    y = np.max(np.asarray(radiance, np.float64), axis=-1)
    y = y[y > 0.0]
    level = float(np.percentile(y, PERCENTILE)) if y.size else 0.0
    return VIEWER_LEVEL / level if np.isfinite(level) and level > 0.0 else 1.0


def display_curve(radiance: Float[ArrayLike, "*shape"], exposure: float = 1.0) -> UInt8[np.ndarray, "*shape"]:
    """exposure x L -> Reinhard x / (1 + x) -> sRGB -> uint8."""
    x = np.clip(exposure * np.asarray(radiance, np.float64), 0.0, None)
    x = x / (1.0 + x)
    s = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)
    return np.round(np.clip(s, 0.0, 1.0) * 255.0).astype(np.uint8)


def png_bytes(image: UInt8[ArrayLike, "h w c"]) -> bytes:
    """uint8 (H, W, 3 | 4) -> PNG file bytes (Pillow, imported here)."""
    import io

    from PIL import Image
    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(image)).save(buf, format="PNG")
    return buf.getvalue()


def measured_png(measured: "_Measured", size: int = SPHERE_SIZE) -> bytes:
    """The lit sphere as PNG bytes (cached per measurement and size)."""
    cached = _CACHE.setdefault(measured, {})
    if size not in cached:
        cached[size] = png_bytes(lit_sphere(measured, size))
    return cached[size]


def _fmt(x) -> str:
    return f"{x:.4g}"


def measured_html(measured: "_Measured", size: int = SPHERE_SIZE) -> str:
    """Format, material, file, sample counts, value ranges and the lit sphere, as HTML."""
    d = measured.summary_dict()
    e = html.escape
    n, nv = d["samples"], d["valid"]
    rows = [("material", e(str(d["material"])) + (f" ({e(d['description'])})" if d["description"] else "")),
            ("format", e(str(d["format"]))), ("file", f"<code>{e(str(d['file']))}</code>"),
            ("samples", f"{n:,} ({nv:,} valid, {100.0 * nv / max(n, 1):.1f} %)"),
            ("isotropic", "yes" if d["isotropic"] else "no"), ("units", e(str(d["units"])))]
    for name, c in d["channels_per_sr"].items():
        rows.append((f"{name} (1/sr)", "no valid sample" if c is None else
                     f"{_fmt(c['min'])} .. {_fmt(c['max'])} (median {_fmt(c['median'])})"))
    if d["history"]:
        rows.append(("history", e("; ".join(d["history"]))))
    table = "".join(f"<tr><th style=\"text-align:left\">{k}</th><td style=\"text-align:left\">{v}</td></tr>"
                    for k, v in rows)
    try:
        png = base64.b64encode(measured_png(measured, size)).decode("ascii")
        sphere = (f"<figure style=\"margin:0\"><img src=\"data:image/png;base64,{png}\" width=\"{size}\" "
                  f"height=\"{size}\" alt=\"lit sphere of {e(str(d['material']))}\"><figcaption "
                  "style=\"font-size:smaller\">lit sphere from the table's own lookup, auto exposure"
                  "</figcaption></figure>")
    except Exception as err:           # a display never raises: say why the sphere is missing
        sphere = f"<p>lit sphere not shown: {e(type(err).__name__)}: {e(str(err))}</p>"
    return ("<div class=\"brdf-measured\" style=\"display:flex;gap:1em;align-items:flex-start\">"
            f"{sphere}<table><caption style=\"text-align:left\"><b>MeasuredBRDF</b> "
            f"{e(str(d['material']))}</caption>{table}</table></div>")
