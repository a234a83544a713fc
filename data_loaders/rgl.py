"""RGL-EPFL measured BRDFs (Dupuy & Jakob 2018, "An Adaptive Parameterization
for Efficient Material Acquisition and Rendering"): Mitsuba ``tensor_file``
v1.0 reader and the reference evaluation, in vectorised numpy (the
container itself: ``data_loaders.tensor_file``).

Evaluation (our own implementation of the scheme of ``rgl-epfl/brdf-loader``,
``powitacq_rgb.inl``): for (wi, wo) above the horizon, h = normalize(wi + wo),

    u_wi = (sqrt(theta_i 2/pi), (phi_i + pi) / (2 pi))
    u_wm = (sqrt(theta_h 2/pi), frac((phi_h - phi_i + pi) / (2 pi)))  (isotropic;
           anisotropic files use phi_h itself)
    s    = inverse of the VNDF warp at u_wm (2D marginal/conditional CDF of the
           bilinearly interpolated ``vndf`` table, conditioned on phi_i,
           theta_i by linear interpolation between the tabulated slices)
    f_c * cos(theta_o) = max(0, bilerp(rgb[.., c, ..], s)) * bilerp(ndf, u_wm)
                         / (4 bilerp(sigma, u_wi))

The reference loader's ``eval`` returns f * cos(theta_o); ``lookup`` here
returns the BRDF f = eval / cos(theta_o) (``eval_cosine`` gives the former).
The reference computes in float32; we use float64.

Spectral files (``*_spec.bsdf``, the reference's ``powitacq.inl``) hold
``spectra`` f32[phi_i, theta_i, n, N, N] at ``wavelengths`` f32[n] (nm) instead
of ``rgb``; ``read_rgl`` converts them to linear sRGB on reading
(``data_loaders.spectral``, docs/colour.md) and evaluates them as above.
"""

import os

import numpy as np

from ._typing import ArrayLike, Float
from .directions import half_diff_to_std
from .errors import MeasuredDataError
from .measured import MeasuredBRDF, Provenance
from .spectral import is_spectral, rgl_spectral_to_rgb
from .tensor_file import read_tensor_file, write_tensor_file  # noqa: F401 (re-exported)

REQUIRED_FIELDS = ("description", "phi_i", "theta_i", "sigma", "ndf", "vndf",
                   "luminance", "rgb", "jacobian")

UNITS_NOTE = ("BRDF in 1/sr, no cosine (reference loader's eval / cos theta_o); linear RGB as "
              "stored by RGL (sRGB primaries per the reference loader), negative out-of-gamut "
              "values clamped to 0")
SPECTRAL_UNITS_NOTE = ("BRDF in 1/sr, no cosine (reference loader's eval / cos theta_o); linear sRGB "
                       "converted from spectral ({n} wavelengths, {lo:g}-{hi:g} nm): CIE 1931 2-degree "
                       "observer, D65, trapezoid over the file's wavelengths, Y = 1 for a perfect white "
                       "reflector, IEC 61966-2-1 matrix (docs/colour.md); negative values clamped to 0")

# Default sample grid: (theta_h, theta_d, phi_d) cells, theta_h sqrt-spaced.
DEFAULT_GRID = (48, 48, 96)


# ---- interpolation helpers ------------------------------------------------------------

def _param_corners(grids, params):
    """Linear interpolation over conditioning parameters.

    ``grids``: list of 1-D sorted arrays (the tabulated parameter values);
    ``params``: list of (M,) query values. Returns a list of (slice index (M,),
    weight (M,)) over the flattened parameter grid (C order). Interval search
    and clamped weights as in the reference (no extrapolation).
    """
    m = params[0].shape[0]
    corners = [(np.zeros(m, dtype=np.int64), np.ones(m))]
    for grid, x in zip(grids, params):
        n = grid.shape[0]
        if n == 1:
            corners = [(idx * n, w) for idx, w in corners]
            continue
        i = np.clip(np.searchsorted(grid, x, side="right") - 1, 0, n - 2)
        p0, p1 = grid[i], grid[i + 1]
        w1 = np.clip((x - p0) / (p1 - p0), 0.0, 1.0)
        corners = [c for idx, w in corners
                   for c in ((idx * n + i, w * (1.0 - w1)), (idx * n + i + 1, w * w1))]
    return corners


