// The classic lobe models: Blinn-Phong, modified Phong (bare and with the microfacet
// factor), Ward, Ward-Duer, Ashikhmin-Shirley, Lafortune (mirrors brdf/lobes.py; docs/models.md, "Lobe models").
//
// Sources: Blinn 1977 (normalised half-vector lobe, NDF form); Lafortune &
// Willems 1994 (modified Phong, the energy-conserving mirror lobe); Ward 1992;
// Duer 2006 (Ward's normalisation corrected); Ashikhmin & Shirley 2000; Lafortune et al.
// 1997 with Ngan et al. 2005's normalisation; Walter et al. 2007 eq. 33 (the
// Phong exponent of Beckmann's alpha, n = 2 / alpha^2 - 2).
#include "geometry.glsl"
#include "fresnel.glsl"
#include "beckmann.glsl"

// Walter et al. 2007 eq. 33: the Phong exponent of Beckmann's alpha, n = 2 / alpha^2 - 2.
float phong_exponent(float alpha) {
    float a = max(alpha, ALPHA_MIN);
    return 2.0 / (a * a) - 2.0;
}

// log c by its atanh series above this cosine (brdf.lobes.LOG_SERIES_MIN)
const float LOG_SERIES_MIN = 0.9;
const float THIRD = 0.333333333333333333;
const float FIFTH = 0.2;
const float SEVENTH = 0.142857142857142857;

// log c for c > 0: above LOG_SERIES_MIN as 2 atanh(u) = 2 u (1 + u^2/3 + u^4/5 + u^6/7),
// u = (c - 1)/(c + 1), accurate near c = 1 where the exponent (up to 2e6) multiplies it;
// the same operations as brdf.lobes.log_cosine (GLSL's log is not accurate enough there).
float log_cosine(float c) {
    precise float u = (c - 1.0) / (c + 1.0);
    precise float u2 = u * u;
    precise float series = 2.0 * u * (1.0 + u2 * (THIRD + u2 * (FIFTH + u2 * SEVENTH)));
    return c > LOG_SERIES_MIN ? series : log(c);
}

// max(0, c)^n as exp(n log c), 0 for c <= 0.
float cosine_power(float c, float exponent) {
    return c > 0.0 ? exp(exponent * log_cosine(c)) : 0.0;
}

// Normalised Blinn-Phong lobe (NDF form): (n + 2) / (2 pi) max(0, n.h)^n.
float blinn_phong(float n_dot_h, float exponent) {
    return (exponent + 2.0) * (0.5 * INV_PI) * cosine_power(n_dot_h, exponent);
}

// r.wo with r = 2 (n.wi) n - wi, the mirror of wi: 2 (n.wi)(n.wo) - wi.wo.
float mirror_cosine(vec3 wi, vec3 wo) {
    precise float m = 2.0 * wi.z * wo.z - dot3(wi, wo);
    return m;
}

// Modified Phong (Lafortune & Willems 1994): (n + 2) / (2 pi) max(0, r.wo)^n.
float phong_modified(float r_dot_v, float exponent) {
    return (exponent + 2.0) * (0.5 * INV_PI) * cosine_power(r_dot_v, exponent);
}

// The microfacet BRDF's factor of an NDF, 1 / (4 (wi.h) max(n.wi, n.wo)), with Ashikhmin &
// Shirley 2000's max(n.wi, n.wo) for (n.wi)(n.wo) / G (blinn_phong_mf, phong_mf).
float microfacet_factor(float v_dot_h, float n_dot_l, float n_dot_v) {
    return 0.25 / (clamp_cos(v_dot_h) * max(clamp_cos(n_dot_l), clamp_cos(n_dot_v)));
}

// exp(-tan^2 theta_h / alpha^2) / (4 pi alpha^2), 0 for n.h <= 0: Beckmann's D
// (beckmann.glsl, n.h floored alike) times cos^4 theta_h / 4.
float ward_exp(float n_dot_h, float alpha) {
    float c = max(n_dot_h, BECKMANN_NDF_COS_MIN);
    precise float c2 = c * c;
    return beckmann_ndf(n_dot_h, alpha) * (c2 * c2 / 4.0);
}

// Isotropic Ward (1992): exp(-tan^2 theta_h / alpha^2) / (4 pi alpha^2 sqrt(n.l n.v)).
float ward(float n_dot_h, float n_dot_l, float n_dot_v, float alpha) {
    return ward_exp(n_dot_h, alpha) / sqrt(clamp_cos(n_dot_l) * clamp_cos(n_dot_v));
}

// Ward-Duer (Duer 2006): exp(-tan^2 theta_h / alpha^2) / (4 pi alpha^2 n.l n.v).
float ward_duer(float n_dot_h, float n_dot_l, float n_dot_v, float alpha) {
    return ward_exp(n_dot_h, alpha) / (clamp_cos(n_dot_l) * clamp_cos(n_dot_v));
}

