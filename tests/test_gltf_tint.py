"""The glTF model's ``tint``: KHR_materials_specular's colour alone, in [0, 1], its
factor held at 1 (F90 = 1, the Fresnel three.js and Blender's importer draw alike).

Numbers from round trips: the same BRDF as ``specular`` at factor 1, the glTF file
read back, a fit of a table made with known values.
"""

import numpy as np
import pytest

from brdf import gltf
from brdf.gltf_material import material_json, parameters_from_material
from brdf.model import evaluate, parse_model
from brdf.spec import UnknownModelError
from shaders import parity


def _arrays(params):
    return {k: np.asarray(v, np.float64) for k, v in params.items()}


def _pairs(n=300, seed=0):
    """float64 direction pairs above the horizon (shaders.parity's mix, grazing ones included)."""
    return tuple(x.astype(np.float64) for x in parity.random_pairs(n, seed))


PARAMS = {"base_color": [0.5, 0.2, 0.1], "metallic": 0.0, "roughness": 0.3, "ior": 1.8,
          "specular_color": [0.9, 0.6, 0.3]}


def test_tint_is_specular_at_factor_one():
    wi, wo = _pairs()
    tint = np.asarray(evaluate(parse_model("gltf+ior+tint"), _arrays(PARAMS), wi, wo))
    spec = np.asarray(evaluate(parse_model("gltf+ior+specular"), _arrays({**PARAMS, "specular": 1.0}), wi, wo))
    np.testing.assert_allclose(tint, spec, rtol=1e-12)
    direct = np.asarray(gltf.gltf_brdf(wi, wo, np.array(PARAMS["base_color"]), 0.0, 0.3, 1.8, 1.0,
                                       np.array(PARAMS["specular_color"])))
    np.testing.assert_allclose(tint, direct, rtol=1e-12)


def test_tint_beside_specular_is_refused_in_one_line():
    with pytest.raises(UnknownModelError, match="'specular' .* or 'tint', not both"):
        parse_model("gltf+specular+tint")


def test_tint_is_a_colour():
    (colour,) = [p for p in parse_model("gltf+tint").schema() if p.name == "specular_color"]
    assert (colour.lower, colour.upper) == (0.0, 1.0)


def test_written_without_a_specular_factor_and_read_back_as_the_same_brdf():
    material, extensions = material_json({"model": "gltf+ior+tint", "parameters": PARAMS})
    assert material["extensions"]["KHR_materials_specular"] == {"specularColorFactor": PARAMS["specular_color"]}
    assert set(extensions) == {"KHR_materials_ior", "KHR_materials_specular"}
    model, back = parameters_from_material(material)
    assert model == "gltf+ior+specular" and back["specular"] == 1.0       # the schema's default factor
    wi, wo = _pairs(seed=1)
    np.testing.assert_allclose(evaluate(parse_model(model), _arrays(back), wi, wo),
                               evaluate(parse_model("gltf+ior+tint"), _arrays(PARAMS), wi, wo), rtol=1e-12)


def test_a_fit_recovers_a_tinted_dielectric():
    from fitting import fit, synthetic_measured
    measured = synthetic_measured("gltf+ior+tint", PARAMS, noise=0.0)
    result = fit(measured, "gltf+ior+tint", samples=20_000, starts=2)
    np.testing.assert_allclose(result.parameters["base_color"], PARAMS["base_color"], atol=2e-3)
    assert result.parameters["roughness"] == pytest.approx(0.3, abs=2e-3)
    # F0 = F0(ior) x colour is what the table determines
    f0 = ((result.parameters["ior"] - 1) / (result.parameters["ior"] + 1)) ** 2 * np.array(result.parameters["specular_color"])
    np.testing.assert_allclose(f0, ((1.8 - 1) / 2.8) ** 2 * np.array(PARAMS["specular_color"]), rtol=2e-2)
