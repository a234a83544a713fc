"""Screening for ``--model auto``: every model fitted cheaply, only the contenders fitted fully.

``auto`` is judged by what it gives the user: the winner, its ranking error
(``fitting.ranking``) and the exact fit of every model it reports as fitted.
So ``fit_models(..., screen=...)`` runs in two stages:

1. every model is *screened*: one local fit of M1 (the log loss) on a strided
   ``SCREEN_SAMPLES`` part of the optimizer's subsample, from the best start
   of the roughness scan (one per start variant) or, as in a full fit, from
   its screened parent's optimum (``fit.warm_start``), at most
   ``SCREEN_EVALS`` evaluations, to SCREEN_TOL (a small table's runs to
   SMALL_SCREEN_TOL: ``ScreenScene.tol``); the best optimum released from its bounds and
   given back a dropped coat, as a full fit's (``refine.release``,
   ``starts.reseeded``; docs/batch.md: on twenty tables, the same winners kept
   at the cap, 0.45 s more screening a table, 0.5 s less refining); then
   (hybrid) the best of those optima refined with a low-resolution image term
   (a full fit refines each; replayed on the ten dev tables, refining each left
   every winner's screening ratio the same to three digits and cost 14 % more
   screening time); its screening errors are M1 on that part and the image
   error (``errors["image"]``, the reported image) of the screened parameters
   -- with ``export``, also the exported glTF material's two.  The
   models with and without ``ms`` are screened on one family root, the
   compensation a runtime switch (``family.shared_programs(switch_energy=True)``:
   half the programs to compile, the same screening errors) -- but where the
   screening part is the fit's own coarse part (a table of fewer than
   2 x SCREEN_SAMPLES pairs), on the fit's four roots (``ScreenScene.switch_energy``):
   those programs are compiled for the fits anyway, and on such a table an
   evaluation is mostly XLA's fixed cost, which a model without ``ms`` pays the
   compensation's share of on the two roots (10-35 % more per evaluation on 636
   pairs; docs/performance.md, *Many tiny tables*);
2. the *contenders*, whose screening ranking error is within ``SCREEN_MARGIN``
   x the best screened one, at most ``SCREEN_MOST`` of them (the best screened),
   are fitted fully, each exactly as ``--keep-all``
   fits it: a contender's parents (the models it starts from) are refined with
   it, and the programs are the family's (``family.shared_programs`` over the
   whole list), so its FitResult equals ``--keep-all``'s bit for bit.

Every other model's outcome is ``ModelScreened``: its screening errors, no
result.  SCREEN_MARGIN is chosen by replaying the ten dev tables x 24 models
(benchmarks/screen_margin.py, docs/batch.md): the true winner's screening
ranking error was at most 1.112 x the best screened one (red-plastic; median
1.004); 1.25 refined a median of 7 models of 24 (with their parents), at most 24
(green-fabric, where they all lie close).  SCREEN_MOST from the same replay over
twenty tables (the ten and ten of benchmarks/library_scale.py's variations): the
winner was at most the 6th best screened (among models whose screening errors tie,
within 1.4 % of each other fitted); 6 keeps every winner the margin keeps and refines
for 39 % fewer seconds (a third less with the screening); at 5 two winners of twenty
are lost, each to a model within 2.2 % of its ranking error.
"""

import functools
import math
import time
import typing

from .ranking import HYBRID_WEIGHT, exported_ranking_error, ranking_error

if typing.TYPE_CHECKING:
    from brdf.model import ModelSpec
    from data_loaders import MeasuredBRDF

    from .image_error import ImageTarget, ImageTargets
    from .samples import SampleSet

