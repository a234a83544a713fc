// Image-based lighting: equirectangular maps, spherical-harmonics irradiance,
// the split-sum approximation.
//
// - Split sum (Karis 2013, "Real shading in Unreal Engine 4"): the specular
//   integral ~ prefiltered radiance(R, r) x (F0 A + F90 B), with A, B the
//   DFG terms brdf.energy.tables() tabulates on (mu = n.v, r) and the
//   prefiltered map made by ibl_prefilter.glsl (mip level m <-> roughness
//   m / (levels - 1)).
// - Irradiance from 9 SH coefficients (Ramamoorthi & Hanrahan 2001),
//   projected and convolved in shaders/environment.py.
// - A ModelSpec's material (with a spec only): each term's file says what
//   stands for it under image lighting (fresnel_f0 / fresnel_f90; diffuse_albedo
//   and the lobe's moments diffuse_ibl_moments(n.v), tabulated like the DFG
//   term by shaders/diffuse_ibl.py and integrated against the SH; clearcoat_weight;
//   energy_ibl: the multiple-scattering combination,
//   Fdez-Aguera 2019 for Kulla-Conty), the composition how the diffuse lobe is
//   weighted (composition_diffuse_weight, model.glsl / gltf.glsl).
//
// World frame +y up; lat-long mapping as shaders/environment.py documents.
#include "energy.glsl"
#include "clearcoat.glsl"
#include "sheen.glsl"
#include "sampling.glsl"

uniform sampler2D ibl_environment;     // radiance, lat-long, full mip chain
uniform sampler2D ibl_prefiltered;     // GGX-prefiltered radiance, lat-long, mip m = roughness m/(n-1)
uniform sampler2D ibl_dfg;             // (A, B)[mu_j, r_k] at texel (k, j), R32G32F
uniform vec3 ibl_sh[9];                // irradiance E(n) expansion, W/m^2
uniform float ibl_prefiltered_max_lod; // levels - 1
uniform float ibl_intensity;           // scales the whole environment

// Lat-long texture coordinates of a world direction: u = atan2(x, -z)/(2 pi) + 1/2,
// v = acos(y)/pi (v = 0 at the top row, which is uploaded first).
vec2 dir_to_equirect(vec3 d) {
    return vec2(atan(d.x, -d.z) * (0.5 * INV_PI) + 0.5, acos(clamp(d.y, -1.0, 1.0)) * INV_PI);
}
vec3 equirect_to_dir(vec2 uv) {
    float phi = (uv.x - 0.5) * 2.0 * PI;
    float theta = uv.y * PI;
    return vec3(sin(theta) * sin(phi), cos(theta), -sin(theta) * cos(phi));
}

// Y_lm normalisation constants of the real SH basis, bands 0-2 (environment.py's SH_C*).
const float SH_C0 = 0.282095;
const float SH_C1 = 0.488603;
const float SH_C2 = 1.092548;
const float SH_C3 = 0.315392;
const float SH_C4 = 0.546274;
// Clamped-cosine convolution per band (A_0 = pi, A_1 = 2 pi / 3, A_2 = pi / 4):
// ibl_sh holds radiance coefficients times these.
const float SH_A0 = 3.14159265358979323846;
const float SH_A1 = 2.09439510239319549231;
const float SH_A2 = 0.785398163397448309616;

// Irradiance E(n) from the SH expansion (clamped: band-limited ringing can dip below 0).
vec3 sh_irradiance(vec3 n) {
    vec3 e = ibl_sh[0] * SH_C0
           + ibl_sh[1] * (SH_C1 * n.y) + ibl_sh[2] * (SH_C1 * n.z) + ibl_sh[3] * (SH_C1 * n.x)
           + ibl_sh[4] * (SH_C2 * n.x * n.y) + ibl_sh[5] * (SH_C2 * n.y * n.z)
           + ibl_sh[6] * (SH_C3 * (3.0 * n.z * n.z - 1.0)) + ibl_sh[7] * (SH_C2 * n.x * n.z)
           + ibl_sh[8] * (SH_C4 * (n.x * n.x - n.y * n.y));
    return max(e, vec3(0.0)) * ibl_intensity;
}

