"""The classic lobe models (brdf/lobes.py): Blinn-Phong, modified Phong, Ward, Ward-Duer,
Ashikhmin-Shirley.

Expected numbers come from numpy: the formulas restated (Blinn 1977; Lafortune
& Willems 1994; Ward 1992; Duer 2006; Ashikhmin & Shirley 2000; REFERENCE.md
section 10) and
Gauss-Legendre quadrature over the hemisphere for the normalisations.
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import brdf
from brdf import lobes
from brdf.constants import ROUGHNESS_MIN

V = np.array([0.604023, 0.219846, 0.766044])          # REFERENCE.md's test geometry
L = np.array([-0.769751, -0.280166, 0.573576])
H = (V + L) / np.linalg.norm(V + L)
QUAD_RTOL = 1e-3


def sph(theta_deg, phi_deg):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


def hemisphere(n=400, theta_max=math.pi / 2):
    """Directions and solid-angle weights of a (theta, phi) Gauss-Legendre grid, theta in [0, theta_max]."""
    x, w = np.polynomial.legendre.leggauss(n)
    theta, wt = (x + 1) * theta_max / 2, w * theta_max / 2
    phi, wp = (x + 1) * math.pi, w * math.pi
    tt, pp = np.meshgrid(theta, phi, indexing="ij")
    d = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], axis=-1).reshape(-1, 3)
    return d, (np.outer(wt * np.sin(theta), wp)).reshape(-1)


def params(model, roughness, rho_s, albedo=0.0):
    return {"albedo": jnp.full(3, albedo), "roughness": jnp.asarray(roughness),
            "specular_albedo": jnp.full(3, rho_s)}


# --- values by hand -----------------------------------------------------------------------

def test_phong_exponent_is_walters():
    for alpha in (0.05, 0.25, 1.0):
        np.testing.assert_allclose(lobes.phong_exponent(alpha), 2 / alpha ** 2 - 2, rtol=1e-12)


@pytest.mark.parametrize("wi, wo", [(L, V), (sph(70, 150), sph(65, 10)), (sph(20, 0), sph(25, 180))])
def test_models_by_hand(wi, wo):
    wi, wo = wi / np.linalg.norm(wi), wo / np.linalg.norm(wo)      # (L, V are printed to 6 digits)
    r, rho_s, rho_d = 0.5, 0.3, np.array([0.2, 0.1, 0.05])
    alpha = r * r
    n = 2 / alpha ** 2 - 2
    h = (wi + wo) / np.linalg.norm(wi + wo)
    nh, nl, nv = h[2], wi[2], wo[2]
    mirror = 2 * nl * np.array([0, 0, 1.0]) - wi
    tan2 = (1 - nh * nh) / (nh * nh)
    ward_exp = math.exp(-tan2 / alpha ** 2) / (4 * math.pi * alpha ** 2)
    expected = {
        "blinn_phong": rho_s * (n + 2) / (2 * math.pi) * max(nh, 0) ** n,
        "phong": rho_s * (n + 2) / (2 * math.pi) * max(float(mirror @ wo), 0) ** n,
        "ward": rho_s * ward_exp / math.sqrt(nl * nv),
        "ward_duer": rho_s * ward_exp / (nl * nv),
        "ashikhmin_shirley": (n + 1) / (8 * math.pi) * nh ** n / (float(wo @ h) * max(nl, nv))
        * (rho_s + (1 - rho_s) * (1 - float(wi @ h)) ** 5),
    }
    for name, lobe in expected.items():
        p = dict(params(name, r, rho_s), albedo=jnp.asarray(rho_d))
        np.testing.assert_allclose(brdf.evaluate(name + "+lambert", p, wi, wo), rho_d / math.pi + lobe,
                                   rtol=1e-9, err_msg=name)


def test_mirror_cosine_is_the_reflected_direction():
    r = 2 * L[2] * np.array([0.0, 0.0, 1.0]) - L
    np.testing.assert_allclose(lobes.mirror_cosine(L, V), r @ V, rtol=1e-12)


def test_log_cosine_is_log():
    c = np.concatenate([np.linspace(1e-3, 1.0, 2001), 1.0 - np.geomspace(1e-12, 1e-2, 50)])
    np.testing.assert_allclose(lobes.log_cosine(jnp.asarray(c)), np.log(c), rtol=1e-10, atol=1e-300)


# --- normalisation and energy ---------------------------------------------------------------

@pytest.mark.parametrize("alpha", [0.05, 0.25, 1.0])
def test_blinn_phong_is_a_normalised_distribution(alpha):
    """integral (n+2)/(2 pi) (n.h)^n (n.h) dw_h = 1 (the NDF form)."""
    n = 2 / alpha ** 2 - 2
    theta_max = min(math.pi / 2, 12.0 / math.sqrt(n + 2))        # (cos theta)^n < 1e-30 beyond
    d, w = hemisphere(600, theta_max)
    value = np.asarray(lobes.blinn_phong(jnp.asarray(d[:, 2]), n))
    assert np.sum(w * value * d[:, 2]) == pytest.approx(1.0, rel=QUAD_RTOL)


@pytest.mark.parametrize("roughness", [0.5, 0.7])
def test_modified_phong_conserves_energy(roughness):
    """Directional albedo of rho_d/pi + modified Phong: rho_d + rho_s at normal incidence
    (the lobe's normalisation), less towards grazing: never above 1 for rho_d + rho_s = 1."""
    rho_d, rho_s = 0.4, 0.6
    d, w = hemisphere(500)
    p = params("phong", roughness, rho_s, rho_d)
    for theta_o, exact in ((0.0, True), (45.0, False), (75.0, False)):
        wo = np.broadcast_to(sph(theta_o, 0.0), d.shape)
        f = np.asarray(brdf.evaluate("phong+lambert", p, jnp.asarray(d), jnp.asarray(wo)))[:, 0]
        albedo = np.sum(w * f * d[:, 2])
        if exact:
            assert albedo == pytest.approx(rho_d + rho_s, rel=QUAD_RTOL)
        else:
            assert albedo < 1.0


def test_ward_duer_over_ward_is_the_missing_root():
    wi, wo = sph(60, 30), sph(45, 200)
    h = (wi + wo) / np.linalg.norm(wi + wo)
    ratio = lobes.ward_duer(h[2], wi[2], wo[2], 0.2) / lobes.ward(h[2], wi[2], wo[2], 0.2)
    np.testing.assert_allclose(ratio, 1 / math.sqrt(wi[2] * wo[2]), rtol=1e-12)


# --- model strings and gradients ----------------------------------------------------------------

@pytest.mark.parametrize("text", ["ward+separable", "phong+lambert+f90", "blinn_phong+vgroove",
                                  "ward+lambert+ms", "blinn_phong+lambert+coupled", "phong+conductor"])
def test_a_lobe_takes_no_microfacet_option(text):
    with pytest.raises(brdf.UnknownModelError):
        brdf.parse_model(text)


def test_schema_of_a_lobe_model():
    names = [p.name for p in brdf.parse_model("blinn_phong+burley+clearcoat").schema()]
    assert names == ["albedo", "roughness", "specular_albedo", "clearcoat", "clearcoat_roughness"]


@pytest.mark.parametrize("model", ["blinn_phong+lambert", "phong+lambert", "ward+lambert", "ward_duer+lambert",
                                   "ashikhmin_shirley+lambert"])
@pytest.mark.parametrize("roughness", [ROUGHNESS_MIN, 0.45, 1.0])
def test_gradient_is_finite_and_matches_differences(model, roughness):
    wi = jnp.asarray(np.array([L, [0.0, 0.0, 1.0], sph(85, 0)]))
    wo = jnp.asarray(np.array([V, [0.0, 0.0, 1.0], sph(80, 180)]))     # generic, n.h = 1, near the mirror
    p = params(model, roughness, 0.2, 0.3)

    def loss(r):
        return jnp.sum(jnp.log1p(brdf.evaluate(model, {**p, "roughness": r}, wi, wo) * wi[:, 2:3]))

    grad = jax.grad(loss)(p["roughness"])
    assert np.isfinite(float(grad))
    if roughness > ROUGHNESS_MIN:
        eps = 1e-6
        fd = (loss(p["roughness"] + eps) - loss(p["roughness"] - eps)) / (2 * eps)
        np.testing.assert_allclose(grad, fd, rtol=1e-5)
    full = jax.grad(lambda q: jnp.sum(brdf.evaluate(model, q, wi, wo)))(p)
    assert all(np.all(np.isfinite(np.asarray(v))) for v in full.values())


def test_glsl_constants_match():
    """shaders/lobes.glsl's constants are brdf/lobes.py's."""
    import pathlib
    import re
    text = (pathlib.Path(lobes.__file__).parent.parent / "shaders" / "lobes.glsl").read_text()
    found = {k: float(v) for k, v in re.findall(r"const float (\w+) = ([-+0-9.e]+);", text)}
    assert found == pytest.approx({"WARD_COS_MIN": lobes.WARD_COS_MIN, "LOG_SERIES_MIN": lobes.LOG_SERIES_MIN,
                                   "THIRD": lobes.THIRD, "FIFTH": lobes.FIFTH, "SEVENTH": lobes.SEVENTH},
                                  rel=1e-15)


# --- anisotropic Ward ----------------------------------------------------------------------------

def test_ward_aniso_by_angles():
    """Ward's own form: tan^2 theta_h (cos^2 phi_h / ax^2 + sin^2 phi_h / ay^2), from h's angles."""
    wi, wo = sph(50, 20), sph(35, 230)
    h = (wi + wo) / np.linalg.norm(wi + wo)
    theta_h, phi_h = math.acos(h[2]), math.atan2(h[1], h[0])
    ax, ay = 0.3, 0.1
    e = math.tan(theta_h) ** 2 * (math.cos(phi_h) ** 2 / ax ** 2 + math.sin(phi_h) ** 2 / ay ** 2)
    base = math.exp(-e) / (4 * math.pi * ax * ay)
    np.testing.assert_allclose(lobes.ward_aniso(h, wi[2], wo[2], ax, ay), base / math.sqrt(wi[2] * wo[2]), rtol=1e-9)
    np.testing.assert_allclose(lobes.ward_duer_aniso(h, wi[2], wo[2], ax, ay), base / (wi[2] * wo[2]), rtol=1e-9)
    np.testing.assert_allclose(lobes.ward_aniso(h, wi[2], wo[2], 0.2, 0.2), lobes.ward(h[2], wi[2], wo[2], 0.2),
                               rtol=1e-12)


def test_ward_aniso_model_rotates_and_remaps():
    """ward_aniso+lambert: Kulla-Conty's (alpha (1 + a), alpha (1 - a)) in the frame turned by
    ``rotation``; a quarter turn exchanges the axes (a -> -a)."""
    wi, wo = sph(50, 20), sph(35, 230)
    h = (wi + wo) / np.linalg.norm(wi + wo)
    r, a, rho_s = 0.5, 0.4, 0.2
    alpha = r * r
    base = {"albedo": jnp.zeros(3), "roughness": jnp.asarray(r), "specular_albedo": jnp.full(3, rho_s)}
    f0 = brdf.evaluate("ward_aniso", dict(base, anisotropy=jnp.asarray(a), rotation=jnp.asarray(0.0)), wi, wo)
    expected = rho_s * lobes.ward_aniso(h, wi[2], wo[2], alpha * (1 + a), alpha * (1 - a))
    np.testing.assert_allclose(f0, np.full(3, expected), rtol=1e-9)
    turned = brdf.evaluate("ward_aniso", dict(base, anisotropy=jnp.asarray(-a), rotation=jnp.asarray(math.pi / 2)),
                           wi, wo)
    np.testing.assert_allclose(turned, f0, rtol=1e-9)


def test_ward_aniso_gradient_is_finite():
    wi = jnp.asarray(np.array([L, [0.0, 0.0, 1.0], sph(85, 0)]))
    wo = jnp.asarray(np.array([V, [0.0, 0.0, 1.0], sph(80, 180)]))
    for r in (ROUGHNESS_MIN, 0.5):
        p = dict(params("ward_aniso", r, 0.2, 0.3), anisotropy=jnp.asarray(0.5), rotation=jnp.asarray(0.3))
        grad = jax.grad(lambda q: jnp.sum(jnp.log1p(brdf.evaluate("ward_aniso+lambert", q, wi, wo))))(p)
        assert all(np.all(np.isfinite(np.asarray(v))) for v in grad.values())
