// Microfacet specular terms: the GGX / Trowbridge-Reitz NDF and Smith masking
// (mirrors brdf/specular.py; docs/models.md).
//
// Sources: Trowbridge & Reitz 1975; Walter et al. 2007 (GGX); Heitz 2014,
// "Understanding the masking-shadowing function in microfacet-based BRDFs"
// (Smith Lambda, height-correlated form, anisotropic extension); Karis 2013
// (UE4 Schlick-GGX); Kulla & Conty 2017 (anisotropy remap); glTF
// KHR_materials_anisotropy.
//
// Every function takes alpha = roughness^2 (not the perceptual roughness) and
// floors it at ALPHA_MIN.  Anisotropic functions take vectors in the tangent
// frame (t.v, b.v, n.v).
#include "geometry.glsl"

float alpha_floor(float alpha) { return max(alpha, ALPHA_MIN); }

// --- normal distribution ----------------------------------------------------

// Isotropic GGX: D = a^2 / (pi ((n.h)^2 (a^2 - 1) + 1)^2), 0 for n.h <= 0.
float ggx_ndf(float n_dot_h, float alpha) {
    float a = alpha_floor(alpha);
    float a2 = a * a;
    float c = max(n_dot_h, 0.0);
    // precise: no fused multiply-add, so the cancellation near n.h = 1 rounds
    // exactly as brdf.specular.ggx_ndf (float32) does.
    precise float d = c * c * (a2 - 1.0) + 1.0;
    return n_dot_h > 0.0 ? a2 / (PI * d * d) : 0.0;
}

// Anisotropic GGX, overflow-safe form (Heitz 2014; UE D_GGXaniso):
// a2 = at ab, f = (ab t.h, at b.h, a2 n.h), D = a2 (a2 / |f|^2)^2 / pi.
float ggx_ndf_aniso(vec3 h, float alpha_t, float alpha_b) {
    float at = alpha_floor(alpha_t);
    float ab = alpha_floor(alpha_b);
    float a2 = at * ab;
    float fx = ab * h.x;
    float fy = at * h.y;
    float fz = a2 * h.z;
    float w2 = a2 / (fx * fx + fy * fy + fz * fz);
    return h.z > 0.0 ? a2 * w2 * w2 * INV_PI : 0.0;
}

// --- anisotropy remaps: each returns (alpha_t, alpha_b) -----------------------

// Kulla & Conty 2017: (alpha, a in [-1, 1]) -> (alpha (1 + a), alpha (1 - a)).
vec2 anisotropy_kulla_conty(float alpha, float anisotropy) {
    return vec2(max(alpha * (1.0 + anisotropy), ALPHA_MIN),
                max(alpha * (1.0 - anisotropy), ALPHA_MIN));
}

// KHR_materials_anisotropy: alpha_t = mix(alpha, 1, s^2), alpha_b = alpha.
vec2 anisotropy_gltf(float alpha, float strength) {
    float s2 = strength * strength;
    return vec2(alpha + (1.0 - alpha) * s2, alpha);
}

// Burley 2012 (Disney): aspect = sqrt(1 - 0.9 a); (r^2 / aspect, r^2 aspect).
vec2 anisotropy_burley(float roughness, float anisotropic) {
    float aspect = sqrt(1.0 - 0.9 * anisotropic);
    float r2 = roughness * roughness;
    return vec2(max(r2 / aspect, ALPHA_MIN), max(r2 * aspect, ALPHA_MIN));
}

// --- Smith masking -------------------------------------------------------------

// Lambda(v) = (-1 + sqrt(1 + a^2 tan^2 theta)) / 2 for GGX.
float smith_lambda(float n_dot_v, float alpha) {
    float c = clamp_cos(n_dot_v);
    precise float c2 = c * c;
    float a = alpha_floor(alpha);
    float a2 = a * a;
    precise float tan2 = (1.0 - c2) / c2;
    return 0.5 * (sqrt(1.0 + a2 * tan2) - 1.0);
}

// Anisotropic Lambda: a^2 tan^2 becomes (at^2 (t.v)^2 + ab^2 (b.v)^2) / (n.v)^2.
float smith_lambda_aniso(vec3 v, float alpha_t, float alpha_b) {
    float at = alpha_floor(alpha_t);
    float ab = alpha_floor(alpha_b);
    float c = clamp_cos(v.z);
    float tx = at * v.x;
    float ty = ab * v.y;
    float x = tx * tx + ty * ty;
    return 0.5 * (sqrt(1.0 + x / (c * c)) - 1.0);
}

