"""The classic models through the fitting engine: jax.grad fallback, recovery,
result files, the command line, the glTF conversion's notes."""

import json

import numpy as np
import pytest

from brdf import parse_model
from brdf.gltf_material import convert
from brdf_fit.cli import main
from data_loaders import write_samples
from fitting import fused
from fitting.fit import fit
from fitting.result import FitResult
from fitting.synthetic import synthetic_measured

TRUTH = {"albedo": [0.45, 0.2, 0.08], "roughness": 0.35, "f0": [0.06, 0.05, 0.045]}

# Synthetic recovery as tests/test_fitting_engine.py's: 2 % noise, every parameter within 2 %.
RECOVERY_CASES = {
    "beckmann+lambert": TRUTH,
    "beckmann+lambert+vgroove": dict(TRUTH, roughness=0.5),
    "beckmann_aniso+lambert": dict(TRUTH, roughness=0.4, anisotropy=0.5, rotation=0.4),
}
# the lobe models' scale is their specular albedo rho_s (brdf/lobes.py)
LOBE_TRUTH = {"albedo": [0.45, 0.2, 0.08], "roughness": 0.35, "specular_albedo": [0.06, 0.05, 0.045]}
RECOVERY_CASES.update({
    "blinn_phong+lambert": LOBE_TRUTH,
    "phong+lambert": dict(LOBE_TRUTH, roughness=0.5),
    "ward+lambert": LOBE_TRUTH,
    "ward_duer+lambert": dict(LOBE_TRUTH, roughness=0.25),
    "ashikhmin_shirley+lambert": dict(LOBE_TRUTH, roughness=0.4),
    # Ngan et al.'s variant: a scale and a grey R_s, told apart by the Fresnel rise at grazing
    "ashikhmin_shirley_scaled+lambert": dict(LOBE_TRUTH, roughness=0.4, specular_albedo=[0.6, 0.5, 0.45],
                                             fresnel_reflectance=0.1),
    "ward_aniso+lambert": dict(LOBE_TRUTH, roughness=0.4, anisotropy=0.5, rotation=0.4),
    "ashikhmin_shirley_aniso+lambert": dict(LOBE_TRUTH, roughness=0.4, anisotropy=0.5, rotation=0.4),
    "lafortune+lambert": dict(LOBE_TRUTH, roughness=0.45, lafortune_cz=0.45),   # a lobe bent off the mirror
    # a sharp lobe and a broad one bent to grazing (Lafortune et al. 1997's sum)
    "lafortune2+lambert": dict(LOBE_TRUTH, lafortune_cz=0.5, lafortune_roughness_2=0.75,
                               lafortune_albedo_2=[0.2, 0.15, 0.1], lafortune_cz_2=0.3),
})


@pytest.mark.parametrize("model", ["beckmann+lambert", "beckmann+burley+clearcoat", "beckmann+lambert+vgroove",
                                   "beckmann_aniso+lambert", "ggx+lambert+vgroove", "blinn_phong+lambert",
                                   "phong+lambert", "ward+lambert", "ward_duer+burley+clearcoat",
                                   "ashikhmin_shirley+lambert", "lafortune+lambert"])
def test_classic_models_take_jax_grad(model):
    """fitting.fused's closed-form gradient covers GGX only: these fall back to jax.grad."""
    assert not fused.supports(parse_model(model), "log")


@pytest.mark.parametrize("model", list(RECOVERY_CASES))
def test_synthetic_recovery_with_noise(model):
    from test_fitting_engine import assert_recovered
    assert_recovered(model, RECOVERY_CASES[model])


def test_beckmann_and_ggx_are_told_apart():
    """A Beckmann table is fitted better by beckmann than by ggx, and the other way round."""
    for truth_model, other in (("beckmann+lambert", "ggx+lambert"), ("ggx+lambert", "beckmann+lambert")):
        data = synthetic_measured(truth_model, dict(TRUTH, roughness=0.3), grid=(24, 24, 48, 1))
        own = fit(data, truth_model, samples=10_000, starts=1)
        theirs = fit(data, other, samples=10_000, starts=1)
        assert own.errors["m1"] < 0.5 * theirs.errors["m1"], (truth_model, own.errors["m1"], theirs.errors["m1"])


