"""The fit's optimizers: nlopt driven by JAX gradients, and optimistix under jit.

nlopt: ``lbfgs`` = LD_LBFGS, ``bobyqa`` = LN_BOBYQA, global ``crs2`` =
GN_CRS2_LM and ``mlsl`` = G_MLSL_LDS with L-BFGS inside.  optimistix:
``optx_bfgs``, ``optx_lm`` = LevenbergMarquardt, ``optx_dogleg``; their solves
run entirely under jit.  Every optimizer works on the unconstrained vector u
of ``fitting.transforms``.
"""

import functools
from collections.abc import Callable

import jax
import nlopt
import numpy as np
from jaxtyping import Array, Bool, Float, Int

from brdf.model import ModelSpec, parse_model

from .choices import DEFAULT_OPTIMIZER, NLOPT_CODES, OPTIMIZERS, OPTX_SOLVERS  # noqa: F401 (re-exported)
from .objective import _objective, _residuals, _value_and_grad
from .samples import FitError, SampleSet, _device
from .transforms import stretches

NLOPT_ALGORITHMS = {name: getattr(nlopt, code) for name, code in NLOPT_CODES.items()}
GLOBAL_BOX = 6.0        # unconstrained box +-6 for the global nlopt searches


def _run_nlopt(name, value_and_grad, u0, max_evals, tol, stretch=1.0):
    """nlopt's ``name`` from u0; the global searches in the box +-GLOBAL_BOX x ``stretch``
    (per entry: fitting.transforms.stretches, the same share of each range)."""
    n = u0.size
    box = GLOBAL_BOX * np.broadcast_to(np.asarray(stretch, np.float64), (n,))
    state = {"best": np.inf, "x": u0.copy(), "evals": 0}

    def f(x, grad):
        value, g = value_and_grad(x)
        # through numpy: a JAX scalar's own float() costs ~20 us more, a sixth of an evaluation
        # on a small table (pinned to one core); the same number
        value = float(np.asarray(value))
        if grad.size:
            grad[:] = np.asarray(g, dtype=np.float64)
        state["evals"] += 1
        if np.isfinite(value) and value < state["best"]:
            state["best"], state["x"] = value, x.copy()
        return value if np.isfinite(value) else 1e30

    opt = nlopt.opt(NLOPT_ALGORITHMS[name], n)
    opt.set_min_objective(f)
    if name in ("crs2", "mlsl"):
        opt.set_lower_bounds(-box)
        opt.set_upper_bounds(box)
        u0 = np.clip(u0, -box, box)
        if name == "mlsl":
            local = nlopt.opt(nlopt.LD_LBFGS, n)
            local.set_ftol_rel(tol)
            opt.set_local_optimizer(local)
        opt.set_maxeval(max_evals * 10)
    elif name == "bobyqa":
        opt.set_maxeval(max_evals * 5)     # derivative-free: more, cheaper evaluations
        opt.set_initial_step(0.5)          # in the unconstrained space: about 10 % of a range
    else:
        opt.set_maxeval(max_evals)
    opt.set_ftol_rel(tol)
    opt.set_xtol_rel(tol)
    # BOBYQA's trust region can collapse on the sigmoid's flat directions;
    # restarting it from its own answer (a fresh region) fixes that.
    restarts = 3 if name == "bobyqa" else 1
    for _ in range(restarts):
        before = state["best"]
        converged = True
        try:
            opt.optimize(state["x"] if np.isfinite(before) else u0)
            code = opt.last_optimize_result()
            converged = code in (nlopt.SUCCESS, nlopt.FTOL_REACHED, nlopt.XTOL_REACHED,
                                 nlopt.STOPVAL_REACHED)
        except nlopt.RoundoffLimited:
            pass     # L-BFGS at the float precision limit: the best point is the answer
        except Exception:      # nlopt's own runtime_error / invalid-argument types
            converged = False
        if not before - state["best"] > tol * abs(before):
            break
    return state["x"], state["best"], state["evals"], converged


def optx_solve(
    spec: ModelSpec | str, loss: str = "log", solver: str = "optx_bfgs", max_steps: int = 400, tol: float = 1e-7,
) -> Callable[[SampleSet, Float[Array, " n"]], tuple[Float[Array, " n"], Int[Array, ""], Bool[Array, ""]]]:
    """A pure (data, u0) -> (u, steps, converged) optimistix solve of ``spec`` on a
    SampleSet from ``prepare``, for use under ``jax.jit`` and ``jax.vmap``
    (e.g. ``jax.vmap(solve, in_axes=(None, 0))(data, starts)`` runs several
    starts as one batched solve).  ``solver``: one of OPTX_SOLVERS.

    The fitter runs it in float64: jit and call it inside
    ``with jax.enable_x64(True):`` for the same numbers (``prepare``'s
    SampleSets are float64)."""
    import optimistix as optx   # here: importing it (and equinox) takes ~0.4 s

    spec = parse_model(spec)
    if solver == "optx_bfgs":
        method = optx.BFGS(rtol=tol, atol=tol * 1e-3)

        def solve(data, u0):
            fn = lambda u, _: _objective(spec, loss, data)(u)
            sol = optx.minimise(fn, method, u0, max_steps=max_steps, throw=False)
            return sol.value, sol.stats["num_steps"], sol.result == optx.RESULTS.successful
    elif solver in ("optx_lm", "optx_dogleg"):
        method = (optx.LevenbergMarquardt if solver == "optx_lm" else optx.Dogleg)(
            rtol=tol, atol=tol * 1e-3)

        def solve(data, u0):
            sol = optx.least_squares(_residuals(spec, loss, data), method, u0,
                                     max_steps=max_steps, throw=False)
            return sol.value, sol.stats["num_steps"], sol.result == optx.RESULTS.successful
    else:
        raise FitError(f"unknown optimistix solver {solver!r}; valid: {', '.join(OPTX_SOLVERS)}")
    return solve


@functools.cache
def _optx_jit(name, spec, loss, max_evals, tol):
    return jax.jit(optx_solve(spec, loss, name, max_evals, tol))


def _run_optx(name, spec, loss, data, u0, max_evals, tol):
    u, steps, ok = _optx_jit(name, spec, loss, max_evals, tol)(data, _device(u0, data.weights.dtype))
    value = float(_value_and_grad(spec, loss)(u, data)[0])
    return np.asarray(u, dtype=np.float64), value, int(steps), bool(ok)


def _minimise(optimizer, spec, loss, data, u0, max_evals, tol, dtype):
    """One local (or global) optimisation from u0: (u, loss, evaluations, converged).
    Called by ``fit``, in its float64 scope."""
    if optimizer in NLOPT_ALGORITHMS:
        vg = _value_and_grad(spec, loss)
        return _run_nlopt(optimizer, lambda x: vg(np.asarray(x, dtype), data)[:2], u0, max_evals, tol,
                          stretches(spec))
    return _run_optx(optimizer, spec, loss, data, u0, max_evals, tol)
