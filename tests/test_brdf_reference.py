"""Point reference values of ../shared/REFERENCE.md sections 1-7 (float64).

Every expected number below is a **ref** value printed by
../shared/tools/formulas_refvalues.py and quoted in REFERENCE.md (the section
is named next to each table), or a product / ratio of such values where a
composed model must reproduce them.  Tolerances: 1e-5 relative for closed
forms (the refs carry 6 significant digits), 1e-3 for quadrature results, and
2e-3 for values read through the interpolated energy tables (see
``TABLE_RTOL``).

The test geometry is rebuilt from its angles in float64 (the vectors printed in
REFERENCE.md are rounded to 6 digits): v = wo = (theta 40, phi 20 deg),
l = wi = (theta 55, phi 200 deg).
"""

import math

import numpy as np
import pytest

import brdf
from brdf import clearcoat, diffuse, energy, fresnel, gltf, specular
from brdf.geometry import rotate_tangent

RTOL = 1e-5          # closed forms against 6-significant-digit refs
QUAD_RTOL = 1e-3     # the project's own quadrature (64^2 Gauss-Legendre) vs the 512^2 reference
# Values read through the energy tables (E on a 32 x 32 (mu, r) grid, bilinear,
# from a 64^2-node quadrature): E differs from the 512^2 reference by up to
# ~8e-4 relative (E(1, alpha=0.0625)); 1 - E factors (Kulla-Conty) amplify that
# to ~6e-4 on f_ms.  2e-3 leaves room for the table and still catches a wrong
# formula (a swapped mu_i/mu_o, a missing pi or F_avg would be off by >10%).
TABLE_RTOL = 2e-3


def sph(theta_deg, phi_deg):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


V = sph(40.0, 20.0)      # wo, to the viewer
L = sph(55.0, 200.0)     # wi, to the light
H = (V + L) / np.linalg.norm(V + L)
NOV, NOL, NOH, LOH = V[2], L[2], H[2], float(L @ H)


# The refs are printed to 6 decimals (energy refs to 5): a small value such as
# Lambda = 0.008713 is only known to +-5e-7, i.e. 6e-5 relative.  ``close``
# therefore also allows half a unit of the last printed decimal.
HALF_ULP6 = 5e-7
HALF_ULP5 = 5e-6


def close(actual, expected, rtol=RTOL, atol=HALF_ULP6):
    np.testing.assert_allclose(np.asarray(actual, dtype=float), expected, rtol=rtol, atol=atol)


def pair(nov, nol, dphi_deg=180.0):
    """(wi, wo) with n.wo = nov, n.wi = nol, azimuths 0 and dphi."""
    so, si = math.sqrt(1 - nov * nov), math.sqrt(1 - nol * nol)
    c, s = math.cos(math.radians(dphi_deg)), math.sin(math.radians(dphi_deg))
    return np.array([si * c, si * s, nol]), np.array([so, 0.0, nov])


def pair_with_vh(c, theta_h_deg=5.0):
    """(wi, wo) mirror pair about h = (theta_h, 0) with v.h = c (both above the horizon)."""
    th, td = math.radians(theta_h_deg), math.acos(c)
    wo = np.array([math.sin(th + td), 0.0, math.cos(th + td)])
    wi = np.array([math.sin(th - td), 0.0, math.cos(th - td)])
    assert wo[2] > 0 and wi[2] > 0
    return wi, wo


def params(model, **kw):
    p = brdf.default_params(brdf.parse_model(model))
    for k, v in kw.items():
        assert k in p, (model, k)
        p[k] = np.asarray(v, dtype=float) * np.ones(np.shape(p[k]))
    return p


def ev(model, wi, wo, **kw):
    return np.asarray(brdf.evaluate(model, params(model, **kw), np.asarray(wi), np.asarray(wo)))


def test_geometry_matches_printed_vectors():
    # REFERENCE.md preamble prints the rounded vectors; ours agree to rounding.
    np.testing.assert_allclose(V, [0.604023, 0.219846, 0.766044], atol=6e-7)
    np.testing.assert_allclose(L, [-0.769751, -0.280166, 0.573576], atol=6e-7)
    np.testing.assert_allclose(H, [-0.122654, -0.044643, 0.991445], atol=6e-7)


