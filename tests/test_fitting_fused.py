"""The fused loss+gradient and the fast log1p, held to the plain loss and jax.grad."""

import gc

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from brdf import parse_model
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
                "gltf+clearcoat", "gltf+ior+specular+clearcoat"]


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


@pytest.mark.parametrize("model", FUSED_MODELS)
def test_fused_matches_jax_grad_of_the_plain_loss(model, data):
    spec = parse_model(model)
    assert fused.supports(spec, "log")
    reference = jax.jit(jax.value_and_grad(lambda u, d: _objective(spec, "log", d)(u)))
    fast = fused.value_and_grad(spec)
    rng = np.random.default_rng(7)
    for _ in range(3):
        # includes roughness parameters on both sides of the floor clamp
        u = jnp.asarray(rng.normal(size=vector_size(spec)) * 1.5)
        value, grad, errors = fast(u, data)
        ref_value, ref_grad = reference(u, data)
        assert float(value) == pytest.approx(float(ref_value), rel=1e-12)
        np.testing.assert_allclose(grad, ref_grad, rtol=1e-9, atol=1e-12 * np.max(np.abs(ref_grad)))
        np.testing.assert_allclose(errors, channel_errors(spec, "log", to_params(spec, u), data),
                                   rtol=1e-12)


@pytest.mark.parametrize("model", ["ggx_aniso+lambert", "ggx+oren_nayar", "gltf+aniso", "ggx+lambert+turquin",
                                   "ggx+lambert+coupled"])
def test_other_models_take_the_plain_path(model):
    assert not fused.supports(parse_model(model), "log")
    assert not fused.supports(parse_model("ggx+lambert"), "ngan")


@pytest.mark.parametrize("model", ["ggx+lambert", "ggx+frostbite+ms+f90", "ggx+cod_wwii+clearcoat+f90",
                                   "gltf", "gltf+ior+specular+clearcoat"])
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
    forgotten with the set (the parts are copies: they do not keep it alive)."""
    parts = data.parts(6_000)
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
    count = len(samples._PARTS)
    del other
    gc.collect()
    assert len(samples._PARTS) == count - 1
