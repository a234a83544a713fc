// The glTF 2.0 metallic-roughness BRDF, exactly as the specification writes it
// (mirrors brdf/gltf.py; glTF 2.0 Appendix B with KHR_materials_ior,
// KHR_materials_specular, KHR_materials_anisotropy, for the diffuse lobe
// KHR_materials_diffuse_roughness drawn as EON (diffuse.glsl), and the sheen
// layer of KHR_materials_sheen over it all (sheen.glsl); docs/gltf.md):
//
//   fresnel_w  = (1 - |v.h|)^5
//   f0         = min(F0(ior) specularColor, 1) specular,   f90 = specular
//   F          = mix(f0, f90, fresnel_w)                     (RGB)
//   dielectric = F D V + (1 - max(F)) baseColor / pi
//   metal      = (baseColor + (1 - baseColor) fresnel_w) D V
//   material   = mix(dielectric, metal, metallic)
//
// GLSL has no default arguments: the defaults of brdf.gltf.gltf_brdf are
// ior = IOR_DEFAULT, specular = 1, specular_color = vec3(1); the anisotropic
// lobe has its own *_aniso functions.
#include "specular.glsl"
#include "fresnel.glsl"
#include "diffuse.glsl"
#include "energy.glsl"
#include "sheen.glsl"

// D V of the isotropic glTF lobe.
float gltf_specular_dv(vec3 wi, vec3 wo, float roughness) {
    float alpha = roughness * roughness;
    vec3 h = half_vector(wi, wo);
    return ggx_ndf(h.z, alpha) * visibility_height_correlated(wi.z, wo.z, alpha);
}

// D V of KHR_materials_anisotropy's lobe: alpha_t = mix(alpha, 1, s^2) along
// the tangent rotated by `anisotropy_rotation` (radians, CCW), alpha_b = alpha.
float gltf_specular_dv_aniso(vec3 wi, vec3 wo, float roughness,
                             float anisotropy_strength, float anisotropy_rotation) {
    float alpha = roughness * roughness;
    vec3 h = half_vector(wi, wo);
    vec2 ab = anisotropy_gltf(alpha, anisotropy_strength);
    vec3 l = rotate_tangent(wi, anisotropy_rotation);
    vec3 v = rotate_tangent(wo, anisotropy_rotation);
    vec3 hr = rotate_tangent(h, anisotropy_rotation);
    return ggx_ndf_aniso(hr, ab.x, ab.y) * visibility_height_correlated_aniso(l, v, ab.x, ab.y);
}

// The glTF metal (metallic 1) from its specular D V and v.h.
vec3 gltf_metal(float dv, float v_dot_h, vec3 base_color) {
    float fw = pow5(1.0 - clamp(abs(v_dot_h), 0.0, 1.0));
    return (base_color + (1.0 - base_color) * fw) * dv;
}

// The glTF material from its specular D V, v.h (|v.h| is taken here) and the
// diffuse lobe of albedo baseColor (baseColor / pi: Lambert's).
vec3 gltf_combine(float dv, float v_dot_h, vec3 base_color, float metallic,
                  float ior, float specular, vec3 specular_color, vec3 diffuse) {
    float fw = pow5(1.0 - clamp(abs(v_dot_h), 0.0, 1.0));
    vec3 f0 = min(f0_from_ior(ior) * specular_color, vec3(1.0)) * specular;
    vec3 fresnel = f0 + (specular - f0) * fw;
    float f_max = max(max(fresnel.r, fresnel.g), fresnel.b);
    vec3 dielectric = fresnel * dv + (1.0 - f_max) * diffuse;
    vec3 metal = gltf_metal(dv, v_dot_h, base_color);
    return dielectric + (metal - dielectric) * metallic;
}

