// Blender's Principled BSDF as Cycles draws it (mirrors brdf/cycles.py and brdf/principled.py;
// docs/models.md, docs/blender.md): Cycles' layering of a dielectric layer (one minus its
// estimate of the layer's albedo, F0 + (1 - F0) S(r, n.v, z)), its coat's energy preservation,
// its Oren-Nayar diffuse, its sheen, its Multiscatter GGX, and the Principled compositions built
// from them.
//
// The tables are brdf.cycles.dielectric_s_table() and ggx_albedo_tables(), uploaded by
// shaders.tables.table_texture() as R32F textures and read with texelFetch and Cycles'
// lookup_table_read weights, as brdf.cycles reads them:
//   brdf_cycles_s       S[z_k, mu_j, r_i] at texel (i, 16 k + j)     (16 x 256)
//   brdf_cycles_e       E[mu_j, r_i] at texel (i, j)                 (32 x 32)
//   brdf_cycles_e_avg   E_avg[r_i] at texel (i, 0)                   (32 x 1)
#include "common.glsl"
#include "geometry.glsl"
#include "specular.glsl"
#include "fresnel.glsl"
#include "openpbr.glsl"

uniform sampler2D brdf_cycles_s;
uniform sampler2D brdf_cycles_e;
uniform sampler2D brdf_cycles_e_avg;

const int CYCLES_TABLE_SIZE = 16;
const int CYCLES_ALBEDO_SIZE = 32;
const float CYCLES_LAMBERT_BELOW = 1e-5;

// lookup_table_read along one axis: the node below x (saturated), the next (clamped), the weight.
void cycles_node(float x, int size, out int i0, out int i1, out float t) {
    float u = clamp(x, 0.0, 1.0) * float(size - 1);
    i0 = min(int(floor(u)), size - 1);
    i1 = min(i0 + 1, size - 1);
    t = u - float(i0);
}

float cycles_s_plane(int k, int x0, int x1, float fx, int y0, int y1, float fy) {
    int row = k * CYCLES_TABLE_SIZE;
    float s00 = texelFetch(brdf_cycles_s, ivec2(x0, row + y0), 0).r;
    float s01 = texelFetch(brdf_cycles_s, ivec2(x1, row + y0), 0).r;
    float s10 = texelFetch(brdf_cycles_s, ivec2(x0, row + y1), 0).r;
    float s11 = texelFetch(brdf_cycles_s, ivec2(x1, row + y1), 0).r;
    return (1.0 - fy) * ((1.0 - fx) * s00 + fx * s01) + fy * ((1.0 - fx) * s10 + fx * s11);
}

// S(r, n.v, z): Cycles' ggx_gen_schlick_ior_s, read trilinearly (lookup_table_read_3D).
float cycles_dielectric_s(float roughness, float n_dot_v, float z) {
    int x0, x1, y0, y1, z0, z1;
    float fx, fy, fz;
    cycles_node(roughness, CYCLES_TABLE_SIZE, x0, x1, fx);
    cycles_node(n_dot_v, CYCLES_TABLE_SIZE, y0, y1, fy);
    cycles_node(z, CYCLES_TABLE_SIZE, z0, z1, fz);
    return (1.0 - fz) * cycles_s_plane(z0, x0, x1, fx, y0, y1, fy) + fz * cycles_s_plane(z1, x0, x1, fx, y0, y1, fy);
}

// Cycles' estimate of a dielectric layer's albedo at the view: F0 + (1 - F0) S.
float cycles_dielectric_albedo(float n_dot_v, float roughness, float ior) {
    float f0 = f0_from_ior(ior);
    float z = sqrt(max(abs((ior - 1.0) / (ior + 1.0)), 1e-12));
    return f0 + (1.0 - f0) * cycles_dielectric_s(roughness, n_dot_v, z);
}

