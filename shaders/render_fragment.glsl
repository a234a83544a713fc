// Fragment stage of the preview renderer (included after the code that
// defines `vec3 shade_brdf(vec3 wi, vec3 wo)` in the local frame: a spec's
// brdf_evaluate or a measured lookup).
//
//   RENDER_IBL_SPLIT_SUM   environment by the split sum (ibl.glsl; models only)
//   RENDER_IBL_SAMPLED     environment by Monte-Carlo integration of shade_brdf:
//                          cosine + GGX(alpha hint) sampling, balance heuristic,
//                          filtered lookups; the same per-pixel sample pattern
//                          for every material, so measured and fitted renders
//                          differ by their BRDFs, not by their noise
//   (neither)              analytic lights only
//
// Point lights (inverse-square falloff) and directional lights are evaluated
// with shade_brdf exactly in every mode.  No shadows.
#include "ibl.glsl"
#include "sampling.glsl"
#include "lights.glsl"

in vec3 v_position;
in vec3 v_normal;
in vec3 v_tangent;
out vec4 frag_color;

uniform vec3 camera_position;
uniform uint ibl_samples;              // per strategy (sampled mode)
uniform float ibl_alpha_hint;          // GGX lobe used for importance sampling
uniform float env_texel_solid_angle;   // 4 pi / (W H) of the environment's level 0
uniform float env_max_lod;

#ifdef RENDER_IBL_SAMPLED
// One balance-heuristic term: f L cos / (p_cos + p_ggx), the lookup level
// matched to the sample's share of the sphere.
vec3 mis_term(vec3 wi, vec3 wo, mat3 to_world, float count) {
    float p = wi.z * INV_PI + pdf_ggx_reflection(wi, wo, ibl_alpha_hint);
    if (wi.z <= 0.0 || p <= 0.0) return vec3(0.0);
    float omega = 1.0 / (count * p);
    float lod = clamp(0.5 * log2(omega / env_texel_solid_angle), 0.0, env_max_lod);
    vec3 radiance = environment_radiance(to_world * wi, lod);
    return shade_brdf(wi, wo) * radiance * (wi.z / p);
}

vec3 ibl_sampled(vec3 wo, mat3 to_world) {
    uint n = max(ibl_samples, 1u);
    vec2 rotation = hash2(uvec2(gl_FragCoord.xy));
    vec3 sum = vec3(0.0);
    for (uint i = 0u; i < n; ++i) {
        vec2 u = fract(hammersley(i, n) + rotation);
        sum += mis_term(sample_cosine(u), wo, to_world, float(n));
        vec3 h = sample_ggx_half(fract(u + vec2(0.5, 0.5)), ibl_alpha_hint);
        sum += mis_term(2.0 * dot(wo, h) * h - wo, wo, to_world, float(n));
    }
    return sum / float(n);
}
#endif

void main() {
    vec3 n = normalize(v_normal);
    vec3 v = normalize(camera_position - v_position);
    // Interpolated normals can face away from the viewer at silhouettes:
    // bend them just enough to see the surface at a grazing angle.
    float nv = dot(n, v);
    if (nv < 1e-3) n = normalize(n + (1e-3 - nv) * v);
    vec3 t = normalize(v_tangent - n * dot(n, v_tangent));
    vec3 b = cross(n, t);
    mat3 to_world = mat3(t, b, n);          // local (t, b, n) -> world
    mat3 to_local = transpose(to_world);
    vec3 wo = to_local * v;
    vec3 color = vec3(0.0);
    for (int i = 0; i < n_point_lights; ++i) {
        vec3 l = point_light_position[i] - v_position;
        float d2 = dot(l, l);
        vec3 wi = to_local * (l * inversesqrt(d2));
        if (wi.z > 0.0) color += shade_brdf(wi, wo) * point_light_intensity[i] * (wi.z / d2);
    }
    for (int i = 0; i < n_directional_lights; ++i) {
        vec3 wi = to_local * directional_light_direction[i];
        if (wi.z > 0.0) color += shade_brdf(wi, wo) * directional_light_irradiance[i] * wi.z;
    }
#if defined(RENDER_IBL_SPLIT_SUM)
    color += ibl_split_sum(ibl_material(material), n, v);
#elif defined(RENDER_IBL_SAMPLED)
    color += ibl_sampled(wo, to_world);
#endif
    frag_color = vec4(color, 1.0);
}
