"""The default loss and its gradient as a handful of fused sums, for the engine models.

``jax.value_and_grad`` of the plain loss (``fit._objective``) is the
reference, and stays the path for every spec.  On XLA:CPU its backward pass
writes some forty sample-sized arrays per call; for the specs below the
gradient has a closed structure that needs none of them.  Per sample and
channel c,

    base_c = albedo_c B(r) + DV(r) (f0_c (1 - s5) + f90 s5) + M(r) K_c(f0_c, r)
    f_c    = base_c (1 - cc Fc) + cc Fc C(rc),        s5 = (1 - v.h)^5

with B the diffuse lobe for albedo 1, DV the GGX lobe's D V, M the
Kulla-Conty lobe and K_c its colour (a number per channel), C the clearcoat
lobe and Fc its Fresnel at the outgoing direction (so the two orientations of
a pair differ when coated).  With the log loss's per-sample sensitivities
h1 = 2 w r1 n.l / (1 + f1 n.l) and h2 = 2 w r2 n.v / (1 + f2 n.v) of the two
orientations, G = h1 (1 - cc Fc(n.v)) + h2 (1 - cc Fc(n.l)) is the
sensitivity to base_c and every partial is one weighted sum: dS_c/d albedo_c
= sum G B, dS_c/d f0_c = sum G DV (1 - s5) + dK_c/df0_c sum G M, ... and the
roughness partials use forward-mode derivatives (jax.jvp) of the model's own
lobe functions.  XLA fuses each sum with the model evaluation it needs; tests
hold the result to jax.grad of the plain loss.

Which specs this covers is declared with the terms (``Term.fused``, brdf/):
an isotropic NDF with either masking, Schlick F0 (and F90), any diffuse lobe
of the form albedo x a factor of the roughness, the additive composition,
Kulla-Conty compensation or none, with or without the clearcoat.  With
``switched``, the same sums for every model of a family root's program
(fitting/family.py): the diffuse lobe is a runtime switch, F90 held at 1
where a model lacks it.
"""

from collections.abc import Callable

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from brdf.clearcoat import clearcoat_brdf, clearcoat_fresnel
from brdf.energy import kulla_conty_fresnel_factor, kulla_conty_lobe, lookup_e_avg
from brdf.fresnel import fresnel_schlick_average
from brdf.model import ModelSpec, diffuse_lobe, has_diffuse, roughness_alpha, specular_dv, terms

from . import family
from .losses import log1p
from .transforms import to_params


def supports(spec: ModelSpec, loss: str) -> bool:
    """True when ``value_and_grad`` below covers (spec, loss): the log loss and
    every term of the spec declared ``fused``."""
    return loss == "log" and all(term.fused for term in terms(spec))


