"""The Principled BSDF with Multiscatter GGX as Cycles draws it (brdf/principled.py,
brdf.cycles.cycles_multiscatter, issue 61): ``principled+metal+ms`` and ``principled+nonmetal+ms``.

- the model strings and their mistakes;
- values at direction pairs worked in numpy from bsdf_microfacet.h and bsdf_util.h: the lobe times
  1 + F_ms (1 - E) / E with Cycles' GGX albedo tables read by hand (tests/test_principled._read),
  F_ss the F82-tint Fresnel's average per channel for the metal, the dielectric's within [F0, 1] for
  the specular, whose layer weighs the diffuse by saturate(1 - E C albedo(n.v));
- the factor is at least 1 and grows with the roughness; the lobe is view-sided (not reciprocal);
- the export writes the distribution "MULTI_GGX";
- with Blender's Python (``make blender``; skipped otherwise): Cycles' render of the written .blend
  within 1 % of the model, nearer it than the single-scattering model of the same values.
(The GLSL twins: tests/test_shaders_parity.py.)
"""

import pathlib
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "benchmarks"))

import engine_blender  # noqa: E402
from brdf import cycles, parse_model, principled  # noqa: E402
from brdf.model import model_string  # noqa: E402
from brdf.spec import UnknownModelError  # noqa: E402
from brdf_fit.export.blender_file import material_entry  # noqa: E402
from fitting.result import FitResult  # noqa: E402
from hemisphere import upper_directions  # noqa: E402
from model_tables import evaluate64  # noqa: E402
from test_principled import PAIRS, _albedo, _by_hand, _read, _unit, cycles_ratios  # noqa: E402

METAL = {"base_color": [0.9, 0.6, 0.5], "specular_color": [0.8, 0.5, 0.3], "roughness": 0.7}
NONMETAL = {"base_color": [0.5, 0.2, 0.1], "specular_ior": 1.6, "base_diffuse_roughness": 0.4, "roughness": 0.8}


def test_ms_model_strings_and_their_mistakes():
    assert parse_model("principled+metal+ms").composition == "principled_metal_ms"
    assert model_string(parse_model("principled+ms+nonmetal")) == "principled+nonmetal+ms"
    for wrong in ("principled+metal+coat+ms", "principled+nonmetal+sheen+ms", "principled+ms"):
        with pytest.raises(UnknownModelError, match=r"principled\+metal\+ms"):
            parse_model(wrong)


def _kept(n_v, rough, fss):
    e_table, e_avg_table = cycles.ggx_albedo_tables()
    e, e_avg = _read(e_table, (n_v, rough)), _read(e_avg_table, (rough,))
    f_ms = fss * e_avg / (1 - fss * (1 - e_avg))
    return 1 + f_ms * (1 - e) / e, e


def _ms_by_hand(params, wi, wo, metal):
    n_v, r = wo[2], params["roughness"]
    if metal:
        f0, tint = np.asarray(params["base_color"]), np.asarray(params["specular_color"])
        b = (f0 + (1 - f0) * (6 / 7) ** 5) * (1 - tint) * 7 / (6 / 7) ** 6       # fresnel_f82tint_B
        kept, _ = _kept(n_v, r, f0 + (1 - f0) / 21 - b / 126)                     # fresnel_f82_Fss
        return _by_hand(params, wi, wo, metal=True, coated=False) * kept
    eta = params["specular_ior"]
    f0 = ((eta - 1) / (eta + 1)) ** 2
    kept, e = _kept(n_v, r, min(max((eta - 1) / (4.08567 + 1.00071 * eta), f0), 1.0))
    # the bare base by hand is top + through x diffuse: take its two parts apart at albedo 0
    top = _by_hand({**params, "base_color": [0.0] * 3}, wi, wo, metal=False, coated=False)
    through = min(max(1 - _albedo(n_v, r, eta), 0.0), 1.0)
    diffuse = (_by_hand(params, wi, wo, metal=False, coated=False) - top) / through
    return top * kept + min(max(1 - e * kept * _albedo(n_v, r, eta), 0.0), 1.0) * diffuse


