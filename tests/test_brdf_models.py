"""ModelSpec, model strings, parameter schemas and the energy tables' shape.

Round trips (string -> spec -> string, spec -> string -> spec), schema
consistency with default_params, the error a user gets for an unknown name,
and sanity of the tabulated E(mu, r) / E_avg(r) (no timing is asserted).
"""

import itertools
import math

import jax.numpy as jnp
import numpy as np
import pytest

import brdf
from brdf import energy
from brdf.principled import FIXED_COMPOSITIONS
from brdf.model import (ANISOTROPY_REMAPS, COMPOSITIONS, DIFFUSES, ENERGIES, FRESNELS,
                        GLTF_EXTENSIONS, MASKINGS, NDFS, ModelSpec, check_params)


@pytest.mark.parametrize("text", brdf.MODEL_EXAMPLES)
def test_model_string_round_trip(text):
    spec = brdf.parse_model(text)
    assert str(spec) == text
    assert brdf.model_string(spec) == text
    assert brdf.parse_model(str(spec)) == spec
    assert brdf.parse_model(spec) is spec
    hash(spec)                                   # usable as a jit static argument


@pytest.mark.parametrize("text, canonical", [
    ("ggx+clearcoat+lambert+ms", "ggx+lambert+ms+clearcoat"),
    (" GGX + Lambert ", "ggx+lambert"),
    ("gltf+clearcoat+specular+ior", "gltf+ior+specular+clearcoat"),
    ("gltf+aniso+ior", "gltf+ior+aniso"),
    ("ggx", "ggx"),
])
def test_model_string_canonical_order(text, canonical):
    assert str(brdf.parse_model(text)) == canonical


def all_valid_specs():
    """Every ModelSpec the dataclass accepts (the canonical ones, deduplicated).  A composition
    that fixes its terms (openpbr, principled: FIXED_COMPOSITIONS) sets its diffuse to "none" and
    is refused with any other terms, so its diffuse lobes, anisotropy remaps and glTF extensions
    are not run through (each gave one spec, at 4.5 s a composition).  The glTF extensions' sets
    are made of the extensions a spec accepts one at a time (a set is refused where one of its
    extensions alone is: six million specs tried for the same 4 076 took 30-50 s)."""
    specs = set()

    def valid(*fields):
        try:
            return ModelSpec(*fields)
        except brdf.UnknownModelError:
            return None
    for ndf, masking, fresnel, diffuse, comp, energy_, cc, remap in itertools.product(
            NDFS, MASKINGS, FRESNELS, DIFFUSES, COMPOSITIONS, ENERGIES, (False, True), ANISOTROPY_REMAPS):
        fixed = comp in FIXED_COMPOSITIONS
        if fixed and (diffuse, remap) != (next(iter(DIFFUSES)), next(iter(ANISOTROPY_REMAPS))):
            continue
        terms = (ndf, masking, fresnel, diffuse, comp, energy_, cc, remap)
        alone = [] if fixed else [ext for ext in GLTF_EXTENSIONS if valid(*terms, (ext,))]
        for n_ext in range(len(alone) + 1):
            for exts in itertools.combinations(alone, n_ext):
                specs.add(valid(*terms, exts))
    specs.discard(None)
    return sorted(specs, key=str)


def test_every_spec_round_trips_through_its_string():
    specs = all_valid_specs()
    assert len(specs) > 500
    strings = set()
    for spec in specs:
        text = str(spec)
        assert brdf.parse_model(text) == spec, text
        strings.add(text)
    assert len(strings) == len(specs)          # distinct specs print differently


def test_equal_specs_evaluate_alike():
    # the glTF model always uses the KHR anisotropy remap, whatever the field said
    direct = ModelSpec(composition="gltf", ndf="ggx_aniso", anisotropy="kulla_conty")
    assert direct == brdf.parse_model("gltf+aniso")
    # an isotropic spec ignores the remap field
    assert ModelSpec(anisotropy="gltf") == ModelSpec()
    p = brdf.default_params(direct)
    p["anisotropy"] = jnp.asarray(0.6)
    wi = np.array([0.3, 0.1, 0.9]) / np.linalg.norm([0.3, 0.1, 0.9])
    wo = np.array([-0.4, 0.3, 0.8]) / np.linalg.norm([-0.4, 0.3, 0.8])
    np.testing.assert_array_equal(brdf.evaluate(direct, p, wi, wo), brdf.evaluate("gltf+aniso", p, wi, wo))


def _examples_and_more():
    return list(brdf.MODEL_EXAMPLES) + ["ggx_aniso+oren_nayar+separable+f90+turquin",
                                        "ggx+conductor+coupled+burley", "gltf+ior+specular+aniso+clearcoat"]