def value_and_grad(spec: ModelSpec, switched: bool = False
                   ) -> Callable[..., tuple[Float[Array, ""], Float[Array, " n"], Float[Array, "3"]]]:
    """(u, SampleSet) -> (loss, d loss / du, per-channel mean square error): the same
    numbers as jax.value_and_grad of the plain log loss (and fit.channel_errors),
    for a spec ``supports`` accepts.  ``switched``: (u, switches, SampleSet) for a
    family root (``family.Variant.switches``)."""
    multiple = spec.energy == "kulla_conty"
    diffuse = has_diffuse(spec)

    def lobes(params, geo, raw_roughness):
        """The roughness-dependent per-sample lobes: DV, B (albedo 1) and M (or 0)."""
        roughness, alpha = roughness_alpha(raw_roughness)
        dv = specular_dv(spec, params, geo, alpha)
        zero = jnp.zeros_like(dv)
        b = diffuse_lobe(spec, dict(params, albedo=1.0), geo, roughness, alpha) if diffuse else zero
        m = kulla_conty_lobe(geo.n_dot_l, geo.n_dot_v, roughness) if multiple else zero
        return dv, b, m

    def colour(f0_c, raw_roughness):
        """K_c: the Kulla-Conty lobe's colour for one channel."""
        roughness, _ = roughness_alpha(raw_roughness)
        return kulla_conty_fresnel_factor(fresnel_schlick_average(f0_c), lookup_e_avg(roughness))

    def loss_and_grad(u, switches, data):
        if switched:
            params, pull = jax.vjp(lambda u: family.held(spec, u, switches), u)
            lobe_params = family.with_switches(params, switches)
        else:
            params, pull = jax.vjp(lambda u: to_params(spec, u), u)
            lobe_params = params
        geo = data.geo
        r = params["roughness"]
        (dv, b, m), (ddv, db, dm) = jax.jvp(lambda r: lobes(lobe_params, geo, r), (r,), (jnp.ones_like(r),))
        x = 1.0 - jnp.clip(geo.v_dot_h, 0.0, 1.0)
        s5 = x * x * x * x * x
        f90 = params.get("f90", 1.0)
        albedo = params["albedo"] if diffuse else jnp.zeros(3, u.dtype)
        nl, nv = geo.n_dot_l, geo.n_dot_v
        w = jnp.where((nl > 0.0) & (nv > 0.0), data.weights, 0.0)   # the model is 0 below the horizon
        if spec.clearcoat:
            cc, rc = params["clearcoat"], params["clearcoat_roughness"]
            coat, dcoat = jax.jvp(lambda rc: clearcoat_brdf(nl, nv, geo.n_dot_h, rc), (rc,), (jnp.ones_like(rc),))
            fc_v, fc_l = clearcoat_fresnel(nv), clearcoat_fresnel(nl)
            keep_v, keep_l = 1.0 - cc * fc_v, 1.0 - cc * fc_l
        rows = []
        for c in range(3):
            f0_c = params["f0"][c]
            fresnel = f0_c * (1.0 - s5) + f90 * s5
            base = albedo[c] * b + dv * fresnel
            r_lobes = albedo[c] * db + ddv * fresnel       # d base / d roughness, per sample
            if multiple:
                k_c, (dk_df0, dk_dr) = colour(f0_c, r), jax.grad(colour, argnums=(0, 1))(f0_c, r)
                base = base + m * k_c
                r_lobes = r_lobes + dm * k_c
            if spec.clearcoat:
                f1 = base * keep_v + cc * fc_v * coat      # orientation (wi, wo): Fc at n.v
                f2 = base * keep_l + cc * fc_l * coat      # orientation (wo, wi): Fc at n.l
            else:
                f1 = f2 = base
            y1, y2 = f1 * nl, f2 * nv
            r1 = log1p(y1) - data.log_i[:, c]
            r2 = log1p(y2) - data.log_o[:, c]
            h1 = 2.0 * w * r1 * nl / (1.0 + y1)
            h2 = 2.0 * w * r2 * nv / (1.0 + y2)
            g = h1 * keep_v + h2 * keep_l if spec.clearcoat else h1 + h2
            row = {"S": jnp.sum(w * (r1 * r1 + r2 * r2)),
                   "albedo": jnp.sum(g * b),
                   "f0": jnp.sum(g * dv * (1.0 - s5)),
                   "f90": jnp.sum(g * dv * s5),
                   "roughness": jnp.sum(g * r_lobes)}
            if multiple:      # K_c is one number per channel: its partials multiply one sum
                gm = jnp.sum(g * m)
                row["f0"] = row["f0"] + dk_df0 * gm
                row["roughness"] = row["roughness"] + dk_dr * gm
            if spec.clearcoat:
                hc = h1 * fc_v + h2 * fc_l
                row["clearcoat"] = jnp.sum(hc * (coat - base))
                row["clearcoat_roughness"] = cc * jnp.sum(hc * dcoat)
            rows.append(row)
        sums = {k: jnp.stack([row[k] for row in rows]) for k in rows[0]}
        rms = jnp.sqrt(sums["S"])
        dloss_ds = 0.5 / rms / 3.0            # loss = mean_c sqrt(S_c)
        cotangent = {name: dloss_ds * sums[name] if jnp.ndim(value) else jnp.sum(dloss_ds * sums[name])
                     for name, value in params.items()}
        return jnp.mean(rms), pull(cotangent)[0], sums["S"]

    if switched:
        return jax.jit(loss_and_grad)
    return jax.jit(lambda u, data: loss_and_grad(u, None, data))