// The glTF BRDF (RGB, 1/sr, without the cosine).
vec3 gltf_brdf(vec3 wi, vec3 wo, vec3 base_color, float metallic, float roughness,
               float ior, float specular, vec3 specular_color) {
    float dv = gltf_specular_dv(wi, wo, roughness);
    float v_dot_h = dot3(wo, half_vector(wi, wo));
    return gltf_combine(dv, v_dot_h, base_color, metallic, ior, specular, specular_color,
                        base_color * INV_PI);
}
vec3 gltf_brdf(vec3 wi, vec3 wo, vec3 base_color, float metallic, float roughness) {
    return gltf_brdf(wi, wo, base_color, metallic, roughness, IOR_DEFAULT, 1.0, vec3(1.0));
}

// The glTF BRDF with KHR_materials_anisotropy.
vec3 gltf_brdf_aniso(vec3 wi, vec3 wo, vec3 base_color, float metallic, float roughness,
                     float ior, float specular, vec3 specular_color,
                     float anisotropy_strength, float anisotropy_rotation) {
    float dv = gltf_specular_dv_aniso(wi, wo, roughness, anisotropy_strength, anisotropy_rotation);
    float v_dot_h = dot3(wo, half_vector(wi, wo));
    return gltf_combine(dv, v_dot_h, base_color, metallic, ior, specular, specular_color,
                        base_color * INV_PI);
}

// --- the spec's glTF material -----------------------------------------------------
// The glTF composition (BRDF_COMPOSITION_GLTF) fixes its Fresnel and diffuse
// terms, so it defines here what fresnel.glsl / diffuse.glsl define for the
// other compositions; one block per value of ModelSpec.gltf_extensions
// (BRDF_GLTF_EXTENSIONS_<VALUE>) gives its parameter or the core default.
//   vec3 gltf_material(BrdfParams p, vec3 wi, vec3 wo, float dv, float v_dot_h)
//       the BRDF (model.glsl)
//   vec3 fresnel_f0(p), fresnel_f90(p), diffuse_albedo(p), diffuse_ibl_shape(p),
//   diffuse_ibl_moments(n_dot_v, x) (Lambert's), composition_diffuse_weight(albedo)
//       the material under image lighting (ibl.glsl), as the glTF sample
//       viewer does: Schlick with f0 = mix(f0_dielectric, baseColor, metallic),
//       f90 = mix(specular, 1, metallic), rho = baseColor (1 - metallic),
//       weighted by 1 - the specular albedo.
#if defined(BRDF_PARAMS_DECLARED) && defined(BRDF_COMPOSITION_GLTF)

#ifdef BRDF_GLTF_EXTENSIONS_METAL
float gltf_metallic(BrdfParams p) { return 1.0; }
#elif defined(BRDF_GLTF_EXTENSIONS_NONMETAL)
float gltf_metallic(BrdfParams p) { return 0.0; }
#else
float gltf_metallic(BrdfParams p) { return p.metallic; }
#endif

#ifdef BRDF_GLTF_EXTENSIONS_IOR
float gltf_ior(BrdfParams p) { return p.ior; }
#else
float gltf_ior(BrdfParams p) { return IOR_DEFAULT; }
#endif

#ifdef BRDF_GLTF_EXTENSIONS_SPECULAR
float gltf_specular(BrdfParams p) { return p.specular; }
vec3 gltf_specular_color(BrdfParams p) { return p.specular_color; }
#elif defined(BRDF_GLTF_EXTENSIONS_TINT)
float gltf_specular(BrdfParams p) { return 1.0; }
vec3 gltf_specular_color(BrdfParams p) { return p.specular_color; }
#else
float gltf_specular(BrdfParams p) { return 1.0; }
vec3 gltf_specular_color(BrdfParams p) { return vec3(1.0); }
#endif

#ifdef BRDF_GLTF_EXTENSIONS_DIFFUSE_ROUGHNESS
vec3 gltf_diffuse(BrdfParams p, vec3 wi, vec3 wo) {
    return eon(p.base_color, p.diffuse_roughness, wi.z, wo.z, dot3(wi, wo));
}
#else
vec3 gltf_diffuse(BrdfParams p, vec3 wi, vec3 wo) { return p.base_color * INV_PI; }
#endif

