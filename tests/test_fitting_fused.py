"""The fused loss+gradient and the fast log1p, held to the plain loss and jax.grad."""

import gc

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from brdf import parse_model
from brdf.model import evaluate_geometry, parameter_schema
from data_loaders.buffers import aligned_empty
from fitting import fused, samples
from fitting.fit import _objective, channel_errors, prepare
from fitting.losses import log1p
from fitting.objective import full_set_errors
from fitting.synthetic import synthetic_measured
from fitting.transforms import to_params, vector_size

FUSED_MODELS = ["ggx", "ggx+lambert", "ggx+burley", "ggx+frostbite", "ggx+cod_wwii",
                "ggx+lambert+f90", "ggx+frostbite+f90", "ggx+burley+separable",
                "ggx+cod_wwii+separable+f90", "ggx+lambert+ms", "ggx+frostbite+ms+f90",
                "ggx+burley+clearcoat", "ggx+cod_wwii+clearcoat+f90", "ggx+lambert+ms+clearcoat",
                "ggx+ms+clearcoat+separable", "gltf", "gltf+ior", "gltf+specular",
                "gltf+clearcoat", "gltf+ior+specular+clearcoat", "gltf+metal+turquin",
                "gltf+nonmetal+ior+turquin+clearcoat"]
# held to jax.grad below: every fused term (each diffuse model, separable, f90, ms,
# clearcoat, the glTF BRDF with ior and specular, and in the engines' reading, whose
# lobes differ between a pair's two orientations) at least once, and the terms that
# share a sample's quantities (ms with the coat, separable with f90) together; each
# model costs a few seconds of compiling
GRAD_CHECKED = ["ggx", "ggx+burley+separable", "ggx+cod_wwii+separable+f90", "ggx+frostbite+ms+f90",
                "ggx+lambert+ms+clearcoat", "ggx+cod_wwii+clearcoat+f90", "gltf", "gltf+ior+specular+clearcoat",
                "gltf+metal+turquin", "gltf+nonmetal+ior+turquin+clearcoat"]


def test_log1p_matches_numpy_to_a_few_ulp():
    rng = np.random.default_rng(0)
    y = np.concatenate([10.0 ** rng.uniform(-30, 8, 50_000), rng.random(50_000), [0.0, 1.0, 1e300]])
    got = np.asarray(jax.jit(log1p)(jnp.asarray(y)))
    ref = np.log1p(y)
    assert np.max(np.abs(got - ref) / np.maximum(1.0, ref)) < 1e-15


def test_log1p_derivative_is_one_over_one_plus_y():
    y = jnp.asarray([0.0, 1e-9, 0.3, 7.0, 1e6])
    np.testing.assert_allclose(jax.vmap(jax.grad(log1p))(y), 1.0 / (1.0 + y), rtol=1e-15)


@pytest.fixture(scope="module")
def data():
    truth = {"albedo": [0.3, 0.2, 0.1], "roughness": 0.3, "f0": [0.05, 0.06, 0.07]}
    measured = synthetic_measured("ggx+burley", truth, grid=(30, 30, 60, 1), noise=0.05, seed=3)
    return prepare(measured, samples=20_000)[1]


def test_the_fused_models_take_the_fused_path_and_the_checked_ones_cover_their_terms():
    assert all(fused.supports(parse_model(m), "log") for m in FUSED_MODELS)
    def used(models):
        return {(type(t).__name__, t.name) for m in models for t in fused.terms(parse_model(m))}
    assert used(GRAD_CHECKED) == used(FUSED_MODELS)