@pytest.mark.parametrize("text", _examples_and_more())
def test_schema_consistent_with_default_params(text):
    spec = brdf.parse_model(text)
    schema = spec.schema()
    assert schema == brdf.parameter_schema(spec)
    names = [p.name for p in schema]
    assert len(set(names)) == len(names)
    assert "roughness" in names
    params = brdf.default_params(spec)
    assert list(params) == names               # the fit vector's order
    check_params(spec, params)
    for p in schema:
        assert p.size in (1, 3), p
        assert p.lower < p.upper, p
        assert p.lower <= p.default <= p.upper, p
        assert p.description
        assert params[p.name].shape == ((3,) if p.size == 3 else ()), p
        np.testing.assert_array_equal(params[p.name], p.default)
    # roughness floors are the named constant (EON's diffuse roughness is no alpha: 0 is Lambert)
    for p in schema:
        if "roughness" in p.name and not p.name.endswith("diffuse_roughness"):    # (and OpenPBR's base_...)
            assert p.lower == brdf.ROUGHNESS_MIN and p.upper == 1.0
    assert math.isclose(brdf.ROUGHNESS_MIN ** 2, brdf.ALPHA_MIN)
    # the defaults evaluate to something finite and positive
    wi = np.array([0.2, -0.3, 0.93]) / np.linalg.norm([0.2, -0.3, 0.93])
    wo = np.array([-0.5, 0.1, 0.86]) / np.linalg.norm([-0.5, 0.1, 0.86])
    f = np.asarray(brdf.evaluate(spec, params, wi, wo))
    assert f.shape == (3,) and np.all(np.isfinite(f)) and np.all(f > 0)
    # default_params honours dtype
    assert all(v.dtype == jnp.float32 for v in brdf.default_params(spec, jnp.float32).values())


@pytest.mark.parametrize("text, expected_names", [
    ("ggx+lambert", ["albedo", "roughness", "f0"]),
    ("ggx+oren_nayar", ["albedo", "sigma", "roughness", "f0"]),
    ("ggx_aniso+lambert+clearcoat", ["albedo", "roughness", "anisotropy", "rotation", "f0",
                                     "clearcoat", "clearcoat_roughness"]),
    ("ggx+f90", ["roughness", "f0", "f90"]),
    ("ggx+dielectric", ["roughness", "ior"]),
    ("ggx+conductor", ["roughness", "eta", "k"]),
    ("gltf", ["base_color", "metallic", "roughness"]),
    ("gltf+ior+specular+aniso+clearcoat", ["base_color", "metallic", "roughness", "ior", "specular",
                                           "specular_color", "anisotropy", "rotation", "clearcoat",
                                           "clearcoat_roughness"]),
])
def test_schema_names(text, expected_names):
    assert [p.name for p in brdf.parse_model(text).schema()] == expected_names


def test_anisotropy_bounds_follow_the_remap():
    kc = {p.name: p for p in brdf.parse_model("ggx_aniso").schema()}["anisotropy"]
    gl = {p.name: p for p in brdf.parse_model("ggx_aniso+gltf_aniso").schema()}["anisotropy"]
    assert kc.lower < 0 < kc.upper < 1          # Kulla-Conty a in (-1, 1)
    assert (gl.lower, gl.upper) == (0.0, 1.0)   # KHR strength in [0, 1]


def test_check_params_rejects_missing_and_extra():
    spec = brdf.parse_model("ggx+lambert")
    p = brdf.default_params(spec)
    with pytest.raises(ValueError, match="missing.*f0"):
        check_params(spec, {k: v for k, v in p.items() if k != "f0"})
    with pytest.raises(ValueError, match="unexpected.*sigma"):
        check_params(spec, {**p, "sigma": 0.1})


@pytest.mark.parametrize("text, must_list", [
    ("torrance_sparrow", ["ggx", "ggx_aniso", "beckmann", "beckmann_aniso", "blinn_phong", "phong", "ward", "gltf"]),
    ("trowbridge+lambert", ["ggx", "beckmann", "gltf"]),
    ("ggx+lamber", ["lambert", "burley", "frostbite", "cod_wwii", "oren_nayar", "ms", "clearcoat"]),
    ("ggx+fresnel", ["dielectric", "conductor", "f90"]),
    ("gltf+lambert", ["ior", "specular", "aniso", "clearcoat"]),
    ("", ["ggx+lambert"]),
])
def test_unknown_names_list_valid_ones(text, must_list):
    with pytest.raises(brdf.UnknownModelError) as err:
        brdf.parse_model(text)
    message = str(err.value)
    for token in must_list:
        assert token in message, (token, message)
    assert isinstance(err.value, ValueError)


