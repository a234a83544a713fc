// The Beckmann NDF with its exact Smith Lambda, and Cook-Torrance's V-groove
// masking (mirrors brdf/beckmann.py; docs/models.md, "Beckmann" and
// "Cook-Torrance").
//
// Sources: Beckmann & Spizzichino 1963; Walter et al. 2007, "Microfacet models
// for refraction through rough surfaces" (normalised D, Smith Lambda with erf);
// Heitz 2014 (height-correlated G2, anisotropic Lambda); Cook & Torrance 1982
// (V-groove masking).  GLSL has no erfc: erfc_scaled below is the Chebyshev fit
// of Press et al., Numerical Recipes (erfcc, fractional error < 1.2e-7), where
// JAX uses the exact erfc.
//
// Every function takes alpha = roughness^2 and floors it at ALPHA_MIN
// (alpha_floor, specular.glsl).
#include "geometry.glsl"

// The same values as brdf/beckmann.py's constants.
const float BECKMANN_LAMBDA_A_MAX = 6.0;      // Lambda(a) < 1e-17 beyond: 0
const float BECKMANN_SIN2_MIN = 1e-12;        // floor on sin^2 theta before it divides
const float BECKMANN_NDF_COS_MIN = 1e-3;      // n.h read as at least this (D = 0 there)
const float INV_SQRT_PI = 0.564189583547756287;

// --- normal distribution ----------------------------------------------------------

// Beckmann: D = exp(-tan^2 theta_h / a^2) / (pi a^2 cos^4 theta_h), 0 for n.h <= 0.
float beckmann_ndf(float n_dot_h, float alpha) {
    float a = alpha_floor(alpha);
    float a2 = a * a;
    bool up = n_dot_h > 0.0;
    float c = up ? max(n_dot_h, BECKMANN_NDF_COS_MIN) : 1.0;
    // precise: rounds as brdf.beckmann.beckmann_ndf (float32) near n.h = 1
    precise float c2 = c * c;
    precise float tan2 = (1.0 - c2) / c2;
    return up ? exp(-tan2 / a2) / (PI * a2 * c2 * c2) : 0.0;
}

// Anisotropic Beckmann: exp(-((t.h/at)^2 + (b.h/ab)^2) / (n.h)^2) / (pi at ab (n.h)^4).
float beckmann_ndf_aniso(vec3 h, float alpha_t, float alpha_b) {
    float at = alpha_floor(alpha_t);
    float ab = alpha_floor(alpha_b);
    bool up = h.z > 0.0;
    float hz = up ? max(h.z, BECKMANN_NDF_COS_MIN) : 1.0;
    precise float hz2 = hz * hz;
    float x = h.x / at;
    float y = h.y / ab;
    precise float e = (x * x + y * y) / hz2;
    return up ? exp(-e) / (PI * at * ab * hz2 * hz2) : 0.0;
}

// --- Smith Lambda --------------------------------------------------------------------

// exp(a^2) erfc(a) for a >= 0 (Numerical Recipes' erfcc without its exp(-a^2)).
float erfc_scaled(float a) {
    float t = 1.0 / (1.0 + 0.5 * a);
    float p = -1.26551223 + t * (1.00002368 + t * (0.37409196 + t * (0.09678418
              + t * (-0.18628806 + t * (0.27886807 + t * (-1.13520398 + t * (1.48851587
              + t * (-0.82215223 + t * 0.17087277))))))));
    return t * exp(p);
}

// Lambda(a) = (erf(a) - 1)/2 + exp(-a^2) / (2 a sqrt(pi)), a = 1 / (alpha tan theta)
// (Walter et al. 2007, eq. 27) = exp(-a^2) (1 / (a sqrt(pi)) - exp(a^2) erfc(a)) / 2.
float beckmann_lambda_of_a(float a) {
    if (a >= BECKMANN_LAMBDA_A_MAX) return 0.0;
    return 0.5 * exp(-a * a) * (INV_SQRT_PI / a - erfc_scaled(a));
}

// Beckmann's Smith Lambda(v) at a = n.v / (alpha sqrt(1 - (n.v)^2)).
float beckmann_lambda(float n_dot_v, float alpha) {
    float c = clamp_cos(n_dot_v);
    precise float s2 = max(1.0 - c * c, BECKMANN_SIN2_MIN);
    return beckmann_lambda_of_a(c / (alpha_floor(alpha) * sqrt(s2)));
}

// Anisotropic Lambda: a = n.v / sqrt(at^2 (t.v)^2 + ab^2 (b.v)^2) (Heitz 2014).
float beckmann_lambda_aniso(vec3 v, float alpha_t, float alpha_b) {
    float at = alpha_floor(alpha_t);
    float ab = alpha_floor(alpha_b);
    float c = clamp_cos(v.z);
    float tx = at * v.x;
    float ty = ab * v.y;
    float x = max(tx * tx + ty * ty, BECKMANN_SIN2_MIN);
    return beckmann_lambda_of_a(c / sqrt(x));
}

// --- Cook-Torrance's V-groove masking -------------------------------------------------

// Cook & Torrance 1982: G = min(1, 2 (n.h)(n.v) / (v.h), 2 (n.h)(n.l) / (v.h)).
float g_vgroove(float n_dot_l, float n_dot_v, float n_dot_h, float v_dot_h) {
    float k = 2.0 * max(n_dot_h, 0.0) / clamp_cos(v_dot_h);
    return min(1.0, k * min(clamp_cos(n_dot_v), clamp_cos(n_dot_l)));
}
