"""The Beckmann NDF with its exact Smith Lambda, and Cook-Torrance's V-groove masking.

Sources: Beckmann & Spizzichino 1963 (the distribution of slopes); Walter et
al. 2007 ("Microfacet models for refraction through rough surfaces": the
normalised D, the Smith G1 in closed form with erf); Heitz 2014 (the
height-correlated G2 = 1 / (1 + Lambda(l) + Lambda(v)) and the anisotropic
Lambda); Cook & Torrance 1982 (the V-groove masking-shadowing).  Formulas
restated in docs/models.md ("Beckmann" and "Cook-Torrance").

Like brdf.specular, every function takes alpha (= roughness**2, the rms slope
times sqrt 2 of Beckmann's paper: D = exp(-tan^2/alpha^2) / (pi alpha^2
cos^4)) and floors it at ALPHA_MIN.  Lambda is exact (erfc), not Walter's
rational fit.  The maskings themselves (how two Lambdas make G) are declared
once in brdf/specular.py; the NDF declares its own Lambda, so ``beckmann``
with ``separable`` is Beckmann's Smith G1 G1, never GGX's.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from jaxtyping import Float

from ._lazy import jax, jnp
from .constants import ALPHA_MIN
from .declare import GltfRule, Masking, Ndf
from .geometry import clamp_cos
from .specular import ROUGHNESS

if TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import Array, ArrayLike

# Lambda(a) < 1e-17 for a >= LAMBDA_A_MAX (a = 1 / (alpha tan theta)): taken as
# exactly 0 there, which also keeps a = infinity (theta = 0) out of the formula.
LAMBDA_A_MAX = 6.0
# floor on sin^2 theta before it divides: a stays finite at normal incidence
SIN2_MIN = 1e-12
INV_SQRT_PI = 1.0 / math.sqrt(math.pi)
# n.h below this reads as this: there exp(-tan^2 / alpha^2) < exp(-1e6) = 0 for
# every alpha <= 1, and (n.h)^4 stays a normal float32
NDF_COS_MIN = 1e-3


def _floor(alpha):
    return jnp.maximum(alpha, ALPHA_MIN)


# --- normal distribution --------------------------------------------------------

def beckmann_ndf(n_dot_h: Float[ArrayLike, "*batch"], alpha: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Beckmann: D = exp(-tan^2 theta_h / a^2) / (pi a^2 cos^4 theta_h), 0 for n.h <= 0."""
    a2 = _floor(alpha) ** 2
    up = n_dot_h > 0.0
    c = jnp.where(up, jnp.maximum(n_dot_h, NDF_COS_MIN), 1.0)
    c2 = c * c
    tan2 = (1.0 - c2) / c2
    return jnp.where(up, jnp.exp(-tan2 / a2) / (jnp.pi * a2 * c2 * c2), 0.0)


def beckmann_ndf_aniso(h: Float[ArrayLike, "*batch 3"], alpha_t: Float[ArrayLike, "*#batch"],
                       alpha_b: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Anisotropic Beckmann: exp(-((t.h/at)^2 + (b.h/ab)^2) / (n.h)^2) / (pi at ab (n.h)^4).

    ``h`` is the (unit) half vector in the tangent frame (t.h, b.h, n.h).
    """
    at, ab = _floor(alpha_t), _floor(alpha_b)
    up = h[..., 2] > 0.0
    hz = jnp.where(up, jnp.maximum(h[..., 2], NDF_COS_MIN), 1.0)
    hz2 = hz * hz
    x, y = h[..., 0] / at, h[..., 1] / ab
    return jnp.where(up, jnp.exp(-(x * x + y * y) / hz2) / (jnp.pi * at * ab * hz2 * hz2), 0.0)


# --- Smith Lambda -------------------------------------------------------------------

def beckmann_lambda_of_a(a: Float[ArrayLike, "*batch"]) -> Float[Array, "*batch"]:
    """Lambda(a) = (erf(a) - 1)/2 + exp(-a^2) / (2 a sqrt(pi)), a = 1 / (alpha tan theta)
    (Walter et al. 2007, eq. 27), written as (exp(-a^2) / (a sqrt(pi)) - erfc(a)) / 2."""
    inside = a < LAMBDA_A_MAX
    s = jnp.where(inside, a, LAMBDA_A_MAX)
    lam = 0.5 * (jnp.exp(-s * s) * INV_SQRT_PI / s - jax.scipy.special.erfc(s))
    return jnp.where(inside, lam, 0.0)


def beckmann_lambda(n_dot_v: Float[ArrayLike, "*batch"], alpha: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Beckmann's Smith Lambda(v) at a = n.v / (alpha sqrt(1 - (n.v)^2))."""
    c = clamp_cos(n_dot_v)
    s2 = jnp.maximum(1.0 - c * c, SIN2_MIN)
    return beckmann_lambda_of_a(c / (_floor(alpha) * jnp.sqrt(s2)))


def beckmann_lambda_aniso(v: Float[ArrayLike, "*batch 3"], alpha_t: Float[ArrayLike, "*#batch"],
                          alpha_b: Float[ArrayLike, "*#batch"]) -> Float[Array, "*batch"]:
    """Anisotropic Lambda: a = n.v / sqrt(at^2 (t.v)^2 + ab^2 (b.v)^2) (Heitz 2014)."""
    at, ab = _floor(alpha_t), _floor(alpha_b)
    c = clamp_cos(v[..., 2])
    x = jnp.maximum((at * v[..., 0]) ** 2 + (ab * v[..., 1]) ** 2, SIN2_MIN)
    return beckmann_lambda_of_a(c / jnp.sqrt(x))


# --- Cook-Torrance's V-groove masking ---------------------------------------------

def g_vgroove(n_dot_l: Float[ArrayLike, "*batch"], n_dot_v: Float[ArrayLike, "*batch"],
              n_dot_h: Float[ArrayLike, "*batch"], v_dot_h: Float[ArrayLike, "*batch"]) -> Float[Array, "*batch"]:
    """Cook & Torrance 1982: G = min(1, 2 (n.h)(n.v) / (v.h), 2 (n.h)(n.l) / (v.h)) (v.h = l.h)."""
    k = 2.0 * jnp.maximum(n_dot_h, 0.0) / clamp_cos(v_dot_h)
    return jnp.minimum(1.0, k * jnp.minimum(clamp_cos(n_dot_v), clamp_cos(n_dot_l)))


# --- declarations -------------------------------------------------------------------

_BECKMANN_GLTF = GltfRule(note="glTF's NDF is GGX: the Beckmann lobe is exported as the GGX lobe of the "
                               "same alpha (equal peak D(n.h = 1) = 1/(pi alpha^2); GGX's tails are longer)")

NDFS = {
    "beckmann": Ndf(name="beckmann", params=(ROUGHNESS,), lobe=beckmann_ndf, smith_lambda=beckmann_lambda,
                    gltf=_BECKMANN_GLTF, energy_tables=False),
    "beckmann_aniso": Ndf(name="beckmann_aniso", params=(ROUGHNESS,), lobe=beckmann_ndf_aniso,
                          smith_lambda=beckmann_lambda_aniso, anisotropic=True, gltf=_BECKMANN_GLTF,
                          energy_tables=False),
}

VGROOVE = Masking(name="vgroove", token="vgroove", hint="V-groove masking: with beckmann, Cook-Torrance",
                  geometric=g_vgroove,
                  gltf=GltfRule(note="glTF uses height-correlated Smith masking: the V-groove masking is dropped"))