@pytest.mark.parametrize("model", GRAD_CHECKED)
def test_fused_matches_jax_grad_of_the_plain_loss(model, data):
    spec = parse_model(model)
    assert fused.supports(spec, "log")
    reference = jax.jit(jax.value_and_grad(lambda u, d: _objective(spec, "log", d)(u)))
    fast = fused.value_and_grad(spec)
    rng = np.random.default_rng(7)
    for _ in range(3):
        # includes roughness parameters on both sides of the floor clamp
        u = jnp.asarray(rng.normal(size=vector_size(spec)) * 1.5)
        value, grad, errors, jac = fast(u, data)
        ref_value, ref_grad = reference(u, data)
        assert float(value) == pytest.approx(float(ref_value), rel=1e-12)
        np.testing.assert_allclose(grad, ref_grad, rtol=1e-9, atol=1e-12 * np.max(np.abs(ref_grad)))
        np.testing.assert_allclose(errors, channel_errors(spec, "log", to_params(spec, u), data),
                                   rtol=1e-12)
        # each channel's dS/du, against forward-mode AD of the plain errors
        ref_jac = np.asarray(jax.jacfwd(lambda u: channel_errors(spec, "log", to_params(spec, u), data))(u))
        np.testing.assert_allclose(jac, ref_jac, rtol=1e-9, atol=1e-12 * np.max(np.abs(ref_jac)))


@pytest.mark.parametrize("model", ["ggx+lambert", "ggx+cod_wwii+ms+clearcoat+f90", "gltf+ior+specular+clearcoat",
                                   "gltf+nonmetal+ior+turquin+clearcoat"])
def test_the_hybrid_loss_in_parts_is_the_whole_sets(model, monkeypatch):
    """objective.PartedHybrid on a set larger than its coarse part (a fit's subsample) runs
    only programs of the part's size (the coarse stages') and gives the loss, gradient and
    table errors of the hybrid program on the whole set; on a family root's programs (the
    model's columns of dS/du) the same."""
    from fitting import family, image_error, objective
    from fitting.auto import AUTO_FAMILY
    truth = {"albedo": [0.3, 0.2, 0.1], "roughness": 0.3, "f0": [0.05, 0.06, 0.07]}
    measured = synthetic_measured("ggx+burley", truth, grid=(30, 30, 60, 1), noise=0.05, seed=3)
    opt = prepare(measured, samples=20_000)[1]
    hybrid = objective.HybridSet(opt, image_error.ImageTarget.from_measured(measured, size=24), np.float64(0.5))
    monkeypatch.setattr(samples, "COARSE_SAMPLES", 6_000)         # 20 000 samples: parts of 6 667
    spec = parse_model(model)
    rng = np.random.default_rng(4)
    with jax.enable_x64(True), family.shared_programs(AUTO_FAMILY):
        whole = objective._program(spec, "hybrid")
        parted = objective._value_and_grad(spec, "hybrid")
        runs = parted.runs(np.zeros(vector_size(spec)), hybrid)
        assert [(loss, args[1].size) for loss, _, args in runs] == [("hybrid", 6_667)] + [("log", 6_667)] * 3
        for _ in range(2):
            u = rng.normal(size=vector_size(spec))
            value, grad, errors = parted(u, hybrid)
            ref_value, ref_grad, ref_errors = whole(u, hybrid)
            assert float(value) == pytest.approx(float(ref_value), rel=1e-12)
            np.testing.assert_allclose(grad, ref_grad, rtol=1e-9, atol=1e-12 * np.max(np.abs(ref_grad)))
            np.testing.assert_allclose(errors, ref_errors, rtol=1e-12)
        small = hybrid._replace(samples=opt.every(4))               # 5 000 samples: one program, as it is
        assert [loss for loss, _, _ in parted.runs(u, small)] == ["hybrid"]


@pytest.mark.parametrize("model", ["ggx_aniso+lambert", "ggx+oren_nayar", "gltf+aniso", "ggx+lambert+turquin",
                                   "ggx+lambert+coupled"])
def test_other_models_take_the_plain_path(model):
    assert not fused.supports(parse_model(model), "log")
    assert not fused.supports(parse_model("ggx+lambert"), "ngan")


@pytest.mark.parametrize("model", ["ggx+lambert", "ggx+frostbite+ms+f90", "ggx+cod_wwii+clearcoat+f90",
                                   "gltf", "gltf+ior+specular+clearcoat", "gltf+nonmetal+ior+turquin+clearcoat"])
