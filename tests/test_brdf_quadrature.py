"""Integral identities of the models, by our own quadrature (float64).

- NDF normalisation: int D(m) (n.m) dw_m = 1.
- Projected area: int max(0, v.m) D(m) dw_m = (n.v)(1 + Lambda(v)), which is
  the integral definition of Smith's G1 = cos(theta_v) / int max(0, v.m) D dw_m.
- White-furnace albedo of the diffuse lobes (REFERENCE.md s.4 table).
- White furnace of the GGX lobe through ``brdf.evaluate``: F = 1 single
  scattering reproduces E(mu, alpha) of REFERENCE.md s.5, and Kulla-Conty
  (or Turquin with F0 = 1) restores an albedo of 1.

All quadratures are tensor-product Gauss-Legendre rules.  Half vectors are
importance-warped in theta, theta = atan(s tan(pi u / 2)) (exact Jacobian
below), and every kink of an integrand (the max(0, .) of the projected area,
the horizon n.l = 0 seen from the half-vector domain, Oren-Nayar's
min/max(theta_i, theta_o) and max(0, cos dphi)) is put on a panel boundary
so that each panel integrates a smooth function.
"""

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import brdf
from brdf import diffuse, specular

QUAD_RTOL = 1e-3
# LLVM optimisation level 0 for the quadrature kernels: compile time dominates
# here, and IEEE semantics are unchanged (XLA CPU fast-math stays off).
FAST_COMPILE = {"xla_backend_optimization_level": 0}


@functools.lru_cache(maxsize=None)
def _leggauss(n):
    return np.polynomial.legendre.leggauss(n)


def gl(n, a=0.0, b=1.0):
    """Gauss-Legendre nodes and weights on [a, b] (a, b may be arrays: nodes on the last axis)."""
    x, w = _leggauss(n)
    a, b = np.asarray(a, float)[..., None], np.asarray(b, float)[..., None]
    return a + (b - a) * 0.5 * (x + 1.0), (b - a) * 0.5 * w


def warp(u, s):
    """theta = atan(s tan(pi u / 2)) and d theta / d u."""
    x = 0.5 * np.pi * u
    return np.arctan(s * np.tan(x)), s * 0.5 * np.pi / (np.cos(x) ** 2 + (s * np.sin(x)) ** 2)


def u_of_theta(theta, s):
    return 2.0 / np.pi * np.arctan(np.tan(theta) / s)


def sph(theta, phi):
    st = np.sin(theta)
    return np.stack(np.broadcast_arrays(st * np.cos(phi), st * np.sin(phi), np.cos(theta)), axis=-1)


def sph_deg(theta, phi):
    return sph(math.radians(theta), math.radians(phi))


V_TEST = sph_deg(40.0, 20.0)


# --- NDF normalisation ------------------------------------------------------------

def d_cos_nodes(s, n=256):
    """Directions m and weights w with sum w g(m) = int g(m) (n.m) dw_m, theta warped with scale s."""
    u, wu = gl(n)
    th, dth = warp(u, s)
    ph, wph = gl(n, 0.0, 2 * np.pi)
    m = sph(th[:, None], ph[None, :])
    return m, (wu * dth * np.sin(th) * np.cos(th))[:, None] * wph[None, :]


@functools.partial(jax.jit, compiler_options=FAST_COMPILE)
def _sum_d_iso(alpha, m, w):
    return jnp.sum(specular.ggx_ndf(m[..., 2], alpha) * w)


@functools.partial(jax.jit, compiler_options=FAST_COMPILE)
def _sum_d_aniso(at, ab, m, w):
    return jnp.sum(specular.ggx_ndf_aniso(m, at, ab) * w)


@pytest.mark.parametrize("alpha", [0.05, 0.25, 1.0, brdf.ALPHA_MIN])
def test_ndf_normalised_iso(alpha):
    total = float(_sum_d_iso(alpha, *d_cos_nodes(alpha)))
    assert abs(total - 1.0) < 1e-6


