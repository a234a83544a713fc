"""MERL ``.binary`` isotropic BRDF tables (Matusik et al. 2003): read, write, look up.

Layout (docs/data-formats.md): header 3 x int32 (90, 90, 180), then
3 x 1,458,000 float64, channel-planar R, G, B, little-endian; the file is
34,992,012 bytes. ``data.reshape(3, 90, 90, 180)`` is [c][theta_h][theta_d][phi_d].
Stored values x (1/1500, 1.15/1500, 1.66/1500) = BRDF in 1/sr (not x cos).
Negative raw values mark unmeasured cells: they are masked invalid here,
never clamped.

Cell of index (i, j, k): theta_h in [(i/90)^2, ((i+1)/90)^2] * pi/2 (sqrt
binning), theta_d in [j, j+1] * pi/180, phi_d in [k, k+1] * pi/180 (phi_d and
phi_d + pi are the same cell by reciprocity). Samples sit at the cell
centres with phi_h = 0.
"""

import functools
import os

import numpy as np

from ._typing import ArrayLike, Bool, Float, Int
from .directions import half_diff_to_std, std_to_half_diff  # noqa: F401 (re-exported)
from .errors import MeasuredDataError
from .measured import MeasuredBRDF, Provenance, read_file_bytes, write_file_atomic

N_THETA_H, N_THETA_D, N_PHI_D = 90, 90, 180
MERL_SHAPE = (N_THETA_H, N_THETA_D, N_PHI_D)
MERL_CELLS = N_THETA_H * N_THETA_D * N_PHI_D            # 1,458,000
MERL_HEADER_BYTES = 12
MERL_FILE_SIZE = MERL_HEADER_BYTES + 3 * 8 * MERL_CELLS  # 34,992,012
MERL_SCALES = np.array([1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0])

# Weight normalisation: weight = (cos th_lo - cos th_hi) (sin^2 td_hi - sin^2 td_lo)
# dphi_d * MERL_WEIGHT_FACTOR, so that the weights of all cells sum to (2 pi)^2.
# (This is the exact Jacobian 4 cos td sin td sin th of (theta_h, phi_h, theta_d,
# phi_d) integrated over phi_h, counting each stored phi_d cell once; counting
# the reciprocal cell phi_d + pi as well would double it. A constant factor
# does not change weighted means.)
MERL_WEIGHT_FACTOR = 4.0 * np.pi

UNITS_NOTE = ("BRDF in 1/sr (raw x (1/1500, 1.15/1500, 1.66/1500)), no cosine; "
              "negative raw cells masked invalid")


# ---- index maths --------------------------------------------------------------

def merl_index(
    theta_h: Float[ArrayLike, "*#batch"], theta_d: Float[ArrayLike, "*#batch"], phi_d: Float[ArrayLike, "*#batch"],
) -> tuple[Int[np.ndarray, "*batch"], Int[np.ndarray, "*batch"], Int[np.ndarray, "*batch"], Int[np.ndarray, "*batch"]]:
    """Standard MERL cell indices (the reference reader's floor lookup).

    i_th = floor(sqrt(theta_h / (pi/2)) * 90) (theta_h <= 0 -> 0),
    i_td = floor(theta_d / (pi/2) * 90), phi_d < 0 -> phi_d + pi (reciprocity),
    i_pd = floor(phi_d / pi * 180); all clamped to [0, N-1].
    Returns (i_th, i_td, i_pd, flat) with flat = i_pd + 180 i_td + 16200 i_th.
    """
    theta_h = np.asarray(theta_h, dtype=np.float64)
    theta_d = np.asarray(theta_d, dtype=np.float64)
    phi_d = np.asarray(phi_d, dtype=np.float64)
    th = np.sqrt(np.clip(theta_h, 0.0, None) / (np.pi / 2)) * N_THETA_H
    i_th = np.clip(np.floor(th), 0, N_THETA_H - 1).astype(np.int64)
    i_td = np.clip(np.floor(theta_d / (np.pi / 2) * N_THETA_D), 0, N_THETA_D - 1).astype(np.int64)
    pd = np.where(phi_d < 0.0, phi_d + np.pi, phi_d)
    i_pd = np.clip(np.floor(pd / np.pi * N_PHI_D), 0, N_PHI_D - 1).astype(np.int64)
    flat = i_pd + N_PHI_D * i_td + N_PHI_D * N_THETA_D * i_th
    return i_th, i_td, i_pd, flat


