"""MaterialX's own generated GLSL as a judge of the written OpenPBR documents (issue 61 item 3):
an ``openpbr+metal`` and an ``openpbr+nonmetal`` fit, written by ``export_materialx``, drawn by
shaders/materialx_render.py on the lit sphere of benchmarks/engine_three.py (``scene_pairs``,
``ELEVATIONS``; 32 x 32 pixels here), against the toolkit's JAX model of the same pixels
(engine_three's ``spec_images``: brdf.model.evaluate x cos theta_i).

Where they may differ, and by what (brdf/openpbr.py's docstring): MaterialX multiplies each
GGX lobe by ``mx_ggx_energy_compensation`` (Turquin 2019, eq. 14 and 16, as the genglsl has it):

    comp = 1 + F (1 - Ess) / Ess,   Ess = mx_ggx_dir_albedo(n.v, alpha, 1, 1) = A + B

with F the lobe's Fresnel at v.h, and the dielectric's throughput over the diffuse is
1 - E comp (E its directional albedo at F0 of the IOR); the toolkit leaves both out.  No
GenContext option turns it off in MaterialX 1.39.5 (GenOptions has none), so:

- ``compensated_images`` (benchmarks/engine_materialx.py) computes MaterialX's expected
  radiance from the toolkit's own terms in numpy: the specular lobe (the model at base_color 0 for the non-metal) times comp, the
  diffuse times (1 - E comp) / (1 - E); E and Ess from brdf.openpbr.ggx_dir_albedo
  (MaterialX's analytic fit, GGX_ALBEDO_FIT), F from brdf.openpbr.fresnel_f82 and
  brdf.fresnel.fresnel_dielectric.  MaterialX's render must match it at every lit pixel,
  at low and high roughness, to float32 precision (FLOAT32_REL below);
- at roughness 0.2 (alpha 0.04) comp is within comp_bound(0.2) (0.076, |1 / Ess - 1| at its
  largest over n.v; any F in [0, 1]) of 1, so the render must also match the uncompensated
  spec to within it at every lit pixel;
- at roughness 0.7 the metal is brighter than the spec by comp exactly: the ratio is
  checked against comp, and comp is checked to be far from 1 (the test can fail).

The non-metal is drawn with base_diffuse_roughness 0, where EON is Lambert in both (MaterialX's
EON differs from the paper's only above 0: brdf/openpbr.py).
"""

import pathlib
import sys

import numpy as np
import pytest

pytest.importorskip("MaterialX")    # the dev extra; not a run-time dependency

from shaders.gl import gl_available  # noqa: E402

ok, reason = gl_available()
pytestmark = pytest.mark.skipif(not ok, reason=f"no OpenGL: {reason}")

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "benchmarks"))

from engine_materialx import compensated_images  # noqa: E402
from engine_three import ELEVATIONS, light_direction, scene_pairs  # noqa: E402
from materialx_code import written_open_pbr_surface  # noqa: E402

SIZE = 32
METAL = {"base_color": [0.9, 0.6, 0.3], "specular_color": [0.8, 0.9, 1.0]}
NONMETAL = {"base_color": [0.6, 0.3, 0.1], "specular_ior": 1.5, "base_diffuse_roughness": 0.0}
LOW, HIGH = 0.2, 0.7
#: MaterialX's GLSL runs in float32 (2^-24 = 6e-8 relative per rounding), the JAX model in
#: float64; a few hundred roundings (GGX's D near its peak at alpha 0.04 is a difference of
#: nearly equal numbers) stay below 2e-5 (measured: 7.4e-6 at most, both models, both roughnesses)
FLOAT32_REL = 2e-5


def comp_bound(roughness):
    """The largest |comp - 1| that any Fresnel F in [0, 1] can give at ``roughness``:
    max over n.v in (0, 1] of |1 / Ess - 1| (Ess by MaterialX's analytic fit)."""
    import jax
    import jax.numpy as jnp

    from brdf.openpbr import ggx_dir_albedo
    with jax.enable_x64(True):
        ess = np.asarray(ggx_dir_albedo(jnp.linspace(1e-3, 1.0, 2001), roughness ** 2, 1.0))
    return float(np.abs(1.0 / ess - 1.0).max())