@pytest.mark.parametrize("at, ab", [(0.3, 0.1), (0.05, 0.5), (0.25, 0.25)])
def test_ndf_normalised_aniso(at, ab):
    total = float(_sum_d_aniso(at, ab, *d_cos_nodes(math.sqrt(at * ab))))
    assert abs(total - 1.0) < 1e-6


# --- projected area and Smith G1 ----------------------------------------------------

def projected_area_nodes(v, s, n=160):
    """Directions m and weights w with sum w g(m) = int max(0, v.m) g(m) dw_m.

    Panels in theta_m: [0, pi/2 - theta_v] where v.m > 0 for every phi, and
    [pi/2 - theta_v, pi/2] where phi is limited to |phi - phi_v| < arccos(-cot th_v cot th_m).
    """
    v = np.asarray(v, float)
    tv, pv = math.acos(v[2]), math.atan2(v[1], v[0])
    uc = u_of_theta(0.5 * np.pi - tv, s) if tv > 0 else 1.0
    ms, ws = [], []
    for (u0, u1), full in (((0.0, uc), True), ((uc, 1.0), False)):
        u, wu = gl(n, u0, u1)
        th, dth = warp(u, s)
        if full:
            half = np.full_like(th, np.pi)
        else:
            c = -v[2] * np.cos(th) / max(math.sin(tv), 1e-300) / np.sin(th)
            half = np.arccos(np.clip(c, -1.0, 1.0))
        ph, wph = gl(n, pv - half, pv + half)                 # (n_theta, n_phi)
        m = sph(th[:, None], ph)
        ms.append(m)
        ws.append((wu * dth * np.sin(th))[:, None] * wph * np.maximum(m @ v, 0.0))
    return np.concatenate(ms), np.concatenate(ws)


def projected_area_iso(alpha, v):
    return float(_sum_d_iso(alpha, *projected_area_nodes(v, alpha)))


def projected_area_aniso(at, ab, v):
    return float(_sum_d_aniso(at, ab, *projected_area_nodes(v, math.sqrt(at * ab))))


def test_projected_area_reference_values():
    # REFERENCE.md s.1: test v, alpha = 0.3 -> 0.777994; (0.3, 0.1) -> 0.776768
    np.testing.assert_allclose(projected_area_iso(0.3, V_TEST), 0.777994, atol=5e-7)
    np.testing.assert_allclose(projected_area_aniso(0.3, 0.1, V_TEST), 0.776768, atol=5e-7)
    np.testing.assert_allclose(V_TEST[2] * (1 + specular.smith_lambda(V_TEST[2], 0.3)), 0.777994, atol=5e-7)
    np.testing.assert_allclose(V_TEST[2] * (1 + specular.smith_lambda_aniso(V_TEST, 0.3, 0.1)),
                               0.776768, atol=5e-7)


@pytest.mark.parametrize("alpha", [0.05, 0.3, 0.7, 1.0])
@pytest.mark.parametrize("theta_v", [0.0, 30.0, 60.0, 80.0, 88.0])
def test_smith_g1_integral_definition(alpha, theta_v):
    # G1(v) = cos theta_v / int max(0, v.m) D(m) dw_m = 1 / (1 + Lambda(v))
    v = sph_deg(theta_v, 35.0)
    g1_integral = v[2] / projected_area_iso(alpha, v)
    np.testing.assert_allclose(specular.smith_g1(v[2], alpha), g1_integral, rtol=1e-6)
    np.testing.assert_allclose(1.0 / (1.0 + specular.smith_lambda(v[2], alpha)), g1_integral, rtol=1e-6)


@pytest.mark.parametrize("at, ab", [(0.3, 0.1), (0.1, 0.5), (0.9, 0.2)])
@pytest.mark.parametrize("theta_v, phi_v", [(40.0, 20.0), (75.0, 100.0), (85.0, -60.0)])
def test_smith_lambda_aniso_integral_definition(at, ab, theta_v, phi_v):
    # the theta warp follows sqrt(at ab) and phi is not warped: 1e-5 at a 5:1 aspect ratio
    v = sph_deg(theta_v, phi_v)
    g1_integral = v[2] / projected_area_aniso(at, ab, v)
    np.testing.assert_allclose(1.0 / (1.0 + specular.smith_lambda_aniso(v, at, ab)), g1_integral, rtol=1e-5)