# --- 1. GGX NDF ----------------------------------------------------------------

def test_ggx_ndf_iso():
    close(specular.ggx_ndf(0.9, 0.25), 0.343596)
    close(specular.ggx_ndf(1.0, 0.25), 5.092958)
    close(specular.ggx_ndf(1.0, 0.25), 1.0 / (math.pi * 0.25 ** 2))
    assert float(specular.ggx_ndf(-0.1, 0.25)) == 0.0


def test_ggx_ndf_aniso_at_test_h():
    close(specular.ggx_ndf_aniso(H, 0.3, 0.1), 5.826895)
    close(specular.ggx_ndf_aniso(H, 0.25, 0.25), 3.230708)
    close(specular.ggx_ndf(NOH, 0.25), 3.230708)
    assert float(specular.ggx_ndf_aniso(-H, 0.3, 0.1)) == 0.0


@pytest.mark.parametrize("fn, args, expected", [
    (specular.anisotropy_kulla_conty, (0.25, 0.5), (0.375, 0.125)),
    (specular.anisotropy_burley, (0.5, 0.5), (0.337100, 0.185405)),
    (specular.anisotropy_gltf, (0.25, 0.5), (0.4375, 0.25)),
], ids=["kulla_conty", "burley", "gltf"])
def test_anisotropy_remaps(fn, args, expected):
    close(fn(*args), expected)


def test_kulla_conty_remap_clamps_at_alpha_min():
    # REFERENCE.md s.1 table: "clamp >= 1e-3"
    at, ab = specular.anisotropy_kulla_conty(0.25, 1.0)
    close(at, 0.5)
    assert float(ab) == brdf.ALPHA_MIN


# --- 2. Smith -------------------------------------------------------------------

ALPHA = 0.25   # r = 0.5


def test_smith_lambda_g1():
    close(specular.smith_lambda(0.5, ALPHA), 0.044862)
    close(specular.smith_lambda(0.8, ALPHA), 0.008713)
    close(specular.smith_g1(0.5, ALPHA), 0.957064)
    close(specular.smith_g1(0.8, ALPHA), 0.991362)


def test_smith_g_sep_g2_v():
    close(specular.g_separable(0.8, 0.5, ALPHA), 0.948797)
    close(specular.g_height_correlated(0.8, 0.5, ALPHA), 0.949149)
    close(specular.visibility_height_correlated(0.8, 0.5, ALPHA), 0.593218)
    close(specular.visibility_height_correlated(0.8, 0.5, ALPHA), 0.949149 / (4 * 0.4))
    close(specular.visibility_separable(0.8, 0.5, ALPHA), 0.948797 / (4 * 0.4))


@pytest.mark.parametrize("k, expected", [((0.5 + 1) ** 2 / 8, 0.729215), (0.25 / 2, 0.861953)],
                         ids=["k_analytic", "k_ibl"])
def test_schlick_ggx(k, expected):
    g = specular.smith_g1_schlick(0.5, k) * specular.smith_g1_schlick(0.8, k)
    close(g, expected)


def test_smith_aniso_at_test_geometry():
    close(specular.visibility_height_correlated_aniso(L, V, 0.3, 0.1), 0.540055)
    close(specular.visibility_height_correlated_aniso(L, V, 0.25, 0.25), 0.546150)
    close(specular.visibility_height_correlated(NOL, NOV, 0.25), 0.546150)
    close(specular.smith_lambda_aniso(V, 0.3, 0.1), 0.013999)


def test_smith_aniso_reduces_to_iso():
    # at alpha_t = alpha_b the anisotropic forms are the isotropic ones (s.2)
    close(specular.smith_lambda_aniso(V, 0.25, 0.25), specular.smith_lambda(NOV, 0.25), 1e-12)
    close(specular.visibility_separable_aniso(L, V, 0.25, 0.25),
          specular.visibility_separable(NOL, NOV, 0.25), 1e-12)


# --- 3. Fresnel -----------------------------------------------------------------

