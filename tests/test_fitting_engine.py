"""The fitting engine: transforms, losses, M1, optimizers, parameter recovery."""

import math
import types

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from brdf import parse_model, parameter_schema
from fitting.fit import OPTIMIZERS, evaluate_result, fit, optx_solve, prepare
from fitting.losses import LOSSES
from fitting.result import FitResult
from fitting.synthetic import half_diff_grid, synthetic_measured
from fitting.transforms import from_params, to_params, to_python, to_values, vector_size, wrap_rotation


def test_transforms_round_trip_and_bounds():
    spec = parse_model("ggx_aniso+oren_nayar+clearcoat")
    rng = np.random.default_rng(1)
    values = {}
    for p in parameter_schema(spec):
        x = rng.uniform(p.lower, p.upper, p.size)
        values[p.name] = list(x) if p.size == 3 else float(x[0])
    u = from_params(spec, values)
    back = to_python(spec, to_params(spec, jnp.asarray(u)))
    for p in parameter_schema(spec):
        np.testing.assert_allclose(back[p.name], values[p.name], rtol=1e-9, atol=1e-12)
    # any unconstrained vector maps inside the bounds
    wild = to_params(spec, jnp.asarray(rng.normal(0, 30, u.size)))
    for p in parameter_schema(spec):
        if p.name != "rotation":
            x = np.asarray(wild[p.name])
            assert np.all(x >= p.lower) and np.all(x <= p.upper), p.name


def test_numpy_parameter_map_equals_the_programs():
    """to_values (numpy, for looks outside a program) gives to_params' values, tails included."""
    spec = parse_model("ggx_aniso+oren_nayar+clearcoat")
    u = np.random.default_rng(2).normal(0, 10, vector_size(spec))     # tails: sigmoid near 0 and 1
    with jax.enable_x64(True):
        expected = to_params(spec, jnp.asarray(u, jnp.float64))
    got = to_values(spec, u)
    for p in parameter_schema(spec):
        assert isinstance(got[p.name], (np.ndarray, np.floating)), p.name
        np.testing.assert_allclose(got[p.name], np.asarray(expected[p.name]), rtol=1e-13, atol=1e-300)


def test_rotation_wraps_to_half_period():
    assert wrap_rotation(math.pi / 2 + 0.1) == pytest.approx(-math.pi / 2 + 0.1)
    assert wrap_rotation(-0.3) == pytest.approx(-0.3)


def test_grid_weights_sum_to_pair_measure():
    """The synthetic grid uses MERL's cell measure: it sums to (2 pi)^2."""
    _, _, w = half_diff_grid(20, 20, 40, 1)
    assert w.sum() == pytest.approx((2 * np.pi) ** 2, rel=1e-12)
    _, _, w = half_diff_grid(10, 10, 20, 4)
    assert w.sum() == pytest.approx((2 * np.pi) ** 2, rel=1e-12)


TRUTH = {"albedo": [0.45, 0.2, 0.08], "roughness": 0.35, "f0": [0.06, 0.05, 0.045]}


@pytest.fixture(scope="module")
def lambert_data():
    return synthetic_measured("ggx+lambert", TRUTH, grid=(40, 40, 80, 1))


def m1_numpy(result, measured, max_theta=80.0):
    """M1 recomputed from its definition (issue 4), independently of fitting.losses."""
    sel = measured.select(max_theta_deg=max_theta)
    wi, wo, fhat, w = sel.wi, sel.wo, sel.values, sel.weights
    total = np.zeros(3)
    for a, b in ((wi, wo), (wo, wi)):
        f = evaluate_result(result, a, b)
        c = a[:, 2:3]
        total += np.sum(w[:, None] * (np.log1p(f * c) - np.log1p(fhat * c)) ** 2, axis=0)
    return float(np.mean(np.sqrt(total / (2 * w.sum()))))


@pytest.mark.parametrize("model, exact", [("ggx+frostbite", False), ("ggx+oren_nayar", True)])
def test_m1_matches_its_definition(lambert_data, model, exact):
    """The full-set M1 (run part by part through the subsample's program, the last
    part padded), for a fused and a plain-gradient model, against numpy."""
    result = fit(lambert_data, model, samples=20_000, starts=1)
    assert result.optimizer["samples_full"] % 20_000           # a padded last part
    assert result.errors["m1"] == pytest.approx(m1_numpy(result, lambert_data), rel=1e-9)
    # Frostbite cannot fit Lambert data exactly; Oren-Nayar with sigma = 0 is Lambert
    assert (result.errors["m1"] < 1e-4) == exact


