"""Fit several models to one measurement: ``fit_models`` yields each model's outcome, in order.

The commands that fit a list of models on one file (``fit``, ``batch``,
``export``) share this loop.  The samples and the image targets are made
once; a model starts from its parent's optimum (``fit.warm_start``: +ms from
the model without it).  With ``screen`` (``--model auto``), every model is
screened cheaply first and only the contenders are fitted, each exactly as
without it (fitting/screen.py); the others' outcome is ``ModelScreened``.
With ``cut`` (``auto`` where screening does not apply: losses other than log
and hybrid, other optimizers), a model that cannot beat the models before it
stops after its coarse stage (``fit.ModelCut``).

With ``threads`` = 2, two fits run at once: XLA's programs leave the GIL, and
on two cores one fit's scan and coarse stage overlap the other's refinement
and final errors.  The outcomes equal those of one thread, bit for bit: a
model waits for what it reads from the models before it -- its parents'
results before it starts, and, with ``cut``, every earlier result before it
decides whether it is cut.

This module imports nothing heavy (``FIT_THREADS`` is read by brdf_fit.batch.executors).
"""

import concurrent.futures
import contextlib
import os
import typing
from collections.abc import Callable, Collection, Iterator

from .memory import check as check_memory
from .ranking import best_ranking_error

if typing.TYPE_CHECKING:
    from data_loaders import MeasuredBRDF

    from .result import FitResult
    from .screen import ModelScreened

#: Fits run at once by default: two where the machine has two cores or more
#: (more fits at once only share the same cores).
FIT_THREADS = min(2, os.cpu_count() or 1)
#: ``apart`` models (the glTF family) refined: within APART_MARGIN x the best of them
#: screened, at most APART_MOST.  Replayed on the 80 MERL tables (benchmarks/family_screen.py,
#: docs/batch.md): the shipped material is the same on all 80 at 1.25 and 3 (2: green-fabric's
#: image error 1.055x; 1: seven tables, up to 1.098x); it keeps 62 % of the family's fit seconds
#: and adds 9 % for its screening.
APART_MARGIN, APART_MOST = 1.25, 3


