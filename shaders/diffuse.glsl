// Diffuse lobes (mirrors brdf/diffuse.py; docs/models.md#diffuse-lobes).  Each returns
// f = albedo / pi * factor.
//
// Sources: Lambert 1760; Burley 2012, "Physically-based shading at Disney";
// Lagarde & de Rousiers 2014, "Moving Frostbite to PBR" (renormalised Burley);
// Chan 2018, "Material advances in Call of Duty: WWII" (with its gloss
// parameterisation); Oren & Nayar 1994; Portsmouth, Kutz & Hill 2025, "EON: A
// Practical Energy-Preserving Rough Diffuse BRDF" (JCGT 14(1)).
//
// Which roughness each takes is part of its signature: `roughness` is the
// perceptual r (glTF roughnessFactor), `alpha` = r^2.
//
// Under image lighting (ibl.glsl) a lobe is known by the moments of order 0,
// 1 and 2 of g(l) = f_d(l, v) cos(theta_l) (rho = 1) over the light
// directions, tabulated by shaders/diffuse_ibl.py from brdf/'s lobe on
// (mu = n.v, x), x the lobe's roughness or sigma (docs/renderer.md).
#include "common.glsl"
#include "energy.glsl"

// Frostbite's renormalisation: energyFactor goes from 1 to 1/1.51.
const float FROSTBITE_ENERGY_FACTOR_ROUGH = 0.662251655629139073;   // 1 / 1.51
// Call of Duty WWII gloss parameterisation alpha^2 = 2 / (1 + 2^(18 g)).
const float COD_GLOSS_BITS = 18.0;
// EON: A = 1 / (1 + EON_A_SLOPE r); the average albedo of its single scattering
// A (1 + EON_AVERAGE_SLOPE r); G(mu) / pi as the paper's cubic in 1 - mu.
const float EON_A_SLOPE = 0.2877934092108062;          // 1/2 - 2/(3 pi)
const float EON_AVERAGE_SLOPE = 0.07248821245692394;   // 2/3 - 28/(15 pi)
const vec4 EON_G_POLY = vec4(0.0571085289, 0.491881867, -0.332181442, 0.0714429953);
const float EON_EPS = 1e-7;

// (1 + (FD90 - 1)(1 - n.l)^5)(1 + (FD90 - 1)(1 - n.v)^5).
float diffuse_schlick_pair(float fd90, float n_dot_l, float n_dot_v) {
    float nl = clamp(n_dot_l, 0.0, 1.0);
    float nv = clamp(n_dot_v, 0.0, 1.0);
    return (1.0 + (fd90 - 1.0) * pow5(1.0 - nl)) * (1.0 + (fd90 - 1.0) * pow5(1.0 - nv));
}

// Lambert: albedo / pi.
vec3 lambert(vec3 albedo, float n_dot_l, float n_dot_v) {
    return albedo * INV_PI;
}

// Burley 2012: FD90 = 0.5 + 2 r (l.h)^2, factor = Schlick pair with FD90
// (r perceptual, as in Disney's disney.brdf).
vec3 burley(vec3 albedo, float roughness, float n_dot_l, float n_dot_v, float l_dot_h) {
    float fd90 = 0.5 + 2.0 * roughness * l_dot_h * l_dot_h;
    return albedo * INV_PI * diffuse_schlick_pair(fd90, n_dot_l, n_dot_v);
}

// Frostbite renormalised Burley (Lagarde & de Rousiers 2014, listing 10), r =
// their linearRoughness = our perceptual roughness: energyBias = 0.5 r,
// energyFactor = lerp(1, 1/1.51, r), FD90 = energyBias + 2 (l.h)^2 r.
vec3 frostbite(vec3 albedo, float roughness, float n_dot_l, float n_dot_v, float l_dot_h) {
    float energy_bias = 0.5 * roughness;
    float energy_factor = 1.0 + (FROSTBITE_ENERGY_FACTOR_ROUGH - 1.0) * roughness;
    float fd90 = energy_bias + 2.0 * l_dot_h * l_dot_h * roughness;
    return albedo * INV_PI * (energy_factor * diffuse_schlick_pair(fd90, n_dot_l, n_dot_v));
}

