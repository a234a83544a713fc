"""Fit a brdf ModelSpec to a MeasuredBRDF.

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

Optimizers: nlopt (``lbfgs`` = LD_LBFGS, ``bobyqa`` = LN_BOBYQA, global
``crs2`` = GN_CRS2_LM and ``mlsl`` = G_MLSL_LDS with L-BFGS inside) driven by
JAX gradients, and optimistix (``optx_bfgs``, ``optx_lm`` =
LevenbergMarquardt, ``optx_dogleg``), whose solves run entirely under jit.
"""

import concurrent.futures
import math
import time
import typing

from . import _jax  # noqa: F401 -- float64 and the compilation cache, before any JAX array
import jax
import jax.numpy as jnp
import nlopt
import numpy as np

from brdf import __version__
from brdf.model import (Geometry, evaluate, evaluate_geometry, geometry, model_string,
                        parameter_schema, parse_model)
from brdf.specular import ggx_ndf

from . import fused
from .losses import channel_mse, check_loss, compress, log1p
from .result import FitResult
from .transforms import from_params, to_params, to_params_jit, to_python, vector_size

NLOPT_ALGORITHMS = {
    "lbfgs": nlopt.LD_LBFGS,
    "bobyqa": nlopt.LN_BOBYQA,
    "crs2": nlopt.GN_CRS2_LM,
    "mlsl": nlopt.G_MLSL_LDS,
}
OPTX_SOLVERS = ("optx_bfgs", "optx_lm", "optx_dogleg")
OPTIMIZERS = tuple(NLOPT_ALGORITHMS) + OPTX_SOLVERS
DEFAULT_OPTIMIZER = "lbfgs"
GLOBAL_BOX = 6.0        # unconstrained box +-6 for the global nlopt searches
ROUGHNESS_SCAN = np.geomspace(0.04, 1.0, 16)
COAT_STARTS = ((0.0, 0.1), (1.0, 0.05), (1.0, 0.15), (1.0, 0.4))   # (clearcoat, its roughness)
COARSE_SAMPLES = 20_000  # pairs each start of a multi-start sees
COARSE_TOL = 1e-5        # the starts only need to find their basin
CHUNK = 1 << 17         # samples per jitted chunk when evaluating the full set


class FitError(ValueError):
    """A fit that cannot run (no usable samples, bad option)."""


class SampleSet(typing.NamedTuple):
    """Direction pairs (as a brdf Geometry), measurements and normalised weights.

    ``weights`` sum to 1/2 so that the two orientations of every pair together
    carry a total weight of 1.  Everything that does not depend on the model
    is computed once: the geometry (an isotropic model's loss reads four
    contiguous cosine arrays) and the log-compressed measurements
    log1p(fhat cos) of both orientations, which the default loss compares with.
    """
    geo: Geometry
    values: jax.Array
    weights: jax.Array
    log_i: jax.Array     # log1p(values * n.l), orientation (wi, wo)
    log_o: jax.Array     # log1p(values * n.v), orientation (wo, wi)

    @classmethod
    def from_arrays(cls, wi, wo, values, weights, dtype):
        w = np.asarray(weights, dtype=np.float64)
        total = w.sum()
        if not np.isfinite(total) or total <= 0:
            raise FitError("no usable samples (all weights zero)")
        geo = jax.tree.map(lambda x: x.astype(dtype),
                           _geometry(np.asarray(wi, np.float64), np.asarray(wo, np.float64)))
        values = np.asarray(values, np.float64)
        log_i = np.log1p(values * np.asarray(wi)[:, 2:3])
        log_o = np.log1p(values * np.asarray(wo)[:, 2:3])
        return cls(geo, *(_device(x, dtype) for x in (values, 0.5 * w / total, log_i, log_o)))

    @property
    def size(self):
        return int(self.weights.shape[0])

    def every(self, step):
        """Every ``step``-th sample, weights renormalised (a coarse copy for multi-start).

        Sliced in numpy: an eager JAX slice would compile a kernel per shape."""
        part = jax.tree.map(lambda x: np.asarray(x)[::step], self)
        weights = part.weights * (0.5 / part.weights.sum())
        return jax.device_put(part._replace(weights=weights))

    def parts(self, size):
        """The set as consecutive ``size``-sample parts, the last one padded with
        zero-weight copies of its last sample; sliced in numpy (no compiles)."""
        if size == self.size:
            return [self]
        host = jax.tree.map(np.asarray, self)
        out = []
        for start in range(0, self.size, size):
            part = jax.tree.map(lambda x: x[start:start + size], host)
            extra = size - part.weights.shape[0]
            if extra:      # as ``padded``, in numpy
                pad = lambda x: np.pad(x, [(0, extra)] + [(0, 0)] * (x.ndim - 1), mode="edge")
                part = jax.tree.map(pad, part)._replace(weights=np.pad(part.weights, (0, extra)))
            out.append(jax.device_put(part))
        return out

    def padded(self, extra):
        """The set with ``extra`` zero-weight copies of its last sample appended."""
        pad = lambda x: jnp.pad(x, [(0, extra)] + [(0, 0)] * (x.ndim - 1), mode="edge")
        return jax.tree.map(pad, self)._replace(weights=jnp.pad(self.weights, (0, extra)))