# --- diffuse white furnace (REFERENCE.md s.4) ------------------------------------------

def _dots(wi, wo):
    h = wi + wo
    h = h / jnp.linalg.norm(h, axis=-1, keepdims=True)
    return wi[..., 2], wo[..., 2], jnp.sum(wi * h, -1), h[..., 2]


DIFFUSE = {
    "burley": lambda p, wi, wo: diffuse.burley(1.0, p, *_dots(wi, wo)[:3]),
    "frostbite": lambda p, wi, wo: diffuse.frostbite(1.0, p, *_dots(wi, wo)[:3]),
    "cod_wwii": lambda p, wi, wo: diffuse.cod_wwii(1.0, p, *_dots(wi, wo)),
    "oren_nayar": lambda p, wi, wo: diffuse.oren_nayar(1.0, p, wi, wo),
    "oren_nayar_full": lambda p, wi, wo: diffuse.oren_nayar_full(1.0, p, wi, wo),
    "lambert": lambda p, wi, wo: diffuse.lambert(1.0, wi[..., 2], wo[..., 2]),
}


def diffuse_albedo_nodes(mus, n=32):
    """(wi, wo, w) with sum over the last three axes of w f(wi, wo) = E(mu) = int f (n.wi) dw_i
    for wo = (sqrt(1-mu^2), 0, mu), one row per mu.

    Panels: n.wi in [0, mu] and [mu, 1] (theta_i = theta_o kink of Oren-Nayar);
    phi_i in [-pi/2, pi/2] and [pi/2, 3pi/2] (its max(0, cos dphi), |cos dphi|).
    """
    mus = np.asarray(mus, float)
    wis, ws = [], []
    for a, b in ((0.0 * mus, mus), (mus, 0.0 * mus + 1.0)):
        c, wc = gl(n, a, b)                                       # (n_mu, n)
        for p0, p1 in ((-0.5 * np.pi, 0.5 * np.pi), (0.5 * np.pi, 1.5 * np.pi)):
            ph, wph = gl(n, p0, p1)
            st = np.sqrt(1.0 - c * c)[..., None]
            wis.append(np.stack(np.broadcast_arrays(st * np.cos(ph), st * np.sin(ph), c[..., None]), -1))
            ws.append((wc * c)[..., None] * wph)
    wi = np.concatenate(wis, axis=1)                              # (n_mu, 4n, n, 3)
    wo = np.stack([np.sqrt(1 - mus * mus), 0 * mus, mus], -1)[:, None, None, :]
    return wi, np.broadcast_to(wo, wi.shape), np.concatenate(ws, axis=1)


@functools.lru_cache(maxsize=None)
def _albedo_kernel(name):
    return jax.jit(lambda p, wi, wo, w: jnp.sum(DIFFUSE[name](p, wi, wo) * w, axis=(-2, -1)),
                   compiler_options=FAST_COMPILE)


def diffuse_albedo(name, p, mus, n=32):
    return np.asarray(_albedo_kernel(name)(p, *diffuse_albedo_nodes(mus, n)))


DIFFUSE_TABLE = [  # model, parameter, E(1), E(0.5), E(0.1), E_avg
    ("lambert", None, 1.0, 1.0, 1.0, 1.0),
    ("burley", 0.0, .9762, .9609, .6880, .9529),
    ("burley", 0.5, 1.0060, 1.0083, 1.0235, 1.0082),
    ("burley", 1.0, 1.0357, 1.0569, 1.3801, 1.0652),
    ("frostbite", 0.0, .9524, .9226, .3900, .9070),
    ("frostbite", 0.5, .8262, .8217, .7194, .8182),
    ("frostbite", 1.0, .6859, .6999, .9140, .7054),
    ("cod_wwii", 1e-4, .9643, .9417, .5372, .9298),     # alpha -> 0: g = 1
    ("cod_wwii", 0.25, .9440, .8800, .8478, .9016),
    ("cod_wwii", 1.0, .9732, .9389, 1.0450, .9552),     # g = 0
    ("oren_nayar", 0.5, .7845, .8831, .9386, .8553),
    ("oren_nayar", 1.0, .6241, .7471, .8164, .7124),
    ("oren_nayar_full", 0.5, .8963, .9270, .9909, .9167),
    ("oren_nayar_full", 1.0, .7745, .8128, .8925, .8000),
]


