// Multiple-scattering energy compensation for the GGX lobe (mirrors
// brdf/energy.py; docs/models.md).
//
// - Kulla & Conty 2017, "Revisiting physically based shading at Imageworks":
//   f_ms = (1 - E(mu_o))(1 - E(mu_i)) / (pi (1 - E_avg)) times the Fresnel
//   factor F_avg^2 E_avg / (1 - F_avg (1 - E_avg)).
// - Turquin 2019, "Practical multiple scattering compensation for microfacet
//   models": f = f_ss (1 + F0 (1 - E) / E).
// - Under image lighting (the split sum, ibl.glsl): Fdez-Aguera 2019, "A
//   multiple-scattering microfacet model for real-time image-based lighting"
//   (docs/models.md) for Kulla-Conty, Turquin's factor with E = A + B.
//
// E(mu, alpha = r^2) and E_avg(alpha) are brdf.energy.tables(), uploaded by
// shaders.tables.table_texture() as R32F textures (E: width = roughness
// nodes, height = mu nodes; E_avg: width = roughness nodes, height 1) and read
// with texelFetch and the same bilinear weights as brdf.energy.lookup_e, so
// the GPU sees the very numbers JAX interpolates.
#include "common.glsl"
#include "fresnel.glsl"

uniform sampler2D brdf_energy_e;       // E[mu_j, r_k] at texel (k, j)
uniform sampler2D brdf_energy_e_avg;   // E_avg[r_k] at texel (k, 0)

// The roughness axis of the tables runs from ROUGHNESS_MIN to 1.
const float ENERGY_ROUGHNESS_SPAN = 0.968377223398316207;   // 1 - ROUGHNESS_MIN

// Divisions by a constant are written as products with its reciprocal: XLA
// rewrites x / c into x * (1 / c), and the ulp this moves matters here.

// Fractional index of u on a uniform grid of `size` nodes (u already scaled
// to [0, size - 1]) and its integer floor, as brdf.energy._interp_coord.
void energy_interp_coord(float u_scaled, int size, out int i0, out float frac) {
    float u = clamp(u_scaled, 0.0, float(size) - 1.0);
    i0 = clamp(int(floor(u)), 0, size - 2);
    frac = u - float(i0);
}

// E(mu, alpha = r^2), bilinear in (mu, r).
float lookup_e(float mu, float roughness) {
    ivec2 size = textureSize(brdf_energy_e, 0);
    int i, k;
    float fi, fk;
    energy_interp_coord(mu * float(size.y - 1), size.y, i, fi);
    energy_interp_coord((roughness - ROUGHNESS_MIN) * (1.0 / ENERGY_ROUGHNESS_SPAN) * float(size.x - 1),
                        size.x, k, fk);
    float e00 = texelFetch(brdf_energy_e, ivec2(k, i), 0).r;
    float e01 = texelFetch(brdf_energy_e, ivec2(k + 1, i), 0).r;
    float e10 = texelFetch(brdf_energy_e, ivec2(k, i + 1), 0).r;
    float e11 = texelFetch(brdf_energy_e, ivec2(k + 1, i + 1), 0).r;
    // precise: no fused multiply-adds, so the weights round as in JAX (1 - E is
    // tiny for smooth surfaces and amplifies every ulp).
    precise float e0 = (1.0 - fk) * e00 + fk * e01;
    precise float e1 = (1.0 - fk) * e10 + fk * e11;
    precise float e = (1.0 - fi) * e0 + fi * e1;
    return e;
}

// E_avg(alpha = r^2), linear in r.
float lookup_e_avg(float roughness) {
    int size = textureSize(brdf_energy_e_avg, 0).x;
    int k;
    float fk;
    energy_interp_coord((roughness - ROUGHNESS_MIN) * (1.0 / ENERGY_ROUGHNESS_SPAN) * float(size - 1),
                        size, k, fk);
    precise float e = (1.0 - fk) * texelFetch(brdf_energy_e_avg, ivec2(k, 0), 0).r
                      + fk * texelFetch(brdf_energy_e_avg, ivec2(k + 1, 0), 0).r;
    return e;
}

// F_avg^2 E_avg / (1 - F_avg (1 - E_avg)): the colour of the extra bounces.
float kulla_conty_fresnel_factor(float f_avg, float e_avg) {
    return f_avg * f_avg * e_avg / (1.0 - f_avg * (1.0 - e_avg));
}
vec3 kulla_conty_fresnel_factor(vec3 f_avg, float e_avg) {
    return f_avg * f_avg * e_avg / (1.0 - f_avg * (1.0 - e_avg));
}

// The uncoloured multiple-scattering lobe (1 - E(mu_o))(1 - E(mu_i)) / (pi (1 - E_avg)).
float kulla_conty_lobe(float n_dot_l, float n_dot_v, float roughness, out float e_avg) {
    float e_i = lookup_e(clamp(n_dot_l, 0.0, 1.0), roughness);
    float e_o = lookup_e(clamp(n_dot_v, 0.0, 1.0), roughness);
    e_avg = lookup_e_avg(roughness);
    return (1.0 - e_i) * (1.0 - e_o) / (PI * (1.0 - e_avg));
}
float kulla_conty_lobe(float n_dot_l, float n_dot_v, float roughness) {
    float e_avg;
    return kulla_conty_lobe(n_dot_l, n_dot_v, roughness, e_avg);
}

