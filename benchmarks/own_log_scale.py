"""A wide parameter of a model of one's own on a linear and on a log scale (docs/models.md,
"Wide positive ranges"): the same model declared both ways, fitted to noise-free synthetic
tables of itself, from several starts.

    .venv/bin/python benchmarks/own_log_scale.py

Two models: a normalised Blinn-Phong lobe beside a Lambertian, exponent n in [1, 1e6]
(n = 3 ... 10 000 from starts 100 ... 100 000), and the ABC model's shape A / (1 + B x)^C,
x = 1 - n.h, beside a Lambertian, A in [1e-3, 1e7] and B in [1, 1e7] (three (A, B), C = 1.5,
from four starts).  Each table has 24 x 24 x 48 half/difference cells, each fit 5 000
samples and the default optimizer.  A case is recovered when M1 < 1e-6 and every wide
parameter is within 0.1 % of the truth.  Prints one line per fit and a summary per model and
scale: recovered, median evaluations, fits whose wide parameter is flagged at a bound.
About 1.5 minutes on the shared 2-core machine."""

import jax.numpy as jnp
import numpy as np

from brdf.own import OwnModel, Param, Start
from fitting import fit
from fitting.synthetic import synthetic_measured

RHO = Param("rho", 3, 0.0, 1.0, 0.3, "diffuse albedo", start=Start(rule=lambda e: e.albedo))
WIDE = ("n", "a", "b")
GRID = (24, 24, 48, 1)


def _half_cosine(wi, wo):
    h = wi + wo
    return (h / jnp.linalg.norm(h, axis=-1, keepdims=True))[..., 2]


def blinn_phong(p, wi, wo):
    """rho / pi + k_s (n + 2) / (2 pi) (n.h)^n."""
    n_dot_h = jnp.clip(_half_cosine(wi, wo), 1e-9, 1.0)
    lobe = (p["n"] + 2.0) / (2.0 * jnp.pi) * jnp.exp(p["n"] * jnp.log(n_dot_h))
    return p["rho"] / jnp.pi + p["ks"] * lobe[..., None]


def abc(p, wi, wo):
    """rho / pi + A / (1 + B (1 - n.h))^C (Loew et al. 2012's smooth-surface shape, no Fresnel)."""
    x = 1.0 - jnp.clip(_half_cosine(wi, wo), 0.0, 1.0)
    return p["rho"] / jnp.pi + (p["a"] / (1.0 + p["b"] * x) ** p["c"])[..., None]


def blinn_phong_model(scale, n0):
    return OwnModel(f"phong_{scale}", (RHO, Param("ks", 1, 0.0, 1.0, 0.1, "k_s"),
                                       Param("n", 1, 1.0, 1e6, n0, "exponent", scale=scale)), blinn_phong)


def abc_model(scale, start):
    a0, b0 = start
    return OwnModel(f"abc_{scale}", (RHO, Param("a", 1, 1e-3, 1e7, a0, "A", scale=scale),
                                     Param("b", 1, 1.0, 1e7, b0, "B", scale=scale),
                                     Param("c", 1, 0.1, 10.0, 1.0, "C")), abc)


CASES = ([("blinn-phong", blinn_phong_model, {"rho": [0.3, 0.2, 0.1], "ks": 0.2, "n": n}, start)
          for n in (3.0, 10.0, 30.0, 100.0, 1e3, 1e4) for start in (100.0, 1e3, 1e4, 1e5)]
         + [("abc", abc_model, {"rho": [0.3, 0.2, 0.1], "a": a, "b": b, "c": 1.5}, start)
            for a, b in ((30.0, 100.0), (300.0, 3000.0), (3000.0, 1e5))
            for start in ((10.0, 1e3), (1e3, 1e4), (1e2, 1e2), (1e4, 1e5))])


def main():
    rows = {}
    for kind, make, truth, start in CASES:
        measured = synthetic_measured(make("linear", start), truth, grid=GRID)
        for scale in ("linear", "log"):
            r = fit(measured, make(scale, start), samples=5000)
            wide = [k for k in truth if k in WIDE]
            recovered = r.errors["m1"] < 1e-6 and all(abs(r.parameters[k] / truth[k] - 1.0) < 1e-3 for k in wide)
            flagged = any(k in r.at_bounds() for k in wide)
            rows.setdefault((kind, scale), []).append((recovered, r.optimizer["evaluations"], flagged))
            print(f"{kind:12s} {scale:6s} truth {', '.join(f'{k}={truth[k]:g}' for k in wide)} start {start}: "
                  f"{'recovered' if recovered else 'MISSED'} M1 {r.errors['m1']:.3g}, "
                  f"{r.optimizer['evaluations']} evaluations, at bounds {r.at_bounds()}", flush=True)
    for (kind, scale), found in rows.items():
        print(f"{kind} {scale}: recovered {sum(f[0] for f in found)}/{len(found)}, median evaluations "
              f"{np.median([f[1] for f in found]):.0f}, wide parameter flagged at a bound "
              f"{sum(f[2] for f in found)}/{len(found)}")


if __name__ == "__main__":
    main()
