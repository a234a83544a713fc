// Fresnel reflectance: Schlick's approximation, exact dielectric and conductor
// (mirrors brdf/fresnel.py; REFERENCE.md s.3).
//
// Sources: Schlick 1994; Lagarde 2011 / Fdez-Aguera 2019 (roughness-dependent
// Schlick for ambient light); Walter et al. 2007 eq. 22 (unpolarised
// dielectric); the complex-IOR conductor formula (Born & Wolf).  `cos` is the
// cosine between the incident direction and the (micro)normal, v.h for a
// specular lobe.
#include "common.glsl"

// F = F0 + (F90 - F0)(1 - cos)^5.
float fresnel_schlick(float f0, float cos_theta, float f90) {
    float w = pow5(1.0 - clamp(cos_theta, 0.0, 1.0));
    return f0 + (f90 - f0) * w;
}
vec3 fresnel_schlick(vec3 f0, float cos_theta, vec3 f90) {
    float w = pow5(1.0 - clamp(cos_theta, 0.0, 1.0));
    return f0 + (f90 - f0) * w;
}
vec3 fresnel_schlick(vec3 f0, float cos_theta, float f90) { return fresnel_schlick(f0, cos_theta, vec3(f90)); }
float fresnel_schlick(float f0, float cos_theta) { return fresnel_schlick(f0, cos_theta, 1.0); }
vec3 fresnel_schlick(vec3 f0, float cos_theta) { return fresnel_schlick(f0, cos_theta, vec3(1.0)); }

// Lagarde's ambient Schlick: F0 + (max(1 - r, F0) - F0)(1 - cos)^5.
float fresnel_schlick_roughness(float f0, float cos_theta, float roughness) {
    return fresnel_schlick(f0, cos_theta, max(1.0 - roughness, f0));
}
vec3 fresnel_schlick_roughness(vec3 f0, float cos_theta, float roughness) {
    return fresnel_schlick(f0, cos_theta, max(vec3(1.0 - roughness), f0));
}

// Exact unpolarised Fresnel reflectance of a dielectric, eta = n_t / n_i:
// g^2 = eta^2 - 1 + c^2 (g^2 < 0: total internal reflection, F = 1),
// F = 1/2 ((g - c)/(g + c))^2 (1 + ((c (g + c) - 1)/(c (g - c) + 1))^2).
float fresnel_dielectric(float cos_theta, float eta) {
    float c = clamp(cos_theta, 0.0, 1.0);
    float g2 = eta * eta - 1.0 + c * c;
    float g = sqrt(max(g2, 1e-12));
    float a = (g - c) / (g + c);
    float b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    return g2 > 0.0 ? 0.5 * a * a * (1.0 + b * b) : 1.0;
}

// --- complex arithmetic, by hand: a complex number is a vec2 (re, im) --------

vec2 complex_mul(vec2 a, vec2 b) { return vec2(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x); }
float complex_abs2(vec2 a) { return a.x * a.x + a.y * a.y; }

// Principal square root, computed without cancellation on either branch.
vec2 complex_sqrt(vec2 z) {
    float r = sqrt(z.x * z.x + z.y * z.y);
    if (z.x >= 0.0) {
        float t = sqrt(0.5 * (r + z.x));
        return vec2(t, t > 0.0 ? z.y / (2.0 * t) : 0.0);
    }
    float t = sqrt(0.5 * (r - z.x));
    return vec2(abs(z.y) / (2.0 * t), z.y < 0.0 ? -t : t);
}

// Unpolarised Fresnel reflectance of a conductor with complex IOR eta = n + i k:
// cos_t = sqrt(1 - (1 - c^2)/eta^2), r_s = (c - eta cos_t)/(c + eta cos_t),
// r_p = (eta c - cos_t)/(eta c + cos_t), F = (|r_s|^2 + |r_p|^2) / 2.
float fresnel_conductor(float cos_theta, float n, float k) {
    float c = clamp(cos_theta, 1e-6, 1.0);
    vec2 eta = vec2(n, k);
    vec2 eta2 = complex_mul(eta, eta);
    // (1 - c^2) / eta^2 = (1 - c^2) conj(eta^2) / |eta^2|^2
    float s = (1.0 - c * c) / complex_abs2(eta2);
    vec2 cos_t = complex_sqrt(vec2(1.0 - s * eta2.x, s * eta2.y));
    vec2 eta_cos_t = complex_mul(eta, cos_t);
    float rs = complex_abs2(vec2(c, 0.0) - eta_cos_t) / complex_abs2(vec2(c, 0.0) + eta_cos_t);
    vec2 eta_c = eta * c;
    float rp = complex_abs2(eta_c - cos_t) / complex_abs2(eta_c + cos_t);
    return 0.5 * (rs + rp);
}
vec3 fresnel_conductor(float cos_theta, vec3 n, vec3 k) {
    return vec3(fresnel_conductor(cos_theta, n.r, k.r),
                fresnel_conductor(cos_theta, n.g, k.g),
                fresnel_conductor(cos_theta, n.b, k.b));
}

// Normal-incidence reflectance ((n - 1)^2 + k^2) / ((n + 1)^2 + k^2).
float f0_from_ior(float n, float k) {
    float nm = n - 1.0, np = n + 1.0;
    return (nm * nm + k * k) / (np * np + k * k);
}
vec3 f0_from_ior(vec3 n, vec3 k) {
    vec3 nm = n - 1.0, np = n + 1.0;
    return (nm * nm + k * k) / (np * np + k * k);
}
float f0_from_ior(float n) { return f0_from_ior(n, 0.0); }

// Dielectric IOR with the given F0: n = (1 + sqrt F0) / (1 - sqrt F0).
float ior_from_f0(float f0) {
    float s = sqrt(clamp(f0, 0.0, 0.999999));
    return (1.0 + s) / (1.0 - s);
}

// Hemispherical average 2 int F(mu) mu dmu of Schlick = F0 + (1 - F0) / 21.
// (Written as a product with 1/21, the way XLA evaluates the division.)
float fresnel_schlick_average(float f0) { return f0 + (1.0 - f0) * (1.0 / 21.0); }
vec3 fresnel_schlick_average(vec3 f0) { return f0 + (1.0 - f0) * (1.0 / 21.0); }
