"""Model families (fitting/family.py): one compiled program per family root, and
every model run on its root's program gives its own program's numbers."""

import jax
import numpy as np
import pytest

from brdf import parse_model
from brdf.clearcoat import CLEARCOAT
from brdf.model import evaluate_geometry
from fitting import family, fused
from fitting import image_error as ie
from fitting.auto import AUTO_FAMILY
from brdf_fit.export.export_first import GLTF_FAMILY, SPEC_ONLY_FAMILY
from fitting.fit import CUT_MARGIN, ModelCut, fit, prepare, warm_start
from fitting.objective import HYBRID_WEIGHT, HybridSet, _own_value_and_grad, _program, full_set_errors
from fitting.objective import channel_errors
from fitting.ranking import IMAGE_WEIGHT, SECOND_WEIGHT, best_ranking_error
from fitting.starts import _scan_jit
from fitting.synthetic import synthetic_measured
from fitting.transforms import to_params, vector_size

TRUTH = {"albedo": [0.3, 0.2, 0.1], "roughness": 0.3, "f0": [0.05, 0.06, 0.07]}
# each option of the engine family once, and the glTF family
MODELS = ["ggx+lambert", "ggx+burley+ms", "ggx+frostbite+clearcoat", "ggx+cod_wwii+ms+clearcoat",
          "ggx+lambert+f90", "ggx+burley+clearcoat+f90", "gltf", "gltf+specular", "gltf+clearcoat",
          "gltf+specular+clearcoat"]


def test_the_families_roots():
    roots = {family.root_of(parse_model(m)) for m in AUTO_FAMILY}
    assert roots == {parse_model(m) for m in ("ggx+lambert+f90", "ggx+lambert+ms+f90", "ggx+lambert+clearcoat+f90",
                                              "ggx+lambert+ms+clearcoat+f90")}
    roots = {family.root_of(parse_model(m)) for m in SPEC_ONLY_FAMILY}
    assert roots == {parse_model("gltf+specular"), parse_model("gltf+specular+clearcoat")}
    # the portable family (metallic held at 1 or 0 by its model strings): no two models share a root
    roots = [family.root_of(parse_model(m)) for m in GLTF_FAMILY]
    assert len(set(roots)) == len(GLTF_FAMILY)
    # with the compensation switched (auto's screening): two roots
    roots = {family.root_of(parse_model(m), switch_energy=True) for m in AUTO_FAMILY + SPEC_ONLY_FAMILY}
    assert roots == {parse_model(m) for m in ("ggx+lambert+ms+f90", "ggx+lambert+ms+clearcoat+f90",
                                              "gltf+specular", "gltf+specular+clearcoat")}
    # no root: an anisotropic lobe, a diffuse lobe with its own parameters, no diffuse lobe
    for model in ("ggx_aniso+lambert", "ggx+oren_nayar", "ggx"):
        assert family.root_of(parse_model(model)) is None


def test_roots_are_shared_where_two_models_share_them():
    spec = parse_model("ggx+burley+ms")
    assert family.variant(spec) is None                  # a single fit compiles its own (smaller) program
    with family.shared_programs(["ggx+burley+ms", "ggx+lambert+ms", "gltf"]):
        assert family.variant(spec).root == parse_model("ggx+lambert+ms+f90")
        assert family.variant(parse_model("gltf")) is None      # alone in its family
    with family.shared_programs(["ggx+burley+ms", "ggx+lambert", "gltf"]):
        assert family.variant(spec) is None
        with family.shared_programs(["ggx+burley+ms", "ggx+lambert"], switch_energy=True):
            assert family.variant(spec).switches()["energy_on"] == 1.0
            assert family.variant(parse_model("ggx+lambert")).root == parse_model("ggx+lambert+ms+f90")
            assert family.variant(parse_model("ggx+lambert")).switches()["energy_on"] == 0.0
        assert family.variant(spec) is None
    assert family.variant(spec) is None


def test_a_model_sits_in_its_roots_vector():
    spec = parse_model("ggx+cod_wwii+clearcoat")
    v = family._variant(spec)
    u = np.arange(vector_size(spec), dtype=float) / 10 - 0.3
    root_params = to_params(v.root, v.embed(u))
    for name, value in to_params(spec, u).items():
        np.testing.assert_array_equal(root_params[name], value)
    assert dict(v.on) == {"f90": 0.0}