def _fetch(table, corners, *index):
    """Sum over parameter corners of weight * table[slice, *index]."""
    out = 0.0
    for s, w in corners:
        out = out + w * table[(s,) + index]
    return out


def _cell(u, n):
    """Bilinear cell of coordinates u in [0, 1] on n nodes: (index, fraction)."""
    x = u * (n - 1)
    i = np.clip(np.floor(x).astype(np.int64), 0, n - 2)
    return i, x - i


def _bilerp(table, u_x, u_y):
    """Bilinear interpolation of a 2-D table (rows = y, cols = x) at u in [0, 1]^2."""
    ix, fx = _cell(u_x, table.shape[1])
    iy, fy = _cell(u_y, table.shape[0])
    return ((1 - fy) * ((1 - fx) * table[iy, ix] + fx * table[iy, ix + 1])
            + fy * ((1 - fx) * table[iy + 1, ix] + fx * table[iy + 1, ix + 1]))


# ---- the BRDF ---------------------------------------------------------------------------

class RglTable:
    """An RGL tensor-file BRDF ready for evaluation.

    ``fields`` holds every parsed field; the evaluation uses ``theta_i``,
    ``phi_i``, ``ndf``, ``sigma``, ``vndf`` and ``rgb`` (``luminance`` is only
    needed for importance sampling, ``valid`` and ``jacobian`` are kept as read).
    """

    methods = (None,)

    def __init__(self, fields: dict[str, np.ndarray], path: str = "<memory>") -> None:
        self.fields = fields
        self.description = bytes(fields["description"]).decode("utf-8", "replace").rstrip("\0")
        self.theta_i = fields["theta_i"].astype(np.float64)
        self.phi_i = fields["phi_i"].astype(np.float64)
        self.isotropic = self.phi_i.shape[0] <= 2
        self.ndf = fields["ndf"].astype(np.float64)
        self.sigma = fields["sigma"].astype(np.float64)
        n_slices = self.phi_i.shape[0] * self.theta_i.shape[0]
        vndf = fields["vndf"].astype(np.float64)
        ny, nx = vndf.shape[2:]
        vndf = vndf.reshape(n_slices, ny, nx)
        rgb = fields["rgb"].astype(np.float64)
        self.rgb = rgb.reshape((n_slices,) + rgb.shape[2:])     # (S, 3, N, N)

        # Marginal/conditional CDFs of the bilinear interpolant of each vndf slice
        # (trapezoid rule in index units), normalised so the marginal ends at 1.
        cond = np.zeros_like(vndf)
        cond[:, :, 1:] = np.cumsum(0.5 * (vndf[:, :, :-1] + vndf[:, :, 1:]), axis=2)
        marg = np.zeros((n_slices, ny))
        marg[:, 1:] = np.cumsum(0.5 * (cond[:, :-1, -1] + cond[:, 1:, -1]), axis=1)
        total = marg[:, -1]
        if not np.all(total > 0.0):
            raise MeasuredDataError(path, "a vndf slice integrates to zero: cannot build its warp")
        norm = 1.0 / total
        self.vndf_data = vndf * norm[:, None, None]
        self.vndf_cond = cond * norm[:, None, None]
        self.vndf_marg = marg * norm[:, None]

    def _corners(self, phi_i, theta_i):
        return _param_corners([self.phi_i, self.theta_i], [phi_i, theta_i])

    def invert_vndf(self, u_x: Float[np.ndarray, " m"], u_y: Float[np.ndarray, " m"],
                    corners: np.ndarray) -> tuple[Float[np.ndarray, " m"], Float[np.ndarray, " m"]]:
        """Inverse of the VNDF warp: sample-space coordinates (s_x, s_y) of u_wm."""
        ny, nx = self.vndf_data.shape[1:]
        ix, fx = _cell(u_x, nx)
        iy, fy = _cell(u_y, ny)
        d = self.vndf_data
        v00 = _fetch(d, corners, iy, ix)
        v10 = _fetch(d, corners, iy, ix + 1)
        v01 = _fetch(d, corners, iy + 1, ix)
        v11 = _fetch(d, corners, iy + 1, ix + 1)
        c0 = (1 - fy) * v00 + fy * v01          # density along x at column ix, row fraction fy
        c1 = (1 - fy) * v10 + fy * v11
        # x: CDF of the row-interpolated density up to u_x, over the row total
        sx = fx * (c0 + 0.5 * fx * (c1 - c0))
        cdf = self.vndf_cond
        sx = sx + (1 - fy) * _fetch(cdf, corners, iy, ix) + fy * _fetch(cdf, corners, iy + 1, ix)
        r0 = _fetch(cdf, corners, iy, nx - 1)
        r1 = _fetch(cdf, corners, iy + 1, nx - 1)
        row_total = (1 - fy) * r0 + fy * r1
        sx = np.where(row_total > 0.0, sx / np.where(row_total > 0.0, row_total, 1.0), 0.0)
        # y: marginal CDF up to u_y
        sy = fy * (r0 + 0.5 * fy * (r1 - r0)) + _fetch(self.vndf_marg, corners, iy)
        return sx, sy

    def eval_cosine(self, wi: Float[ArrayLike, "m 3"], wo: Float[ArrayLike, "m 3"]) -> Float[np.ndarray, "m 3"]:
        """The reference loader's ``eval``: f_r * cos(theta_o), RGB (M, 3)."""
        wi = np.asarray(wi, dtype=np.float64)
        wo = np.asarray(wo, dtype=np.float64)
        out = np.zeros((wi.shape[0], 3))
        ok = (wi[:, 2] > 0.0) & (wo[:, 2] > 0.0)
        if not ok.any():
            return out
        wi, wo = wi[ok], wo[ok]
        wm = wi + wo
        wm /= np.linalg.norm(wm, axis=1, keepdims=True)
        theta_i = np.arccos(np.clip(wi[:, 2], -1.0, 1.0))
        phi_i = np.arctan2(wi[:, 1], wi[:, 0])
        theta_m = np.arccos(np.clip(wm[:, 2], -1.0, 1.0))
        phi_m = np.arctan2(wm[:, 1], wm[:, 0])

        u_wi_x = np.sqrt(theta_i * (2.0 / np.pi))
        u_wi_y = (phi_i + np.pi) / (2.0 * np.pi)
        u_wm_x = np.sqrt(theta_m * (2.0 / np.pi))
        u_wm_y = ((phi_m - phi_i) if self.isotropic else phi_m) / (2.0 * np.pi) + 0.5
        u_wm_y = u_wm_y - np.floor(u_wm_y)

        corners = self._corners(phi_i, theta_i)
        sx, sy = self.invert_vndf(u_wm_x, u_wm_y, corners)
        n_rows, n_cols = self.rgb.shape[2:]
        ix, fx = _cell(sx, n_cols)
        iy, fy = _cell(sy, n_rows)
        fr = np.empty((wi.shape[0], 3))
        for c in range(3):
            v = ((1 - fy) * ((1 - fx) * _fetch(self.rgb, corners, c, iy, ix)
                             + fx * _fetch(self.rgb, corners, c, iy, ix + 1))
                 + fy * ((1 - fx) * _fetch(self.rgb, corners, c, iy + 1, ix)
                         + fx * _fetch(self.rgb, corners, c, iy + 1, ix + 1)))
            fr[:, c] = np.maximum(v, 0.0)     # negative = out of gamut: clamp
        scale = _bilerp(self.ndf, u_wm_x, u_wm_y) / (4.0 * _bilerp(self.sigma, u_wi_x, u_wi_y))
        out[ok] = fr * scale[:, None]
        return out

    def lookup(self, wi: Float[ArrayLike, "m 3"], wo: Float[ArrayLike, "m 3"],
               method: str | None = None) -> Float[np.ndarray, "m 3"]:
        """BRDF f_r (M, 3) without cosine = reference eval / cos(theta_o); 0 below the horizon."""
        if method not in self.methods:
            raise ValueError(f"unknown RGL lookup method {method!r}; the only one is None")
        wo = np.asarray(wo, dtype=np.float64)
        cos_o = wo[:, 2]
        ev = self.eval_cosine(wi, wo)
        return np.where(cos_o[:, None] > 0.0, ev / np.where(cos_o > 0.0, cos_o, 1.0)[:, None], 0.0)