FRESNEL_TABLE = [  # c, Schlick .04, exact 1.5, conductor, Schlick(F0 cond), Schlick-rough(.04, r=.5)
    (1.0, 0.040000, 0.040000, 0.944991, 0.944991, 0.040000),
    (0.5, 0.070000, 0.089187, 0.939540, 0.946710, 0.054375),
    (0.2, 0.354573, 0.338894, 0.945221, 0.963016, 0.190733),
]


@pytest.mark.parametrize("row", FRESNEL_TABLE, ids=lambda r: f"c={r[0]}")
def test_fresnel_table(row):
    c, schlick, exact, cond, schlick_cond, rough = row
    close(fresnel.fresnel_schlick(0.04, c), schlick)
    close(fresnel.fresnel_schlick(np.array([0.04, 0.04, 0.04]), c), [schlick] * 3)
    close(fresnel.fresnel_dielectric(c, 1.5), exact)
    close(fresnel.fresnel_conductor(c, 0.18, 3.42), cond)
    close(fresnel.fresnel_schlick(fresnel.f0_from_ior(0.18, 3.42), c), schlick_cond)
    close(fresnel.fresnel_schlick_roughness(0.04, c, 0.5), rough)


def test_fresnel_f90_and_tir():
    # F90 = 1 is the default; at c = 0 Schlick returns F90 exactly (s.3 formula)
    close(fresnel.fresnel_schlick(0.04, 0.0, 0.5), 0.5, 1e-12)
    # eta < 1 beyond the critical angle: total internal reflection, F = 1
    assert float(fresnel.fresnel_dielectric(0.1, 1.0 / 1.5)) == 1.0


def test_f0_ior():
    close(fresnel.f0_from_ior(1.5), 0.04)
    close(fresnel.f0_from_ior(1.33), 0.020059)
    close(fresnel.ior_from_f0(0.05), 1.576014)
    close(fresnel.f0_from_ior(0.18, 3.42), 0.944991)
    # round trip (s.3: n = (1 + sqrt F0) / (1 - sqrt F0) inverts F0(n))
    for n in (1.1, 1.5, 2.4):
        close(fresnel.ior_from_f0(fresnel.f0_from_ior(n)), n, 1e-12)


def test_fresnel_schlick_average():
    # s.5: F_avg = F0 + (1 - F0)/21; the Fdez-Aguera row gives 0.08571 for F0 = 0.04
    close(fresnel.fresnel_schlick_average(0.04), 0.08571, 1e-5, HALF_ULP5)


# --- 4. Diffuse point values (rho = 1, test geometry) ------------------------------

@pytest.mark.parametrize("name, fn, expected", [
    ("lambert", lambda: diffuse.lambert(1.0, NOL, NOV), 1.0 / math.pi),
    ("burley", lambda: diffuse.burley(1.0, 0.5, NOL, NOV, LOH), 0.318105),
    ("frostbite", lambda: diffuse.frostbite(1.0, 0.5, NOL, NOV, LOH), 0.263406),
    ("cod_wwii", lambda: diffuse.cod_wwii(1.0, 0.25, NOL, NOV, LOH, NOH), 0.231620),
    ("oren_nayar", lambda: diffuse.oren_nayar(1.0, 0.5, L, V), 0.249709),
    ("oren_nayar_full", lambda: diffuse.oren_nayar_full(1.0, 0.5, L, V), 0.227706),
], ids=lambda x: x if isinstance(x, str) else "")
def test_diffuse_point_values(name, fn, expected):
    close(fn(), expected)


def test_diffuse_rgb_albedo_scales():
    rho = np.array([0.8, 0.2, 0.1])
    close(diffuse.burley(rho, 0.5, NOL, NOV, LOH), 0.318105 * rho)
    close(diffuse.oren_nayar(rho, 0.5, L, V), 0.249709 * rho)


@pytest.mark.parametrize("alpha, g", [(0.0625, 0.499843), (0.25, 0.275233), (0.5, 0.155964),
                                      (1e-4, 1.0), (2.0, 0.0)])
def test_cod_gloss(alpha, g):
    # last two: the clamp of s.4 (alpha < 0.00276 -> g = 1, alpha > 1 -> g = 0)
    close(diffuse.cod_gloss_from_alpha(alpha), g)


# --- 5. Energy compensation -----------------------------------------------------

