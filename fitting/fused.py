"""The default loss and its gradient as a handful of fused sums, for the engine and glTF models.

``jax.value_and_grad`` of the plain loss (``fit._objective``) is the
reference, and stays the path for every spec.  On XLA:CPU its backward pass
writes some forty sample-sized arrays per call; for the specs below the
gradient has a closed structure that needs none of them.  Per sample and
channel c the BRDF before the coat is a sum of a few per-sample *lobes*
phi_j (functions of the geometry and the roughness) times per-channel
*coefficients* k_cj (functions of the parameters only):

    base_c = sum_j k_cj phi_j,       f_c = base_c (1 - cc Fc) + cc Fc C(rc)

additive (s5 = (1 - v.h)^5, B the diffuse lobe for albedo 1, DV the GGX
lobe's D V, M the Kulla-Conty lobe, K_c its colour):

    phi = (DV (1 - s5), DV s5, B, M),     k_c = (f0_c, f90, albedo_c, K_c(f0_c, r))

gltf (brdf/gltf.py; F0 = min(F0(ior) specularColor, 1) specular, s =
specular, m = metallic, b_c = baseColor; the max over RGB of the Fresnel is
the Fresnel of the largest F0, as every channel's is affine in s5 with the
same end s):

    phi = (DV (1 - s5), DV s5, 1 - s5, s5)
    k_c = ((1 - m) F0_c + m b_c, (1 - m) s + m, (1 - m) b_c/pi (1 - max F0), (1 - m) b_c/pi (1 - s))

C is the clearcoat lobe and Fc its Fresnel at the outgoing direction (so the
two orientations of a pair differ when coated).  With the log loss's
per-sample sensitivities h1 = 2 w r1 n.l / (1 + f1 n.l) and h2 = 2 w r2 n.v /
(1 + f2 n.v) of the two orientations, G = h1 (1 - cc Fc(n.v)) + h2 (1 - cc
Fc(n.l)) is the sensitivity to base_c, and the loss's partials are a few
weighted sums: dS_c/dk_cj = sum G phi_j (carried back to the parameters by
jax.vjp of the coefficients), dS_c/dr = sum G sum_j k_cj dphi_j/dr (the
lobes' forward-mode derivative, jax.jvp), and the coat's two.  The hybrid
loss's image term (fitting.image_error) takes the same sums over the image's
(light, view) pairs, with G the sensitivity of the image error to each pair's
f (jax.grad of the small per-pixel part: tone map, Delta E_ITP, RMS) in place of
the log residuals'; the lobes are evaluated once on the table's pairs followed
by the image's, and one set of sums runs over both (the lobes' code is in the
program once: about a quarter less to compile than a second evaluation for the
image).  XLA fuses each sum with the model evaluation it needs; tests hold the
result to jax.grad of the plain loss.

Which specs this covers is declared with the terms (``Term.fused``, brdf/):
an isotropic NDF with either masking, Schlick F0 (and F90), any diffuse lobe
of the form albedo x a factor of the roughness, the additive composition
with Kulla-Conty compensation or none, the glTF composition with its ior
and specular extensions and in the engines' reading (+turquin: two lobes more,
the first two times 1/E - 1 at the viewer's n, ``Oriented`` as they differ
between a pair's orientations), with or without the clearcoat.  With ``switched``,
the same sums for every model of a family root's program
(fitting/family.py): the diffuse lobe is a runtime switch, F90 (glTF's
specular) held at its neutral value where a model lacks it, a Kulla-Conty
root's compensation switched off (M = 0) for a model without it.
"""

import functools
import operator
import typing
from collections.abc import Callable

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from brdf.clearcoat import clearcoat_brdf, clearcoat_fresnel
from brdf.constants import IOR_DEFAULT
from brdf.energy import ENERGIES, kulla_conty_fresnel_factor, kulla_conty_lobe, lookup_e, lookup_e_avg
from brdf.fresnel import f0_from_ior, fresnel_schlick_average
from brdf.model import (SWITCHES, ModelSpec, diffuse_lobe, energy_switched, has_diffuse, held_values, roughness_alpha,
                        specular_dv, terms)

from . import family
from .image_error import image_term
from .losses import log1p
from .stored import stored_jit
from .transforms import to_params


def supports(spec: ModelSpec, loss: str) -> bool:
    """True when ``value_and_grad`` below covers (spec, loss): the log loss and every term
    of the spec declared ``fused`` (and Turquin's in the glTF composition: ``_gltf``)."""
    return loss == "log" and all(term.fused or (spec.composition == "gltf" and term is ENERGIES["turquin"])
                                 for term in terms(spec))


