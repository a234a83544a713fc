"""One compiled program per model family, not one per model.

``--model auto`` fits 24 engine models: GGX with each diffuse lobe of the
albedo x factor form (Lambert, Burley, Frostbite, CoD: WWII), with or
without Kulla-Conty compensation, the clearcoat and a Schlick F90.  They are
four *root* models, ``ggx+lambert+f90`` with or without ``ms`` and
``clearcoat``, each running four to eight of them, with

- the diffuse lobe a runtime input (``brdf.model.DIFFUSE_SWITCH``: an index
  into ``SWITCH_DIFFUSES``, run by ``jax.lax.switch``),
- the parameters the model does not have held at their declared neutral
  value (``Param.neutral``: F90 1, glTF's specular 1), where the root's BRDF
  is the model's, exactly.

(One root for all 24, with the compensation and the coat switched too, was
tried first: it compiles once, but runs ``ggx+lambert`` 2-3x slower per
evaluation, computing a coat and a compensation it multiplies by 0.)  A
Kulla-Conty root switches its compensation too (``brdf.model.ENERGY_SWITCH``:
on for its own models), and with ``shared_programs(..., switch_energy=True)``
it runs its siblings without ``ms`` as well, the compensation switched off:
two roots for the 24, half the programs to compile, where an evaluation of a
model without ``ms`` computes the compensation it leaves out.  ``auto``'s
screening runs so (fitting/screen.py): a fresh process spends most of its
screening compiling (red-plastic's, one model at a time: 12.9 s against 20.1 s
on four roots with empty caches), and on its 5 000 pairs, where XLA's fixed
cost per call is much of an evaluation, a model without ``ms`` costs 6-15 %
more for M1 and 26-30 % for the hybrid loss (about 0.2 s of a table's warm
screening, one model at a time).  The fits keep four roots: at 20 000 pairs
M1's loss and gradient of ``ggx+lambert+f90`` on its ``ms`` sibling cost 58 %
more, on the 100 000-pair subsample the hybrid loss 22 %.  The
glTF family has two roots the same way (``gltf+specular`` runs ``gltf``;
``gltf+specular+clearcoat`` runs ``gltf+clearcoat``).  A ``Variant`` says how a
model runs on its root: where its parameter vector sits in the root's
(``embed``), which switches it sets (``switches``), and how its parameters
become the root's (``expand``).  The fit's programs -- the loss and its
gradient, the parameter map, the start scan, the image error, the full-set
errors -- are compiled once per root and shape (``shared``); a model's run
differs from its own program's by the order of floating-point operations only.

The root's programs are bigger than a model's own (a fresh single fit of
``ggx+lambert`` would compile about twice as long), so they are used where
they pay: inside ``shared_programs(models)``, for the roots two or more of
``models`` share -- ``fit`` and ``batch`` with several models, ``export``
from a measurement.  ``BRDF_FIT_FAMILY=off`` in the environment gives every
model its own programs everywhere, and no fit a warm start from its parent
(``fit.warm_start``): what benchmarks/family_speed.py compares against.
"""

import collections
import contextlib
import contextvars
import dataclasses
import functools
import os
from collections.abc import Callable, Iterator

import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike, Float

from brdf.model import (DIFFUSE_SWITCH, ENERGY_SWITCH, FRESNELS, GLTF_EXTENSIONS, NDFS, SWITCH_DIFFUSES, ModelSpec,
                        parameter_schema, parse_model)
from brdf.spec import METAL_UNUSED

from .stored import stored_jit
from .transforms import from_params, layout, to_params, to_params_jit

