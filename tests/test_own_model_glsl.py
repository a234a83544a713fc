"""A model of one's own drawn by the preview renderer through its ``glsl=`` (brdf/own.py,
shaders/own_glsl.py, examples/own_model.py, docs/models.md "A model of your own").

Every asserted number's source: the example's GLSL twin is held to its JAX function
(brdf.model.evaluate, float32, eager, as tests/test_shaders_parity.py does) under that
file's parity criterion (shaders.parity: relative 1e-4 where |JAX| > 1e-4, absolute 1e-6
elsewhere).  The sphere of the fitted example is held, pixel by pixel under the same
criterion, to the sphere of the toolkit's own ``blinn_phong+lambert`` (brdf/lobes.py and
lobes.glsl, code of its own) at the same BRDF: exponent n = 2 / alpha^2 - 2 of its
roughness (Walter et al. 2007 eq. 33, as tests/test_own_model.py's comparison of the two
JAX functions), so alpha = sqrt(2 / (n + 2)) and roughness = sqrt(alpha).  Both spheres
see the same lights, environment, sample pattern and importance-sampling hint: only the
BRDFs differ.
"""

import pathlib

import numpy as np
import pytest

from shaders.gl import gl_available

ok, reason = gl_available()
pytestmark = pytest.mark.skipif(not ok, reason=f"no OpenGL 4.3 context: {reason}")

from brdf import own  # noqa: E402
from brdf.model import parse_model  # noqa: E402
from brdf_fit.cli import main  # noqa: E402
from fitting.fit import fit  # noqa: E402
from fitting.synthetic import synthetic_measured  # noqa: E402
from shaders import library, parity, render  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "own_model.py"
NAME = "BLINN_PHONG_LAMBERT"
TRUTH = {"diffuse_albedo": [0.3, 0.2, 0.1], "specular": [0.1, 0.12, 0.15], "exponent": 300.0}
N = 10_000
SIZE = 96               # sphere images, pixels a side
COVERED = 0.3           # the framed sphere covers more than this of the image (it covers ~70 %)


def _assert_parity(result, label):
    assert result["nonfinite"] == 0, f"{label}: non-finite values {result}"
    assert result["n_big"] > 0.5 * result["n"], f"{label}: too few values above parity.BIG to compare {result}"
    assert result["max_rel"] < parity.REL_TOL and result["max_abs"] < parity.ABS_TOL, (
        f"{label}: max rel {result['max_rel']:.3e} (limit {parity.REL_TOL}), "
        f"max abs {result['max_abs']:.3e} (limit {parity.ABS_TOL}), {result}")


@pytest.fixture(scope="module")
def example():
    return own.load_file(EXAMPLE, NAME)


def test_example_glsl_is_its_jax_function(example):
    """Random pairs (grazing, near-mirror, near-retro, 2 % below the horizon) and random
    parameters in the declared bounds (5 % at a bound; exponents up to 10 000), per pair."""
    _assert_parity(parity.model_parity(parse_model(example), N, seed=0), "own:blinn_phong_lambert")


def test_example_glsl_through_the_renderers_uniform_block(example):
    wi, wo = parity.random_pairs(N, 3, below=0.02)
    gl = parity.evaluate_model(example, TRUTH, wi, wo)
    shared = {k: np.broadcast_to(np.asarray(v, np.float32), (N,) + np.shape(v)) for k, v in TRUTH.items()}
    _assert_parity(parity.compare(gl, parity.jax_reference(example, shared, wi, wo)), "uniform block")


@pytest.fixture(scope="module")
def fitted(example):
    """The example fitted (from Python) to its own noiseless table at TRUTH."""
    measured = synthetic_measured(example, TRUTH, grid=(12, 12, 24, 1))
    return fit(measured, example, samples=2000)


