// GGX prefiltering of a lat-long environment for the split sum (Karis 2013):
// with n = v = r, prefiltered(r) = sum L(l) (n.l) / sum (n.l) over half
// vectors h ~ D(h)(n.h), l = reflect(-v, h).  Each sample reads the source's
// mip chain at the level whose texel matches the sample's solid angle
// (filtered importance sampling, Krivanek & Colbert 2008), which keeps a few
// hundred samples free of fireflies.
//
// Two entry points around the same prefilter_texel (shaders/scene.py picks):
//   PREFILTER_COMPUTE   a compute shader writing one mip level as an image
//                       (OpenGL 4.3)
//   (otherwise)         a fragment shader drawn over a full-screen triangle
//                       into a float target of the level's size (OpenGL 3.3);
//                       gl_FragCoord.xy = texel + 0.5, the compute path's texel.
#include "sampling.glsl"
#include "ibl.glsl"

uniform float prefilter_roughness;
uniform uint prefilter_samples;
uniform float prefilter_source_texel_solid_angle;   // 4 pi / (W H) of source level 0
uniform float prefilter_source_max_lod;

// Prefiltered radiance of texel `px` of a `size` lat-long level.
vec3 prefilter_texel(ivec2 px, ivec2 size) {
    vec3 n = equirect_to_dir((vec2(px) + 0.5) / vec2(size));
    vec3 t, b;
    basis_from_normal(n, t, b);
    float alpha = prefilter_roughness * prefilter_roughness;
    vec3 sum = vec3(0.0);
    float weight = 0.0;
    for (uint i = 0u; i < prefilter_samples; ++i) {
        vec3 hl = sample_ggx_half(hammersley(i, prefilter_samples), alpha);
        vec3 h = t * hl.x + b * hl.y + n * hl.z;
        vec3 l = 2.0 * dot(n, h) * h - n;
        float nl = dot(n, l);
        if (nl <= 0.0) continue;
        // pdf of l: D(h) (n.h) / (4 v.h) with v = n, so D / 4
        float pdf = ggx_ndf(hl.z, alpha) * 0.25;
        float omega_s = 1.0 / (float(prefilter_samples) * pdf + 1e-6);
        float lod = clamp(0.5 * log2(omega_s / prefilter_source_texel_solid_angle) + 1.0,
                          0.0, prefilter_source_max_lod);
        sum += textureLod(ibl_environment, dir_to_equirect(l), lod).rgb * nl;
        weight += nl;
    }
    return sum / max(weight, 1e-6);
}

#ifdef PREFILTER_COMPUTE
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba32f, binding = 0) writeonly uniform image2D prefilter_target;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(prefilter_target);
    if (px.x >= size.x || px.y >= size.y) return;
    imageStore(prefilter_target, px, vec4(prefilter_texel(px, size), 1.0));
}
#else
uniform ivec2 prefilter_size;        // of the level being drawn
out vec4 frag_color;

void main() {
    frag_color = vec4(prefilter_texel(ivec2(gl_FragCoord.xy), prefilter_size), 1.0);
}
#endif
