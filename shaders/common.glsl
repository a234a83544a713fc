// Named constants shared by the JAX models (brdf/constants.py) and the GLSL
// library.  Same names, same values: tests/test_shaders_library.py parses both
// files and compares them.  Conventions (docs/models.md#conventions): local frame n = +z,
// t = +x, b = +y; wi (to the light) and wo (to the viewer) point away from the
// surface; BRDFs are returned without the cosine factor, in 1/sr.

const float PI = 3.14159265358979323846;
const float INV_PI = 0.318309886183790671538;

// Floor on alpha = roughness^2 that every D and G term sees (glTF: never
// evaluate alpha = 0).
const float ALPHA_MIN = 1e-3;
const float ROUGHNESS_MIN = 0.0316227766016837933;   // sqrt(ALPHA_MIN)

// Cosines are clamped to at least this before they divide anything.
const float COS_EPS = 1e-4;

// Normal-incidence reflectance of a dielectric of IOR 1.5 (glTF's default).
const float F0_DIELECTRIC = 0.04;
const float IOR_DEFAULT = 1.5;

// (1 - x)^5 and friends are written as products (pow() is exp2(y log2 x) on
// most GPUs: inexact, and undefined for x = 0).
float pow5(float x) { float x2 = x * x; return x2 * x2 * x; }
vec3 pow5(vec3 x) { vec3 x2 = x * x; return x2 * x2 * x; }

// --- accurate transcendentals --------------------------------------------------
// Mesa's llvmpipe evaluates atan() with an absolute error of ~3e-6 and tan()
// near pi/2 with ~1e-4 relative error; Oren-Nayar (full) needs better.  These
// follow the Cephes single-precision algorithms (Moshier): range reduction,
// then the minimax polynomials of atanf / tanf; 2-3 ulp over their range.

// atan(t) for t in [0, 1].
float atan_unit(float t) {
    bool reduce = t > 0.41421356;                       // tan(pi/8)
    float x = reduce ? (t - 1.0) / (t + 1.0) : t;
    float z = x * x;
    float p = ((((8.05374449538e-2 * z - 1.38776856032e-1) * z + 1.99777106478e-1) * z
                - 3.33329491539e-1) * z * x + x);
    return reduce ? 0.25 * PI + p : p;
}

// atan2(y, x) in (-pi, pi], as numpy / JAX define it (0 at the origin).
float atan2_accurate(float y, float x) {
    float ax = abs(x), ay = abs(y);
    float a = 0.0;
    if (ay > ax) {
        a = 0.5 * PI - atan_unit(ax / ay);
    } else if (ax > 0.0) {
        a = atan_unit(ay / ax);
    }
    if (x < 0.0) a = PI - a;
    return y < 0.0 ? -a : a;
}

// tan(x), with the argument reduced by pi/4 in three parts (Cody-Waite).
float tan_accurate(float x) {
    float s = x < 0.0 ? -1.0 : 1.0;
    float ax = abs(x);
    int j = int(ax * (4.0 / PI));
    j += j & 1;
    float y = float(j);
    float z = ((ax - y * 0.78515625) - y * 2.4187564849853515625e-4) - y * 3.77489497744594108e-8;
    float zz = z * z;
    float r = ax > 1e-4
        ? (((((9.38540185543e-3 * zz + 3.11992232697e-3) * zz + 2.44301354525e-2) * zz
              + 5.34112807005e-2) * zz + 1.33387994085e-1) * zz + 3.33331568548e-1) * zz * z + z
        : z;
    if ((j & 2) != 0) r = -1.0 / r;
    return s * r;
}

// --- the compositions that fix their terms ------------------------------------
// glTF's (gltf.glsl), OpenPBR's (openpbr.glsl) and the Principled BSDF's (principled.glsl)
// compositions fix their Fresnel, and the non-metals their diffuse, and the coated ones the
// coat's image-lighting pair: fresnel.glsl, diffuse.glsl and clearcoat.glsl step aside for
// them, model.glsl hands them to openpbr_material.  Named once here: a new fixed composition
// goes into each list that holds it, its _MX twin too (openpbr.glsl maps those to their twins
// later); tests/test_shaders_structure.py holds the lists to brdf.principled.FIXED_COMPOSITIONS.
#if defined(BRDF_COMPOSITION_OPENPBR_NONMETAL) || defined(BRDF_COMPOSITION_OPENPBR_NONMETAL_MX) \
    || defined(BRDF_COMPOSITION_OPENPBR_NONMETAL_COAT) || defined(BRDF_COMPOSITION_OPENPBR_NONMETAL_COAT_MX) \
    || defined(BRDF_COMPOSITION_OPENPBR_NONMETAL_FUZZ) || defined(BRDF_COMPOSITION_OPENPBR_NONMETAL_FUZZ_MX) \
    || defined(BRDF_COMPOSITION_PRINCIPLED_NONMETAL) || defined(BRDF_COMPOSITION_PRINCIPLED_NONMETAL_COAT) \
    || defined(BRDF_COMPOSITION_PRINCIPLED_NONMETAL_SHEEN) || defined(BRDF_COMPOSITION_PRINCIPLED_NONMETAL_MS)
#define BRDF_FIXED_NONMETAL 1
#endif
#if defined(BRDF_COMPOSITION_OPENPBR_METAL_COAT) || defined(BRDF_COMPOSITION_OPENPBR_METAL_COAT_MX) \
    || defined(BRDF_COMPOSITION_OPENPBR_NONMETAL_COAT) || defined(BRDF_COMPOSITION_OPENPBR_NONMETAL_COAT_MX) \
    || defined(BRDF_COMPOSITION_PRINCIPLED_METAL_COAT) || defined(BRDF_COMPOSITION_PRINCIPLED_NONMETAL_COAT)
#define BRDF_FIXED_COAT 1
#endif
#if defined(BRDF_FIXED_NONMETAL) || defined(BRDF_FIXED_COAT) || defined(BRDF_COMPOSITION_OPENPBR) \
    || defined(BRDF_COMPOSITION_OPENPBR_METAL_MX) || defined(BRDF_COMPOSITION_PRINCIPLED_METAL_MS)
#define BRDF_FIXED_LOBES 1       // openpbr_material draws the BRDF (openpbr.glsl, principled.glsl)
#endif
