"""Spectral samples -> linear sRGB, and the spectral variant of RGL tensor files.

The convention (docs/colour.md says the same, with the reasons):

- observer: CIE 1931 2-degree standard colorimetric observer, 1 nm table
  360-830 nm (``cie_tables``);
- illuminant: CIE standard illuminant D65 (5 nm table, linearly interpolated
  to 1 nm); the spectral values are treated as reflectance factors (here:
  BRDF values, 1/sr) seen under D65;
- method: the trapezoid rule over the file's own sample wavelengths, on
  the product D65 x CMF x spectrum, with D65 and the CMFs interpolated
  linearly at those wavelengths (CIE 015's summation, at the file's sampling
  instead of 1 or 5 nm). Only 360-830 nm counts (the CMFs are 0 outside):
  samples outside it are dropped and, where the samples straddle 360 or
  830 nm, the spectrum is interpolated linearly there and the ends added as
  nodes; a file that stops short of 360 or 830 nm has its spectrum held at
  its first / last value over the 1 nm grid beyond (as Mitsuba's spectral
  interpolant of a ``measured`` BSDF does);
- normalisation: per channel, as ASTM E308 does for its tables of weights:
  X = X_w * sum_k q_k S(l_k) xbar(l_k) R(l_k) / sum_k q_k S(l_k) xbar(l_k)
  (q_k the trapezoid weights, l_k the nodes above; likewise Y, Z), where
  (X_w, 1, Z_w) is the D65 white point of the full 1 nm tables (trapezoid
  over 360-830 nm, Y = 1): a perfect white reflector (R = 1) gets exactly
  that white point, Y = 1, whatever the file's sampling;
- XYZ -> linear sRGB: the IEC 61966-2-1:1999 matrix (4 decimals, D65 white,
  no chromatic adaptation). The perfect white reflector maps to
  (1.00001, 1.00008, 0.99983) (the published matrix is rounded), not exactly 1.

Files must cover at least 400-700 nm with samples at most 10 nm apart there
(the trapezoid sum is then within about 1e-3 of the integral for smooth spectra).

Everything is linear in the spectrum, so the conversion is one (3, n) matrix
of the file's n wavelengths (:func:`srgb_matrix`); applying it to every
spectral entry of a table equals converting the spectrum the table
interpolates at any point (the RGL interpolation is linear too).
"""

import os

import numpy as np

from . import cie_tables
from ._typing import ArrayLike, Float
from .errors import MeasuredDataError

# IEC 61966-2-1:1999 (sRGB), XYZ (D65, Y = 1) -> linear sRGB.
SRGB_FROM_XYZ = np.array([[3.2406, -1.5372, -0.4986],
                          [-0.9689, 1.8758, 0.0415],
                          [0.0557, -0.2040, 1.0570]])

# A spectral file must cover at least this range (nm): outside it lie 0.04 % of
# the D65-weighted y-bar, 0.2 % of x-bar and 0.3 % of z-bar (there the
# spectrum is held at its end values if the file stops short).
REQUIRED_RANGE_NM = (400.0, 700.0)
MAX_STEP_NM = 10.0                       # largest sample spacing allowed inside that range
MAX_WAVELENGTHS = 4096                   # RGL spectral files have a few hundred at most


def cmf_grid() -> tuple[Float[np.ndarray, "471"], Float[np.ndarray, "471 3"], Float[np.ndarray, "471"]]:
    """(wavelengths (471,) nm, cmf (471, 3) x-bar y-bar z-bar, D65 (471,)) on the 1 nm grid."""
    lam = cie_tables.CMF_START_NM + cie_tables.CMF_STEP_NM * np.arange(len(cie_tables.CIE1931_Y),
                                                                        dtype=np.float64)
    cmf = np.stack([cie_tables.CIE1931_X, cie_tables.CIE1931_Y, cie_tables.CIE1931_Z], axis=1)
    d65_lam = cie_tables.D65_START_NM + cie_tables.D65_STEP_NM * np.arange(len(cie_tables.CIE_D65))
    d65 = np.interp(lam, d65_lam, np.asarray(cie_tables.CIE_D65, dtype=np.float64))
    return lam, cmf.astype(np.float64), d65