def test_reported_loss_matches_its_definition(lambert_data):
    """With a loss other than M1, both are reported on the full set (Ngan's L2 in numpy)."""
    result = fit(lambert_data, "ggx+burley", loss="ngan", samples=20_000, starts=1)
    sel = lambert_data.select(max_theta_deg=80.0)
    total = np.zeros(3)
    for a, b in ((sel.wi, sel.wo), (sel.wo, sel.wi)):
        c = a[:, 2:3]
        residual = (evaluate_result(result, a, b) - sel.values) * c
        total += np.sum(sel.weights[:, None] * residual ** 2, axis=0)
    ngan = np.sqrt(total / (2 * sel.weights.sum()))
    np.testing.assert_allclose(result.errors["loss_per_channel"], ngan, rtol=1e-9)
    assert result.errors["m1"] == pytest.approx(m1_numpy(result, lambert_data), rel=1e-9)


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_the_losses_log_is_numpys_to_a_few_ulp(dtype):
    """fitting.losses.log1p (its own log, from x's bits and a series) against numpy's log1p
    in float64: within 4 ulp of max(1, result) from 0 to 1e30, across the range reduction's
    edges (sqrt(2) 2^k and its neighbours); inf and NaN pass through."""
    from fitting.losses import log1p
    rng = np.random.default_rng(3)
    edges = np.sqrt(2.0) * 2.0 ** np.arange(-1, 60)
    x = np.concatenate([[0.0], 10.0 ** rng.uniform(-20, 30, 20_000), rng.exponential(1.0, 20_000),
                        np.nextafter(edges, 0) - 1, edges - 1, np.nextafter(edges, np.inf) - 1]).astype(dtype)
    x = x[x >= 0]
    with jax.enable_x64(True):
        got = np.asarray(jax.jit(log1p)(jnp.asarray(x)), np.float64)
        extremes = np.asarray(jax.jit(log1p)(jnp.asarray(np.array([np.inf, np.nan], dtype))))
    want = np.log1p(x.astype(np.float64))
    ulp = np.finfo(dtype).eps * np.maximum(1.0, want)
    assert np.max(np.abs(got - want) / ulp) <= 4.0
    assert extremes[0] == np.inf and np.isnan(extremes[1])


@pytest.fixture(scope="module")
def noisy_data():
    return synthetic_measured("ggx+lambert", TRUTH, grid=(40, 40, 80, 1), noise=0.02, seed=5)


@pytest.fixture(scope="module")
def lbfgs_reference(noisy_data):
    return fit(noisy_data, "ggx+lambert", optimizer="lbfgs", samples=20_000, starts=1)


@pytest.mark.parametrize("solver", ["optx_bfgs", "optx_lm"])
def test_optimistix_solve_under_vmap(noisy_data, lbfgs_reference, solver):
    """The optimistix solve is a pure function: vmapped over three starts it gives
    each start's own solve, and every start reaches L-BFGS's parameters."""
    spec = parse_model("ggx+lambert")
    data = prepare(noisy_data, samples=5_000)[1]
    solve = optx_solve(spec, "log", solver)
    starts = jnp.asarray([from_params(spec, dict(TRUTH, roughness=r)) for r in (0.15, 0.35, 0.7)])
    batched = jax.jit(jax.vmap(solve, in_axes=(None, 0)))(data, starts)
    single = jax.jit(solve)
    for k in range(3):
        u, steps, ok = single(data, starts[k])
        assert bool(ok) and bool(batched[2][k])
        np.testing.assert_allclose(batched[0][k], u, rtol=1e-6, atol=1e-8)
        fitted = to_python(spec, to_params(spec, u))
        np.testing.assert_allclose(fitted["roughness"], lbfgs_reference.parameters["roughness"], rtol=2e-2)