def test_fused_errors_are_the_plain_channel_errors(model, data):
    """The value-only program of the full-set errors (M1's) against channel_errors."""
    spec = parse_model(model)
    rng = np.random.default_rng(8)
    for _ in range(2):
        params = to_params(spec, jnp.asarray(rng.normal(size=vector_size(spec)) * 1.5))
        np.testing.assert_allclose(fused.errors(spec)(params, data), channel_errors(spec, "log", params, data),
                                   rtol=1e-12)


def test_parts_cover_the_set_once_and_are_made_once(data):
    """SampleSet.parts: consecutive parts, the last padded with zero-weight copies of the
    last sample; the same list while the set lives, new parts for a set with other arrays,
    forgotten with the set (the parts do not keep it alive, though they share the memory of
    the arrays the set made itself)."""
    parts = data.parts(6_000)
    for name in ("values", "weights", "log_i", "log_o"):        # views of the set's own buffers
        assert getattr(parts[1], name).unsafe_buffer_pointer() == (
            getattr(data, name).unsafe_buffer_pointer() + 6_000 * np.asarray(getattr(data, name))[0].nbytes)
    assert [p.size for p in parts] == [6_000] * 4        # 20 000 samples: 3 x 6 000 + 2 000 padded
    for name in ("values", "weights", "log_i", "log_o"):
        joined = np.concatenate([np.asarray(getattr(p, name)) for p in parts])
        np.testing.assert_array_equal(joined[:data.size], np.asarray(getattr(data, name)))
    np.testing.assert_array_equal(np.asarray(parts[-1].weights)[2_000:], 0.0)
    np.testing.assert_array_equal(np.asarray(parts[-1].values)[2_000:], np.asarray(data.values)[-1:].repeat(4_000, 0))
    spec = parse_model("ggx+lambert")
    params = to_params(spec, jnp.zeros(vector_size(spec)))
    np.testing.assert_allclose(full_set_errors(spec, "log", params, parts), channel_errors(spec, "log", params, data),
                               rtol=1e-12)
    assert data.parts(6_000) is parts
    other = data._replace(values=data.values * 2.0)
    assert other.parts(6_000) is not parts
    np.testing.assert_array_equal(np.asarray(other.parts(6_000)[0].values), 2.0 * np.asarray(parts[0].values))
    coarse = other.every(3)                  # the coarse copy: kept the same way
    assert other.every(3) is coarse and other.every(4) is not coarse
    np.testing.assert_array_equal(np.asarray(coarse.values), np.asarray(other.values)[::3])
    count = len(samples._KEPT)
    del other
    gc.collect()
    assert len(samples._KEPT) == count - 3


def test_device_arrays_own_their_memory(data):
    """samples._device copies (the set never changes with its source); an array of the set's
    own, aligned, is wrapped as it is (no second copy) and known as wrapped while it lives:
    prepare's sets wrap the selection's arrays and their own."""
    for x in (data.geo.wi, data.geo.wo, data.values, data.weights, data.log_i, data.log_o):
        assert samples._wrapped(x) is not None
    source = np.arange(12.0).reshape(4, 3)
    copied = samples._device(source, np.float64)
    source[:] = -1.0
    np.testing.assert_array_equal(np.asarray(copied), np.arange(12.0).reshape(4, 3))
    buffer = aligned_empty((5, 3))
    buffer[:] = 2.0
    wrapped = samples._own_device(buffer, np.float64)
    assert samples._wrapped(wrapped) is buffer
    assert wrapped.unsafe_buffer_pointer() == buffer.ctypes.data
    assert samples._wrapped(jnp.asarray(buffer) + 0.0) is None


