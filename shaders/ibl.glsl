// Image-based lighting: equirectangular maps, spherical-harmonics irradiance,
// the split-sum approximation and its multiple-scattering combination.
//
// - Split sum (Karis 2013, "Real shading in Unreal Engine 4"): the specular
//   integral ~ prefiltered radiance(R, r) x (F0 A + F90 B), with A, B the
//   DFG terms brdf.energy.tables() tabulates on (mu = n.v, r) and the
//   prefiltered map made by ibl_prefilter.glsl (mip level m <-> roughness
//   m / (levels - 1)).
// - Irradiance from 9 SH coefficients (Ramamoorthi & Hanrahan 2001),
//   projected and convolved in shaders/environment.py.
// - Multiple scattering (Fdez-Aguera 2019, "A multiple-scattering microfacet
//   model for real-time image-based lighting"; REFERENCE.md s.5):
//   E_ss = A + B, E_ms = 1 - E_ss, F_avg = F0 + (1 - F0)/21,
//   F_ms E_ms = F_ss E_ss F_avg E_ms / (1 - E_ms F_avg),
//   specular = F_ss E_ss prefiltered + F_ms E_ms irradiance / pi,
//   coupled diffuse k_D = rho (1 - (F_ss E_ss + F_ms E_ms)).
//
// World frame +y up; lat-long mapping as shaders/environment.py documents.
#include "fresnel.glsl"
#include "energy.glsl"
#include "clearcoat.glsl"

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

// Irradiance E(n) from the SH expansion (clamped: band-limited ringing can dip below 0).
vec3 sh_irradiance(vec3 n) {
    vec3 e = ibl_sh[0] * 0.282095
           + ibl_sh[1] * (0.488603 * n.y) + ibl_sh[2] * (0.488603 * n.z) + ibl_sh[3] * (0.488603 * n.x)
           + ibl_sh[4] * (1.092548 * n.x * n.y) + ibl_sh[5] * (1.092548 * n.y * n.z)
           + ibl_sh[6] * (0.315392 * (3.0 * n.z * n.z - 1.0)) + ibl_sh[7] * (1.092548 * n.x * n.z)
           + ibl_sh[8] * (0.546274 * (n.x * n.x - n.y * n.y));
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

// What the split sum needs to know about a material.
struct IblMaterial {
    vec3 diffuse;          // rho of the diffuse lobe (Lambert under image lighting)
    bool coupled;          // diffuse weighted by (1 - specular albedo) (coupled, glTF)
    vec3 f0;
    vec3 f90;
    float roughness;       // perceptual
    int energy;            // 0 none, 1 Kulla-Conty (-> Fdez-Aguera), 2 Turquin
    float clearcoat;
    float clearcoat_roughness;
};

// Outgoing radiance under the environment (split sum), world-space n and v.
vec3 ibl_split_sum(IblMaterial m, vec3 n, vec3 v) {
    float nv = clamp(dot(n, v), 1e-4, 1.0);
    vec3 r = reflect(-v, n);
    vec3 irradiance = sh_irradiance(n) * INV_PI;     // radiance of a white Lambertian
    vec2 ab = lookup_dfg(nv, m.roughness);
    vec3 fss_ess = m.f0 * ab.x + m.f90 * ab.y;
    vec3 spec = fss_ess * prefiltered_radiance(r, m.roughness);
    vec3 albedo_spec = fss_ess;
    if (m.energy == 1) {
        float e_ss = ab.x + ab.y;
        float e_ms = 1.0 - e_ss;
        vec3 f_avg = fresnel_schlick_average(m.f0);
        vec3 fms_ems = fss_ess * f_avg * e_ms / (1.0 - e_ms * f_avg);
        spec += fms_ems * irradiance;
        albedo_spec += fms_ems;
    } else if (m.energy == 2) {
        float e_ss = ab.x + ab.y;
        vec3 factor = 1.0 + m.f0 * (1.0 - e_ss) / e_ss;
        spec *= factor;
        albedo_spec *= factor;
    }
    vec3 kd = m.coupled ? m.diffuse * (1.0 - albedo_spec) : m.diffuse;
    vec3 color = spec + kd * irradiance;
    if (m.clearcoat > 0.0) {
        float w = m.clearcoat * clearcoat_fresnel(nv);
        vec2 abc = lookup_dfg(nv, m.clearcoat_roughness);
        vec3 coat = (abc.x + abc.y) * prefiltered_radiance(r, m.clearcoat_roughness);
        color = color * (1.0 - w) + w * coat;
    }
    return color;
}

#ifdef BRDF_PARAMS_DECLARED
// The IblMaterial of the spec's parameters (defines as in model.glsl).
// Approximations: every diffuse lobe acts as Lambert, anisotropy is ignored,
// exact dielectric / conductor Fresnel become Schlick with their F0.
IblMaterial ibl_material(BrdfParams p) {
    IblMaterial m;
    m.roughness = clamp(p.roughness, ROUGHNESS_MIN, 1.0);
    m.energy = 0;
    m.clearcoat = 0.0;
    m.clearcoat_roughness = 1.0;
    m.f90 = vec3(1.0);
    m.diffuse = vec3(0.0);
    m.coupled = false;
#ifdef BRDF_COMPOSITION_GLTF
#ifdef BRDF_PARAM_IOR
    float ior = p.ior;
#else
    float ior = IOR_DEFAULT;
#endif
#ifdef BRDF_PARAM_SPECULAR
    float specular = p.specular;
    vec3 specular_color = p.specular_color;
#else
    float specular = 1.0;
    vec3 specular_color = vec3(1.0);
#endif
    vec3 f0_dielectric = min(f0_from_ior(ior) * specular_color, vec3(1.0)) * specular;
    m.f0 = mix(f0_dielectric, p.base_color, p.metallic);
    m.f90 = mix(vec3(specular), vec3(1.0), p.metallic);
    m.diffuse = p.base_color * (1.0 - p.metallic);
    m.coupled = true;
#else
#if defined(BRDF_FRESNEL_SCHLICK)
    m.f0 = p.f0;
#elif defined(BRDF_FRESNEL_SCHLICK_F90)
    m.f0 = p.f0;
    m.f90 = vec3(p.f90);
#elif defined(BRDF_FRESNEL_DIELECTRIC)
    m.f0 = vec3(f0_from_ior(p.ior));
#else
    m.f0 = f0_from_ior(p.eta, p.k);
#endif
#ifndef BRDF_DIFFUSE_NONE
    m.diffuse = p.albedo;
#endif
#ifdef BRDF_COMPOSITION_COUPLED
    m.coupled = true;
#endif
#if defined(BRDF_ENERGY_KULLA_CONTY)
    m.energy = 1;
#elif defined(BRDF_ENERGY_TURQUIN)
    m.energy = 2;
#endif
#endif
#ifdef BRDF_CLEARCOAT
    m.clearcoat = p.clearcoat;
    m.clearcoat_roughness = clamp(p.clearcoat_roughness, ROUGHNESS_MIN, 1.0);
#endif
    return m;
}
#endif
