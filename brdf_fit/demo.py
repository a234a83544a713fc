"""The demo: MERL-format stand-ins synthesised from published ABC fits.

Loew et al. 2012 ("BRDF models for accurate and efficient rendering of glossy
surfaces", ACM TOG 31(1)) fitted their ABC model to MERL materials:

    f = kD / pi + F_dielectric(ior, wi.h) A / (1 + B (1 - n.h))^C
                  * G_CT / (pi cos_i cos_o),

G_CT the Cook-Torrance V-groove masking min(1, 2 n.h n.v / v.h, 2 n.h n.l / v.h).
The parameters below are the published fits (kD RGB, A RGB, B, C, ior) as the
fitting issue quotes them.  The tables written from them are labelled as
synthesised stand-ins, not measurements.
"""

import os
import pathlib
from collections.abc import Iterable

import numpy as np
import numpy.typing as npt
from jaxtyping import Float

ABC_FITS = {
    "blue-acrylic": dict(kd=(0.011106, 0.035057, 0.104254), a=(1191.397, 1099.257, 1082.125),
                         b=255868.95, c=1.084736, ior=1.475061),
    "red-plastic": dict(kd=(0.268000, 0.044432, 0.010675), a=(1.081538, 1.045352, 1.037089),
                        b=34.117554, c=1.529797, ior=1.666450),
    "gold-metallic-paint": dict(kd=(0.009164, 0.005649, 0.000424), a=(1.685630, 1.147257, 0.418757),
                                b=53.738525, c=1.511730, ior=9.031934),
}
ABC_SOURCE = "synthesised from the published ABC fit (Loew et al. 2012); a stand-in, not a measurement"


def _fresnel_dielectric(c, eta):
    g = np.sqrt(np.maximum(eta * eta - 1.0 + c * c, 0.0))
    a = (g - c) / (g + c)
    b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
    return 0.5 * a * a * (1.0 + b * b)


def abc_brdf(wi: Float[np.ndarray, "n 3"], wo: Float[np.ndarray, "n 3"], kd: Float[npt.ArrayLike, "#3"], a: float,
             b: float, c: float, ior: float) -> Float[np.ndarray, "n 3"]:
    """The ABC model (numpy, float64): (N, 3) directions -> (N, 3) RGB in 1/sr."""
    h = wi + wo
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    nl, nv, nh = wi[:, 2], wo[:, 2], h[:, 2]
    vh = np.clip(np.sum(wo * h, axis=-1), 1e-9, 1.0)
    g_ct = np.minimum(1.0, np.minimum(2 * nh * nv / vh, 2 * nh * nl / vh))
    fresnel = _fresnel_dielectric(vh, ior)
    s = fresnel / (1.0 + b * (1.0 - nh)) ** c * g_ct / (np.pi * np.maximum(nl * nv, 1e-12))
    f = np.asarray(kd) / np.pi + np.asarray(a) * s[:, None]
    above = (nl > 0) & (nv > 0)
    return np.where(above[:, None], f, 0.0)


def write_standins(folder: str | os.PathLike[str], materials: Iterable[str] | None = None) -> list[pathlib.Path]:
    """Write <folder>/<material>.binary MERL tables of the ABC stand-ins; return the paths."""
    from data_loaders.merl import MERL_SHAPE, write_merl
    from fitting.synthetic import half_diff_grid

    wi, wo, _ = half_diff_grid(*MERL_SHAPE, 1)
    valid = (wi[:, 2] > 0) & (wo[:, 2] > 0)
    paths = []
    for name in materials or ABC_FITS:
        rgb = abc_brdf(wi, wo, **ABC_FITS[name])
        path = folder / f"{name}.binary"
        write_merl(path, rgb.reshape(MERL_SHAPE + (3,)), valid.reshape(MERL_SHAPE))
        paths.append(path)
    return paths