class Oriented(typing.NamedTuple):
    """A per-sample quantity that differs between a pair's orientations (wi, wo) and (wo, wi) (a
    lobe that is not reciprocal: glTF's engines' reading); elsewhere one array serves both."""
    first: jax.Array
    second: jax.Array


def _side(x, second):
    """x in the orientation (wi, wo) or, ``second``, (wo, wi)."""
    return (x.second if second else x.first) if isinstance(x, Oriented) else x


class _Coat(typing.NamedTuple):
    """The clearcoat's per-sample lobe C, its roughness derivative and Fresnel weights."""
    weight: jax.Array
    lobe: jax.Array
    d_lobe: jax.Array
    fc_v: jax.Array
    fc_l: jax.Array
    keep_v: jax.Array
    keep_l: jax.Array


def _coat(params, geo):
    """The coat's per-sample quantities for the parameters' clearcoat and its roughness."""
    cc, rc = params["clearcoat"], params["clearcoat_roughness"]
    nl, nv = geo.n_dot_l, geo.n_dot_v
    lobe, d_lobe = jax.jvp(lambda rc: clearcoat_brdf(nl, nv, geo.n_dot_h, rc), (rc,), (jnp.ones_like(rc),))
    fc_v, fc_l = clearcoat_fresnel(nv), clearcoat_fresnel(nl)
    return _Coat(cc, lobe, d_lobe, fc_v, fc_l, 1.0 - cc * fc_v, 1.0 - cc * fc_l)


def _coated(base, coat, at_v):
    """f of one orientation: the base under the coat (or none), whose Fresnel is
    at n.v for the orientation (wi, wo) (``at_v``), at n.l for (wo, wi)."""
    if coat is None:
        return base
    fc, keep = (coat.fc_v, coat.keep_v) if at_v else (coat.fc_l, coat.keep_l)
    return base * keep + coat.weight * fc * coat.lobe


def _partials(h1, h2, base, r_base, factors, coat):
    """The sums of one channel's partials, given each pair's sensitivity to f in
    the orientation (wi, wo) (``h1``) and, or None, in (wo, wi) (``h2``): d/d
    roughness through the base (``r_base`` = d base / d roughness), the coat's
    two, and sum G x1 x2 ... for each ``factors`` entry (name -> (x1, x2, ...)),
    G being the sensitivity to the base (any of base, r_base and the x may be ``Oriented``)."""
    g1 = h1 if coat is None else h1 * coat.keep_v
    g2 = None if h2 is None else (h2 if coat is None else h2 * coat.keep_l)

    def total(*xs):
        """sum G x1 x2 ... over both orientations (one sum: the oriented factors weigh each side's)."""
        oriented = [x for x in xs if isinstance(x, Oriented)]
        if g2 is None or not oriented:
            g = g1 if g2 is None else g1 + g2
            return jnp.sum(functools.reduce(operator.mul, [_side(x, False) for x in xs], g))
        g = (g1 * functools.reduce(operator.mul, [x.first for x in oriented])
             + g2 * functools.reduce(operator.mul, [x.second for x in oriented]))
        return jnp.sum(functools.reduce(operator.mul, [x for x in xs if not isinstance(x, Oriented)], g))
    row = {**{name: total(*xs) for name, xs in factors.items()}, "roughness": total(r_base)}
    if coat is not None:
        hc = h1 * coat.fc_v + h2 * coat.fc_l if h2 is not None else h1 * coat.fc_v
        b1, b2 = _side(base, False), _side(base, True)
        row["clearcoat"] = jnp.sum(hc * (coat.lobe - b1)) if b2 is b1 or h2 is None else (
            jnp.sum(h1 * coat.fc_v * (coat.lobe - b1)) + jnp.sum(h2 * coat.fc_l * (coat.lobe - b2)))
        row["clearcoat_roughness"] = coat.weight * jnp.sum(hc * coat.d_lobe)
    return row


def _log_sensitivities(base, coat, log_i, log_o, geo, w):
    """One channel's squared error S for the log loss and each pair's sensitivities
    h1, h2 to f in its two orientations."""
    nl, nv = geo.n_dot_l, geo.n_dot_v
    f1, f2 = _coated(_side(base, False), coat, at_v=True), _coated(_side(base, True), coat, at_v=False)
    y1, y2 = f1 * nl, f2 * nv
    r1 = log1p(y1) - log_i
    r2 = log1p(y2) - log_o
    h1 = 2.0 * w * r1 * nl / (1.0 + y1)
    h2 = 2.0 * w * r2 * nv / (1.0 + y2)
    return jnp.sum(w * (r1 * r1 + r2 * r2)), h1, h2


