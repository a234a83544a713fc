"""Fit a brdf ModelSpec to a MeasuredBRDF: ``fit(measured, spec, *, ...)`` -> FitResult.

This module is also callable: ``fitting.fit(measured, "ggx+lambert")`` (and
``from fitting import fit``) call its ``fit`` function, while ``import
fitting.fit`` / ``from fitting.fit import X`` reach the module as usual.

The flow of ``fit``:
1. keep valid samples with theta_i, theta_o <= ``max_theta`` (80 degrees);
2. draw a stratified, seeded subsample (``samples``, default 100 000) for the
   optimizer -- the loss and its gradient on ~100 k pairs take a few ms, and
   give the same parameters (within ~1 %) as the full 1.1 M MERL cells;
3. data-driven starting points (diffuse albedo from the off-specular region,
   roughness from a scan of the loss over a roughness grid with F0 matched
   to the specular peak) and the best ``starts`` of them optimised;
4. the final errors (M1, the loss) evaluated on the full selected set, with an
   optional full-set polish.

The pieces live in their own modules, and their public names are importable
from here too: ``fitting.samples`` (``SampleSet``, ``prepare``),
``fitting.objective`` (per-channel errors, the loss and its gradient),
``fitting.optimizers`` (nlopt's ``lbfgs``, ``bobyqa``, ``crs2``, ``mlsl``
driven by JAX gradients; optimistix's ``optx_bfgs``, ``optx_lm``,
``optx_dogleg`` under jit).

Everything here runs in float64 without touching JAX's global flag: the entry
points are decorated with ``fitting._jax.float64``.
"""

import functools
import inspect
import sys
import time
import types
import typing
import weakref

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import ArrayLike, Float
from numpy.typing import DTypeLike

from brdf.model import ModelSpec, evaluate, model_string, parameter_schema, parse_model, terms

from . import family
from ._jax import float64
from .compile_ahead import compile_ahead, compile_exported
from .image_error import ImageTargets, image_error
from .losses import HYBRID, check_loss
from .material_errors import exported_errors
from .objective import (CHUNK, HYBRID_WEIGHT, HybridSet, keep_colours,  # noqa: F401
                        _objective, _value_and_grad, channel_errors, full_set_errors, is_reciprocal)
from .optimizers import (DEFAULT_OPTIMIZER, NLOPT_ALGORITHMS, OPTIMIZERS,  # noqa: F401 (re-exported)
                         OPTX_SOLVERS, _minimise, optx_solve)
from . import ranking
from .ranking import image_term
from .result import FitResult
from .second_error import picture_errors, with_second
from .result_file import MAX_MATERIAL_CHARS
from .samples import (COARSE_SAMPLES, FitError, SampleSet, _device, _name, coarse_step,  # noqa: F401
                      prepare)  # (re-exported)
from .refine import keep_picture, refine_all, release, reseed
from .starts import choose_starts, initial_candidates, scan_losses, warm_candidates
from .transforms import from_params, non_finite, own_file, to_jax, to_python, vector_size

if typing.TYPE_CHECKING:
    from data_loaders import MeasuredBRDF

COARSE_TOL = 1e-5        # the starts only need to find their basin
COARSE_REFINE = 4        # a hybrid fit refines on the coarse part first when it is 1/4 of the subsample or less
# A fit given ``cut_above`` stops after its coarse stage when the best start's M1
# there exceeds CUT_MARGIN x cut_above.  The refined fit cannot end much below
# the coarse stage's M1 (the refinement stays in the best start's basin; the
# coarse part is a strided 20 k of the subsample: on the ten dev tables x 24
# models the refined full-set M1 was 1.009-1.54 x the coarse one), and a ranking
# error is at least the M1, so such a model cannot win a ranking whose best is
# cut_above (docs/batch.md).
CUT_MARGIN = 1.1


class ModelCut(Exception):
    """A fit stopped after its coarse stage: the model cannot beat ``bound`` (``fit(cut_above=)``)."""

    def __init__(self, model: str, coarse_m1: float, bound: float) -> None:
        self.model, self.coarse_m1, self.bound = model, coarse_m1, bound
        super().__init__(f"{model} cut after its coarse stage: M1 there {coarse_m1:.4g} > "
                         f"{CUT_MARGIN:g} x the best ranking error {bound:.4g}; it cannot win")


# --- the fit ----------------------------------------------------------------

