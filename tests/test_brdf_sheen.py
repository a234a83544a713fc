"""KHR_materials_sheen: Charlie's sheen lobe and its albedo-scaling layer over the glTF material.

Every number comes from an independent computation: a numpy transcription of the
extension README's GLSL as written (np.power, its own branches), Gauss-Legendre
quadratures of the hemisphere in another parameterisation than brdf.sheen's own
(the normalisation of D, the directional albedo E the layer's table holds, the
white furnace), exact identities (sheen colour 0 is the base material; the lobe and
the layer are reciprocal) and a fit recovering the parameters of a table made with
known ones.
"""

import math

import numpy as np
import pytest

import jax
import jax.numpy as jnp

from brdf import gltf, sheen
from brdf.constants import ALPHA_MIN, ROUGHNESS_MIN
from brdf.model import evaluate
from shaders.parity import random_pairs
from hemisphere import hemisphere

# The albedo table's bilinear accuracy (brdf/sheen.py) where a fabric's sheen lives.
TABLE_ACCURACY = 1e-3


def _readme_dv(n_dot_h, n_dot_l, n_dot_v, sheen_roughness):
    """D V as the extension's README writes them (numpy), with alphaG = sheenRoughness^2
    (the Sample Viewer's) and V clamped to [0, 1] (the Sample Viewer's V_Sheen)."""
    alpha = sheen_roughness ** 2
    inv_r = 1.0 / alpha
    sin2h = 1.0 - n_dot_h * n_dot_h
    d = (2.0 + inv_r) * np.power(sin2h, inv_r * 0.5) / (2.0 * np.pi)

    def lfit(x):  # the README's l(x, alphaG)
        t = (1.0 - alpha) * (1.0 - alpha)
        a = 21.5473 + (25.3245 - 21.5473) * t
        b = 3.82987 + (3.32435 - 3.82987) * t
        c = 0.19823 + (0.16801 - 0.19823) * t
        dd = -1.97760 + (-1.27393 + 1.97760) * t
        e = -4.32054 + (-4.85967 + 4.32054) * t
        return a / (1.0 + b * np.power(x, c)) + dd * x + e

    def lam(cos):
        return np.where(np.abs(cos) < 0.5, np.exp(lfit(cos)), np.exp(2.0 * lfit(0.5) - lfit(1.0 - cos)))
    v = 1.0 / ((1.0 + lam(n_dot_v) + lam(n_dot_l)) * (4.0 * n_dot_v * n_dot_l))
    return d * np.minimum(v, 1.0)


def _view(mu, like):
    return np.broadcast_to(np.array([math.sqrt(1.0 - mu * mu), 0.0, mu]), like.shape)


def _n_dot_h(wi, wo):
    h = wi + wo
    return h[..., 2] / np.linalg.norm(h, axis=-1)


def _pairs(n, seed):
    wi, wo = (np.asarray(x, float) for x in random_pairs(n, seed))
    wi /= np.linalg.norm(wi, axis=-1, keepdims=True)
    wo /= np.linalg.norm(wo, axis=-1, keepdims=True)
    keep = (wi[:, 2] > 1e-3) & (wo[:, 2] > 1e-3) & (_n_dot_h(wi, wo) < 1.0 - 1e-7)
    return wi[keep], wo[keep]


@pytest.mark.parametrize("alpha", [ALPHA_MIN, 0.01, 0.09, 0.25, 1.0])
def test_charlie_ndf_is_normalised(alpha):
    """int D(h) (n.h) dh = 1 (Gauss-Legendre over theta_h, 400 nodes)."""
    x, w = np.polynomial.legendre.leggauss(400)
    theta, w_theta = (x + 1) * np.pi / 4, w * np.pi / 4
    d = np.asarray(sheen.charlie_ndf(np.cos(theta), alpha))
    assert 2.0 * np.pi * np.sum(d * np.cos(theta) * np.sin(theta) * w_theta) == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize("r", [0.2, 0.5, 1.0])
def test_sheen_lobe_is_the_readme_formula(r):
    wi, wo = _pairs(3000, 1)
    nh = _n_dot_h(wi, wo)
    ours = np.asarray(sheen.sheen_dv(nh, wi[:, 2], wo[:, 2], r))
    # (1e-5: our floors on x in Lambda's x^c, which 1 - n.l reaches within 0.1 deg of the normal)
    np.testing.assert_allclose(ours, _readme_dv(nh, wi[:, 2], wo[:, 2], r), rtol=1e-5, atol=1e-12)