def test_result_file_round_trip(tmp_path):
    data = synthetic_measured("beckmann+lambert+vgroove", TRUTH, grid=(16, 16, 32, 1))
    result = fit(data, "beckmann+lambert+vgroove", samples=5_000, starts=1)
    back = FitResult.load(result.save(tmp_path / "r.json"))
    assert back == result and back.spec == "beckmann+lambert+vgroove"


def test_command_line_fits_a_lobe_model(tmp_path):
    m = synthetic_measured("ward+lambert", LOBE_TRUTH, grid=(24, 24, 48, 1))
    keep = m.valid
    path = tmp_path / "w.npz"
    write_samples(path, m.wi[keep], m.wo[keep], m.values[keep], weights=m.weights[keep], material="w",
                  isotropic=True)
    assert main(["fit", str(path), "--model", "ward+lambert", "--samples", "5000", "--out", str(tmp_path)]) == 0
    result = FitResult.load(tmp_path / "w.ward+lambert.json")
    np.testing.assert_allclose(result.parameters["specular_albedo"], LOBE_TRUTH["specular_albedo"], rtol=1e-3)
    assert result.errors["exported_model"].startswith("gltf")


def test_command_line_fit_and_models(tmp_path, capsys):
    m = synthetic_measured("beckmann+lambert+vgroove", TRUTH, grid=(24, 24, 48, 1))
    keep = m.valid
    path = tmp_path / "ct.npz"
    write_samples(path, m.wi[keep], m.wo[keep], m.values[keep], weights=m.weights[keep], material="ct",
                  isotropic=True)
    assert main(["fit", str(path), "--model", "beckmann+lambert+vgroove", "--samples", "5000",
                 "--out", str(tmp_path)]) == 0
    result = FitResult.load(tmp_path / "ct.beckmann+lambert+vgroove.json")
    np.testing.assert_allclose(result.parameters["roughness"], TRUTH["roughness"], rtol=1e-3)
    capsys.readouterr()
    assert main(["models", "--json"]) == 0
    listing = json.loads(capsys.readouterr().out)
    assert {"beckmann", "beckmann_aniso", "blinn_phong", "phong", "ward", "ward_duer"} <= set(listing["ndfs"])
    assert "beckmann+lambert+vgroove" in listing["examples"]


@pytest.mark.parametrize("model, note", [("beckmann+lambert", "Beckmann lobe is exported as the GGX lobe"),
                                         ("beckmann+lambert+vgroove", "V-groove masking is dropped"),
                                         ("beckmann_aniso+lambert", "Beckmann lobe is exported as the GGX lobe"),
                                         ("blinn_phong+lambert", "F0 = 4 rho_s"), ("phong+lambert", "F0 = 4 rho_s"),
                                         ("ward+lambert", "F0 = rho_s"), ("ward_duer+lambert", "F0 = rho_s"),
                                         ("ashikhmin_shirley+lambert", "F0 = R_s"),
                                         ("ward_aniso+lambert", "F0 = rho_s"),
                                         ("lafortune+lambert", "its Cz = 0.577 (the lobe's bend) is dropped"),
                                         ("lafortune2+lambert", "lobes 2 and up are dropped")])
def test_gltf_conversion_says_it_is_approximate(model, note):
    params = dict(LOBE_TRUTH if parse_model(model).lobe_model else TRUTH)
    if model.startswith("lafortune"):
        params["lafortune_cz"] = 0.57735
    if model.startswith("lafortune2"):
        params.update(lafortune_roughness_2=0.8, lafortune_albedo_2=[0.02] * 3, lafortune_cz_2=0.3)
    if parse_model(model).anisotropic:
        params.update(anisotropy=0.3, rotation=0.2)
    conversion = convert(model, params)
    assert not conversion["lossless"]
    assert any(note in n for n in conversion["notes"]), conversion["notes"]
    assert conversion["model"].startswith("gltf")
    if not parse_model(model).anisotropic:      # the documented matching rule: the same alpha (equal peak)
        assert conversion["parameters"]["roughness"] == pytest.approx(TRUTH["roughness"])