ENERGY_TABLE = [  # alpha, E(1), E(0.5), A(0.5), B(0.5), E_avg
    (0.0625, 0.99571, 0.98832, 0.95569, 0.03264, 0.98725),
    (0.25, 0.91581, 0.85726, 0.83492, 0.02235, 0.88232),
    (0.5, 0.68785, 0.69825, 0.68810, 0.01015, 0.70024),
    (1.0, 0.30685, 0.45069, 0.44771, 0.00299, 0.40914),
]


@pytest.mark.parametrize("row", ENERGY_TABLE, ids=lambda r: f"alpha={r[0]}")
def test_energy_quadrature(row):
    alpha, e1, e05, a05, b05, e_avg = row
    close(energy.directional_albedo(1.0, alpha), e1, QUAD_RTOL)
    a, b = energy.dfg_terms(0.5, alpha)
    close(a + b, e05, QUAD_RTOL)
    close(a, a05, QUAD_RTOL)
    # B is small: 1e-3 relative of B is 3e-6 absolute at alpha = 1
    np.testing.assert_allclose(b, b05, rtol=QUAD_RTOL, atol=5e-6)


@pytest.mark.parametrize("row", ENERGY_TABLE, ids=lambda r: f"alpha={r[0]}")
def test_energy_table_lookup(row):
    alpha, e1, e05, _, _, e_avg = row
    r = math.sqrt(alpha)
    close(energy.lookup_e(1.0, r), e1, TABLE_RTOL)
    close(energy.lookup_e(0.5, r), e05, TABLE_RTOL)
    close(energy.lookup_e_avg(r), e_avg, TABLE_RTOL)


def test_fdez_aguera_from_dfg_terms():
    # s.5, F0 = 0.04, alpha = 0.25, NoV = 0.5 with k_S = F0
    a, b = energy.dfg_terms(0.5, 0.25)
    f0 = 0.04
    fss_ess = f0 * a + b
    e_ms = 1.0 - (a + b)
    f_avg = float(fresnel.fresnel_schlick_average(f0))
    fms_ems = fss_ess * f_avg * e_ms / (1.0 - e_ms * f_avg)
    close(fss_ess, 0.05574, QUAD_RTOL, HALF_ULP5)
    # E_ms = 1 - E inherits E's absolute error (1e-3 E), not a relative one
    np.testing.assert_allclose(e_ms, 0.14274, atol=QUAD_RTOL * (a + b))
    close(f_avg, 0.08571, 1e-5, HALF_ULP5)
    # printed to 5 decimals: 0.00069 carries only 2 significant digits
    np.testing.assert_allclose(fms_ems, 0.00069, atol=HALF_ULP5)
    close(1.0 - (fss_ess + fms_ems), 0.94357, QUAD_RTOL)


@pytest.mark.parametrize("f0, expected", [(0.04, 1.00666), (1.0, 1.16650)])
def test_turquin_factor(f0, expected):
    close(energy.turquin_factor(0.5, 0.5, f0), expected, TABLE_RTOL)
    close(energy.turquin_factor(0.5, 0.5, np.array([f0] * 3)), [expected] * 3, TABLE_RTOL)
    # the formula itself, fed the reference E(0.5, 0.25) = 0.85726
    close(1.0 + f0 * (1 - 0.85726) / 0.85726, expected, 1e-5, HALF_ULP5)


def test_kulla_conty_f_ms():
    # f_ms(mu_o = .5, mu_i = .8, alpha = .25) with F = 1
    close(energy.kulla_conty(0.8, 0.5, 0.5), 0.039663, TABLE_RTOL)
    close(energy.kulla_conty(0.5, 0.8, 0.5), 0.039663, TABLE_RTOL)