// Chan 2018 gloss from alpha: g = clamp(log2(2 / alpha^2 - 1) / 18, 0, 1).
float cod_gloss_from_alpha(float alpha) {
    float a = max(alpha, ALPHA_MIN);
    float a2 = a * a;
    return clamp(log2(max(2.0 / a2 - 1.0, 1e-12)) * (1.0 / COD_GLOSS_BITS), 0.0, 1.0);
}

// Call of Duty: WWII diffuse (Chan 2018), identical to UE's Diffuse_Chan:
// f_rough = l.h + (1 - l.h)^5; f_smooth = (1 - 0.75 (1-n.l)^5)(1 - 0.75 (1-n.v)^5);
// fd = lerp(f_rough, f_smooth, clamp(2.2 g - 0.5, 0, 1));
// fb = (34.5 g^2 - 59 g + 24.5) l.h 2^(-max(73.2 g - 21.2, 8.9) sqrt(n.h)).
vec3 cod_wwii(vec3 albedo, float alpha, float n_dot_l, float n_dot_v, float l_dot_h, float n_dot_h) {
    float g = cod_gloss_from_alpha(alpha);
    float nl = clamp(n_dot_l, 0.0, 1.0);
    float nv = clamp(n_dot_v, 0.0, 1.0);
    float lh = clamp(l_dot_h, 0.0, 1.0);
    float nh = clamp(n_dot_h, 0.0, 1.0);
    float f_rough = lh + pow5(1.0 - lh);
    float f_smooth = (1.0 - 0.75 * pow5(1.0 - nl)) * (1.0 - 0.75 * pow5(1.0 - nv));
    float t = clamp(2.2 * g - 0.5, 0.0, 1.0);
    float fd = f_rough + (f_smooth - f_rough) * t;
    float fb = (34.5 * g * g - 59.0 * g + 24.5) * lh
               * exp2(-max(73.2 * g - 21.2, 8.9) * sqrt(max(nh, 1e-12)));
    return albedo * INV_PI * (fd + fb);
}

// Angles of Oren-Nayar: (sin alpha_o, tan beta, cos(phi_i - phi_o)) and
// (alpha_o, beta), alpha_o = max(theta_i, theta_o), beta = min(theta_i, theta_o).
void oren_nayar_angles(vec3 wi, vec3 wo, out float sin_alpha, out float tan_beta,
                       out float cos_phi, out float alpha_o, out float beta) {
    float ci = clamp(wi.z, 1e-6, 1.0);
    float co = clamp(wo.z, 1e-6, 1.0);
    float si = sqrt(max(1.0 - ci * ci, 1e-12));
    float so = sqrt(max(1.0 - co * co, 1e-12));
    float proj = wi.x * wo.x + wi.y * wo.y;
    cos_phi = clamp(proj / (si * so), -1.0, 1.0);
    sin_alpha = max(si, so);
    float cos_beta = max(ci, co);
    tan_beta = min(si, so) / cos_beta;
    alpha_o = atan2_accurate(sin_alpha, min(ci, co));
    beta = atan2_accurate(min(si, so), cos_beta);
}

// Qualitative Oren-Nayar 1994, sigma = slope standard deviation (radians):
// factor = A + B max(0, cos(phi_i - phi_o)) sin(alpha_o) tan(beta),
// A = 1 - 0.5 s^2 / (s^2 + 0.33), B = 0.45 s^2 / (s^2 + 0.09).
vec3 oren_nayar(vec3 albedo, float sigma, vec3 wi, vec3 wo) {
    float s2 = sigma * sigma;
    float a = 1.0 - 0.5 * s2 / (s2 + 0.33);
    float b = 0.45 * s2 / (s2 + 0.09);
    float sin_alpha, tan_beta, cos_phi, alpha_o, beta;
    oren_nayar_angles(wi, wo, sin_alpha, tan_beta, cos_phi, alpha_o, beta);
    return albedo * INV_PI * (a + b * max(0.0, cos_phi) * sin_alpha * tan_beta);
}