def _builtin_twin(params):
    """blinn_phong+lambert's parameters for the example's (the module docstring)."""
    alpha = np.sqrt(2.0 / (float(params["exponent"]) + 2.0))
    return {"albedo": params["diffuse_albedo"], "roughness": float(np.sqrt(alpha)),
            "specular_albedo": params["specular"]}, float(alpha)


def _assert_same_sphere(mine, theirs):
    covered = mine[..., 3] > 0.5
    assert covered.mean() > COVERED and np.array_equal(covered, theirs[..., 3] > 0.5)
    assert np.all(np.isfinite(mine)) and np.all(mine[covered][:, :3] > 0.0)     # lit everywhere: not blank
    _assert_parity(parity.compare(mine[covered][:, :3], theirs[covered][:, :3]), "sphere")


def test_fitted_sphere_is_the_builtin_blinn_phong_lambert(fitted):
    """The preview of the fitted own model (render_material: its split sum falls back to
    sampled image lighting, as a measured table's) against the built-in model's sampled one."""
    assert fitted.model.own.glsl is not None
    theirs, alpha = _builtin_twin(fitted.parameters)
    mine = render.render_material(fitted.model, fitted.parameters, SIZE, linear=True, alpha_hint=alpha)
    ref = render.render_material("blinn_phong+lambert", theirs, SIZE, linear=True, ibl="sampled", alpha_hint=alpha)
    _assert_same_sphere(mine, ref)


def test_sphere_under_lights_only_is_the_builtins(example):
    """Point and directional lights evaluate the BRDF exactly (no image lighting): TRUTH's sphere."""
    from shaders.environment import DirectionalLight, PointLight
    lights = [PointLight((2.0, 3.0, 4.0), (30.0, 30.0, 30.0)), DirectionalLight((-1.0, 1.0, 2.0), (2.0, 2.0, 2.0))]
    theirs, _ = _builtin_twin(TRUTH)
    common = dict(env=None, lights=lights, ibl="none", msaa=0)
    mine = render.render_hdr(render.Material(example, TRUTH), SIZE, **common)
    ref = render.render_hdr(render.Material("blinn_phong+lambert", theirs), SIZE, **common)
    covered = mine[..., 3] > 0.5
    assert covered.mean() > COVERED and np.all(np.isfinite(mine))
    lit = covered & (ref[..., :3].max(axis=-1) > 0.0)
    assert lit.mean() > 0.5 * covered.mean()           # most of the sphere faces a light: compared there
    _assert_parity(parity.compare(mine[lit][:, :3], ref[lit][:, :3]), "lights")
    assert np.all(mine[covered & ~lit][:, :3] == 0.0)


BROKEN = '''
import jax.numpy as jnp
from brdf.own import OwnModel, Param

P = (Param("rho", 3, 0.0, 1.0, 0.5, "albedo"),)


def lambert(p, wi, wo):
    return jnp.broadcast_to(p["rho"] / jnp.pi, wi.shape)


NO_GLSL = OwnModel("no_glsl", P, lambert)
SYNTAX = OwnModel("syntax_error", P, lambert, glsl="""
vec3 own_brdf(BrdfParams p, vec3 wi, vec3 wo) {
    return p.rho / PI
}
""")
SIGNATURE = OwnModel("wrong_signature", P, lambert, glsl="vec3 own_brdf(vec3 wi, vec3 wo) { return vec3(INV_PI); }")
'''
RHO = {"rho": [0.5, 0.4, 0.3]}


@pytest.fixture(scope="module")
def broken(tmp_path_factory):
    """broken.py's models, each fitted (noiseless Lambert) and its result saved: {name: (model, path)}."""
    folder = tmp_path_factory.mktemp("broken")
    (folder / "broken.py").write_text(BROKEN)
    out = {}
    for name in ("NO_GLSL", "SYNTAX", "SIGNATURE"):
        model = own.load_file(folder / "broken.py", name)
        result = fit(synthetic_measured(model, RHO, grid=(12, 12, 24, 1)), model, samples=2000)
        out[name] = (model, result.save(folder / f"{model.name}.json"))
    return out