_geometry = jax.jit(geometry)    # one compiled call instead of a dozen eager ops


def _device(x, dtype):
    """numpy -> JAX array without a compile (jnp.asarray compiles a small program per shape)."""
    return jax.device_put(np.asarray(x, dtype))


def is_reciprocal(spec):
    """True when f(wi, wo) == f(wo, wi) for the spec (clearcoat and Turquin are not)."""
    return not spec.clearcoat and spec.energy != "turquin"


def _both_orientations(spec, params, data):
    f = evaluate_geometry(spec, params, data.geo)
    fr = f if is_reciprocal(spec) else evaluate_geometry(spec, params, data.geo.reversed())
    return f, fr


def channel_errors(spec, loss, params, data):
    """Per-channel weighted mean square error over both orientations: (3,)."""
    f, fr = _both_orientations(spec, params, data)
    if loss == "log":
        r1 = log1p(f * data.geo.n_dot_l[:, None]) - data.log_i
        r2 = log1p(fr * data.geo.n_dot_v[:, None]) - data.log_o
        return jnp.dot(data.weights, r1 * r1 + r2 * r2)
    return (channel_mse(loss, f, data.values, data.geo.n_dot_l, data.weights)
            + channel_mse(loss, fr, data.values, data.geo.n_dot_v, data.weights))


def _objective(spec, loss, data):
    """u -> loss (mean over RGB of per-channel RMS), a pure function for jit."""
    def objective(u):
        return jnp.mean(jnp.sqrt(channel_errors(spec, loss, to_params(spec, u), data)))
    return objective


def _plain_value_and_grad(spec, loss):
    """(u, data) -> (loss, gradient, per-channel errors) by jax.value_and_grad."""
    def objective(u, data):
        errors = channel_errors(spec, loss, to_params(spec, u), data)
        return jnp.mean(jnp.sqrt(errors)), errors

    def value_and_grad(u, data):
        (value, errors), grad = jax.value_and_grad(objective, has_aux=True)(u, data)
        return value, grad, errors
    return jax.jit(value_and_grad)


def _residuals(spec, loss, data):
    """u -> residual vector whose sum of squares is sum over channels of the MSE."""
    if loss == "relative":
        raise FitError("least-squares optimizers support the log, ngan and cuberoot losses")
    sw = jnp.sqrt(data.weights)[:, None]

    def residuals(u, _args=None):
        f, fr = _both_orientations(spec, to_params(spec, u), data)
        ci, co = data.geo.n_dot_l[:, None], data.geo.n_dot_v[:, None]
        r1 = compress(loss, f, ci) - compress(loss, data.values, ci)
        r2 = compress(loss, fr, co) - compress(loss, data.values, co)
        return jnp.concatenate([(sw * r1).ravel(), (sw * r2).ravel()])
    return residuals


def full_set_errors(spec, loss, params, data, chunk=CHUNK):
    """Per-channel MSE on a large set: one jitted pass over fixed-size chunks (bounded memory)."""
    return np.asarray(_full_errors(spec, loss, min(chunk, data.size))(params, data), np.float64)


_FULL_CACHE = {}


def _full_errors(spec, loss, chunk):
    key = (spec, loss, chunk)
    if key not in _FULL_CACHE:
        def errors(params, data):
            parts = jax.tree.map(lambda x: x.reshape((-1, chunk) + x.shape[1:]),
                                 data.padded(-data.size % chunk))
            per_chunk = jax.lax.map(lambda part: channel_errors(spec, loss, params, part), parts)
            return jnp.sum(per_chunk, axis=0)
        _FULL_CACHE[key] = jax.jit(errors)
    return _FULL_CACHE[key]