def _scene():
    _, normals, wi, wo, cos_i = scene_pairs(SIZE, ELEVATIONS)
    return normals, wi, wo, cos_i, np.array([light_direction(e) for e in ELEVATIONS])


def _materialx(spec, params, tmp_path):
    from shaders.materialx_render import materialx_radiance
    path = tmp_path / "material.mtlx"
    _, info = written_open_pbr_surface(spec, params, "judged", path)
    (name,) = [m for m, category in info["materials"].items() if category == "open_pbr_surface"]
    normals, _, _, cos_i, lights = _scene()
    return materialx_radiance(path, name, normals, lights), cos_i > 0.0


def compensated(spec, params):
    """(MaterialX's expected radiance (L, P, 3), comp (L, P, 3), the toolkit's spec image)."""
    _, wi, wo, cos_i, _ = _scene()
    return compensated_images(spec, params, wi, wo, cos_i)


def _relative(got, want, lit):
    return np.abs(got[lit] - want[lit]) / np.abs(want[lit])


@pytest.mark.parametrize("spec,params", [("openpbr+metal", METAL), ("openpbr+nonmetal", NONMETAL)])
@pytest.mark.parametrize("roughness", [LOW, HIGH])
def test_materialx_draws_the_model_with_its_energy_compensation(tmp_path, spec, params, roughness):
    params = {**params, "roughness": roughness}
    got, lit = _materialx(spec, params, tmp_path)
    want, _, _ = compensated(spec, params)
    assert got.shape == want.shape and np.all(np.isfinite(got))
    assert want[lit].min() > 0.0 and lit.sum() > 0.3 * SIZE * SIZE
    assert _relative(got, want, lit).max() <= FLOAT32_REL


@pytest.mark.parametrize("spec,params", [("openpbr+metal", METAL), ("openpbr+nonmetal", NONMETAL)])
def test_at_low_roughness_materialx_draws_the_spec(tmp_path, spec, params):
    """At alpha 0.04, |comp - 1| <= comp_bound(0.2) = 0.076 (at grazing n.v; 0.016 above
    n.v 0.3): the plain spec is within that of MaterialX's render at every lit pixel."""
    params = {**params, "roughness": LOW}
    got, lit = _materialx(spec, params, tmp_path)
    _, comp, plain = compensated(spec, params)
    bound = comp_bound(LOW)
    assert bound < 0.08
    assert np.abs(comp[lit] - 1.0).max() <= bound
    assert _relative(got, plain, lit).max() <= bound + FLOAT32_REL


def test_at_high_roughness_the_metal_is_brighter_by_the_compensation(tmp_path):
    params = {**METAL, "roughness": HIGH}
    got, lit = _materialx("openpbr+metal", params, tmp_path)
    _, comp, plain = compensated("openpbr+metal", params)
    ratio = got[lit] / plain[lit]
    assert np.abs(ratio / comp[lit] - 1.0).max() <= FLOAT32_REL
    # comp - 1 = F (1 / Ess - 1): at alpha 0.49, 1 / Ess - 1 >= 0.087 on n.v in [0.05, 1]
    # (0.1 is the rim's smallest n.v at 32 pixels) and F >= 0.3 (the blue F0, untinted):
    # comp >= 1.026 everywhere, far from 1, so the ratio check above can fail
    assert comp[lit].min() > 1.02


def test_a_missing_material_is_named(tmp_path):
    from shaders.materialx_render import MaterialXRenderError, materialx_radiance
    path = tmp_path / "m.mtlx"
    written_open_pbr_surface("openpbr+metal", {**METAL, "roughness": LOW}, "judged", path)
    with pytest.raises(MaterialXRenderError, match="no material 'M_nothing'"):
        materialx_radiance(path, "M_nothing", [[0.0, 0.0, 1.0]], [[0.0, 0.0, 1.0]])