// Ashikhmin & Shirley 2000, isotropic, without its Fresnel factor:
// (n + 1) / (8 pi) (n.h)^n / ((h.wi) max(n.wi, n.wo)).
float ashikhmin_shirley(float n_dot_h, float v_dot_h, float n_dot_l, float n_dot_v, float exponent) {
    float denominator = clamp_cos(v_dot_h) * max(clamp_cos(n_dot_l), clamp_cos(n_dot_v));
    return (exponent + 1.0) * (0.125 * INV_PI) * cosine_power(n_dot_h, exponent) / denominator;
}

// exp(-((t.h/at)^2 + (b.h/ab)^2) / (n.h)^2) / (4 pi at ab), 0 for n.h <= 0: the
// anisotropic Beckmann D times (n.h)^4 / 4.
float ward_exp_aniso(vec3 h, float alpha_t, float alpha_b) {
    float hz = max(h.z, BECKMANN_NDF_COS_MIN);
    precise float hz2 = hz * hz;
    return beckmann_ndf_aniso(h, alpha_t, alpha_b) * (hz2 * hz2 / 4.0);
}

// Anisotropic Ward (1992), h in the lobe's rotated frame:
// exp(-tan^2 theta_h (cos^2 phi_h / at^2 + sin^2 phi_h / ab^2)) / (4 pi at ab sqrt(n.l n.v)).
float ward_aniso(vec3 h, float n_dot_l, float n_dot_v, float alpha_t, float alpha_b) {
    return ward_exp_aniso(h, alpha_t, alpha_b) / sqrt(clamp_cos(n_dot_l) * clamp_cos(n_dot_v));
}

// Anisotropic Ward-Duer (Duer 2006): the same over n.l n.v.
float ward_duer_aniso(vec3 h, float n_dot_l, float n_dot_v, float alpha_t, float alpha_b) {
    return ward_exp_aniso(h, alpha_t, alpha_b) / (clamp_cos(n_dot_l) * clamp_cos(n_dot_v));
}

// h's tangential sin^2 below this: h is the normal, the mean exponent taken (brdf.lobes.AS_SIN2_MIN).
const float AS_SIN2_MIN = 1e-12;

// Ashikhmin & Shirley 2000 (their eq. 4), without its Fresnel factor, h in the lobe's rotated
// frame: sqrt((nu + 1)(nv + 1)) / (8 pi) (n.h)^((nu hx^2 + nv hy^2) / (1 - hz^2)) / ((h.wi) max(n.wi, n.wo)).
// An exponent below 0 (an alpha above 1 from the anisotropy remap) reads as 0.
float ashikhmin_shirley_aniso(vec3 h, float v_dot_h, float n_dot_l, float n_dot_v, float exponent_u,
                              float exponent_v) {
    exponent_u = max(exponent_u, 0.0);
    exponent_v = max(exponent_v, 0.0);
    precise float sin2 = h.x * h.x + h.y * h.y;
    precise float mixed = sin2 > AS_SIN2_MIN
        ? (exponent_u * h.x * h.x + exponent_v * h.y * h.y) / max(sin2, AS_SIN2_MIN)
        : 0.5 * (exponent_u + exponent_v);
    float denominator = clamp_cos(v_dot_h) * max(clamp_cos(n_dot_l), clamp_cos(n_dot_v));
    float scale = sqrt((exponent_u + 1.0) * (exponent_v + 1.0)) * (0.125 * INV_PI);
    return scale * cosine_power(h.z, mixed) / denominator;
}

// (1 - Cz^2) / 2 below this reads as this under Lafortune's square root (brdf.lobes.LAFORTUNE_SQUARE_MIN).
const float LAFORTUNE_SQUARE_MIN = 1e-12;

// Cx = Cy of the unit forward C = (Cxy, Cxy, Cz): -sqrt((1 - Cz^2) / 2).
float lafortune_cxy(float cz) {
    return -sqrt(max(0.5 * (1.0 - cz * cz), LAFORTUNE_SQUARE_MIN));
}

// Lafortune et al. 1997's generalised cosine over Ngan's max(|Cxy|, |Cz|):
// (Cxy (wi_x wo_x + wi_y wo_y) + Cz wi_z wo_z) / max(|Cxy|, |Cz|).
float lafortune_cosine(vec3 wi, vec3 wo, float cxy, float cz) {
    precise float tangential = wi.x * wo.x + wi.y * wo.y;
    precise float c = cxy * tangential + cz * wi.z * wo.z;
    return c / max(abs(cxy), abs(cz));
}

// Ngan et al. 2005's Lafortune lobe: (n + 2) / (2 pi) max(0, cosine)^n.
float lafortune(float cosine, float exponent) {
    return (exponent + 2.0) * (0.5 * INV_PI) * cosine_power(cosine, exponent);
}

// One Lafortune lobe of a sum (lafortune2, lafortune3): rho times the lobe of roughness r
// (clamped, alpha = max(r^2, ALPHA_MIN) as the model's own) and shape Cz.
vec3 lafortune_term(vec3 wi, vec3 wo, vec3 rho, float roughness, float cz) {
    float r = clamp(roughness, ROUGHNESS_MIN, 1.0);
    float alpha = max(r * r, ALPHA_MIN);
    return rho * lafortune(lafortune_cosine(wi, wo, lafortune_cxy(cz), cz), phong_exponent(alpha));
}
