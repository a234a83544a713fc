"""A model of your own: a normalised Blinn-Phong lobe beside a Lambertian (docs/models.md).

    brdf-fit fit TABLE.binary --model examples/own_model.py:BLINN_PHONG_LAMBERT

    f = rho_d / pi + k_s (n + 2) / (2 pi) max(0, n.h)^n           (1/sr, without the cosine)

the Blinn-Phong lobe normalised as an NDF (Blinn 1977; the normalisation
integral (n+2)/(2 pi) (n.h)^n (n.h) dw_h = 1), written here with nothing
but JAX so that it shows what a user writes: the toolkit's own
``blinn_phong+lambert`` (brdf/lobes.py) is the same formula with its
exponent from a roughness.
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


BLINN_PHONG_LAMBERT = OwnModel(
    "blinn_phong_lambert",
    (Param("diffuse_albedo", 3, 0.0, 1.0, 0.3, "rho_d, the Lambertian albedo",
           start=Start(rule=lambda e: e.albedo)),
     Param("specular", 3, 0.0, 1.0, 0.05, "k_s, the lobe's scale"),
     Param("exponent", 1, 1.0, 10000.0, 100.0, "n, the Blinn-Phong exponent",
           start=Start(scan=(10.0, 100.0, 1000.0)))),
    blinn_phong_lambert,
    description="normalised Blinn-Phong + Lambert (the example of docs/models.md)",
)