# --- data preparation -------------------------------------------------------

def prepare(measured, max_theta=80.0, samples=100_000, seed=0, dtype=jnp.float64):
    """(full SampleSet, optimisation SampleSet) from a MeasuredBRDF."""
    selected = measured.select(max_theta_deg=max_theta)
    if len(selected.wi) == 0 or not np.any(selected.valid):
        raise FitError(f"{_name(measured)}: no valid samples with theta <= {max_theta} degrees")
    full = SampleSet.from_arrays(selected.wi[selected.valid], selected.wo[selected.valid],
                                 selected.values[selected.valid], selected.weights[selected.valid],
                                 dtype)
    if samples and samples < int(np.sum(selected.valid)):
        sub = selected.subsample(samples, seed=seed)
        opt = SampleSet.from_arrays(sub.wi[sub.valid], sub.wo[sub.valid], sub.values[sub.valid],
                                    sub.weights[sub.valid], dtype)
    else:
        opt = full
    return full, opt


def _name(measured):
    prov = getattr(measured, "provenance", None)
    return getattr(prov, "path", None) or getattr(prov, "material", None) or "measured data"


# --- starting points --------------------------------------------------------

def _theta_h(data):
    return np.degrees(np.arccos(np.clip(np.asarray(data.geo.n_dot_h, np.float64), -1.0, 1.0)))


def initial_candidates(spec, data):
    """Data-driven starting parameter sets ({name: value}), roughly best first.

    Diffuse albedo = pi x the 25th percentile of the measurement away from the
    specular peak (theta_h > 35 deg); for each roughness of a scan, F0 (or the
    glTF base colour) is set so the model matches the median measurement in
    the peak (theta_h < 3 deg).  Anisotropic specs add anisotropy and rotation
    variants.
    """
    names = {p.name: p for p in parameter_schema(spec)}
    values = np.asarray(data.values, dtype=np.float64)
    th = _theta_h(data)
    off = th > 35.0
    albedo = np.pi * (np.percentile(values[off], 25, axis=0) if off.sum() > 10
                      else np.percentile(values, 5, axis=0))
    albedo = np.clip(albedo, 0.0, 1.0)
    peak = th < max(3.0, float(np.percentile(th, 0.5)))
    peak_value = np.median(values[peak], axis=0) - (albedo / np.pi if "albedo" in names else 0.0)

    base = {p.name: np.full(p.size, p.default) if p.size == 3 else p.default for p in names.values()}
    if "albedo" in names:
        base["albedo"] = albedo
    out = []
    for r in ROUGHNESS_SCAN:
        cand = dict(base, roughness=float(r))
        probe = dict(cand)
        if "albedo" in probe:
            probe["albedo"] = np.zeros(3)
        if "f0" in names:
            probe["f0"] = np.ones(3)
        if "base_color" in names:
            probe.update(base_color=np.ones(3), metallic=1.0)
        model = np.asarray(_evaluate_jit(spec)(_as_jax(probe), data.geo))   # fixed shape: one compile
        model_peak = np.median(model[peak], axis=0)
        scale = np.clip(peak_value / np.maximum(model_peak, 1e-12), 0.0, 1.0)
        if "f0" in names:
            cand["f0"] = scale
        if "base_color" in names:
            metal = bool(np.mean(albedo) < 0.05 and np.mean(scale) > 0.2)
            cand["metallic"] = 1.0 if metal else 0.0
            cand["base_color"] = scale if metal else np.clip(albedo / 0.96, 0, 1)
        if "eta" in names:
            from brdf.fresnel import ior_from_f0
            cand["eta"] = np.asarray(ior_from_f0(np.clip(scale, 0.02, 0.95)))
            cand["k"] = np.zeros(3)
        if "ior" in names and spec.composition != "gltf":
            from brdf.fresnel import ior_from_f0
            cand["ior"] = float(ior_from_f0(np.clip(np.mean(scale), 0.01, 0.5)))
        out.append(cand)
    if spec.clearcoat:
        # The coat is a second lobe: try it off, sharp (a core over a wide
        # base) and wide (a halo under a sharp base); from clearcoat = 0
        # alone the sigmoid's flat tail would keep it off.
        out = [dict(c, clearcoat=w, clearcoat_roughness=r) for c in out for w, r in COAT_STARTS]
    if spec.anisotropic:
        lo = names["anisotropy"].lower
        variants = [(0.0, 0.0), (0.5, 0.0), (max(lo, -0.5), 0.0), (0.5, math.pi / 4), (0.5, -math.pi / 4)]
        out = [dict(c, anisotropy=a, rotation=rot) for c in out for a, rot in variants]
    return out


