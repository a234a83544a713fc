"""The default loss and its gradient as a handful of fused sums, for the engine models.

``jax.value_and_grad`` of the plain loss (``fit._objective``) is the
reference, and stays the path for every spec.  On XLA:CPU its backward pass
writes some forty sample-sized arrays per call; for the specs below the
gradient has a closed structure that needs none of them:

    f_c = albedo_c B(r) + DV(r) (f0_c (1 - s5) + f90 s5),   s5 = (1 - v.h)^5

with B the diffuse lobe for albedo 1 and DV the GGX lobe's D V, both
functions of the roughness r only (per sample).  With the log loss's
per-sample sensitivity g_c = dS_c/df_c = 2 w (r1 n.l / (1 + f n.l) + r2 n.v / (1 + f n.v))
every partial is one weighted sum: dS_c/d albedo_c = sum g_c B, dS_c/d f0_c =
sum g_c DV (1 - s5), dS/d f90 = sum g_c DV s5 and dS/dr = sum g_c (albedo_c B'
+ DV' F_c), where B' and DV' are forward-mode derivatives (jax.jvp) of the
model's own term functions.  XLA fuses each sum with the model evaluation it
needs; tests hold the result to jax.grad of the plain loss.
"""

import jax
import jax.numpy as jnp

from brdf.model import _diffuse_lobe, _specular_dv, roughness_alpha

from .losses import log1p
from .transforms import to_params

DIFFUSES = ("none", "lambert", "burley", "frostbite", "cod_wwii")


def supports(spec, loss):
    """True when ``value_and_grad`` below covers (spec, loss)."""
    return (loss == "log" and spec.ndf == "ggx" and spec.fresnel in ("schlick", "schlick_f90")
            and spec.diffuse in DIFFUSES and spec.composition == "additive"
            and spec.energy == "none" and not spec.clearcoat)


def value_and_grad(spec):
    """(u, SampleSet) -> (loss, d loss / du, per-channel mean square error): the same
    numbers as jax.value_and_grad of the plain log loss (and fit.channel_errors),
    for a spec ``supports`` accepts."""
    def lobes(params, geo, raw_roughness):
        roughness, alpha = roughness_alpha(raw_roughness)
        dv = _specular_dv(spec, params, geo, alpha)
        if spec.diffuse == "none":
            return dv, jnp.zeros_like(dv)
        return dv, _diffuse_lobe(spec, dict(params, albedo=1.0), geo, roughness, alpha)

    def loss_and_grad(u, data):
        params, pull = jax.vjp(lambda u: to_params(spec, u), u)
        geo = data.geo
        r = params["roughness"]
        (dv, b), (ddv, db) = jax.jvp(lambda r: lobes(params, geo, r), (r,), (jnp.ones_like(r),))
        x = 1.0 - jnp.clip(geo.v_dot_h, 0.0, 1.0)
        s5 = x * x * x * x * x
        f90 = params.get("f90", 1.0)
        albedo = params["albedo"] if spec.diffuse != "none" else jnp.zeros(3, u.dtype)
        nl, nv = geo.n_dot_l, geo.n_dot_v
        w = jnp.where((nl > 0.0) & (nv > 0.0), data.weights, 0.0)   # the model is 0 below the horizon
        sums = {"S": [], "albedo": [], "f0": [], "f90": [], "roughness": []}
        for c in range(3):
            fresnel = params["f0"][c] * (1.0 - s5) + f90 * s5
            f = albedo[c] * b + dv * fresnel
            y1, y2 = f * nl, f * nv
            r1 = log1p(y1) - data.log_i[:, c]
            r2 = log1p(y2) - data.log_o[:, c]
            g = 2.0 * w * (r1 * nl / (1.0 + y1) + r2 * nv / (1.0 + y2))
            sums["S"].append(jnp.sum(w * (r1 * r1 + r2 * r2)))
            sums["albedo"].append(jnp.sum(g * b))
            sums["f0"].append(jnp.sum(g * dv * (1.0 - s5)))
            sums["f90"].append(jnp.sum(g * dv * s5))
            sums["roughness"].append(jnp.sum(g * (albedo[c] * db + ddv * fresnel)))
        sums = {k: jnp.stack(v) for k, v in sums.items()}
        rms = jnp.sqrt(sums["S"])
        dloss_ds = 0.5 / rms / 3.0            # loss = mean_c sqrt(S_c)
        partial = {name: dloss_ds * sums[name] for name in ("albedo", "f0", "f90", "roughness")}
        cotangent = {name: (partial[name] if jnp.ndim(value) else jnp.sum(partial[name]))
                     for name, value in params.items()}
        return jnp.mean(rms), pull(cotangent)[0], sums["S"]

    return jax.jit(loss_and_grad)