SCREEN_SAMPLES = 5_000    # pairs of the screening fit: a strided part of the optimizer's subsample
SCREEN_IMAGE = 32         # image side of the screening fit's image term (the hybrid loss)
SCREEN_EVALS = 200        # evaluations of each screening run (each costs ~1/15 of a full fit's refinement)
SCREEN_TOL = 1e-5         # relative tolerance of the screening runs (the coarse stage's) ...
SMALL_SCREEN_TOL = 3e-3   # ... and on a small table's (``ScreenScene.tol``: a third of the evaluations)
SCREEN_INSET = 0.05        # a screening start on a bound of a parameter moves this share of its range inside
SCREEN_MARGIN = 1.25      # contenders: screening ranking error <= SCREEN_MARGIN x the best screened one ...
SCREEN_MOST = 6           # ... and at most this many, the best screened (their parents added)
SCREEN_LOSSES = ("log", "hybrid")    # losses whose fits minimise M1 first; others are never screened
RANKINGS = {"fit": ranking_error, "export": exported_ranking_error}


class ScreenScene(typing.NamedTuple):
    """What every screening fit on a measurement sees: ``data`` (the screening
    SampleSet), ``image`` (the measurement's ImageTargets: the reported image
    error), ``fit_image`` (the hybrid term's low-resolution ImageTarget: SCREEN_IMAGE
    pixels wide, or a small table's own fit term, ``image.fit``, where that is no wider) and
    ``switch_energy``: the models with and without ``ms`` on one root (the module's
    docstring; False where ``data`` is the fit's own coarse part) and ``tol``, the
    screening runs' tolerance: SMALL_SCREEN_TOL there, a small table's (fewer than
    2 x SCREEN_SAMPLES pairs), where an evaluation is mostly XLA's fixed cost and the
    screening two thirds of a table's work: on 20 tables of benchmarks/library_tiny.py,
    5 640 -> 2 900 evaluations a table's screening at 1e-3 (a median 56 -> 24 a run), the
    contenders changed on 11 (models whose ranking errors tie within the noise; the
    library's results on 40, docs/performance.md, *Many tiny tables*); 3e-3 since
    2026-12-07: the screened-out models' screening seconds -16 % on 40 tables, every
    fit the library refined either way the same, the shipped material the same on all 40."""
    data: "SampleSet"
    image: "ImageTargets | None"
    fit_image: "ImageTarget | None"
    switch_energy: bool = True
    tol: float = SCREEN_TOL

    @classmethod
    def from_measured(cls, measured: "MeasuredBRDF", opt_data: "SampleSet", image: "ImageTargets | None",
                      samples: int = SCREEN_SAMPLES, image_size: int = SCREEN_IMAGE) -> "ScreenScene":
        from .image_error import ImageTarget, fit_size
        from .samples import coarse_step
        step = max(1, opt_data.size // samples)
        if image is None:
            fit_image = None
        elif fit_size(measured) <= image_size:      # a small table's: the fit's own term, made already
            fit_image = image.fit
        else:
            fit_image = ImageTarget.from_measured(measured, image_size, float(image.report.exposure))
            if not isinstance(image.report, ImageTarget):    # with the second error
                from .second_error import Pictures
                fit_image = Pictures.of(fit_image, measured, image_size, float(image.report.weight))
        small = step == coarse_step(opt_data.size)         # the fit's own coarse part: a small table
        return cls(opt_data.every(step), image, fit_image, switch_energy=not small,
                   tol=SMALL_SCREEN_TOL if small else SCREEN_TOL)


class ModelScreened(Exception):
    """The outcome of a model ``auto`` screened and did not refine: no result, its screening errors.

    ``errors``: {"m1", "image", "ranking_error"} (and "exported_m1",
    "exported_image" with ``export``) of the screening fit; ``bound``: the best
    screened ranking error on this measurement (of its group: ``fit_models(apart=)``);
    ``margin`` and ``most``: the contenders' margin and number.
    """

    def __init__(self, model: str, errors: dict[str, float], bound: float, margin: float,
                 seconds: float = 0.0, parameters: dict | None = None, most: int = SCREEN_MOST) -> None:
        self.model, self.errors, self.bound, self.margin, self.most = model, errors, bound, margin, most
        self.seconds, self.parameters = seconds, parameters or {}
        ranking = errors["ranking_error"]
        self.reason = (f"> {margin:g} x the best screened {bound:.4g}" if ranking > margin * bound else
                       f"within {margin:g} x the best screened {bound:.4g}, not among the {most} best")
        super().__init__(f"{model} screened: ranking error {ranking:.4g} {self.reason}; not refined")

    @property
    def optimizer(self) -> dict[str, float]:
        """What a summary row reads of it as of a FitResult: the screening's seconds."""
        return {"seconds_total": self.seconds}

    def to_dict(self) -> dict[str, object]:
        """What ``--json`` shows of a screened model."""
        return {"model": self.model, "status": "screened", "screening": dict(self.errors),
                "best_screened_ranking_error": self.bound, "margin": self.margin,
                "seconds": round(self.seconds, 4)}

    def to_record(self) -> dict[str, object]:
        """Everything ``from_record`` needs to rebuild it, as plain JSON values (a
        batch's screening record: a resumed batch need not screen again)."""
        return {"model": self.model, "errors": {k: float(v) for k, v in self.errors.items()},
                "bound": float(self.bound), "margin": float(self.margin), "seconds": float(self.seconds),
                "most": int(self.most), "parameters": {k: [float(x) for x in v] if isinstance(v, list) else float(v)
                               for k, v in self.parameters.items()}}

    @classmethod
    def from_record(cls, data: object) -> "ModelScreened":
        """The ModelScreened of a ``to_record`` dict.  A record is read from a file, so
        anything but exactly its fields, with their types and every number a finite
        float, raises ValueError.  (A record without ``most``, written before the glTF
        family was screened apart, is read with SCREEN_MOST.)"""
        fields = {"model", "errors", "bound", "margin", "seconds", "parameters"}
        if not isinstance(data, dict) or set(data) not in (fields, fields | {"most"}):
            raise ValueError("not a screened model's record")
        most = data.get("most", SCREEN_MOST)
        if not isinstance(most, int) or isinstance(most, bool) or most < 1:
            raise ValueError("a screened model's record: most is not a positive integer")
        model, errors, parameters = data["model"], data["errors"], data["parameters"]
        if not isinstance(model, str) or not isinstance(errors, dict) or not isinstance(parameters, dict):
            raise ValueError("a screened model's record: model, errors or parameters of the wrong type")
        numbers = [data["bound"], data["margin"], data["seconds"], *errors.values()]
        numbers += [x for v in parameters.values() for x in (v if isinstance(v, list) else [v])]
        if "ranking_error" not in errors or not all(_finite_float(x) for x in numbers):
            raise ValueError("a screened model's record: a number missing, not a float or not finite")
        return cls(model, dict(errors), data["bound"], data["margin"], data["seconds"], dict(parameters), most)


def _finite_float(x: object) -> bool:
    return isinstance(x, float) and math.isfinite(x)


class Screen(typing.NamedTuple):
    """One model's screening fit: its parameters, errors (with its ranking error) and cost."""
    model: str
    parameters: dict[str, float | list[float]]
    errors: dict[str, float]
    evaluations: int
    seconds: float


def screen_model(spec: "ModelSpec", scene: ScreenScene, *, warm: dict | None = None, loss: str = "hybrid",
                 image_weight: float = HYBRID_WEIGHT, rank: str = "fit", max_evals: int = SCREEN_EVALS,
                 tol: float | None = None, dtype: object = None, each: bool = False) -> Screen:
    """Screen one model (a ModelSpec) in ``scene``; see the module's docstring.
    ``tol``: the runs' relative tolerance (None: the scene's, ``ScreenScene.tol``).  ``each``: every
    start's M1 optimum refined with the image term, not only the best's, and the lowest hybrid loss
    kept, as a full fit refines them (the image term can prefer another of M1's basins)."""
    import numpy as np

    from brdf.model import model_string, parameter_schema

    from . import family
    from .second_error import picture_errors
    from .losses import HYBRID
    from .material_errors import exported_errors
    from .objective import HybridSet, _value_and_grad
    from .optimizers import _minimise
    from .refine import release, reseed
    from .starts import choose_starts, initial_candidates, scan_losses, warm_candidates
    from .transforms import from_params, to_python
    t = time.perf_counter()
    dtype = dtype or np.float64
    tol = scene.tol if tol is None else tol
    data, image = scene.data, scene.image
    candidates = initial_candidates(spec, data)
    if warm is not None and {p.name for p in parameter_schema(spec)} <= set(warm):
        chosen = warm_candidates(spec, candidates, warm)
    else:
        vg = _value_and_grad(spec, "log")
        losses = scan_losses(spec, vg, candidates, data, dtype, "log")
        chosen = choose_starts(candidates, losses, 1)
    evaluations = 0

    def run(run_loss, run_data, u0):
        nonlocal evaluations
        u, value, evals, ok = _minimise("lbfgs", spec, run_loss, run_data, u0, max_evals, tol, dtype)
        evaluations += evals
        return u, value, ok
    # M1, as a fit's coarse stage: the best optimum released from its bounds and reseeded
    optima = [run("log", data, from_params(spec, c))
              for c in map(functools.partial(_inside, parameter_schema(spec)), chosen)]
    m1_best = min(optima, key=lambda o: o[1])
    best = release(run, spec, "log", data, m1_best)
    reseeded_end = reseed(run, spec, "log", data, best)
    best = reseeded_end[0] if reseeded_end is not None else best
    u = np.asarray(best[0], dtype)
    if loss == HYBRID and scene.fit_image is not None:     # M1's best optimum refined with the image term
        hybrid = HybridSet(data, scene.fit_image, np.asarray(image_weight, dtype))
        ends = [u] + ([np.asarray(o[0], dtype) for o in optima if o is not m1_best] if each else [])
        u = np.asarray(min((run(HYBRID, hybrid, end) for end in ends), key=lambda r: r[1])[0], dtype)
        m1 = float(np.mean(np.sqrt(np.asarray(_value_and_grad(spec, HYBRID)(u, hybrid)[2]))))
    else:
        m1 = float(best[1])
    params = family.params_program(spec)(u)
    errors = {"m1": m1}
    if image is not None:
        pictures = picture_errors(spec, params, image.report)
        errors.update({k: v for k, v in pictures.items() if k in ("image", "second_image")})
    parameters = to_python(spec, params)
    if rank == "export":
        errors.update({k: v for k, v in exported_errors(spec, parameters, data, image, errors).items()
                       if k != "exported_model"})
    errors["ranking_error"] = RANKINGS[rank](errors)
    return Screen(model_string(spec), parameters, errors, evaluations, time.perf_counter() - t)


def _inside(schema, start):
    """``start`` with every value on a bound of its parameter moved SCREEN_INSET of the range
    inside: there the parameter map's slope is ~0 and a short run would leave it where it is
    (F90's start is 1, its upper bound: a full fit moves it in hundreds of evaluations).
    A log-scale parameter's range and share are of log(x) (``Param.position``)."""
    import numpy as np
    out = dict(start)
    for p in schema:
        if p.scale == "log" and p.name in out:
            with np.errstate(divide="ignore"):
                t = p.position(np.maximum(np.asarray(out[p.name], float), 0.0), np)
            out[p.name] = np.where(t <= 1e-3, p.at_position(SCREEN_INSET, np),
                                   np.where(t >= 1.0 - 1e-3, p.at_position(1.0 - SCREEN_INSET, np), out[p.name]))
        elif p.period is None and p.name in out:
            x, span = np.asarray(out[p.name], float), p.upper - p.lower
            edge = 1e-3 * span
            out[p.name] = np.where(x <= p.lower + edge, p.lower + SCREEN_INSET * span,
                                   np.where(x >= p.upper - edge, p.upper - SCREEN_INSET * span, x))
    return out


def screen_models(models: list[str], scene: ScreenScene, threads: int = 1, **options: object) -> list[Screen]:
    """Screen each of ``models``: a model starts from its screened parent's optimum, as
    in a full fit; ``threads`` screenings run at once, each waiting for its parents'
    (the same screens as one at a time).  ``options``: ``screen_model``'s."""
    import concurrent.futures

    from brdf.model import parse_model

    from . import family
    from ._jax import float64
    from .fit import is_parent

    futures: list[concurrent.futures.Future] = []

    @float64          # jax.enable_x64 is thread-local, and so is the shared programs' context
    def one(i, spec):
        parents = [futures[j].result() for j in range(i)
                   if family.enabled() and is_parent(parse_model(models[j]), spec)]
        warm = min(parents, key=lambda s: s.errors["m1"]).parameters if parents else None
        with family.shared_programs(models, switch_energy=scene.switch_energy):    # two roots, or the fit's
            return screen_model(spec, scene, warm=warm, **options)

    # first in, first started: a model waits only for earlier ones, already running or done
    with concurrent.futures.ThreadPoolExecutor(max(1, threads), thread_name_prefix="brdf-screen") as pool:
        for i, model in enumerate(models):
            futures.append(pool.submit(one, i, parse_model(model)))
        return [future.result() for future in futures]


def contenders(models: list[str], screens: list[Screen], margin: float = SCREEN_MARGIN,
               most: int = SCREEN_MOST) -> list[str]:
    """The models to refine, in the order of ``models``: those whose screening ranking
    error is within ``margin`` x the best, at most ``most`` of them (the best screened;
    ties in the order of ``models``), and every model one of them starts from
    (``fit.is_parent``: its result must equal a ``--keep-all`` fit's)."""
    from brdf.model import parse_model

    from .fit import is_parent
    best = min(s.errors["ranking_error"] for s in screens)
    ranked = sorted(screens, key=lambda s: s.errors["ranking_error"])       # stable: ties in models' order
    chosen = {s.model for s in ranked[:most] if s.errors["ranking_error"] <= margin * best}
    for i in reversed(range(len(models))):      # a parent comes before its child
        if models[i] in chosen:
            spec = parse_model(models[i])
            chosen.update(m for m in models[:i] if is_parent(parse_model(m), spec))
    return [m for m in models if m in chosen]


def screened_out(measured: "MeasuredBRDF", models: list[str], options: dict[str, object], rank: str = "fit",
                 margin: float = SCREEN_MARGIN, most: int = SCREEN_MOST, threads: int = 1,
                 scene: ScreenScene | None = None) -> "dict[str, ModelScreened] | None":
    """Screen ``models`` on ``measured`` (``options``: ``fit``'s, with the prepared
    ``data`` and ``image``; ``threads`` screenings at once); {model: ModelScreened} for those
    not to refine (``contenders``: ``margin``, ``most``), or
    None when the fit's loss or optimizer is not one screening stands for
    (``SCREEN_LOSSES``, the default optimizer): then every model is fitted.  ``scene``:
    the measurement's ScreenScene, made already (two groups screened on one measurement)."""
    from .optimizers import DEFAULT_OPTIMIZER
    if options.get("loss", "log") not in SCREEN_LOSSES or options.get("optimizer", DEFAULT_OPTIMIZER) != \
            DEFAULT_OPTIMIZER or len(models) < 2:
        return None
    scene = scene or ScreenScene.from_measured(measured, options["data"][1], options.get("image"))
    own = {k: options[k] for k in ("loss", "image_weight", "dtype") if k in options}
    screens = screen_models(models, scene, threads, rank=rank, **own)
    keep = set(contenders(models, screens, margin, most))
    best = min(s.errors["ranking_error"] for s in screens)
    return {s.model: ModelScreened(s.model, s.errors, best, margin, s.seconds, s.parameters, most)
            for s in screens if s.model not in keep}