def _variant(candidate):
    """What distinguishes a candidate besides roughness and the peak-matched values."""
    return tuple(candidate.get(k) for k in ("clearcoat", "clearcoat_roughness", "anisotropy", "rotation"))


def choose_starts(candidates, losses, starts):
    """Starting points: the local minima of the roughness scan (one per basin),
    the best of every variant (coat on/off, anisotropy...) first, then the
    other basins by loss, at most max(``starts``, number of variants).
    Neighbours of a minimum on the scan would only descend into the same basin."""
    order = sorted(range(len(candidates)), key=lambda i: (not np.isfinite(losses[i]), losses[i]))
    groups = {}
    for i, c in enumerate(candidates):
        groups.setdefault(_variant(c), []).append(i)
    minima = set()
    for members in groups.values():
        members = sorted(members, key=lambda i: candidates[i]["roughness"])
        for k, i in enumerate(members):
            left = losses[members[k - 1]] if k > 0 else np.inf
            right = losses[members[k + 1]] if k + 1 < len(members) else np.inf
            if np.isfinite(losses[i]) and losses[i] <= left and losses[i] <= right:
                minima.add(i)
    limit = max(1, starts, len(groups))
    chosen, seen = [], set()
    for i in order:                      # the best basin of each variant
        if i in minima and _variant(candidates[i]) not in seen:
            seen.add(_variant(candidates[i]))
            chosen.append(i)
    chosen += [i for i in order if i in minima and i not in chosen]
    chosen = chosen[:limit] or order[:1]
    return [candidates[i] for i in chosen]


_EVAL_CACHE = {}


def _evaluate_jit(spec):
    if spec not in _EVAL_CACHE:
        _EVAL_CACHE[spec] = jax.jit(lambda params, geo: evaluate_geometry(spec, params, geo))
    return _EVAL_CACHE[spec]


def _as_jax(values):
    return {k: _device(v, np.float64) for k, v in values.items()}


# --- optimizers -------------------------------------------------------------

def _run_nlopt(name, value_and_grad, u0, max_evals, tol):
    n = u0.size
    state = {"best": np.inf, "x": u0.copy(), "evals": 0}

    def f(x, grad):
        value, g = value_and_grad(x)
        value = float(value)
        if grad.size:
            grad[:] = np.asarray(g, dtype=np.float64)
        state["evals"] += 1
        if np.isfinite(value) and value < state["best"]:
            state["best"], state["x"] = value, x.copy()
        return value if np.isfinite(value) else 1e30

    opt = nlopt.opt(NLOPT_ALGORITHMS[name], n)
    opt.set_min_objective(f)
    if name in ("crs2", "mlsl"):
        opt.set_lower_bounds(np.full(n, -GLOBAL_BOX))
        opt.set_upper_bounds(np.full(n, GLOBAL_BOX))
        u0 = np.clip(u0, -GLOBAL_BOX, GLOBAL_BOX)
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


def optx_solve(spec, loss="log", solver="optx_bfgs", max_steps=400, tol=1e-7):
    """A pure (data, u0) -> (u, steps, converged) optimistix solve of ``spec`` on a
    SampleSet from ``prepare``, for use under ``jax.jit`` and ``jax.vmap``
    (e.g. ``jax.vmap(solve, in_axes=(None, 0))(data, starts)`` runs several
    starts as one batched solve).  ``solver``: one of OPTX_SOLVERS."""
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


_OPTX_CACHE = {}


def _run_optx(name, spec, loss, data, u0, max_evals, tol):
    key = (name, spec, loss, max_evals, tol)
    if key not in _OPTX_CACHE:
        _OPTX_CACHE[key] = jax.jit(optx_solve(spec, loss, name, max_evals, tol))
    u, steps, ok = _OPTX_CACHE[key](data, _device(u0, data.weights.dtype))
    value = float(_value_and_grad(spec, loss)(u, data)[0])
    return np.asarray(u, dtype=np.float64), value, int(steps), bool(ok)


_VG_CACHE = {}