def fit_models(measured: "MeasuredBRDF", models: list[str], *, cut: bool = False, screen: str | None = None,
               threads: int = 1, known: dict[str, "FitResult"] | None = None,
               screened: "dict[str, ModelScreened] | None" = None,
               on_screened: "Callable[[dict[str, ModelScreened]], object] | None" = None,
               unscreened: "Collection[str]" = (), apart: "Collection[str]" = (),
               **options: object) -> Iterator[tuple[str, "FitResult | Exception"]]:
    """Fit each of ``models`` to ``measured``; yield (model, outcome) in the order
    of ``models`` as soon as each is known.  The outcome is the FitResult, or the
    exception its fit raised (``fit.ModelCut`` for a cut model,
    ``screen.ModelScreened`` for a screened one; a caller decides whether it
    ends the work).  ``screen`` ("fit" or "export": the ranking it screens by,
    ``--model auto``): every model is screened and only the contenders are
    fitted (fitting/screen.py), each exactly as without ``screen``; where
    screening does not apply (another loss or optimizer), ``cut`` instead.
    ``known``: results already at hand (a resumed batch), yielded as they are
    and read like fitted ones.  ``screened``: a screening's outcome recorded
    earlier (a resumed batch's ``MATERIAL.screening``): no screening runs, those
    models' outcome is theirs and every other model is a contender.
    ``on_screened``: called (it must not raise) with the outcome of the screening
    run here as soon as it is known, before the first contender's fit, so a
    caller can record it.  ``unscreened``: models of ``models`` fitted fully whatever
    the screening or the cut (those a list names beside ``auto``: ``auto.fitted_fully``).
    ``apart``: models of ``models`` screened as a group of their own, by the ranking of
    their exported material, APART_MARGIN and APART_MOST (export-first's glTF family
    beside ``auto``: the shipped material is chosen among its contenders and ``auto``'s);
    never cut.  ``options``: those of ``fit.fit`` (``loss``, ``samples``, ``seed``,
    ``max_theta``...)."""
    from brdf.model import parse_model

    from .family import shared_programs
    from .fit import fit, image_targets, is_parent, prepare, warm_start
    known = dict(known or {})
    todo = [model for model in models if model not in known and model not in (screened or {})]
    try:
        if todo:    # once per measurement: the memory it needs, the samples and the image error's scene
            check_memory(len(measured.values), auto=bool(screen or cut), name=measured.provenance.path)
            sampling = {name: options[name] for name in ("max_theta", "samples", "seed", "dtype") if name in options}
            options.setdefault("data", prepare(measured, **sampling))
            options.setdefault("image", image_targets(measured))
    except Exception as err:  # noqa: BLE001 -- every model to fit fails with it
        yield from ((model, known.get(model, err)) for model in models)
        return
    if screened is None:
        try:
            screened = _screened(measured, models, options, screen, unscreened, apart, threads) \
                if screen and todo else None
        except Exception:  # noqa: BLE001 -- a screening that fails screens nothing: every model is fitted
            screened = None
        if screened is not None and on_screened is not None:
            on_screened(screened)
    cut = cut and screened is None       # screening replaces the cut
    screened = screened or {}
    outcomes: list[concurrent.futures.Future] = []

    def settled(before):
        """The results among the outcomes of the models at ``before`` (waiting for them)."""
        done = [outcomes[j].result() for j in before]
        return [r for r in done if not isinstance(r, Exception)]

    def one(i, model):
        if model in known:
            return known[model]
        if model in screened:
            return screened[model]
        spec = parse_model(model)
        parents = [j for j in range(i) if is_parent(parse_model(models[j]), spec)]
        cuts = cut and model not in unscreened and model not in apart
        bound = (lambda: best_ranking_error(settled(range(i)))) if cuts else None
        with shared_programs(models), _own_code(spec):     # one compiled program per family
            return fit(measured, model, warm=warm_start(spec, settled(parents)), cut_above=bound, **options)

    def outcome(i, model):
        try:
            return one(i, model)
        except Exception as err:  # noqa: BLE001 -- the caller decides
            return err

    if threads <= 1:
        for i, model in enumerate(models):
            future = concurrent.futures.Future()
            future.set_result(outcome(i, model))
            outcomes.append(future)
            yield model, future.result()
        return
    pool = concurrent.futures.ThreadPoolExecutor(threads, thread_name_prefix="brdf-fit")
    try:
        for i, model in enumerate(models):     # first in, first started: a model waits only for earlier ones
            outcomes.append(pool.submit(outcome, i, model))
        for model, future in zip(models, outcomes):
            yield model, future.result()
    finally:
        pool.shutdown(wait=False, cancel_futures=True)


@contextlib.contextmanager
def _own_code(spec):
    """The fit of a model of one's own (spec.own): the user's code runs in it (evaluate
    traced, jax.debug callbacks run), so what it prints goes to stderr, and an exception
    it causes is one line naming its file (brdf/own_guard.py: running), an OwnModelError,
    which ends that model's fit only (a FitError too); a cut and MemoryError pass as they are."""
    from brdf.own_guard import OwnModelError, running

    from .fit import FitError, ModelCut
    try:
        with running(spec.own, "its fit", passing=(ModelCut, FitError)):
            yield
    except FitError as err:     # (non-finite values: its formula on these pairs) that model only
        if spec.own is None:
            raise
        raise OwnModelError(str(err)) from None


def _screened(measured, models, options, screen, unscreened, apart, threads):
    """The screening's outcome (``screen.screened_out``) of ``models`` less ``unscreened``:
    ``apart`` screened as a group of its own, by their exported material, the others by
    ``screen``'s ranking, both in one ScreenScene; None where screening does not apply."""
    from .screen import ScreenScene, screened_out
    rest = [m for m in models if m not in unscreened and m not in apart]
    own = [m for m in models if m in apart and m not in unscreened]
    scene = ScreenScene.from_measured(measured, options["data"][1], options.get("image")) if rest and own else None
    outcomes = [screened_out(measured, rest, options, screen, threads=threads, scene=scene) if rest else None,
                screened_out(measured, own, options, "export", APART_MARGIN, APART_MOST, threads=threads,
                             scene=scene) if own else None]
    if all(o is None for o in outcomes):
        return None
    return {model: out for o in outcomes if o is not None for model, out in o.items()}
