"""Diffuse lobes under image lighting: the moment tables diffuse.glsl reads.

The split sum pre-integrates the specular lobe (DFG table, prefiltered map);
this module does the same for the diffuse lobe (docs/renderer.md).  For a
view direction v with n.v = mu, the lobe seen as a function of the light
direction, g(l) = f_d(l, v) cos(theta_l) with rho = 1, is tabulated by its
moments in the frame (t, b, n) of v (v = (sin theta_v, 0, mu)):

    m0 = int g dl                the directional albedo E_d (REFERENCE.md s.4)
    m1 = int g l dl              components t, n   (b vanishes: g is even in b)
    m2 = int g l l^T dl          entries tt, bb, nn, tn

on a (mu, x) grid, x = perceptual roughness (Burley, Frostbite, CoD: WWII) or
the Oren-Nayar sigma.  The environment's irradiance is already a 9-coefficient
SH expansion, i.e. its radiance a polynomial of degree 2 in l; against it these
moments give int L g dl exactly (ibl.glsl's sh_lobe_radiance).  So the lobe's
view dependence (Burley's grazing gain, Frostbite's loss) and the tilt of
retro-reflective lobes towards v (CoD, Oren-Nayar) are kept, at the SH's
own accuracy; Lambert's moments are constants and give the SH irradiance / pi.

The lobes are brdf/'s own (``brdf.model.DIFFUSES``, JAX), integrated by
Gauss-Legendre quadrature in cos(theta_l) and the midpoint rule in phi.
"""

import functools

import numpy as np

from brdf.constants import ROUGHNESS_MIN

from .gl import gl_cache

#: The tabulated moments, in this order (RGBA texel k: the first four; k + N: the rest).
MOMENTS = ("m0", "m1_t", "m1_n", "m2_tn", "m2_tt", "m2_bb", "m2_nn")
#: (mu, x) nodes of each table: mu_j = j / (N - 1), x_k uniform over the axis.
TABLE_SIZE = 32
#: Quadrature nodes in cos(theta_l) (Gauss-Legendre on [0, 1]) and phi (midpoint on [0, pi]).
COS_NODES = 64
PHI_NODES = 64
#: Texture unit of the table (the energy tables use 14 and 15).
TABLE_UNIT = 13
#: (mu, x) pairs integrated per JAX call (memory: pairs x nodes x a few arrays).
PAIRS_PER_CALL = 32
#: Smallest n.v the tables are evaluated at (the shaders clamp to COS_EPS as well).
MU_MIN = 1e-4


def table_axis(diffuse):
    """(parameter name, first node, last node) of the table's second axis, or
    None for a lobe without a table (none, Lambert)."""
    from brdf.model import DIFFUSES
    term = DIFFUSES[diffuse]
    if diffuse in ("none", "lambert") or term.lobe is None:
        return None
    shape = [p for p in term.params if p.name != "albedo"]
    if shape:                                    # Oren-Nayar's sigma
        return shape[0].name, float(shape[0].lower), float(shape[0].upper)
    return "roughness", float(ROUGHNESS_MIN), 1.0


def _nodes(cos_nodes, phi_nodes):
    """(wi (M, 3), weights (M,)) of the hemisphere quadrature (solid angle)."""
    c, wc = np.polynomial.legendre.leggauss(cos_nodes)
    c, wc = 0.5 * (c + 1.0), 0.5 * wc                        # cos(theta_l) on [0, 1]
    phi = (np.arange(phi_nodes) + 0.5) * (np.pi / phi_nodes)
    s = np.sqrt(1.0 - c * c)
    wi = np.stack(np.broadcast_arrays(s[:, None] * np.cos(phi), s[:, None] * np.sin(phi),
                                      c[:, None]), axis=-1).reshape(-1, 3)
    # phi in [0, pi] covers half the hemisphere: the lobes are even in phi
    # (and the moments kept are even in b).
    weight = (wc[:, None] * np.full(phi_nodes, 2.0 * np.pi / phi_nodes)).ravel()
    return wi, weight


def _features(wi):
    """(M, 7) the functions of l whose integrals against g are MOMENTS."""
    x, y, z = wi[:, 0], wi[:, 1], wi[:, 2]
    return np.stack([np.ones_like(x), x, z, x * z, x * x, y * y, z * z], axis=-1)