@pytest.mark.parametrize("row", DIFFUSE_TABLE, ids=lambda r: f"{r[0]}-{r[1]}")
def test_diffuse_white_furnace(row):
    name, p, e1, e05, e01, e_avg = row
    mu_avg, w_avg = gl(24)
    e = diffuse_albedo(name, 0.0 if p is None else p, np.concatenate([[1.0, 0.5, 0.1], mu_avg]))
    got_avg = 2.0 * np.sum(w_avg * mu_avg * e[3:])
    # the table is printed to 4 decimals: allow half a unit of the last one on top of 1e-3
    np.testing.assert_allclose(e[:3], [e1, e05, e01], rtol=QUAD_RTOL, atol=5e-5)
    np.testing.assert_allclose(got_avg, e_avg, rtol=QUAD_RTOL, atol=5e-5)


def test_diffuse_quadrature_is_converged():
    # the rule itself: doubling the nodes moves Oren-Nayar full E(0.5) by < 1e-6
    a = diffuse_albedo("oren_nayar_full", 1.0, [0.5], 32)[0]
    b = diffuse_albedo("oren_nayar_full", 1.0, [0.5], 64)[0]
    assert abs(a - b) < 1e-6


# --- GGX white furnace through brdf.evaluate (REFERENCE.md s.5) -------------------------

def specular_albedo_nodes(mu, alpha, n_u=64, n_phi=32):
    """Nodes (wi, wo, weight), fixed shape (2 n_u n_phi, 3), with
    sum weight f(wi, wo) = int f (n.wi) dw_i at n.wo = mu.

    Half vectors h(theta, phi), theta warped with scale alpha; wi = reflect(wo, h),
    dw_i = 4 (wo.h) dw_h.  n.wi > 0 <=> cos phi > -cot(theta_o) cot(2 theta): all phi for
    theta < (pi/2 - theta_o)/2, a symmetric phi range up to (pi/2 + theta_o)/2, none above.
    """
    to = math.acos(mu)
    so = math.sin(to)
    wo = np.array([so, 0.0, mu])
    th1, th2 = 0.5 * (0.5 * np.pi - to), 0.5 * (0.5 * np.pi + to)
    u1, u2 = u_of_theta(th1, alpha), u_of_theta(th2, alpha)
    wis, ws = [], []
    for (a, b), full in (((0.0, u1), True), ((u1, u2), False)):
        u, wu = gl(n_u, a, b)
        th, dth = warp(u, alpha)
        if full:
            half = np.full_like(th, np.pi)
        elif so == 0.0:
            half = np.zeros_like(th)            # empty panel (u1 == u2): zero weights
        else:
            c = -mu * np.cos(2 * th) / (so * np.sin(2 * th))
            half = np.arccos(np.clip(c, -1.0, 1.0))
        ph, wph = gl(n_phi, -half, half)
        h = sph(th[:, None], ph)
        vh = h @ wo
        wi = 2.0 * vh[..., None] * h - wo
        wis.append(wi.reshape(-1, 3))
        ws.append(((wu * dth * np.sin(th))[:, None] * wph * 4.0 * vh * np.maximum(wi[..., 2], 0.0)).reshape(-1))
    wi = np.concatenate(wis)
    return wi, np.broadcast_to(wo, wi.shape), np.concatenate(ws)


