"""UTIA anisotropic BRDF tables (Filip & Vavra 2014): read, write, look up.

Layout (docs/data-formats.md): ``.bin`` without header, 3 x 6 x 48 x 6 x 48 =
248,832 float64 (1,990,656 bytes), channel-planar;
``reshape(3, 6, 48, 6, 48)`` is [c][theta_i][phi_i][theta_v][phi_v] with
theta in {0, 15, ..., 75} deg and phi in {0, 7.5, ..., 352.5} deg measured
from the material tangent (+x), so the table is anisotropic. Azimuths of
query directions are computed with atan2 (signed, then wrapped to [0, 360)).

Units: the absolute scale of UTIA data is not documented consistently. Two
conventions, chosen with ``units=``:

- ``"raw"`` (default): the stored values as they are, the BRDF samples that
  Filip's own code returns (no cosine). Negative raw values (noise in some
  materials) are masked invalid in the sample set (values 0) but left in the
  table, which ``lookup`` interpolates as Filip's code does.
- ``"dj_brdf"``: the decoding of jdupuy/dj_brdf (used for Dupuy et al. 2015
  fits): table = max(raw, 0) / 140 ("magic constant from Jiri Filip"); a
  lookup interpolates this table (Filip's quadrilinear scheme) and then
  decodes the result v as sRGB with dj_brdf's threshold, v > 0.0375:
  ((v + 0.055) / 1.055)^2.4, else v / 12.92, multiplies by 100 and clamps at
  0. Sample values are the same decoding applied to the grid values. dj_brdf
  then multiplies by cos(theta_o) in its ``eval``; we do not (no cosine).
"""

import os

import numpy as np

from ._typing import ArrayLike, Float
from .directions import dir_to_spherical, spherical_to_dir
from .errors import MeasuredDataError
from .measured import MeasuredBRDF, Provenance, read_file_bytes, write_file_atomic

N_THETA, N_PHI = 6, 48
STEP_THETA_DEG, STEP_PHI_DEG = 15.0, 7.5
UTIA_SHAPE = (3, N_THETA, N_PHI, N_THETA, N_PHI)
UTIA_VALUES = 3 * N_THETA * N_PHI * N_THETA * N_PHI      # 248,832
UTIA_FILE_SIZE = 8 * UTIA_VALUES                         # 1,990,656
UNITS = ("raw", "dj_brdf")

DJ_BRDF_SCALE = 1.0 / 140.0
DJ_BRDF_SRGB_THRESHOLD = 0.0375
DJ_BRDF_GAIN = 100.0

_UNITS_NOTES = {
    "raw": "raw UTIA values (Filip's convention: BRDF samples, no cosine; absolute scale "
           "uncertain); negative values masked invalid",
    "dj_brdf": "dj_brdf decoding: inverse sRGB (threshold 0.0375) of max(raw, 0)/140, x 100; "
               "no cosine",
}


