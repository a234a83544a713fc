"""The vocabulary a model is declared in: ``Param`` and ``Term`` (and their parts).

Every option of a ModelSpec field -- each diffuse lobe, each Fresnel option,
the NDFs, maskings and anisotropy remaps, energy compensation, the clearcoat,
the compositions and the glTF extensions -- is one ``Term``, declared in the
module of its formula (brdf/diffuse.py, fresnel.py, ...) beside that formula.
The other layers read the declarations instead of naming terms or parameters:

    brdf/spec.py          the model strings (``Term.token``), the schema (``Term.params``)
    brdf/model.py         the evaluation dispatch (``Term.lobe``)
    brdf/gltf_material.py the glTF conversion (``Term.gltf``, ``Param.gltf``)
    fitting/transforms.py bounded / periodic / log-scale parameters (``Param.period``, ``Param.scale``)
    fitting/starts.py     start candidates (``Param.start``, ``Term.variants``)
    fitting/fused.py      the closed-form gradient's coverage (``Term.fused``)
    shaders/library.py    GLSL #defines and the uniform block (spec fields, schema)
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing

from jaxtyping import Float

if typing.TYPE_CHECKING:     # jaxtyping's Array and ArrayLike import JAX (see brdf/_lazy.py)
    from jaxtyping import ArrayLike


@dataclasses.dataclass(frozen=True)
class GltfKey:
    """Where a parameter lives in a glTF 2.0 material, 1:1.

    ``owner`` is "pbrMetallicRoughness" or a KHR_materials_* extension, ``key``
    the property there, ``default`` its value when absent (the glTF / KHR
    schema's), ``extra`` the components glTF stores after ours (the alpha of
    baseColorFactor).
    """
    owner: str
    key: str
    default: float
    extra: tuple = ()


CORE = "pbrMetallicRoughness"


@dataclasses.dataclass(frozen=True)
class Start:
    """How a fit's start selection (fitting/starts.py) sets a parameter.

    scan   values tried, one start candidate each (the roughness scan)
    probe  its value while the model's specular peak is measured (None: its start value)
    rule   estimate -> its start value (None: the schema default).  The estimate
           has ``albedo`` (pi x the measurement away from the specular peak,
           RGB in [0, 1]) and ``scale`` (the measured peak over the probed
           model's peak, RGB in [0, 1]).
    peak   estimate -> what the parameter's lobe adds to the measured peak (taken
           off before ``scale`` is formed), or None
    """
    scan: tuple = ()
    probe: typing.Optional[float] = None
    rule: typing.Optional[typing.Callable] = None
    peak: typing.Optional[typing.Callable] = None


DEFAULT_START = Start()


LINEAR, LOG = "linear", "log"      # the scales a parameter is fitted on (``Param.scale``)


@dataclasses.dataclass(frozen=True)
class Param:
    """One entry of a parameter schema (``size`` 1: shared by R, G, B; 3: per channel).

    ``scale`` is the scale the fit works on: "linear" (the default) or "log" for a wide
    positive range (0 < lower; [1, 1e7], say), where the optimizer moves log(x) and a step
    changes x by a factor, not by an amount.  Its starts are kept to a relative epsilon of
    log(x) and "at a bound" is 1 % of the log range (``position``: fitting/transforms.py,
    fitting.result.FitResult.at_bounds)."""
    name: str
    size: int
    lower: float
    upper: float
    default: float
    description: str
    unit: str = ""
    _: dataclasses.KW_ONLY
    period: typing.Optional[float] = None   # an angle: free in the fit, wrapped to [lower, lower + period)
    gltf: typing.Optional[GltfKey] = None   # the glTF material value it is, 1:1
    start: Start = DEFAULT_START
    # the value at which its term adds nothing (F90 1, glTF's specular 1): a model
    # without the term is its family's program with the parameter held there
    # (fitting/family.py); None: the term cannot be switched off
    neutral: typing.Optional[float] = None
    scale: str = LINEAR

    def position(self, x: Float[ArrayLike, "*batch"], xp: types.ModuleType) -> Float[ArrayLike, "*batch"]:
        """Where ``x`` lies in the bounds on the parameter's scale: 0 at ``lower``, 1 at
        ``upper`` (of log(x) on a log scale); ``xp`` is numpy, jax.numpy or math."""
        if self.scale == LOG:
            lo = math.log(self.lower)
            return (xp.log(x) - lo) / (math.log(self.upper) - lo)
        return (x - self.lower) / (self.upper - self.lower)

    def at_position(self, t: Float[ArrayLike, "*batch"], xp: types.ModuleType) -> Float[ArrayLike, "*batch"]:
        """The value at ``t`` of the bounds on the parameter's scale (``position``'s inverse)."""
        if self.scale == LOG:
            lo = math.log(self.lower)
            return xp.exp(lo + (math.log(self.upper) - lo) * t)
        return self.lower + (self.upper - self.lower) * t

    def wrap(self, x: Float[ArrayLike, "*batch"]) -> Float[ArrayLike, "*batch"]:
        """``x`` mapped into [lower, lower + period) for a periodic parameter, else unchanged."""
        return (x - self.lower) % self.period + self.lower if self.period else x


@dataclasses.dataclass(frozen=True)
class GltfRule:
    """How a term becomes part of a glTF material (brdf/gltf_material.py).

    quantities  params -> {name: value} the term gives the conversion: "rho" (the
                diffuse albedo), "f0" (RGB), "f90", "conductor" (True: exported
                as a metal when the model has no diffuse lobe).  None: nothing.
    note        None when glTF carries the term exactly; otherwise what is
                approximated or dropped, a ``str.format`` template over the
                parameters, the quantities (formatted) and ``name``.
    """
    quantities: typing.Optional[typing.Callable] = None
    note: typing.Optional[str] = None


EXACT = GltfRule()


@dataclasses.dataclass(frozen=True, kw_only=True)
class Term:
    """One option of a ModelSpec field ("burley" of ``diffuse``, "schlick_f90" of ``fresnel``).

    name      the field's value
    token     the model-string option that selects it ("f90"); None for a field's default
    hint      a few words for ``brdf-fit models``
    params    the Params it adds to the schema
    lobe      its JAX function, with the signature of its field (brdf/model.py)
    fused     fitting.fused's closed-form loss gradient covers it
    gltf      how it becomes glTF (a GltfRule)
    variants  alternative start values: ((names), ((values), ...)), each row a
              start family of its own (values are clipped to the bounds)
    reseed    values of the ``variants`` names put on the multi-start stage's best
              optimum for one more start (fitting.starts.reseeded: a lobe that
              optimum dropped, back in a weak form); () for none
    holds     ((name, value), ...): parameters of the composition it takes out of the
              schema, held at that value (glTF's ``metal``: metallic 1)
    reciprocal  f(wi, wo) = f(wo, wi) at every parameter value; False (a layer weighed at
              n.v, a compensation at n.v): the fitter evaluates a pair in both orientations
              (``fitting.objective.is_reciprocal``), tests/test_brdf_properties.py holds each
              declaration to the formula
    """
    name: str
    token: typing.Optional[str] = None
    hint: str = ""
    params: tuple = ()
    lobe: typing.Optional[typing.Callable] = None
    fused: bool = False
    gltf: GltfRule = EXACT
    variants: tuple = ()
    reseed: tuple = ()
    holds: tuple = ()
    reciprocal: bool = True


@dataclasses.dataclass(frozen=True, kw_only=True)
class Ndf(Term):
    """lobe(n_dot_h, alpha), or lobe(h in the rotated tangent frame, alpha_t, alpha_b).

    smith_lambda   its own Smith Lambda: (n_dot_v, alpha), or (v rotated, alpha_t,
                   alpha_b) -- what a Smith masking (``Masking.combine``) is made of
    visibility     ((masking name, V), ...): closed forms of V = G / (4 n.l n.v) for that
                   masking with this NDF's Lambda (same arguments as the Lambda,
                   for both directions: (n_dot_l, n_dot_v, alpha) or (l, v,
                   alpha_t, alpha_b)); used instead of combining the Lambdas
    energy_tables  brdf.energy's (GGX) tables describe it: ``ms`` / ``turquin`` apply
    """
    anisotropic: bool = False
    smith_lambda: typing.Optional[typing.Callable] = None
    visibility: tuple = ()
    energy_tables: bool = True


@dataclasses.dataclass(frozen=True, kw_only=True)
class Lobe(Ndf):
    """A classic lobe model in the NDF's place (brdf/lobes.py): lobe(params, g, alpha),
    or anisotropic lobe(params, g, alpha_t, alpha_b, h rotated), is the whole RGB
    specular term -- no masking, no Fresnel term (the spec's masking and Fresnel stay
    at their defaults and add nothing), no energy tables."""
    energy_tables: bool = False


@dataclasses.dataclass(frozen=True, kw_only=True)
class Masking(Term):
    """A masking-shadowing G, one of two kinds:

    combine    Smith: (Lambda(l), Lambda(v)) -> G, with the NDF's own Lambda
    geometric  of the geometry only: (n_dot_l, n_dot_v, n_dot_h, v_dot_h) -> G
    """
    combine: typing.Optional[typing.Callable] = None
    geometric: typing.Optional[typing.Callable] = None


@dataclasses.dataclass(frozen=True, kw_only=True)
class Remap(Term):
    """remap(alpha, anisotropy, xp) -> (alpha_t, alpha_b); ``xp`` is jax.numpy in the
    model, numpy in the float64 glTF conversion."""
    remap: typing.Optional[typing.Callable] = None


@dataclasses.dataclass(frozen=True, kw_only=True)
class Composition(Term):
    """How the lobes are summed.  ``weights_diffuse``: f_diffuse is weighted by
    (1 - F(v.h)); ``own_lobes``: the composition brings its own diffuse and
    Fresnel (its params replace theirs) and lobe(params, g, dv) is the BRDF."""
    weights_diffuse: bool = False
    own_lobes: bool = False