def test_kulla_conty_fresnel_factor():
    f_avg = fresnel.fresnel_schlick_average(0.04)
    # the closed form fed the reference E_avg(0.25) = 0.88232 (5 digits)
    close(energy.kulla_conty_fresnel_factor(f_avg, 0.88232), 0.006548, 1e-4)  # E_avg input has 5 digits
    close(energy.kulla_conty_fresnel_factor(f_avg, energy.lookup_e_avg(0.5)), 0.006548, TABLE_RTOL)
    close(energy.kulla_conty_fresnel_factor(fresnel.fresnel_schlick_average(1.0),
                                            energy.lookup_e_avg(0.5)), 1.0, 1e-12)
    rgb = energy.kulla_conty(0.8, 0.5, 0.5, np.array([f_avg, f_avg, 1.0]))
    close(rgb, [0.039663 * 0.006548, 0.039663 * 0.006548, 0.039663], TABLE_RTOL)


# --- 6. Clearcoat ---------------------------------------------------------------

def test_clearcoat_terms():
    close(clearcoat.clearcoat_fresnel(NOV), 0.040673)
    close(clearcoat.clearcoat_fresnel(0.5), 0.07)
    close(clearcoat.clearcoat_brdf(NOL, NOV, NOH, 0.1), 0.061678)


BASE = np.array([0.8, 0.2, 0.1])
GLTF_DIELECTRIC = np.array([0.320248, 0.137560, 0.107112])
GLTF_METAL = np.array([1.412829, 0.357962, 0.182151])
GLTF_SPECULAR_COLOR = np.array([0.380423, 0.135023, 0.070681])
COATED = np.array([0.309731, 0.134474, 0.105264])


def test_apply_clearcoat_on_gltf_dielectric():
    close(clearcoat.apply_clearcoat(GLTF_DIELECTRIC, 1.0, 0.1, NOL, NOV, NOH), COATED)


def test_gltf_clearcoat_model():
    f = ev("gltf+clearcoat", L, V, base_color=BASE, metallic=0.0, roughness=0.5,
           clearcoat=1.0, clearcoat_roughness=0.1)
    close(f, COATED)
    # clearcoat factor 0 leaves the base material
    f0 = ev("gltf+clearcoat", L, V, base_color=BASE, metallic=0.0, roughness=0.5,
            clearcoat=0.0, clearcoat_roughness=0.1)
    close(f0, GLTF_DIELECTRIC)


# --- 7. glTF ----------------------------------------------------------------------

def test_gltf_terms():
    close(gltf.gltf_specular_dv(L, V, 0.5), 1.764451)
    close(0.04 + 0.96 * (1 - float(V @ H)) ** 5, 0.043449)


@pytest.mark.parametrize("model, kw, expected", [
    ("gltf", dict(metallic=0.0), GLTF_DIELECTRIC),
    ("gltf", dict(metallic=1.0), GLTF_METAL),
    ("gltf+ior", dict(metallic=0.0, ior=1.5), GLTF_DIELECTRIC),
    ("gltf+specular", dict(metallic=0.0, specular=1.0, specular_color=1.0), GLTF_DIELECTRIC),
    ("gltf+specular", dict(metallic=0.0, specular=1.0, specular_color=[2.0, 1.0, 0.5]),
     GLTF_SPECULAR_COLOR),
    ("gltf+specular", dict(metallic=1.0, specular=0.3, specular_color=[2.0, 1.0, 0.5]), GLTF_METAL),
    ("gltf+aniso", dict(metallic=0.0, anisotropy=0.0, rotation=0.7), GLTF_DIELECTRIC),
    ("gltf+aniso", dict(metallic=1.0, anisotropy=0.0, rotation=0.0), GLTF_METAL),
], ids=["core", "metal", "ior_default", "specular_default", "specular_color",
        "metal_ignores_specular", "aniso0_rot", "aniso0_metal"])
def test_gltf_reference(model, kw, expected):
    close(ev(model, L, V, base_color=BASE, roughness=0.5, **kw), expected)


def test_gltf_metallic_mix_is_linear():
    # material = mix(dielectric, metal, metallic), s.7
    f = ev("gltf", L, V, base_color=BASE, roughness=0.5, metallic=0.3)
    close(f, 0.7 * GLTF_DIELECTRIC + 0.3 * GLTF_METAL)


def test_gltf_ior_changes_f0():
    # KHR_materials_ior: ior 1.33 -> F0 = 0.020059 (s.3); dielectric = F DV + (1 - F) base/pi
    fw = (1 - float(V @ H)) ** 5
    f0 = 0.020059
    fr = f0 + (1 - f0) * fw
    expected = fr * 1.764451 + (1 - fr) * BASE / math.pi
    close(ev("gltf+ior", L, V, base_color=BASE, roughness=0.5, metallic=0.0, ior=1.33), expected)


