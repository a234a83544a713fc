"""The model declarations (brdf.declare) and the layers that read them.

Every declared glTF key is a real glTF / KHR property with its real default;
periodic parameters are free in the fit and wrapped on output; the fused
gradient's coverage is the declared one; model tokens are unambiguous.  And
the claim the declarations exist for: a diffuse lobe or a Fresnel option
declared in a test (registered in brdf's dictionaries, nothing else touched)
flows through the model string, the schema, the evaluation, the start
selection, the fused gradient (held to jax.grad) and the glTF conversion.
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import brdf
from brdf import diffuse, fresnel, gltf_material
from brdf.declare import GltfRule, Param, Start, Term
from brdf.model import (DIFFUSES, FIELDS, FRESNELS, ModelSpec, all_terms, describe_tokens, evaluate,
                        parameter_schema, parse_model)
from fitting import fused
from fitting.auto import AUTO_FAMILY
from brdf_fit.export.export_first import GLTF_FAMILY
from brdf_fit.export.gltf import convert
from fitting.fit import _objective, channel_errors, prepare
from fitting.starts import initial_candidates
from fitting.synthetic import synthetic_measured
from fitting.transforms import from_params, to_params, to_python, vector_size

# glTF 2.0 material.pbrMetallicRoughness and the KHR_materials_* schemas: (key, default, components)
GLTF_KEYS = {
    ("pbrMetallicRoughness", "baseColorFactor"): ([1.0, 1.0, 1.0, 1.0], 4),
    ("pbrMetallicRoughness", "metallicFactor"): (1.0, 1),
    ("pbrMetallicRoughness", "roughnessFactor"): (1.0, 1),
    ("KHR_materials_ior", "ior"): (1.5, 1),
    ("KHR_materials_specular", "specularFactor"): (1.0, 1),
    ("KHR_materials_specular", "specularColorFactor"): ([1.0, 1.0, 1.0], 3),
    ("KHR_materials_clearcoat", "clearcoatFactor"): (0.0, 1),
    ("KHR_materials_clearcoat", "clearcoatRoughnessFactor"): (0.0, 1),
    ("KHR_materials_anisotropy", "anisotropyStrength"): (0.0, 1),
    ("KHR_materials_anisotropy", "anisotropyRotation"): (0.0, 1),
    ("KHR_materials_diffuse_roughness", "diffuseRoughnessFactor"): (0.0, 1),
    ("KHR_materials_sheen", "sheenColorFactor"): ([0.0, 0.0, 0.0], 3),
    ("KHR_materials_sheen", "sheenRoughnessFactor"): (0.0, 1),
}


def declared_params():
    return {id(p): p for t in all_terms() for p in t.params}.values()


def test_every_gltf_key_is_a_gltf_property_with_its_default():
    keyed = [p for p in declared_params() if p.gltf]
    assert {(p.gltf.owner, p.gltf.key) for p in keyed} == set(GLTF_KEYS)
    for p in keyed:
        default, components = GLTF_KEYS[(p.gltf.owner, p.gltf.key)]
        assert p.size + len(p.gltf.extra) == components, p.name
        ours = [p.gltf.default] * 3 + list(p.gltf.extra) if p.size == 3 else p.gltf.default
        assert ours == default, p.name


@pytest.mark.parametrize("model", ["gltf", "gltf+ior+specular+aniso+clearcoat",
                                   "gltf+specular+diffuse_roughness+clearcoat", "gltf+specular+sheen+clearcoat"])
def test_every_parameter_of_a_gltf_model_has_its_key(model):
    keys = [(p.gltf.owner, p.gltf.key) for p in parse_model(model).schema()]
    assert len(set(keys)) == len(keys)


def test_tokens_are_unambiguous():
    tokens = [t.token for t in all_terms() if t.token]
    assert len(set(tokens)) == len(tokens), tokens
    assert not set(tokens) & set(FIELDS["ndf"])


def test_fused_coverage_is_the_declared_one():
    """Every model of --model auto and of export-first's glTF family takes the
    fused path; what the declarations leave out (anisotropy, Oren-Nayar's
    sigma, exact Fresnels, the coupled composition, Turquin) takes jax.grad."""
    for model in AUTO_FAMILY + GLTF_FAMILY + ("ggx+lambert+separable+f90+ms+clearcoat", "gltf+ior"):
        assert fused.supports(parse_model(model), "log"), model
        assert not fused.supports(parse_model(model), "ngan"), model
    for model in ("ggx_aniso+lambert", "ggx+oren_nayar", "ggx+lambert+dielectric", "ggx+conductor",
                  "ggx+lambert+coupled", "gltf+aniso", "gltf+specular+aniso", "ggx+lambert+turquin",
                  "gltf+diffuse_roughness", "gltf+sheen"):
        assert not fused.supports(parse_model(model), "log"), model


# --- periodic parameters -------------------------------------------------------------

def test_periodic_parameters_are_free_and_wrap():
    periodic = [p for p in declared_params() if p.period]
    assert [p.name for p in periodic] == ["rotation"]
    spec = parse_model("ggx_aniso+lambert")
    (rot,) = [p for p in spec.schema() if p.period]
    # free in the unconstrained vector: any value passes through to_params unchanged
    u = from_params(spec, {**{p.name: p.default for p in spec.schema()}, "rotation": 7.0})
    assert float(to_params(spec, jnp.asarray(u))["rotation"]) == 7.0
    # wrapped into [lower, lower + period) on output
    out = to_python(spec, to_params(spec, jnp.asarray(u)))["rotation"]
    assert rot.lower <= out < rot.lower + rot.period
    assert out == pytest.approx(7.0 - 2 * math.pi)
    for x in np.linspace(-10, 10, 41):
        assert rot.lower <= rot.wrap(x) < rot.lower + rot.period
        assert math.isclose(math.cos(2 * rot.wrap(x)), math.cos(2 * x), abs_tol=1e-12)


def test_the_model_has_the_declared_period():
    spec = parse_model("ggx_aniso+lambert")
    p = brdf.default_params(spec)
    p.update(anisotropy=jnp.asarray(0.6), rotation=jnp.asarray(0.3), roughness=jnp.asarray(0.4))
    wi = jnp.asarray([0.3, 0.1, 0.9]) / np.linalg.norm([0.3, 0.1, 0.9])
    wo = jnp.asarray([-0.4, 0.3, 0.8]) / np.linalg.norm([-0.4, 0.3, 0.8])
    f = evaluate(spec, p, wi, wo)
    np.testing.assert_allclose(evaluate(spec, dict(p, rotation=0.3 + math.pi), wi, wo), f, rtol=1e-12)
    assert not np.allclose(evaluate(spec, dict(p, rotation=0.3 + math.pi / 2), wi, wo), f, rtol=1e-3)


# --- a diffuse lobe and a Fresnel option declared here ----------------------------------

def half_lambert(p, g, roughness, alpha):
    """A throwaway lobe: Lambert x (1 - r / 2), albedo x a roughness-only factor."""
    return diffuse.lambert(p["albedo"], g.n_dot_l, g.n_dot_v) * (1.0 - 0.5 * roughness)


HALF_LAMBERT = Term(name="half_lambert", token="half_lambert", params=(diffuse.ALBEDO,), lobe=half_lambert,
                    fused=True, gltf=diffuse.NOT_LAMBERT)


def _grey(p, cos):
    ones = jnp.ones(3, jnp.result_type(p["f0_grey"], cos))
    return fresnel.fresnel_schlick(p["f0_grey"] * ones, cos), p["f0_grey"] * ones


GREY = Term(name="schlick_grey", token="grey", lobe=_grey, gltf=GltfRule(lambda p: {"f0": p["f0_grey"]}),
            params=(Param("f0_grey", 1, 0.0, 1.0, 0.04, "grey Schlick F0",
                          start=Start(probe=1.0, rule=lambda e: float(np.mean(e.scale)))),))


@pytest.fixture
def registered(monkeypatch):
    monkeypatch.setitem(DIFFUSES, "half_lambert", HALF_LAMBERT)
    monkeypatch.setitem(FRESNELS, "schlick_grey", GREY)


@pytest.fixture(scope="module")
def data():
    truth = {"albedo": [0.3, 0.2, 0.1], "roughness": 0.3, "f0": [0.05, 0.06, 0.07]}
    measured = synthetic_measured("ggx+burley", truth, grid=(24, 24, 48, 1), noise=0.05, seed=3)
    return prepare(measured, samples=10_000)[1]


WI = np.array([[0.3, 0.1, 0.9], [-0.6, 0.2, 0.5], [0.1, -0.7, 0.3]])
WO = np.array([[-0.4, 0.3, 0.8], [0.5, -0.1, 0.7], [0.2, 0.6, 0.4]])
WI, WO = WI / np.linalg.norm(WI, axis=1, keepdims=True), WO / np.linalg.norm(WO, axis=1, keepdims=True)


def test_a_new_diffuse_lobe_flows_through_every_layer(registered, data):
    spec = parse_model("ggx+half_lambert+clearcoat")
    assert str(spec) == "ggx+half_lambert+clearcoat" and "half_lambert" in describe_tokens()
    assert [p.name for p in spec.schema()] == ["albedo", "roughness", "f0", "clearcoat", "clearcoat_roughness"]
    # evaluation: the lobe the declaration names
    p = {"albedo": jnp.asarray([0.5, 0.4, 0.3]), "roughness": jnp.asarray(0.6), "f0": jnp.asarray([0.04] * 3),
         "clearcoat": jnp.asarray(0.0), "clearcoat_roughness": jnp.asarray(0.1)}
    lambert = evaluate("ggx+lambert", {k: p[k] for k in ("albedo", "roughness", "f0")}, WI, WO)
    specular = evaluate("ggx", {k: p[k] for k in ("roughness", "f0")}, WI, WO)
    np.testing.assert_allclose(evaluate(spec, p, WI, WO) - specular, (lambert - specular) * 0.7, rtol=1e-12)
    # start selection: the albedo's declared start
    candidates = initial_candidates(spec, data)
    assert len(candidates) == 16 * 4 and all(np.all(c["albedo"] > 0) for c in candidates)
    # the fused loss and gradient, held to jax.grad of the plain loss
    assert fused.supports(spec, "log")
    reference = jax.jit(jax.value_and_grad(lambda u, d: _objective(spec, "log", d)(u)))
    fast = fused.value_and_grad(spec)
    u = jnp.asarray(np.random.default_rng(5).normal(size=vector_size(spec)))
    value, grad, errors, _ = fast(u, data)
    ref_value, ref_grad = reference(u, data)
    assert float(value) == pytest.approx(float(ref_value), rel=1e-12)
    np.testing.assert_allclose(grad, ref_grad, rtol=1e-9, atol=1e-12 * np.max(np.abs(ref_grad)))
    np.testing.assert_allclose(errors, channel_errors(spec, "log", to_params(spec, u), data), rtol=1e-12)
    # the glTF conversion: Lambert with the same albedo, the dropped factor named
    params = {"albedo": [0.3, 0.2, 0.1], "roughness": 0.5, "f0": [0.05] * 3, "clearcoat": 0.5,
              "clearcoat_roughness": 0.2}
    conv = convert({"spec": str(spec), "parameters": params})
    like = gltf_material.convert("ggx+lambert+clearcoat", params)
    assert conv["parameters"] == like["parameters"] and conv["model"] == "gltf+ior+clearcoat"
    assert "the half_lambert factor is dropped" in " ".join(conv["notes"]) and not conv["lossless"]


def test_a_new_fresnel_option_flows_through_every_layer(registered, data):
    spec = parse_model("ggx+grey+lambert")
    assert spec.fresnel == "schlick_grey" and str(spec) == "ggx+lambert+grey"
    assert [p.name for p in spec.schema()] == ["albedo", "roughness", "f0_grey"]
    p = {"albedo": jnp.asarray([0.5, 0.4, 0.3]), "roughness": jnp.asarray(0.6), "f0_grey": jnp.asarray(0.05)}
    rgb = dict(p, f0=jnp.asarray([0.05] * 3))
    del rgb["f0_grey"]
    np.testing.assert_array_equal(evaluate(spec, p, WI, WO), evaluate("ggx+lambert", rgb, WI, WO))
    # its start rule: the grey of the peak-matched scale F0 gets for ggx+lambert
    grey = [c["f0_grey"] for c in initial_candidates(spec, data)]
    rgb_f0 = [float(np.mean(c["f0"])) for c in initial_candidates(parse_model("ggx+lambert"), data)]
    np.testing.assert_allclose(grey, rgb_f0, rtol=1e-12)
    assert not fused.supports(spec, "log")          # not declared fused: the jax.grad path
    conv = convert({"spec": str(spec), "parameters": {"albedo": [0.3, 0.2, 0.1], "roughness": 0.5,
                                                       "f0_grey": 0.05}})
    like = gltf_material.convert("ggx+lambert", {"albedo": [0.3, 0.2, 0.1], "roughness": 0.5, "f0": [0.05] * 3})
    assert conv == like


def test_unregistered_options_are_gone_again():
    with pytest.raises(brdf.UnknownModelError):
        parse_model("ggx+half_lambert")
    assert "grey" not in describe_tokens() and "f0_grey" not in [p.name for p in parameter_schema(ModelSpec())]
