"""``MeasuredBRDF``: the one container every reader returns.

A MeasuredBRDF is a set of direction-pair samples (the format's own grid or
sample list) plus a reference to the format's native table, so the BRDF can
also be evaluated at arbitrary directions with the format's own
interpolation (``lookup``). Loaders know nothing of models.

Conventions (docs/models.md#conventions): local frame n = +z, t = +x, b = +y; ``wi`` (to the
light) and ``wo`` (to the viewer) point away from the surface; values are the
BRDF without the cosine factor, in 1/sr (for UTIA see ``utia.py`` about the
uncertain absolute scale).
"""

import dataclasses
import hashlib
import os
from dataclasses import dataclass, field

import numpy as np

from ._typing import ArrayLike, Float
from .buffers import take_rows
from .directions import as_directions, dir_to_spherical, std_to_half_diff
from .atomic import write_file_atomic  # noqa: F401 -- its old home; readers and writers import it here
from .displayable import MeasuredDisplay
from .errors import MeasuredDataError, open_regular, require_file

CHANNEL_NAMES = ("r", "g", "b")

# Measure of the set of (wi, wo) pairs over two hemispheres, in sr^2.
HEMISPHERE_PAIR_MEASURE = (2.0 * np.pi) ** 2

# Rows per step of ``subsample``'s strata: the half/difference angles of a MERL table's
# 0.9 M pairs at once allocate ~200 MB of temporaries, which a fresh process pays for in
# page faults (1.0-1.5 s against 0.2 s warm); in steps of 2^16 rows they reuse a few MB.
STRATA_ROWS = 1 << 16


@dataclass(frozen=True)
class Provenance:
    """Where a MeasuredBRDF came from and what was done to it since."""

    path: str
    format: str            # "merl", "utia", "rgl", "csv", "npz"
    material: str
    sha256: str            # of the file's bytes
    units: str             # channel convention / units note
    description: str = ""  # the file's own description, if it has one
    history: tuple = ()    # operations applied after loading, e.g. "select(max_theta_deg=80)"

    def to_dict(self) -> dict[str, object]:
        d = dataclasses.asdict(self)
        d["history"] = list(self.history)
        return d


# ---- plausibility (``load`` warns; the data are still returned) -------------------------

# Measured BRDFs stay far below this within PLAUSIBLE_MAX_THETA_DEG of the normal
# (peaks seen: RGL-EPFL glossy vinyl 2.3e3 1/sr, MERL-like chrome 3.9e3 1/sr);
# values above it suggest wrong units or a corrupt file. Near the horizon f
# itself legitimately grows without bound (RGL's f = (f cos theta_o) / cos theta_o
# reaches 2.6e7 1/sr at theta_o = 89.99 deg on a 64 x 64 x 128 grid), so there
# f cos theta_i cos theta_o is held to the same threshold (at most 1.5e2 in
# the RGL files, on any grid).
MAX_PLAUSIBLE_BRDF = 1e6                     # 1/sr
PLAUSIBLE_MAX_THETA_DEG = 80.0

# A table (almost) all zero holds nothing to fit: the fitted parameters go to their bounds.
# A value at or below NEGLIGIBLE_BRDF is zero for the fit (M1 compares log(1 + f cos theta_i):
# 1e-6 is a millionth of the log of a white diffuse surface's value, far below any fit's
# error), and a table in which fewer than MIN_SIGNAL_FRACTION of the valid samples rise
# above it -- all zero, all 1e-30, zero but for a few cells -- is flagged.  Measured tables
# are far from it: 99.4 to 99.9 % of the samples of the RGL-EPFL files and 100 % of MERL
# chrome rise above 1e-6 1/sr, and so do 60 % of a GGX mirror at half the roughness floor.
NEGLIGIBLE_BRDF = 1e-6                       # 1/sr
MIN_SIGNAL_FRACTION = 0.01


