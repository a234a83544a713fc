// The composition of a BRDF model from a ModelSpec (mirrors brdf/model.py's
// evaluate()).  Which terms are compiled in is chosen by the #defines that
// shaders.library.defines_for(spec) generates from the same ModelSpec:
//
//   BRDF_NDF_{GGX, GGX_ANISO}          BRDF_MASKING_{HEIGHT_CORRELATED, SEPARABLE}
//   BRDF_FRESNEL_{SCHLICK, SCHLICK_F90, DIELECTRIC, CONDUCTOR}
//   BRDF_DIFFUSE_{NONE, LAMBERT, BURLEY, FROSTBITE, COD_WWII, OREN_NAYAR}
//   BRDF_COMPOSITION_{ADDITIVE, COUPLED, GLTF}
//   BRDF_ENERGY_{NONE, KULLA_CONTY, TURQUIN}
//   BRDF_ANISOTROPY_{KULLA_CONTY, GLTF}  BRDF_CLEARCOAT  BRDF_GLTF_EXTENSIONS_{IOR, SPECULAR}
//   BRDF_PARAM_<NAME> for every entry of spec.schema()
//
// and the parameters arrive in `struct BrdfParams`, whose members (and their
// std140 layout) shaders.library generates from spec.schema(): the uniform
// block of the renderer and the per-pair buffer of the parity harness share it.
//
// Compositions
//   additive  f = D V F + f_diffuse
//   coupled   f = D V F + (1 - F(v.h)) f_diffuse
//   gltf      the glTF 2.0 metallic-roughness BRDF: gltf_combine of the
//             spec's D V (gltf.glsl)
#include "specular.glsl"
#include "fresnel.glsl"
#include "diffuse.glsl"
#include "energy.glsl"
#include "clearcoat.glsl"
#include "gltf.glsl"

#ifndef BRDF_PARAMS_DECLARED
#error "model.glsl needs the struct BrdfParams that shaders.library.header(spec) generates"
#endif

// D V of the specular lobe (isotropic or anisotropic, either masking); the
// glTF composition uses it too (its spec has height-correlated masking and,
// with "aniso", the KHR remap).
float brdf_specular_dv(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float alpha) {
#ifdef BRDF_NDF_GGX_ANISO
#ifdef BRDF_ANISOTROPY_GLTF
    vec2 ab = anisotropy_gltf(alpha, p.anisotropy);
#else
    vec2 ab = anisotropy_kulla_conty(alpha, p.anisotropy);
#endif
    vec3 l = rotate_tangent(wi, p.rotation);
    vec3 v = rotate_tangent(wo, p.rotation);
    vec3 hr = rotate_tangent(h, p.rotation);
#ifdef BRDF_MASKING_SEPARABLE
    return ggx_ndf_aniso(hr, ab.x, ab.y) * visibility_separable_aniso(l, v, ab.x, ab.y);
#else
    return ggx_ndf_aniso(hr, ab.x, ab.y) * visibility_height_correlated_aniso(l, v, ab.x, ab.y);
#endif
#else
#ifdef BRDF_MASKING_SEPARABLE
    return ggx_ndf(h.z, alpha) * visibility_separable(wi.z, wo.z, alpha);
#else
    return ggx_ndf(h.z, alpha) * visibility_height_correlated(wi.z, wo.z, alpha);
#endif
#endif
}

#ifndef BRDF_COMPOSITION_GLTF

// RGB Fresnel at v.h and the normal-incidence F0 (for energy compensation).
vec3 brdf_fresnel(BrdfParams p, float v_dot_h, out vec3 f0) {
#if defined(BRDF_FRESNEL_SCHLICK)
    f0 = p.f0;
    return fresnel_schlick(p.f0, v_dot_h);
#elif defined(BRDF_FRESNEL_SCHLICK_F90)
    f0 = p.f0;
    return fresnel_schlick(p.f0, v_dot_h, vec3(p.f90));
#elif defined(BRDF_FRESNEL_DIELECTRIC)
    f0 = vec3(f0_from_ior(p.ior));
    return vec3(fresnel_dielectric(v_dot_h, p.ior));
#else
    f0 = f0_from_ior(p.eta, p.k);
    return fresnel_conductor(v_dot_h, p.eta, p.k);
#endif
}

#ifndef BRDF_DIFFUSE_NONE
// The diffuse lobe named by the spec (l.h is taken as v.h, equal by symmetry,
// as brdf.model does).
vec3 brdf_diffuse_lobe(BrdfParams p, vec3 wi, vec3 wo, vec3 h, float v_dot_h,
                       float roughness, float alpha) {
    float nl = wi.z, nv = wo.z, lh = v_dot_h;
#if defined(BRDF_DIFFUSE_LAMBERT)
    return lambert(p.albedo, nl, nv);
#elif defined(BRDF_DIFFUSE_BURLEY)
    return burley(p.albedo, roughness, nl, nv, lh);
#elif defined(BRDF_DIFFUSE_FROSTBITE)
    return frostbite(p.albedo, roughness, nl, nv, lh);
#elif defined(BRDF_DIFFUSE_COD_WWII)
    return cod_wwii(p.albedo, alpha, nl, nv, lh, h.z);
#else
    return oren_nayar(p.albedo, p.sigma, wi, wo);
#endif
}
#endif

#endif  // !BRDF_COMPOSITION_GLTF

// The BRDF of the spec (RGB, 1/sr, without the cosine) at one direction pair
// in the local frame; 0 when either direction is at or below the horizon.
vec3 brdf_evaluate(BrdfParams p, vec3 wi, vec3 wo) {
    float roughness = clamp(p.roughness, ROUGHNESS_MIN, 1.0);
    float alpha = max(roughness * roughness, ALPHA_MIN);
    float nl = wi.z, nv = wo.z;
    vec3 h = half_vector(wi, wo);
    float v_dot_h = dot3(wo, h);
    vec3 f;
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
    float dv = brdf_specular_dv(p, wi, wo, h, alpha);
    f = gltf_combine(dv, v_dot_h, p.base_color, p.metallic, ior, specular, specular_color);
#else
    vec3 f0;
    vec3 fresnel = brdf_fresnel(p, v_dot_h, f0);
    f = brdf_specular_dv(p, wi, wo, h, alpha) * fresnel;
#if defined(BRDF_ENERGY_KULLA_CONTY)
    f = f + kulla_conty(nl, nv, roughness, fresnel_schlick_average(f0));
#elif defined(BRDF_ENERGY_TURQUIN)
    f = f * turquin_factor(nv, roughness, f0);
#endif
#ifndef BRDF_DIFFUSE_NONE
    vec3 fd = brdf_diffuse_lobe(p, wi, wo, h, v_dot_h, roughness, alpha);
#ifdef BRDF_COMPOSITION_COUPLED
    fd = fd * (1.0 - fresnel);
#endif
    f = f + fd;
#endif
#endif
#ifdef BRDF_CLEARCOAT
    f = apply_clearcoat(f, p.clearcoat, p.clearcoat_roughness, nl, nv, h.z);
#endif
    return (nl > 0.0 && nv > 0.0) ? f : vec3(0.0);
}
