// OpenPBR Surface's two bases (mirrors brdf/openpbr.py; issue 61).  Read in the
// MaterialX python package 1.39.5: libraries/bxdf/open_pbr_surface.mtlx (metal_bsdf:
// generalized_schlick_bsdf with color0 = base_color, color82 = specular_color,
// color90 = 1, exponent 5; dielectric_base: layer of dielectric_reflection over
// diffuse_bsdf), libraries/pbrlib/genglsl/mx_dielectric_bsdf.glsl, mx_layer_bsdf.glsl
// and lib/mx_microfacet_specular.glsl (mx_fresnel_hoffman_schlick,
// mx_fresnel_dielectric, mx_ggx_dir_albedo_analytic).
//
// The metal, Hoffman 2023 / Kutz et al. 2021:
//   S(mu) = F0 + (1 - F0)(1 - mu)^5
//   F(mu) = S(mu) - a mu (1 - mu)^6,   a = S(1/7)(1 - F82) / ((1/7)(6/7)^6)
//           clamped at 0 (a dark tint over a dark F0 dips below it between
//           mu = 1/7 and 6/7; MaterialX leaves it negative)
//   f     = F(v.h) D V                 (GGX, height-correlated Smith; no energy
//                                       compensation, unlike MaterialX's genglsl)
// The non-metal (MaterialX's layer: the base weighted by the top's throughput,
// 1 - its directional albedo at the view direction):
//   f     = F_dielectric(v.h, ior) D V + (1 - E(n.v)) eon(base_color, base_diffuse_roughness)
//   E(mu) = F0(ior) A(mu, alpha) + B(mu, alpha)    (MaterialX's analytic fit)
// The coat over either base (mirrors brdf/openpbr_coat.py; open_pbr_surface.mtlx's coat_bsdf,
// coat_layer, effective_specular_roughness, eta_s, base_darkening), coat weight w, IOR c:
//   f     = w F_dielectric(v.h, c) D_c V_c + (1 - w E_c(n.v)) Delta f_base'
//   Delta = mix(1, (1 - K) / (1 - base_color K), w),  K = 1 - (1 - F0(c)) / c^2
//   f_base' the base at roughness mix(r, min(1, 2 r_c^4 + r^4)^(1/4), w) and (non-metal)
//           IOR mix(s, s / c if s > c else c / s, w)
// MaterialX's reading (the option mx, brdf/openpbr_coat.py; genglsl's mx_ggx_energy_compensation,
// mx_generalized_schlick_bsdf.glsl, mx_dielectric_bsdf.glsl): each GGX lobe times
//   comp  = 1 + F (1 - Ess) / Ess,  Ess = ggx_dir_albedo(n.v, alpha, 1), F the lobe's Fresnel at v.h
// (per channel for the metal's F82) and each dielectric's throughput 1 - w E comp.
#include "specular.glsl"
#include "fresnel.glsl"
#include "diffuse.glsl"

// (1 - 1/7)^5 and 1 / ((1/7)(1 - 1/7)^6): brdf.openpbr.F82_SCHLICK_W, F82_FACTOR.
const float F82_SCHLICK_W = 0.46266436603796024;
const float F82_FACTOR = 17.651384602194792;

// Hoffman's F82-tint coefficient (brdf.openpbr.f82_tint_b): fresnel_f82's a, cycles_f82_fss's b.
vec3 f82_tint_b(vec3 f0, vec3 f82) { return (f0 + (1.0 - f0) * F82_SCHLICK_W) * (1.0 - f82) * F82_FACTOR; }

