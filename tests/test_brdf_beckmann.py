"""Beckmann NDF, its Smith Lambda, the V-groove masking and the models they make.

Every expected number is computed here independently of brdf/: by quadrature
over the slope plane (numpy Gauss-Legendre), from Python's math.erf, or by
restating the formula with numpy (docs/models.md, REFERENCE.md section 10).
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import brdf
from brdf import beckmann
from brdf.constants import ALPHA_MIN, ROUGHNESS_MIN

# REFERENCE.md's test geometry: v = (theta 40, phi 20), l = (theta 55, phi 200)
V = np.array([0.604023, 0.219846, 0.766044])
L = np.array([-0.769751, -0.280166, 0.573576])
H = (V + L) / np.linalg.norm(V + L)
# a grazing view (theta 70, phi 20), where Lambda is far from 0 at these alphas
V_GRAZING = np.array([math.sin(math.radians(70)) * math.cos(math.radians(20)),
                      math.sin(math.radians(70)) * math.sin(math.radians(20)), math.cos(math.radians(70))])
QUAD_RTOL = 1e-3          # REFERENCE.md's tolerance for quadrature results


def slope_quadrature(alpha_t, alpha_b, n=400, extent=9.0):
    """Microfacet normals m over the slope plane (p, q) in +-extent alpha and the
    weights w with sum w g(m) = integral of g(m) (n.m)^-3 ... : dw_m = cos^3 dp dq."""
    x, wx = np.polynomial.legendre.leggauss(n)
    p, q = extent * alpha_t * x, extent * alpha_b * x
    pp, qq = np.meshgrid(p, q, indexing="ij")
    ww = np.outer(wx * extent * alpha_t, wx * extent * alpha_b)
    norm = np.sqrt(1.0 + pp * pp + qq * qq)
    m = np.stack([-pp / norm, -qq / norm, 1.0 / norm], axis=-1)
    return m.reshape(-1, 3), (ww / norm ** 3).reshape(-1)          # cos^3 theta_m = 1 / norm^3


def lambda_by_erf(cos_theta, alpha):
    """Walter et al. 2007 eq. 27 with Python's math.erf."""
    a = cos_theta / (alpha * math.sqrt(1.0 - cos_theta ** 2))
    return (math.erf(a) - 1.0) / 2.0 + math.exp(-a * a) / (2.0 * a * math.sqrt(math.pi))


# --- the NDF ------------------------------------------------------------------------------

def test_ndf_point_values():
    alpha = 0.25
    tan2 = (1 - 0.81) / 0.81
    expected = math.exp(-tan2 / alpha ** 2) / (math.pi * alpha ** 2 * 0.9 ** 4)
    np.testing.assert_allclose(beckmann.beckmann_ndf(0.9, alpha), expected, rtol=1e-12)
    # the peak equals GGX's: 1 / (pi alpha^2) (REFERENCE.md section 1: 5.092958 at alpha 0.25)
    np.testing.assert_allclose(beckmann.beckmann_ndf(1.0, alpha), 5.092958, rtol=1e-6)
    assert float(beckmann.beckmann_ndf(-0.1, alpha)) == 0.0
    assert float(beckmann.beckmann_ndf(0.0, alpha)) == 0.0


@pytest.mark.parametrize("alpha_t, alpha_b", [(0.05, 0.05), (0.25, 0.25), (1.0, 1.0), (0.3, 0.1)])
def test_ndf_is_normalised(alpha_t, alpha_b):
    """integral D(m) (n.m) dw_m = 1."""
    m, w = slope_quadrature(alpha_t, alpha_b)
    if alpha_t == alpha_b:
        d = np.asarray(beckmann.beckmann_ndf(jnp.asarray(m[:, 2]), alpha_t))
    else:
        d = np.asarray(beckmann.beckmann_ndf_aniso(jnp.asarray(m), alpha_t, alpha_b))
    assert np.sum(w * d * m[:, 2]) == pytest.approx(1.0, rel=QUAD_RTOL)


