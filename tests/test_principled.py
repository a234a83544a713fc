"""Blender's Principled BSDF as models (brdf/principled.py, issue 61): ``principled+metal`` and
``principled+nonmetal`` (OpenPBR's bare bases), ``principled+metal+coat`` and
``principled+nonmetal+coat`` (OpenPBR's coat without its three effects on the base).

The values by hand are numpy (the coat's albedo fit read from MaterialX's genglsl, the GGX D V
and the exact Fresnel written out: tests/test_openpbr_coat.py's helpers), not brdf/.  With
Blender's Python (``make blender``; skipped otherwise): Cycles' render of the written .blend on
benchmarks/engine_three.py's lit sphere against the toolkit's model.
"""

import pathlib
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "benchmarks"))

import engine_blender  # noqa: E402
from brdf import gltf_material, openpbr_coat, parse_model, principled  # noqa: E402
from brdf.spec import COMPOSITIONS, UnknownModelError  # noqa: E402
from brdf_fit.export.blender_file import (PRINCIPLED_HELD, drawn_by_principled, export_blender,  # noqa: E402
                                          principled_inputs)
from engine_three import scene_pairs, spec_images  # noqa: E402
from fitting.result import FitResult  # noqa: E402
from hemisphere import upper_directions  # noqa: E402
from model_tables import evaluate64  # noqa: E402
from test_openpbr_coat import _by_hand  # noqa: E402

# The lead's measured cases (2026-12-06, /tmp/coat_probe.py, /tmp/coat_probe2.py): Cycles 5.0.1 / the formula
# at 48 px, 16 samples: METAL_1 0.9978, METAL_2 1.0001, NONMETAL_1 0.984-0.987, NONMETAL_2 0.988.
METAL_1 = {"base_color": [0.9, 0.6, 0.5], "specular_color": [0.8, 0.5, 0.3], "roughness": 0.5,
           "coat_weight": 1.0, "coat_roughness": 0.1, "coat_ior": 1.5}
METAL_2 = {"base_color": [0.3, 0.3, 0.3], "specular_color": [1.0, 1.0, 1.0], "roughness": 0.2,
           "coat_weight": 0.6, "coat_roughness": 0.3, "coat_ior": 1.8}
NONMETAL_1 = {"base_color": [0.5, 0.2, 0.1], "specular_ior": 1.5, "base_diffuse_roughness": 0.0, "roughness": 0.4,
              "coat_weight": 1.0, "coat_roughness": 0.1, "coat_ior": 1.5}
NONMETAL_2 = {"base_color": [0.05, 0.05, 0.05], "specular_ior": 2.0, "base_diffuse_roughness": 0.0,
              "roughness": 0.5, "coat_weight": 0.7, "coat_roughness": 0.15, "coat_ior": 1.4}
PAIRS = [((0.3, 0.1, 0.95), (-0.3, -0.1, 0.95)), ((0.6, 0.0, 0.8), (-0.2, 0.3, 0.93)),
         ((0.1, 0.5, 0.86), (-0.1, -0.97, 0.2)), ((0.5, 0.5, 0.7), (0.5, 0.4, 0.77))]