@pytest.mark.parametrize("optimizer", [o for o in OPTIMIZERS if o not in ("crs2", "mlsl")])
def test_local_optimizers_agree_on_noisy_data(noisy_data, lbfgs_reference, optimizer):
    """Every local optimizer reaches L-BFGS's minimum (the noise keeps the loss
    smooth there: with exact data M1's square roots have kinks at zero, which
    derivative-free BOBYQA cannot resolve)."""
    result = fit(noisy_data, "ggx+lambert", optimizer=optimizer, samples=20_000, starts=1)
    m1_ref = lbfgs_reference.errors["m1"]
    # the least-squares solvers minimise the sum of squares, a slightly different optimum
    slack = 2e-3 if optimizer in ("optx_lm", "optx_dogleg") else 1e-5
    assert result.errors["m1"] <= m1_ref * (1 + slack)
    for name in TRUTH:
        np.testing.assert_allclose(result.parameters[name], lbfgs_reference.parameters[name],
                                   rtol=5e-3, err_msg=name)


@pytest.mark.parametrize("optimizer", ["lbfgs", "optx_bfgs", "optx_lm", "optx_dogleg"])
def test_gradient_optimizers_recover_noise_free_parameters(lambert_data, optimizer):
    result = fit(lambert_data, "ggx+lambert", optimizer=optimizer, samples=20_000, starts=1)
    for name, value in TRUTH.items():
        np.testing.assert_allclose(result.parameters[name], value, rtol=2e-3, err_msg=name)
    assert result.errors["m1"] < 1e-4


@pytest.mark.parametrize("optimizer", ["crs2", "mlsl"])
def test_global_optimizers_reach_the_basin(lambert_data, optimizer):
    result = fit(lambert_data, "ggx+lambert", optimizer=optimizer, samples=5_000, starts=1,
                 max_evals=300)
    np.testing.assert_allclose(result.parameters["roughness"], TRUTH["roughness"], rtol=0.05)


@pytest.mark.parametrize("loss", LOSSES)
def test_every_loss_is_zero_at_the_truth_and_recovers_it(lambert_data, loss):
    result = fit(lambert_data, "ggx+lambert", loss=loss, samples=20_000, starts=1)
    assert result.errors["loss_name"] == loss
    assert result.errors["loss"] < 1e-4
    np.testing.assert_allclose(result.parameters["roughness"], TRUTH["roughness"], rtol=2e-3)


@pytest.mark.parametrize("loss, model", [("log", "ggx+lambert"), ("hybrid", "gltf+specular"),
                                         ("hybrid", "ggx+oren_nayar")])
def test_float32_samples_reach_the_float64_optimum(model, loss):
    """``dtype=float32`` (samples and image scene in single precision; the fused gradient of
    the engine and glTF families, the plain gradient of a model it does not cover, with and
    without the image term) run, and end near the float64 optimum: the loss's float32
    rounding (~1e-7 relative, the optimizer's tolerance) stops the optimizer a little early."""
    data = synthetic_measured("ggx+lambert", TRUTH, grid=(16, 16, 32, 1), noise=0.03, seed=5)
    double = fit(data, model, loss=loss, samples=5000)
    single = fit(data, model, loss=loss, samples=5000, dtype=jnp.float32)
    assert single.errors["m1"] == pytest.approx(double.errors["m1"], rel=0.05)
    assert single.errors["image"] == pytest.approx(double.errors["image"], abs=1e-3)    # sRGB, in [0, 1]


# Synthetic recovery (issue 4): 2 % multiplicative noise, every parameter within 2 %.
RECOVERY_CASES = {
    "ggx+lambert": TRUTH,
    "ggx+burley": dict(TRUTH, roughness=0.5),
    "ggx+frostbite": dict(TRUTH, roughness=0.6),
    "ggx+cod_wwii": dict(TRUTH, roughness=0.3),
    "ggx+oren_nayar": dict(TRUTH, sigma=0.6),
    "ggx_aniso+lambert": dict(TRUTH, roughness=0.4, anisotropy=0.5, rotation=0.4),
}


def assert_recovered(model, truth):
    """A table of ``model`` at ``truth`` with 2 % noise, fitted by the same model: every parameter
    within 2 % of its truth."""
    data = synthetic_measured(model, truth, noise=0.02, seed=3)
    result = fit(data, model, samples=60_000)
    for name, value in truth.items():
        np.testing.assert_allclose(result.parameters[name], value, rtol=0.02, err_msg=name)


@pytest.mark.parametrize("model", list(RECOVERY_CASES))
def test_synthetic_recovery_with_noise(model):
    assert_recovered(model, RECOVERY_CASES[model])


