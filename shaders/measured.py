"""Measured BRDF tables for the GPU (``measured.glsl``), built from plain numpy.

``MeasuredTable`` holds a float32 array in the layout measured.glsl reads:

- ``kind="merl"``: (90 * 90 * 180, 3) RGB interleaved, in 1/sr, 0 where invalid;
  looked up with the standard MERL floor index and the phi_d reciprocity fold.
- ``kind="utia"``: the (3, 6, 48, 6, 48) table as it is stored, quadrilinear
  (Filip), signed azimuths from the tangent frame.

``MeasuredTable.from_measured(m)`` accepts what the rest of the toolkit hands
over, without importing data_loaders: an object with a native ``table``
(data_loaders' MerlTable: ``rgb`` (90, 90, 180, 3) and ``valid``; UtiaTable:
``data`` (3, 6, 48, 6, 48) and ``decode``), anything with ``lookup(wi, wo)``
(resampled at the MERL cell centres, isotropic), or a plain callable
``f(wi, wo) -> (M, 3)``.
"""

import dataclasses

import numpy as np

from .gl import gl_cache

MERL_SHAPE = (90, 90, 180)
MERL_CELLS = 90 * 90 * 180
MERL_SCALES = np.array([1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0])
UTIA_SHAPE = (3, 6, 48, 6, 48)
UTIA_DECODES = (None, "dj_brdf")
FLOAT32_MAX = float(np.finfo(np.float32).max)


@dataclasses.dataclass(frozen=True, eq=False)
class MeasuredTable:
    kind: str                 # "merl" | "utia"
    values: np.ndarray        # float32, the layout measured.glsl reads
    decode: str = None        # UTIA only: None or "dj_brdf"
    name: str = "measured"

    def __post_init__(self):
        if self.kind not in ("merl", "utia"):
            raise ValueError(f"measured table kind must be 'merl' or 'utia', got {self.kind!r}")
        expect = (MERL_CELLS, 3) if self.kind == "merl" else UTIA_SHAPE
        values = np.asarray(self.values)
        if values.shape != expect:
            raise ValueError(f"a {self.kind} table has shape {expect}, got {values.shape}")
        if not np.all(np.isfinite(values)):
            raise ValueError(f"{self.name}: the {self.kind} table has NaN or inf values")
        # Finite values beyond float32's range (a file in wrong units, which its loader
        # warned about) are held at its largest number, not cast to inf.
        values = np.ascontiguousarray(np.clip(values, -FLOAT32_MAX, FLOAT32_MAX), dtype=np.float32)
        if self.decode not in UTIA_DECODES or (self.decode and self.kind != "utia"):
            raise ValueError(f"decode must be one of {UTIA_DECODES} (UTIA only), got {self.decode!r}")
        object.__setattr__(self, "values", values)

    @property
    def define(self):
        """The fragment shader's #define for this table."""
        return "RENDER_MEASURED_" + self.kind.upper()

    # --- constructors ----------------------------------------------------------
    @classmethod
    def from_merl_rgb(cls, rgb, valid=None, name="merl"):
        """From a (90, 90, 180, 3) table in 1/sr ([theta_h][theta_d][phi_d][c])."""
        rgb = np.asarray(rgb, dtype=np.float64)
        if rgb.shape != MERL_SHAPE + (3,):
            raise ValueError(f"a MERL RGB table is (90, 90, 180, 3), got {rgb.shape}")
        if valid is not None:
            rgb = np.where(np.asarray(valid, bool)[..., None], rgb, 0.0)
        return cls("merl", rgb.reshape(MERL_CELLS, 3), name=name)

    @classmethod
    def from_merl_raw(cls, raw, name="merl"):
        """From the raw file values: 3 x 1,458,000 channel-planar, unscaled
        (negative = unmeasured, set to 0), as docs/data-formats.md describes."""
        raw = np.asarray(raw, dtype=np.float64).reshape(3, MERL_CELLS)
        rgb = np.where(raw >= 0.0, raw, 0.0) * MERL_SCALES[:, None]
        return cls("merl", rgb.T, name=name)

    @classmethod
    def from_utia(cls, data, decode=None, name="utia"):
        """From a (3, 6, 48, 6, 48) UTIA table ([c][theta_i][phi_i][theta_v][phi_v])."""
        return cls("utia", np.asarray(data, dtype=np.float64).reshape(UTIA_SHAPE), decode=decode, name=name)

    @classmethod
    def resample(cls, lookup, name="resampled", chunk=200_000):
        """Tabulate any ``lookup(wi, wo) -> (M, 3)`` at the MERL cell centres (phi_h = 0).

        An isotropic resampling: anisotropic data lose their azimuthal
        dependence (use a native UTIA table for those)."""
        wi, wo = merl_cell_directions()
        out = np.zeros((MERL_CELLS, 3))
        for start in range(0, MERL_CELLS, chunk):
            sl = slice(start, start + chunk)
            above = (wi[sl, 2] > 0.0) & (wo[sl, 2] > 0.0)
            if not above.any():
                continue
            vals = np.asarray(lookup(wi[sl][above], wo[sl][above]), dtype=np.float64)
            vals = vals.reshape(-1, vals.shape[-1] if vals.ndim > 1 else 1)
            if vals.shape[1] == 1:
                vals = np.repeat(vals, 3, axis=1)
            block = np.zeros((min(chunk, MERL_CELLS - start), 3))
            block[above] = np.nan_to_num(vals[:, :3], nan=0.0, posinf=0.0, neginf=0.0)
            out[sl] = block
        return cls("merl", out, name=name)

    @classmethod
    def from_measured(cls, measured):
        """A MeasuredTable from a MeasuredTable, a data_loaders MeasuredBRDF (or
        its native table), an object with ``lookup(wi, wo)``, or a callable."""
        if isinstance(measured, MeasuredTable):
            return measured
        name = getattr(measured, "material", None) or getattr(
            getattr(measured, "provenance", None), "material", None) or "measured"
        table = getattr(measured, "table", measured)
        rgb = getattr(table, "rgb", None)
        if rgb is not None and np.shape(rgb) == MERL_SHAPE + (3,):
            return cls.from_merl_rgb(rgb, getattr(table, "valid", None), name=name)
        data = getattr(table, "data", None)
        if data is not None and np.shape(data) == UTIA_SHAPE:
            return cls.from_utia(data, getattr(table, "decode", None), name=name)
        if hasattr(measured, "lookup"):
            return cls.resample(measured.lookup, name=name)
        if callable(measured):
            return cls.resample(measured, name=name)
        raise TypeError(f"cannot make a GPU table of {type(measured).__name__}: give a MeasuredBRDF, "
                        "a MERL / UTIA table, an object with lookup(wi, wo) or a callable")