def _channel_sums(base, r_base, factors, log_i, log_o, geo, w, coat):
    """One channel's sums for the log loss: S (the squared error) and ``_partials``."""
    s, h1, h2 = _log_sensitivities(base, coat, log_i, log_o, geo, w)
    return {"S": s, **_partials(h1, h2, base, r_base, factors, coat)}


def _additive(spec):
    """channels(params, lobe_params, geo, s5) -> ([(base_c, d base_c / d roughness,
    factors_c)], finish); finish(rows, d loss / d S) -> the parameters' cotangent."""
    multiple = spec.energy == "kulla_conty"
    diffuse = has_diffuse(spec)

    def lobes(params, geo, raw_roughness):
        """The roughness-dependent per-sample lobes: DV, B (albedo 1) and M (or 0)."""
        roughness, alpha = roughness_alpha(raw_roughness)
        dv = specular_dv(spec, params, geo, alpha)
        zero = jnp.zeros_like(dv)
        b = diffuse_lobe(spec, dict(params, albedo=1.0), geo, roughness, alpha) if diffuse else zero
        m = energy_switched(params, kulla_conty_lobe(geo.n_dot_l, geo.n_dot_v, roughness), zero) if multiple else zero
        return dv, b, m

    def colour(f0_c, raw_roughness):
        """K_c: the Kulla-Conty lobe's colour for one channel."""
        roughness, _ = roughness_alpha(raw_roughness)
        return kulla_conty_fresnel_factor(fresnel_schlick_average(f0_c), lookup_e_avg(roughness))

    def channels(params, lobe_params, geo, s5):
        r = params["roughness"]
        (dv, b, m), (ddv, db, dm) = jax.jvp(lambda r: lobes(lobe_params, geo, r), (r,), (jnp.ones_like(r),))
        f90 = params.get("f90", 1.0)
        albedo = params["albedo"] if diffuse else jnp.zeros(3, r.dtype)
        factors = {"f0": (dv, 1.0 - s5), "f90": (dv, s5), **({"albedo": (b,)} if diffuse else {}),
                   **({"m": (m,)} if multiple else {})}
        out, colour_grads = [], []
        for c in range(3):
            f0_c = params["f0"][c]
            fresnel = f0_c * (1.0 - s5) + f90 * s5
            base = albedo[c] * b + dv * fresnel
            r_lobes = albedo[c] * db + ddv * fresnel       # d base / d roughness, per sample
            if multiple:
                k_c = colour(f0_c, r)
                colour_grads.append(jax.grad(colour, argnums=(0, 1))(f0_c, r))
                base = base + m * k_c
                r_lobes = r_lobes + dm * k_c
            out.append((base, r_lobes, factors))

        def finish(rows, dloss_ds):
            rows = [dict(row) for row in rows]      # (called once per cotangent: rows stay as given)
            for row, (dk_df0, dk_dr) in zip(rows, colour_grads):   # K_c is one number per channel:
                row["f0"] = row["f0"] + dk_df0 * row["m"]              # its partials multiply one sum
                row["roughness"] = row["roughness"] + dk_dr * row["m"]
            sums = {k: jnp.stack([row[k] for row in rows]) for k in rows[0]}
            return {name: dloss_ds * sums[name] if jnp.ndim(value) else jnp.sum(dloss_ds * sums[name])
                    for name, value in params.items()}
        return out, finish
    return channels