@float64
def fit(measured: "MeasuredBRDF", spec: ModelSpec | str, *, loss: str = "log", optimizer: str = DEFAULT_OPTIMIZER,
        samples: int = 100_000, starts: int = 3, seed: int = 0, max_theta: float = 80.0, polish: bool = False,
        max_evals: int = 400, tol: float = 1e-7, dtype: DTypeLike = jnp.float64,
        image_weight: float = HYBRID_WEIGHT, data: tuple[SampleSet, SampleSet] | None = None,
        image: ImageTargets | None = None, warm: dict | None = None,
        cut_above: float | typing.Callable[[], float | None] | None = None) -> FitResult:
    """Fit ``spec`` (a ModelSpec or model string) to ``measured``; return a FitResult.

    Options (keywords only): ``loss`` (``fitting.losses.LOSSES``; "log" = M1),
    ``optimizer`` (``OPTIMIZERS``), ``samples`` in the optimizer's subsample
    (0: all), ``starts`` optimised, ``seed`` of the subsample, ``max_theta``
    in degrees, ``polish`` (a last run on the full set), ``max_evals`` and
    ``tol`` of each run, ``dtype`` of the sample arrays, ``image_weight`` of
    the hybrid loss (M1 + image_weight x image error).  ``data`` may pass a
    ready (full, optimisation) pair of SampleSets from ``prepare`` to skip the
    preparation when fitting several models, and ``image`` the measurement's
    ``ImageTargets`` (made here when not given) for the image error every
    result reports and the ``hybrid`` loss.  ``warm``: the fitted parameters
    of a model with all of this one's parameters (``warm_start``): the fit
    starts from them (once per start variant) instead of the roughness scan.
    ``cut_above``: the best ranking error among models fitted so far
    (``fitting.ranking``), or a function called for it after the coarse stage
    (None: no bound); the fit raises ModelCut after its coarse stage when the
    model cannot beat it (losses whose starts minimise M1: log, hybrid).
    """
    t_start = time.perf_counter()
    spec = parse_model(spec)
    loss = check_loss(loss)
    if optimizer not in OPTIMIZERS:
        raise FitError(f"unknown optimizer {optimizer!r}; valid: {', '.join(OPTIMIZERS)}")
    full, opt_data = data if data is not None else prepare(measured, max_theta, samples, seed, dtype)
    if full.size < vector_size(spec):
        raise FitError(f"{_name(measured)}: {full.size} valid sample(s) with theta <= {max_theta:g} "
                       f"degrees cannot determine the {vector_size(spec)} parameters of "
                       f"{model_string(spec)}")

    if image is None:
        image = _image_targets_once(measured, required=loss == HYBRID)
    # The multi-start stage minimises the table loss (M1 for a hybrid fit,
    # whose image term comes in with the refinement: it ends in one of M1's
    # basins, the refinement only lowering the hybrid loss of its start).
    start_loss = "log" if loss == HYBRID else loss
    if loss == HYBRID and not (np.isfinite(image_weight) and image_weight >= 0):
        raise FitError(f"the image weight must be a finite number >= 0, got {image_weight}")
    weight = np.asarray(image_weight, dtype)
    scene = jax.tree.map(lambda x: x.astype(dtype), image.fit) if loss == HYBRID else None  # the samples' dtype

    def wrap(d):
        return d if scene is None else HybridSet(d, scene, weight)

    # the scan uses the loss+gradient function the optimizer compiles anyway
    vg = _value_and_grad(spec, start_loss)
    coarse = opt_data.every(coarse_step(opt_data.size))
    opt_set, full_set = wrap(opt_data), wrap(full)
    # Coarse to fine: every start runs on a strided ~COARSE_SAMPLES part of
    # the subsample, the best is refined on the whole subsample (and, with
    # ``polish``, on the full set).  A hybrid fit refines on the coarse part
    # first: the image term moves the parameters some way from M1's optimum
    # (30-110 evaluations), and there each evaluation costs a third; the
    # subsample's run then starts near its end (3-16).  (On a smaller subsample
    # the gain would not pay for compiling one more program.)  There every
    # start's optimum is refined, not only M1's best: the image term can prefer
    # another basin (chrome's glTF clearcoat as a broad second lobe: hybrid
    # loss 0.056 -> 0.042, M1 0.0131 -> 0.0104, image error 0.087 -> 0.065),
    # and up to three ways (``refine.refine_all``: from M1 polished, and for
    # a model of several lobes through a heavier image weight and from its start);
    # a hybrid fit drawing a worse image than M1's optimum, or giving up more than 15 % of its
    # M1, is taken back towards it (``refine.keep_picture``).
    # The hybrid loss on the subsample runs in parts of the coarse part's size,
    # through the coarse stages' programs (``objective.PartedHybrid``): none is
    # compiled for the subsample's size.
    runs_on = [("coarse", coarse, start_loss)]
    if loss == HYBRID and COARSE_REFINE * coarse.size <= opt_data.size:
        runs_on.append(("coarse refine", wrap(coarse), loss))
    runs_on.append(("subsample", opt_set, loss))
    if polish and opt_data is not full:
        runs_on.append(("full", full_set, loss))
    u_example = np.asarray(from_params(spec, {p.name: p.default for p in parameter_schema(spec)}), dtype)
    later = compile_ahead(spec, [r for r in runs_on if r[0] != "full"], u_example, full, image)
    candidates = initial_candidates(spec, coarse)
    later.wait("coarse")      # not compiled twice
    if warm is not None and {p.name for p in parameter_schema(spec)} <= set(warm):
        # the parent has every parameter of this model (it differs by a switch, +ms) and has
        # searched their basins: its optimum, once per start variant, replaces the scan
        chosen = warm_candidates(spec, candidates, warm)
    else:
        losses = scan_losses(spec, vg, candidates, coarse, dtype, start_loss)
        chosen = choose_starts(candidates, losses, starts)

    t_opt = time.perf_counter()
    if len(chosen) == 1 and loss != HYBRID:      # one start: straight on the subsample
        runs_on[:2] = [("subsample", opt_set, loss)]
    runs, best, log_best, optima, polished = [], None, None, [], []
    several_lobes = any(term.variants for term in terms(spec))
    for stage, (name, stage_data, stage_loss) in enumerate(runs_on):
        later.wait(name)
        first_hybrid = stage_loss == HYBRID and runs_on[stage - 1][2] != HYBRID   # the image term comes in
        stage_tol = COARSE_TOL if len(runs_on) > 1 and stage == 0 else tol

        def run(run_loss, run_data, start, run_tol=stage_tol, stage=stage):
            u, val, evals, ok = _minimise(optimizer, spec, run_loss, run_data, start, max_evals, run_tol, dtype)
            runs.append({"stage": stage, "samples": run_data.size, "loss": val,
                         "evaluations": evals, "converged": ok})
            return u, val, ok
        if first_hybrid:        # M1's optima refined with the image term (fitting/refine.py): every
            found = refine_all(run, stage_data, optima if name == "coarse refine"     # start's, or the best's
                               else [min(optima, key=lambda o: o[1])], stage_loss, polished)
            # the best end pinned at a bound: once more from just inside it (as M1's optima below)
            found.append(release(run, spec, stage_loss, stage_data, min(found, key=lambda f: f[1])))
        else:
            starts_u = [from_params(spec, c) for c in chosen] if stage == 0 else [best[0]]
            found = [run(stage_loss, stage_data, u0) for u0 in starts_u]
        if stage == 0:
            # an optimum pinned at a bound runs once more from just inside it, and the best
            # once more with its dropped lobes put back weak (``refine.reseed``), kept
            # when that lowers the loss by more than MOVED
            found = [release(run, spec, stage_loss, stage_data, f) for f in found]
            reseeded_end = reseed(run, spec, stage_loss, stage_data, min(found, key=lambda f: f[1]))
            if reseeded_end is not None:
                found, starts_u = found + [reseeded_end[0]], starts_u + [reseeded_end[1]]
            # M1's optima: (u, M1, for a model of several lobes the start it came from)
            optima = [(f[0], f[1], u0 if several_lobes else None) for f, u0 in zip(found, starts_u)]
        stage_best = min(found, key=lambda f: f[1])
        best, log_best = stage_best, stage_best if stage == 0 else log_best   # stage 0: M1 alone
        if stage_loss == HYBRID and name != "coarse refine":     # no colour collapse (objective.keep_colours)
            best = keep_colours(spec, best, log_best, stage_data, lambda d, u0: _minimise(
                optimizer, spec, HYBRID, d, u0, max_evals, tol, dtype), runs, stage)
        if cut_above is not None and stage == 0 and len(runs_on) > 1 and stage_loss == "log":
            bound = cut_above() if callable(cut_above) else cut_above
            if bound is not None and best[1] > CUT_MARGIN * bound:
                later.wait()            # nothing compiling in the background is left behind
                raise ModelCut(model_string(spec), float(best[1]), float(bound))
        if stage == 0:      # the exported material's programs, as the starts' best optimum converts
            compile_exported(later, spec, to_python(spec, family.params_program(spec)(best[0])), full, image, dtype)
    seconds_opt = time.perf_counter() - t_opt

    later.wait()
    if loss == HYBRID and polished and image is not None:    # the image term must not lose the picture
        t_opt = time.perf_counter()
        # the lighter weights' search on the part the hybrid refinement ran on first (the
        # coarse part: a third to a fifth of an evaluation), the kept end finished on the subsample
        search = next((d for name, d, _ in runs_on if name == "coarse refine"), opt_set)

        def hybrid_on(on):
            return lambda factor, u0: _minimise(optimizer, spec, HYBRID, on._replace(
                weight=(weight * factor).astype(dtype)), u0, max_evals, tol, dtype)
        best = keep_picture(
            spec, best, min(polished, key=lambda p: p[1])[0], image, dtype,
            lambda u0: _minimise(optimizer, spec, "log", opt_data, u0, max_evals, tol, dtype),
            runs, len(runs_on) - 1, opt_data.size, m1=lambda u: float(vg(np.asarray(u, dtype), coarse)[0]),
            lighter=hybrid_on(search), lighter_samples=search.size,
            polish=hybrid_on(opt_set) if search is not opt_set else None)
        seconds_opt += time.perf_counter() - t_opt

    u_best = np.asarray(best[0], dtype)
    params = family.params_program(spec)(u_best)
    parts = full.parts(min(CHUNK, full.size))       # the full set once, for every error taken on it
    m1_channels = np.sqrt(full_set_errors(spec, "log", params, parts))
    table_channels = (m1_channels if loss in ("log", HYBRID) else
                      np.sqrt(full_set_errors(spec, loss, params, parts)))
    pictures = picture_errors(spec, params, image.report) if image is not None else None
    loss_channels = (m1_channels + image_weight * image_term(pictures) if loss == HYBRID   # M1_c + w I
                     else table_channels)
    values = [*np.ravel(u_best), *m1_channels, *loss_channels, *(pictures["image_per_channel"] if pictures else [])]
    if not np.all(np.isfinite(values)):
        raise FitError(f"{_name(measured)}: the fit of {model_string(spec)}{own_file(spec)} ended with "
                       f"{non_finite(spec, u_best)}" + ("" if spec.own else "; the data cannot determine this model"))
    errors = {"m1": float(np.mean(m1_channels)), "m1_per_channel": [float(x) for x in m1_channels],
              "loss_name": loss, "loss": float(np.mean(loss_channels)),
              "loss_per_channel": [float(x) for x in loss_channels]}
    if pictures:
        errors.update(pictures, image_fixed=image_error(spec, params, image.fixed)[0])
    parameters = to_python(spec, params)
    errors.update(exported_errors(spec, parameters, parts, image, errors, readings=True))
    prov = _provenance(measured)
    return FitResult(
        spec=model_string(spec),
        parameters=parameters,
        errors=errors,
        optimizer={"name": optimizer, "starts": len(chosen), "runs": runs,
                   "evaluations": int(sum(r["evaluations"] for r in runs)),
                   "converged": bool(best[2]), "seconds": round(seconds_opt, 4),
                   "seconds_total": round(time.perf_counter() - t_start, 4),
                   "samples": opt_data.size, "samples_full": full.size, "polish": bool(polish),
                   "max_theta": max_theta, "seed": seed,
                   "options": fit_options_record(loss, optimizer, samples, starts, seed, max_theta,
                                                 polish, image_weight)},
        provenance=prov,
        model_file=spec.own.record if spec.own is not None else None,     # name, sha256, path as given
    )