// Hoffman's F82-tint Fresnel with F90 = 1 and exponent 5.
vec3 fresnel_f82(vec3 f0, vec3 f82, float cos_theta) {
    float mu = clamp(cos_theta, 0.0, 1.0);
    float x = 1.0 - mu;
    float x2 = x * x;
    float x5 = x2 * x2 * x;
    vec3 schlick = f0 + (1.0 - f0) * x5;
    vec3 a = f82_tint_b(f0, f82);
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

// GGX's directional albedo F0 A + B (F90 = 1): MaterialX 1.39.5's
// mx_ggx_dir_albedo_analytic, its rational quadratic fit of (A, B) in x = n.v and
// y = alpha (brdf.openpbr.GGX_ALBEDO_FIT holds the same coefficients).
float ggx_dir_albedo(float n_dot_v, float alpha, float f0) {
    float x = clamp(n_dot_v, 0.0, 1.0);
    float y = alpha;
    float x2 = x * x;
    float y2 = y * y;
    vec4 r = vec4(0.1003, 0.9345, 1.0, 1.0) +
             vec4(-0.6303, -2.323, -1.765, 0.2281) * x +
             vec4(9.748, 2.229, 8.263, 15.94) * y +
             vec4(-2.038, -3.748, 11.53, -55.83) * x * y +
             vec4(29.34, 1.424, 28.96, 13.08) * x2 +
             vec4(-8.245, -0.7684, -7.507, 41.26) * y2 +
             vec4(-26.44, 1.436, -36.11, 54.9) * x2 * y +
             vec4(19.99, 0.2913, 15.86, 300.2) * x * y2 +
             vec4(-5.448, 0.6286, 33.37, -285.1) * x2 * y2;
    vec2 ab = clamp(r.xy / r.zw, 0.0, 1.0);
    return f0 * ab.x + ab.y;
}

// MaterialX 1.39.5's mx_ggx_energy_compensation (Turquin 2019, eq. 14 and 16), its order of operations.
float ggx_energy_compensation(float n_dot_v, float alpha, float f) {
    float ess = ggx_dir_albedo(n_dot_v, alpha, 1.0);
    return 1.0 + f * (1.0 - ess) / ess;
}

vec3 ggx_energy_compensation(float n_dot_v, float alpha, vec3 f) {
    float ess = ggx_dir_albedo(n_dot_v, alpha, 1.0);
    return 1.0 + f * (1.0 - ess) / ess;
}

// The metal's lobe F D V, with mx times MaterialX's comp (per channel of F).
vec3 metal_lobe(vec3 fresnel, float dv, float n_dot_v, float alpha, bool mx) {
    vec3 f = fresnel * dv;
    return mx ? f * ggx_energy_compensation(n_dot_v, alpha, fresnel) : f;
}

// OpenPBR's non-metal from its specular D V (the header's formula; mx: with MaterialX's comp).
vec3 nonmetal_layered(float dv, float v_dot_h, float n_dot_l, float n_dot_v, float l_dot_v, float alpha,
                      vec3 base_color, float specular_ior, float diffuse_roughness, bool mx) {
    float fresnel = fresnel_dielectric(v_dot_h, specular_ior);
    float albedo = ggx_dir_albedo(n_dot_v, alpha, f0_from_ior(specular_ior));
    float comp = mx ? ggx_energy_compensation(n_dot_v, alpha, fresnel) : 1.0;
    float specular = fresnel * dv * comp;
    float throughput = 1.0 - albedo * comp;
    vec3 diffuse = eon(base_color, diffuse_roughness, n_dot_l, n_dot_v, l_dot_v);
    return specular + throughput * diffuse;
}

vec3 nonmetal_combine(float dv, float v_dot_h, float n_dot_l, float n_dot_v, float l_dot_v, float alpha,
                      vec3 base_color, float specular_ior, float diffuse_roughness) {
    return nonmetal_layered(dv, v_dot_h, n_dot_l, n_dot_v, l_dot_v, alpha, base_color, specular_ior,
                            diffuse_roughness, false);
}

// OpenPBR's non-metal (RGB, 1/sr, without the cosine), GGX of alpha = roughness^2;
// wo is the view direction.
vec3 openpbr_nonmetal(vec3 wi, vec3 wo, vec3 base_color, float specular_ior, float roughness,
                      float diffuse_roughness) {
    float alpha = roughness * roughness;
    vec3 h = half_vector(wi, wo);
    float dv = ggx_ndf(h.z, alpha) * visibility_height_correlated(wi.z, wo.z, alpha);
    return nonmetal_combine(dv, dot3(wo, h), wi.z, wo.z, dot3(wi, wo), alpha, base_color, specular_ior,
                            diffuse_roughness);
}

// The base's roughness under the coat (the graph's effective_specular_roughness).
float coat_roughened(float roughness, float coat_roughness, float coat_weight) {
    float r2 = roughness * roughness;
    float c2 = coat_roughness * coat_roughness;
    float coated = sqrt(sqrt(min(2.0 * c2 * c2 + r2 * r2, 1.0)));
    return roughness * (1.0 - coat_weight) + coated * coat_weight;
}

// The non-metal's IOR under the coat (the graph's eta_s, its ratio inverted above 1).
float coated_ior(float specular_ior, float coat_ior, float coat_weight) {
    float ratio = specular_ior / coat_ior;
    float inverted = ratio > 1.0 ? ratio : coat_ior / specular_ior;
    return specular_ior * (1.0 - coat_weight) + inverted * coat_weight;
}

// The base's darkening under the coat (base_darkening at coat_darkening 1; E_base = base_color).
vec3 coat_darkening(vec3 base_color, float coat_ior, float coat_weight) {
    float k = 1.0 - (1.0 - f0_from_ior(coat_ior)) / (coat_ior * coat_ior);
    return (1.0 - coat_weight) + (1.0 - k) / (1.0 - base_color * k) * coat_weight;
}

// The coat (its D V) over a base already roughened: MaterialX's layer of a weighted dielectric
// (mx: its lobe and albedo times MaterialX's comp; darkens 0: no coat darkening).
vec3 coat_layered(vec3 base, vec3 base_color, float coat_dv, float v_dot_h, float n_dot_v, float coat_alpha,
                  float coat_weight, float coat_ior, bool mx, float darkens) {
    float fresnel = fresnel_dielectric(v_dot_h, coat_ior);
    float albedo = ggx_dir_albedo(n_dot_v, coat_alpha, f0_from_ior(coat_ior));
    float comp = mx ? ggx_energy_compensation(n_dot_v, coat_alpha, fresnel) : 1.0;
    float top = coat_weight * (fresnel * comp) * coat_dv;
    float throughput = 1.0 - coat_weight * (albedo * comp);
    return top + throughput * coat_darkening(base_color, coat_ior, coat_weight * darkens) * base;
}

vec3 coat_layer(vec3 base, vec3 base_color, float coat_dv, float v_dot_h, float n_dot_v, float coat_alpha,
                float coat_weight, float coat_ior) {
    return coat_layered(base, base_color, coat_dv, v_dot_h, n_dot_v, coat_alpha, coat_weight, coat_ior, false, 1.0);
}

float openpbr_dv(vec3 wi, vec3 wo, vec3 h, float alpha) {
    return ggx_ndf(h.z, alpha) * visibility_height_correlated(wi.z, wo.z, alpha);
}

// OpenPBR's coated metal (RGB, 1/sr, without the cosine); wo is the view direction; mx: with comp.
// A switch at 0 leaves that coat's effect on the base out.
vec3 openpbr_metal_coated(vec3 wi, vec3 wo, vec3 base_color, vec3 specular_color, float roughness,
                          float coat_weight, float coat_roughness, float coat_ior, bool mx, float roughens,
                          float darkens) {
    vec3 h = half_vector(wi, wo);
    float v_dot_h = dot3(wo, h);
    float r = coat_roughened(roughness, coat_roughness, coat_weight * roughens);
    vec3 base = metal_lobe(fresnel_f82(base_color, specular_color, v_dot_h), openpbr_dv(wi, wo, h, r * r), wo.z,
                           r * r, mx);
    float alpha_c = coat_roughness * coat_roughness;
    return coat_layered(base, base_color, openpbr_dv(wi, wo, h, alpha_c), v_dot_h, wo.z, alpha_c, coat_weight,
                        coat_ior, mx, darkens);
}

vec3 openpbr_metal_coat(vec3 wi, vec3 wo, vec3 base_color, vec3 specular_color, float roughness,
                        float coat_weight, float coat_roughness, float coat_ior) {
    return openpbr_metal_coated(wi, wo, base_color, specular_color, roughness, coat_weight, coat_roughness, coat_ior,
                                false, 1.0, 1.0);
}

// OpenPBR's coated non-metal (RGB, 1/sr, without the cosine); wo is the view direction; mx: with comp.
// A switch at 0 leaves that coat's effect on the base out.
vec3 openpbr_nonmetal_coated(vec3 wi, vec3 wo, vec3 base_color, float specular_ior, float roughness,
                             float diffuse_roughness, float coat_weight, float coat_roughness, float coat_ior,
                             bool mx, float roughens, float darkens, float inverts_ior) {
    vec3 h = half_vector(wi, wo);
    float v_dot_h = dot3(wo, h);
    float r = coat_roughened(roughness, coat_roughness, coat_weight * roughens);
    float alpha = r * r;
    vec3 base = nonmetal_layered(openpbr_dv(wi, wo, h, alpha), v_dot_h, wi.z, wo.z, dot3(wi, wo), alpha, base_color,
                                 coated_ior(specular_ior, coat_ior, coat_weight * inverts_ior), diffuse_roughness, mx);
    float alpha_c = coat_roughness * coat_roughness;
    return coat_layered(base, base_color, openpbr_dv(wi, wo, h, alpha_c), v_dot_h, wo.z, alpha_c, coat_weight,
                        coat_ior, mx, darkens);
}

vec3 openpbr_nonmetal_coat(vec3 wi, vec3 wo, vec3 base_color, float specular_ior, float roughness,
                           float diffuse_roughness, float coat_weight, float coat_roughness, float coat_ior) {
    return openpbr_nonmetal_coated(wi, wo, base_color, specular_ior, roughness, diffuse_roughness, coat_weight,
                                   coat_roughness, coat_ior, false, 1.0, 1.0, 1.0);
}

// The bare bases in MaterialX's reading (RGB, 1/sr, without the cosine; wo the view direction).
vec3 openpbr_metal_mx(vec3 wi, vec3 wo, vec3 base_color, vec3 specular_color, float roughness) {
    float alpha = roughness * roughness;
    vec3 h = half_vector(wi, wo);
    return metal_lobe(fresnel_f82(base_color, specular_color, dot3(wo, h)), openpbr_dv(wi, wo, h, alpha), wo.z,
                      alpha, true);
}

vec3 openpbr_nonmetal_mx(vec3 wi, vec3 wo, vec3 base_color, float specular_ior, float roughness,
                         float diffuse_roughness) {
    float alpha = roughness * roughness;
    vec3 h = half_vector(wi, wo);
    return nonmetal_layered(openpbr_dv(wi, wo, h, alpha), dot3(wo, h), wi.z, wo.z, dot3(wi, wo), alpha, base_color,
                            specular_ior, diffuse_roughness, true);
}

// The fuzz over the non-metal (mirrors brdf/openpbr_fuzz.py; open_pbr_surface.mtlx's fuzz_bsdf,
// a sheen_bsdf of mode zeltner, and fuzz_layer; genglsl's mx_sheen_bsdf.glsl and
// lib/mx_microfacet_sheen.glsl): Zeltner et al. 2022's LTC sheen, fuzz weight w, colour c,
//   f = w c E(n.v) a^2 / (pi |M^-1 w_l|^4) + (1 - w E(n.v)) f_nonmetal
// (E clamped at 0: MaterialX's fit dips to -2e-5 at low roughness and leaves it there).
float zeltner_dir_albedo(float x, float y) {
    float s = y * (0.0206607 + 1.58491 * y) / (0.0379424 + y * (1.32227 + y));
    float m = y * (-0.193854 + y * (-1.14885 + y * (1.7932 - 0.95943 * y * y))) / (0.046391 + y);
    float o = y * (0.000654023 + (-0.0207818 + 0.119681 * y) * y) / (1.26264 + y * (-1.92021 + y));
    float t = (x - m) / s;
    return exp(-0.5 * (t * t)) / (s * 2.5066282746310002) + o;
}

// (a, b) of the inverse LTC matrix: mx_zeltner_sheen_ltc_aInv, _bInv.
vec2 zeltner_ltc(float x, float y) {
    float a = (2.58126 * x + 0.813703 * y) * y / (1.0 + 0.310327 * x * x + 2.60994 * x * y);
    float b = sqrt(1.0 - x) * (y - 1.0) * y * y * y / (0.0000254053 + 1.71228 * x - 1.71506 * x * y + 1.34174 * y * y);
    return vec2(a, b);
}

// D(l) / n.l of the LTC lobe in the frame of the view's projection (x along +x where the view is the normal).
float zeltner_density(vec3 wi, vec3 wo, float n_dot_v, float roughness) {
    float across = wo.x * wo.x + wo.y * wo.y;
    float inv = across > 0.0 ? 1.0 / sqrt(across) : 0.0;
    float xx = across > 0.0 ? wo.x * inv : 1.0;
    float xy = wo.y * inv;
    precise float wx = xx * wi.x + xy * wi.y;
    precise float wy = xx * wi.y - xy * wi.x;
    vec2 ab = zeltner_ltc(n_dot_v, roughness);
    precise float tx = ab.x * wx + ab.y * wi.z;
    float ty = ab.x * wy;
    float length2 = tx * tx + ty * ty + wi.z * wi.z;
    float q = ab.x / length2;
    return wi.z > 0.0 ? q * q * INV_PI : 0.0;
}

// The fuzz over the BRDF below it.
vec3 fuzz_layer(vec3 below, vec3 wi, vec3 wo, float fuzz_weight, vec3 fuzz_color, float fuzz_roughness) {
    float n_dot_v = clamp(wo.z, 1e-8, 1.0);
    float r = clamp(fuzz_roughness, 0.01, 1.0);
    float albedo = fuzz_weight * max(zeltner_dir_albedo(n_dot_v, r), 0.0);
    vec3 top = (albedo * zeltner_density(wi, wo, n_dot_v, r)) * fuzz_color;
    return top + (1.0 - albedo) * below;
}

// OpenPBR's non-metal under its fuzz (RGB, 1/sr, without the cosine; wo the view direction).
vec3 openpbr_nonmetal_fuzz(vec3 wi, vec3 wo, vec3 base_color, float specular_ior, float roughness,
                           float diffuse_roughness, float fuzz_weight, vec3 fuzz_color, float fuzz_roughness) {
    vec3 below = openpbr_nonmetal(wi, wo, base_color, specular_ior, roughness, diffuse_roughness);
    return fuzz_layer(below, wi, wo, fuzz_weight, fuzz_color, fuzz_roughness);
}

// --- the spec's OpenPBR materials -------------------------------------------------
// The openpbr compositions (BRDF_COMPOSITION_OPENPBR: the metal, _OPENPBR_NONMETAL:
// the non-metal) fix their Fresnel and diffuse: each defines here what fresnel.glsl
// defines for the other compositions (the metal's diffuse lobe is diffuse.glsl's
// "none"; the non-metal defines its own, as gltf.glsl does):
//   vec3 openpbr_material(BrdfParams p, vec3 wi, vec3 wo, float dv, float v_dot_h, float alpha)
//       the BRDF (model.glsl)
//   fresnel_f0(p), fresnel_f90(p), composition_diffuse_weight: under image lighting the
//       split sum's Schlick stands for each Fresnel (the metal's F82 dip near grazing
//       is not drawn there), the non-metal's diffuse is Lambert's of base_color weighted
//       by 1 - the specular albedo (EON's shape is not drawn there)
// The coated compositions (_OPENPBR_METAL_COAT, _OPENPBR_NONMETAL_COAT) draw the base as it
// is bare under image lighting (not roughened, not darkened) and the coat as clearcoat.glsl's
// layer is drawn there (clearcoat_weight, clearcoat_ibl_roughness: Schlick of IOR 1.5 mixed
// over the base), which is not the coat's exact Fresnel of coat_ior nor its layering.
// MaterialX's reading (the compositions openpbr_*_mx) is its twin's block with OPENPBR_MX: the
// same under image lighting (without the compensation there).  The fuzz (_OPENPBR_NONMETAL_FUZZ)
// is drawn there as gltf.glsl's sheen is (sheen_ibl_color = fuzz_weight fuzz_color: Charlie's
// albedo, 1 - max3 of it over the base), not Zeltner's, and so is the Principled BSDF's sheen.
// The Principled BSDF's compositions (_PRINCIPLED_NONMETAL, _PRINCIPLED_METAL_COAT,
// _PRINCIPLED_NONMETAL_COAT, _PRINCIPLED_NONMETAL_SHEEN) define their
// openpbr_material in principled.glsl (Cycles' layering) and are drawn here under image
// lighting as OpenPBR's non-metal and coats are.
#if defined(BRDF_COMPOSITION_OPENPBR_METAL_MX)
#define BRDF_COMPOSITION_OPENPBR 1
#define OPENPBR_MX 1
#elif defined(BRDF_COMPOSITION_OPENPBR_NONMETAL_MX)
#define BRDF_COMPOSITION_OPENPBR_NONMETAL 1
#define OPENPBR_MX 1
#elif defined(BRDF_COMPOSITION_OPENPBR_METAL_COAT_MX)
#define BRDF_COMPOSITION_OPENPBR_METAL_COAT 1
#define OPENPBR_MX 1
#elif defined(BRDF_COMPOSITION_OPENPBR_NONMETAL_COAT_MX)
#define BRDF_COMPOSITION_OPENPBR_NONMETAL_COAT 1
#define OPENPBR_MX 1
#elif defined(BRDF_COMPOSITION_OPENPBR_NONMETAL_FUZZ_MX)
#define BRDF_COMPOSITION_OPENPBR_NONMETAL_FUZZ 1
#define OPENPBR_MX 1
#endif
#ifdef OPENPBR_MX
const bool OPENPBR_MX_ON = true;
#else
const bool OPENPBR_MX_ON = false;
#endif
#if defined(BRDF_COMPOSITION_OPENPBR_METAL_COAT) || defined(BRDF_COMPOSITION_OPENPBR_NONMETAL_COAT)
#define COAT_ON_BASE 1.0
#endif

// A coated composition's alphas (base, coat): the roughnesses clamped to [ROUGHNESS_MIN, 1],
// the base's roughened, each alpha floored at ALPHA_MIN, as brdf.openpbr_coat._coated
// (the model's dv and alpha, of the bare base, are not used).
vec2 coated_alphas(float roughness, float coat_roughness, float coat_weight) {
    float r_c = clamp(coat_roughness, ROUGHNESS_MIN, 1.0);
    float r = coat_roughened(clamp(roughness, ROUGHNESS_MIN, 1.0), r_c, coat_weight);
    return vec2(max(r * r, ALPHA_MIN), max(r_c * r_c, ALPHA_MIN));
}

#if defined(BRDF_PARAMS_DECLARED) && defined(BRDF_COMPOSITION_OPENPBR)
vec3 openpbr_material(BrdfParams p, vec3 wi, vec3 wo, float dv, float v_dot_h, float alpha) {
    return metal_lobe(fresnel_f82(p.base_color, p.specular_color, v_dot_h), dv, wo.z, alpha, OPENPBR_MX_ON);
}
#elif defined(BRDF_PARAMS_DECLARED) && defined(BRDF_COMPOSITION_OPENPBR_NONMETAL)
vec3 openpbr_material(BrdfParams p, vec3 wi, vec3 wo, float dv, float v_dot_h, float alpha) {
    return nonmetal_layered(dv, v_dot_h, wi.z, wo.z, dot3(wi, wo), alpha, p.base_color, p.specular_ior,
                            p.base_diffuse_roughness, OPENPBR_MX_ON);
}
#elif defined(BRDF_PARAMS_DECLARED) && defined(BRDF_COMPOSITION_OPENPBR_NONMETAL_FUZZ)
vec3 openpbr_material(BrdfParams p, vec3 wi, vec3 wo, float dv, float v_dot_h, float alpha) {
    vec3 below = nonmetal_layered(dv, v_dot_h, wi.z, wo.z, dot3(wi, wo), alpha, p.base_color, p.specular_ior,
                                  p.base_diffuse_roughness, OPENPBR_MX_ON);
    return fuzz_layer(below, wi, wo, p.fuzz_weight, p.fuzz_color, p.fuzz_roughness);
}
#elif defined(BRDF_PARAMS_DECLARED) && defined(BRDF_COMPOSITION_OPENPBR_METAL_COAT)
vec3 openpbr_material(BrdfParams p, vec3 wi, vec3 wo, float dv, float v_dot_h, float alpha) {
    vec2 a = coated_alphas(p.roughness, p.coat_roughness, p.coat_weight * COAT_ON_BASE);
    vec3 h = half_vector(wi, wo);
    vec3 base = metal_lobe(fresnel_f82(p.base_color, p.specular_color, v_dot_h), openpbr_dv(wi, wo, h, a.x), wo.z, a.x,
                           OPENPBR_MX_ON);
    return coat_layered(base, p.base_color, openpbr_dv(wi, wo, h, a.y), v_dot_h, wo.z, a.y, p.coat_weight, p.coat_ior,
                        OPENPBR_MX_ON, COAT_ON_BASE);
}
#elif defined(BRDF_PARAMS_DECLARED) && defined(BRDF_COMPOSITION_OPENPBR_NONMETAL_COAT)
vec3 openpbr_material(BrdfParams p, vec3 wi, vec3 wo, float dv, float v_dot_h, float alpha) {
    vec2 a = coated_alphas(p.roughness, p.coat_roughness, p.coat_weight * COAT_ON_BASE);
    vec3 h = half_vector(wi, wo);
    float eta = coated_ior(p.specular_ior, p.coat_ior, p.coat_weight * COAT_ON_BASE);
    vec3 base = nonmetal_layered(openpbr_dv(wi, wo, h, a.x), v_dot_h, wi.z, wo.z, dot3(wi, wo), a.x, p.base_color,
                                 eta, p.base_diffuse_roughness, OPENPBR_MX_ON);
    return coat_layered(base, p.base_color, openpbr_dv(wi, wo, h, a.y), v_dot_h, wo.z, a.y, p.coat_weight, p.coat_ior,
                        OPENPBR_MX_ON, COAT_ON_BASE);
}
#endif

// Under image lighting: the metals, bare or coated
#if defined(BRDF_PARAMS_DECLARED) && defined(BRDF_FIXED_LOBES) && !defined(BRDF_FIXED_NONMETAL)
vec3 fresnel_f0(BrdfParams p) { return p.base_color; }
vec3 fresnel_f90(BrdfParams p) { return vec3(1.0); }
vec3 composition_diffuse_weight(vec3 specular_albedo) { return vec3(1.0); }   // (no diffuse lobe)
#endif

// the non-metals, bare or coated
#if defined(BRDF_PARAMS_DECLARED) && defined(BRDF_FIXED_NONMETAL)
vec3 fresnel_f0(BrdfParams p) { return vec3(f0_from_ior(p.specular_ior)); }
vec3 fresnel_f90(BrdfParams p) { return vec3(1.0); }
vec3 diffuse_albedo(BrdfParams p) { return p.base_color; }
float diffuse_ibl_shape(BrdfParams p) { return 0.0; }
DiffuseMoments diffuse_ibl_moments(float n_dot_v, float x) { return lambert_moments(); }
vec3 composition_diffuse_weight(vec3 specular_albedo) { return 1.0 - specular_albedo; }
#endif

// the coat, as clearcoat.glsl's layer is drawn there
#if defined(BRDF_PARAMS_DECLARED) && defined(BRDF_FIXED_COAT)
float clearcoat_weight(BrdfParams p) { return p.coat_weight; }
float clearcoat_ibl_roughness(BrdfParams p) { return clamp(p.coat_roughness, ROUGHNESS_MIN, 1.0); }
#endif
