"""benchmarks/ngan_reference.py: the reader of Ngan et al. 2005's published fits (bbm's .fit
format) and their mapping to our models, on a .fit text written here.

Expected values: Ngan's models evaluated by hand from their definitions (bbm's
include/bsdfmodel/ngan.h: Ward 1992, Lafortune et al. 1997 with Ngan's (n+2)/(2 pi max|C|^n),
the modified Phong mirror lobe, Cook-Torrance with the 1/pi "Cook" normalisation,
a normalised Beckmann D, V-groove G and Schlick F), numpy only.
"""

import math
import pathlib
import sys

import numpy as np
import pytest

import brdf

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "benchmarks"))
import ngan_reference as ngan  # noqa: E402

FIT_TEXT = """# BSDF fits written by the test (the format of bbm's fits/ files)
mat-a = Aggregate(Lambertian(albedo = [0.1, 0.05, 0.02]), NganWard(albedo = [0.03, 0.02, 0.01], roughness = 0.12))
mat-b = Aggregate(Lambertian(albedo = [0.2, 0.1, 0.05]), NganCookTorrance(albedo = [0.3, 0.2, 0.1], eta = 0.4, roughness = 0.2))
mat-c = Aggregate(Lambertian(albedo = [0.05, 0.05, 0.05]), NganLafortune(albedo = [0.4, 0.3, 0.2], Cxy = -0.5, Cz = 0.3, sharpness = 30.0))
mat-d = Aggregate(Lambertian(albedo = [0.1, 0.1, 0.1]), NganBlinnPhong(albedo = [0.2, 0.1, 0.05], sharpness = 120.0))
mat-e = Aggregate(Lambertian(albedo = [0.03, 0.04, 0.05]), NganAshikhminShirley(albedo = [0.5, 0.3, 0.2], fresnelReflectance = 0.09, sharpness = 60.0))
"""
PAIRS = [(np.array([-0.769751, -0.280166, 0.573576]), np.array([0.604023, 0.219846, 0.766044])),
         (np.array([0.5, 0.0, 0.8660254]), np.array([-0.6, 0.1, 0.7937254])),
         (np.array([0.0, 0.3, 0.9539392]), np.array([0.1, -0.35, 0.9313968]))]


@pytest.fixture
def fits(tmp_path):
    path = tmp_path / "ngan_test.fit"
    path.write_text(FIT_TEXT)
    return ngan.read_fits(path)


def _unit(v):
    return v / np.linalg.norm(v)


def _arrays(params):
    return {k: np.asarray(v, np.float64) for k, v in params.items()}


def _ours(fit):
    label, model, params = ngan.as_ours(fit)[0]
    assert label == "published"
    return model, _arrays(params)


def _assert_published(fit, model, wi, wo, expected):
    """The published fit's first evaluation is ``model`` and equals ``expected`` at (wi, wo)."""
    ours, params = _ours(fit)
    assert ours == model
    np.testing.assert_allclose(brdf.evaluate(model, params, wi, wo), expected, rtol=1e-9)


def test_reader(fits):
    assert list(fits) == ["mat-a", "mat-b", "mat-c", "mat-d", "mat-e"]
    c = fits["mat-c"]
    assert c.model == "NganLafortune" and c.lambert == (0.05, 0.05, 0.05)
    assert c.params == {"albedo": (0.4, 0.3, 0.2), "Cxy": -0.5, "Cz": 0.3, "sharpness": 30.0}


def test_a_line_not_in_the_format_is_refused():
    with pytest.raises(ValueError, match="not a Ngan fit line"):
        ngan.parse_line("mat = Lambertian(albedo = [0.1, 0.1, 0.1])")
    assert ngan.parse_line("# a comment") is None


def test_roughness_of_exponent_inverts_walters():
    for n in (3.0, 120.0, 13700.0):
        alpha = ngan.roughness_of_exponent(n) ** 2
        assert 2 / alpha ** 2 - 2 == pytest.approx(n, rel=1e-12)