def cell_edges() -> tuple[Float[np.ndarray, "91"], Float[np.ndarray, "91"], Float[np.ndarray, "181"]]:
    """Cell edges (theta_h (91,), theta_d (91,), phi_d (181,)), radians."""
    th = (np.arange(N_THETA_H + 1) / N_THETA_H) ** 2 * (np.pi / 2)
    td = np.arange(N_THETA_D + 1) / N_THETA_D * (np.pi / 2)
    pd = np.arange(N_PHI_D + 1) / N_PHI_D * np.pi
    return th, td, pd


def cell_centres() -> tuple[Float[np.ndarray, "90"], Float[np.ndarray, "90"], Float[np.ndarray, "180"]]:
    """Cell-centre angles (theta_h (90,), theta_d (90,), phi_d (180,)), radians."""
    th = ((np.arange(N_THETA_H) + 0.5) / N_THETA_H) ** 2 * (np.pi / 2)
    td = (np.arange(N_THETA_D) + 0.5) / N_THETA_D * (np.pi / 2)
    pd = (np.arange(N_PHI_D) + 0.5) / N_PHI_D * np.pi
    return th, td, pd


def cell_weights() -> Float[np.ndarray, "90 90 180"]:
    """(90, 90, 180) solid-angle weights of the cells; they sum to (2 pi)^2."""
    th, td, pd = cell_edges()
    w_h = np.cos(th[:-1]) - np.cos(th[1:])
    w_d = np.sin(td[1:]) ** 2 - np.sin(td[:-1]) ** 2
    w_p = np.diff(pd)
    return MERL_WEIGHT_FACTOR * w_h[:, None, None] * w_d[None, :, None] * w_p[None, None, :]


@functools.lru_cache(maxsize=1)
def _sample_geometry():
    """Cell-centre directions (wi, wo flat (N, 3)), weights (N,), above-horizon mask.

    The same for every MERL file, so computed once (arrays are read-only)."""
    # half_diff_to_std with phi_h = 0, written separably for speed:
    # wi = R_y(theta_h) d, h = (sin th, 0, cos th), wi . h = d_z = cos td.
    th, td, pd = cell_centres()
    ct, st = np.cos(th)[:, None, None], np.sin(th)[:, None, None]
    dx = (np.sin(td)[:, None] * np.cos(pd)[None, :])[None]
    dy = (np.sin(td)[:, None] * np.sin(pd)[None, :])[None]
    dz = np.broadcast_to(np.cos(td)[:, None], (N_THETA_D, N_PHI_D))[None]
    wi = np.empty(MERL_SHAPE + (3,))
    wo = np.empty(MERL_SHAPE + (3,))
    wi[..., 0] = ct * dx + st * dz
    wi[..., 1] = dy
    wi[..., 2] = ct * dz - st * dx
    wo[..., 0] = 2.0 * dz * st - wi[..., 0]
    wo[..., 1] = -dy
    wo[..., 2] = 2.0 * dz * ct - wi[..., 2]
    wi, wo = wi.reshape(-1, 3), wo.reshape(-1, 3)
    above = (wi[:, 2] > 0.0) & (wo[:, 2] > 0.0)
    weights = cell_weights().ravel()
    for a in (wi, wo, weights, above):
        a.flags.writeable = False
    return wi, wo, weights, above


@functools.lru_cache(maxsize=1)
def _above_horizon():
    """_sample_geometry's above-horizon mask (N,) from the z components alone (the same
    expressions): a file read for lookups needs no direction arrays."""
    th, td, pd = cell_centres()
    ct, st = np.cos(th)[:, None, None], np.sin(th)[:, None, None]
    dx = (np.sin(td)[:, None] * np.cos(pd)[None, :])[None]
    dz = np.broadcast_to(np.cos(td)[:, None], (N_THETA_D, N_PHI_D))[None]
    wi_z = ct * dz - st * dx
    above = ((wi_z > 0.0) & (2.0 * dz * ct - wi_z > 0.0)).ravel()
    above.flags.writeable = False
    return above


# ---- native table -----------------------------------------------------------------

