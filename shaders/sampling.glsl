// Sample generation for the Monte-Carlo paths (image-based lighting by
// sampling, and the prefiltering of environment maps).
//
// Hammersley points (van der Corput radical inverse in base 2) rotated per
// pixel by a hash (Cranley-Patterson rotation), cosine-weighted hemisphere
// sampling, and GGX half-vector sampling with pdf D(h) (n.h) (Walter et al.
// 2007, eq. 35-36; as in Karis 2013's prefilter).  Local frame: n = +z.
#include "specular.glsl"

// Radical inverse of i in base 2 (bit reversal).
float radical_inverse_vdc(uint bits) {
    bits = (bits << 16u) | (bits >> 16u);
    bits = ((bits & 0x55555555u) << 1u) | ((bits & 0xAAAAAAAAu) >> 1u);
    bits = ((bits & 0x33333333u) << 2u) | ((bits & 0xCCCCCCCCu) >> 2u);
    bits = ((bits & 0x0F0F0F0Fu) << 4u) | ((bits & 0xF0F0F0F0u) >> 4u);
    bits = ((bits & 0x00FF00FFu) << 8u) | ((bits & 0xFF00FF00u) >> 8u);
    return float(bits) * 2.3283064365386963e-10;   // / 2^32
}

vec2 hammersley(uint i, uint n) { return vec2((float(i) + 0.5) / float(n), radical_inverse_vdc(i)); }

// A 32-bit integer hash (Jarzynski & Olano 2020, PCG-style) -> [0, 1)^2.
uvec2 pcg2d(uvec2 v) {
    v = v * 1664525u + 1013904223u;
    v.x += v.y * 1664525u; v.y += v.x * 1664525u;
    v = v ^ (v >> 16u);
    v.x += v.y * 1664525u; v.y += v.x * 1664525u;
    v = v ^ (v >> 16u);
    return v;
}
vec2 hash2(uvec2 v) { return vec2(pcg2d(v)) * 2.3283064365386963e-10; }

// Cosine-weighted direction about +z; pdf = cos(theta) / pi.
vec3 sample_cosine(vec2 u) {
    float r = sqrt(u.x);
    float phi = 2.0 * PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), sqrt(max(0.0, 1.0 - u.x)));
}

// GGX half vector about +z with pdf D(h) (n.h): theta_h = atan(alpha sqrt(u / (1 - u))).
vec3 sample_ggx_half(vec2 u, float alpha) {
    float a = alpha_floor(alpha);
    float tan2 = a * a * u.x / max(1.0 - u.x, 1e-7);
    float cos_t = 1.0 / sqrt(1.0 + tan2);
    float sin_t = sqrt(max(0.0, 1.0 - cos_t * cos_t));
    float phi = 2.0 * PI * u.y;
    return vec3(sin_t * cos(phi), sin_t * sin(phi), cos_t);
}

// pdf (per solid angle of wi) of wi = reflect(-wo, h) with h ~ D(h) (n.h).
float pdf_ggx_reflection(vec3 wi, vec3 wo, float alpha) {
    vec3 h = normalize(wi + wo);
    float vh = dot(wo, h);
    if (h.z <= 0.0 || vh <= 0.0) return 0.0;
    return ggx_ndf(h.z, alpha) * h.z / (4.0 * vh);
}

// An orthonormal basis (t, b) around a unit n (Duff et al. 2017).
void basis_from_normal(vec3 n, out vec3 t, out vec3 b) {
    float s = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (s + n.z);
    float c = n.x * n.y * a;
    t = vec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
    b = vec3(c, s + n.y * n.y * a, -n.y);
}