def test_gltf_aniso_lobe():
    # alpha_b = alpha = 0.1, strength s with mix(0.1, 1, s^2) = 0.3 -> (alpha_t, alpha_b) = (0.3, 0.1)
    s = math.sqrt((0.3 - 0.1) / 0.9)
    close(gltf.gltf_specular_dv(L, V, math.sqrt(0.1), s, 0.0), 5.826895 * 0.540055)
    # metallic white base: f = (1 + 0 * fw) D V
    f = ev("gltf+aniso", L, V, base_color=1.0, metallic=1.0, roughness=math.sqrt(0.1),
           anisotropy=s, rotation=0.0)
    close(f, [5.826895 * 0.540055] * 3)


# --- composed ggx models against the refs -------------------------------------------

DV = 1.764451          # s.7, D V at the test geometry, alpha = 0.25
F_SCHLICK = 0.043449   # s.7, Schlick F0 = 0.04 at v.h of the test geometry


@pytest.mark.parametrize("model, kw, diffuse_ref", [
    ("ggx+lambert", {}, 1.0 / math.pi),
    ("ggx+burley", {}, 0.318105),
    ("ggx+frostbite", {}, 0.263406),
    ("ggx+cod_wwii", {}, 0.231620),
    ("ggx+oren_nayar", dict(sigma=0.5), 0.249709),
    ("ggx", {}, 0.0),
])
def test_ggx_additive_compositions(model, kw, diffuse_ref):
    albedo = {} if model == "ggx" else dict(albedo=BASE)
    f = ev(model, L, V, roughness=0.5, f0=0.04, **albedo, **kw)
    close(f, DV * F_SCHLICK + diffuse_ref * (BASE if albedo else 0.0))


def test_ggx_coupled_is_gltf_dielectric():
    # coupled: D V F + (1 - F) rho/pi == glTF dielectric with baseColor = rho
    close(ev("ggx+lambert+coupled", L, V, albedo=BASE, roughness=0.5, f0=0.04), GLTF_DIELECTRIC)


def test_ggx_coupled_clearcoat_is_gltf_coated():
    close(ev("ggx+lambert+coupled+clearcoat", L, V, albedo=BASE, roughness=0.5, f0=0.04,
             clearcoat=1.0, clearcoat_roughness=0.1), COATED)


def test_ggx_separable_ratio():
    # at n.v = 0.5, n.l = 0.8 the separable/correlated ratio is G_sep/G2 (s.2), whatever h
    wi, wo = pair(0.5, 0.8, 150.0)
    ratio = ev("ggx+separable", wi, wo, roughness=0.5, f0=0.04) / ev("ggx", wi, wo, roughness=0.5, f0=0.04)
    close(ratio, [0.948797 / 0.949149] * 3)


@pytest.mark.parametrize("c_index", [0, 1, 2])
def test_ggx_fresnel_options(c_index):
    # ratio to the F = 1 lobe (Schlick with f0 = 1) is the Fresnel table of s.3 at v.h = c
    c, schlick, exact, cond, _, _ = FRESNEL_TABLE[c_index]
    wi, wo = pair_with_vh(c)
    one = ev("ggx", wi, wo, roughness=0.5, f0=1.0)
    close(ev("ggx", wi, wo, roughness=0.5, f0=0.04) / one, [schlick] * 3)
    close(ev("ggx+f90", wi, wo, roughness=0.5, f0=0.04, f90=1.0) / one, [schlick] * 3)
    close(ev("ggx+dielectric", wi, wo, roughness=0.5, ior=1.5) / one, [exact] * 3)
    close(ev("ggx+conductor", wi, wo, roughness=0.5, eta=0.18, k=3.42) / one, [cond] * 3)