@pytest.mark.parametrize("metal", [True, False])
def test_values_worked_by_hand(metal):
    params = METAL if metal else NONMETAL
    model = "principled+metal+ms" if metal else "principled+nonmetal+ms"
    wi, wo = _unit([p[0] for p in PAIRS]), _unit([p[1] for p in PAIRS])
    hand = np.array([_ms_by_hand(params, a, b, metal) for a, b in zip(wi, wo)])
    np.testing.assert_allclose(evaluate64(model, params, wi, wo), hand, rtol=1e-10)
    with jax.enable_x64(True):
        if metal:
            twin = principled.principled_metal_ms(jnp.asarray(wi), jnp.asarray(wo), jnp.asarray(METAL["base_color"]),
                                                  jnp.asarray(METAL["specular_color"]), METAL["roughness"])
        else:
            twin = principled.principled_nonmetal_ms(jnp.asarray(wi), jnp.asarray(wo),
                                                     jnp.asarray(NONMETAL["base_color"]), NONMETAL["specular_ior"],
                                                     NONMETAL["roughness"], NONMETAL["base_diffuse_roughness"])
    np.testing.assert_allclose(np.asarray(twin), hand, rtol=1e-10)


def test_the_factor_grows_with_roughness_and_is_view_sided():
    rng = np.random.default_rng(2)
    wi, wo = upper_directions(rng, 500), upper_directions(rng, 500)
    gains = []
    for rough in (0.2, 0.5, 0.9):
        params = {**METAL, "roughness": rough}
        ratio = evaluate64("principled+metal+ms", params, wi, wo) / evaluate64("openpbr+metal", params, wi, wo)
        assert np.all(ratio >= 1.0 - 1e-12)
        gains.append(np.median(ratio))
    assert gains[0] < gains[1] < gains[2] and gains[2] > 1.1, gains
    f, g = (evaluate64("principled+metal+ms", {**METAL, "roughness": 0.9}, a, b) for a, b in ((wi, wo), (wo, wi)))
    assert np.abs(f / g - 1.0).max() > 1e-3


def test_the_export_writes_multiscatter_ggx():
    def entry(spec, params):
        return material_entry(FitResult(spec=spec, parameters=params, errors={"m1": 0.001, "image": 0.01},
                                        optimizer={"max_theta": 80.0}, provenance={"material": "m"}))
    assert entry("principled+metal+ms", METAL)["distribution"] == "MULTI_GGX"
    assert entry("principled+nonmetal+ms", NONMETAL)["distribution"] == "MULTI_GGX"
    assert entry("principled+nonmetal", NONMETAL)["distribution"] == "GGX"


# --- Cycles ----------------------------------------------------------------------------------

needs_blender = pytest.mark.skipif(not engine_blender.blender_available(),
                                   reason="no Blender Python with bpy (make blender; $BRDF_BLENDER_PYTHON)")
DRAWN = {"metal": ("principled+metal+ms", METAL), "nonmetal": ("principled+nonmetal+ms", NONMETAL)}
SINGLE = {"principled+metal+ms": "openpbr+metal", "principled+nonmetal+ms": "principled+nonmetal"}
BOUNDS = (0.99, 1.01)      # as the single-scattering models (tests/test_principled.py)


@needs_blender
def test_cycles_draws_multiscatter_ggx(tmp_path):
    ratio = cycles_ratios(tmp_path, DRAWN)
    for name, (model, _) in DRAWN.items():
        ours, single = ratio(name, model), ratio(name, SINGLE[model])
        assert np.all((ours > BOUNDS[0]) & (ours < BOUNDS[1])), (name, ours)
        assert np.abs(ours - 1.0).max() < np.abs(single - 1.0).min(), (name, ours, single)