def _unit(v):
    v = np.asarray(v, np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def test_model_strings():
    """The bare two are OpenPBR's bases (one BRDF, one composition, the canonical string openpbr's);
    the coated two are new compositions with OpenPBR's coated parameters, bounds and starts."""
    for text, composition, canonical in (
            ("principled+metal", "openpbr", "openpbr+metal"),
            ("principled+nonmetal", "openpbr_nonmetal", "openpbr+nonmetal"),
            ("principled+metal+coat", "principled_metal_coat", "principled+metal+coat"),
            ("principled+coat+nonmetal", "principled_nonmetal_coat", "principled+nonmetal+coat")):
        spec = parse_model(text)
        assert spec.composition == composition and str(spec) == canonical and parse_model(canonical) == spec
    for base in ("metal", "nonmetal"):
        ours, theirs = parse_model(f"principled+{base}+coat"), parse_model(f"openpbr+{base}+coat")
        assert ours.schema() == theirs.schema()
        ours_c, theirs_c = COMPOSITIONS[ours.composition], COMPOSITIONS[theirs.composition]
        assert ours_c.variants == theirs_c.variants and ours_c.gltf.quantities == theirs_c.gltf.quantities
    assert set(principled.PRINCIPLED_COAT_COMPOSITIONS).isdisjoint(openpbr_coat.OPENPBR_COMPOSITIONS)
    for text in ("principled", "principled+coat", "principled+metal+clearcoat", "principled+metal+nonmetal",
                 "principled+metal+coat+coat"):
        with pytest.raises(UnknownModelError, match="principled"):
            parse_model(text)


# --- worked by hand -------------------------------------------------------------------

@pytest.mark.parametrize("case", ["metal_1", "metal_2", "nonmetal_1", "nonmetal_2"])
def test_values_worked_by_hand(case):
    """At four pairs (the mirror pair, off-specular, grazing view, retro) the model and its
    standalone twin are the formula worked in numpy, to 1e-10."""
    params = {"metal_1": METAL_1, "metal_2": METAL_2, "nonmetal_1": NONMETAL_1, "nonmetal_2": NONMETAL_2}[case]
    metal = case.startswith("metal")
    wi, wo = _unit([p[0] for p in PAIRS]), _unit([p[1] for p in PAIRS])
    hand = np.array([_by_hand(params, a, b, metal, openpbr=False) for a, b in zip(wi, wo)])
    model = "principled+metal+coat" if metal else "principled+nonmetal+coat"
    np.testing.assert_allclose(evaluate64(model, params, wi, wo), hand, rtol=1e-10)
    with jax.enable_x64(True):
        base = ([jnp.asarray(params["specular_color"]), params["roughness"]] if metal else
                [params["specular_ior"], params["roughness"], params["base_diffuse_roughness"]])
        twin = principled.principled_metal_coat if metal else principled.principled_nonmetal_coat
        g = np.asarray(twin(jnp.asarray(wi), jnp.asarray(wo), jnp.asarray(params["base_color"]), *base,
                            params["coat_weight"], params["coat_roughness"], params["coat_ior"]))
    np.testing.assert_allclose(g, hand, rtol=1e-10)


@pytest.mark.parametrize("base", ["metal", "nonmetal"])
def test_no_coat_is_the_bare_base(base):
    """Coat weight 0: the bare base exactly, as OpenPBR's coat at weight 0 is; a coat is view-sided
    (not reciprocal: tests/test_brdf_properties.py turns it off)."""
    rng = np.random.default_rng(5)
    wi, wo = upper_directions(rng, 2000), upper_directions(rng, 2000)
    params = {**(METAL_1 if base == "metal" else {**NONMETAL_1, "base_diffuse_roughness": 0.4}), "coat_weight": 0.0}
    bare = {k: v for k, v in params.items() if not k.startswith("coat_")}
    f = evaluate64(f"principled+{base}+coat", params, wi, wo)
    np.testing.assert_array_equal(f, evaluate64(f"principled+{base}", bare, wi, wo))
    np.testing.assert_array_equal(f, evaluate64(f"openpbr+{base}+coat", params, wi, wo))
    coated = {**params, "coat_weight": 0.8}       # a coat weighs the base by 1 - w E_c at the view side only
    f, g = evaluate64(f"principled+{base}+coat", coated, wi, wo), evaluate64(f"principled+{base}+coat", coated, wo, wi)
    assert np.abs(f - g).max() > 1e-3


def _twin(base, params, wi, wo, **switches):
    """brdf.openpbr_coat's standalone coated function with the switches given."""
    with jax.enable_x64(True):
        rest = ([jnp.asarray(params["specular_color"]), params["roughness"]] if base == "metal" else
                [params["specular_ior"], params["roughness"], params["base_diffuse_roughness"]])
        twin = openpbr_coat.openpbr_metal_coat if base == "metal" else openpbr_coat.openpbr_nonmetal_coat
        return np.asarray(twin(jnp.asarray(wi), jnp.asarray(wo), jnp.asarray(params["base_color"]), *rest,
                               params["coat_weight"], params["coat_roughness"], params["coat_ior"], **switches))


# Where each switch matters: a sharp base under a rough coat (roughening r 0.2 -> 0.75), a dark base
# (darkening (1 - K) / (1 - 0.05 K) = 0.88 at coat_ior 1.6), a base IOR equal to the coat's
# (inverted to c / s = 1: no specular reflection left at the interface).
SWITCHED = {"metal": {"base_color": [0.05, 0.3, 0.6], "specular_color": [1.0, 0.8, 0.6], "roughness": 0.2,
                      "coat_weight": 1.0, "coat_roughness": 0.6, "coat_ior": 1.6},
            "nonmetal": {"base_color": [0.05, 0.05, 0.05], "specular_ior": 1.6, "base_diffuse_roughness": 0.0,
                         "roughness": 0.2, "coat_weight": 1.0, "coat_roughness": 0.6, "coat_ior": 1.6}}


@pytest.mark.parametrize("base", ["metal", "nonmetal"])
def test_the_coat_is_openpbrs_without_its_three_effects_on_the_base(base):
    """The principled coated composition is OpenPBR's coat function with all switches off (exactly),
    OpenPBR's composition with all on; each switch alone changes the value (mean > 5 %)."""
    rng = np.random.default_rng(11)
    wi, wo = upper_directions(rng, 3000), upper_directions(rng, 3000)
    params = SWITCHED[base]
    names = ("roughens", "darkens") + (("inverts_ior",) if base == "nonmetal" else ())
    off = _twin(base, params, wi, wo, **{n: False for n in names})
    np.testing.assert_allclose(evaluate64(f"principled+{base}+coat", params, wi, wo), off, rtol=1e-12, atol=1e-300)
    np.testing.assert_allclose(evaluate64(f"openpbr+{base}+coat", params, wi, wo),
                               _twin(base, params, wi, wo, **{n: True for n in names}), rtol=1e-12)
    for name in names:
        one = _twin(base, params, wi, wo, **{n: n == name for n in names})
        change = np.abs(one - off).mean() / off.mean()
        assert change > 0.05, (name, change)


def test_gltf_note_and_no_open_pbr_surface(tmp_path):
    """The glTF conversion is the OpenPBR coated models' (the base as theirs) with a note naming the
    Principled coat; open_pbr_surface 1:1 is refused (not OpenPBR's coat): the MaterialX export
    writes the glTF conversion's (the coat dropped, as the note says), no coat."""
    from brdf_fit.export.materialx_file import export_materialx
    for base, params in (("metal", METAL_1), ("nonmetal", NONMETAL_1)):
        ours = gltf_material.convert(f"principled+{base}+coat", params)
        theirs = gltf_material.convert(f"openpbr+{base}+coat", params)
        assert ours["parameters"] == theirs["parameters"] and ours["model"] == theirs["model"]
        assert any("Principled BSDF's is the exact Fresnel" in note for note in ours["notes"])
        with pytest.raises(ValueError, match="not an OpenPBR composition"):
            openpbr_coat.open_pbr_surface_inputs(params, f"principled_{base}_coat")
        info = export_materialx(FitResult(spec=f"principled+{base}+coat", parameters=params, errors={"m1": 0.001},
                                          optimizer={}, provenance={"material": base}), tmp_path / f"{base}.mtlx")
        surface = info["materialx_inputs"]["open_pbr_surface"]
        assert "coat_weight" not in surface and surface["specular_roughness"] == params["roughness"]
        assert not any("1:1" in note for note in info["materialx_notes"]["open_pbr_surface"])


def test_principled_inputs_write_the_coat():
    assert drawn_by_principled("principled+metal+coat") and drawn_by_principled("principled+nonmetal+coat")
    assert drawn_by_principled("principled+metal") and not drawn_by_principled("openpbr+metal+coat")
    metal = principled_inputs("principled+metal+coat", METAL_2)
    assert metal == {"Metallic": 1.0, "Base Color": METAL_2["base_color"], "Specular Tint": METAL_2["specular_color"],
                     "Roughness": 0.2, **PRINCIPLED_HELD, "Coat Weight": 0.6, "Coat Roughness": 0.3, "Coat IOR": 1.8,
                     "Coat Tint": [1.0, 1.0, 1.0]}
    nonmetal = principled_inputs("principled+nonmetal+coat", NONMETAL_2)
    assert nonmetal == {"Metallic": 0.0, "Base Color": NONMETAL_2["base_color"], "IOR": 2.0, "Roughness": 0.5,
                        "Diffuse Roughness": 0.0, "Specular Tint": [1.0, 1.0, 1.0], **PRINCIPLED_HELD,
                        "Coat Weight": 0.7, "Coat Roughness": 0.15, "Coat IOR": 1.4, "Coat Tint": [1.0, 1.0, 1.0]}
    assert principled_inputs("principled+metal", METAL_2)["Coat Weight"] == 0.0     # bare: no coat written


# --- the GLSL twin ---------------------------------------------------------------------------

@pytest.mark.parametrize("base", ["metal", "nonmetal"])
def test_glsl_parity(base):
    """Per-pair parameters (shaders.parity.model_parity) and the renderer's uniform block (one
    parameter set), to the parity harness's limits (1e-4 relative, 1e-6 absolute)."""
    from shaders.gl import gl_available
    ok, reason = gl_available()
    if not ok:
        pytest.skip(f"no OpenGL 4.3 context: {reason}")
    from shaders import parity
    model = f"principled+{base}+coat"
    for result in (parity.model_parity(model, 20_000, seed=4), _shared_block(parity, model)):
        assert result["nonfinite"] == 0 and result["max_rel"] < parity.REL_TOL and result["max_abs"] < parity.ABS_TOL, \
            result


def _shared_block(parity, model, n=20_000):
    wi, wo = parity.random_pairs(n, 3, below=0.02)
    shared = {k: v[0] for k, v in parity.random_params(model, 1, seed=7).items()}
    gl = parity.evaluate_model(model, shared, wi, wo)
    return parity.compare(gl, parity.jax_reference(model, {k: np.broadcast_to(v, (n,) + v.shape)
                                                           for k, v in shared.items()}, wi, wo))


# --- Cycles --------------------------------------------------------------------------------

needs_blender = pytest.mark.skipif(not engine_blender.blender_available(),
                                   reason="no Blender Python with bpy (make blender; $BRDF_BLENDER_PYTHON)")
SIZE, SAMPLES, ELEVATIONS = 32, 4, (30.0, 85.0)
CASES = {"metal_1": ("metal", METAL_1), "metal_2": ("metal", METAL_2),
         "nonmetal_1": ("nonmetal", NONMETAL_1), "nonmetal_2": ("nonmetal", NONMETAL_2)}
# Cycles / the toolkit summed over the lit sphere.  Metals: within 1 % (tests/test_export_blender.py's
# AGREEMENT; measured 0.998-1.000).  Non-metals: Cycles draws the non-metal's base darker than the toolkit
# (its layering albedo: docs/blender.md, 0.8 % at IOR 1.5 to 6.5 % at IOR 2.2 on a rough lobe, 1-9 % over
# its table): from 10 % below (9 % + the 1 %) to 1 % above; measured 0.984-0.988.
BOUNDS = {"metal": (0.99, 1.01), "nonmetal": (0.90, 1.01)}


@pytest.fixture(scope="module")
def cycles(tmp_path_factory):
    folder = tmp_path_factory.mktemp("principled_blender")
    blends = {}
    for name, (base, params) in CASES.items():
        blends[name] = folder / f"{name}.blend"
        result = FitResult(spec=f"principled+{base}+coat", parameters=params, errors={"m1": 0.001, "image": 0.01},
                           optimizer={"max_theta": 80.0}, provenance={"file": f"/data/{name}.binary",
                                                                      "sha256": "ab" * 32, "format": "merl",
                                                                      "material": name})
        export_blender(result, blends[name])
    images, _, _, _ = engine_blender.blender_images(blends, SIZE, ELEVATIONS, folder, samples=SAMPLES, seeds=(0,),
                                                    variants=("shipped",))
    index, _, wi, wo, cos_i = scene_pairs(SIZE, ELEVATIONS)
    lit = cos_i > 0.05

    def ratio(name, model):
        drawn = engine_blender.pixels(images[name]["shipped"], index)
        return drawn[lit].sum(0) / spec_images(model, CASES[name][1], wi, wo, cos_i)[lit].sum(0)
    return ratio


@needs_blender
@pytest.mark.parametrize("name", list(CASES))
def test_cycles_draws_the_principled_coat(cycles, name):
    """Cycles' render of the written .blend against the toolkit's model (BOUNDS), and nearer it
    than OpenPBR's coat of the same values (measured at 48 px: 1.13-1.64 metal, 1.64-2.36 non-metal)."""
    base = CASES[name][0]
    ours, openpbr = cycles(name, f"principled+{base}+coat"), cycles(name, f"openpbr+{base}+coat")
    low, high = BOUNDS[base]
    assert np.all((ours > low) & (ours < high)), ours
    assert np.abs(ours - 1.0).mean() < np.abs(openpbr - 1.0).mean(), (ours, openpbr)