#ifdef BRDF_GLTF_EXTENSIONS_SHEEN
vec3 gltf_sheen(BrdfParams p, vec3 f, vec3 wi, vec3 wo) {
    return sheen_layer(f, p.sheen_color, p.sheen_roughness, wi.z, wo.z, half_vector(wi, wo).z);
}
#else
vec3 gltf_sheen(BrdfParams p, vec3 f, vec3 wi, vec3 wo) { return f; }
#endif

vec3 fresnel_f0(BrdfParams p) {
    vec3 f0_dielectric = min(f0_from_ior(gltf_ior(p)) * gltf_specular_color(p), vec3(1.0)) * gltf_specular(p);
    return mix(f0_dielectric, p.base_color, gltf_metallic(p));
}

vec3 gltf_material(BrdfParams p, vec3 wi, vec3 wo, float dv, float v_dot_h) {
    // The specular lobe times energy.glsl's factor: 1, or in the engines' reading (+turquin)
    // Turquin's 1 + F0 (1/E(n.v) - 1) at the blended F0 (three.js r187's direct light;
    // brdf/gltf.py).  gltf_combine is linear in D V and the diffuse together.
    vec3 k = energy_specular_factor(wo.z, clamp(p.roughness, ROUGHNESS_MIN, 1.0), fresnel_f0(p));
#ifdef BRDF_GLTF_EXTENSIONS_METAL
    vec3 f = gltf_metal(dv, v_dot_h, p.base_color) * k;    // (the mix at metallic 1 cancels in float32)
#else
    vec3 f = gltf_combine(dv, v_dot_h, p.base_color, gltf_metallic(p), gltf_ior(p), gltf_specular(p),
                          gltf_specular_color(p), vec3(0.0)) * k
             + gltf_combine(0.0, v_dot_h, p.base_color, gltf_metallic(p), gltf_ior(p), gltf_specular(p),
                            gltf_specular_color(p), gltf_diffuse(p, wi, wo));
#endif
    return gltf_sheen(p, f, wi, wo);
}
vec3 fresnel_f90(BrdfParams p) { return mix(vec3(gltf_specular(p)), vec3(1.0), gltf_metallic(p)); }
vec3 diffuse_albedo(BrdfParams p) { return p.base_color * (1.0 - gltf_metallic(p)); }
float diffuse_ibl_shape(BrdfParams p) { return 0.0; }
DiffuseMoments diffuse_ibl_moments(float n_dot_v, float x) { return lambert_moments(); }
vec3 composition_diffuse_weight(vec3 specular_albedo) { return 1.0 - specular_albedo; }

#endif  // BRDF_PARAMS_DECLARED && BRDF_COMPOSITION_GLTF

// KHR_materials_sheen's values under image lighting (ibl.glsl's split sum; colour 0,
// for every model without +sheen: no sheen).
#ifdef BRDF_PARAMS_DECLARED
#ifdef BRDF_GLTF_EXTENSIONS_SHEEN
vec3 sheen_ibl_color(BrdfParams p) { return p.sheen_color; }
float sheen_ibl_roughness(BrdfParams p) { return p.sheen_roughness; }
#elif defined(BRDF_COMPOSITION_OPENPBR_NONMETAL_FUZZ) || defined(BRDF_COMPOSITION_OPENPBR_NONMETAL_FUZZ_MX) \
      || defined(BRDF_COMPOSITION_PRINCIPLED_NONMETAL_SHEEN)
// OpenPBR's fuzz and the Principled BSDF's sheen under image lighting (openpbr.glsl, principled.glsl):
// drawn as this sheen of fuzz_weight fuzz_color
vec3 sheen_ibl_color(BrdfParams p) { return p.fuzz_weight * p.fuzz_color; }
float sheen_ibl_roughness(BrdfParams p) { return p.fuzz_roughness; }
#else
vec3 sheen_ibl_color(BrdfParams p) { return vec3(0.0); }
float sheen_ibl_roughness(BrdfParams p) { return 1.0; }
#endif
#endif  // BRDF_PARAMS_DECLARED
