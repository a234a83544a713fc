"""EON, KHR_materials_diffuse_roughness's lobe (Portsmouth, Kutz & Hill 2025), and the
glTF material drawing it.

Every number comes from an independent computation: a numpy transcription of the
paper's formulas in their own form (the divisions by 1 - E that brdf.diffuse.eon
rewrites), Gauss-Legendre quadratures of the hemisphere (the white furnace, the
single-scattering lobe's directional and average albedo that EON's closed forms
approximate), Lambert at roughness 0, and a fit recovering the parameters of a
table made with known ones.
"""

import math

import numpy as np
import pytest

import jax
import jax.numpy as jnp

from brdf import diffuse, gltf
from shaders import parity
from hemisphere import hemisphere

SLOPE_A = 0.5 - 2.0 / (3.0 * math.pi)            # the paper's A = 1 / (1 + SLOPE_A r)
SLOPE_AVERAGE = 2.0 / 3.0 - 28.0 / (15.0 * math.pi)
# EON's polynomial for G(mu) / pi fits the exact directional albedo to about 1e-3
# (the paper's accuracy claim for its approximation); quadrature here is better than 1e-6.
FIT_ACCURACY = 1.5e-3


def _numpy_eon(rho, r, mu_i, mu_o, l_dot_v):
    """The paper's EON as written (three.js r187's BRDF_EON: the same lines)."""
    s = l_dot_v - mu_i * mu_o
    s_over_t = np.where(s > 0, s / np.maximum(np.maximum(mu_i, mu_o), 1e-7), s)
    a = 1.0 / (1.0 + SLOPE_A * r)
    f_ss = rho / np.pi * a * (1.0 + r * s_over_t)

    def e_fon(mu):
        x = 1.0 - mu
        g = x * (0.0571085289 + x * (0.491881867 + x * (-0.332181442 + x * 0.0714429953)))
        return a * (1.0 + r * g)
    e_avg = a * (1.0 + SLOPE_AVERAGE * r)
    rho_ms = rho * rho * e_avg / (1.0 - rho * (1.0 - e_avg))
    f_ms = (rho_ms / np.pi * np.maximum(1e-7, 1.0 - e_fon(mu_o)) * np.maximum(1e-7, 1.0 - e_fon(mu_i))
            / max(1e-7, 1.0 - e_avg))
    return f_ss + f_ms


def _view(mu):
    return np.array([math.sqrt(1.0 - mu * mu), 0.0, mu])


def _albedo(lobe, mu):
    """int lobe(l, v) cos(theta_l) dl for a view v of cosine mu."""
    dirs, weights = hemisphere(160)
    v = _view(mu)
    return float(np.sum(lobe(dirs, v) * dirs[:, 2] * weights))


def _random_pairs(n, seed):
    """float64 direction pairs above the horizon (shaders.parity's mix, grazing ones included)."""
    return tuple(x.astype(np.float64) for x in parity.random_pairs(n, seed))


def test_eon_is_the_papers_formula_as_written():
    wi, wo = _random_pairs(2000, 1)
    rng = np.random.default_rng(2)
    rho = rng.uniform(0, 1, (2000, 3))
    for r in (0.05, 0.4, 1.0):
        ours = np.asarray(diffuse.eon(rho, r, wi[:, 2], wo[:, 2], np.sum(wi * wo, -1)))
        theirs = _numpy_eon(rho, r, wi[:, 2:3], wo[:, 2:3], np.sum(wi * wo, -1, keepdims=True))
        np.testing.assert_allclose(ours, theirs, rtol=1e-6, atol=1e-7)


def test_eon_at_roughness_zero_is_lambert_and_is_reciprocal():
    wi, wo = _random_pairs(500, 3)
    rho = np.array([0.7, 0.4, 0.1])
    lv = np.sum(wi * wo, -1)
    np.testing.assert_allclose(diffuse.eon(rho, 0.0, wi[:, 2], wo[:, 2], lv), np.broadcast_to(rho / np.pi, (500, 3)),
                               rtol=1e-14)
    for r in (0.3, 1.0):
        np.testing.assert_allclose(diffuse.eon(rho, r, wi[:, 2], wo[:, 2], lv),
                                   diffuse.eon(rho, r, wo[:, 2], wi[:, 2], lv), rtol=1e-12)


@pytest.mark.parametrize("r", [0.25, 0.5, 1.0])
def test_fon_directional_and_average_albedo_match_quadrature(r):
    """E_FON(mu) and its average A (1 + (2/3 - 28/(15 pi)) r) against the hemisphere
    integrals of EON's single-scattering lobe alone (rho = 1)."""
    def single(dirs, v):
        s = dirs @ v - dirs[:, 2] * v[2]
        t = np.where(s > 0, np.maximum(dirs[:, 2], v[2]), 1.0)
        return (1.0 + r * s / t) / (1.0 + SLOPE_A * r) / np.pi
    mus = np.polynomial.legendre.leggauss(24)
    mu_nodes, mu_weights = (mus[0] + 1) / 2, mus[1] / 2
    exact = np.array([_albedo(single, mu) for mu in mu_nodes])
    approx = np.asarray(diffuse.fon_directional_albedo(r, mu_nodes))
    assert np.max(np.abs(approx - exact)) < FIT_ACCURACY
    average = 2.0 * np.sum(exact * mu_nodes * mu_weights)
    assert (1.0 + SLOPE_AVERAGE * r) / (1.0 + SLOPE_A * r) == pytest.approx(average, abs=FIT_ACCURACY)


