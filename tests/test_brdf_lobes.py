"""The classic lobe models (brdf/lobes.py): Blinn-Phong, modified Phong (bare and with the
microfacet factor), Ward, Ward-Duer, Ashikhmin-Shirley, Lafortune.

Expected numbers come from numpy: the formulas restated (Blinn 1977; Lafortune
& Willems 1994; Ward 1992; Duer 2006; Ashikhmin & Shirley 2000; Lafortune et al. 1997
with Ngan et al. 2005's normalisation; REFERENCE.md
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
from hemisphere import hemisphere

V = np.array([0.604023, 0.219846, 0.766044])          # REFERENCE.md's test geometry
L = np.array([-0.769751, -0.280166, 0.573576])
H = (V + L) / np.linalg.norm(V + L)
QUAD_RTOL = 1e-3
RS = 0.08                 # a grey R_s of the scaled Ashikhmin-Shirley lobe


def sph(theta_deg, phi_deg):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


LAFORTUNE_CZ = 0.45       # a forward lobe bent towards grazing (Cz below the mirror lobe's 1/sqrt(3))


def params(model, roughness, rho_s, albedo=0.0):
    out = {"albedo": jnp.full(3, albedo), "roughness": jnp.asarray(roughness),
           "specular_albedo": jnp.full(3, rho_s)}
    if model.startswith("lafortune"):
        out["lafortune_cz"] = jnp.asarray(LAFORTUNE_CZ)
    if model.startswith("ashikhmin_shirley_scaled"):
        out["fresnel_reflectance"] = jnp.asarray(RS)
    return out


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
        # Ngan et al. 2005 (bbm's NganAshikhminShirley): albedo x the lobe with Schlick F of a grey R_s
        "ashikhmin_shirley_scaled": rho_s * (n + 1) / (8 * math.pi) * nh ** n / (float(wo @ h) * max(nl, nv))
        * (RS + (1 - RS) * (1 - float(wi @ h)) ** 5),
    }
    # the same two lobes times the microfacet factor 1 / (4 (wi.h) max(n.wi, n.wo))
    factor = 1 / (4 * float(wi @ h) * max(nl, nv))
    expected["blinn_phong_mf"] = expected["blinn_phong"] * factor
    expected["phong_mf"] = expected["phong"] * factor
    # Lafortune 1997 eq. 4 with C = (Cxy, Cxy, Cz) a unit vector, times Ngan's (n+2)/(2 pi max(|C|)^n)
    cz = LAFORTUNE_CZ
    cxy = -math.sqrt((1 - cz * cz) / 2)
    generalised = cxy * wi[0] * wo[0] + cxy * wi[1] * wo[1] + cz * wi[2] * wo[2]
    expected["lafortune"] = rho_s * max(generalised, 0) ** n * (n + 2) / (2 * math.pi * max(abs(cxy), cz) ** n)
    for name, lobe in expected.items():
        p = dict(params(name, r, rho_s), albedo=jnp.asarray(rho_d))
        np.testing.assert_allclose(brdf.evaluate(name + "+lambert", p, wi, wo), rho_d / math.pi + lobe,
                                   rtol=1e-9, err_msg=name)


@pytest.mark.parametrize("name", ["blinn_phong_mf", "phong_mf"])
def test_microfacet_lobes_at_normal_incidence(name):
    """wi = wo = n: n.h = r.wo = 1, the factor 1/4: rho_s (n + 2) / (8 pi), here r = 0.5
    (alpha 0.25, n = 30), rho_s = 0.3: 0.3 * 32 / (8 pi) = 0.381971863420549."""
    z = np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(brdf.evaluate(name + "+lambert", params(name, 0.5, 0.3), z, z),
                               np.full(3, 0.381971863420549), rtol=1e-12)


@pytest.mark.parametrize("name", ["blinn_phong_mf", "phong_mf"])
def test_microfacet_lobes_are_the_bare_lobes_times_the_factor(name):
    """At random pairs above the horizon: >= 0, finite, and the bare lobe times
    1 / (4 (wi.h) max(n.wi, n.wo)), which is at least 1/4 (wi.h <= 1, max(n.wi, n.wo) <= 1)."""
    rng = np.random.default_rng(3)
    wi, wo = (np.array([sph(t, p) for t, p in zip(rng.uniform(0, 89, 64), rng.uniform(0, 360, 64))])
              for _ in range(2))
    with_factor = np.asarray(brdf.evaluate(name + "+lambert", params(name, 0.6, 0.5), wi, wo))
    bare = np.asarray(brdf.evaluate(name[:-3] + "+lambert", params(name[:-3], 0.6, 0.5), wi, wo))
    h = (wi + wo) / np.linalg.norm(wi + wo, axis=-1, keepdims=True)
    factor = 1 / (4 * np.sum(wi * h, -1) * np.maximum(wi[:, 2], wo[:, 2]))
    assert np.all(np.isfinite(with_factor)) and np.all(with_factor >= 0) and np.all(factor >= 0.25)
    np.testing.assert_allclose(with_factor, bare * factor[:, None], rtol=1e-10, atol=1e-300)


@pytest.mark.parametrize("wi, wo", [(L, V), (sph(70, 150), sph(65, 10)), (sph(20, 0), sph(25, 180))])
def test_lafortune_of_the_mirror_c_is_modified_phong(wi, wo):
    """C = (-1, -1, 1)/sqrt(3): C . (wi * wo) / max|C| = r . wo, Lafortune & Willems 1994's lobe."""
    cz = lobes.LAFORTUNE_MIRROR_CZ
    np.testing.assert_allclose(lobes.lafortune_cxy(cz), -cz, rtol=1e-12)
    cosine = lobes.lafortune_cosine(wi, wo, lobes.lafortune_cxy(cz), cz)
    np.testing.assert_allclose(cosine, lobes.mirror_cosine(wi, wo), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(lobes.lafortune(cosine, 40.0), lobes.phong_modified(lobes.mirror_cosine(wi, wo), 40.0),
                               rtol=1e-10, atol=1e-300)


def test_lafortune_lobe_peaks_off_the_mirror_below_it():
    """Cz < 1/sqrt(3) (Cxy < -Cz): for wi at 45 degrees the lobe's maximum over wo in the plane of
    incidence lies beyond the mirror direction, towards grazing (Lafortune et al. 1997's off-specular peak)."""
    wi = sph(45, 180)
    theta = np.linspace(1.0, 89.0, 881)
    wo = np.stack([np.sin(np.radians(theta)), np.zeros_like(theta), np.cos(np.radians(theta))], axis=-1)
    for cz, beyond in ((0.3, True), (lobes.LAFORTUNE_MIRROR_CZ, False)):
        cosine = lobes.lafortune_cosine(np.broadcast_to(wi, wo.shape), wo, lobes.lafortune_cxy(cz), cz)
        peak = theta[int(np.argmax(np.asarray(lobes.lafortune(cosine, 50.0))))]
        assert (peak > 45.5) == beyond, (cz, peak)


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
                                   "ashikhmin_shirley+lambert", "ashikhmin_shirley_scaled+lambert",
                                   "lafortune+lambert", "blinn_phong_mf+lambert", "phong_mf+lambert"])
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


