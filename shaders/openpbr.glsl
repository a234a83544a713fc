// OpenPBR Surface's metal with its F82 edge tint (mirrors brdf/openpbr.py; the
// first slice of issue 61).  Read in the MaterialX python package 1.39.5:
// libraries/bxdf/open_pbr_surface.mtlx (metal_bsdf: generalized_schlick_bsdf with
// color0 = base_color, color82 = specular_color, color90 = 1, exponent 5) and
// libraries/pbrlib/genglsl/lib/mx_microfacet_specular.glsl (mx_fresnel_hoffman_schlick).
// Hoffman 2023 / Kutz et al. 2021:
//
//   S(mu) = F0 + (1 - F0)(1 - mu)^5
//   F(mu) = S(mu) - a mu (1 - mu)^6,   a = S(1/7)(1 - F82) / ((1/7)(6/7)^6)
//           clamped at 0 (a dark tint over a dark F0 dips below it between
//           mu = 1/7 and 6/7; MaterialX leaves it negative)
//   f     = F(v.h) D V                 (GGX, height-correlated Smith; no energy
//                                       compensation, unlike MaterialX's genglsl)
#include "specular.glsl"

// (1 - 1/7)^5 and 1 / ((1/7)(1 - 1/7)^6): brdf.openpbr.F82_SCHLICK_W, F82_FACTOR.
const float F82_SCHLICK_W = 0.46266436603796024;
const float F82_FACTOR = 17.651384602194792;

// Hoffman's F82-tint Fresnel with F90 = 1 and exponent 5.
vec3 fresnel_f82(vec3 f0, vec3 f82, float cos_theta) {
    float mu = clamp(cos_theta, 0.0, 1.0);
    float x = 1.0 - mu;
    float x2 = x * x;
    float x5 = x2 * x2 * x;
    vec3 schlick = f0 + (1.0 - f0) * x5;
    vec3 schlick_82 = f0 + (1.0 - f0) * F82_SCHLICK_W;
    vec3 a = schlick_82 * (1.0 - f82) * F82_FACTOR;
    // precise: the difference cancels where F is near 0 (a dark tint near mu = 1/7):
    // no fused multiply-add, so it rounds as brdf.openpbr.fresnel_f82 (float32)
    precise vec3 correction = a * mu * (x5 * x);
    precise vec3 f = schlick - correction;
    return max(f, vec3(0.0));
}

// OpenPBR's metal (RGB, 1/sr, without the cosine), GGX of alpha = roughness^2.
vec3 openpbr_metal(vec3 wi, vec3 wo, vec3 base_color, vec3 specular_color, float roughness) {
    float alpha = roughness * roughness;
    vec3 h = half_vector(wi, wo);
    float dv = ggx_ndf(h.z, alpha) * visibility_height_correlated(wi.z, wo.z, alpha);
    return fresnel_f82(base_color, specular_color, dot3(wo, h)) * dv;
}

// --- the spec's OpenPBR material --------------------------------------------------
// The openpbr composition (BRDF_COMPOSITION_OPENPBR) fixes its Fresnel: it defines
// here what fresnel.glsl defines for the other compositions (its diffuse lobe is
// diffuse.glsl's "none").
//   vec3 openpbr_material(BrdfParams p, float dv, float v_dot_h)   the BRDF (model.glsl)
//   fresnel_f0(p) = base_color, fresnel_f90(p) = 1: under image lighting the split
//       sum's Schlick stands for it (the F82 dip near grazing is not drawn there)
#if defined(BRDF_PARAMS_DECLARED) && defined(BRDF_COMPOSITION_OPENPBR)

vec3 openpbr_material(BrdfParams p, float dv, float v_dot_h) {
    return fresnel_f82(p.base_color, p.specular_color, v_dot_h) * dv;
}
vec3 fresnel_f0(BrdfParams p) { return p.base_color; }
vec3 fresnel_f90(BrdfParams p) { return vec3(1.0); }
vec3 composition_diffuse_weight(vec3 specular_albedo) { return vec3(1.0); }   // (no diffuse lobe)

#endif  // BRDF_PARAMS_DECLARED && BRDF_COMPOSITION_OPENPBR