// The specular layer over the diffuse: its lobe top + below x saturate(1 - albedo(n.v)).
vec3 cycles_dielectric_layer(float top, vec3 below, float n_dot_v, float roughness, float ior) {
    float through = clamp(1.0 - cycles_dielectric_albedo(n_dot_v, roughness, ior), 0.0, 1.0);
    return top + through * below;
}

// (E(r, n.v), E_avg(r)): Cycles' ggx_E read bilinearly and ggx_Eavg linearly.
vec2 cycles_ggx_albedo(float n_dot_v, float roughness) {
    int x0, x1, y0, y1;
    float fx, fy;
    cycles_node(roughness, CYCLES_ALBEDO_SIZE, x0, x1, fx);
    cycles_node(n_dot_v, CYCLES_ALBEDO_SIZE, y0, y1, fy);
    float e00 = texelFetch(brdf_cycles_e, ivec2(x0, y0), 0).r;
    float e01 = texelFetch(brdf_cycles_e, ivec2(x1, y0), 0).r;
    float e10 = texelFetch(brdf_cycles_e, ivec2(x0, y1), 0).r;
    float e11 = texelFetch(brdf_cycles_e, ivec2(x1, y1), 0).r;
    float e = (1.0 - fy) * ((1.0 - fx) * e00 + fx * e01) + fy * ((1.0 - fx) * e10 + fx * e11);
    float e_avg = (1.0 - fx) * texelFetch(brdf_cycles_e_avg, ivec2(x0, 0), 0).r
                  + fx * texelFetch(brdf_cycles_e_avg, ivec2(x1, 0), 0).r;
    return vec2(e, e_avg);
}

// fresnel_dielectric_Fss: the dielectric Fresnel's hemispherical average (Kulla and Conty's fit).
float cycles_dielectric_fss(float ior) { return (ior - 1.0) / (4.08567 + 1.00071 * ior); }

// fresnel_f82_Fss: the F82-tint Fresnel's average, F0 + (1 - F0) / 21 - b / 126.
vec3 cycles_f82_fss(vec3 f0, vec3 f82) {
    return f0 + (1.0 - f0) / 21.0 - f82_tint_b(f0, f82) / 126.0;
}

// 1 + F_ms (1 - E) / E from (E, E_avg) and the Fresnel's average.
float cycles_kept(vec2 e, float fss) {
    float f_ms = fss * e.y / (1.0 - fss * (1.0 - e.y));
    return 1.0 + f_ms * (1.0 - e.x) / e.x;
}

// microfacet_ggx_preserve_energy's factor on a GGX lobe of Fresnel average fss, per channel.
vec3 cycles_multiscatter(float n_dot_v, float roughness, vec3 fss) {
    vec2 e = cycles_ggx_albedo(n_dot_v, roughness);
    return vec3(cycles_kept(e, fss.r), cycles_kept(e, fss.g), cycles_kept(e, fss.b));
}

// A dielectric layer kept its energy over below: w C top + saturate(1 - w E C albedo(n.v)) below.
vec3 cycles_kept_layer(float top, vec3 below, float n_dot_v, float roughness, float ior, float weight, float fss) {
    vec2 e = cycles_ggx_albedo(n_dot_v, roughness);
    float kept = cycles_kept(e, fss);
    float through = clamp(1.0 - weight * e.x * kept * cycles_dielectric_albedo(n_dot_v, roughness, ior), 0.0, 1.0);
    return weight * kept * top + through * below;
}

// The coat (weight w, its lobe top = F D V) over below, kept energy as Cycles sets it up:
// w C top + below x saturate(1 - w E C albedo(n.v)), C = 1 + F_ms (1 - E) / E.
vec3 cycles_coat_layer(float top, vec3 below, float n_dot_v, float roughness, float ior, float weight) {
    return cycles_kept_layer(top, below, n_dot_v, roughness, ior, weight, cycles_dielectric_fss(ior));
}

