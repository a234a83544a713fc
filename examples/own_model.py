"""A model of your own: a normalised Blinn-Phong lobe beside a Lambertian (docs/models.md).

    brdf-fit fit TABLE.binary --model examples/own_model.py:BLINN_PHONG_LAMBERT

    f = rho_d / pi + k_s (n + 2) / (2 pi) max(0, n.h)^n           (1/sr, without the cosine)

the Blinn-Phong lobe normalised as an NDF (Blinn 1977; the normalisation
integral (n+2)/(2 pi) (n.h)^n (n.h) dw_h = 1), written here with nothing
but JAX so that it shows what a user writes: the toolkit's own
``blinn_phong+lambert`` (brdf/lobes.py) is the same formula with its
exponent from a roughness.  GLSL below is its twin, which the preview
renderer draws (the report's lit spheres, ``brdf-fit render``).
"""

import jax.numpy as jnp

from brdf.own import OwnModel, Param, Start


def blinn_phong_lambert(p, wi, wo):
    """(..., 3) directions -> (..., 3) RGB BRDF; p: {"diffuse_albedo": (3,), "specular": (3,), "exponent": ()}."""
    h = wi + wo
    h = h / jnp.linalg.norm(h, axis=-1, keepdims=True)
    n_dot_h = jnp.clip(h[..., 2], 1e-6, 1.0)
    lobe = (p["exponent"] + 2.0) / (2.0 * jnp.pi) * jnp.exp(p["exponent"] * jnp.log(n_dot_h))
    return p["diffuse_albedo"] / jnp.pi + p["specular"] * lobe[..., None]


# The same function in GLSL: p holds the parameters by name (float for size 1, vec3 for
# size 3).  half_vector (normalize(wi + wo) rounded as JAX rounds it: an ulp of n.h is
# 6e-4 of the lobe at n = 10000) and log_cosine (log, accurate near 1 where GLSL's is
# not) come from the toolkit's GLSL library, PI from its constants.
GLSL = """
vec3 own_brdf(BrdfParams p, vec3 wi, vec3 wo) {
    vec3 h = half_vector(wi, wo);
    float n_dot_h = clamp(h.z, 1e-6, 1.0);
    float lobe = (p.exponent + 2.0) / (2.0 * PI) * exp(p.exponent * log_cosine(n_dot_h));
    return p.diffuse_albedo / PI + p.specular * lobe;
}
"""

BLINN_PHONG_LAMBERT = OwnModel(
    "blinn_phong_lambert",
    (Param("diffuse_albedo", 3, 0.0, 1.0, 0.3, "rho_d, the Lambertian albedo",
           start=Start(rule=lambda e: e.albedo)),
     Param("specular", 3, 0.0, 1.0, 0.05, "k_s, the lobe's scale"),
     Param("exponent", 1, 1.0, 10000.0, 100.0, "n, the Blinn-Phong exponent",
           start=Start(scan=(10.0, 100.0, 1000.0)))),
    blinn_phong_lambert,
    glsl=GLSL,
    description="normalised Blinn-Phong + Lambert (the example of docs/models.md)",
)