def test_result_json_round_trip(tmp_path, lambert_data):
    result = fit(lambert_data, "ggx+lambert+clearcoat", samples=10_000, starts=1)
    path = result.save(tmp_path / "r.json")
    back = FitResult.load(path)
    assert back == result
    assert back.to_json() == result.to_json()
    assert back.schema_version == 1 and back.spec == "ggx+lambert+clearcoat"


def test_prepare_rejects_all_invalid():
    data = synthetic_measured("ggx+lambert", TRUTH, grid=(8, 8, 16, 1))
    with pytest.raises(ValueError, match="no valid samples"):
        prepare(data, max_theta=0.0)


def test_hybrid_refinements_polish_m1_first_and_explore_the_other_lobes():
    """Each start's M1 optimum is refined with the image term (fitting.refine.refine_all): from
    itself; from M1 polished to the fit's tolerance (recorded) when that lowered M1 by more than
    MOVED; and, for a model of several lobes, from the best-ending starts' start itself --
    every path with the hybrid loss at the fit's weight."""
    from fitting.refine import MOVED, refine_all
    calls = []
    ends = {"a": 3.0, "b": 1.0}        # the hybrid loss each start's refinements end with

    def run(loss, data, u0):
        calls.append((loss, data.weight if loss == "hybrid" else data, u0))
        return f"{loss}@{calls[-1][1]}<-{u0}", (1.0 if loss == "log" else ends.get(u0[-1], 2.0)), True
    data = types.SimpleNamespace(samples="coarse", weight=np.float64(0.5))
    polished = []
    found = refine_all(run, data, [("a", 2.0, "start-a"), ("b", 1.0, "start-b")], "hybrid", polished, explore=1)
    assert [c[:2] for c in calls] == [
        ("hybrid", 0.5), ("log", "coarse"), ("hybrid", 0.5),    # a: M1 polished from 2 to 1, refined again
        ("hybrid", 0.5), ("log", "coarse"),                      # b: M1 not lowered
        ("hybrid", 0.5)]                                         # the best-ending start's other lobes: b's
    assert polished == [("log@coarse<-a", 1.0), ("log@coarse<-b", 1.0)]
    assert [f[0] for f in found] == ["hybrid@0.5<-a", "hybrid@0.5<-log@coarse<-a", "hybrid@0.5<-b",
                                     "hybrid@0.5<-start-b"]
    calls.clear()           # one lobe (no start), M1 barely lowered by the polish: the first path only
    found = refine_all(run, data, [("a", 1.0 / (1.0 - MOVED / 2), None)], "hybrid", [])
    assert [c[0] for c in calls] == ["hybrid", "log"] and len(found) == 1


def test_a_hybrid_fit_never_keeps_a_worse_picture_than_its_m1_optimum():
    """fitting.refine.keep_picture: a hybrid optimum that draws a worse image than the M1
    optimum it was refined from is replaced by M1 alone refined from that optimum; one that
    draws a better image is kept as it is."""
    from fitting.refine import keep_picture
    from fitting.image_error import ImageTargets
    spec = parse_model("ggx+lambert")
    data = synthetic_measured(spec, TRUTH, grid=(16, 16, 32, 1))
    image = ImageTargets.from_measured(data)
    with jax.enable_x64(True):
        u_true = from_params(spec, TRUTH)
        u_wrong = from_params(spec, dict(TRUTH, roughness=0.9))
        refined = []

        def refine(u0):
            refined.append(u0)
            return u0, 0.5, 7, True
        runs = []
        kept = keep_picture(spec, (u_wrong, 1.0, True), u_true, image, jnp.float64, refine, runs, 2, 100)
        assert kept[0] is u_true and refined == [u_true]
        assert runs == [{"stage": 2, "samples": 100, "loss": 0.5, "evaluations": 7, "converged": True}]
        kept = keep_picture(spec, (u_true, 1.0, True), u_wrong, image, jnp.float64, refine, [], 2, 100)
        assert kept[0] is u_true and len(refined) == 1