// G1 = 1 / (1 + Lambda) = 2 n.v / (n.v + sqrt(a^2 + (1 - a^2)(n.v)^2)).
float smith_g1(float n_dot_v, float alpha) {
    float c = clamp_cos(n_dot_v);
    float a = alpha_floor(alpha);
    float a2 = a * a;
    return 2.0 * c / (c + sqrt(a2 + (1.0 - a2) * c * c));
}

// Schlick-GGX (Karis 2013): G1 ~ n.v / (n.v (1 - k) + k);
// k = (r + 1)^2 / 8 for analytic lights, k = alpha / 2 for image lighting.
float smith_g1_schlick(float n_dot_v, float k) {
    float c = clamp_cos(n_dot_v);
    return c / (c * (1.0 - k) + k);
}

// Uncorrelated Smith: G = G1(l) G1(v).
float g_separable(float n_dot_l, float n_dot_v, float alpha) {
    return smith_g1(n_dot_l, alpha) * smith_g1(n_dot_v, alpha);
}

// Height-correlated Smith: G2 = 1 / (1 + Lambda(l) + Lambda(v)).
float g_height_correlated(float n_dot_l, float n_dot_v, float alpha) {
    return 1.0 / (1.0 + smith_lambda(n_dot_l, alpha) + smith_lambda(n_dot_v, alpha));
}

// V = G2 / (4 n.l n.v) = 0.5 / (n.l sqrt(a^2 + (n.v)^2 (1 - a^2)) + n.v sqrt(a^2 + (n.l)^2 (1 - a^2))).
float visibility_height_correlated(float n_dot_l, float n_dot_v, float alpha) {
    float nl = clamp_cos(n_dot_l);
    float nv = clamp_cos(n_dot_v);
    float a = alpha_floor(alpha);
    float a2 = a * a;
    float gv = nl * sqrt(a2 + nv * nv * (1.0 - a2));
    float gl = nv * sqrt(a2 + nl * nl * (1.0 - a2));
    return 0.5 / (gv + gl);
}

// V = G1(l) G1(v) / (4 n.l n.v), written without the cancelling cosines.
float visibility_separable(float n_dot_l, float n_dot_v, float alpha) {
    float nl = clamp_cos(n_dot_l);
    float nv = clamp_cos(n_dot_v);
    float a = alpha_floor(alpha);
    float a2 = a * a;
    float gl = nl + sqrt(a2 + (1.0 - a2) * nl * nl);
    float gv = nv + sqrt(a2 + (1.0 - a2) * nv * nv);
    return 1.0 / (gl * gv);
}

// Anisotropic height-correlated V (Heitz 2014):
// 0.5 / (n.l |(at t.v, ab b.v, n.v)| + n.v |(at t.l, ab b.l, n.l)|).
float visibility_height_correlated_aniso(vec3 l, vec3 v, float alpha_t, float alpha_b) {
    float at = alpha_floor(alpha_t);
    float ab = alpha_floor(alpha_b);
    float nl = clamp_cos(l.z);
    float nv = clamp_cos(v.z);
    float vx = at * v.x, vy = ab * v.y;
    float lx = at * l.x, ly = ab * l.y;
    float lv = sqrt(vx * vx + vy * vy + nv * nv);
    float ll = sqrt(lx * lx + ly * ly + nl * nl);
    return 0.5 / (nl * lv + nv * ll);
}

// V = G1(l) G1(v) / (4 n.l n.v) with the anisotropic Lambda.
float visibility_separable_aniso(vec3 l, vec3 v, float alpha_t, float alpha_b) {
    float g = 1.0 / ((1.0 + smith_lambda_aniso(l, alpha_t, alpha_b))
                     * (1.0 + smith_lambda_aniso(v, alpha_t, alpha_b)));
    return g / (4.0 * clamp_cos(l.z) * clamp_cos(v.z));
}

// Height-correlated Smith from the NDF's Lambdas: G2 = 1 / (1 + Lambda(l) + Lambda(v)).
float g2_height_correlated(float lambda_l, float lambda_v) {
    return 1.0 / (1.0 + lambda_l + lambda_v);
}

// Uncorrelated Smith from the NDF's Lambdas: G = 1 / ((1 + Lambda(l)) (1 + Lambda(v))).
float g2_separable(float lambda_l, float lambda_v) {
    return 1.0 / ((1.0 + lambda_l) * (1.0 + lambda_v));
}

