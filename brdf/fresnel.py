"""Fresnel reflectance: Schlick's approximation, exact dielectric and conductor.

Sources: Schlick 1994; Lagarde 2011 / Fdez-Aguera 2019 (roughness-dependent
Schlick for ambient light); Walter et al. 2007 eq. 22 (unpolarised dielectric);
the standard complex-IOR conductor formula (Born & Wolf).  docs/models.md#fresnel.
``cos`` is the cosine between the incident direction and the (micro)normal,
v.h for a specular lobe.  The Fresnel options of a model are declared at the
end (``FRESNELS``).
"""

from __future__ import annotations

from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np
from jaxtyping import Float

from ._lazy import jnp
from .declare import GltfRule, Param, Start, Term

if TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import Array, ArrayLike


def _pow5(x):
    x2 = x * x
    return x2 * x2 * x


def fresnel_schlick(f0: Float[ArrayLike, "*#batch #3"], cos: Float[ArrayLike, "*batch"],
                    f90: Float[ArrayLike, "*#batch #3"] = 1.0) -> Float[Array, "*batch #3"]:
    """F = F0 + (F90 - F0)(1 - cos)^5.  F0 scalar or RGB (broadcast on the last axis)."""
    w = _pow5(1.0 - jnp.clip(cos, 0.0, 1.0))
    if jnp.ndim(f0) or jnp.ndim(f90):
        w = w[..., None]
    return f0 + (f90 - f0) * w