class MerlTable:
    """A MERL table in BRDF units: ``rgb`` (90, 90, 180, 3) float64 (0 where
    invalid) and ``valid`` (90, 90, 180) bool."""

    methods = (None, "nearest", "trilinear")

    def __init__(self, rgb: Float[np.ndarray, "90 90 180 3"], valid: Bool[np.ndarray, "90 90 180"]) -> None:
        self.rgb = rgb
        self.valid = valid

    def lookup(self, wi: Float[ArrayLike, "m 3"], wo: Float[ArrayLike, "m 3"],
               method: str | None = None) -> Float[np.ndarray, "m 3"]:
        """BRDF (M, 3) at unit directions wi, wo (M, 3).

        method None / "nearest": the standard MERL floor lookup (with the
        phi_d < 0 -> phi_d + pi reciprocity fold); invalid cells give 0.
        method "trilinear": trilinear interpolation between cell centres in
        index space (sqrt(theta_h), theta_d, phi_d; phi_d periodic with period
        pi, theta axes clamped at the end cells), using only valid corner
        cells and renormalising their weights (0 if none is valid).
        Pairs with wi or wo at or below the horizon give 0.
        """
        if method not in self.methods:
            raise ValueError(f"unknown MERL lookup method {method!r}; use one of {self.methods}")
        theta_h, _, theta_d, phi_d = std_to_half_diff(wi, wo)
        above = (wi[:, 2] > 0.0) & (wo[:, 2] > 0.0)
        if method == "trilinear":
            out = self._trilinear(theta_h, theta_d, phi_d)
        else:
            i_th, i_td, i_pd, _ = merl_index(theta_h, theta_d, phi_d)
            out = self.rgb[i_th, i_td, i_pd]
        return np.where(above[:, None], out, 0.0)

    def _trilinear(self, theta_h, theta_d, phi_d):
        x = np.clip(np.sqrt(np.clip(theta_h, 0.0, None) / (np.pi / 2)) * N_THETA_H - 0.5,
                    0.0, N_THETA_H - 1)
        y = np.clip(theta_d / (np.pi / 2) * N_THETA_D - 0.5, 0.0, N_THETA_D - 1)
        z = np.mod(phi_d, np.pi) / np.pi * N_PHI_D - 0.5     # periodic, period 180 cells
        x0 = np.minimum(np.floor(x).astype(np.int64), N_THETA_H - 2)
        y0 = np.minimum(np.floor(y).astype(np.int64), N_THETA_D - 2)
        z0 = np.floor(z).astype(np.int64)
        fx, fy, fz = x - x0, y - y0, z - z0
        total = np.zeros(theta_h.shape + (3,))
        wsum = np.zeros(theta_h.shape)
        for a in (0, 1):
            wa = fx if a else 1.0 - fx
            for b in (0, 1):
                wb = fy if b else 1.0 - fy
                for c in (0, 1):
                    wc = fz if c else 1.0 - fz
                    ix, iy, iz = x0 + a, y0 + b, np.mod(z0 + c, N_PHI_D)
                    w = wa * wb * wc * self.valid[ix, iy, iz]
                    total += w[:, None] * self.rgb[ix, iy, iz]
                    wsum += w
        return np.where(wsum[:, None] > 0.0, total / np.where(wsum > 0.0, wsum, 1.0)[:, None], 0.0)


# ---- read / write ---------------------------------------------------------------------

def read_merl(path: str | os.PathLike[str], material: str | None = None) -> MeasuredBRDF:
    """Read a MERL ``.binary`` file into a MeasuredBRDF (1,458,000 cell-centre samples).

    ``valid`` = all three raw channels >= 0 and both sample directions above
    the horizon; ``values`` are 0 where invalid. ``material`` defaults to the
    file name without extension. Raises MeasuredDataError for a wrong size,
    wrong header dims, NaN/inf values or a table with no valid cell.
    """
    path = os.fspath(path)
    raw, sha, measured, valid = _read_checked(path)
    wi, wo, weights, _ = _sample_geometry()
    values = raw.T * MERL_SCALES
    values[~measured] = 0.0
    table = MerlTable(values.reshape(MERL_SHAPE + (3,)), measured.reshape(MERL_SHAPE))
    return MeasuredBRDF(wi=wi, wo=wo, values=np.where(valid[:, None], values, 0.0),
                        weights=weights, valid=valid, isotropic=True,
                        provenance=_provenance(path, material, sha), table=table)