def is_parent(other: ModelSpec, spec: ModelSpec) -> bool:
    """True when a fit of ``other`` can start one of ``spec`` (``warm_start``): the
    same lobes and the same parameters, less a switch (ggx+lambert for
    ggx+lambert+ms, ggx+lambert+clearcoat for ggx+lambert+ms+clearcoat)."""
    same_lobes = (other.ndf, other.masking, other.diffuse, other.composition) == \
        (spec.ndf, spec.masking, spec.diffuse, spec.composition)
    return (other != spec and same_lobes and other.own is None and spec.own is None
            and {p.name for p in parameter_schema(other)} == {p.name for p in parameter_schema(spec)})


def warm_start(spec: ModelSpec | str, fitted: "list[FitResult]") -> dict | None:
    """The parameters a fit of ``spec`` starts from, given results ``fitted`` on the
    same measurement: those of its best parent (``is_parent``), or None.  (A
    parent with fewer parameters was tried as one more start beside the scan:
    mostly better, but it can win the coarse stage and refine to a worse
    optimum, +2 % M1 on one dev table.)"""
    spec = parse_model(spec)
    if not family.enabled():
        return None
    parents = [r for r in fitted if is_parent(parse_model(r.spec), spec)]
    best = min(parents, key=lambda r: r.errors["m1"], default=None)
    return dict(best.parameters) if best else None