// UE Vis_SmithJointApprox: 0.5 / (n.l (n.v (1 - a) + a) + n.v (n.l (1 - a) + a)).
float visibility_smith_joint_approx(float n_dot_l, float n_dot_v, float alpha) {
    float nl = clamp_cos(n_dot_l);
    float nv = clamp_cos(n_dot_v);
    float a = alpha_floor(alpha);
    return 0.5 / (nl * (nv * (1.0 - a) + a) + nv * (nl * (1.0 - a) + a));
}

#include "beckmann.glsl"
#include "lobes.glsl"

// --- the spec's specular lobe ---------------------------------------------------
// One block per value of ModelSpec.masking, .anisotropy and .ndf, selected by
// the BRDF_<FIELD>_<VALUE> symbols of shaders.library.defines_for(spec); the
// composition (model.glsl) calls
//   float specular_dv(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha)
// = D V of the spec's lobe at alpha = roughness^2 (already floored).
#ifdef BRDF_PARAMS_DECLARED

// V = G / (4 n.l n.v) of a masking's G (brdf.model.visibility's generic form).
float visibility_of_g(float g, vec3 wi, vec3 wo) {
    return g / (4.0 * clamp_cos(wi.z) * clamp_cos(wo.z));
}

// Per masking: masking_visibility(lambda_l, lambda_v, wi, wo, h), V from the NDF's
// own Lambdas (V-groove reads the geometry only), and GGX's V -- its closed
// forms for the Smith maskings (ggx_visibility, ggx_visibility_aniso).
#if defined(BRDF_MASKING_HEIGHT_CORRELATED)
float masking_visibility(float lambda_l, float lambda_v, vec3 wi, vec3 wo, vec3 h) {
    return visibility_of_g(g2_height_correlated(lambda_l, lambda_v), wi, wo);
}
float ggx_visibility(vec3 wi, vec3 wo, vec3 h, float alpha) {
    return visibility_height_correlated(wi.z, wo.z, alpha);
}
float ggx_visibility_aniso(vec3 l, vec3 v, vec3 wi, vec3 wo, vec3 h, float alpha_t, float alpha_b) {
    return visibility_height_correlated_aniso(l, v, alpha_t, alpha_b);
}
#elif defined(BRDF_MASKING_SEPARABLE)
float masking_visibility(float lambda_l, float lambda_v, vec3 wi, vec3 wo, vec3 h) {
    return visibility_of_g(g2_separable(lambda_l, lambda_v), wi, wo);
}
float ggx_visibility(vec3 wi, vec3 wo, vec3 h, float alpha) {
    return visibility_separable(wi.z, wo.z, alpha);
}
float ggx_visibility_aniso(vec3 l, vec3 v, vec3 wi, vec3 wo, vec3 h, float alpha_t, float alpha_b) {
    return visibility_separable_aniso(l, v, alpha_t, alpha_b);
}
#elif defined(BRDF_MASKING_VGROOVE)
float masking_visibility(float lambda_l, float lambda_v, vec3 wi, vec3 wo, vec3 h) {
    return visibility_of_g(g_vgroove(wi.z, wo.z, h.z, dot3(wo, h)), wi, wo);
}
float ggx_visibility(vec3 wi, vec3 wo, vec3 h, float alpha) {
    return masking_visibility(0.0, 0.0, wi, wo, h);
}
float ggx_visibility_aniso(vec3 l, vec3 v, vec3 wi, vec3 wo, vec3 h, float alpha_t, float alpha_b) {
    return masking_visibility(0.0, 0.0, wi, wo, h);
}
#else
#error "specular.glsl has no block for the spec's masking (BRDF_MASKING_*)"
#endif

#if defined(BRDF_ANISOTROPY_KULLA_CONTY)
vec2 anisotropy_term(float alpha, float anisotropy) { return anisotropy_kulla_conty(alpha, anisotropy); }
#elif defined(BRDF_ANISOTROPY_GLTF)
vec2 anisotropy_term(float alpha, float anisotropy) { return anisotropy_gltf(alpha, anisotropy); }
#else
#error "specular.glsl has no block for the spec's anisotropy remap (BRDF_ANISOTROPY_*)"
#endif