def read_merl_table(path: str | os.PathLike[str], material: str | None = None) -> tuple[MeasuredBRDF, int]:
    """A MERL file for lookups only, at the cost of reading, hashing and checking it:
    (a MeasuredBRDF with no samples -- empty ``wi``, ``wo``, ``values`` -- whose
    ``table`` gives read_merl's numbers, converting only the cells a lookup reads;
    read_merl's ``n_valid``).  Same checks and provenance as read_merl: for a
    picture's few thousand lookups (brdf_fit.library), not for fitting."""
    path = os.fspath(path)
    raw, sha, measured, valid = _read_checked(path)
    table = MerlTable(_Cells(raw, measured), measured.reshape(MERL_SHAPE))
    empty = np.empty((0, 3))
    return MeasuredBRDF(wi=empty, wo=empty, values=empty, weights=empty[:, 0], valid=np.empty(0, bool),
                        isotropic=True, provenance=_provenance(path, material, sha),
                        table=table), int(np.count_nonzero(valid))


class _Cells:
    """MerlTable.rgb of a file's raw channels (3, cells), converted when indexed by
    (theta_h, theta_d, phi_d) index arrays: raw x MERL_SCALES, 0 where unmeasured."""

    def __init__(self, raw, measured):
        self.raw, self.measured = raw, measured

    def __getitem__(self, index):
        flat = np.ravel_multi_index(index, MERL_SHAPE)
        out = np.moveaxis(self.raw[:, flat], 0, -1) * MERL_SCALES
        out[~self.measured[flat]] = 0.0
        return out


def _read_checked(path):
    """(raw (3, cells) float64, sha256, measured (cells,), valid (cells,)) of a MERL file,
    or MeasuredDataError (read_merl's checks)."""
    data, sha = read_file_bytes(path, max_bytes=MERL_FILE_SIZE)
    if len(data) < MERL_HEADER_BYTES:
        raise MeasuredDataError(path, f"only {len(data)} bytes: too short for the MERL header (12 bytes)")
    dims = tuple(int(d) for d in np.frombuffer(data, dtype="<i4", count=3))
    if dims != MERL_SHAPE:
        raise MeasuredDataError(
            path, f"MERL header dims are {dims}, expected {MERL_SHAPE} (not a MERL table, or another resolution)")
    if len(data) != MERL_FILE_SIZE:
        raise MeasuredDataError(
            path, f"file is {len(data):,} bytes, a 90x90x180 MERL table has {MERL_FILE_SIZE:,} "
                  "(truncated or padded?)")
    raw = np.frombuffer(data, dtype="<f8", offset=MERL_HEADER_BYTES).reshape(3, MERL_CELLS)
    finite = np.isfinite(raw)
    if not finite.all():
        bad = raw.size - int(np.count_nonzero(finite))
        raise MeasuredDataError(path, f"{bad:,} values are NaN or inf")
    measured = (raw >= 0.0).all(axis=0)
    valid = measured & _above_horizon()
    if not valid.any():
        raise MeasuredDataError(path, "all-invalid table: no cell has a non-negative value above the horizon")
    return raw, sha, measured, valid


def _provenance(path, material, sha):
    if material is None:
        material = os.path.splitext(os.path.basename(path))[0]
    return Provenance(path=os.path.abspath(path), format="merl", material=material, sha256=sha, units=UNITS_NOTE)


def write_merl(path: str | os.PathLike[str], rgb: Float[ArrayLike, "90 90 180 3"],
               valid: Bool[ArrayLike, "90 90 180"] | None = None) -> None:
    """Write a MERL ``.binary`` file.

    ``rgb``: (90, 90, 180, 3) BRDF in 1/sr ([theta_h][theta_d][phi_d][channel]);
    ``valid``: optional (90, 90, 180) bool, cells where it is False are written
    as raw -1 (unmeasured). The file is written atomically (temp + rename).
    """
    rgb = np.asarray(rgb, dtype=np.float64)
    if rgb.shape != MERL_SHAPE + (3,):
        raise ValueError(f"rgb must have shape {MERL_SHAPE + (3,)}, got {rgb.shape}")
    raw = rgb / MERL_SCALES
    if valid is not None:
        valid = np.asarray(valid, dtype=bool)
        if valid.shape != MERL_SHAPE:
            raise ValueError(f"valid must have shape {MERL_SHAPE}, got {valid.shape}")
        raw = np.where(valid[..., None], raw, -1.0)
    payload = np.moveaxis(raw, -1, 0).astype("<f8")
    write_file_atomic(path, np.array(MERL_SHAPE, dtype="<i4").tobytes() + payload.tobytes())