def image_targets(measured: "MeasuredBRDF", required: bool = False) -> ImageTargets | None:
    """The measurement's ImageTargets (made once per measurement and passed to
    every ``fit(..., image=)`` of it), or None when it has no lookup: then its
    results have no image error, and the hybrid loss (``required``) cannot run."""
    if not callable(getattr(measured, "lookup", None)):
        if required:
            raise FitError(f"{_name(measured)}: the hybrid loss needs a measurement with a lookup")
        return None
    image = ImageTargets.from_measured(measured)
    if ranking.SECOND_WEIGHT > 0.0:          # the second image error weighed beside it (the default)
        image = with_second(image, measured, ranking.SECOND_WEIGHT)
    return image


_IMAGE_TARGETS: dict[int, ImageTargets] = {}    # by id of a live measurement (``_image_targets_once``)


def _image_targets_once(measured, required=False):
    """``image_targets``, made once per live measurement object (not changed in place: loaders make new ones)."""
    if _IMAGE_TARGETS.get(id(measured)) is None:
        _IMAGE_TARGETS[id(measured)] = image_targets(measured, required)
        weakref.finalize(measured, _IMAGE_TARGETS.pop, id(measured), None)
    return _IMAGE_TARGETS[id(measured)]


def fit_options_record(loss, optimizer, samples, starts, seed, max_theta, polish, image_weight=HYBRID_WEIGHT):
    """The options a fit was asked for, as stored in ``optimizer["options"]``: a batch
    resumes a result only when they equal the new run's.  ``image_weight`` is
    recorded for the hybrid loss only (it changes nothing else); the second image error's
    weight whenever it is weighed (``ranking.SECOND_WEIGHT``), so that results fitted without
    it (older ones, or with BRDF_SECOND_WEIGHT=0) are fitted again, not ranked beside these."""
    record = {"loss": loss, "optimizer": optimizer, "samples": int(samples or 0), "starts": int(starts),
              "seed": int(seed), "max_theta": float(max_theta), "polish": bool(polish)}
    if loss == HYBRID:
        record["image_weight"] = float(image_weight)
    if ranking.SECOND_WEIGHT > 0.0:
        record["second_weight"] = ranking.SECOND_WEIGHT
    return record


