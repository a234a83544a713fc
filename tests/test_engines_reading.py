"""The glTF material in the engines' reading (``+turquin``, brdf/gltf.py; docs/gltf.md, "The
engines' reading"): the same file, drawn with the multiple scattering three.js r187 adds to the
specular lobe under direct light, 1 + F0_b (1/E(n.v) - 1) at the blended F0.

Checked here: the BRDF against the formula worked out in numpy (the diffuse and the coat left
as they are), that the written material is the same file, and on a synthetic table drawn in
that reading (a rough, high-F0 non-metal, the kind of table nylon and the fabrics are) that the
fit in the engines' reading recovers the material while the fit in the specification's
reading, drawn as the engines draw its file, is too bright.  (Against three.js itself:
tests/test_cross_render.py, test_three_draws_the_engines_reading.)
"""

import numpy as np
import pytest

from brdf import parse_model
from brdf.energy import lookup_e
from brdf.fresnel import f0_from_ior
from brdf.gltf_material import convert, material_json
from brdf.model import evaluate
from fitting.fit import fit
from fitting.material_errors import m1_errors
from fitting.synthetic import synthetic_measured

PAIRS = np.array([[[0.3, 0.1, 0.9], [-0.2, 0.3, 0.8]], [[0.7, -0.2, 0.3], [0.1, 0.5, 0.4]],
                  [[-0.5, 0.5, 0.2], [0.6, 0.1, 0.3]]])
# rough and bright at normal incidence: where the engines' multiple scattering is largest
TRUTH = {"base_color": [0.12, 0.13, 0.09], "roughness": 0.85, "ior": 2.6}


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _by_hand(p, metallic, wi, wo, coat=None):
    """The glTF BRDF in the engines' reading, term by term in numpy (one pair)."""
    h = _unit(wi + wo)
    a = p["roughness"] ** 2
    d = a * a / (np.pi * (h[2] ** 2 * (a * a - 1) + 1) ** 2)
    lam = [np.sqrt(n * n * (1 - a * a) + a * a) for n in (wi[2], wo[2])]
    v = 0.5 / (wi[2] * lam[1] + wo[2] * lam[0])
    w = (1 - abs(wo @ h)) ** 5
    base = np.asarray(p["base_color"])
    f0 = np.full(3, float(f0_from_ior(p.get("ior", 1.5))))
    dielectric_spec = (f0 + (1 - f0) * w) * d * v
    metal = (base + (1 - base) * w) * d * v
    blended = f0 + (base - f0) * metallic
    e = float(lookup_e(wo[2], p["roughness"]))
    spec = (dielectric_spec + (metal - dielectric_spec) * metallic) * (1 + blended * (1 / e - 1))
    f = spec + (1 - metallic) * (1 - np.max(f0 + (1 - f0) * w)) * base / np.pi
    if coat is None:
        return f
    cc, rc = coat
    ac = rc * rc
    dc = ac * ac / (np.pi * (h[2] ** 2 * (ac * ac - 1) + 1) ** 2)
    lc = [np.sqrt(n * n * (1 - ac * ac) + ac * ac) for n in (wi[2], wo[2])]
    fc = 0.04 + 0.96 * (1 - wo[2]) ** 5          # KHR_materials_clearcoat: Fresnel at n.v
    return f * (1 - cc * fc) + cc * fc * dc * 0.5 / (wi[2] * lc[1] + wo[2] * lc[0])


@pytest.mark.parametrize("model, metallic", [("gltf+metal+turquin", 1.0), ("gltf+nonmetal+ior+turquin", 0.0),
                                             ("gltf+turquin", 0.4)])
def test_the_engines_reading_is_the_formula(model, metallic):
    p = {"base_color": np.array([0.9, 0.5, 0.2]), "roughness": 0.6, "ior": 2.2}
    params = {k: v for k, v in p.items() if k in {q.name for q in parse_model(model).schema()}}
    if "metallic" in {q.name for q in parse_model(model).schema()}:
        params["metallic"] = metallic
    for wi, wo in PAIRS:
        wi, wo = _unit(wi), _unit(wo)
        expected = _by_hand(p if "ior" in params else {**p, "ior": 1.5}, metallic, wi, wo)
        np.testing.assert_allclose(np.asarray(evaluate(model, params, wi, wo)), expected, rtol=1e-5)


def test_the_coat_is_left_single_scattering():
    p = {"base_color": np.array([0.3, 0.2, 0.1]), "roughness": 0.8, "ior": 2.5,
         "clearcoat": 0.5, "clearcoat_roughness": 0.1}
    for wi, wo in PAIRS:
        wi, wo = _unit(wi), _unit(wo)
        np.testing.assert_allclose(np.asarray(evaluate("gltf+nonmetal+ior+turquin+clearcoat", p, wi, wo)),
                                   _by_hand(p, 0.0, wi, wo, coat=(0.5, 0.1)), rtol=1e-5)


def test_the_file_is_the_same_material():
    p = {"base_color": [0.3, 0.2, 0.1], "roughness": 0.8, "ior": 2.5, "clearcoat": 0.5, "clearcoat_roughness": 0.1}
    engines = convert("gltf+nonmetal+ior+turquin+clearcoat", p)
    plain = convert("gltf+nonmetal+ior+clearcoat", p)
    assert engines["lossless"] and engines["model"] == "gltf+ior+turquin+clearcoat"
    assert any("engines' reading" in note for note in engines["notes"])
    assert material_json(engines) == material_json(plain)


@pytest.fixture(scope="module")
def engines_table():
    return synthetic_measured("gltf+nonmetal+ior+turquin", TRUTH, grid=(30, 30, 60, 1), seed=5)


def test_the_engines_reading_fit_is_the_material_the_engines_draw(engines_table):
    """Fitted in the engines' reading, the material is recovered; fitted by the specification,
    its file drawn as the engines draw it (its parameters under +turquin) misses the table."""
    engines = fit(engines_table, "gltf+nonmetal+ior+turquin", samples=5_000, starts=1)
    plain = fit(engines_table, "gltf+nonmetal+ior", samples=5_000, starts=1)
    assert engines.parameters["roughness"] == pytest.approx(TRUTH["roughness"], abs=0.01)
    assert engines.parameters["ior"] == pytest.approx(TRUTH["ior"], abs=0.02)
    (m1_engines, _), (m1_plain_drawn, _) = m1_errors(engines_table, [
        ("gltf+nonmetal+ior+turquin", engines.parameters), ("gltf+nonmetal+ior+turquin", plain.parameters)])
    print(f"M1 in the engines' reading: fitted so {m1_engines:.2e}, fitted by the specification {m1_plain_drawn:.4f} "
          f"(its own reading {plain.errors['m1']:.4f})")
    # (measured: 0.00087 and 0.0036, the plain fit's own 0.0007.  Not 0: the table holds each pair
    # once and M1 compares both orientations with it, where the engines' reading, which looks at
    # n.v, is not reciprocal)
    assert m1_plain_drawn > 3 * m1_engines and m1_plain_drawn > plain.errors["m1"]