def test_aniso_ndf_reduces_to_iso_and_rotates():
    np.testing.assert_allclose(beckmann.beckmann_ndf_aniso(H, 0.25, 0.25), beckmann.beckmann_ndf(H[2], 0.25),
                               rtol=1e-12)
    swapped = np.array([H[1], -H[0], H[2]])              # the tangent frame turned by 90 degrees
    np.testing.assert_allclose(beckmann.beckmann_ndf_aniso(H, 0.3, 0.1),
                               beckmann.beckmann_ndf_aniso(swapped, 0.1, 0.3), rtol=1e-12)


# --- Smith Lambda ----------------------------------------------------------------------------

@pytest.mark.parametrize("cos_theta, alpha", [(0.5, 0.25), (0.8, 0.25), (0.766044, 0.3), (0.1, 0.5),
                                              (0.05, 1.0), (0.9, 0.05)])
def test_lambda_matches_math_erf(cos_theta, alpha):
    np.testing.assert_allclose(beckmann.beckmann_lambda(cos_theta, alpha), lambda_by_erf(cos_theta, alpha),
                               rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("alpha_t, alpha_b", [(0.3, 0.3), (0.6, 0.6), (0.3, 0.1)])
def test_lambda_is_the_projected_area_of_the_ndf(alpha_t, alpha_b):
    """integral max(0, v.m) D(m) dw_m = (n.v)(1 + Lambda(v)) (REFERENCE.md section 1's test)."""
    m, w = slope_quadrature(alpha_t, alpha_b, n=600)
    d = np.asarray(beckmann.beckmann_ndf_aniso(jnp.asarray(m), alpha_t, alpha_b))
    projected = np.sum(w * d * np.maximum(m @ V_GRAZING, 0.0))
    lam = float(beckmann.beckmann_lambda_aniso(V_GRAZING, alpha_t, alpha_b))
    assert lam > 0.005               # a test that cannot pass with Lambda = 0
    assert projected == pytest.approx(V_GRAZING[2] * (1.0 + lam), rel=QUAD_RTOL)
    if alpha_t == alpha_b:
        np.testing.assert_allclose(lam, beckmann.beckmann_lambda(V_GRAZING[2], alpha_t), rtol=1e-9)


def test_lambda_vanishes_at_normal_incidence_and_grows_at_grazing():
    assert float(beckmann.beckmann_lambda(1.0, 0.5)) == 0.0
    assert float(beckmann.beckmann_lambda_aniso(np.array([0.0, 0.0, 1.0]), 0.5, 0.2)) == 0.0
    # a -> 0: Lambda ~ 1 / (2 a sqrt(pi)) - 1/2
    a = 1e-3
    np.testing.assert_allclose(beckmann.beckmann_lambda_of_a(a), 0.5 / (a * math.sqrt(math.pi)) - 0.5 + a / 2,
                               rtol=1e-6)


def test_smith_maskings_use_beckmanns_lambda():
    """beckmann's G (height-correlated and separable) is Beckmann's Lambda combined, not GGX's."""
    nl, nv, alpha = 0.3, 0.5, 0.6
    lam_l, lam_v = lambda_by_erf(nl, alpha), lambda_by_erf(nv, alpha)
    wi = np.array([math.sqrt(1 - nl * nl), 0.0, nl])
    wo = np.array([-math.sqrt(1 - nv * nv), 0.0, nv])
    h = (wi + wo) / np.linalg.norm(wi + wo)
    d = lambda_d = float(beckmann.beckmann_ndf(h[2], alpha))
    for masking, g in (("", 1.0 / (1.0 + lam_l + lam_v)), ("+separable", 1.0 / ((1.0 + lam_l) * (1.0 + lam_v)))):
        params = {"albedo": jnp.zeros(3), "roughness": jnp.asarray(math.sqrt(alpha)), "f0": jnp.ones(3)}
        f = brdf.evaluate("beckmann" + masking, params, wi, wo)
        np.testing.assert_allclose(f, d * g / (4 * nl * nv), rtol=1e-9)
    assert lambda_d > 0


# --- V-groove and Cook-Torrance ---------------------------------------------------------------

def sph(theta_deg, phi_deg):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


@pytest.mark.parametrize("wi, wo", [(L, V), (sph(80, 150), V_GRAZING), (sph(85, 0), sph(60, 180))])
def test_vgroove_by_hand(wi, wo):
    h = (wi + wo) / np.linalg.norm(wi + wo)
    nh, nv, nl, vh = h[2], wo[2], wi[2], float(wo @ h)
    expected = min(1.0, 2 * nh * nv / vh, 2 * nh * nl / vh)
    np.testing.assert_allclose(beckmann.g_vgroove(nl, nv, nh, vh), expected, rtol=1e-12)


def test_vgroove_shadows_at_grazing():
    wi, wo = sph(80, 150), V_GRAZING
    h = (wi + wo) / np.linalg.norm(wi + wo)
    assert float(beckmann.g_vgroove(wi[2], wo[2], h[2], wo @ h)) < 0.9
    assert float(beckmann.g_vgroove(1.0, 1.0, 1.0, 1.0)) == 1.0


def test_cook_torrance_model_by_hand():
    """beckmann+lambert+vgroove = rho/pi + D G F / (4 n.l n.v), Schlick F (docs/models.md)."""
    r, albedo, f0 = 0.4, np.array([0.3, 0.2, 0.1]), np.array([0.05, 0.06, 0.07])
    alpha = r * r
    nh, nv, nl, vh = H[2], V[2], L[2], float(V @ H)
    tan2 = (1 - nh * nh) / (nh * nh)
    d = math.exp(-tan2 / alpha ** 2) / (math.pi * alpha ** 2 * nh ** 4)
    g = min(1.0, 2 * nh * nv / vh, 2 * nh * nl / vh)
    fresnel = f0 + (1 - f0) * (1 - vh) ** 5
    expected = albedo / math.pi + d * g * fresnel / (4 * nl * nv)
    params = {"albedo": jnp.asarray(albedo), "roughness": jnp.asarray(r), "f0": jnp.asarray(f0)}
    np.testing.assert_allclose(brdf.evaluate("beckmann+lambert+vgroove", params, L, V), expected, rtol=1e-9)


def test_ggx_keeps_its_closed_forms():
    """ggx's V is its own closed form, bit for bit (the declared Ndf.visibility)."""
    from brdf import specular
    g = brdf.model.geometry(jnp.asarray(L), jnp.asarray(V))
    for masking, closed in (("height_correlated", specular.visibility_height_correlated),
                            ("separable", specular.visibility_separable)):
        spec = brdf.ModelSpec(masking=masking)
        np.testing.assert_array_equal(brdf.model.visibility(spec, g, g.n_dot_l, g.n_dot_v, 0.3),
                                      closed(g.n_dot_l, g.n_dot_v, 0.3))


# --- gradients ---------------------------------------------------------------------------------

def _pairs():
    """Generic pairs, the mirror pair at normal incidence (n.h = 1) and a grazing one."""
    wi = np.array([L, [0.0, 0.0, 1.0], [0.999, 0.0, 0.0447]])
    wo = np.array([V, [0.0, 0.0, 1.0], [-0.2, 0.1, 0.97]])
    return jnp.asarray(wi / np.linalg.norm(wi, axis=1, keepdims=True)), \
        jnp.asarray(wo / np.linalg.norm(wo, axis=1, keepdims=True))


@pytest.mark.parametrize("model", ["beckmann+lambert", "beckmann+lambert+separable", "beckmann+lambert+vgroove",
                                   "beckmann_aniso+lambert"])
@pytest.mark.parametrize("roughness", [ROUGHNESS_MIN, 0.45, 1.0])
def test_gradient_is_finite_and_matches_differences(model, roughness):
    spec = brdf.parse_model(model)
    params = {k: v for k, v in brdf.default_params(spec).items()}
    params["roughness"] = jnp.asarray(roughness)
    if spec.anisotropic:
        params["anisotropy"], params["rotation"] = jnp.asarray(0.4), jnp.asarray(0.3)
    wi, wo = _pairs()

    def loss(r):
        f = brdf.evaluate(spec, {**params, "roughness": r}, wi, wo)
        return jnp.sum(jnp.log1p(f * wi[:, 2:3]))

    grad = jax.grad(loss)(params["roughness"])
    assert np.isfinite(float(grad))
    if roughness > ROUGHNESS_MIN:        # at the floor the clamp is a kink: finite is what is asked
        eps = 1e-6
        fd = (loss(params["roughness"] + eps) - loss(params["roughness"] - eps)) / (2 * eps)
        np.testing.assert_allclose(grad, fd, rtol=1e-5)
    full = jax.grad(lambda p: jnp.sum(brdf.evaluate(spec, p, wi, wo)))(params)
    assert all(np.all(np.isfinite(np.asarray(v))) for v in full.values())


def test_lambda_gradient_is_finite_everywhere():
    a = jnp.asarray([1e-4, 0.5, 3.0, beckmann.LAMBDA_A_MAX, 50.0, 1e9])
    grad = jax.vmap(jax.grad(beckmann.beckmann_lambda_of_a))(a)
    assert np.all(np.isfinite(np.asarray(grad)))
    c = jnp.asarray([1e-4, 0.3, 1.0])
    for alpha in (ALPHA_MIN, 0.3, 1.0):
        g = jax.vmap(jax.grad(beckmann.beckmann_lambda, argnums=(0, 1)), in_axes=(0, None))(c, jnp.asarray(alpha))
        assert all(np.all(np.isfinite(np.asarray(x))) for x in g)


def test_glsl_constants_match():
    """shaders/beckmann.glsl's constants are brdf/beckmann.py's."""
    import pathlib
    import re
    text = (pathlib.Path(beckmann.__file__).parent.parent / "shaders" / "beckmann.glsl").read_text()
    found = {k: float(v) for k, v in re.findall(r"const float (\w+) = ([-+0-9.e]+);", text)}
    assert found == pytest.approx({"BECKMANN_LAMBDA_A_MAX": beckmann.LAMBDA_A_MAX,
                                   "BECKMANN_SIN2_MIN": beckmann.SIN2_MIN,
                                   "BECKMANN_NDF_COS_MIN": beckmann.NDF_COS_MIN,
                                   "INV_SQRT_PI": beckmann.INV_SQRT_PI}, rel=1e-15)


@pytest.mark.parametrize("wi, wo", [(L, V), (sph(70, 150), V_GRAZING), (sph(30, 0), sph(35, 180))])
def test_ngans_cook_normalisation_is_four_over_pi_ks(wi, wo):
    """Ngan et al. 2005's Cook-Torrance as bsdfbenchmark/bbm's ngan.h defines it (microfacet_n::Cook = pi,
    ndf::beckmann's default normalised D (with its 1/pi), Schlick F at v.h, scaled by ks), restated
    with numpy, is beckmann+lambert+vgroove+f90 with F0' = (4/pi) ks F0, F90' = (4/pi) ks
    (docs/models.md, Cook-Torrance; bbm's plain cooktorrance.h, without the 1/pi, would give 4 ks)."""
    rho, ks, f0, m = np.array([0.0143, 0.033, 0.0639]), 0.03, 0.117, 0.3      # grey ks: one F90
    h = (wi + wo) / np.linalg.norm(wi + wo)
    nh, nv, nl, vh = h[2], wo[2], wi[2], float(wo @ h)
    d = math.exp(-(1 - nh * nh) / (nh * nh) / m ** 2) / (math.pi * m ** 2 * nh ** 4)
    g = min(1.0, 2 * nh * nv / vh, 2 * nh * nl / vh)
    fresnel = f0 + (1 - f0) * (1 - vh) ** 5
    expected = rho / math.pi + ks * d * g * fresnel / (math.pi * nl * nv)
    scale = 4 / math.pi * ks
    params = {"albedo": jnp.asarray(rho), "roughness": jnp.asarray(math.sqrt(m)),
              "f0": jnp.full(3, scale * f0), "f90": jnp.asarray(scale)}
    np.testing.assert_allclose(brdf.evaluate("beckmann+lambert+vgroove+f90", params, wi, wo), expected, rtol=1e-9)