def _provenance(measured):
    prov = getattr(measured, "provenance", None)
    if prov is None:
        return {"file": None, "sha256": None, "format": None, "material": None}
    get = (lambda k: prov.get(k)) if isinstance(prov, dict) else (lambda k: getattr(prov, k, None))
    path, material = get("path") or get("file"), get("material")
    if isinstance(material, str):           # a result file holds this much of a name (result_file.py)
        material = material[:MAX_MATERIAL_CHARS]
    return {"file": str(path) if path else None, "sha256": get("sha256"),
            "format": get("format"), "material": material}


@functools.cache
def _result_model(spec):
    return jax.jit(lambda p, a, b: evaluate(spec, p, a, b))


@float64
def evaluate_result(result: FitResult, wi: Float[ArrayLike, "n 3"],
                    wo: Float[ArrayLike, "n 3"]) -> Float[np.ndarray, "n 3"]:
    """Evaluate a FitResult's model at (N, 3) direction pairs -> (N, 3) numpy float64."""
    spec = parse_model(result.spec)
    f = _result_model(spec)(
        to_jax(spec, result.parameters), jnp.asarray(wi, jnp.float64), jnp.asarray(wo, jnp.float64))
    return np.asarray(f, dtype=np.float64)


__all__ = ["fit", "prepare", "FitError", "ModelCut", "SampleSet", "OPTIMIZERS", "evaluate_result", "optx_solve",
           "initial_candidates", "full_set_errors", "is_parent", "warm_start", "is_reciprocal", "vector_size"]


class _CallableModule(types.ModuleType):
    """This module's type: calling the module calls its ``fit``, so that
    ``fitting.fit(measured, spec, ...)`` works although ``fitting.fit`` is a module."""

    def __call__(self, measured, spec, **options):
        return fit(measured, spec, **options)


__signature__ = inspect.signature(fit)     # what help() / IPython show for fitting.fit(...)
sys.modules[__name__].__class__ = _CallableModule