// Full Oren-Nayar 1994 (eqs. 47-50 with the interreflection term L2, which
// carries an extra factor albedo: this lobe is not linear in albedo).
vec3 oren_nayar_full(vec3 albedo, float sigma, vec3 wi, vec3 wo) {
    float s2 = sigma * sigma;
    float sin_alpha, tan_beta, cos_phi, alpha_o, beta;
    oren_nayar_angles(wi, wo, sin_alpha, tan_beta, cos_phi, alpha_o, beta);
    float c1 = 1.0 - 0.5 * s2 / (s2 + 0.33);
    float b = 0.45 * s2 / (s2 + 0.09);
    float x = 2.0 * beta * INV_PI;
    float c2 = cos_phi >= 0.0 ? b * sin_alpha : b * (sin_alpha - x * (x * x));
    float y = 4.0 * alpha_o * beta * INV_PI * INV_PI;
    float c3 = 0.125 * s2 / (s2 + 0.09) * (y * y);
    float l1 = c1 + cos_phi * c2 * tan_beta
               + (1.0 - abs(cos_phi)) * c3 * tan_accurate(0.5 * (alpha_o + beta));
    float l2 = 0.17 * s2 / (s2 + 0.13) * (1.0 - cos_phi * (x * x));
    return albedo * INV_PI * (l1 + albedo * l2);
}

// G(mu) / pi of EON's directional albedo (the paper's eq. 21 fit).
float eon_g_over_pi(float mu) {
    float x = 1.0 - clamp(mu, 0.0, 1.0);
    return x * (EON_G_POLY.x + x * (EON_G_POLY.y + x * (EON_G_POLY.z + x * EON_G_POLY.w)));
}

// E_FON(mu) = A (1 + r G(mu) / pi), the albedo of EON's single scattering (rho = 1).
float fon_directional_albedo(float roughness, float mu) {
    return (1.0 + roughness * eon_g_over_pi(mu)) / (1.0 + EON_A_SLOPE * roughness);
}

// EON (KHR_materials_diffuse_roughness as three.js r187 draws it), r = diffuse
// roughness in [0, 1]: f_ss = rho/pi A (1 + r s/t), s = l.v - n.l n.v, t = max(n.l,
// n.v) where s > 0 else 1; f_ms = rho_ms/pi (1 - E(n.v))(1 - E(n.l))/(1 - E_avg),
// rho_ms = rho^2 E_avg / (1 - rho (1 - E_avg)); written as brdf/diffuse.py's eon,
// 1 - E(mu) = A r (EON_A_SLOPE - G(mu)/pi) held at 0 or above.
vec3 eon(vec3 albedo, float roughness, float n_dot_l, float n_dot_v, float l_dot_v) {
    vec3 rho = clamp(albedo, 0.0, 1.0);
    float nl = clamp(n_dot_l, 0.0, 1.0);
    float nv = clamp(n_dot_v, 0.0, 1.0);
    float s = l_dot_v - nl * nv;
    float s_over_t = s > 0.0 ? s / max(max(nl, nv), EON_EPS) : s;
    float a = 1.0 / (1.0 + EON_A_SLOPE * roughness);
    float single = a * (1.0 + roughness * s_over_t);
    float lack_l = max(EON_A_SLOPE - eon_g_over_pi(nl), 0.0);
    float lack_v = max(EON_A_SLOPE - eon_g_over_pi(nv), 0.0);
    float multiple = a * roughness * lack_l * lack_v / (EON_A_SLOPE - EON_AVERAGE_SLOPE);
    float average = a * (1.0 + EON_AVERAGE_SLOPE * roughness);
    vec3 rho_ms = rho * rho * average / (1.0 - rho * (1.0 - average));
    return INV_PI * (rho * single + rho_ms * multiple);
}