def white_point() -> Float[np.ndarray, "3"]:
    """XYZ (3,) of a perfect white reflector under D65, Y = 1 (trapezoid over the 1 nm tables)."""
    lam, cmf, d65 = cmf_grid()
    w = np.ones_like(lam)
    w[[0, -1]] = 0.5
    xyz = (cmf * (w * d65)[:, None]).sum(axis=0)
    return xyz / xyz[1]


def xyz_matrix(wavelengths: Float[ArrayLike, " n"]) -> Float[np.ndarray, "3 n"]:
    """(3, n): XYZ (the D65 white point, Y = 1, for a perfect white reflector) of a
    spectrum sampled at ``wavelengths`` (strictly increasing, nm), by the
    module's method: trapezoid over the sample wavelengths clipped to
    360-830 nm, the spectrum held at its end values over the 1 nm grid beyond
    the samples, each channel normalised to the white point.
    """
    wl = np.asarray(wavelengths, dtype=np.float64)
    if wl.ndim != 1 or wl.shape[0] < 1 or not np.all(np.diff(wl) > 0):
        raise ValueError("wavelengths must be a strictly increasing 1-D array")
    lam, cmf, d65 = cmf_grid()
    lo, hi = lam[0], lam[-1]
    nodes = np.unique(np.concatenate([
        wl[(wl >= lo) & (wl <= hi)],                       # the samples inside the CMF range
        lam[(lam < wl[0]) | (lam > wl[-1])],               # held spectrum beyond the samples
        [x for x in (lo, hi) if wl[0] < x < wl[-1]]]))     # CMF range ends between samples
    step = np.diff(nodes)
    q = np.zeros_like(nodes)
    q[:-1] += 0.5 * step
    q[1:] += 0.5 * step
    s = np.interp(nodes, lam, d65) * q
    weighted = np.stack([np.interp(nodes, lam, cmf[:, c]) for c in range(3)], axis=1) * s[:, None]
    # the spectrum at each node: linear interpolation between samples k and k + 1,
    # held at the end values (clipped fraction); its weights go to those two samples
    n = wl.shape[0]
    out = np.zeros((n + 1, 3))                             # row n: a spare for n == 1
    k = np.clip(np.searchsorted(wl, nodes, side="right") - 1, 0, max(n - 2, 0))
    frac = np.clip((nodes - wl[k]) / (wl[k + 1] - wl[k]), 0.0, 1.0) if n > 1 else np.zeros_like(nodes)
    np.add.at(out, k, weighted * (1.0 - frac)[:, None])
    np.add.at(out, k + 1, weighted * frac[:, None])
    return out[:n].T * (white_point() / weighted.sum(axis=0))[:, None]


def srgb_matrix(wavelengths: Float[ArrayLike, " n"]) -> Float[np.ndarray, "3 n"]:
    """(3, n): linear sRGB of a spectrum sampled at ``wavelengths`` (see the module docstring)."""
    return SRGB_FROM_XYZ @ xyz_matrix(wavelengths)


def spectrum_to_srgb(wavelengths: Float[ArrayLike, " n"],
                     values: Float[ArrayLike, "*batch n"]) -> Float[np.ndarray, "*batch 3"]:
    """Linear sRGB (..., 3) of spectra ``values`` (..., n) sampled at ``wavelengths`` (n,) nm."""
    return np.asarray(values, dtype=np.float64) @ srgb_matrix(wavelengths).T


# ---- RGL spectral tensor files (``*_spec.bsdf``) ----------------------------------------

def is_spectral(fields: dict[str, np.ndarray]) -> bool:
    """A tensor file of the spectral RGL variant (``spectra`` + ``wavelengths``, no ``rgb``)."""
    return "rgb" not in fields and ("spectra" in fields or "wavelengths" in fields)