@pytest.mark.parametrize("cz", [0.0, 0.2, LAFORTUNE_CZ, 0.8, 1.0])
def test_lafortune_cz_gradient_matches_differences(cz):
    """jax.grad of the loss in Lafortune's shape parameter against central differences
    (one-sided at the bounds 0 and 1: the square root's floor keeps it finite at Cz = 1)."""
    wi = jnp.asarray(np.array([L, sph(60, 10), sph(30, 100)]))
    wo = jnp.asarray(np.array([V, sph(70, 185), sph(40, 290)]))
    p = params("lafortune", 0.6, 0.2, 0.3)

    def loss(c):
        return jnp.sum(jnp.log1p(brdf.evaluate("lafortune+lambert", {**p, "lafortune_cz": c}, wi, wo) * wi[:, 2:3]))

    grad = float(jax.grad(loss)(jnp.asarray(cz)))
    assert np.isfinite(grad)
    eps = 1e-6
    lo, hi = max(cz - eps, 0.0), min(cz + eps, 1.0)
    if cz < 1.0:
        np.testing.assert_allclose(grad, (loss(hi) - loss(lo)) / (hi - lo), rtol=1e-4, atol=1e-7)


def test_glsl_constants_match():
    """shaders/lobes.glsl's constants are brdf/lobes.py's."""
    import pathlib
    import re
    text = (pathlib.Path(lobes.__file__).parent.parent / "shaders" / "lobes.glsl").read_text()
    found = {k: float(v) for k, v in re.findall(r"const float (\w+) = ([-+0-9.e]+);", text)}
    assert found == pytest.approx({"LOG_SERIES_MIN": lobes.LOG_SERIES_MIN,
                                   "THIRD": lobes.THIRD, "FIFTH": lobes.FIFTH, "SEVENTH": lobes.SEVENTH,
                                   "LAFORTUNE_SQUARE_MIN": lobes.LAFORTUNE_SQUARE_MIN, "AS_SIN2_MIN": lobes.AS_SIN2_MIN},
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


def test_ashikhmin_shirley_aniso_by_angles():
    """Ashikhmin & Shirley 2000 eq. 4 from h's angles: sqrt((nu+1)(nv+1))/(8 pi)
    (n.h)^(nu cos^2 phi_h + nv sin^2 phi_h) / ((h.k) max(n.wi, n.wo)); nu = nv is the isotropic lobe."""
    wi, wo = sph(50, 20), sph(35, 230)
    h = (wi + wo) / np.linalg.norm(wi + wo)
    phi_h = math.atan2(h[1], h[0])
    nu, nv = 40.0, 400.0
    lobe = (math.sqrt((nu + 1) * (nv + 1)) / (8 * math.pi) * h[2] ** (nu * math.cos(phi_h) ** 2 + nv * math.sin(phi_h) ** 2)
            / (float(h @ wo) * max(wi[2], wo[2])))
    np.testing.assert_allclose(lobes.ashikhmin_shirley_aniso(h, float(h @ wo), wi[2], wo[2], nu, nv), lobe, rtol=1e-9)
    np.testing.assert_allclose(lobes.ashikhmin_shirley_aniso(h, float(h @ wo), wi[2], wo[2], 90.0, 90.0),
                               lobes.ashikhmin_shirley(h[2], float(h @ wo), wi[2], wo[2], 90.0), rtol=1e-12)
    # at h = n the exponent has no direction: (n.h)^e = 1 whatever e (the mean is taken), and an
    # exponent below 0 (an alpha above 1) reads as 0
    n = np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(lobes.ashikhmin_shirley_aniso(n, 1.0, 1.0, 1.0, nu, nv),
                               math.sqrt((nu + 1) * (nv + 1)) / (8 * math.pi), rtol=1e-12)
    np.testing.assert_allclose(lobes.ashikhmin_shirley_aniso(h, float(h @ wo), wi[2], wo[2], nu, -1.5),
                               lobes.ashikhmin_shirley_aniso(h, float(h @ wo), wi[2], wo[2], nu, 0.0), rtol=1e-12)


def test_ashikhmin_shirley_aniso_model_is_the_isotropic_one_without_anisotropy():
    wi, wo = sph(50, 20), sph(35, 230)
    base = {"albedo": jnp.full(3, 0.1), "roughness": jnp.asarray(0.4), "specular_albedo": jnp.full(3, 0.05)}
    aniso = brdf.evaluate("ashikhmin_shirley_aniso+lambert",
                          dict(base, anisotropy=jnp.asarray(0.0), rotation=jnp.asarray(0.7)), wi, wo)
    np.testing.assert_allclose(aniso, brdf.evaluate("ashikhmin_shirley+lambert", base, wi, wo), rtol=1e-9)


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


# --- Lafortune's sums of two and three lobes -------------------------------------------------------

MORE_LOBES = {"lafortune_roughness_2": 0.8, "lafortune_albedo_2": 0.1, "lafortune_cz_2": 0.25,
              "lafortune_roughness_3": 0.6, "lafortune_albedo_3": 0.05, "lafortune_cz_3": 0.9}


def _ngan_lafortune(wi, wo, rho, roughness, cz):
    """One lobe by hand: rho (n+2)/(2 pi max(|Cxy|, Cz)^n) max(0, C.(wi*wo))^n, C unit, n from r."""
    alpha = roughness * roughness
    n = 2 / alpha ** 2 - 2
    cxy = -math.sqrt((1 - cz * cz) / 2)
    c = cxy * (wi[0] * wo[0] + wi[1] * wo[1]) + cz * wi[2] * wo[2]
    return rho * (n + 2) / (2 * math.pi * max(abs(cxy), cz) ** n) * max(c, 0.0) ** n


@pytest.mark.parametrize("wi, wo", [(L, V), (sph(70, 150), sph(65, 10)), (sph(60, 0), sph(80, 180))])
def test_lafortune_sums_by_hand(wi, wo):
    wi, wo = wi / np.linalg.norm(wi), wo / np.linalg.norm(wo)
    p = {k: jnp.asarray(v) for k, v in MORE_LOBES.items()}
    p.update(params("lafortune", 0.4, 0.2, 0.1))
    first = 0.1 / math.pi + _ngan_lafortune(wi, wo, 0.2, 0.4, LAFORTUNE_CZ)
    second = _ngan_lafortune(wi, wo, 0.1, 0.8, 0.25)
    third = _ngan_lafortune(wi, wo, 0.05, 0.6, 0.9)
    two = {k: v for k, v in p.items() if not k.endswith("_3")}
    for model, q, expected in (("lafortune2+lambert", two, first + second),
                               ("lafortune3+lambert", p, first + second + third)):
        q = {k: (jnp.full(3, v) if "albedo" in k and np.ndim(v) == 0 else v) for k, v in q.items()}
        np.testing.assert_allclose(brdf.evaluate(model, q, wi, wo), np.full(3, expected), rtol=1e-9, err_msg=model)


def test_lafortune3_gradient_is_finite():
    wi = jnp.asarray(np.array([L, [0.0, 0.0, 1.0], sph(85, 0)]))
    wo = jnp.asarray(np.array([V, [0.0, 0.0, 1.0], sph(80, 180)]))
    p = {k: jnp.asarray(v) for k, v in MORE_LOBES.items()}
    p.update(params("lafortune", 0.4, 0.2, 0.1))
    p = {k: (jnp.full(3, v) if "albedo" in k and np.ndim(v) == 0 else v) for k, v in p.items()}
    grad = jax.grad(lambda q: jnp.sum(jnp.log1p(brdf.evaluate("lafortune3+lambert", q, wi, wo))))(p)
    assert set(grad) == set(p) and all(np.all(np.isfinite(np.asarray(v))) for v in grad.values())
    assert all(np.any(np.asarray(grad[k]) != 0.0) for k in MORE_LOBES)