@pytest.mark.parametrize("r", [0.0, 0.2, 0.6, 1.0])
def test_white_furnace(r):
    """rho = 1: EON's albedo is 1 at every angle, to its fit's accuracy, never above it
    by more; rho = 0.5 reflects less than rho (energy preserving, not gaining)."""
    for mu in (1.0, 0.8, 0.5, 0.2, 0.05):
        white = _albedo(lambda d, v: np.asarray(diffuse.eon(1.0, r, d[:, 2], v[2], d @ v)), mu)
        assert white == pytest.approx(1.0, abs=FIT_ACCURACY)
        assert white <= 1.0 + FIT_ACCURACY
        grey = _albedo(lambda d, v: np.asarray(diffuse.eon(0.5, r, d[:, 2], v[2], d @ v)), mu)
        assert grey <= 0.5 + FIT_ACCURACY


def test_eon_flattens_and_back_scatters():
    """The lobe's shape (the extension's text): rough, it is brighter towards the light
    (back-scattering) and darker away from it than Lambert, on the plane of incidence."""
    mu = math.cos(math.radians(60))
    light = _view(mu)
    back, forward = light, np.array([-light[0], 0.0, light[2]])
    f_back = float(diffuse.eon(1.0, 1.0, mu, back[2], float(light @ back)))
    f_forward = float(diffuse.eon(1.0, 1.0, mu, forward[2], float(light @ forward)))
    assert f_back > 1.0 / np.pi > f_forward


def test_gltf_with_diffuse_roughness_changes_only_the_diffuse():
    """glTF + KHR_materials_diffuse_roughness: the spec's material with EON of albedo
    baseColor in place of baseColor / pi, weighted by the same 1 - max F; metals unchanged."""
    wi, wo = _random_pairs(400, 5)
    base = np.array([0.8, 0.3, 0.1])
    lambert = np.asarray(gltf.gltf_brdf(wi, wo, base, 0.0, 0.5))
    rough = np.asarray(gltf.gltf_brdf(wi, wo, base, 0.0, 0.5, diffuse_roughness=0.8))
    specular_only = np.asarray(gltf.gltf_brdf(wi, wo, np.zeros(3), 0.0, 0.5))
    h = (wi + wo) / np.linalg.norm(wi + wo, axis=-1, keepdims=True)
    weight = 1.0 - (0.04 + 0.96 * (1.0 - np.abs(np.sum(wo * h, -1))) ** 5)
    eon = _numpy_eon(base, 0.8, wi[:, 2:3], wo[:, 2:3], np.sum(wi * wo, -1, keepdims=True))
    # (rtol 1e-6: near-retro pairs, where h is rounded differently here and in the model)
    np.testing.assert_allclose(rough, specular_only + weight[:, None] * eon, rtol=1e-6)
    np.testing.assert_allclose(lambert, specular_only + weight[:, None] * base / np.pi, rtol=1e-6)
    metal = [np.asarray(gltf.gltf_brdf(wi, wo, base, 1.0, 0.5, diffuse_roughness=d)) for d in (None, 0.8)]
    np.testing.assert_allclose(metal[0], metal[1], rtol=1e-12)


def test_eon_gradients_are_finite_at_roughness_zero_and_at_normal_incidence():
    n = jnp.array([0.0, 0.0, 1.0])
    grad = jax.grad(lambda r, rho: jnp.sum(diffuse.eon(rho, r, 1.0, 1.0, jnp.dot(n, n))), argnums=(0, 1))
    for r in (0.0, 1e-9, 1.0):
        g_r, g_rho = grad(r, jnp.array([1.0, 0.5, 0.0]))
        assert np.isfinite(g_r) and np.all(np.isfinite(g_rho))


def test_a_fit_recovers_the_diffuse_roughness():
    """A table of the glTF model with EON and known values, fitted: every value back;
    the glTF model without the extension cannot reproduce it."""
    from fitting import fit, synthetic_measured
    truth = {"base_color": [0.6, 0.3, 0.1], "metallic": 0.0, "roughness": 0.4, "diffuse_roughness": 0.7}
    measured = synthetic_measured("gltf+diffuse_roughness", truth, noise=0.0)
    result = fit(measured, "gltf+diffuse_roughness", samples=20_000, starts=2)
    assert result.parameters["diffuse_roughness"] == pytest.approx(0.7, abs=1e-3)
    np.testing.assert_allclose(result.parameters["base_color"], truth["base_color"], atol=1e-3)
    assert result.parameters["roughness"] == pytest.approx(0.4, abs=1e-3)
    lambert = fit(measured, "gltf", samples=20_000, starts=2)
    assert lambert.errors["m1"] > 100 * result.errors["m1"]