@pytest.mark.parametrize("mu", [0.1, 0.3, 0.6, 0.95])
@pytest.mark.parametrize("r", [0.3, 0.6, 1.0])
def test_albedo_table_against_quadrature(mu, r):
    """E(mu, r) from the table against the lobe's hemisphere integral over (theta_l, phi_l)
    (a grid unlike sheen_albedo_quadrature's), and against that quadrature with more nodes."""
    dirs, weights = hemisphere(200)
    v = _view(mu, dirs)
    lobe = np.asarray(sheen.sheen_dv(_n_dot_h(dirs, v), dirs[:, 2], mu, r))
    exact = float(np.sum(lobe * dirs[:, 2] * weights))
    # (1e-4: V's clamp at 1 is a kink neither Gauss-Legendre grid resolves below ~5e-5)
    assert float(sheen.sheen_albedo_quadrature(mu, r, nodes=96)) == pytest.approx(exact, abs=1e-4)
    assert float(sheen.lookup_sheen_e(mu, r)) == pytest.approx(exact, abs=TABLE_ACCURACY)


def test_albedo_table_nodes_are_its_quadrature():
    table = sheen.sheen_table()
    np.testing.assert_allclose(sheen.lookup_sheen_e(table["mu"][:, None], table["roughness"][None, :]),
                               table["E"], rtol=1e-12, atol=1e-15)


def test_sheen_colour_zero_is_the_base_material_exactly():
    """The extension: "If sheenColorFactor is zero, the whole sheen layer is disabled"."""
    wi, wo = _pairs(2000, 2)
    base = dict(base_color=np.array([0.7, 0.3, 0.2]), metallic=0.3, roughness=0.45)
    plain = np.asarray(gltf.gltf_brdf(wi, wo, **base))
    off = np.asarray(gltf.gltf_brdf(wi, wo, **base, sheen_color=np.zeros(3), sheen_roughness=0.7))
    np.testing.assert_array_equal(off, plain)
    params = {"base_color": base["base_color"], "metallic": 0.3, "roughness": 0.45, "specular": 0.8,
              "specular_color": np.array([1.0, 0.9, 0.8]), "clearcoat": 0.4, "clearcoat_roughness": 0.2}
    without = np.asarray(evaluate("gltf+specular+clearcoat", params, wi, wo))
    with_off = np.asarray(evaluate("gltf+specular+sheen+clearcoat",
                                   {**params, "sheen_color": np.zeros(3), "sheen_roughness": 0.5}, wi, wo))
    np.testing.assert_array_equal(with_off, without)


def test_sheen_layer_is_the_extension_layering():
    """f = sheenColor D V + f_base min(1 - max3(c) E(n.v), 1 - max3(c) E(n.l)), E the lobe's albedo."""
    wi, wo = _pairs(1000, 3)
    c, r = np.array([0.6, 0.4, 0.2]), 0.5
    base = dict(base_color=np.array([0.3, 0.5, 0.7]), metallic=0.0, roughness=0.6)
    layered = np.asarray(gltf.gltf_brdf(wi, wo, **base, sheen_color=c, sheen_roughness=r))
    plain = np.asarray(gltf.gltf_brdf(wi, wo, **base))
    e = lambda mu: np.asarray(sheen.lookup_sheen_e(mu, r))    # noqa: E731 (checked against quadrature above)
    scaling = np.minimum(1.0 - 0.6 * e(wo[:, 2]), 1.0 - 0.6 * e(wi[:, 2]))
    dv = _readme_dv(_n_dot_h(wi, wo), wi[:, 2], wo[:, 2], r)
    np.testing.assert_allclose(layered, c * dv[:, None] + plain * scaling[:, None], rtol=1e-5, atol=1e-12)