def utia_index(theta_i: float, phi_i: float, theta_v: float, phi_v: float, channel: int) -> int:
    """Flat index into a UTIA file of the grid node nearest to the given angles (radians).

    index = c * 82944 + 288 * (48 * i_theta_i + i_phi_i) + 48 * i_theta_v + i_phi_v.
    """
    def node(angle, step, n, wrap):
        k = int(np.rint(np.degrees(angle) / step))
        if wrap:
            return k % n
        if not 0 <= k < n:
            raise ValueError(f"theta {np.degrees(angle):g} deg is outside the UTIA grid (0..75 deg)")
        return k

    c = int(channel)
    if not 0 <= c < 3:
        raise ValueError(f"channel must be 0, 1 or 2, got {channel}")
    iti = node(theta_i, STEP_THETA_DEG, N_THETA, False)
    ipi = node(phi_i, STEP_PHI_DEG, N_PHI, True)
    itv = node(theta_v, STEP_THETA_DEG, N_THETA, False)
    ipv = node(phi_v, STEP_PHI_DEG, N_PHI, True)
    return c * (UTIA_VALUES // 3) + N_THETA * N_PHI * (N_PHI * iti + ipi) + N_PHI * itv + ipv


def grid_angles() -> tuple[Float[np.ndarray, "6"], Float[np.ndarray, "48"]]:
    """Node angles (theta (6,), phi (48,)), radians."""
    theta = np.radians(np.arange(N_THETA) * STEP_THETA_DEG)
    phi = np.radians(np.arange(N_PHI) * STEP_PHI_DEG)
    return theta, phi


def node_solid_angles() -> Float[np.ndarray, "6 48"]:
    """(6, 48) solid angle of each direction node's cell: theta cells centred on
    the nodes ([0, 7.5], [7.5, 22.5], ..., [67.5, 90] deg; the last reaches the
    horizon, which Filip's extrapolation covers), phi cells 7.5 deg wide. They
    sum to 2 pi."""
    edges = np.radians(np.concatenate([[0.0], np.arange(N_THETA - 1) * STEP_THETA_DEG + 7.5, [90.0]]))
    band = np.cos(edges[:-1]) - np.cos(edges[1:])
    return np.repeat(band[:, None], N_PHI, axis=1) * np.radians(STEP_PHI_DEG)


def _dj_brdf_decode(v):
    v = np.asarray(v, dtype=np.float64)
    with np.errstate(over="ignore"):        # raw values above ~1e130 decode to inf
        high = ((np.maximum(v, 0.0) + 0.055) / 1.055) ** 2.4
        return np.maximum(np.where(v > DJ_BRDF_SRGB_THRESHOLD, high, v / 12.92) * DJ_BRDF_GAIN, 0.0)


class UtiaTable:
    """A UTIA table ``data`` (3, 6, 48, 6, 48) with Filip's quadrilinear lookup;
    ``decode`` is None (raw) or "dj_brdf" (decoding applied after interpolation)."""

    methods = (None, "quadrilinear")

    def __init__(self, data: Float[np.ndarray, "3 6 48 6 48"], decode: str | None = None) -> None:
        self.data = data
        self.decode = decode

    def lookup(self, wi: Float[ArrayLike, "m 3"], wo: Float[ArrayLike, "m 3"],
               method: str | None = None) -> Float[np.ndarray, "m 3"]:
        """RGB (M, 3) at unit directions (M, 3), Filip's quadrilinear interpolation.

        Theta: i0 = min(floor(theta / 15 deg), 4), i1 = i0 + 1,
        w1 = (theta - 15 i0) / 15, so theta > 75 deg extrapolates linearly;
        phi: i0 = floor(phi / 7.5 deg), index 48 wraps to 0; theta > 90 deg
        (below the horizon) gives 0.
        """
        if method not in self.methods:
            raise ValueError(f"unknown UTIA lookup method {method!r}; use one of {self.methods}")
        ti, pi_ = dir_to_spherical(wi)
        tv, pv = dir_to_spherical(wo)
        above = (ti <= np.pi / 2) & (tv <= np.pi / 2)
        axes = []
        for angle, step, n, periodic in ((ti, STEP_THETA_DEG, N_THETA, False),
                                         (np.mod(np.degrees(pi_), 360.0), STEP_PHI_DEG, N_PHI, True),
                                         (tv, STEP_THETA_DEG, N_THETA, False),
                                         (np.mod(np.degrees(pv), 360.0), STEP_PHI_DEG, N_PHI, True)):
            x = angle if periodic else np.degrees(angle)
            i0 = np.floor(x / step).astype(np.int64)
            if periodic:
                i0 = np.clip(i0, 0, n - 1)      # mod can round up to exactly 360
            else:
                i0 = np.minimum(i0, n - 2)
            w1 = (x - step * i0) / step
            i1 = (i0 + 1) % n if periodic else i0 + 1
            axes.append(((i0, 1.0 - w1), (i1, w1)))
        out = np.zeros((ti.shape[0], 3))
        for a_idx, a_w in axes[0]:
            for b_idx, b_w in axes[1]:
                for c_idx, c_w in axes[2]:
                    for d_idx, d_w in axes[3]:
                        w = a_w * b_w * c_w * d_w
                        out += w[:, None] * self.data[:, a_idx, b_idx, c_idx, d_idx].T
        if self.decode == "dj_brdf":
            out = _dj_brdf_decode(out)
        return np.where(above[:, None], out, 0.0)


def read_utia(path: str | os.PathLike[str], units: str = "raw", material: str | None = None) -> MeasuredBRDF:
    """Read a UTIA ``.bin`` file into a MeasuredBRDF (82,944 grid samples).

    ``units="raw"`` (default) keeps the stored values; ``units="dj_brdf"``
    applies dj_brdf's decoding (see the module docstring for both). Samples
    are the 6 x 48 x 6 x 48 grid nodes in C order (theta_i, phi_i, theta_v,
    phi_v); weights are products of the two nodes' cell solid angles (they
    sum to (2 pi)^2). Raises MeasuredDataError for a wrong size, NaN/inf
    values, no valid sample, or (``dj_brdf``) values whose decoding overflows.
    """
    if units not in UNITS:
        raise ValueError(f"units must be one of {UNITS}, got {units!r}")
    path = os.fspath(path)
    data, sha = read_file_bytes(path, max_bytes=UTIA_FILE_SIZE)
    if len(data) != UTIA_FILE_SIZE:
        raise MeasuredDataError(
            path, f"file is {len(data):,} bytes, a UTIA table (6x48x6x48x3 float64) has "
                  f"{UTIA_FILE_SIZE:,}")
    raw = np.frombuffer(data, dtype="<f8").reshape(UTIA_SHAPE)
    if not np.isfinite(raw).all():
        bad = raw.size - int(np.count_nonzero(np.isfinite(raw)))
        raise MeasuredDataError(path, f"{bad:,} values are NaN or inf")
    if units == "raw":
        table = UtiaTable(raw.astype(np.float64))
        values = raw.reshape(3, -1).T
        valid = (values >= 0.0).all(axis=1)
        if not valid.any():
            raise MeasuredDataError(path, "all-invalid table: every sample has a negative value")
    else:
        encoded = np.maximum(raw, 0.0) * DJ_BRDF_SCALE
        table = UtiaTable(encoded, decode="dj_brdf")
        values = _dj_brdf_decode(encoded.reshape(3, -1).T)
        overflow = values.size - int(np.count_nonzero(np.isfinite(values)))
        if overflow:
            raise MeasuredDataError(path, f"{overflow:,} values overflow to infinity when decoded with "
                                          f"units='dj_brdf' (raw values up to {raw.max():.3g})")
        valid = np.ones(values.shape[0], dtype=bool)

    theta, phi = grid_angles()
    dirs = spherical_to_dir(theta[:, None], phi[None, :]).reshape(-1, 3)   # (288, 3)
    omega = node_solid_angles().ravel()
    n_dir = dirs.shape[0]
    wi = np.repeat(dirs, n_dir, axis=0)
    wo = np.tile(dirs, (n_dir, 1))
    weights = np.outer(omega, omega).ravel()
    if material is None:
        material = os.path.splitext(os.path.basename(path))[0]
    prov = Provenance(path=os.path.abspath(path), format="utia", material=material,
                      sha256=sha, units=_UNITS_NOTES[units])
    return MeasuredBRDF(wi=wi, wo=wo, values=np.where(valid[:, None], values, 0.0),
                        weights=weights, valid=valid, isotropic=False, provenance=prov, table=table)


def write_utia(path: str | os.PathLike[str], data: Float[ArrayLike, "3 6 48 6 48"]) -> None:
    """Write a UTIA ``.bin`` file from ``data`` of shape (3, 6, 48, 6, 48)
    ([c][theta_i][phi_i][theta_v][phi_v], raw values), atomically."""
    data = np.asarray(data, dtype=np.float64)
    if data.shape != UTIA_SHAPE:
        raise ValueError(f"data must have shape {UTIA_SHAPE}, got {data.shape}")
    write_file_atomic(path, data.astype("<f8").tobytes())