// Kulla-Conty multiple-scattering lobe (1/sr), to add to D V F; `f_avg` is
// the hemispherical average Fresnel (1 for F = 1).
float kulla_conty(float n_dot_l, float n_dot_v, float roughness, float f_avg) {
    float e_avg;
    float f_ms = kulla_conty_lobe(n_dot_l, n_dot_v, roughness, e_avg);
    return f_ms * kulla_conty_fresnel_factor(f_avg, e_avg);
}
vec3 kulla_conty(float n_dot_l, float n_dot_v, float roughness, vec3 f_avg) {
    float e_avg;
    float f_ms = kulla_conty_lobe(n_dot_l, n_dot_v, roughness, e_avg);
    return f_ms * kulla_conty_fresnel_factor(f_avg, e_avg);
}
float kulla_conty(float n_dot_l, float n_dot_v, float roughness) {
    return kulla_conty(n_dot_l, n_dot_v, roughness, 1.0);
}

// Turquin 2019: 1 + F0 (1 - E(mu_o)) / E(mu_o), multiplying the specular lobe.
float turquin_factor(float n_dot_v, float roughness, float f0) {
    float e = lookup_e(clamp(n_dot_v, 0.0, 1.0), roughness);
    return 1.0 + f0 * (1.0 - e) / e;
}
vec3 turquin_factor(float n_dot_v, float roughness, vec3 f0) {
    float e = lookup_e(clamp(n_dot_v, 0.0, 1.0), roughness);
    return 1.0 + f0 * (1.0 - e) / e;
}

// --- the spec's energy compensation ---------------------------------------------
// One block per value of ModelSpec.energy (BRDF_ENERGY_<VALUE>, generated by
// shaders.library.defines_for), each defining
//   vec3 energy_compensate(vec3 f_ss, float n_dot_l, float n_dot_v, float roughness, vec3 f0)
//       the single-scattering lobe D V F with the energy it misses (model.glsl);
//   void energy_ibl(vec2 dfg, vec3 f0, vec3 irradiance, inout vec3 radiance, inout vec3 albedo)
//       the same in the split sum (ibl.glsl): dfg = (A, B) at (n.v, r), radiance
//       and albedo the specular F_ss E_ss terms on entry, irradiance E / pi;
//   vec3 energy_specular_factor(float n_dot_v, float roughness, vec3 f0)
//       what multiplies the glTF composition's specular lobe (gltf.glsl: its engines'
//       reading, +turquin; 1 otherwise).
#ifdef BRDF_PARAMS_DECLARED

#if defined(BRDF_ENERGY_NONE)
vec3 energy_compensate(vec3 f_ss, float n_dot_l, float n_dot_v, float roughness, vec3 f0) {
    return f_ss;
}
vec3 energy_specular_factor(float n_dot_v, float roughness, vec3 f0) { return vec3(1.0); }
void energy_ibl(vec2 dfg, vec3 f0, vec3 irradiance, inout vec3 radiance, inout vec3 albedo) {}

#elif defined(BRDF_ENERGY_KULLA_CONTY)
// Kulla & Conty 2017: f = f_ss + f_ms (F_avg of Schlick with the spec's F0).
vec3 energy_compensate(vec3 f_ss, float n_dot_l, float n_dot_v, float roughness, vec3 f0) {
    return f_ss + kulla_conty(n_dot_l, n_dot_v, roughness, fresnel_schlick_average(f0));
}
vec3 energy_specular_factor(float n_dot_v, float roughness, vec3 f0) { return vec3(1.0); }   // (not glTF's)
// Fdez-Aguera 2019: E_ss = A + B, E_ms = 1 - E_ss, F_avg = F0 + (1 - F0)/21,
// F_ms E_ms = F_ss E_ss F_avg E_ms / (1 - E_ms F_avg), lit by the irradiance.
void energy_ibl(vec2 dfg, vec3 f0, vec3 irradiance, inout vec3 radiance, inout vec3 albedo) {
    float e_ss = dfg.x + dfg.y;
    float e_ms = 1.0 - e_ss;
    vec3 f_avg = fresnel_schlick_average(f0);
    vec3 fms_ems = albedo * f_avg * e_ms / (1.0 - e_ms * f_avg);
    radiance += fms_ems * irradiance;
    albedo += fms_ems;
}

#elif defined(BRDF_ENERGY_TURQUIN)
// Turquin 2019: f = f_ss (1 + F0 (1 - E(n.v)) / E(n.v)).
vec3 energy_compensate(vec3 f_ss, float n_dot_l, float n_dot_v, float roughness, vec3 f0) {
    return f_ss * turquin_factor(n_dot_v, roughness, f0);
}
vec3 energy_specular_factor(float n_dot_v, float roughness, vec3 f0) {
    return turquin_factor(n_dot_v, roughness, f0);
}
// The same factor with E = A + B.
void energy_ibl(vec2 dfg, vec3 f0, vec3 irradiance, inout vec3 radiance, inout vec3 albedo) {
    float e_ss = dfg.x + dfg.y;
    vec3 factor = 1.0 + f0 * (1.0 - e_ss) / e_ss;
    radiance *= factor;
    albedo *= factor;
}

#else
#error "energy.glsl has no block for the spec's energy compensation (BRDF_ENERGY_*)"
#endif

#endif  // BRDF_PARAMS_DECLARED