@functools.lru_cache(maxsize=None)
def _integrator(diffuse, cos_nodes, phi_nodes):
    """A jitted (mu (P,), x (P,)) -> moments (P, 7) for one lobe."""
    import jax
    import jax.numpy as jnp
    from brdf.model import DIFFUSES, geometry, roughness_alpha
    name = table_axis(diffuse)[0]
    lobe = DIFFUSES[diffuse].lobe
    wi, weight = _nodes(cos_nodes, phi_nodes)
    # g = f cos(theta_l): the cosine goes into the weights
    kernel = jnp.asarray((weight * wi[:, 2])[:, None] * _features(wi), jnp.float32)
    wi = jnp.asarray(wi, jnp.float32)

    def moments(mu, x):
        m = jnp.maximum(mu, MU_MIN)[:, None]
        wo = jnp.stack(jnp.broadcast_arrays(jnp.sqrt(1.0 - m * m), jnp.zeros_like(m), m), axis=-1)
        shape = m.shape[:1] + wi.shape
        g = geometry(jnp.broadcast_to(wi, shape), jnp.broadcast_to(wo, shape))
        value = x[:, None]
        r, a = roughness_alpha(value if name == "roughness" else jnp.full_like(value, 0.5))
        f = lobe({"albedo": jnp.float32(1.0), name: value}, g, r, a)
        return f @ kernel

    return jax.jit(moments)


def lobe_moments(diffuse, mu, x, cos_nodes=COS_NODES, phi_nodes=PHI_NODES):
    """MOMENTS of brdf's ``diffuse`` lobe (rho = 1) by quadrature: float64
    (*broadcast(mu, x), 7).  ``x`` is the table_axis parameter."""
    mu, x = np.broadcast_arrays(np.asarray(mu, float), np.asarray(x, float))
    fn = _integrator(diffuse, cos_nodes, phi_nodes)
    flat_mu, flat_x = mu.ravel(), x.ravel()
    out = np.empty((flat_mu.size, len(MOMENTS)))
    for start in range(0, flat_mu.size, PAIRS_PER_CALL):
        chunk = slice(start, start + PAIRS_PER_CALL)
        m = np.zeros(PAIRS_PER_CALL, np.float32)          # fixed shapes: one compilation
        v = np.zeros(PAIRS_PER_CALL, np.float32)
        n = flat_mu[chunk].size
        m[:n], v[:n] = flat_mu[chunk], flat_x[chunk]
        out[chunk] = np.asarray(fn(m, v), np.float64)[:n]
    return out.reshape(mu.shape + (len(MOMENTS),))


def directional_albedo(diffuse, mu, x, cos_nodes=COS_NODES, phi_nodes=PHI_NODES):
    """E_d(mu, x) = m0, the white-furnace directional albedo of the lobe (rho = 1)."""
    return lobe_moments(diffuse, mu, x, cos_nodes, phi_nodes)[..., 0]


@functools.lru_cache(maxsize=None)
def table(diffuse, size=TABLE_SIZE):
    """{"mu" (size,), "x" (size,), "axis" (name, first, last), "moments" (size,
    size, 7) [mu, x, MOMENTS]} for ``diffuse``, or None when it needs no table.
    Computed on first use (well under a second per lobe) and cached."""
    axis = table_axis(diffuse)
    if axis is None:
        return None
    mu = np.linspace(0.0, 1.0, size)
    x = np.linspace(axis[1], axis[2], size)
    return {"mu": mu, "x": x, "axis": axis, "moments": lobe_moments(diffuse, mu[:, None], x[None, :])}


def texture_data(diffuse):
    """float32 (size_mu, 2 size_x, 4) texels of the table as diffuse.glsl reads
    it: texel (k, j) = (m0, m1_t, m1_n, m2_tn), texel (k + size_x, j) =
    (m2_tt, m2_bb, m2_nn, 0); None without a table."""
    t = table(diffuse)
    if t is None:
        return None
    m = t["moments"]
    rest = np.concatenate([m[..., 4:], np.zeros(m.shape[:2] + (1,))], axis=-1)
    return np.ascontiguousarray(np.concatenate([m[..., :4], rest], axis=1), np.float32)


_TEXTURES = gl_cache()


def table_texture(ctx, diffuse):
    """The RGBA32F texture of ``texture_data(diffuse)`` on ``ctx`` (cached);
    None for a lobe without a table."""
    key = (id(ctx), diffuse)
    if key not in _TEXTURES:
        import moderngl
        data = texture_data(diffuse)
        tex = None
        if data is not None:
            tex = ctx.texture((data.shape[1], data.shape[0]), 4, data.tobytes(), dtype="f4")
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            tex.repeat_x = tex.repeat_y = False
        _TEXTURES[key] = tex
    return _TEXTURES[key]


def bind_table(ctx, program, spec):
    """Bind the table of the spec's diffuse lobe (if the program reads one) to TABLE_UNIT."""
    from .gl import set_uniform
    if program.get("brdf_diffuse_moments", None) is None:
        return
    tex = table_texture(ctx, spec.diffuse)
    if tex is None:
        return
    tex.use(location=TABLE_UNIT)
    set_uniform(program, "brdf_diffuse_moments", TABLE_UNIT)
    _, first, last = table(spec.diffuse)["axis"]
    set_uniform(program, "brdf_diffuse_moments_axis", (first, last))