@functools.lru_cache(maxsize=None)
def _specular_albedo_kernel(model):
    spec = brdf.parse_model(model)

    def one(args):
        r, f0, wi, wo, w = args
        p = brdf.default_params(spec)
        p["roughness"], p["f0"] = r, f0 * jnp.ones(3)
        return jnp.einsum("n,nc->c", w, brdf.evaluate(spec, p, wi, wo))
    return jax.jit(lambda *args: jax.lax.map(one, args), compiler_options=FAST_COMPILE)


def albedo_of(model, roughness_mu, f0=1.0):
    """Directional albedo (RGB) of ``model`` with Schlick f0 for each (roughness, mu) pair."""
    nodes = [specular_albedo_nodes(mu, max(r * r, brdf.ALPHA_MIN)) for r, mu in roughness_mu]
    r = np.array([c[0] for c in roughness_mu])
    wi, wo, w = (np.stack([nd[k] for nd in nodes]) for k in range(3))
    return np.asarray(_specular_albedo_kernel(model)(r, np.full_like(r, f0), wi, wo, w))


ENERGY_TABLE = [  # alpha, E(1), E(0.5), E_avg
    (0.0625, 0.99571, 0.98832, 0.98725),
    (0.25, 0.91581, 0.85726, 0.88232),
    (0.5, 0.68785, 0.69825, 0.70024),
    (1.0, 0.30685, 0.45069, 0.40914),
]


def test_single_scattering_albedo_matches_reference_table():
    mu_avg, w_avg = gl(16)
    cfg = []
    for alpha, *_ in ENERGY_TABLE:
        r = math.sqrt(alpha)
        cfg += [(r, 1.0), (r, 0.5)] + [(r, m) for m in mu_avg]
    e = albedo_of("ggx", cfg)[:, 0].reshape(len(ENERGY_TABLE), -1)
    for (alpha, e1, e05, e_avg), row in zip(ENERGY_TABLE, e):
        got_avg = 2.0 * np.sum(w_avg * mu_avg * row[2:])
        np.testing.assert_allclose([row[0], row[1], got_avg], [e1, e05, e_avg],
                                   rtol=QUAD_RTOL, atol=5e-6, err_msg=f"alpha={alpha}")


FURNACE_ALPHAS = [0.05, 0.1, 0.25, 0.5, 0.75, 1.0]
FURNACE_MUS = [0.1, 0.2, 0.35, 0.5, 0.75, 1.0]


@pytest.mark.parametrize("model", ["ggx+ms", "ggx+turquin"])
def test_energy_compensation_white_furnace(model):
    # F = 1 (Schlick f0 = 1): Kulla-Conty adds the lost 1 - E; Turquin with F0 = 1 divides by E
    cfg = [(math.sqrt(a), mu) for a in FURNACE_ALPHAS for mu in FURNACE_MUS]
    e = albedo_of(model, cfg)
    assert np.all(np.abs(e - 1.0) < 0.01), np.c_[cfg, e[:, :1]][np.abs(e[:, 0] - 1) >= 0.01]
    # and the single-scattering lobe alone does lose energy (up to 60% at alpha = 1)
    e_ss = albedo_of("ggx", cfg)
    assert e_ss.min() < 0.5


def test_specular_quadrature_is_converged():
    # the rule itself: doubling the nodes moves a sharp and a rough grazing albedo by < 1e-6
    @jax.jit
    def e(alpha, wi, wo, w):
        h = (wi + wo) / jnp.linalg.norm(wi + wo, axis=-1, keepdims=True)
        f = specular.ggx_ndf(h[..., 2], alpha) * specular.visibility_height_correlated(wi[..., 2], wo[..., 2], alpha)
        return jnp.sum(w * f)
    for alpha, mu in ((0.05, 0.1), (1.0, 0.1), (0.3, 1.0)):
        ea = float(e(alpha, *specular_albedo_nodes(mu, alpha)))
        eb = float(e(alpha, *specular_albedo_nodes(mu, alpha, 128, 64)))
        assert abs(ea - eb) < 1e-6, (alpha, mu, ea, eb)
