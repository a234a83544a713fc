// Measured BRDF tables, looked up on the GPU (docs/data-formats.md).  The tables
// are RGB32F textures that shaders/measured.py fills from numpy (no dependency
// on data_loaders), read with texelFetch: exact float values, no filtering,
// available from OpenGL 3.3 fragment shaders and 4.3 compute shaders alike.
//
// MERL (Matusik et al. 2003; reader readBRDF.cpp): 90 x 90 x 180 cells over
// (theta_h, theta_d, phi_d), RGB interleaved here and already in 1/sr
// (raw x (1/1500, 1.15/1500, 1.66/1500); invalid cells 0).  Standard lookup:
// i_th = floor(sqrt(theta_h / (pi/2)) 90), i_td = floor(theta_d / (pi/2) 90),
// phi_d < 0 -> phi_d + pi (reciprocity), i_pd = floor(phi_d / pi 180), all
// clamped; flat = i_pd + 180 i_td + 16200 i_th.
//
// UTIA (Filip & Vavra 2014): [c][theta_i 6][phi_i 48][theta_v 6][phi_v 48],
// flat = c 82944 + 288 (48 i_ti + i_pi) + 48 i_tv + i_pv, quadrilinear as in
// Filip's TBRDF.cpp: theta i0 = min(floor(theta / 15), 4), w1 = (theta - 15 i0)/15
// (extrapolates above 75 deg), phi i0 = floor(phi / 7.5), index 48 wraps to 0.
// Azimuths are signed angles in the tangent frame, atan2(y, x) mapped to
// [0, 360) - not acos-based azimuths, which lose the sign (anisotropy).
//
// Angles come from atan2_accurate (common.glsl): llvmpipe's acos/atan are
// too coarse next to the cell edges.
#include "common.glsl"

// MERL: texel (i_pd, i_td, i_th) of a 180 x 90 x 90 3D texture holds the RGB of
// cell flat = i_pd + 180 i_td + 16200 i_th (the table's own memory order).
uniform sampler3D measured_merl;
// UTIA: texel (48 i_tv + i_pv, 48 i_ti + i_pi) of a 288 x 288 2D texture holds
// the RGB of [c][i_ti][i_pi][i_tv][i_pv].
uniform sampler2D measured_utia;

const int MERL_THETA_H = 90;
const int MERL_THETA_D = 90;
const int MERL_PHI_D = 180;
const int UTIA_THETA = 6;
const int UTIA_PHI = 48;
const float UTIA_THETA_STEP_DEG = 15.0;
const float UTIA_PHI_STEP_DEG = 7.5;

uniform int utia_decode;   // 0: raw values, 1: dj_brdf decoding after interpolation

// Rusinkiewicz half/difference angles: (theta_h, phi_h, theta_d, phi_d).
vec4 std_to_half_diff(vec3 wi, vec3 wo) {
    vec3 h = normalize(wi + wo);
    float theta_h = atan2_accurate(length(h.xy), h.z);
    float phi_h = atan2_accurate(h.y, h.x);
    float cp = cos(phi_h), sp = sin(phi_h);
    float ct = h.z, st = length(h.xy);          // cos / sin of theta_h
    float x = cp * wi.x + sp * wi.y;            // R_z(-phi_h) wi
    float y = -sp * wi.x + cp * wi.y;
    float z = wi.z;
    float dx = ct * x - st * z;                 // R_y(-theta_h)
    float dz = st * x + ct * z;
    float theta_d = atan2_accurate(length(vec2(dx, y)), dz);
    float phi_d = atan2_accurate(y, dx);
    return vec4(theta_h, phi_h, theta_d, phi_d);
}