@pytest.mark.parametrize("wi, wo", PAIRS)
def test_cook_torrance_by_hand(fits, wi, wo):
    """albedo D G F / (pi n.wi n.wo) + rho/pi: D = exp(-tan^2/a^2)/(pi a^2 cos^4), G V-groove, F Schlick(eta)."""
    wi, wo = _unit(wi), _unit(wo)
    f = fits["mat-b"]
    a, eta, ks, rho = 0.2, 0.4, np.array(f.params["albedo"]), np.array(f.lambert)
    h = _unit(wi + wo)
    nh, nl, nv, vh = h[2], wi[2], wo[2], wo @ h
    d = math.exp(-(1 - nh ** 2) / nh ** 2 / a ** 2) / (math.pi * a ** 2 * nh ** 4)
    g = min(1.0, 2 * nh * nv / vh, 2 * nh * nl / vh)
    fresnel = eta + (1 - eta) * (1 - vh) ** 5
    expected = rho / math.pi + ks * d * g * fresnel / (math.pi * nl * nv)
    _assert_published(f, "beckmann+lambert+vgroove+f90", wi, wo, expected)


@pytest.mark.parametrize("wi, wo", PAIRS)
def test_lafortune_by_hand(fits, wi, wo):
    """Ngan's Lafortune with a C of norm != 1: albedo (n+2)/(2 pi max(|Cz|,|Cxy|)^n) max(0, C.(wi*wo))^n."""
    wi, wo = _unit(wi), _unit(wo)
    f = fits["mat-c"]
    n, cxy, cz = 30.0, -0.5, 0.3
    dot = cxy * wi[0] * wo[0] + cxy * wi[1] * wo[1] + cz * wi[2] * wo[2]
    lobe = (n + 2) / (2 * math.pi * max(abs(cz), abs(cxy)) ** n) * max(dot, 0.0) ** n
    expected = np.array(f.lambert) / math.pi + np.array(f.params["albedo"]) * lobe
    _assert_published(f, "lafortune+lambert", wi, wo, expected)


@pytest.mark.parametrize("wi, wo", PAIRS)
def test_ward_by_hand(fits, wi, wo):
    wi, wo = _unit(wi), _unit(wo)
    f = fits["mat-a"]
    a = 0.12
    h = wi + wo                         # unnormalised, as bbm's: the ratio is tan^2
    lobe = math.exp(-(h[0] ** 2 + h[1] ** 2) / h[2] ** 2 / a ** 2) / (4 * math.pi * a * a * math.sqrt(wi[2] * wo[2]))
    expected = np.array(f.lambert) / math.pi + np.array(f.params["albedo"]) * lobe
    _assert_published(f, "ward+lambert", wi, wo, expected)


@pytest.mark.parametrize("wi, wo", PAIRS)
def test_blinn_phong_two_evaluations(fits, wi, wo):
    """bbm's NganBlinnPhong is the modified Phong mirror lobe; the half-vector reading is the second."""
    wi, wo = _unit(wi), _unit(wo)
    f = fits["mat-d"]
    n, ks, rho = 120.0, np.array(f.params["albedo"]), np.array(f.lambert)
    r = 2 * wi[2] * np.array([0.0, 0.0, 1.0]) - wi
    h = _unit(wi + wo)
    mirror = rho / math.pi + ks * (n + 2) / (2 * math.pi) * max(r @ wo, 0.0) ** n
    half = rho / math.pi + ks * (n + 2) / (2 * math.pi) * h[2] ** n
    (_, m1, p1), (_, m2, p2) = ngan.as_ours(f)
    np.testing.assert_allclose(brdf.evaluate(m1, _arrays(p1), wi, wo), mirror, rtol=1e-9)
    np.testing.assert_allclose(brdf.evaluate(m2, _arrays(p2), wi, wo), half, rtol=1e-9)


@pytest.mark.parametrize("wi, wo", PAIRS)
def test_ashikhmin_shirley_by_hand(fits, wi, wo):
    """bbm's NganAshikhminShirley: albedo (n+1)/(8 pi) (n.h)^n F(h.wi) / (h.wi max(n.wi, n.wo)),
    F Schlick of the grey fresnelReflectance R_s, plus rho/pi."""
    wi, wo = _unit(wi), _unit(wo)
    f = fits["mat-e"]
    n, rs, ks, rho = 60.0, 0.09, np.array(f.params["albedo"]), np.array(f.lambert)
    h = _unit(wi + wo)
    hi = h @ wi
    fresnel = rs + (1 - rs) * (1 - hi) ** 5
    expected = rho / math.pi + ks * (n + 1) / (8 * math.pi) * h[2] ** n * fresnel / (hi * max(wi[2], wo[2]))
    _assert_published(f, "ashikhmin_shirley_scaled+lambert", wi, wo, expected)