def merl_cell_directions():
    """(wi, wo) float64 (1458000, 3) at the MERL cell centres with phi_h = 0
    (theta_h = ((i + 0.5)/90)^2 pi/2, theta_d = (j + 0.5) pi/180, phi_d = (k + 0.5) pi/180)."""
    th = ((np.arange(90) + 0.5) / 90) ** 2 * (np.pi / 2)
    td = (np.arange(90) + 0.5) / 90 * (np.pi / 2)
    pd = (np.arange(180) + 0.5) / 180 * np.pi
    th, td, pd = np.meshgrid(th, td, pd, indexing="ij")
    d = np.stack([np.sin(td) * np.cos(pd), np.sin(td) * np.sin(pd), np.cos(td)], axis=-1)
    ct, st = np.cos(th)[..., None], np.sin(th)[..., None]
    # wi = R_y(theta_h) d  (phi_h = 0), wo = 2 (wi.h) h - wi with h = (sin th, 0, cos th)
    wi = np.stack([ct[..., 0] * d[..., 0] + st[..., 0] * d[..., 2], d[..., 1],
                   -st[..., 0] * d[..., 0] + ct[..., 0] * d[..., 2]], axis=-1)
    h = np.stack([st[..., 0], np.zeros_like(th), ct[..., 0]], axis=-1)
    wo = 2.0 * np.sum(wi * h, axis=-1, keepdims=True) * h - wi
    return wi.reshape(-1, 3), wo.reshape(-1, 3)


#: Texture unit of the measured table (+1 for the unused sampler; the renderer's
#: other samplers use 0-2 and 13-15).
TABLE_UNIT = 3
#: UTIA as a 2D texture: rows (theta_i, phi_i), columns (theta_v, phi_v).
UTIA_TEXTURE_SIDE = UTIA_SHAPE[1] * UTIA_SHAPE[2]

_TEXTURES = gl_cache()


def texture_data(table):
    """(size, float32 RGB texels) of the texture measured.glsl reads for ``table``:
    MERL (180, 90, 90) 3D, texel (i_pd, i_td, i_th); UTIA (288, 288) 2D, texel
    (48 i_tv + i_pv, 48 i_ti + i_pi)."""
    if table.kind == "merl":
        return MERL_SHAPE[::-1], table.values                    # already [th][td][pd][c]
    rgb = np.moveaxis(table.values, 0, -1)                       # [ti][pi][tv][pv][c]
    return (UTIA_TEXTURE_SIDE, UTIA_TEXTURE_SIDE), np.ascontiguousarray(rgb, np.float32)


def table_texture(ctx, table):
    """The RGB32F texture holding ``table`` on ``ctx`` (cached per table object)."""
    import moderngl
    key = (id(ctx), id(table))
    if key not in _TEXTURES:
        if len(_TEXTURES) > 4:
            for k in list(_TEXTURES)[:-4]:
                _TEXTURES.pop(k)[1].release()
        size, data = texture_data(table)
        make = ctx.texture3d if len(size) == 3 else ctx.texture
        tex = make(size, 3, data.tobytes(), dtype="f4")
        tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        _TEXTURES[key] = (table, tex)
    return _TEXTURES[key][1]


def bind_table(ctx, program, table):
    """Bind the table's texture to TABLE_UNIT and set its uniforms."""
    from .gl import set_uniform
    table_texture(ctx, table).use(location=TABLE_UNIT)
    used, other = ("measured_merl", "measured_utia") if table.kind == "merl" else ("measured_utia", "measured_merl")
    set_uniform(program, used, TABLE_UNIT)
    set_uniform(program, other, TABLE_UNIT + 1)   # samplers of two types must not share a unit
    set_uniform(program, "utia_decode", 1 if table.decode == "dj_brdf" else 0)


def evaluate_measured(table, wi, wo):
    """The GPU lookup of ``table`` at N direction pairs (parity harness): float32 (N, 3)."""
    from . import parity
    from .gl import get_context
    table = MeasuredTable.from_measured(table)
    wi = np.asarray(wi, np.float32).reshape(-1, 3)
    wo = np.asarray(wo, np.float32).reshape(-1, 3)
    fn = "merl_lookup" if table.kind == "merl" else "utia_lookup"
    n, arrays = parity._prepare_inputs({"wi": wi, "wo": wo})
    source, line_map = parity._kernel(f"{fn}(wi, wo)", arrays, ("measured.glsl",))
    ctx = get_context()
    from .gl import compute_program
    program = compute_program(source, line_map)
    bind_table(ctx, program, table)
    out = parity._run(source, line_map, n, np.concatenate([wi, wo], axis=1))
    return out[:, :3]