def test_renderer_draws_the_classic_models():
    """The preview renderer reads the declarations: a Beckmann / Cook-Torrance
    material compiles and lights like its GGX sibling of the same alpha."""
    from shaders.gl import gl_available
    ok, reason = gl_available()
    if not ok:
        pytest.skip(f"no OpenGL 4.3 context: {reason}")
    from shaders import render
    images = {m: render.render_material(m, TRUTH, size=64).astype(float)
              for m in ("ggx+lambert", "beckmann+lambert", "beckmann+lambert+vgroove")}
    images.update({m: render.render_material(m, LOBE_TRUTH, size=64).astype(float)
                   for m in ("blinn_phong+lambert", "phong+lambert", "ward+lambert", "ward_duer+lambert",
                             "ashikhmin_shirley+lambert")})
    images.update({m: render.render_material(m, RECOVERY_CASES[m], size=64).astype(float)
                   for m in ("lafortune+lambert", "lafortune2+lambert")})
    for model, img in images.items():
        assert img.shape == (64, 64, 3) and img[24:40, 24:40].mean() > 10, model
    diff = np.abs(images["beckmann+lambert"] - images["ggx+lambert"]).mean()
    assert 0.0 < diff < 0.1 * images["ggx+lambert"].mean()


# --- the named set 'classic' (fitting/auto.py) ---------------------------------------------------

def test_classic_set_expands():
    from fitting.auto import AUTO_FAMILY, CLASSIC_FAMILY, expand_models, uses_auto
    assert expand_models("classic") == list(CLASSIC_FAMILY)
    assert {"blinn_phong+lambert", "phong+lambert", "ward+lambert", "ward_duer+lambert", "ashikhmin_shirley+lambert",
            "lafortune+lambert", "beckmann+lambert+vgroove", "beckmann+lambert"} == set(CLASSIC_FAMILY)
    assert expand_models("classic,auto") == list(CLASSIC_FAMILY) + list(AUTO_FAMILY)
    assert expand_models("phong+lambert, classic") == ["phong+lambert"] + [m for m in CLASSIC_FAMILY
                                                                          if m != "phong+lambert"]
    assert not uses_auto("classic") and uses_auto("classic,auto")


def test_command_line_fits_the_classic_set(tmp_path, capsys):
    """fit --model classic: every classic model fitted (none screened or cut), one result each,
    ranked; ``models --json`` lists the set."""
    from fitting.auto import CLASSIC_FAMILY
    m = synthetic_measured("blinn_phong+lambert", LOBE_TRUTH, grid=(12, 12, 24, 1))
    keep = m.valid
    path = tmp_path / "bp.npz"
    write_samples(path, m.wi[keep], m.wo[keep], m.values[keep], weights=m.weights[keep], material="bp",
                  isotropic=True)
    assert main(["fit", str(path), "--model", "classic", "--samples", "2000", "--starts", "1",
                 "--out", str(tmp_path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert sorted(r["spec"] for r in out["results"]) == sorted(CLASSIC_FAMILY)
    assert not out["cut"] and not out["screened"]
    assert out["results"][0]["spec"] == "blinn_phong+lambert"        # its own model ranks first
    assert all((tmp_path / f"bp.{model}.json").exists() for model in CLASSIC_FAMILY)
    assert main(["models", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["classic"] == list(CLASSIC_FAMILY)


def test_result_schema_names_every_lobe_models_parameters():
    """``brdf-fit schema`` (additionalProperties false) admits the parameters of every
    declared NDF / lobe, Lafortune's lobes 2 and 3 included."""
    from brdf.model import NDFS
    from fitting.result_schema import result_schema
    # the toolkit's models' parameters: the schema's "then" branch (own:NAME models have their file's)
    names = set(result_schema()["then"]["properties"]["parameters"]["properties"])
    for ndf in NDFS:
        assert {p.name for p in parse_model(f"{ndf}+lambert").schema()} <= names, ndf