def plausibility_problems(measured: "MeasuredBRDF") -> list[str]:
    """Short sentences about valid-looking but implausible content of a
    MeasuredBRDF (an empty list if none): fewer than MIN_SIGNAL_FRACTION of the
    valid samples above NEGLIGIBLE_BRDF (a table of zeros or near-zeros); values
    above MAX_PLAUSIBLE_BRDF within PLAUSIBLE_MAX_THETA_DEG of the normal, or
    f cos theta_i cos theta_o above it anywhere."""
    valid = measured.valid
    values = measured.values[valid]
    if values.size == 0:
        return []
    signal = int(np.count_nonzero(np.max(values, axis=1) > NEGLIGIBLE_BRDF))
    if signal < MIN_SIGNAL_FRACTION * len(values):
        peak = float(np.max(values))
        what = ("all values are zero" if peak == 0.0 else "no value is above 0" if peak < 0.0 else
                f"all values are at most {NEGLIGIBLE_BRDF:g} 1/sr (peak {peak:.3g})" if signal == 0 else
                f"only {signal:,} of {len(values):,} valid samples are above {NEGLIGIBLE_BRDF:g} 1/sr")
        return [f"{what}: nothing to fit, the fitted parameters will sit at their bounds"]
    cos_i = np.clip(measured.wi[valid, 2], 0.0, 1.0)
    cos_o = np.clip(measured.wo[valid, 2], 0.0, 1.0)
    cos_limit = np.cos(np.radians(PLAUSIBLE_MAX_THETA_DEG)) - 1e-12
    inner = (cos_i >= cos_limit) & (cos_o >= cos_limit)
    peak = float(np.max(values[inner])) if inner.any() else 0.0
    if peak > MAX_PLAUSIBLE_BRDF:
        return [f"values up to {peak:.3g} 1/sr, above the {MAX_PLAUSIBLE_BRDF:.0e} 1/sr of any "
                "measured BRDF (wrong units or scale?)"]
    projected = float(np.max(values * (cos_i * cos_o)[:, None]))
    if projected > MAX_PLAUSIBLE_BRDF:
        return [f"values near the horizon with f cos(theta_i) cos(theta_o) up to {projected:.3g} 1/sr, "
                f"above the {MAX_PLAUSIBLE_BRDF:.0e} 1/sr of any measured BRDF (wrong units or scale?)"]
    return []


def read_file_bytes(path: str | os.PathLike[str], max_bytes: int | None = None) -> tuple[bytes, str]:
    """Read a whole file; returns (bytes, sha256 hex digest).

    Raises MeasuredDataError for a missing path, a directory, an empty file,
    a file larger than ``max_bytes`` (checked before reading) or a read error.
    """
    path = require_file(path)
    try:
        size = os.path.getsize(path)
        if size == 0:
            raise MeasuredDataError(path, "empty file (0 bytes)")
        if max_bytes is not None and size > max_bytes:
            raise MeasuredDataError(
                path, f"file is {size:,} bytes, more than the {max_bytes:,} this format can hold")
        with open_regular(path) as f:
            data = f.read(size + 1)      # never more than was checked (+1 to see growth)
    except OSError as e:
        raise MeasuredDataError(path, f"cannot read the file ({e.strerror or e})") from None
    if len(data) != size:
        raise MeasuredDataError(path, f"the file changed while being read ({size:,} bytes, then {len(data):,})")
    return data, hashlib.sha256(data).hexdigest()


def _readonly(a, dtype=None):
    a = np.asarray(a, dtype=dtype)
    view = a.view()
    view.flags.writeable = False
    return view