#if defined(BRDF_NDF_GGX)
float specular_dv(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha) {
    return ggx_ndf(h.z, alpha) * ggx_visibility(wi, wo, h, alpha);
}
#elif defined(BRDF_NDF_GGX_ANISO)
// In the tangent frame rotated by p.rotation, (alpha_t, alpha_b) from the remap.
float specular_dv(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha) {
    vec2 ab = anisotropy_term(alpha, p.anisotropy);
    vec3 l = rotate_tangent(wi, p.rotation);
    vec3 v = rotate_tangent(wo, p.rotation);
    vec3 hr = rotate_tangent(h, p.rotation);
    return ggx_ndf_aniso(hr, ab.x, ab.y) * ggx_visibility_aniso(l, v, wi, wo, h, ab.x, ab.y);
}
#elif defined(BRDF_NDF_BECKMANN)
float specular_dv(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha) {
    float lambda_l = beckmann_lambda(wi.z, alpha);
    float lambda_v = beckmann_lambda(wo.z, alpha);
    return beckmann_ndf(h.z, alpha) * masking_visibility(lambda_l, lambda_v, wi, wo, h);
}
#elif defined(BRDF_NDF_BECKMANN_ANISO)
// In the tangent frame rotated by p.rotation, (alpha_t, alpha_b) from the remap.
float specular_dv(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha) {
    vec2 ab = anisotropy_term(alpha, p.anisotropy);
    vec3 l = rotate_tangent(wi, p.rotation);
    vec3 v = rotate_tangent(wo, p.rotation);
    vec3 hr = rotate_tangent(h, p.rotation);
    float lambda_l = beckmann_lambda_aniso(l, ab.x, ab.y);
    float lambda_v = beckmann_lambda_aniso(v, ab.x, ab.y);
    return beckmann_ndf_aniso(hr, ab.x, ab.y) * masking_visibility(lambda_l, lambda_v, wi, wo, h);
}
#elif defined(BRDF_NDF_BLINN_PHONG)
// The classic lobe models (lobes.glsl) are the whole specular term, called as
//   vec3 specular_lobe(p, wi, wo, h, alpha)  (model.glsl; shaders.library defines
// BRDF_LOBE_MODEL for them)
// and have no Fresnel term: under image lighting (ibl.glsl) they stand as the
// GGX lobe of their alpha with F0 = F90 = lobe_f0(p), the glTF conversion's.
vec3 specular_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha) {
    return p.specular_albedo * blinn_phong(h.z, phong_exponent(alpha));
}
vec3 lobe_f0(BrdfParams p) { return 4.0 * p.specular_albedo; }
#elif defined(BRDF_NDF_PHONG)
vec3 specular_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha) {
    return p.specular_albedo * phong_modified(mirror_cosine(wi, wo), phong_exponent(alpha));
}
vec3 lobe_f0(BrdfParams p) { return 4.0 * p.specular_albedo; }
#elif defined(BRDF_NDF_BLINN_PHONG_MF)
// The two lobes above with the microfacet factor: rho_s D / 4 at normal incidence, F0 = rho_s.
vec3 specular_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha) {
    return p.specular_albedo * (blinn_phong(h.z, phong_exponent(alpha))
                                * microfacet_factor(dot3(wo, h), wi.z, wo.z));
}
vec3 lobe_f0(BrdfParams p) { return p.specular_albedo; }
#elif defined(BRDF_NDF_PHONG_MF)
vec3 specular_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha) {
    return p.specular_albedo * (phong_modified(mirror_cosine(wi, wo), phong_exponent(alpha))
                                * microfacet_factor(dot3(wo, h), wi.z, wo.z));
}
vec3 lobe_f0(BrdfParams p) { return p.specular_albedo; }
#elif defined(BRDF_NDF_WARD)
vec3 specular_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha) {
    return p.specular_albedo * ward(h.z, wi.z, wo.z, alpha);
}
vec3 lobe_f0(BrdfParams p) { return p.specular_albedo; }
#elif defined(BRDF_NDF_WARD_ANISO)
// In the tangent frame rotated by p.rotation, (alpha_t, alpha_b) from the remap.
vec3 specular_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha) {
    vec2 ab = anisotropy_term(alpha, p.anisotropy);
    return p.specular_albedo * ward_aniso(rotate_tangent(h, p.rotation), wi.z, wo.z, ab.x, ab.y);
}
vec3 lobe_f0(BrdfParams p) { return p.specular_albedo; }
#elif defined(BRDF_NDF_WARD_DUER_ANISO)
vec3 specular_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha) {
    vec2 ab = anisotropy_term(alpha, p.anisotropy);
    return p.specular_albedo * ward_duer_aniso(rotate_tangent(h, p.rotation), wi.z, wo.z, ab.x, ab.y);
}
vec3 lobe_f0(BrdfParams p) { return p.specular_albedo; }
#elif defined(BRDF_NDF_ASHIKHMIN_SHIRLEY)
vec3 specular_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha) {
    float v_dot_h = dot3(wo, h);
    float lobe = ashikhmin_shirley(h.z, v_dot_h, wi.z, wo.z, phong_exponent(alpha));
    return fresnel_schlick(p.specular_albedo, v_dot_h) * lobe;
}
vec3 lobe_f0(BrdfParams p) { return p.specular_albedo; }
#elif defined(BRDF_NDF_ASHIKHMIN_SHIRLEY_ANISO)
// In the tangent frame rotated by p.rotation, the exponents from (alpha_t, alpha_b) of the remap.
vec3 specular_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha) {
    vec2 ab = anisotropy_term(alpha, p.anisotropy);
    float v_dot_h = dot3(wo, h);
    float lobe = ashikhmin_shirley_aniso(rotate_tangent(h, p.rotation), v_dot_h, wi.z, wo.z,
                                         phong_exponent(ab.x), phong_exponent(ab.y));
    return fresnel_schlick(p.specular_albedo, v_dot_h) * lobe;
}
vec3 lobe_f0(BrdfParams p) { return p.specular_albedo; }
#elif defined(BRDF_NDF_ASHIKHMIN_SHIRLEY_SCALED)
// Ngan et al. 2005's Ashikhmin-Shirley: the lobe scaled by rho_s, its Fresnel of a grey R_s.
vec3 specular_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha) {
    float v_dot_h = dot3(wo, h);
    float lobe = ashikhmin_shirley(h.z, v_dot_h, wi.z, wo.z, phong_exponent(alpha));
    return p.specular_albedo * (fresnel_schlick(p.fresnel_reflectance, v_dot_h) * lobe);
}
vec3 lobe_f0(BrdfParams p) { return p.specular_albedo * p.fresnel_reflectance; }
#elif defined(BRDF_NDF_LAFORTUNE)
vec3 specular_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha) {
    float cosine = lafortune_cosine(wi, wo, lafortune_cxy(p.lafortune_cz), p.lafortune_cz);
    return p.specular_albedo * lafortune(cosine, phong_exponent(alpha));
}
vec3 lobe_f0(BrdfParams p) { return 4.0 * p.specular_albedo; }
#elif defined(BRDF_NDF_LAFORTUNE2)
// Lafortune et al. 1997's sum of lobes: lobe j >= 2 with its own roughness, albedo and Cz.
vec3 specular_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha) {
    return lafortune_term(wi, wo, p.specular_albedo, p.roughness, p.lafortune_cz)
         + lafortune_term(wi, wo, p.lafortune_albedo_2, p.lafortune_roughness_2, p.lafortune_cz_2);
}
vec3 lobe_f0(BrdfParams p) { return 4.0 * p.specular_albedo; }
#elif defined(BRDF_NDF_LAFORTUNE3)
vec3 specular_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha) {
    return lafortune_term(wi, wo, p.specular_albedo, p.roughness, p.lafortune_cz)
         + lafortune_term(wi, wo, p.lafortune_albedo_2, p.lafortune_roughness_2, p.lafortune_cz_2)
         + lafortune_term(wi, wo, p.lafortune_albedo_3, p.lafortune_roughness_3, p.lafortune_cz_3);
}
vec3 lobe_f0(BrdfParams p) { return 4.0 * p.specular_albedo; }
#elif defined(BRDF_NDF_WARD_DUER)
vec3 specular_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha) {
    return p.specular_albedo * ward_duer(h.z, wi.z, wo.z, alpha);
}
vec3 lobe_f0(BrdfParams p) { return p.specular_albedo; }
#else
#error "specular.glsl has no block for the spec's NDF (BRDF_NDF_*)"
#endif

#ifdef BRDF_LOBE_MODEL
vec3 fresnel_f0(BrdfParams p) { return lobe_f0(p); }
vec3 fresnel_f90(BrdfParams p) { return lobe_f0(p); }
#endif

#endif  // BRDF_PARAMS_DECLARED
