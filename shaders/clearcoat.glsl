// Clearcoat layer as KHR_materials_clearcoat specifies it (mirrors
// brdf/clearcoat.py; REFERENCE.md s.6):
//   coated = mix(base, coat_brdf, clearcoat Fc),
//   Fc = 0.04 + 0.96 (1 - |n_c.v|)^5 (coat IOR 1.5, Fresnel at the coat
//   normal's n.v, the extension README's implementation section),
//   coat_brdf = D V of GGX + height-correlated Smith at alpha_c =
//   clearcoatRoughness^2, no Fresnel inside.
// The layering uses n.v only, so a coated BRDF is not reciprocal (the
// specification's choice, kept so that a fit exports to glTF losslessly).
#include "specular.glsl"

// Fc = 0.04 + 0.96 (1 - |n.v|)^5.
float clearcoat_fresnel(float n_dot_v) {
    float x = 1.0 - clamp(abs(n_dot_v), 0.0, 1.0);
    float x2 = x * x;
    return F0_DIELECTRIC + (1.0 - F0_DIELECTRIC) * x2 * x2 * x;
}

// The coat's own lobe D V (1/sr), alpha_c = coat_roughness^2.
float clearcoat_brdf(float n_dot_l, float n_dot_v, float n_dot_h, float coat_roughness) {
    float alpha = coat_roughness * coat_roughness;
    return ggx_ndf(n_dot_h, alpha) * visibility_height_correlated(n_dot_l, n_dot_v, alpha);
}

// mix(base, coat_brdf, clearcoat Fc) for an RGB base.
vec3 apply_clearcoat(vec3 base, float clearcoat, float coat_roughness,
                     float n_dot_l, float n_dot_v, float n_dot_h) {
    float weight = clearcoat * clearcoat_fresnel(n_dot_v);
    float coat = clearcoat_brdf(n_dot_l, n_dot_v, n_dot_h, coat_roughness);
    return base * (1.0 - weight) + weight * coat;
}