def test_start_probes_run_on_the_peak_pairs_in_parts_of_one_shape(data, monkeypatch):
    """initial_candidates evaluates its probes only at the peak's pairs, in parts of
    PROBE_ROWS (one program for every data size), every point of the roughness scan in one
    call: each point's values are the model's own on the whole set at the peak pairs, and
    the candidates do not depend on the part size."""
    from fitting import starts
    spec = parse_model("ggx+lambert+clearcoat")
    calls = []
    scan = starts._scan_jit(spec)

    def recorded(params, batch, geo):
        out = scan(params, batch, geo)
        calls.append((params, batch, geo.n_dot_h.shape, np.asarray(out)))
        return out
    monkeypatch.setattr(starts, "_scan_jit", lambda s: recorded)
    got = {}
    for rows in (7, 100_000):
        calls.clear()
        monkeypatch.setattr(starts, "PROBE_ROWS", rows)
        got[rows] = starts.initial_candidates(spec, data)
        assert {shape for *_, shape, _ in calls} == {(rows,)}
    th = np.degrees(np.arccos(np.clip(np.asarray(data.geo.n_dot_h), -1.0, 1.0)))
    peak = th < max(3.0, float(np.percentile(th, 0.5)))        # the peak as starts.py defines it
    params, batch, _, out = calls[0]
    roughness = np.geomspace(0.04, 1.0, 16)                     # the declared scan (brdf/specular.py)
    np.testing.assert_array_equal(batch["roughness"], roughness)
    assert len(calls) == 1 and out.shape == (16, 100_000, 3)
    for i, r in enumerate(roughness):
        whole = np.asarray(evaluate_geometry(spec, dict(params, roughness=r), data.geo))   # the model itself
        np.testing.assert_allclose(out[i, :peak.sum()], whole[peak], rtol=1e-10)   # jitted vs op by op
    assert len(got[7]) == len(got[100_000]) == 16 * 4
    for a, b in zip(got[7], got[100_000]):
        for k in a:
            np.testing.assert_allclose(a[k], b[k], rtol=1e-12)


def test_the_scan_program_without_a_scanned_parameter_is_the_one_set(data):
    """_scan_jit with an empty batch (a model that declared no scan) gives the parameters' own
    values, as a batch of one with the scanned value equal to the parameters' own."""
    from fitting import starts
    spec = parse_model("ggx+burley")
    params = starts._float64({p.name: starts._value(p, p.default) for p in parameter_schema(spec)})
    alone = np.asarray(starts._scan_jit(spec)(params, {}, data.geo))
    batch = np.asarray(starts._scan_jit(spec)(params, {"roughness": np.array([params["roughness"]])}, data.geo))
    assert alone.shape == batch.shape == (1, data.size, 3)
    np.testing.assert_allclose(alone, batch, rtol=1e-13)


def test_the_exported_materials_error_programs_are_compiled_ahead(data):
    """compile_exported: the M1 part program of the glTF material a fit exports, sent to the
    compile threads from early parameters (the programs the fit's exported errors then call);
    nothing for a lossless conversion (a glTF fit), each program once per process."""
    from brdf import gltf_material
    from fitting.compile_ahead import _Ahead, compile_exported
    from fitting.transforms import to_jax
    part_set = data.every(3)                       # a part size no other test compiles
    spec = parse_model("ggx+lambert")
    params = {"albedo": [0.3, 0.2, 0.1], "roughness": 0.3, "f0": [0.05, 0.06, 0.07]}
    ahead = _Ahead({})
    compile_exported(ahead, spec, params, part_set, None, np.float64)
    assert set(ahead.futures) == {"exported errors log"}
    compiled = ahead.futures["exported errors log"].result()
    conversion = gltf_material.convert(spec, params)
    gspec = parse_model(conversion["model"])
    gparams = to_jax(gspec, conversion["parameters"])
    with jax.enable_x64(True):
        np.testing.assert_allclose(np.asarray(compiled(gparams, part_set)),
                                   full_set_errors(gspec, "log", gparams, [part_set]), rtol=1e-12)
    again = _Ahead({})
    compile_exported(again, spec, params, part_set, None, np.float64)
    gltf = _Ahead({})
    compile_exported(gltf, gspec, conversion["parameters"], data.every(5), None, np.float64)
    assert again.futures == {} and gltf.futures == {}