def test_a_hybrid_fit_sells_at_most_m1_budget_of_its_table_for_the_picture():
    """fitting.refine.keep_picture with ``m1``: a hybrid optimum whose M1 is above M1_BUDGET x its
    M1 optimum's is refined again from its end with the image weight x each of LIGHTER in turn
    up to the first end within the budget (and no worse a picture), then BISECT times at the
    factor half-way (geometrically) between the heaviest end within and the lightest outside,
    and the heaviest end within is kept; where none is (nor the lightest weight's from the M1
    optimum: tests/test_fitting_basins.py), M1 alone refined from the M1 optimum.
    A search on a smaller set (the coarse part) is finished on the fit's own set (``polish``)."""
    from fitting.refine import BISECT, LIGHTER, M1_BUDGET, keep_picture
    from fitting.image_error import ImageTargets
    spec = parse_model("ggx+lambert")
    data = synthetic_measured(spec, TRUTH, grid=(16, 16, 32, 1))
    image = ImageTargets.from_measured(data)
    with jax.enable_x64(True):
        u_log = from_params(spec, TRUTH)     # the picture of the truth: no end draws a better one
        m1s = {}                             # a stand-in M1 of each u, by its id

        def m1(u):
            return m1s[id(u)]

        def lighter(factor, u0):             # each lighter weight's end: the truth itself, its M1 1 + factor
            u = np.array(u_log)
            m1s[id(u)] = 1.0 + factor
            ends.append(u)
            tried.append(factor)
            return u, factor, 5, True

        def refine(u0):
            refined.append(u0)
            return u0, 0.5, 7, True
        limit = 1.0 + 0.3                    # between LIGHTER[1] = 0.25 (within) and LIGHTER[0] = 0.5
        tried, refined, runs, ends = [], [], [], []
        m1s[id(u_log)] = limit / M1_BUDGET
        best = np.array(u_log)
        m1s[id(best)] = 2.0 * limit          # the same picture, twice the budget's M1
        kept = keep_picture(spec, (best, 1.0, True), u_log, image, jnp.float64, refine, runs, 2, 100,
                            m1=m1, lighter=lighter)
        within, outside, halves = LIGHTER[1], LIGHTER[0], []
        for _ in range(BISECT):              # 0.354 (outside), then 0.297 (within)
            halves.append(np.sqrt(within * outside))
            within, outside = (halves[-1], outside) if 1.0 + halves[-1] <= limit else (within, halves[-1])
        assert tried == pytest.approx(list(LIGHTER[:2]) + halves) and not refined
        assert kept[1] == pytest.approx(within) and within > LIGHTER[1]
        assert kept[0] is ends[tried.index(kept[1])] and len(runs) == len(tried)

        tried, refined, runs = [], [], []    # no lighter end within the budget, from best's end nor,
        m1s[id(u_log)] = 1.0 / M1_BUDGET     # the lightest, from u_log (tests/test_fitting_basins.py): M1 alone
        best = np.array(u_log)
        m1s[id(best)] = 2.0
        kept = keep_picture(spec, (best, 1.0, True), u_log, image, jnp.float64, refine, runs, 2, 100,
                            m1=m1, lighter=lighter)
        assert tried == list(LIGHTER) + [LIGHTER[-1]] and refined == [u_log] and kept[0] is u_log
        assert len(runs) == len(LIGHTER) + 2

        m1s[id(u_log)] = 1.0                 # within the budget: kept as it is, nothing run
        best = np.array(u_log)
        m1s[id(best)] = M1_BUDGET
        tried, refined = [], []
        kept = keep_picture(spec, (best, 1.0, True), u_log, image, jnp.float64, refine, [], 2, 100,
                            m1=m1, lighter=lighter)
        assert kept[0] is best and not tried and not refined

        # the search on a smaller set (lighter_samples), the kept end polished on the fit's own
        # set at its factor: the polished end when it is within the budget, else the search's
        m1s[id(u_log)] = limit / M1_BUDGET
        for polished_m1, taken in ((limit, "polished"), (1.01 * limit, "searched")):
            polishes = []
            def polish(factor, u0, polishes=polishes, polished_m1=polished_m1):
                polishes.append((factor, u0))
                u = np.array(u_log)
                m1s[id(u)] = polished_m1
                return u, -1.0, 3, True
            tried, runs, ends = [], [], []
            best = np.array(u_log)
            m1s[id(best)] = 2.0 * limit
            kept = keep_picture(spec, (best, 1.0, True), u_log, image, jnp.float64, refine, runs, 2, 100,
                                m1=m1, lighter=lighter, lighter_samples=20, polish=polish)
            searched = ends[tried.index(within)]
            assert len(polishes) == 1 and polishes[0][0] == within and polishes[0][1] is searched
            assert [r["samples"] for r in runs] == [20] * len(tried) + [100]
            assert (kept[1] == -1.0 and m1(kept[0]) == limit) if taken == "polished" else kept[0] is searched