// k - G(mu), k = pi / 2 - 2 / 3: Fujii's G (bsdf_oren_nayar_G) without its cancellation towards
// grazing, as brdf.cycles._fujii_missing writes it.
float cycles_fujii_missing(float mu) {
    mu = clamp(mu, 0.0, 1.0);
    float s = sqrt(1.0 - mu * mu);
    return (PI / 2.0 - 2.0 / 3.0) * mu * mu / (1.0 + s) + s * atan2_accurate(mu, s) + s * s * mu
           - 2.0 / 3.0 * s * mu * (1.0 + s + s * s) / (1.0 + s);
}

// Cycles' diffuse of Diffuse Roughness sigma (RGB, 1/sr, without the cosine); Lambert below 1e-5.
vec3 cycles_diffuse(vec3 base_color, float diffuse_roughness, float n_dot_l, float n_dot_v, float l_dot_v) {
    if (diffuse_roughness < CYCLES_LAMBERT_BELOW) {
        return base_color / PI;
    }
    float sigma = clamp(diffuse_roughness, 0.0, 1.0);
    float nl = max(n_dot_l, 0.0);
    float nv = max(n_dot_v, 0.0);
    float a = 1.0 / (PI + sigma * (PI / 2.0 - 2.0 / 3.0));
    float b = sigma * a;
    float t = l_dot_v - nl * nv;
    if (t > 0.0) {
        t = t / max(max(nl, nv), 1e-30);
    }
    // 1 - E(mu) = b (k - G(mu)), 1 - E_avg = b (k - c): brdf.cycles.cycles_diffuse's form
    float missing = b * (PI / 2.0 - 2.0 / 3.0 - (2.0 * PI - 5.6) / 3.0);
    vec3 albedo = clamp(base_color, 0.0, 1.0);
    vec3 e_ms = albedo * albedo / PI * ((1.0 - missing) / missing) / (1.0 - albedo * missing);
    float lost = b * b * cycles_fujii_missing(nv) * cycles_fujii_missing(nl);
    return base_color * ((a + b * t) + e_ms * lost);
}

// The Principled BSDF's dielectric base as Cycles draws it, from its specular D V; ms: with
// Multiscatter GGX (the lobe kept its energy as the coat's, F_ss within [F0, 1]).
vec3 cycles_nonmetal(float dv, float v_dot_h, float n_dot_l, float n_dot_v, float l_dot_v, float roughness,
                     vec3 base_color, float ior, float diffuse_roughness, bool ms) {
    float top = fresnel_dielectric(v_dot_h, ior) * dv;
    vec3 below = cycles_diffuse(base_color, diffuse_roughness, n_dot_l, n_dot_v, l_dot_v);
    if (!ms) {
        return cycles_dielectric_layer(top, below, n_dot_v, roughness, ior);
    }
    float fss = clamp(cycles_dielectric_fss(ior), f0_from_ior(ior), 1.0);
    return cycles_kept_layer(top, below, n_dot_v, roughness, ior, 1.0, fss);
}

// The sheen (weight w, tint t) over the BRDF below, Cycles' top layer (brdf.cycles.cycles_sheen_layer):
// w t E D / n.l + saturate(1 - max_c(w t_c E(n.v))) below, with E and D of MaterialX's fits of
// Zeltner's lobe (openpbr.glsl), where Cycles reads its own table of them.
vec3 cycles_sheen_layer(vec3 below, vec3 wi, vec3 wo, float weight, vec3 tint, float roughness) {
    float n_dot_v = clamp(wo.z, 1e-8, 1.0);
    float r = clamp(roughness, 0.01, 1.0);
    vec3 albedo = weight * max(zeltner_dir_albedo(n_dot_v, r), 0.0) * tint;
    float through = clamp(1.0 - max(albedo.r, max(albedo.g, albedo.b)), 0.0, 1.0);
    return albedo * zeltner_density(wi, wo, n_dot_v, r) + through * below;
}

// --- the Principled BSDF's models (RGB, 1/sr, without the cosine; wo the view direction) ---------