def _one_line(message, *parts):
    assert len(message.strip().splitlines()) == 1, message
    assert "Traceback" not in message and "GLSL Compiler failed" not in message, message
    for part in parts:
        assert part in message, (part, message)


def _cli_error(stderr):
    """The one error line of a command's stderr (a notice line may come before it)."""
    assert "Traceback" not in stderr, stderr
    errors = [line for line in stderr.splitlines() if line.startswith("brdf-fit render: error:")]
    assert len(errors) == 1, stderr
    return errors[0]


@pytest.mark.parametrize("name, parts", [
    ("SYNTAX", ("broken.py: syntax_error: its glsl does not compile", "line 4 of its glsl", "syntax error")),
    ("SIGNATURE", ("broken.py: wrong_signature: its glsl does not compile",
                   "must define vec3 own_brdf(BrdfParams p, vec3 wi, vec3 wo)")),
])
def test_glsl_that_does_not_compile_is_one_error_naming_model_and_file(broken, capsys, name, parts):
    model, path = broken[name]
    with pytest.raises(own.OwnModelError) as err:
        render.render_material(model, RHO, 32)
    _one_line(str(err.value), *parts)
    with pytest.raises(own.OwnModelError) as err:          # the parity harness (a compute shader)
        parity.evaluate_model(model, RHO, np.array([[0.0, 0.0, 1.0]]), np.array([[0.0, 0.0, 1.0]]))
    _one_line(str(err.value), *parts)
    capsys.readouterr()
    assert main(["render", str(path), "--model-file", str(path.parent / "broken.py"),
                 "--out", str(path.parent / "x.png")]) == 2
    _one_line(_cli_error(capsys.readouterr().err), *parts)


def test_without_glsl_it_is_refused_as_before(broken, capsys):
    from brdf_fit.report.pages import _renders
    model, path = broken["NO_GLSL"]
    message = "own:no_glsl is a model of your own: the preview renderer does not draw it"
    with pytest.raises(library.GLSLSourceError, match=message):
        render.render_material(model, RHO, 32)
    capsys.readouterr()
    assert main(["render", str(path), "--out", str(path.parent / "y.png")]) == 2
    assert message in _cli_error(capsys.readouterr().err) and not (path.parent / "y.png").exists()
    from fitting.result import FitResult
    rows = [(path, FitResult.load(path))]
    assert _renders("m", rows, object(), path.parent, "m") == ([], message)     # the report's note


def test_parameters_of_both_sizes_and_a_glsl_keyword():
    """BrdfParams of a float between two vec3s (std140 padding) and a parameter named as a GLSL
    keyword (``sample``, the member ``sample_``): the JAX function's values, per pair and shared."""
    import jax.numpy as jnp
    params = (own.Param("sample", 3, 0.0, 1.0, 0.5, "albedo"), own.Param("gain", 1, 0.0, 2.0, 1.0, "a scale"),
              own.Param("tint", 3, 0.5, 1.5, 1.0, "a tint"))
    model = own.OwnModel(
        "keyword_param", params,
        lambda p, wi, wo: p["sample"] * p["tint"] * (p["gain"] / jnp.pi) * wi[..., 2:3] * wo[..., 2:3],
        glsl="vec3 own_brdf(BrdfParams p, vec3 wi, vec3 wo) "
             "{ return p.sample_ * p.tint * (p.gain / PI) * wi.z * wo.z; }")
    assert [(m.glsl_name, m.glsl_type) for m in library.param_layout(parse_model(model)).members] == [
        ("sample_", "vec3"), ("gain", "float"), ("tint", "vec3")]
    _assert_parity(parity.model_parity(parse_model(model), N, seed=4), "keyword_param")
    wi, wo = parity.random_pairs(N, 5, below=0.02)
    shared = {"sample": [0.2, 0.5, 0.9], "gain": 1.7, "tint": [1.2, 0.6, 1.0]}
    per_pair = {k: np.broadcast_to(np.asarray(v, np.float32), (N,) + np.shape(v)) for k, v in shared.items()}
    _assert_parity(parity.compare(parity.evaluate_model(model, shared, wi, wo),
                                  parity.jax_reference(model, per_pair, wi, wo)), "keyword_param shared")


