// The sheen layer of KHR_materials_sheen (mirrors brdf/sheen.py; docs/gltf.md):
// alpha = sheenRoughness^2 (floored at ALPHA_MIN),
//
//   D       = (2 + 1/alpha) sin(theta_h)^(1/alpha) / (2 pi)        Charlie (Estevez & Kulla 2017)
//   V       = min(1 / ((1 + Lambda(n.v) + Lambda(n.l)) 4 n.l n.v), 1)  the extension's Charlie
//             visibility, clamped as the glTF Sample Viewer's V_Sheen
//   f       = sheenColor D V + f_base max(0, 1 - max3(sheenColor) max(E(n.v), E(n.l)))
//
// E(mu, sheenRoughness), the lobe's directional albedo, is brdf.sheen.sheen_table(),
// uploaded by shaders.tables.table_texture() as an R32F texture (width = roughness
// nodes, height = mu nodes uniform in mu^(1/4)) and read with texelFetch and the
// bilinear weights of brdf.sheen.lookup_sheen_e, so the GPU sees the numbers JAX
// interpolates.  Powers are written exp(c log x), as in JAX.
#include "common.glsl"
#include "energy.glsl"

uniform sampler2D brdf_sheen_e;        // E[mu_j, r_k] at texel (k, j), mu_j = (j / (n - 1))^4

const float SHEEN_SIN2H_MIN = 1e-7;
const float SHEEN_LAMBDA_X_MIN = 1e-6;
const float SHEEN_ROUGHNESS_SPAN = 0.968377223398316207;   // 1 - ROUGHNESS_MIN
// Charlie's Lambda fit: each coefficient is mix(at alpha = 1, at alpha = 0, (1 - alpha)^2).
const float CHARLIE_L_ROUGH[5] = float[5](21.5473, 3.82987, 0.19823, -1.97760, -4.32054);
const float CHARLIE_L_SMOOTH[5] = float[5](25.3245, 3.32435, 0.16801, -1.27393, -4.85967);

// alpha = sheenRoughness^2, floored at ALPHA_MIN.
float sheen_alpha(float roughness) {
    float r = clamp(roughness, ROUGHNESS_MIN, 1.0);
    return max(r * r, ALPHA_MIN);
}

// Charlie: D = (2 + 1/alpha) sin(theta_h)^(1/alpha) / (2 pi).
float charlie_ndf(float n_dot_h, float alpha) {
    float inv = 1.0 / alpha;
    float c = clamp(n_dot_h, 0.0, 1.0);
    precise float sin2 = max(1.0 - c * c, SHEEN_SIN2H_MIN);
    return (2.0 + inv) * exp(0.5 * inv * log(sin2)) * (0.5 * INV_PI);
}

// The extension's l(x, alphaG) = a / (1 + b x^c) + d x + e.
float charlie_l(float x, float alpha) {
    float t = (1.0 - alpha) * (1.0 - alpha);
    float k[5];
    for (int i = 0; i < 5; ++i) {
        k[i] = CHARLIE_L_ROUGH[i] + (CHARLIE_L_SMOOTH[i] - CHARLIE_L_ROUGH[i]) * t;
    }
    float xs = max(x, SHEEN_LAMBDA_X_MIN);
    return k[0] / (1.0 + k[1] * exp(k[2] * log(xs))) + k[3] * xs + k[4];
}

// Lambda: exp(l(cos)) below cos 0.5, exp(2 l(0.5) - l(1 - cos)) above.
float charlie_lambda(float cos_theta, float alpha) {
    float c = clamp(abs(cos_theta), 0.0, 1.0);
    bool low = c < 0.5;
    float l_x = charlie_l(low ? c : 1.0 - c, alpha);      // one l per direction: l(cos) or l(1 - cos)
    return exp(low ? l_x : 2.0 * charlie_l(0.5, alpha) - l_x);
}

// V = min(1 / ((1 + Lambda(n.v) + Lambda(n.l)) 4 n.l n.v), 1).
float charlie_visibility(float n_dot_l, float n_dot_v, float alpha) {
    float nl = clamp(n_dot_l, SHEEN_LAMBDA_X_MIN, 1.0);
    float nv = clamp(n_dot_v, SHEEN_LAMBDA_X_MIN, 1.0);
    float lam = charlie_lambda(nv, alpha) + charlie_lambda(nl, alpha);
    return min(1.0 / ((1.0 + lam) * (4.0 * nl * nv)), 1.0);
}

// D V of the sheen lobe (times sheenColor: f_sheen).
float sheen_dv(float n_dot_h, float n_dot_l, float n_dot_v, float roughness) {
    float alpha = sheen_alpha(roughness);
    return charlie_ndf(n_dot_h, alpha) * charlie_visibility(n_dot_l, n_dot_v, alpha);
}

// E(mu, sheenRoughness), bilinear in (mu^(1/4), r).
float lookup_sheen_e(float mu, float roughness) {
    ivec2 size = textureSize(brdf_sheen_e, 0);
    int i, k;
    float fi, fk;
    energy_interp_coord(sqrt(sqrt(clamp(mu, 0.0, 1.0))) * float(size.y - 1), size.y, i, fi);
    energy_interp_coord((roughness - ROUGHNESS_MIN) * (1.0 / SHEEN_ROUGHNESS_SPAN) * float(size.x - 1),
                       size.x, k, fk);
    float e00 = texelFetch(brdf_sheen_e, ivec2(k, i), 0).r;
    float e01 = texelFetch(brdf_sheen_e, ivec2(k + 1, i), 0).r;
    float e10 = texelFetch(brdf_sheen_e, ivec2(k, i + 1), 0).r;
    float e11 = texelFetch(brdf_sheen_e, ivec2(k + 1, i + 1), 0).r;
    precise float e0 = (1.0 - fk) * e00 + fk * e01;
    precise float e1 = (1.0 - fk) * e10 + fk * e11;
    precise float e = (1.0 - fi) * e0 + fi * e1;
    return e;
}

// sheenColor D V + base max(0, 1 - max3(sheenColor) max(E(n.v), E(n.l))): the extension's
// albedo-scaling layering over the glTF material `base`.
vec3 sheen_layer(vec3 base, vec3 sheen_color, float sheen_roughness, float n_dot_l, float n_dot_v,
                 float n_dot_h) {
    float e_v = lookup_sheen_e(clamp(n_dot_v, 0.0, 1.0), sheen_roughness);
    float e_l = lookup_sheen_e(clamp(n_dot_l, 0.0, 1.0), sheen_roughness);
    float c_max = max(max(sheen_color.r, sheen_color.g), sheen_color.b);
    float scaling = max(1.0 - c_max * max(e_v, e_l), 0.0);
    return sheen_color * sheen_dv(n_dot_h, n_dot_l, n_dot_v, sheen_roughness) + base * scaling;
}