vec3 principled_nonmetal(vec3 wi, vec3 wo, vec3 base_color, float specular_ior, float roughness,
                         float diffuse_roughness) {
    vec3 h = half_vector(wi, wo);
    return cycles_nonmetal(openpbr_dv(wi, wo, h, roughness * roughness), dot3(wo, h), wi.z, wo.z, dot3(wi, wo),
                           roughness, base_color, specular_ior, diffuse_roughness, false);
}

vec3 principled_nonmetal_ms(vec3 wi, vec3 wo, vec3 base_color, float specular_ior, float roughness,
                            float diffuse_roughness) {
    vec3 h = half_vector(wi, wo);
    return cycles_nonmetal(openpbr_dv(wi, wo, h, roughness * roughness), dot3(wo, h), wi.z, wo.z, dot3(wi, wo),
                           roughness, base_color, specular_ior, diffuse_roughness, true);
}

// The metal's F82-tint lobe F D V times its multiscatter factor (Multiscatter GGX).
vec3 principled_metal_ms_lobe(vec3 fresnel, float dv, float n_dot_v, float roughness, vec3 base_color,
                              vec3 specular_color) {
    return fresnel * dv * cycles_multiscatter(n_dot_v, roughness, cycles_f82_fss(base_color, specular_color));
}

vec3 principled_metal_ms(vec3 wi, vec3 wo, vec3 base_color, vec3 specular_color, float roughness) {
    vec3 h = half_vector(wi, wo);
    return principled_metal_ms_lobe(fresnel_f82(base_color, specular_color, dot3(wo, h)),
                                    openpbr_dv(wi, wo, h, roughness * roughness), wo.z, roughness, base_color,
                                    specular_color);
}

vec3 principled_coat(vec3 base, vec3 wi, vec3 wo, vec3 h, float coat_weight, float coat_roughness, float coat_ior) {
    float top = fresnel_dielectric(dot3(wo, h), coat_ior) * openpbr_dv(wi, wo, h, coat_roughness * coat_roughness);
    return cycles_coat_layer(top, base, wo.z, coat_roughness, coat_ior, coat_weight);
}

vec3 principled_metal_coat(vec3 wi, vec3 wo, vec3 base_color, vec3 specular_color, float roughness,
                           float coat_weight, float coat_roughness, float coat_ior) {
    vec3 h = half_vector(wi, wo);
    float alpha = roughness * roughness;
    vec3 base = metal_lobe(fresnel_f82(base_color, specular_color, dot3(wo, h)), openpbr_dv(wi, wo, h, alpha), wo.z,
                           alpha, false);
    return principled_coat(base, wi, wo, h, coat_weight, coat_roughness, coat_ior);
}

vec3 principled_nonmetal_coat(vec3 wi, vec3 wo, vec3 base_color, float specular_ior, float roughness,
                              float diffuse_roughness, float coat_weight, float coat_roughness, float coat_ior) {
    vec3 base = principled_nonmetal(wi, wo, base_color, specular_ior, roughness, diffuse_roughness);
    return principled_coat(base, wi, wo, half_vector(wi, wo), coat_weight, coat_roughness, coat_ior);
}

vec3 principled_nonmetal_sheen(vec3 wi, vec3 wo, vec3 base_color, float specular_ior, float roughness,
                               float diffuse_roughness, float sheen_weight, vec3 sheen_tint, float sheen_roughness) {
    vec3 base = principled_nonmetal(wi, wo, base_color, specular_ior, roughness, diffuse_roughness);
    return cycles_sheen_layer(base, wi, wo, sheen_weight, sheen_tint, sheen_roughness);
}

// --- the compositions (brdf/principled.py): openpbr_material, as openpbr.glsl's are drawn by
// model.glsl; Cycles' roughness is sqrt(alpha) of the model's (clamped, floored) alpha.
#if defined(BRDF_PARAMS_DECLARED) && (defined(BRDF_COMPOSITION_PRINCIPLED_METAL_COAT) || \
                                      defined(BRDF_COMPOSITION_PRINCIPLED_NONMETAL_COAT))