def fresnel_schlick_roughness(f0: Float[ArrayLike, "*#batch #3"], cos: Float[ArrayLike, "*batch"],
                              roughness: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch #3"]:
    """Lagarde's ambient Schlick: F0 + (max(1 - r, F0) - F0)(1 - cos)^5."""
    return fresnel_schlick(f0, cos, jnp.maximum(1.0 - roughness, f0))


def fresnel_dielectric(cos: Float[ArrayLike, "*batch"], eta: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Exact unpolarised Fresnel reflectance of a dielectric, eta = n_t / n_i.

    g^2 = eta^2 - 1 + c^2; total internal reflection (g^2 < 0) gives 1.
    F = 1/2 ((g - c)/(g + c))^2 (1 + ((c (g + c) - 1)/(c (g - c) + 1))^2).
    """
    c = jnp.clip(cos, 0.0, 1.0)
    g2 = eta * eta - 1.0 + c * c
    g = jnp.sqrt(jnp.maximum(g2, 1e-12))
    a = (g - c) / (g + c)
    b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
    return jnp.where(g2 > 0.0, 0.5 * a * a * (1.0 + b * b), 1.0)


def fresnel_conductor(cos: Float[ArrayLike, "*batch"], n: Float[ArrayLike, "*#batch #3"],
                      k: Float[ArrayLike, "*#batch #3"]) -> Float[Array, "*batch #3"]:
    """Unpolarised Fresnel reflectance of a conductor with complex IOR n + i k.

    cos theta_t = sqrt(1 - (1 - c^2)/eta^2) (complex root);
    r_s = (c - eta cos_t)/(c + eta cos_t), r_p = (eta c - cos_t)/(eta c + cos_t),
    F = (|r_s|^2 + |r_p|^2) / 2.  ``n`` and ``k`` broadcast against ``cos``.
    """
    c = jnp.clip(cos, 1e-6, 1.0)
    eta = n + 1j * k
    cos_t = jnp.sqrt(1.0 - (1.0 - c * c) / (eta * eta))
    rs = (c - eta * cos_t) / (c + eta * cos_t)
    rp = (eta * c - cos_t) / (eta * c + cos_t)
    return 0.5 * (jnp.abs(rs) ** 2 + jnp.abs(rp) ** 2)


def f0_from_ior(n: Float[ArrayLike, "*#batch #3"],
                k: Float[ArrayLike, "*#batch #3"] = 0.0) -> Float[Array, "*#batch #3"]:
    """Normal-incidence reflectance ((n - 1)^2 + k^2) / ((n + 1)^2 + k^2)."""
    return ((n - 1.0) ** 2 + k * k) / ((n + 1.0) ** 2 + k * k)


def ior_from_f0(f0: Float[ArrayLike, "*#batch #3"], xp: ModuleType = jnp) -> Float[ArrayLike, "*#batch #3"]:
    """Dielectric IOR with the given F0: n = (1 + sqrt F0) / (1 - sqrt F0).

    ``xp``: jax.numpy, or numpy where the glTF conversion needs float64.
    """
    s = xp.sqrt(xp.clip(f0, 0.0, 0.999999))
    return (1.0 + s) / (1.0 - s)


def fresnel_schlick_average(f0: Float[ArrayLike, "*#batch #3"]) -> Float[Array, "*#batch #3"]:
    """Hemispherical average 2 int F(mu) mu dmu of Schlick = F0 + (1 - F0)/21."""
    return f0 + (1.0 - f0) / 21.0


# --- declarations -------------------------------------------------------------
# lobe(params, v_dot_h) -> (F (..., 3), F0): the reflectance, and its value at
# normal incidence (what energy compensation reads).  RGB ones are made in the
# inputs' dtype: a bare jnp.ones(3) is float64 under x64 and would promote a
# float32 evaluation.

def _ones(*xs):
    return jnp.ones(3, jnp.result_type(*xs))


def _schlick(p, cos):
    return fresnel_schlick(p["f0"], cos), p["f0"]


def _schlick_f90(p, cos):
    return fresnel_schlick(p["f0"], cos, p["f90"] * _ones(p["f90"], cos)), p["f0"]


def _dielectric(p, cos):
    ones = _ones(p["ior"], cos)
    return fresnel_dielectric(cos, p["ior"])[..., None] * ones, f0_from_ior(p["ior"]) * ones


def _conductor(p, cos):
    return fresnel_conductor(cos[..., None], p["eta"], p["k"]), f0_from_ior(p["eta"], p["k"])


F0 = Param("f0", 3, 0.0, 1.0, 0.04, "Fresnel reflectance at normal incidence",
           start=Start(probe=1.0, rule=lambda e: e.scale))
F90 = Param("f90", 1, 0.0, 1.0, 1.0, "Fresnel reflectance at grazing incidence", neutral=1.0)

FRESNELS = {
    "schlick": Term(name="schlick", params=(F0,), lobe=_schlick, fused=True,
                    gltf=GltfRule(lambda p: {"f0": p["f0"]})),
    "schlick_f90": Term(name="schlick_f90", token="f90", params=(F0, F90), lobe=_schlick_f90, fused=True,
                        gltf=GltfRule(lambda p: {"f0": p["f0"], "f90": p["f90"]})),
    "dielectric": Term(
        name="dielectric", token="dielectric", hint="exact, IOR", lobe=_dielectric,
        params=(Param("ior", 1, 1.0, 3.0, 1.5, "index of refraction (exact dielectric Fresnel)",
                      start=Start(rule=lambda e: float(ior_from_f0(np.clip(np.mean(e.scale), 0.01, 0.5))))),),
        gltf=GltfRule(lambda p: {"f0": f0_from_ior(p["ior"])},
                      "exact dielectric Fresnel (ior {ior:.4g}) replaced by glTF's Schlick with the same F0")),
    "conductor": Term(
        name="conductor", token="conductor", hint="n, k", lobe=_conductor,
        params=(Param("eta", 3, 0.05, 5.0, 1.0, "conductor IOR, real part n",
                      start=Start(rule=lambda e: np.asarray(ior_from_f0(np.clip(e.scale, 0.02, 0.95))))),
                Param("k", 3, 0.0, 10.0, 3.0, "conductor IOR, imaginary part k",
                      start=Start(rule=lambda e: np.zeros(3)))),
        gltf=GltfRule(lambda p: {"f0": f0_from_ior(p["eta"], p["k"]), "conductor": True},
                      "conductor Fresnel (n, k) replaced by Schlick with its F0 = {f0} (F90 = 1)")),
}