ivec3 merl_index(float theta_h, float theta_d, float phi_d) {
    float th = theta_h <= 0.0 ? 0.0 : sqrt(theta_h / (0.5 * PI)) * float(MERL_THETA_H);
    int i_th = clamp(int(floor(th)), 0, MERL_THETA_H - 1);
    int i_td = clamp(int(floor(theta_d / (0.5 * PI) * float(MERL_THETA_D))), 0, MERL_THETA_D - 1);
    float pd = phi_d < 0.0 ? phi_d + PI : phi_d;
    int i_pd = clamp(int(floor(pd / PI * float(MERL_PHI_D))), 0, MERL_PHI_D - 1);
    return ivec3(i_th, i_td, i_pd);
}

// MERL BRDF (1/sr) at a direction pair; 0 when either is at or below the horizon.
vec3 merl_lookup(vec3 wi, vec3 wo) {
    if (wi.z <= 0.0 || wo.z <= 0.0) return vec3(0.0);
    vec4 hd = std_to_half_diff(wi, wo);
    ivec3 i = merl_index(hd.x, hd.z, hd.w);
    return texelFetch(measured_merl, ivec3(i.z, i.y, i.x), 0).rgb;
}

// Filip's interpolation nodes on one axis: (i0, i1) and weight of i1.
void utia_theta_nodes(float theta_deg, out int i0, out int i1, out float w1) {
    i0 = min(int(floor(theta_deg / UTIA_THETA_STEP_DEG)), UTIA_THETA - 2);
    i1 = i0 + 1;
    w1 = (theta_deg - UTIA_THETA_STEP_DEG * float(i0)) / UTIA_THETA_STEP_DEG;
}
void utia_phi_nodes(float phi_deg, out int i0, out int i1, out float w1) {
    i0 = clamp(int(floor(phi_deg / UTIA_PHI_STEP_DEG)), 0, UTIA_PHI - 1);
    i1 = (i0 + 1) % UTIA_PHI;
    w1 = (phi_deg - UTIA_PHI_STEP_DEG * float(i0)) / UTIA_PHI_STEP_DEG;
}

// Signed azimuth of a direction in the tangent frame, degrees in [0, 360).
float azimuth_deg(vec3 w) {
    float a = degrees(atan2_accurate(w.y, w.x));
    a = a < 0.0 ? a + 360.0 : a;
    return a >= 360.0 ? 0.0 : a;
}

vec3 utia_decode_dj_brdf(vec3 v) {
    vec3 x = max(v, vec3(0.0));
    vec3 high = pow((x + 0.055) / 1.055, vec3(2.4));
    return max(mix(v / 12.92, high, step(vec3(0.0375), v)) * 100.0, vec3(0.0));
}

// UTIA BRDF at a direction pair (Filip's quadrilinear interpolation).
vec3 utia_lookup(vec3 wi, vec3 wo) {
    if (wi.z < 0.0 || wo.z < 0.0) return vec3(0.0);
    int ti[2], pi_[2], tv[2], pv[2];
    float wti[2], wpi[2], wtv[2], wpv[2];
    float w;
    utia_theta_nodes(degrees(atan2_accurate(length(wi.xy), wi.z)), ti[0], ti[1], w);
    wti[0] = 1.0 - w; wti[1] = w;
    utia_phi_nodes(azimuth_deg(wi), pi_[0], pi_[1], w);
    wpi[0] = 1.0 - w; wpi[1] = w;
    utia_theta_nodes(degrees(atan2_accurate(length(wo.xy), wo.z)), tv[0], tv[1], w);
    wtv[0] = 1.0 - w; wtv[1] = w;
    utia_phi_nodes(azimuth_deg(wo), pv[0], pv[1], w);
    wpv[0] = 1.0 - w; wpv[1] = w;
    vec3 sum = vec3(0.0);
    for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b)
    for (int c = 0; c < 2; ++c)
    for (int d = 0; d < 2; ++d) {
        float weight = wti[a] * wpi[b] * wtv[c] * wpv[d];
        ivec2 texel = ivec2(UTIA_PHI * tv[c] + pv[d], UTIA_PHI * ti[a] + pi_[b]);
        sum += weight * texelFetch(measured_utia, texel, 0).rgb;
    }
    return utia_decode == 1 ? utia_decode_dj_brdf(sum) : sum;
}