@pytest.fixture(scope="module")
def data():
    measured = synthetic_measured("ggx+burley", TRUTH, grid=(30, 30, 60, 1), noise=0.05, seed=3)
    full, opt = prepare(measured, samples=20_000)
    target = ie.ImageTarget.from_measured(measured, size=24)
    return full, opt, HybridSet(opt, target, np.float64(HYBRID_WEIGHT)), target


def _random_vectors(spec, count=3):
    rng = np.random.default_rng(11)
    # wide enough to put the roughness on both sides of its floor clamp
    return [rng.normal(size=vector_size(spec)) * 1.5 for _ in range(count)]


@pytest.mark.parametrize("switch_energy", [False, True])
@pytest.mark.parametrize("model", MODELS)
def test_the_shared_loss_and_gradient_are_the_models_own(model, switch_energy, data):
    """Fused (engine family, log and hybrid) and plain (glTF family, another loss) paths;
    with ``switch_energy``, the models without ``ms`` on a Kulla-Conty root."""
    spec = parse_model(model)
    _, opt, hybrid, _ = data
    cases = [("log", opt), ("hybrid", hybrid)] + ([("ngan", opt)] if model in MODELS[:2] else [])
    with jax.enable_x64(True), family.shared_programs(AUTO_FAMILY + SPEC_ONLY_FAMILY, switch_energy):
        for loss, d in cases:
            shared, own = _program(spec, loss), _own_value_and_grad(spec, loss, False)
            assert isinstance(shared, family.VariantProgram)
            for u in _random_vectors(spec):
                value, grad, errors, *jac = shared(u, d)
                ref_value, ref_grad, ref_errors, *ref_jac = own(u, d)
                assert float(value) == pytest.approx(float(ref_value), rel=1e-12)
                np.testing.assert_allclose(grad, ref_grad, rtol=1e-9, atol=1e-12 * np.max(np.abs(ref_grad)))
                np.testing.assert_allclose(errors, ref_errors, rtol=1e-12)
                assert len(jac) == len(ref_jac) == (loss == "log" and fused.supports(spec, "log"))
                for a, b in zip(jac, ref_jac):       # dS/du: the model's columns of the root's
                    np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12 * np.max(np.abs(b)))


@pytest.mark.parametrize("switch_energy", [False, True])
@pytest.mark.parametrize("model", MODELS)
def test_the_shared_params_programs_are_the_models_own(model, switch_energy, data):
    """The parameter map, the start scan's evaluation, the image error and the full-set errors."""
    spec = parse_model(model)
    full, opt, _, target = data
    with jax.enable_x64(True), family.shared_programs(AUTO_FAMILY + SPEC_ONLY_FAMILY, switch_energy):
        for u in _random_vectors(spec, 2):
            params = family.params_program(spec)(u)
            own = to_params(spec, u)
            assert params.keys() == own.keys()
            for name in own:
                np.testing.assert_allclose(params[name], own[name], rtol=1e-15)
            scanned = _scan_jit(spec)(params, {"roughness": np.array([0.05, 0.6])}, opt.geo)
            for i, r in enumerate([0.05, 0.6]):
                np.testing.assert_allclose(scanned[i], evaluate_geometry(spec, dict(own, roughness=r), opt.geo),
                                           rtol=1e-10, atol=1e-300)    # batched and jitted vs op by op
            for got, want in zip(ie._image_program(spec)(params, target), ie.image_channels(spec, own, target)):
                np.testing.assert_allclose(got, want, rtol=1e-11)      # (image error, components, no E2)
            np.testing.assert_allclose(full_set_errors(spec, "log", params, full, chunk=4096),
                                       channel_errors(spec, "log", own, full), rtol=1e-11)


def test_a_family_fit_equals_its_models_own_fit():
    """The whole fit through the root's programs and through the model's own: the same optimum."""
    measured = synthetic_measured("ggx+frostbite", TRUTH, grid=(24, 24, 48, 1), noise=0.03, seed=2)
    with family.shared_programs(AUTO_FAMILY):
        shared = fit(measured, "ggx+frostbite+clearcoat", samples=20_000, starts=2)
    own = fit(measured, "ggx+frostbite+clearcoat", samples=20_000, starts=2)
    assert shared.errors["m1"] == pytest.approx(own.errors["m1"], rel=1e-6)
    assert shared.errors["image"] == pytest.approx(own.errors["image"], abs=1e-6)   # of ~1e-4: near the truth
    for name, value in own.parameters.items():
        np.testing.assert_allclose(shared.parameters[name], value, rtol=1e-4, atol=1e-5)