def test_ggx_f90_scales_grazing_term():
    # Schlick with F90: F0 + (F90 - F0) (1 - c)^5
    c = 0.2
    wi, wo = pair_with_vh(c)
    one = ev("ggx", wi, wo, roughness=0.5, f0=1.0)
    f = ev("ggx+f90", wi, wo, roughness=0.5, f0=0.04, f90=0.5) / one
    close(f, [0.04 + (0.5 - 0.04) * (1 - c) ** 5] * 3, 1e-12)


@pytest.mark.parametrize("f0, factor", [(1.0, 1.0), (0.04, 0.006548)])
def test_ggx_ms_adds_kulla_conty(f0, factor):
    wi, wo = pair(0.5, 0.8, 120.0)
    extra = ev("ggx+ms", wi, wo, roughness=0.5, f0=f0) - ev("ggx", wi, wo, roughness=0.5, f0=f0)
    close(extra, [0.039663 * factor] * 3, TABLE_RTOL)


@pytest.mark.parametrize("f0, factor", [(0.04, 1.00666), (1.0, 1.16650)])
def test_ggx_turquin_scales_specular(f0, factor):
    wi, wo = pair(0.5, 0.8, 120.0)   # mu_o = n.wo = 0.5
    ratio = ev("ggx+turquin", wi, wo, roughness=0.5, f0=f0) / ev("ggx", wi, wo, roughness=0.5, f0=f0)
    close(ratio, [factor] * 3, TABLE_RTOL)
    # the diffuse lobe is not scaled
    diff = (ev("ggx+lambert+turquin", wi, wo, roughness=0.5, f0=f0, albedo=BASE)
            - ev("ggx+turquin", wi, wo, roughness=0.5, f0=f0))
    close(diff, BASE / math.pi, 1e-12)


def test_ggx_aniso_kulla_conty_lobe():
    # alpha = 0.2, a = 0.5 -> (0.3, 0.1); F = 1 and albedo 0 leave D V
    f = ev("ggx_aniso+lambert", L, V, roughness=math.sqrt(0.2), anisotropy=0.5, rotation=0.0,
           f0=1.0, albedo=0.0)
    close(f, [5.826895 * 0.540055] * 3)


def test_ggx_aniso_gltf_remap_lobe():
    s = math.sqrt((0.3 - 0.1) / 0.9)
    f = ev("ggx_aniso+gltf_aniso", L, V, roughness=math.sqrt(0.1), anisotropy=s, rotation=0.0, f0=1.0)
    close(f, [5.826895 * 0.540055] * 3)


def test_ggx_aniso_rotation_quarter_turn_swaps_axes():
    # rotating the tangent by +90 deg makes t' = b, b' = -t: alpha_t acts along y
    f = ev("ggx_aniso", L, V, roughness=math.sqrt(0.2), anisotropy=-0.5, rotation=math.pi / 2, f0=1.0)
    close(f, [5.826895 * 0.540055] * 3)


@pytest.mark.parametrize("model", ["ggx_aniso+lambert", "ggx_aniso+gltf_aniso+burley",
                                   "ggx_aniso+separable", "gltf+aniso"])
@pytest.mark.parametrize("angle", [0.4, -1.2])
def test_aniso_rotation_covariance(model, angle):
    # rotating both directions by the tangent rotation (CCW about n) gives the unrotated value
    kw = dict(roughness=0.6, anisotropy=0.7)
    if model.startswith("gltf"):
        kw.update(base_color=BASE, metallic=0.4)
    else:
        kw.update(f0=[0.04, 0.5, 0.9])
    c, s = math.cos(angle), math.sin(angle)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    ref = ev(model, L, V, rotation=0.0, **kw)
    close(ev(model, rot @ L, rot @ V, rotation=angle, **kw), ref, 1e-10)
    # and the rotation matters (the lobe is anisotropic)
    assert not np.allclose(ev(model, L, V, rotation=angle, **kw), ref, rtol=1e-3)
    np.testing.assert_allclose(rotate_tangent(rot @ L, angle), L, atol=1e-15)


def test_below_horizon_is_zero():
    for model in brdf.MODEL_EXAMPLES:
        p = brdf.default_params(brdf.parse_model(model))
        f = brdf.evaluate(model, p, np.array([0.3, 0.0, -0.2]) / np.linalg.norm([0.3, 0, -0.2]), V)
        assert np.all(np.asarray(f) == 0.0), model