// --- image lighting: the moments of a lobe ----------------------------------------
// In the frame (t, b, n) of a view direction v = (sin theta_v, 0, n.v), for
// g(l) = f_d(l, v) cos(theta_l) with rho = 1 (every lobe is even in b):
struct DiffuseMoments {
    float m0;     // int g dl: the directional albedo E_d (white furnace)
    vec2 m1;      // (t, n) components of int g l dl
    vec4 m2;      // (tt, bb, nn, tn) entries of int g l l^T dl
};
// The irradiance's SH expansion (ibl.glsl) is a polynomial of degree 2 in l,
// so these moments give a lobe's radiance under it exactly.

// Lambert (g = cos / pi): m0 = 1, int cos^2 / pi = 2/3, int cos^3 / pi = 1/2.
const float LAMBERT_MOMENT_N = 0.666666666666666667;
const float LAMBERT_MOMENT_NN = 0.5;
const float LAMBERT_MOMENT_TT = 0.25;                    // (1 - 1/2) / 2 each for t and b
DiffuseMoments lambert_moments() {
    return DiffuseMoments(1.0, vec2(0.0, LAMBERT_MOMENT_N),
                          vec4(LAMBERT_MOMENT_TT, LAMBERT_MOMENT_TT, LAMBERT_MOMENT_NN, 0.0));
}
DiffuseMoments no_moments() { return DiffuseMoments(0.0, vec2(0.0), vec4(0.0)); }

// The table of the spec's lobe: texel (k, j) holds (m0, m1.t, m1.n, m2.tn) at
// (mu_j, x_k), texel (k + width / 2, j) holds (m2.tt, m2.bb, m2.nn, 0).
uniform sampler2D brdf_diffuse_moments;
uniform vec2 brdf_diffuse_moments_axis;     // x of the first and last column

// The moments at (mu, x), bilinear with the weights of lookup_e (energy.glsl).
DiffuseMoments diffuse_moments_table(float mu, float x) {
    ivec2 size = textureSize(brdf_diffuse_moments, 0);
    int columns = size.x / 2;
    vec2 axis = brdf_diffuse_moments_axis;
    int i, k;
    float fi, fk;
    energy_interp_coord(clamp(mu, 0.0, 1.0) * float(size.y - 1), size.y, i, fi);
    energy_interp_coord((x - axis.x) / (axis.y - axis.x) * float(columns - 1), columns, k, fk);
    vec4 m[2];
    for (int half_ = 0; half_ < 2; ++half_) {
        int c = k + half_ * columns;
        vec4 t00 = texelFetch(brdf_diffuse_moments, ivec2(c, i), 0);
        vec4 t01 = texelFetch(brdf_diffuse_moments, ivec2(c + 1, i), 0);
        vec4 t10 = texelFetch(brdf_diffuse_moments, ivec2(c, i + 1), 0);
        vec4 t11 = texelFetch(brdf_diffuse_moments, ivec2(c + 1, i + 1), 0);
        m[half_] = (1.0 - fi) * ((1.0 - fk) * t00 + fk * t01) + fi * ((1.0 - fk) * t10 + fk * t11);
    }
    return DiffuseMoments(m[0].x, m[0].yz, vec4(m[1].xyz, m[0].w));
}

// --- the spec's diffuse lobe ----------------------------------------------------
// One block per value of ModelSpec.diffuse (BRDF_DIFFUSE_<VALUE>, generated by
// shaders.library.defines_for), each defining
//   vec3 diffuse_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float v_dot_h,
//                     float roughness, float alpha)        f_d (model.glsl)
//   vec3 diffuse_albedo(BrdfParams p)   rho of f_d (image lighting, ibl.glsl)
//   float diffuse_ibl_shape(BrdfParams p)   the x of its moments table
//   DiffuseMoments diffuse_ibl_moments(float n_dot_v, float x)
//                                       its moments for rho = 1 (ibl.glsl)
// l.h is taken as v.h (equal by symmetry, as brdf.model does).  The glTF, OpenPBR and
// Principled non-metal compositions fix their diffuse lobe (common.glsl: BRDF_FIXED_NONMETAL):
// their diffuse_albedo is in gltf.glsl, openpbr.glsl.
#if defined(BRDF_PARAMS_DECLARED) && !defined(BRDF_COMPOSITION_GLTF) && !defined(BRDF_FIXED_NONMETAL)