def _result(model, m1, parameters):
    from fitting.result import FitResult
    return FitResult(spec=model, parameters=parameters, errors={"m1": m1}, optimizer={}, provenance={})


def test_warm_start_is_the_best_parent_with_the_same_parameters():
    lambert = {"albedo": [0.1, 0.2, 0.3], "roughness": 0.2, "f0": [0.05] * 3}
    coat = dict(lambert, clearcoat=0.3, clearcoat_roughness=0.1)
    fitted = [_result("ggx+lambert", 0.02, lambert),
              _result("ggx+lambert+f90", 0.01, dict(lambert, f90=0.7)),
              _result("ggx+burley", 0.005, lambert),                       # another diffuse lobe
              _result("ggx+lambert+clearcoat", 0.03, coat),
              _result("ggx+lambert+ms+clearcoat", 0.04, coat)]
    assert warm_start("ggx+lambert+ms", fitted) == lambert
    assert warm_start("ggx+lambert+ms+clearcoat", fitted) == coat
    assert warm_start("ggx+lambert+clearcoat", fitted) == coat          # from +ms+clearcoat
    assert warm_start("ggx+lambert+clearcoat+f90", fitted) is None      # new parameters: the scan
    assert warm_start("ggx+frostbite+ms", fitted) is None
    assert warm_start("gltf+specular", fitted) is None


def test_warm_fits_reach_the_cold_fits_optimum():
    """+ms started from its parent's optimum (once per start variant) instead of the
    scan: the cold fit's M1 or better, with fewer evaluations where there is no coat."""
    measured = synthetic_measured("ggx+burley+clearcoat", dict(TRUTH, clearcoat=0.4, clearcoat_roughness=0.08),
                                  grid=(24, 24, 48, 1), noise=0.03, seed=4)
    for parent_model, child in (("ggx+burley", "ggx+burley+ms"), ("ggx+burley+clearcoat", "ggx+burley+ms+clearcoat")):
        parent = fit(measured, parent_model, samples=20_000)
        cold = fit(measured, child, samples=20_000)
        warm = fit(measured, child, samples=20_000, warm=warm_start(child, [parent]))
        assert warm.errors["m1"] <= cold.errors["m1"] * 1.005
        if "clearcoat" in child:          # each coat start variant with the parent's base, and the parent
            assert warm.optimizer["starts"] == len(CLEARCOAT.variants[1]) + 1
        else:
            assert warm.optimizer["starts"] == 1
            assert warm.optimizer["evaluations"] < cold.optimizer["evaluations"]


def test_a_model_that_cannot_win_is_cut_after_its_coarse_stage():
    """fit(cut_above=) stops after the coarse stage when the best start's M1 there exceeds
    CUT_MARGIN x the bound; otherwise the fit is the uncut one.  The bound's premise,
    checked on the cut model: its full fit's M1 does not fall below coarse M1 / CUT_MARGIN."""
    measured = synthetic_measured("ggx+lambert", TRUTH, grid=(24, 24, 48, 1), noise=0.03, seed=5)
    data = prepare(measured, samples=20_000)
    fitted = fit(measured, "ggx+lambert", data=data, loss="hybrid")
    bound = best_ranking_error([fitted])
    image_term = fitted.errors["image"] + SECOND_WEIGHT * fitted.errors["second_image"]
    assert bound == pytest.approx(fitted.errors["m1"] + IMAGE_WEIGHT * image_term, rel=1e-12)
    with pytest.raises(ModelCut) as cut:       # no diffuse lobe: far from a diffuse material
        fit(measured, "ggx", data=data, loss="hybrid", cut_above=bound)
    assert cut.value.model == "ggx" and cut.value.bound == bound
    assert cut.value.coarse_m1 > CUT_MARGIN * bound
    full = fit(measured, "ggx", data=data, loss="hybrid")
    assert full.errors["m1"] > cut.value.coarse_m1 / CUT_MARGIN > bound
    # a model that can win runs to the end, unchanged
    burley = fit(measured, "ggx+burley", data=data, loss="hybrid")
    assert fit(measured, "ggx+burley", data=data, loss="hybrid", cut_above=bound).errors == burley.errors