def check_wavelengths(path: str | os.PathLike[str], wavelengths: np.ndarray) -> Float[np.ndarray, " n"]:
    """The ``wavelengths`` field as float64 nm, or MeasuredDataError saying what is wrong."""
    wl = wavelengths
    if wl.ndim != 1 or wl.dtype != np.dtype("<f4"):
        raise MeasuredDataError(path, f"inconsistent RGL spectral file: wavelengths must be f32[n], "
                                      f"got {wl.dtype}{list(wl.shape)}")
    n = wl.shape[0]
    if not 2 <= n <= MAX_WAVELENGTHS:
        raise MeasuredDataError(path, f"RGL spectral file has {n:,} wavelengths; between 2 and "
                                      f"{MAX_WAVELENGTHS} are supported")
    wl = wl.astype(np.float64)
    if not np.all(np.isfinite(wl)):
        raise MeasuredDataError(path, "field 'wavelengths' has NaN or inf values")
    if not np.all(np.diff(wl) > 0):
        raise MeasuredDataError(path, "inconsistent RGL spectral file: wavelengths must be strictly increasing")
    lo, hi = REQUIRED_RANGE_NM
    if wl[0] > lo or wl[-1] < hi:
        raise MeasuredDataError(path, f"RGL spectral file covers {wl[0]:g}-{wl[-1]:g} nm; converting to "
                                      f"RGB needs at least {lo:g}-{hi:g} nm")
    inside = wl[np.searchsorted(wl, lo, side="right") - 1:np.searchsorted(wl, hi, side="left") + 1]
    gap = int(np.argmax(np.diff(inside)))
    if inside[gap + 1] - inside[gap] > MAX_STEP_NM:
        raise MeasuredDataError(path, f"RGL spectral file has no sample between {inside[gap]:g} and "
                                      f"{inside[gap + 1]:g} nm; converting to RGB needs samples at most "
                                      f"{MAX_STEP_NM:g} nm apart over {lo:g}-{hi:g} nm")
    return wl


def rgl_spectral_to_rgb(path: str | os.PathLike[str],
                        fields: dict[str, np.ndarray]) -> tuple[dict[str, np.ndarray], Float[np.ndarray, " n"]]:
    """Fields of a spectral RGL file with its ``spectra`` converted to an ``rgb`` field.

    ``spectra`` f32[phi_i, theta_i, n, N, N] at ``wavelengths`` f32[n] (nm)
    becomes ``rgb`` f32[phi_i, theta_i, 3, N, N] (linear sRGB, module
    convention); every other field is passed on unchanged and checked with
    the RGB ones afterwards. Returns (fields, wavelengths as float64).
    Raises MeasuredDataError for a missing, mis-shaped or non-finite
    ``spectra`` / ``wavelengths`` field. Only views of the file's bytes exist
    before the checks; the result is 3/n the size of ``spectra``.
    """
    missing = [n for n in ("spectra", "wavelengths", "phi_i", "theta_i") if n not in fields]
    if missing:
        raise MeasuredDataError(path, f"spectral tensor file lacks the field(s) {', '.join(missing)} "
                                      "needed for an RGL BRDF")
    wl = check_wavelengths(path, fields["wavelengths"])
    spectra = fields["spectra"]
    expected = (fields["phi_i"].shape[:1] + fields["theta_i"].shape[:1] + (wl.shape[0],))
    if (spectra.ndim != 5 or spectra.dtype != np.dtype("<f4") or spectra.shape[:3] != expected
            or min(spectra.shape[3:]) < 2):
        raise MeasuredDataError(
            path, f"inconsistent RGL spectral file: spectra must be f32[phi_i, theta_i, wavelengths, N, N] "
                  f"= f32[{expected[0]}, {expected[1]}, {expected[2]}, N, N], got "
                  f"{spectra.dtype}{list(spectra.shape)}")
    lum = fields.get("luminance")
    if lum is not None and lum.ndim == 4 and spectra.shape[3:] != lum.shape[2:]:
        raise MeasuredDataError(path, f"inconsistent RGL spectral file: spectra {list(spectra.shape)} and "
                                      f"luminance {list(lum.shape)} differ in their last two dimensions")
    bad = spectra.size - int(np.count_nonzero(np.isfinite(spectra)))
    if bad:
        raise MeasuredDataError(path, f"field 'spectra' has {bad:,} NaN or inf values")
    rgb = np.einsum("ck,ptkij->ptcij", srgb_matrix(wl), spectra, dtype=np.float64)
    out = {k: v for k, v in fields.items() if k != "spectra"}
    out["rgb"] = rgb.astype(np.float32)
    return out, wl