#if defined(BRDF_DIFFUSE_NONE)
vec3 diffuse_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float v_dot_h, float roughness, float alpha) {
    return vec3(0.0);
}
vec3 diffuse_albedo(BrdfParams p) { return vec3(0.0); }
float diffuse_ibl_shape(BrdfParams p) { return 0.0; }
DiffuseMoments diffuse_ibl_moments(float n_dot_v, float x) { return no_moments(); }

#elif defined(BRDF_DIFFUSE_LAMBERT)
vec3 diffuse_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float v_dot_h, float roughness, float alpha) {
    return lambert(p.albedo, wi.z, wo.z);
}
vec3 diffuse_albedo(BrdfParams p) { return p.albedo; }
// Lambert's moments are constants (no table).
float diffuse_ibl_shape(BrdfParams p) { return 0.0; }
DiffuseMoments diffuse_ibl_moments(float n_dot_v, float x) { return lambert_moments(); }

#elif defined(BRDF_DIFFUSE_BURLEY)
vec3 diffuse_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float v_dot_h, float roughness, float alpha) {
    return burley(p.albedo, roughness, wi.z, wo.z, v_dot_h);
}
vec3 diffuse_albedo(BrdfParams p) { return p.albedo; }
// Tabulated on (n.v, r): E_d above 1 at grazing view when rough, below when smooth.
float diffuse_ibl_shape(BrdfParams p) { return clamp(p.roughness, ROUGHNESS_MIN, 1.0); }
DiffuseMoments diffuse_ibl_moments(float n_dot_v, float x) { return diffuse_moments_table(n_dot_v, x); }

#elif defined(BRDF_DIFFUSE_FROSTBITE)
vec3 diffuse_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float v_dot_h, float roughness, float alpha) {
    return frostbite(p.albedo, roughness, wi.z, wo.z, v_dot_h);
}
vec3 diffuse_albedo(BrdfParams p) { return p.albedo; }
// Tabulated on (n.v, r): E_d never above 1 (the renormalisation).
float diffuse_ibl_shape(BrdfParams p) { return clamp(p.roughness, ROUGHNESS_MIN, 1.0); }
DiffuseMoments diffuse_ibl_moments(float n_dot_v, float x) { return diffuse_moments_table(n_dot_v, x); }

#elif defined(BRDF_DIFFUSE_COD_WWII)
vec3 diffuse_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float v_dot_h, float roughness, float alpha) {
    return cod_wwii(p.albedo, alpha, wi.z, wo.z, v_dot_h, h.z);
}
vec3 diffuse_albedo(BrdfParams p) { return p.albedo; }
// Tabulated on (n.v, r) (the lobe takes alpha = r^2, as above): the retro-reflection
// tilts the first moment towards v.
float diffuse_ibl_shape(BrdfParams p) { return clamp(p.roughness, ROUGHNESS_MIN, 1.0); }
DiffuseMoments diffuse_ibl_moments(float n_dot_v, float x) { return diffuse_moments_table(n_dot_v, x); }

#elif defined(BRDF_DIFFUSE_OREN_NAYAR)
vec3 diffuse_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float v_dot_h, float roughness, float alpha) {
    return oren_nayar(p.albedo, p.sigma, wi, wo);
}
vec3 diffuse_albedo(BrdfParams p) { return p.albedo; }
// Tabulated on (n.v, sigma): back-scattering tilts the first moment towards v.
float diffuse_ibl_shape(BrdfParams p) { return p.sigma; }
DiffuseMoments diffuse_ibl_moments(float n_dot_v, float x) { return diffuse_moments_table(n_dot_v, x); }

#else
#error "diffuse.glsl has no block for the spec's diffuse lobe (BRDF_DIFFUSE_*)"
#endif

#endif  // BRDF_PARAMS_DECLARED && !BRDF_COMPOSITION_GLTF && !BRDF_FIXED_NONMETAL