@pytest.mark.parametrize("text", [
    "ggx+lambert+burley",             # two diffuse lobes
    "ggx+ms+turquin",                 # two energy compensations
    "ggx+dielectric+conductor",       # two Fresnels
    "ggx+lambert+lambert",            # repeated option
    "ggx+gltf_aniso",                 # the glTF remap needs ggx_aniso
    "beckmann+gltf_aniso",            # ... or beckmann_aniso
    "beckmann+lambert+ms",            # GGX's energy tables do not describe Beckmann
    "beckmann_aniso+lambert+turquin",
])
def test_conflicting_options_rejected(text):
    with pytest.raises(brdf.UnknownModelError):
        brdf.parse_model(text)


@pytest.mark.parametrize("kwargs, must_list", [
    (dict(ndf="torrance_sparrow"), ["ggx", "ggx_aniso", "beckmann", "beckmann_aniso", "ward"]),
    (dict(diffuse="disney"), ["lambert", "burley", "oren_nayar"]),
    (dict(fresnel="cook"), ["schlick", "dielectric", "conductor"]),
    (dict(composition="gltf", gltf_extensions=("iridescence",)), ["ior", "specular", "sheen"]),
])
def test_model_spec_rejects_unknown_fields(kwargs, must_list):
    with pytest.raises(brdf.UnknownModelError) as err:
        ModelSpec(**kwargs)
    for token in must_list:
        assert token in str(err.value)


@pytest.mark.parametrize("kwargs", [
    dict(composition="gltf", diffuse="burley"),
    dict(composition="gltf", energy="kulla_conty"),
    dict(gltf_extensions=("ior",)),            # extensions without the gltf model
    dict(composition="gltf", ndf="beckmann"),  # glTF's NDF is GGX
])
def test_model_spec_rejects_inconsistent_gltf(kwargs):
    with pytest.raises(brdf.UnknownModelError):
        ModelSpec(**kwargs)


def test_evaluate_shapes_broadcast():
    spec = brdf.parse_model("ggx+lambert")
    p = brdf.default_params(spec)
    rng = np.random.default_rng(0)
    d = rng.normal(size=(4, 5, 3))
    d[..., 2] = np.abs(d[..., 2])
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    f = np.asarray(brdf.evaluate(spec, p, d, d[::-1]))
    assert f.shape == (4, 5, 3)
    np.testing.assert_allclose(f[1, 2], brdf.evaluate(spec, p, d[1, 2], d[::-1][1, 2]), rtol=1e-14)


# --- energy tables ------------------------------------------------------------------

def test_energy_tables_shape_and_sanity():
    t = energy.tables()
    n = energy.TABLE_SIZE
    assert t["mu"].shape == (n,) and t["roughness"].shape == (n,)
    for key in ("A", "B", "E"):
        assert t[key].shape == (n, n), key
    assert t["E_avg"].shape == (n,)
    np.testing.assert_allclose(t["mu"][[0, -1]], [0.0, 1.0])
    np.testing.assert_allclose(t["roughness"][[0, -1]], [brdf.ROUGHNESS_MIN, 1.0])
    np.testing.assert_allclose(t["E"], t["A"] + t["B"], rtol=1e-14)
    assert np.all(np.isfinite(t["E"])) and np.all(t["A"] >= 0) and np.all(t["B"] >= 0)
    # single scattering never creates energy; the quadrature may overshoot 1 by its error only
    assert np.all(t["E"] <= 1.0 + 1e-3) and np.all(t["E_avg"] <= 1.0 + 1e-3)
    assert np.all(t["E"][1:] > 0.2) and np.all(t["E_avg"] > 0.3)
    # E_avg decreases with roughness (more energy lost); near-mirror keeps almost all
    assert np.all(np.diff(t["E_avg"]) < 0)
    assert t["E_avg"][0] > 0.999 and t["E"][-1, 0] > 0.999
    # at normal incidence E decreases with roughness too
    assert np.all(np.diff(t["E"][-1]) < 0)
    # E_avg is the cosine-weighted mean of E over mu (trapezoid on the 32-node mu grid)
    mu = t["mu"]
    e_avg_trapz = 2 * np.trapezoid(t["E"] * mu[:, None], mu, axis=0)
    np.testing.assert_allclose(e_avg_trapz, t["E_avg"], rtol=5e-3)
    # cached: the same object each call
    assert energy.tables() is t


def test_lookup_interpolates_table_nodes_exactly():
    t = energy.tables()
    for i, k in ((0, 0), (5, 7), (31, 31), (17, 3)):
        np.testing.assert_allclose(energy.lookup_e(t["mu"][i], t["roughness"][k]), t["E"][i, k], rtol=1e-12)
        np.testing.assert_allclose(energy.lookup_e_avg(t["roughness"][k]), t["E_avg"][k], rtol=1e-12)
    # out-of-range inputs clamp to the table's edge
    np.testing.assert_allclose(energy.lookup_e(1.5, 2.0), t["E"][-1, -1], rtol=1e-12)
    np.testing.assert_allclose(energy.lookup_e(-0.5, 0.0), t["E"][0, 0], rtol=1e-12)
