"""A hybrid fit's refinement: the paths from M1's optima to the hybrid loss's, and the picture kept.

The multi-start stage of a hybrid fit minimises M1 (fitting.fit); each start's optimum is
then refined with the image term (``refine_all``), and the fit's end is checked against
M1's best optimum (``keep_picture``): the image term may trade table error for a better
picture, never for a worse one, and at most M1_BUDGET of it: where the fit's weight buys
more, a lighter weight's end is taken.  On a dark material M1 is small and the image error
is not, so the fixed weight leans hardest to the picture there (synthetic dark specular:
M1 x 2.3 for image error x 0.16); the budget holds it to the table (docs/metrics.md, the
hybrid loss).
"""

import typing

import numpy as np
from numpy.typing import DTypeLike

from brdf.model import ModelSpec

from . import family
from .image_error import ImageTargets
from .second_error import picture_error
from .objective import HybridSet
from .starts import reseeded
from .transforms import released

MOVED = 0.01    # M1's relative fall, polished, above which its optimum is refined again (``refine_all``) ...
EXPLORE = 2     # ... and the starts whose other lobes are explored
M1_BUDGET = 1.15               # a hybrid fit's M1 at most this x its M1 optimum's (``keep_picture``) ...
LIGHTER = tuple(0.5 ** k for k in range(1, 7))   # ... else the image weight x 1/2, 1/4 ... 1/64 in turn from its end,
BISECT = 2                     # ... and between the first in balance and the one before, this many halvings of the step


def release(run: typing.Callable, spec: ModelSpec, loss: str, data: typing.Any, found: tuple) -> tuple:
    """``found`` = (u, loss, converged) of a run; when a parameter ended pinned at a bound
    (``transforms.released``: its gradient vanishes there), the better of it and
    ``run(loss, data, u0)`` from just inside the bound (blue-acrylic's glTF roughness:
    pinned at its floor 0.0316, M1 0.0097; released, 0.081 and M1 0.0084)."""
    u = released(spec, found[0])
    if u is None:
        return found
    again = run(loss, data, u)
    return again if again[1] < found[1] else found


def reseed(run: typing.Callable, spec: ModelSpec, loss: str, data: typing.Any, best: tuple) -> tuple | None:
    """The best optimum ``best`` = (u, loss, converged) run once more with its dropped lobes
    put back weak (``starts.reseeded``), released from its bounds: (that end, the start it
    ran from) when it lowers the loss by more than MOVED, else None (also for a model
    without a reseed)."""
    u0 = reseeded(spec, best[0])
    if u0 is None:
        return None
    end = release(run, spec, loss, data, run(loss, data, u0))
    return (end, u0) if end[1] < (1.0 - MOVED) * best[1] else None


def refine_all(run: typing.Callable, data: HybridSet, starts: list[tuple], loss: str, polished: list,
               explore: int = EXPLORE) -> list[tuple]:
    """Every start's M1 optimum refined with the image term on ``data``: ``starts`` =
    [(u0, its M1, the start it came from or None)] -> [(u, hybrid loss, converged)], each
    ending with the hybrid loss at the fit's weight.  The image term moves a fit only within
    the basin it starts in, and M1's optima are not always the basins the image asks for:

    1. the hybrid loss from ``u0``;
    2. M1 alone to the fit's tolerance (appended to ``polished`` as (u, M1)), and when that
       lowers M1 by more than MOVED, the hybrid loss from there: the coarse stage (to
       COARSE_TOL) can stop with a parameter on a flat stretch of its sigmoid
       (specular-violet-phenolic's glTF roughness at its floor 0.0316, M1's optimum
       0.055), where the image term alone does not move it (export-first M1 0.0055 ->
       0.0045 at the same image error);
    3. for a model of several lobes (a start given: the model's terms have start variants,
       a coat on or off...), from the ``explore`` starts whose refinements ended best, the
       hybrid loss from the start itself: M1's optimum can drop a lobe the image asks for.
       (A path through twice the weight first found white-paint's glTF coat, by chance;
       the multi-start stage's reseeded coat finds it from M1's best optimum, and without
       that path every dev table's written and ``auto`` fit is the same, 14 % fewer
       evaluations: docs/metrics.md.)
    ``run(loss, data, u0)`` -> (u, loss, converged), recorded in the fit's runs."""
    found = []
    for u0, m1_start, _ in starts:
        paths = [run(loss, data, u0)]
        u_log, m1, _ = run("log", data.samples, u0)
        polished.append((u_log, m1))
        if m1 < (1.0 - MOVED) * m1_start:        # else the same basin as the first path's
            paths.append(run(loss, data, u_log))
        found.append(paths)
    ranked = sorted(range(len(starts)), key=lambda i: min(f[1] for f in found[i]))
    for i in ranked[:explore]:
        start = starts[i][2]
        if start is not None:
            found[i].append(run(loss, data, start))
    return [f for paths in found for f in paths]