def _value_and_grad(spec, loss):
    """Jitted (u, data) -> (loss, gradient, per-channel errors): the fused sums of
    fitting.fused where they apply (the same numbers, about twice as fast), else
    jax.value_and_grad."""
    key = (spec, loss)
    if key not in _VG_CACHE:
        _VG_CACHE[key] = (fused.value_and_grad(spec) if fused.supports(spec, loss) else
                          _plain_value_and_grad(spec, loss))
    return _VG_CACHE[key]


def _minimise(optimizer, spec, loss, data, u0, max_evals, tol, dtype):
    """One local (or global) optimisation from u0: (u, loss, evaluations, converged)."""
    if optimizer in NLOPT_ALGORITHMS:
        vg = _value_and_grad(spec, loss)
        return _run_nlopt(optimizer, lambda x: vg(np.asarray(x, dtype), data)[:2], u0, max_evals, tol)
    return _run_optx(optimizer, spec, loss, data, u0, max_evals, tol)


# --- the fit ----------------------------------------------------------------

_COMPILER = concurrent.futures.ThreadPoolExecutor(max_workers=2, thread_name_prefix="brdf-compile")
_COMPILED = set()


class _Ahead:
    """Compilations running in the background, by name; ``wait`` joins some or all."""

    def __init__(self, futures):
        self.futures = futures

    def wait(self, *names):
        for name in names or list(self.futures):
            future = self.futures.pop(name, None)
            try:
                future and future.result()
            except Exception:      # the call itself will raise it, with its context
                pass


def _compile_ahead(spec, loss, u, coarse, opt_data, full):
    """Compile the fit's programs on two background threads: the loss+gradient
    for the coarse starts and for the subsample (which also gives the full-set
    errors, part by part), the parameter map, and for a loss other than M1 the
    full-set M1.

    A fresh process spends most of its first fit compiling, and XLA compiles
    without holding the GIL, so on two cores the compilations overlap each
    other and the candidate scan's set-up.  ``lower().compile()`` fills the
    same cache the calls use.  Each (function, shapes) is sent once per process.
    """
    vg = _value_and_grad(spec, loss)
    jobs = [(name, ("vg", spec, loss, data.size, u.dtype), vg, (u, data))
            for name, data in (("coarse", coarse), ("subsample", opt_data))]
    jobs.append(("params", ("params", spec, u.dtype), to_params_jit(spec), (u,)))
    if loss != "log":
        errors = _full_errors(spec, "log", min(CHUNK, full.size))
        params = jax.eval_shape(lambda u: to_params(spec, u), u)     # shapes only: no compile
        jobs.append(("m1", ("errors", spec, full.size, u.dtype), errors, (params, full)))
    futures = {}
    for name, key, fn, args in jobs:
        if key not in _COMPILED:
            _COMPILED.add(key)
            futures[name] = _COMPILER.submit(lambda fn=fn, args=args: fn.lower(*args).compile())
    return _Ahead(futures)


def _errors_by_parts(spec, loss, u, data, size):
    """Per-channel errors of a large set from the loss+gradient program compiled
    for ``size`` samples, run part by part: no program of its own to compile."""
    vg = _value_and_grad(spec, loss)
    per_part = [vg(u, part)[2] for part in data.parts(size)]    # dispatched before any is read
    return np.sum([np.asarray(e, np.float64) for e in per_part], axis=0)