def _check_fields(path, fields):
    missing = [n for n in REQUIRED_FIELDS if n not in fields]
    if missing:
        raise MeasuredDataError(path, f"tensor file lacks the field(s) {', '.join(missing)} "
                                      "needed for an RGL BRDF")

    def need(ok, what):
        if not ok:
            shapes = ", ".join(f"{n} {fields[n].dtype}{list(fields[n].shape)}" for n in REQUIRED_FIELDS)
            raise MeasuredDataError(path, f"inconsistent RGL tensor file: {what} (fields: {shapes})")

    f = fields
    f32 = np.dtype("<f4")
    need(f["description"].ndim == 1 and f["description"].dtype == np.uint8, "description must be u8[n]")
    for n in ("theta_i", "phi_i"):
        need(f[n].ndim == 1 and f[n].dtype == f32 and f[n].shape[0] >= 1, f"{n} must be f32[n >= 1]")
    n_phi, n_theta = f["phi_i"].shape[0], f["theta_i"].shape[0]
    for n in ("ndf", "sigma"):
        need(f[n].ndim == 2 and f[n].dtype == f32 and min(f[n].shape) >= 2, f"{n} must be f32[>=2, >=2]")
    need(f["vndf"].ndim == 4 and f["vndf"].dtype == f32 and f["vndf"].shape[:2] == (n_phi, n_theta)
         and min(f["vndf"].shape[2:]) >= 2, "vndf must be f32[phi_i, theta_i, >=2, >=2]")
    need(f["luminance"].ndim == 4 and f["luminance"].dtype == f32
         and f["luminance"].shape[:2] == (n_phi, n_theta)
         and f["luminance"].shape[2] == f["luminance"].shape[3], "luminance must be f32[phi_i, theta_i, N, N]")
    need(f["rgb"].ndim == 5 and f["rgb"].dtype == f32 and f["rgb"].shape[:3] == (n_phi, n_theta, 3)
         and f["rgb"].shape[3:] == f["luminance"].shape[2:] and min(f["rgb"].shape[3:]) >= 2,
         "rgb must be f32[phi_i, theta_i, 3, N, N] matching luminance")
    need(f["jacobian"].shape == (1,) and f["jacobian"].dtype == np.uint8, "jacobian must be u8[1]")
    for n in ("theta_i", "phi_i", "ndf", "sigma", "vndf", "luminance", "rgb"):
        bad = f[n].size - int(np.count_nonzero(np.isfinite(f[n])))
        if bad:
            raise MeasuredDataError(path, f"field {n!r} has {bad:,} NaN or inf values")
    need(np.all(np.diff(f["theta_i"].astype(np.float64)) > 0)
         and np.all(np.diff(f["phi_i"].astype(np.float64)) > 0), "theta_i and phi_i must be increasing")
    need(np.all(f["sigma"] > 0), "sigma must be positive")
    if n_phi > 2:
        span = float(f["phi_i"][-1]) - float(f["phi_i"][0])
        need(int(round(2 * np.pi / span)) == 1, "anisotropic files with a reduced phi_i range are not supported")