// (A, B) bilinear in (mu, r) with the same weights as lookup_e.
vec2 lookup_dfg(float mu, float roughness) {
    ivec2 size = textureSize(ibl_dfg, 0);
    int i, k;
    float fi, fk;
    energy_interp_coord(clamp(mu, 0.0, 1.0) * float(size.y - 1), size.y, i, fi);
    energy_interp_coord((roughness - ROUGHNESS_MIN) * (1.0 / ENERGY_ROUGHNESS_SPAN) * float(size.x - 1),
                        size.x, k, fk);
    vec2 d00 = texelFetch(ibl_dfg, ivec2(k, i), 0).rg;
    vec2 d01 = texelFetch(ibl_dfg, ivec2(k + 1, i), 0).rg;
    vec2 d10 = texelFetch(ibl_dfg, ivec2(k, i + 1), 0).rg;
    vec2 d11 = texelFetch(ibl_dfg, ivec2(k + 1, i + 1), 0).rg;
    return (1.0 - fi) * ((1.0 - fk) * d00 + fk * d01) + fi * ((1.0 - fk) * d10 + fk * d11);
}

vec3 prefiltered_radiance(vec3 r, float roughness) {
    return textureLod(ibl_prefiltered, dir_to_equirect(r), roughness * ibl_prefiltered_max_lod).rgb
           * ibl_intensity;
}

vec3 environment_radiance(vec3 d, float lod) {
    return textureLod(ibl_environment, dir_to_equirect(d), lod).rgb * ibl_intensity;
}

// --- the split sum of a ModelSpec's material -------------------------------------
// (Shaders without a spec, such as the background and the prefilter, skip it
// and model.glsl, which needs the spec's BrdfParams.)
#ifdef BRDF_PARAMS_DECLARED
#include "model.glsl"

// Radiance int L(l) g(l) dl a diffuse lobe g = f_d cos (rho = 1) with moments
// `m` (diffuse.glsl) reflects from the environment's SH expansion of L
// (radiance coefficients ibl_sh[k] / A_l).  Each Y_k is a polynomial of degree
// <= 2 in l, so int g Y_k is a combination of the moments, rotated from the
// frame (t, b, n) of v to the world.  Lambert's moments give sh_irradiance(n) / pi.
vec3 sh_lobe_radiance(DiffuseMoments m, vec3 n, vec3 v) {
    vec3 t = v - n * dot(n, v);
    float len = length(t);
    if (len > COS_EPS) {
        t /= len;
    } else {                        // v = n: the lobe is symmetric about n, any t will do
        vec3 b0;
        basis_from_normal(n, t, b0);
    }
    vec3 b = cross(n, t);
    vec3 m1 = m.m1.x * t + m.m1.y * n;
    mat3 m2 = m.m2.x * outerProduct(t, t) + m.m2.y * outerProduct(b, b) + m.m2.z * outerProduct(n, n)
              + m.m2.w * (outerProduct(t, n) + outerProduct(n, t));
    // m2[i][j] = int g l_i l_j (symmetric): world x, y, z = 0, 1, 2
    vec3 e = ibl_sh[0] * (SH_C0 * m.m0 / SH_A0)
           + (ibl_sh[1] * (SH_C1 * m1.y) + ibl_sh[2] * (SH_C1 * m1.z) + ibl_sh[3] * (SH_C1 * m1.x)) / SH_A1
           + (ibl_sh[4] * (SH_C2 * m2[0][1]) + ibl_sh[5] * (SH_C2 * m2[1][2])
              + ibl_sh[6] * (SH_C3 * (3.0 * m2[2][2] - m.m0)) + ibl_sh[7] * (SH_C2 * m2[0][2])
              + ibl_sh[8] * (SH_C4 * (m2[0][0] - m2[1][1]))) / SH_A2;
    return max(e, vec3(0.0)) * ibl_intensity;
}