def fit(measured, spec, loss="log", optimizer=DEFAULT_OPTIMIZER, samples=100_000,
        starts=3, seed=0, max_theta=80.0, polish=False, max_evals=400, tol=1e-7,
        dtype=jnp.float64, data=None):
    """Fit ``spec`` (a ModelSpec or model string) to ``measured``; return a FitResult.

    ``data`` may pass a ready (full, optimisation) pair of SampleSets from
    ``prepare`` to skip the preparation when fitting several models.
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

    # the scan uses the loss+gradient function the optimizer compiles anyway
    vg = _value_and_grad(spec, loss)
    coarse = opt_data.every(max(1, opt_data.size // COARSE_SAMPLES))
    u_example = np.asarray(from_params(spec, {p.name: p.default for p in parameter_schema(spec)}), dtype)
    later = _compile_ahead(spec, loss, u_example, coarse, opt_data, full)
    candidates = initial_candidates(spec, coarse)
    later.wait("coarse")      # not compiled twice
    losses = [float(vg(np.asarray(from_params(spec, c), dtype), coarse)[0]) for c in candidates]
    chosen = choose_starts(candidates, losses, starts)

    t_opt = time.perf_counter()
    # Coarse to fine: every start runs on a strided ~COARSE_SAMPLES part of
    # the subsample, the best is refined on the whole subsample (and, with
    # ``polish``, on the full set).
    if len(chosen) == 1:
        coarse = opt_data
    stages = [(coarse, chosen)]
    if coarse is not opt_data:
        stages.append((opt_data, None))
    if polish and opt_data is not full:
        stages.append((full, None))
    runs, best = [], None
    for stage, (stage_data, starts_here) in enumerate(stages):
        if stage_data is opt_data:
            later.wait("subsample")
        stage_best = None
        for u0 in ([from_params(spec, c) for c in starts_here] if starts_here else [best[0]]):
            stage_tol = COARSE_TOL if len(stages) > 1 and stage == 0 else tol
            u, val, evals, ok = _minimise(optimizer, spec, loss, stage_data, u0, max_evals, stage_tol,
                                          dtype)
            runs.append({"stage": stage, "samples": stage_data.size, "loss": val,
                         "evaluations": evals, "converged": ok})
            if stage_best is None or val < stage_best[1]:
                stage_best = (u, val, ok)
        best = stage_best
    seconds_opt = time.perf_counter() - t_opt

    later.wait()
    u_best = np.asarray(best[0], dtype)
    params = to_params_jit(spec)(u_best)
    loss_channels = np.sqrt(_errors_by_parts(spec, loss, u_best, full, opt_data.size))
    m1_channels = loss_channels if loss == "log" else np.sqrt(full_set_errors(spec, "log", params, full))
    values = [*np.ravel(u_best), *m1_channels, *loss_channels]
    if not np.all(np.isfinite(values)):
        raise FitError(f"{_name(measured)}: the fit of {model_string(spec)} ended with non-finite "
                       "parameters or errors; the data cannot determine this model")
    prov = _provenance(measured)
    return FitResult(
        spec=model_string(spec),
        parameters=to_python(spec, params),
        errors={"m1": float(np.mean(m1_channels)), "m1_per_channel": [float(x) for x in m1_channels],
                "loss_name": loss, "loss": float(np.mean(loss_channels)),
                "loss_per_channel": [float(x) for x in loss_channels]},
        optimizer={"name": optimizer, "starts": len(chosen), "runs": runs,
                   "evaluations": int(sum(r["evaluations"] for r in runs)),
                   "converged": bool(best[2]), "seconds": round(seconds_opt, 4),
                   "seconds_total": round(time.perf_counter() - t_start, 4),
                   "samples": opt_data.size, "samples_full": full.size, "polish": bool(polish),
                   "max_theta": max_theta, "seed": seed,
                   "options": fit_options_record(loss, optimizer, samples, starts, seed, max_theta,
                                                 polish)},
        provenance=prov,
    )


def fit_options_record(loss, optimizer, samples, starts, seed, max_theta, polish):
    """The options a fit was asked for, as stored in ``optimizer["options"]``: a batch
    resumes a result only when they equal the new run's."""
    return {"loss": loss, "optimizer": optimizer, "samples": int(samples or 0), "starts": int(starts),
            "seed": int(seed), "max_theta": float(max_theta), "polish": bool(polish)}


def _provenance(measured):
    prov = getattr(measured, "provenance", None)
    if prov is None:
        return {"file": None, "sha256": None, "format": None, "material": None}
    get = (lambda k: prov.get(k)) if isinstance(prov, dict) else (lambda k: getattr(prov, k, None))
    path = get("path") or get("file")
    return {"file": str(path) if path else None, "sha256": get("sha256"),
            "format": get("format"), "material": get("material")}


_RESULT_EVAL_CACHE = {}

def evaluate_result(result, wi, wo):
    """Evaluate a FitResult's model at (N, 3) direction pairs -> (N, 3) numpy float64."""
    from .transforms import to_jax
    spec = parse_model(result.spec)
    if spec not in _RESULT_EVAL_CACHE:
        _RESULT_EVAL_CACHE[spec] = jax.jit(lambda p, a, b: evaluate(spec, p, a, b))
    f = _RESULT_EVAL_CACHE[spec](
        to_jax(spec, result.parameters), jnp.asarray(wi, jnp.float64), jnp.asarray(wo, jnp.float64))
    return np.asarray(f, dtype=np.float64)


__all__ = ["fit", "prepare", "FitError", "SampleSet", "OPTIMIZERS", "evaluate_result", "optx_solve",
           "initial_candidates", "full_set_errors", "is_reciprocal", "vector_size"]