def _gltf(spec):
    """The glTF composition's ``channels`` (see ``_additive``): brdf/gltf.py's
    gltf_combine regrouped as per-channel coefficients times per-sample lobes (+turquin: the
    first two again times 1/E - 1 at n.v for (wi, wo), n.l for (wo, wi), coefficients x F0_c)."""
    engines = spec.energy == "turquin"

    def lobes(params, geo, s5, raw_roughness):
        roughness, alpha = roughness_alpha(raw_roughness)
        dv = specular_dv(spec, params, geo, alpha)
        phi = [dv * (1.0 - s5), dv * s5, 1.0 - s5, s5]
        if engines:
            lack = [1.0 / lookup_e(jnp.clip(n, 0.0, 1.0), roughness) - 1.0 for n in (geo.n_dot_v, geo.n_dot_l)]
            phi += [Oriented(phi_j * lack[0], phi_j * lack[1]) for phi_j in phi[:2]]
        return phi

    def coefficients(params):
        s = params.get("specular", 1.0)
        colour = jnp.broadcast_to(params.get("specular_color", 1.0), (3,))
        f0 = jnp.minimum(f0_from_ior(params.get("ior", IOR_DEFAULT)) * colour, 1.0) * s
        f0_max = jnp.maximum(jnp.maximum(f0[0], f0[1]), f0[2])    # pairwise, as gltf_combine
        m, base = params.get("metallic", held_values(spec).get("metallic")), params["base_color"]
        rows = []
        for c in range(3):
            diffuse = (1.0 - m) * base[c] / jnp.pi
            f0_c, f90 = (1.0 - m) * f0[c] + m * base[c], (1.0 - m) * s + m
            rows.append([f0_c, f90, diffuse * (1.0 - f0_max), diffuse * (1.0 - s)]
                        + ([f0_c * f0_c, f90 * f0_c] if engines else []))
        return rows

    def channels(params, lobe_params, geo, s5):
        k, pull_k = jax.vjp(coefficients, params)

        def lobes_and_bases(r):
            phi = lobes(lobe_params, geo, s5, r)
            return phi, [_summed(row, phi) for row in k]
        r = params["roughness"]
        # the lobes, and each channel's base and its roughness derivative at fixed coefficients
        (phi, bases), (_, r_bases) = jax.jvp(lobes_and_bases, (r,), (jnp.ones_like(r),))
        factors = {j: (phi_j,) for j, phi_j in enumerate(phi)}

        def finish(rows, dloss_ds):
            cotangent = pull_k([[dloss_ds[c] * row[j] for j in factors] for c, row in enumerate(rows)])[0]
            for name in ("roughness", "clearcoat", "clearcoat_roughness"):
                if name in rows[0]:
                    cotangent[name] = cotangent[name] + sum(dloss_ds[c] * row[name] for c, row in enumerate(rows))
            return cotangent
        return [(bases[c], r_bases[c], factors) for c in range(3)], finish
    return channels


def _summed(k, phi):
    """sum_j k_j phi_j, ``Oriented`` when a lobe is (the lobes both orientations share summed once)."""
    shared = sum(k_j * phi_j for k_j, phi_j in zip(k, phi) if not isinstance(phi_j, Oriented))
    sides = [sum((k_j * _side(phi_j, second) for k_j, phi_j in zip(k, phi) if isinstance(phi_j, Oriented)), shared)
             for second in (False, True)]
    return shared if sides[0] is shared else Oriented(*sides)


COMPOSITIONS = {"additive": _additive, "gltf": _gltf}


def _horizon_weights(data):
    """The samples' weights, 0 where either direction lies below the horizon."""
    return jnp.where((data.geo.n_dot_l > 0.0) & (data.geo.n_dot_v > 0.0), data.weights, 0.0)


def _s5(geo):
    x = 1.0 - jnp.clip(geo.v_dot_h, 0.0, 1.0)
    return x * x * x * x * x