@dataclass(frozen=True, eq=False, repr=False)
class MeasuredBRDF(MeasuredDisplay):
    """Measured BRDF samples plus the native table for lookups (shown in notebooks: displayable.py).

    Fields (N samples, C channels, C = 3 unless ``channel()`` was used):

    - ``wi``, ``wo``: (N, 3) float64 unit vectors, local frame, away from the surface.
    - ``values``: (N, C) float64 BRDF without cosine, 1/sr; invalid entries are 0.
    - ``weights``: (N,) float64 solid-angle measure (sr^2) of each sample's cell in
      direction-pair space, in the format's native parameterisation, so that
      ``sum(w * f) / sum(w)`` approximates the mean of f over direction pairs.
    - ``valid``: (N,) bool; False for unmeasured cells (MERL negative values,
      below-horizon cells, negative sample-list values).
    - ``isotropic``: whether the data depend on phi_i, phi_o only through phi_i - phi_o.
    - ``provenance``: :class:`Provenance`.
    - ``table``: the format's native table, with ``lookup(wi, wo, method=None)``
      returning (M, 3) RGB.
    - ``channels``: names of the value columns, a subset of ("r", "g", "b").

    All arrays are read-only views.
    """

    wi: np.ndarray
    wo: np.ndarray
    values: np.ndarray
    weights: np.ndarray
    valid: np.ndarray
    isotropic: bool
    provenance: Provenance
    table: object = field(repr=False)
    channels: tuple = CHANNEL_NAMES

    def __post_init__(self):
        for name, dtype in (("wi", np.float64), ("wo", np.float64), ("values", np.float64),
                            ("weights", np.float64), ("valid", bool)):
            object.__setattr__(self, name, _readonly(getattr(self, name), dtype))
        n = self.wi.shape[0]
        if self.wi.shape != (n, 3) or self.wo.shape != (n, 3):
            raise ValueError(f"wi and wo must be (N, 3), got {self.wi.shape} and {self.wo.shape}")
        if self.values.shape != (n, len(self.channels)):
            raise ValueError(f"values must be (N, {len(self.channels)}), got {self.values.shape}")
        if self.weights.shape != (n,) or self.valid.shape != (n,):
            raise ValueError("weights and valid must be (N,)")
        if not all(c in CHANNEL_NAMES for c in self.channels):
            raise ValueError(f"channels must be among {CHANNEL_NAMES}, got {self.channels}")

    # ---- convenience properties -------------------------------------------------

    def __len__(self):
        return self.wi.shape[0]

    @property
    def n_valid(self) -> int:
        return int(np.count_nonzero(self.valid))

    @property
    def theta_i(self) -> Float[np.ndarray, " n"]:
        return dir_to_spherical(self.wi)[0]

    @property
    def theta_o(self) -> Float[np.ndarray, " n"]:
        return dir_to_spherical(self.wo)[0]

    @property
    def phi_i(self) -> Float[np.ndarray, " n"]:
        return dir_to_spherical(self.wi)[1]

    @property
    def phi_o(self) -> Float[np.ndarray, " n"]:
        return dir_to_spherical(self.wo)[1]

    @property
    def format(self) -> str:
        return self.provenance.format

    @property
    def material(self) -> str:
        return self.provenance.material

    # ---- evaluation -------------------------------------------------------------

    def lookup(self, wi: Float[ArrayLike, "m 3"], wo: Float[ArrayLike, "m 3"],
               method: str | None = None) -> Float[np.ndarray, "m c"]:
        """BRDF (M, C) at arbitrary direction pairs with the format's own interpolation.

        ``wi``, ``wo``: (M, 3) or (3,) directions in the local frame (normalised
        here). ``method`` is format specific (MERL: None/"nearest" or
        "trilinear"); None is the format's standard lookup. Directions below
        the horizon give 0.
        """
        wi = as_directions(wi, "wi")
        wo = as_directions(wo, "wo")
        if wi.shape != wo.shape:
            raise ValueError(f"wi and wo must have the same shape, got {wi.shape} and {wo.shape}")
        rgb = np.asarray(self.table.lookup(wi, wo, method=method), dtype=np.float64)
        return rgb[:, [CHANNEL_NAMES.index(c) for c in self.channels]]

    # ---- selections (each returns a new MeasuredBRDF) ------------------------------

    def _subset(self, index, note, weights=None):
        return MeasuredBRDF(
            wi=take_rows(self.wi, index), wo=take_rows(self.wo, index), values=take_rows(self.values, index),
            weights=take_rows(self.weights, index) if weights is None else weights,
            valid=self.valid[index], isotropic=self.isotropic,
            provenance=dataclasses.replace(
                self.provenance, history=self.provenance.history + (note,)),
            table=self.table, channels=self.channels)

    def drop_invalid(self) -> "MeasuredBRDF":
        """Only the valid samples."""
        return self._subset(np.flatnonzero(self.valid), "drop_invalid()")

    def select(self, max_theta_deg: float = 80.0, valid_only: bool = True) -> "MeasuredBRDF":
        """Grazing cut-off: keep samples with theta_i and theta_o <= ``max_theta_deg``.

        The other samples are dropped (not just marked), and with
        ``valid_only`` (default) invalid samples are dropped too. Weights are
        kept as they are (they still measure each kept cell).
        """
        cos_limit = np.cos(np.radians(max_theta_deg))
        keep = (self.wi[:, 2] >= cos_limit - 1e-12) & (self.wo[:, 2] >= cos_limit - 1e-12)
        if valid_only:
            keep &= self.valid
        return self._subset(np.flatnonzero(keep),
                            f"select(max_theta_deg={max_theta_deg:g}, valid_only={valid_only})")

    def subsample(self, n: int, seed: int = 0, bins: tuple[int, int] = (16, 16)) -> "MeasuredBRDF":
        """Stratified random subset of ``n`` valid samples (seeded, reproducible).

        Strata: ``bins[0]`` bins of sqrt(theta_h / (pi/2)) (MERL-like, fine near
        the specular peak) x ``bins[1]`` uniform bins of theta_d. Samples are
        allocated to strata in proportion to their counts (largest remainder),
        with at least one per non-empty stratum when ``n`` allows, drawn without
        replacement, and their weights are rescaled so that the weighted sum of
        each stratum is preserved. Invalid samples are never chosen. If ``n`` is
        at least the number of valid samples, all valid samples are returned.
        """
        n = int(n)
        if n < 1:
            raise ValueError(f"subsample needs n >= 1, got {n}")
        note = f"subsample(n={n}, seed={seed}, bins={tuple(bins)})"
        pool = np.flatnonzero(self.valid)
        if n >= pool.size:
            return self._subset(pool, note)
        nh, nd = int(bins[0]), int(bins[1])
        n_strata = nh * nd
        # int16 strata: numpy's stable sort is then a radix sort
        stratum = np.empty(pool.size, np.int16 if n_strata < 2 ** 15 else np.int64)
        for start in range(0, pool.size, STRATA_ROWS):      # small temporaries (see STRATA_ROWS)
            rows = pool[start:start + STRATA_ROWS]
            theta_h, _, theta_d, _ = std_to_half_diff(self.wi[rows], self.wo[rows])
            bh = np.minimum((np.sqrt(np.clip(theta_h, 0.0, None) / (np.pi / 2)) * nh).astype(np.int64), nh - 1)
            bd = np.minimum((theta_d / (np.pi / 2) * nd).astype(np.int64), nd - 1)
            stratum[start:start + rows.size] = bh * nd + bd
        counts = np.bincount(stratum, minlength=n_strata)
        take = _allocate(n, counts)

        rng = np.random.default_rng(seed)
        perm = rng.permutation(pool.size)
        perm = perm[np.argsort(stratum[perm], kind="stable")]   # grouped by stratum, random within
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        rank = np.arange(pool.size) - starts[stratum[perm]]
        chosen = np.sort(perm[rank < take[stratum[perm]]])

        w = self.weights[pool]
        s = stratum[chosen]
        total = np.bincount(stratum, weights=w, minlength=n_strata)
        kept = np.bincount(s, weights=w[chosen], minlength=n_strata)
        n_kept = np.bincount(s, minlength=n_strata)
        # rescale per stratum; if the chosen weights are all 0, share the total equally
        new_w = np.where(kept[s] > 0, w[chosen] * total[s] / np.where(kept[s] > 0, kept[s], 1.0),
                         total[s] / np.maximum(n_kept[s], 1))
        return self._subset(pool[chosen], note, weights=new_w)

    def channel(self, c: int | str | list[int | str]) -> "MeasuredBRDF":
        """Channel selection: ``c`` is an index or name ("r", "g", "b") or a list of them.

        The result has ``values`` of shape (N, len(c)) and its ``lookup``
        returns the same channels.
        """
        items = [c] if isinstance(c, (int, np.integer, str)) else list(c)
        names = []
        for item in items:
            if isinstance(item, str):
                if item.lower() not in self.channels:
                    raise ValueError(f"unknown channel {item!r}; available: {self.channels}")
                names.append(item.lower())
            elif 0 <= int(item) < len(self.channels):
                names.append(self.channels[int(item)])
            else:
                raise ValueError(f"channel index {item} out of range for {self.channels}")
        cols = [self.channels.index(name) for name in names]
        return MeasuredBRDF(
            wi=self.wi, wo=self.wo, values=self.values[:, cols], weights=self.weights,
            valid=self.valid, isotropic=self.isotropic,
            provenance=dataclasses.replace(
                self.provenance, history=self.provenance.history + (f"channel({names})",)),
            table=self.table, channels=tuple(names))

    # ---- report -----------------------------------------------------------------

    def summary_dict(self) -> dict[str, object]:
        """The summary as plain data (``brdf-fit info --json``): provenance, counts, per-channel ranges."""
        p = self.provenance
        v = self.values[self.valid]
        channels = {}
        for j, name in enumerate(self.channels):
            channels[name] = ({"min": float(np.min(v[:, j])), "median": float(np.median(v[:, j])),
                               "max": float(np.max(v[:, j]))} if v.shape[0] else None)
        return {"file": p.path, "format": p.format, "material": p.material, "description": p.description,
                "sha256": p.sha256, "isotropic": bool(self.isotropic), "units": p.units,
                "samples": len(self), "valid": int(self.n_valid),
                "weights_sum_sr2": float(self.weights.sum()),
                "valid_weights_sum_sr2": float(self.weights[self.valid].sum()),
                "history": list(p.history), "channels_per_sr": channels}

    def summary(self) -> str:
        """Human-readable summary: format, material, sample count, valid fraction, ranges."""
        d = self.summary_dict()
        n, nv = d["samples"], d["valid"]
        lines = [
            f"file:       {d['file']}",
            f"format:     {d['format']}",
            f"material:   {d['material']}" + (f" ({d['description']})" if d["description"] else ""),
            f"sha256:     {d['sha256']}",
            f"isotropic:  {'yes' if d['isotropic'] else 'no'}",
            f"units:      {d['units']}",
            f"samples:    {n:,} ({nv:,} valid, {100.0 * nv / max(n, 1):.1f} %)",
            f"weights:    sum {d['weights_sum_sr2']:.6g} sr^2 (valid {d['valid_weights_sum_sr2']:.6g})",
        ]
        if d["history"]:
            lines.append(f"history:    {'; '.join(d['history'])}")
        lines.append("channel        min     median        max   (valid samples, 1/sr)")
        for name, c in d["channels_per_sr"].items():
            if c is not None:
                lines.append(f"  {name}     {c['min']:10.4g} {c['median']:10.4g} {c['max']:10.4g}")
            else:
                lines.append(f"  {name}     (no valid samples)")
        return "\n".join(lines)


def _allocate(n, counts):
    """Split n draws over strata with ``counts`` members: proportional, largest
    remainder, at least one per non-empty stratum when n allows."""
    nonempty = counts > 0
    base = nonempty.astype(np.int64) if n >= np.count_nonzero(nonempty) else np.zeros_like(counts)
    rest_counts = counts - base
    left = n - base.sum()
    quota = left * rest_counts / max(rest_counts.sum(), 1)
    take = np.floor(quota).astype(np.int64)
    short = left - take.sum()
    if short > 0:
        order = np.argsort(-(quota - take), kind="stable")[:short]
        take[order] += 1
    return np.minimum(base + take, counts)