def keep_picture(spec: ModelSpec, best: tuple, u_log: np.ndarray, image: ImageTargets, dtype: DTypeLike,
                 refine: typing.Callable, runs: list, stage: int, samples: int,
                 m1: typing.Callable | None = None, lighter: typing.Callable | None = None,
                 lighter_samples: int | None = None, polish: typing.Callable | None = None) -> tuple:
    """``best`` (a hybrid fit's (u, loss, converged)) unless it is out of balance with
    ``u_log``, the best M1 optimum it was refined from: its image term (the image error, with
    ``BRDF_SECOND_WEIGHT`` plus the weighed second one: ``second_error.picture_error``) above u_log's (the
    hybrid loss bought table error for nothing), or, given ``m1`` (u -> M1), its M1 above
    M1_BUDGET x u_log's (it sold too much of the table for the picture).  Then the hybrid
    loss again from best's end with the image weight x each of LIGHTER in turn
    (``lighter(factor, u0)``) up to the first end in balance, and BISECT times from the
    heaviest end in balance at the factors half-way (geometrically) to the lightest one out
    of it: the heaviest end in balance is kept, near the budget's edge whatever the weight.
    Where no end is in balance (best's basin is not M1's: a lighter weight keeps it there),
    the same from ``u_log`` upwards: LIGHTER's factors from the lightest, each from the last
    end in balance, up to the first out of it, then the halvings; where even the lightest is
    out of balance, M1 alone refined from ``u_log`` (``refine(u0)``), as ``--loss log``
    would fit it.  The lighter weights' search may run on a smaller set than
    the fit's (``lighter_samples`` pairs: the coarse part, where an evaluation costs a third
    to a fifth); then ``polish(factor, u0)`` refines the kept end on the fit's own set at its
    factor, and that end is taken when it is still in balance.  The callables return (u,
    loss, evaluations, converged); every run is recorded in ``runs``."""
    def picture(u):
        return picture_error(spec, family.params_program(spec)(np.asarray(u, dtype)), image.report)
    picture_limit = picture(u_log)
    m1_limit = M1_BUDGET * m1(u_log) if m1 is not None else np.inf

    def balanced(u):
        return picture(u) <= picture_limit and (m1 is None or m1(u) <= m1_limit)

    def recorded(outcome, size=samples):
        u, val, evals, ok = outcome
        runs.append({"stage": stage, "samples": size, "loss": val, "evaluations": evals, "converged": ok})
        return u, val, ok

    def lighter_end(factor, u0):
        return recorded(lighter(factor, u0), lighter_samples or samples)
    if balanced(best[0]):
        return best
    u, out_of_balance, kept = best[0], 1.0, None
    for factor in LIGHTER if lighter is not None else ():
        end = lighter_end(factor, u)
        if balanced(end[0]):
            kept = (factor, end)
            break
        u, out_of_balance = end[0], factor
    if kept is None and lighter is not None:
        # best's basin is out of balance at every weight: the weights from the lightest up,
        # each from the last end in balance, starting at u_log (in M1's own basin)
        u, out_of_balance = u_log, 1.0
        for factor in reversed(LIGHTER):
            end = lighter_end(factor, u)
            if not balanced(end[0]):
                out_of_balance = factor
                break
            kept, u = (factor, end), end[0]
    if kept is None:
        return recorded(refine(u_log))
    for _ in range(BISECT):
        factor = float(np.sqrt(out_of_balance * kept[0]))
        end = lighter_end(factor, kept[1][0])
        if balanced(end[0]):
            kept = (factor, end)
        else:
            out_of_balance = factor
    if polish is not None:
        end = recorded(polish(kept[0], kept[1][0]))
        if balanced(end[0]):
            return end
    return kept[1]
