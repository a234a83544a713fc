// Vector helpers in the local shading frame (mirrors brdf/geometry.py).
#include "common.glsl"

// A cosine clamped to [COS_EPS, 1] before it is used in a division.
float clamp_cos(float c) { return clamp(c, COS_EPS, 1.0); }

// Sum of the three products of a dot product, in the order XLA's CPU backend
// reduces a length-3 axis ((x + z) + y), with no fused multiply-add: the
// rounding then matches brdf.geometry.dot bit for bit (see shaders/parity.py).
float dot3(vec3 a, vec3 b) {
    precise float s = a.x * b.x + a.z * b.z;
    precise float t = s + a.y * b.y;
    return t;
}

// v / |v| with a tiny floor inside the root, written as brdf.geometry.normalize
// does it (the built-in normalize() may use an approximate inverse root).
vec3 normalize_safe(vec3 v) {
    return v * (1.0 / sqrt(dot3(v, v) + 1e-20));
}

// Half vector h = normalize(wi + wo).
vec3 half_vector(vec3 wi, vec3 wo) { return normalize_safe(wi + wo); }

// v in a tangent frame rotated by `angle` (radians, CCW about n):
// t' = (cos a, sin a, 0), b' = (-sin a, cos a, 0) -> (t'.v, b'.v, n.v).
vec3 rotate_tangent(vec3 v, float angle) {
    float c = cos(angle);
    float s = sin(angle);
    return vec3(c * v.x + s * v.y, -s * v.x + c * v.y, v.z);
}