def test_declaration_without_own_brdf_is_refused():
    lambert = own.OwnModel("lambert_ok", (own.Param("rho", 3, 0.0, 1.0, 0.5, "albedo"),),
                           lambda p, wi, wo: p["rho"] / np.pi + 0.0 * wi)
    for glsl in ("vec3 brdf(BrdfParams p, vec3 wi, vec3 wo) { return p.rho; }", 42):
        with pytest.raises(own.OwnModelError, match="glsl must be GLSL source defining vec3 own_brdf"):
            own.OwnModel("no_function", lambert.params, lambert.evaluate, glsl=glsl)
    glsl = "vec3 own_brdf(BrdfParams p, vec3 wi, vec3 wo) { return vec3(INV_PI); }"
    for name in ("my-param", "gl_rho", "a__b", "_rho"):
        param = own.Param(name, 3, 0.0, 1.0, 0.5, "albedo")
        own.OwnModel("no_glsl_any_name", (param,), lambert.evaluate)        # JAX takes any name
        with pytest.raises(own.OwnModelError, match=f"parameter '{name}' cannot be a member of its GLSL struct"):
            own.OwnModel("glsl_names", (param,), lambert.evaluate, glsl=glsl)


def test_view_draws_it(example):
    """`brdf-fit view`'s picture of the fitted model (shaders.viewer.frame, fitted mode)."""
    from shaders import viewer
    picture = viewer.frame(viewer.ViewState(has_measured=False), render.Material(example, TRUTH), size=64)
    assert picture.shape == (64, 64, 3) and picture.std() > 0


#: Run on Mesa's own 3.3 core context (as tests/test_shaders_gl33.py makes it): the example's
#: sphere and its built-in twin's, saved for the test to compare.
GL33 = '''
import json, sys
import numpy as np
from brdf import own
from shaders import gl, render
model = own.load_file(sys.argv[1], "BLINN_PHONG_LAMBERT")
truth, twin, alpha, out = json.loads(sys.argv[2]), json.loads(sys.argv[3]), float(sys.argv[4]), sys.argv[5]
mine = render.render_material(model, truth, 64, linear=True, alpha_hint=alpha, samples=8)
ref = render.render_material("blinn_phong+lambert", twin, 64, linear=True, ibl="sampled", alpha_hint=alpha,
                             samples=8)
np.savez(out, mine=mine, ref=ref, glsl_version=gl.glsl_version())
'''


def test_example_glsl_compiles_as_glsl_330(tmp_path):
    """The contract's other version: the renderer's fallback context (OpenGL 3.3, #version 330)."""
    import json
    import os
    import subprocess
    import sys
    from shaders.gl import VERSION_ENV
    force_33 = {"MESA_GL_VERSION_OVERRIDE": "3.3", "MESA_GLSL_VERSION_OVERRIDE": "330", VERSION_ENV: "330"}
    theirs, alpha = _builtin_twin(TRUTH)
    out = tmp_path / "gl33.npz"
    run = subprocess.run([sys.executable, "-c", GL33, str(EXAMPLE), json.dumps(TRUTH), json.dumps(theirs),
                          str(alpha), str(out)], env=dict(os.environ, **force_33), capture_output=True,
                         text=True, timeout=600, cwd=ROOT)
    assert run.returncode == 0, run.stderr[-3000:]
    with np.load(out) as data:
        assert int(data["glsl_version"]) == 330
        _assert_same_sphere(data["mine"], data["ref"])