// What the split sum needs to know about a material.
struct IblMaterial {
    vec3 f0;                    // Schlick F0 and F90 that stand for the specular Fresnel
    vec3 f90;
    vec3 diffuse;               // rho of the diffuse lobe
    float diffuse_shape;        // x of its moments table (diffuse.glsl)
    float roughness;            // perceptual
    float clearcoat;            // coat weight (0: no coat)
    float clearcoat_roughness;
    vec3 sheen_color;           // KHR_materials_sheen (0: no sheen)
    float sheen_roughness;
};

// The IblMaterial of the spec's parameters.  Approximations: a diffuse lobe
// sees the environment's 9-coefficient SH expansion (through its moments, so
// its view dependence and tilt are kept), anisotropy is ignored, exact
// dielectric / conductor Fresnel become Schlick with their F0.
IblMaterial ibl_material(BrdfParams p) {
    IblMaterial m;
    m.f0 = fresnel_f0(p);
    m.f90 = fresnel_f90(p);
    m.diffuse = diffuse_albedo(p);
    m.diffuse_shape = diffuse_ibl_shape(p);
    m.roughness = clamp(p.roughness, ROUGHNESS_MIN, 1.0);
    m.clearcoat = clearcoat_weight(p);
    m.clearcoat_roughness = clearcoat_ibl_roughness(p);
    m.sheen_color = sheen_ibl_color(p);
    m.sheen_roughness = sheen_ibl_roughness(p);
    return m;
}

// Outgoing radiance under the environment (split sum), world-space n and v:
// specular F_ss E_ss prefiltered(R, r) with the spec's multiple scattering
// (energy_ibl), diffuse rho w(specular albedo) sh_lobe_radiance, a sheen over
// both (the extension's n.v-only form for indirect light, as three.js r187 draws it:
// the base x (1 - max3(c) E(n.v)) + c E(n.v) x the irradiance's radiance), and the
// coat over all, weighted by clearcoat Fc(n.v), with its own split sum.
vec3 ibl_split_sum(IblMaterial m, vec3 n, vec3 v) {
    float nv = clamp(dot(n, v), COS_EPS, 1.0);
    vec3 r = reflect(-v, n);
    vec3 irradiance = sh_irradiance(n) * INV_PI;     // radiance of a white Lambertian
    vec2 ab = lookup_dfg(nv, m.roughness);
    vec3 fss_ess = m.f0 * ab.x + m.f90 * ab.y;
    vec3 spec = fss_ess * prefiltered_radiance(r, m.roughness);
    vec3 albedo_spec = fss_ess;
    energy_ibl(ab, m.f0, irradiance, spec, albedo_spec);
    vec3 diffuse = sh_lobe_radiance(diffuse_ibl_moments(nv, m.diffuse_shape), n, v);
    vec3 color = spec + m.diffuse * composition_diffuse_weight(albedo_spec) * diffuse;
    float sheen_max = max(max(m.sheen_color.r, m.sheen_color.g), m.sheen_color.b);
    if (sheen_max > 0.0) {
        float e = lookup_sheen_e(nv, m.sheen_roughness);
        color = color * max(1.0 - sheen_max * e, 0.0) + m.sheen_color * e * irradiance;
    }
    if (m.clearcoat > 0.0) {
        float w = m.clearcoat * clearcoat_fresnel(nv);
        vec2 abc = lookup_dfg(nv, m.clearcoat_roughness);
        vec3 coat = (abc.x + abc.y) * prefiltered_radiance(r, m.clearcoat_roughness);
        color = color * (1.0 - w) + w * coat;
    }
    return color;
}
#endif  // BRDF_PARAMS_DECLARED