def sample_grid(grid: tuple[int, int, int] = DEFAULT_GRID,
                n_phi_h: int = 1) -> tuple[Float[np.ndarray, "n 3"], Float[np.ndarray, "n 3"], Float[np.ndarray, " n"]]:
    """Direction pairs on a Rusinkiewicz (theta_h, theta_d, phi_d[, phi_h]) grid.

    ``grid`` = (n_theta_h, n_theta_d, n_phi_d): cell centres with theta_h
    sqrt-spaced over [0, pi/2] (MERL-like, fine near the specular peak),
    theta_d uniform over [0, pi/2], phi_d uniform over [0, 2 pi) (not folded:
    measured data are not exactly reciprocal); ``n_phi_h`` uniform cells of
    phi_h over [0, 2 pi) (1 = phi_h 0 for isotropic data).
    Weights are the exact measure of each cell in (wi, wo) space,
    dwi dwo = 4 cos td sin td sin th dth dphi_h dtd dphi_d
            = 2 dcos(th) dsin^2(td) dphi_h dphi_d,
    integrated over the cell (with phi_h integrated over 2 pi when n_phi_h = 1).
    Only pairs with both directions above the horizon are returned; their
    weights sum to about (2 pi)^2.
    Returns (wi (N, 3), wo (N, 3), weights (N,)).
    """
    n_th, n_td, n_pd = (int(g) for g in grid)
    th_e = (np.arange(n_th + 1) / n_th) ** 2 * (np.pi / 2)
    td_e = np.arange(n_td + 1) / n_td * (np.pi / 2)
    th = ((np.arange(n_th) + 0.5) / n_th) ** 2 * (np.pi / 2)
    td = (np.arange(n_td) + 0.5) / n_td * (np.pi / 2)
    pd = (np.arange(n_pd) + 0.5) / n_pd * (2 * np.pi)
    ph = (np.arange(n_phi_h) + 0.5) / n_phi_h * (2 * np.pi) if n_phi_h > 1 else np.zeros(1)
    w_h = np.cos(th_e[:-1]) - np.cos(th_e[1:])
    w_d = np.sin(td_e[1:]) ** 2 - np.sin(td_e[:-1]) ** 2
    dphi = (2 * np.pi / n_pd) * (2 * np.pi / n_phi_h)
    TH, PH, TD, PD = np.meshgrid(th, ph, td, pd, indexing="ij")
    W = 2.0 * dphi * w_h[:, None, None, None] * w_d[None, None, :, None] * np.ones(TH.shape)
    wi, wo = half_diff_to_std(TH.ravel(), PH.ravel(), TD.ravel(), PD.ravel())
    keep = (wi[:, 2] > 0.0) & (wo[:, 2] > 0.0)
    return wi[keep], wo[keep], W.ravel()[keep]