@dataclasses.dataclass(frozen=True)
class Variant:
    """How ``spec`` runs on the program of ``root``."""
    spec: ModelSpec
    root: ModelSpec
    index: tuple           # positions of spec's parameter vector in the root's
    fill: tuple            # the root's vector elsewhere (any value: those parameters are held)
    on: tuple              # ((name, 1.0 or 0.0), ...) for each root parameter that can be held
    diffuse: int | None    # the spec's index in SWITCH_DIFFUSES, when the root switches it
    energy: float | None = None    # 1.0 or 0.0: the root's compensation on or off for the spec (a ms root)

    def switches(self) -> dict:
        """The runtime inputs of the root's u-programs (a pytree of arrays)."""
        out = {"on": {name: np.float64(flag) for name, flag in self.on}}
        if self.diffuse is not None:
            out[DIFFUSE_SWITCH] = np.int32(self.diffuse)
        if self.energy is not None:
            out[ENERGY_SWITCH] = np.float64(self.energy)
        return out

    def embed(self, u: Float[ArrayLike, " n"]) -> np.ndarray:
        """The spec's parameter vector -> the root's."""
        u = np.asarray(u)
        out = np.array(self.fill, dtype=u.dtype)
        out[list(self.index)] = u
        return out

    def expand(self, params: dict) -> dict:
        """The spec's parameters -> the root's (held ones at their neutral value),
        with the switches: what the root's params-programs take."""
        first = next(iter(params.values()))
        dtype = getattr(first, "dtype", np.float64)
        out = {}
        for p in parameter_schema(self.root):
            if p.name in params:
                out[p.name] = params[p.name]
            else:       # held (a root parameter without a neutral value is never missing: root_of)
                out[p.name] = np.full((3,) if p.size == 3 else (), p.neutral, dtype)
        return with_switches(out, self.switches())


def _holdable(params) -> bool:
    return all(p.neutral is not None for p in params)


def root_of(spec: ModelSpec, switch_energy: bool = False) -> ModelSpec | None:
    """The family root whose programs run ``spec``, or None (it runs its own); with
    ``switch_energy`` a model without compensation runs on its Kulla-Conty sibling's."""
    if spec.composition == "gltf":     # glTF: every extension that can be held at a neutral value
        own = {p.name for p in parameter_schema(spec)}      # (and declares none of the spec's: tint's colour)
        extra = tuple(name for name, term in GLTF_EXTENSIONS.items()     # (metal and nonmetal hold
                      if _holdable(term.params) and not term.holds            # metallic: a model of their own)
                      and not own & {p.name for p in term.params})
        if "metal" in spec.gltf_extensions:       # a metal draws none of the dielectric's options
            extra = tuple(name for name in extra if name not in METAL_UNUSED)
        return dataclasses.replace(spec, gltf_extensions=spec.gltf_extensions + extra)
    if spec.own is not None or spec.anisotropic or spec.lobe_model or spec.diffuse not in SWITCH_DIFFUSES:
        return None
    own = {p.name for p in FRESNELS[spec.fresnel].params}
    wider = [name for name, term in FRESNELS.items()       # the spec's own, or one with held parameters more
             if own <= {p.name for p in term.params}
             and _holdable(p for p in term.params if p.name not in own)]
    energy = ("kulla_conty" if switch_energy and spec.energy == "none" and NDFS[spec.ndf].energy_tables
              else spec.energy)
    return dataclasses.replace(spec, diffuse=SWITCH_DIFFUSES[0], energy=energy,
                               fresnel=max(wider, key=lambda name: len(FRESNELS[name].params)))


# (the roots shared here, switch_energy): set by ``shared_programs``
_SHARED = contextvars.ContextVar("shared_programs", default=(frozenset(), False))


def enabled() -> bool:
    """False with BRDF_FIT_FAMILY=off: no shared programs, no warm starts (the "before" of benchmarks)."""
    return os.environ.get("BRDF_FIT_FAMILY") != "off"


@contextlib.contextmanager
def shared_programs(models: "list[str | ModelSpec]", switch_energy: bool = False) -> Iterator[None]:
    """Within it, the models of every root that two or more of ``models`` share run on
    the root's programs (``variant``); outside, each model on its own.  ``switch_energy``:
    the models with and without Kulla-Conty compensation on one root (``root_of``)."""
    shared = _shared_roots(tuple(models), switch_energy) if enabled() else frozenset()
    token = _SHARED.set((shared, switch_energy))
    try:
        yield
    finally:
        _SHARED.reset(token)


@functools.cache
def _shared_roots(models: tuple, switch_energy: bool) -> frozenset:
    """The roots that two or more of ``models`` share (``shared_programs``), found once per list:
    a tiny table's fits and screenings enter the context some 70 times, each parsing the list."""
    counts = collections.Counter(root_of(parse_model(m), switch_energy) for m in models)
    return frozenset(root for root, n in counts.items() if root is not None and n > 1)


def variant(spec: ModelSpec) -> Variant | None:
    """``spec`` on its family's root, when the root's programs are shared here
    (``shared_programs``), else None: the model runs its own programs."""
    shared, switch_energy = _SHARED.get()
    v = _variant(spec, switch_energy)
    return v if v is not None and v.root in shared else None


