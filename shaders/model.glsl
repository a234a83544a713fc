// The composition of a BRDF model from a ModelSpec (mirrors brdf/model.py's
// evaluate_geometry).
//
// Configuration: shaders.library.header(spec) defines BRDF_<FIELD>_<VALUE> for
// every field of the ModelSpec (brdf/model.py lists the values),
// BRDF_PARAM_<NAME> for every entry of spec.schema(), and `struct BrdfParams`,
// whose members (and their std140 layout) it generates from spec.schema(): the
// renderer's uniform block and the parity harness's per-pair buffer share it.
//
// Terms: each value of a field is one #if block in its term's file, which
// defines the field's function (fixed signature) for it; this file calls them
// and names no option but the composition's:
//
//   field              file            function
//   ndf, masking,      specular.glsl   specular_dv(p, wi, wo, h, alpha), or for a
//                                      classic lobe model specular_lobe(p, wi, wo, h, alpha)
//     anisotropy
//   fresnel            fresnel.glsl    fresnel_term(p, v_dot_h), fresnel_f0(p)
//   diffuse            diffuse.glsl    diffuse_lobe(p, wi, wo, h, v_dot_h, roughness, alpha)
//   energy             energy.glsl     energy_compensate(f_ss, n_dot_l, n_dot_v, roughness, f0)
//   clearcoat          clearcoat.glsl  clearcoat_layer(p, base, n_dot_l, n_dot_v, n_dot_h)
//   gltf_extensions    gltf.glsl       gltf_material(p, wi, wo, dv, v_dot_h)
//   composition        openpbr.glsl    openpbr_material(p, wi, wo, dv, v_dot_h, alpha) (OpenPBR's
//                                      metal and non-metal)
//   composition        here            composition_diffuse_weight(specular)
//
// ibl.glsl's ibl_material reads the same files' image-lighting functions.
//
// A model of one's own (brdf/own.py, shaders/own_glsl.py): BRDF_OWN_MODEL, its
// BrdfParams generated from its Params (without BRDF_PARAMS_DECLARED: no term
// file's block is its), and its glsl= source, appended after the program by
// shaders.library.build_source, defining own_brdf, which is its brdf_evaluate.
#include "specular.glsl"
#include "fresnel.glsl"
#include "diffuse.glsl"
#include "energy.glsl"
#include "clearcoat.glsl"
#include "gltf.glsl"
#include "openpbr.glsl"
#include "principled.glsl"

#if defined(BRDF_OWN_MODEL)
// The user's function (its glsl=, compiled after this file): the BRDF in the local
// frame, RGB, 1/sr, without the cosine, as its JAX evaluate.
vec3 own_brdf(BrdfParams p, vec3 wi, vec3 wo);

// 0 when either direction is at or below the horizon, as brdf.model.evaluate.
vec3 brdf_evaluate(BrdfParams p, vec3 wi, vec3 wo) {
    return (wi.z > 0.0 && wo.z > 0.0) ? own_brdf(p, wi, wo) : vec3(0.0);
}
#elif !defined(BRDF_PARAMS_DECLARED)
#error "model.glsl needs the struct BrdfParams that shaders.library.header(spec) generates"
#endif

// --- a built-in model: its composition of the terms ---------------------------------
#ifdef BRDF_PARAMS_DECLARED

// --- compositions -----------------------------------------------------------------
// How the diffuse lobe is weighted by the specular reflectance above it: F(v.h)
// for a direction pair, the specular albedo under image lighting (ibl.glsl).
//   additive  f = D V F + f_diffuse
//   coupled   f = D V F + (1 - F(v.h)) f_diffuse
//   gltf      the glTF 2.0 metallic-roughness BRDF: gltf_material (gltf.glsl)
//   openpbr, openpbr_nonmetal   OpenPBR Surface's metal, non-metal: openpbr_material (openpbr.glsl)
//   openpbr_metal_coat, openpbr_nonmetal_coat   either under its coat: the same
//   openpbr_nonmetal_fuzz   the non-metal under its fuzz: the same
//   openpbr_*_mx   each in MaterialX's reading: its twin's symbol, defined by openpbr.glsl
//   principled_nonmetal, principled_*_coat, principled_nonmetal_sheen, principled_*_ms   Blender's
//                  Principled BSDF as Cycles draws it: the same (principled.glsl)
// (every one but gltf is common.glsl's BRDF_FIXED_LOBES)
#if defined(BRDF_COMPOSITION_ADDITIVE)
vec3 composition_diffuse_weight(vec3 specular) { return vec3(1.0); }
#elif defined(BRDF_COMPOSITION_COUPLED)
vec3 composition_diffuse_weight(vec3 specular) { return 1.0 - specular; }
#elif !defined(BRDF_COMPOSITION_GLTF) && !defined(BRDF_FIXED_LOBES)
#error "model.glsl has no block for the spec's composition (BRDF_COMPOSITION_*)"
#endif

// --- the BRDF ---------------------------------------------------------------------

// The BRDF of the spec (RGB, 1/sr, without the cosine) at one direction pair
// in the local frame; 0 when either direction is at or below the horizon.
vec3 brdf_evaluate(BrdfParams p, vec3 wi, vec3 wo) {
    float roughness = clamp(p.roughness, ROUGHNESS_MIN, 1.0);
    float alpha = max(roughness * roughness, ALPHA_MIN);
    vec3 h = half_vector(wi, wo);
    float v_dot_h = dot3(wo, h);
#if defined(BRDF_LOBE_MODEL)
    // a classic lobe model: its own specular term, no masking or Fresnel (specular.glsl)
    vec3 f = specular_lobe(p, wi, wo, h, alpha) + diffuse_lobe(p, wi, wo, h, v_dot_h, roughness, alpha);
#elif defined(BRDF_COMPOSITION_GLTF)
    vec3 f = gltf_material(p, wi, wo, specular_dv(p, wi, wo, h, alpha), v_dot_h);
#elif defined(BRDF_FIXED_LOBES)
    vec3 f = openpbr_material(p, wi, wo, specular_dv(p, wi, wo, h, alpha), v_dot_h, alpha);
#else
    float dv = specular_dv(p, wi, wo, h, alpha);
    vec3 fresnel = fresnel_term(p, v_dot_h);
    vec3 f = energy_compensate(dv * fresnel, wi.z, wo.z, roughness, fresnel_f0(p));
    f = f + diffuse_lobe(p, wi, wo, h, v_dot_h, roughness, alpha) * composition_diffuse_weight(fresnel);
#endif
    f = clearcoat_layer(p, f, wi.z, wo.z, h.z);
    return (wi.z > 0.0 && wo.z > 0.0) ? f : vec3(0.0);
}

#endif  // BRDF_PARAMS_DECLARED