def read_rgl(path: str | os.PathLike[str], grid: tuple[int, int, int] = DEFAULT_GRID,
             n_phi_h: int | None = None) -> MeasuredBRDF:
    """Read an RGL ``.bsdf`` tensor file (``*_rgb.bsdf`` or spectral ``*_spec.bsdf``) into a MeasuredBRDF.

    Samples: the full evaluation on :func:`sample_grid` (``grid`` =
    (n_theta_h, n_theta_d, n_phi_d), default (48, 48, 96): about 110,000 pairs
    above the horizon; ``n_phi_h`` defaults to 1 for isotropic files and 24
    otherwise). Spectral files are converted to linear sRGB first
    (``data_loaders.spectral``; ``provenance.units`` says so). Raises
    MeasuredDataError for a wrong magic, a missing or inconsistent field
    (wavelengths too), truncation or NaN/inf data.
    """
    path = os.fspath(path)
    fields, sha = read_tensor_file(path)
    units = UNITS_NOTE
    if is_spectral(fields):
        fields, wl = rgl_spectral_to_rgb(path, fields)
        units = SPECTRAL_UNITS_NOTE.format(n=wl.shape[0], lo=wl[0], hi=wl[-1])
    _check_fields(path, fields)
    table = RglTable(fields, path)
    if n_phi_h is None:
        n_phi_h = 1 if table.isotropic else 24
    wi, wo, weights = sample_grid(grid, n_phi_h)
    values = table.lookup(wi, wo)
    valid = np.isfinite(values).all(axis=1)
    if not valid.any():
        raise MeasuredDataError(path, "all-invalid table: no finite value on the sample grid")
    base = os.path.basename(path)
    suffix = next((s for s in ("_rgb.bsdf", "_spec.bsdf") if base.endswith(s)), None)
    material = base[:-len(suffix)] if suffix else os.path.splitext(base)[0]
    prov = Provenance(path=os.path.abspath(path), format="rgl", material=material, sha256=sha,
                      units=units, description=table.description)
    return MeasuredBRDF(wi=wi, wo=wo, values=np.where(valid[:, None], values, 0.0),
                        weights=weights, valid=valid, isotropic=table.isotropic,
                        provenance=prov, table=table)