@functools.cache
def _variant(spec, switch_energy=False):
    root = root_of(spec, switch_energy)
    if root is None:
        return None
    where = {p.name: (a, b) for p, a, b in layout(root)}
    index = tuple(i for p, _, _ in layout(spec) for i in range(*where[p.name]))
    names = {p.name for p in parameter_schema(spec)}
    on = tuple((p.name, float(p.name in names)) for p in parameter_schema(root) if p.neutral is not None)
    fill = tuple(from_params(root, {p.name: p.default for p in parameter_schema(root)}))
    return Variant(spec, root, index, fill, on,
                   diffuse=SWITCH_DIFFUSES.index(spec.diffuse) if root.composition != "gltf" else None,
                   energy=float(spec.energy == root.energy) if root.energy == "kulla_conty" else None)


def with_switches(params: dict, switches: dict) -> dict:
    """The root's parameters with its switches among them (brdf.model: the diffuse lobe, the compensation)."""
    return dict(params, **{k: v for k, v in switches.items() if k != "on"})


def held(root: ModelSpec, u: Float[ArrayLike, " n"], switches: dict) -> dict:
    """to_params(root, u) with every parameter the variant lacks at its neutral value (JAX, in a program)."""
    params = to_params(root, u)
    neutral = {p.name: p.neutral for p in parameter_schema(root)}
    for name, flag in switches["on"].items():
        params[name] = jnp.where(flag > 0, params[name], neutral[name])
    return params


def switched_params(root: ModelSpec, u: Float[ArrayLike, " n"], switches: dict) -> dict:
    """What the root's BRDF evaluates for a variant: ``held`` parameters with the switches."""
    return with_switches(held(root, u, switches), switches)


def jit_u_program(fn: Callable, switched: bool, name: str) -> Callable:
    """``fn(u, switches, data)`` compiled (``stored_jit``, ``name``: the program and its static
    arguments): a family root's program when ``switched``, else (u, data) without switches."""
    name = f"{name} switched={switched}"
    return stored_jit(fn, name) if switched else stored_jit(lambda u, data: fn(u, None, data), name)


class VariantProgram:
    """A model's u-program, ``(u, *args) -> (value, gradient, *rest)``, run by its
    root's program ``(u_root, switches, *args)``: the vector is embedded, the
    gradient cut back to the model's entries (and so are the columns of the
    per-channel gradients dS/du, ``rest[1]`` of the fused log programs)."""

    def __init__(self, program: Callable, variant: Variant) -> None:
        self.program, self.variant = program, variant
        self._switches = variant.switches()
        self._index = np.asarray(variant.index)

    def __call__(self, u, *args):
        value, grad, *rest = self.program(self.variant.embed(u), self._switches, *args)
        if len(rest) > 1:
            rest[1] = np.asarray(rest[1])[:, self._index]
        return (value, np.asarray(grad)[self._index], *rest)

    def lower(self, u: Float[ArrayLike, " n"], *args: object) -> object:
        """The root program lowered for the model's arguments (fit's compile-ahead)."""
        return self.program.lower(self.variant.embed(u), self._switches, *args)


class ExpandedProgram:
    """A model's params-program, ``(params, *args)``, run by its root's on ``Variant.expand``ed parameters."""

    def __init__(self, program: Callable, variant: Variant) -> None:
        self.program, self.variant = program, variant

    def __call__(self, params, *args):
        return self.program(self.variant.expand(params), *args)

    def lower(self, params: dict, *args: object) -> object:
        """The root program lowered for the model's arguments (fit's compile-ahead)."""
        return self.program.lower(self.variant.expand(params), *args)


def shared(make: Callable) -> Callable:
    """Decorate a per-spec program factory ``make(spec, *static) -> jitted f(params, *args)``:
    a model with a family root gets its root's program (compiled once for the
    family) called with expanded parameters; any other model its own."""
    own = functools.cache(make)

    def program(spec, *static):
        v = variant(spec)
        return own(spec, *static) if v is None else ExpandedProgram(own(v.root, *static), v)
    program.__doc__ = make.__doc__
    return program


def params_program(spec: ModelSpec) -> Callable:
    """u -> the spec's parameters, compiled: its own to_params program, or its root's."""
    v = variant(spec)
    if v is None:
        return to_params_jit(spec)
    root_params = to_params_jit(v.root)
    names = [p.name for p in parameter_schema(spec)]

    def params(u):
        out = root_params(v.embed(u))
        return {name: out[name] for name in names}
    return params