vec3 principled_coated(BrdfParams p, vec3 wi, vec3 wo, vec3 base) {
    float r_c = clamp(p.coat_roughness, ROUGHNESS_MIN, 1.0);
    float alpha_c = max(r_c * r_c, ALPHA_MIN);
    vec3 h = half_vector(wi, wo);
    float top = fresnel_dielectric(dot3(wo, h), p.coat_ior) * openpbr_dv(wi, wo, h, alpha_c);
    return cycles_coat_layer(top, base, wo.z, sqrt(alpha_c), p.coat_ior, p.coat_weight);
}
#endif

#if defined(BRDF_PARAMS_DECLARED) && defined(BRDF_FIXED_NONMETAL)
// The dielectric base from the model's D V (brdf.principled._nonmetal_material); ms: Multiscatter GGX.
vec3 principled_base(BrdfParams p, vec3 wi, vec3 wo, float dv, float v_dot_h, float alpha, bool ms) {
    return cycles_nonmetal(dv, v_dot_h, wi.z, wo.z, dot3(wi, wo), sqrt(alpha), p.base_color, p.specular_ior,
                           p.base_diffuse_roughness, ms);
}
#endif

#if defined(BRDF_PARAMS_DECLARED) && defined(BRDF_COMPOSITION_PRINCIPLED_NONMETAL)
vec3 openpbr_material(BrdfParams p, vec3 wi, vec3 wo, float dv, float v_dot_h, float alpha) {
    return principled_base(p, wi, wo, dv, v_dot_h, alpha, false);
}
#elif defined(BRDF_PARAMS_DECLARED) && defined(BRDF_COMPOSITION_PRINCIPLED_METAL_COAT)
vec3 openpbr_material(BrdfParams p, vec3 wi, vec3 wo, float dv, float v_dot_h, float alpha) {
    return principled_coated(p, wi, wo, metal_lobe(fresnel_f82(p.base_color, p.specular_color, v_dot_h), dv, wo.z,
                                                   alpha, false));
}
#elif defined(BRDF_PARAMS_DECLARED) && defined(BRDF_COMPOSITION_PRINCIPLED_NONMETAL_COAT)
vec3 openpbr_material(BrdfParams p, vec3 wi, vec3 wo, float dv, float v_dot_h, float alpha) {
    return principled_coated(p, wi, wo, principled_base(p, wi, wo, dv, v_dot_h, alpha, false));
}
#elif defined(BRDF_PARAMS_DECLARED) && defined(BRDF_COMPOSITION_PRINCIPLED_METAL_MS)
vec3 openpbr_material(BrdfParams p, vec3 wi, vec3 wo, float dv, float v_dot_h, float alpha) {
    return principled_metal_ms_lobe(fresnel_f82(p.base_color, p.specular_color, v_dot_h), dv, wo.z, sqrt(alpha),
                                    p.base_color, p.specular_color);
}
#elif defined(BRDF_PARAMS_DECLARED) && defined(BRDF_COMPOSITION_PRINCIPLED_NONMETAL_MS)
vec3 openpbr_material(BrdfParams p, vec3 wi, vec3 wo, float dv, float v_dot_h, float alpha) {
    return principled_base(p, wi, wo, dv, v_dot_h, alpha, true);
}
#elif defined(BRDF_PARAMS_DECLARED) && defined(BRDF_COMPOSITION_PRINCIPLED_NONMETAL_SHEEN)
vec3 openpbr_material(BrdfParams p, vec3 wi, vec3 wo, float dv, float v_dot_h, float alpha) {
    return cycles_sheen_layer(principled_base(p, wi, wo, dv, v_dot_h, alpha, false), wi, wo, p.fuzz_weight,
                              p.fuzz_color, p.fuzz_roughness);
}
#endif
