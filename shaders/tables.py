"""The library's tables as textures: the GGX energy tables energy.glsl reads, the sheen's albedo
sheen.glsl reads and Cycles' tables principled.glsl reads, each an R32F texture on a unit of its own
(``TABLE_UNITS``), read with texelFetch and the interpolation weights of the JAX lookups, so the GPU
sees the very numbers JAX interpolates.  ``bind_tables`` binds those a program reads.
"""

import numpy as np

from .gl import gl_cache, set_uniform

#: Texture units the library's own samplers use (the renderer's: 0-4, shaders/scene.py and
#: shaders/measured.py; the diffuse lobe's image-lighting table 13, shaders/diffuse_ibl.py).
SHEEN_E_UNIT = 12
ENERGY_E_UNIT = 14
ENERGY_E_AVG_UNIT = 15
CYCLES_S_UNIT, CYCLES_E_UNIT, CYCLES_E_AVG_UNIT = 9, 10, 11
#: each table's sampler uniform -> its texture unit
TABLE_UNITS = {"brdf_energy_e": ENERGY_E_UNIT, "brdf_energy_e_avg": ENERGY_E_AVG_UNIT, "brdf_sheen_e": SHEEN_E_UNIT,
               "brdf_cycles_s": CYCLES_S_UNIT, "brdf_cycles_e": CYCLES_E_UNIT, "brdf_cycles_e_avg": CYCLES_E_AVG_UNIT}


def table_array(name):
    """The float32 2-D table the sampler uniform ``name`` (TABLE_UNITS) reads: energy.glsl's E[mu, r]
    (rows by mu) and E_avg[r], sheen.glsl's E[mu, r], principled.glsl's Cycles tables (brdf/cycles.py:
    S[z, mu, r] as 16 x 16 rows by z then mu, E[mu, r] and E_avg[r])."""
    if name.startswith("brdf_cycles"):
        from brdf.cycles import dielectric_s_table, ggx_albedo_tables
        s, (e, e_avg) = dielectric_s_table(), ggx_albedo_tables()
        table = {"brdf_cycles_s": s.reshape(-1, s.shape[-1]), "brdf_cycles_e": e, "brdf_cycles_e_avg": e_avg[None, :]}
    elif name == "brdf_sheen_e":
        from brdf.sheen import sheen_table
        table = {name: sheen_table()["E"]}
    else:
        from brdf.energy import tables
        t = tables()
        table = {"brdf_energy_e": t["E"], "brdf_energy_e_avg": t["E_avg"][None, :]}
    return np.ascontiguousarray(table[name], dtype=np.float32)


_TABLE_TEXTURES = gl_cache()


def table_texture(ctx, name):
    """The R32F texture of ``table_array(name)`` on ``ctx`` (cached)."""
    key = (id(ctx), name)
    if key not in _TABLE_TEXTURES:
        import moderngl
        table = table_array(name)
        tex = ctx.texture((table.shape[1], table.shape[0]), 1, table.tobytes(), dtype="f4")
        tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        tex.repeat_x = tex.repeat_y = False
        _TABLE_TEXTURES[key] = tex
    return _TABLE_TEXTURES[key]


def bind_tables(ctx, program):
    """Bind the library's tables the program reads to their units (TABLE_UNITS) and point its samplers
    at them (a table no sampler of the program reads is neither made nor bound)."""
    for name, unit in TABLE_UNITS.items():
        if program.get(name, None) is not None:
            table_texture(ctx, name).use(location=unit)
            set_uniform(program, name, unit)