def test_sheen_is_reciprocal():
    wi, wo = _pairs(2000, 4)
    params = {"base_color": np.array([0.8, 0.5, 0.3]), "metallic": 0.2, "roughness": 0.5,
              "sheen_color": np.array([0.9, 0.7, 0.8]), "sheen_roughness": 0.4}
    np.testing.assert_allclose(evaluate("gltf+sheen", params, wi, wo), evaluate("gltf+sheen", params, wo, wi),
                               rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("sheen_roughness", [0.3, 0.6, 1.0])
def test_white_furnace(sheen_roughness):
    """White sheen over a white base: the albedo scaling takes the total towards 1 and never
    past max(1, the base's own albedo) (+ 2e-3, the table's and the quadrature's accuracy)
    down to n.v = 0.05: over a rough white base (albedo <= 1.0013) the total stays <= 1.002.
    (The glTF base alone passes 1 where it is smooth: 1.18 at roughness 0.3, n.v = 0.1;
    with the sheen it is 1.08 there.)"""
    dirs, weights = hemisphere(200)
    for base_roughness in (0.3, 1.0):
        for mu in (1.0, 0.5, 0.2, 0.1, 0.05):
            v = _view(mu, dirs)
            base = dict(base_color=np.ones(3), metallic=0.0, roughness=base_roughness)
            total = float(np.sum(np.asarray(gltf.gltf_brdf(dirs, v, **base, sheen_color=np.ones(3),
                                                           sheen_roughness=sheen_roughness))[:, 0]
                                 * dirs[:, 2] * weights))
            alone = float(np.sum(np.asarray(gltf.gltf_brdf(dirs, v, **base))[:, 0] * dirs[:, 2] * weights))
            assert total <= max(1.0, alone) + 2e-3, (base_roughness, mu, total, alone)


def test_gradients_are_finite_at_the_floor_the_peak_and_grazing():
    grad = jax.grad(lambda r, c: jnp.sum(sheen.sheen_layer(jnp.ones(3), c, r, jnp.array([1.0, 1e-4, 0.5]),
                                                            jnp.array([1.0, 1e-4, 0.02]),
                                                            jnp.array([1.0, 1e-4, 0.99999]))), argnums=(0, 1))
    for r in (ROUGHNESS_MIN, 0.5, 1.0):
        g_r, g_c = grad(r, jnp.array([1.0, 0.5, 0.0]))
        assert np.isfinite(g_r) and np.all(np.isfinite(g_c))


def test_three_js_draws_another_albedo_scaling():
    """three.js r187 (lights_physical_pars_fragment.glsl.js) scales the base by its curve fit
    IBLSheenBRDF, not by the lobe's albedo: at sheenRoughness 0.3, n.v = 0.1 the lobe
    reflects 0.534 (quadrature), three.js's curve says 0.313 (docs/gltf.md)."""
    assert float(sheen.sheen_albedo_quadrature(0.1, 0.3)) == pytest.approx(0.5342, abs=2e-4)
    assert float(sheen.three_sheen_albedo(0.1, 0.3)) == pytest.approx(0.3134, abs=2e-4)


def test_a_fit_recovers_the_sheen():
    """A table of gltf+sheen with known values, fitted: every value back; the glTF model
    without the sheen cannot reproduce it."""
    from fitting import fit, synthetic_measured
    truth = {"base_color": [0.5, 0.2, 0.15], "metallic": 0.0, "roughness": 0.6,
             "sheen_color": [0.6, 0.5, 0.4], "sheen_roughness": 0.45}
    measured = synthetic_measured("gltf+sheen", truth, noise=0.0)
    result = fit(measured, "gltf+sheen", samples=20_000, starts=2)
    np.testing.assert_allclose(result.parameters["sheen_color"], truth["sheen_color"], atol=2e-3)
    assert result.parameters["sheen_roughness"] == pytest.approx(0.45, abs=2e-3)
    np.testing.assert_allclose(result.parameters["base_color"], truth["base_color"], atol=2e-3)
    assert result.parameters["roughness"] == pytest.approx(0.6, abs=2e-3)
    plain = fit(measured, "gltf", samples=20_000, starts=2)
    assert plain.errors["m1"] > 10 * result.errors["m1"]


def test_split_sum_draws_the_sheen_near_the_sampled_environment():
    """Under image lighting the preview renderer's split sum draws the sheen in the extension's
    n.v-only form (base x (1 - max3(c) E(n.v)) + c E(n.v) x irradiance / pi): measured 0.10
    relative RMSE from the Monte Carlo render of the same environment (``ibl="sampled"``, the
    BRDF itself), where leaving the sheen out would be 0.44 away (the split sum's own error
    without a sheen: 0.03)."""
    from shaders.gl import gl_available
    if not gl_available()[0]:
        pytest.skip("no OpenGL here for the preview renderer")
    from shaders.render import Material, render_hdr
    params = {"base_color": [0.3, 0.05, 0.1], "metallic": 0.0, "roughness": 0.7,
              "sheen_color": [0.8, 0.6, 0.7], "sheen_roughness": 0.5}
    split, sampled = (render_hdr(Material("gltf+sheen", params), 96, ibl=ibl) for ibl in ("split_sum", "sampled"))
    without = render_hdr(Material("gltf+sheen", {**params, "sheen_color": [0.0] * 3}), 96, ibl="split_sum")
    disc = split[..., 3] > 0.5

    def relative_rmse(image):
        return float(np.sqrt(np.mean((image[..., :3][disc] - sampled[..., :3][disc]) ** 2))
                     / np.mean(sampled[..., :3][disc]))
    assert relative_rmse(split) < 0.15
    assert relative_rmse(without) > 3 * relative_rmse(split)