def value_and_grad(spec: ModelSpec, switched: bool = False, hybrid: bool = False
                   ) -> Callable[..., tuple[Float[Array, "..."], ...]]:
    """(u, SampleSet) -> (loss, d loss / du, per-channel mean square error S, dS/du (3, n)):
    the same numbers as jax.value_and_grad of the plain log loss (and
    fit.channel_errors), for a spec ``supports`` accepts; with dS/du a set is
    summed over its parts (``objective.PartedHybrid``).  ``switched``: (u,
    switches, SampleSet) for a family root (``family.Variant.switches``).
    ``hybrid``: the hybrid loss on a HybridSet (fitting.objective): M1 + weight
    x the image error of fitting.image_error, whose gradient takes the same sums
    over the image's pairs, with the sensitivities of the tone-mapped pixels
    (jax.grad of the small per-pixel part) in place of the log residuals'
    (three outputs: no dS/du)."""
    channels = COMPOSITIONS[spec.composition](spec)

    def table(params, lobe_params, data):
        """(M1, d M1 / d S, the per-channel squared errors S, and the parameters' cotangent
        for weights of the channels' S: linear in them)."""
        geo = data.geo
        per_channel, finish = channels(params, lobe_params, geo, _s5(geo))
        w = _horizon_weights(data)
        coat = _coat(params, geo) if spec.clearcoat else None
        rows = [_channel_sums(base, r_base, factors, data.log_i[:, c], data.log_o[:, c], geo, w, coat)
                for c, (base, r_base, factors) in enumerate(per_channel)]
        s = jnp.stack([row["S"] for row in rows])
        root = jnp.sqrt(s)
        dloss_ds = 0.5 / root / 3.0            # loss = mean_c sqrt(S_c)
        return jnp.mean(root), dloss_ds, s, lambda weights: finish(rows, weights)

    def hybrid_loss(params, lobe_params, data):
        """(M1 + weight x the image error, its cotangent, the table's S): the lobes
        evaluated once on the table's pairs followed by the image's, each
        part's sensitivities, and one set of sums over both."""
        table, target = data.samples, data.image
        n = table.geo.n_dot_l.shape[0]
        geo = jax.tree.map(lambda a, b: jnp.concatenate([a, b]), table.geo, target.geo)
        per_channel, finish = channels(params, lobe_params, geo, _s5(geo))
        coat = _coat(params, geo) if spec.clearcoat else None
        table_coat = None if coat is None else _Coat(*(x[:n] if jnp.ndim(x) else x for x in coat))
        w = _horizon_weights(table)
        sums = [_log_sensitivities(jax.tree.map(lambda x: x[:n], base), table_coat, table.log_i[:, c],
                                   table.log_o[:, c], table.geo, w)
                for c, (base, _, _) in enumerate(per_channel)]
        s = jnp.stack([row[0] for row in sums])
        root = jnp.sqrt(s)
        dloss_ds = 0.5 / root / 3.0            # M1 = mean_c sqrt(S_c)
        # the image (orientation (light, view)): its pixels' sensitivity to each pair's f
        above = (target.geo.n_dot_l > 0.0) & (target.geo.n_dot_v > 0.0)
        f = jnp.stack([_coated(_side(base, False), coat, at_v=True)[n:] for base, _, _ in per_channel], axis=-1)
        f = jnp.where(above[:, None], f, 0.0)
        value, d_f = jax.value_and_grad(lambda f: image_term(f, target)[0])(f)
        sensitivity = jnp.where(above[:, None], d_f, 0.0)          # d value / d f per pair and channel
        rows = []
        for c, (base, r_base, factors) in enumerate(per_channel):
            _, h1, h2 = sums[c]
            g1 = jnp.concatenate([dloss_ds[c] * h1, data.weight * sensitivity[:, c]])
            g2 = jnp.concatenate([dloss_ds[c] * h2, jnp.zeros_like(sensitivity[:, c])])
            rows.append(_partials(g1, g2, base, r_base, factors, coat))
        return jnp.mean(root) + data.weight * value, finish(rows, jnp.ones(3, f.dtype)), s

    def loss_and_grad(u, switches, data):
        if switched:
            params, pull = jax.vjp(lambda u: family.held(spec, u, switches), u)
            lobe_params = family.with_switches(params, switches)
        else:
            params, pull = jax.vjp(lambda u: to_params(spec, u), u)
            lobe_params = params
        if hybrid:
            value, cotangent, s = hybrid_loss(params, lobe_params, data)
            return value, pull(cotangent)[0], s
        value, dloss_ds, s, cotangent = table(params, lobe_params, data)
        # dS/du, each channel's row at once (batched: as many small operations as one
        # gradient), and the gradient from it: the map from weights to gradient is linear
        jac = jax.vmap(lambda weights: pull(cotangent(weights))[0])(jnp.eye(3, dtype=s.dtype))
        return value, dloss_ds @ jac, s, jac

    return family.jit_u_program(loss_and_grad, switched, f"fused.value_and_grad {spec!r} hybrid={hybrid}")


def errors(spec: ModelSpec) -> Callable[..., Float[Array, "3"]]:
    """(params, SampleSet) -> the log loss's per-channel squared errors S (``value_and_grad``'s
    third output), value only: the fused sums' forward part.  ``params`` may carry
    a family root's diffuse switch (``family.Variant.expand``)."""
    channels = COMPOSITIONS[spec.composition](spec)

    def run(params, data):
        geo = data.geo
        own = {k: v for k, v in params.items() if k not in SWITCHES}
        per_channel, _ = channels(own, params, geo, _s5(geo))
        coat = _columns(_coat(own, geo)) if spec.clearcoat else None
        # (the unused derivatives drop out)
        base = [jnp.stack([_side(base, second) for base, _, _ in per_channel], axis=-1) for second in (False, True)]
        nl, nv = geo.n_dot_l[:, None], geo.n_dot_v[:, None]
        r1 = log1p(_coated(base[0], coat, at_v=True) * nl) - data.log_i
        r2 = log1p(_coated(base[1], coat, at_v=False) * nv) - data.log_o
        w = _horizon_weights(data)
        return jnp.dot(w, r1 * r1 + r2 * r2)
    return stored_jit(run, f"fused.errors {spec!r}")


def _columns(coat):
    """The coat's per-sample quantities as columns (against (n, 3) channels)."""
    return _Coat(*(x[..., None] if jnp.ndim(x) else x for x in coat))
