"""The GLSL library's plumbing: shared constants, includes, #defines, std140 layout."""

import re

import numpy as np
import pytest

import brdf.constants
import brdf.diffuse
from brdf import MODEL_EXAMPLES, parse_model
from shaders import library
from shaders.gl import gl_available

ok, reason = gl_available()
needs_gl = pytest.mark.skipif(not ok, reason=f"no OpenGL 4.3 context: {reason}")

_CONST = re.compile(r"^\s*const\s+(float|int)\s+([A-Z][A-Z0-9_]*)\s*=\s*([^;]+);", re.M)


def _glsl_constants():
    out = {}
    for path in sorted(library.SHADER_DIR.glob("*.glsl")):
        for _kind, name, value in _CONST.findall(path.read_text()):
            assert name not in out, f"{name} defined twice ({path.name})"
            out[name] = (path.name, float(eval(value, {"PI": np.pi})))  # literals only
    return out


def _python_constants(module):
    return {k: float(v) for k, v in vars(module).items()
            if k.isupper() and isinstance(v, (int, float)) and not isinstance(v, bool)}


def test_common_glsl_has_every_constant_of_brdf_constants():
    glsl = _glsl_constants()
    for name, value in _python_constants(brdf.constants).items():
        assert name in glsl, f"{name} of brdf/constants.py is missing from common.glsl"
        file, glsl_value = glsl[name]
        assert file == "common.glsl", f"{name} belongs in common.glsl, found in {file}"
        assert np.float32(glsl_value) == np.float32(value), (name, glsl_value, value)


def test_module_constants_shared_with_glsl_agree():
    glsl = _glsl_constants()
    shared = 0
    for module in (brdf.diffuse,):
        for name, value in _python_constants(module).items():
            if name in glsl:
                shared += 1
                assert np.float32(glsl[name][1]) == np.float32(value), name
    assert shared >= 2  # FROSTBITE_ENERGY_FACTOR_ROUGH, COD_GLOSS_BITS


def test_includes_are_resolved_once_and_mapped_to_files():
    source, line_map = library.resolve_includes('#include "model.glsl"\n#include "specular.glsl"\nvoid f() {}')
    assert "#include" not in source
    assert source.count("float ggx_ndf(") == 1
    assert source.count("const float ALPHA_MIN") == 1
    assert len(line_map) == source.count("\n") + 1
    i = source.splitlines().index(next(l for l in source.splitlines() if l.startswith("float ggx_ndf(")))
    assert line_map[i][0] == "specular.glsl"
    assert line_map[-1] == ("<source>", 3)


def test_missing_include_is_a_clear_error():
    with pytest.raises(library.GLSLSourceError, match="nope.glsl"):
        library.resolve_includes('#include "nope.glsl"')


def test_defines_follow_the_spec():
    d = library.defines_for("ggx_aniso+cod_wwii+ms+clearcoat")
    for key in ("BRDF_NDF_GGX_ANISO", "BRDF_DIFFUSE_COD_WWII", "BRDF_ENERGY_KULLA_CONTY",
                "BRDF_CLEARCOAT", "BRDF_MASKING_HEIGHT_CORRELATED", "BRDF_FRESNEL_SCHLICK",
                "BRDF_COMPOSITION_ADDITIVE", "BRDF_ANISOTROPIC", "BRDF_PARAM_ALBEDO",
                "BRDF_PARAM_CLEARCOAT_ROUGHNESS", "BRDF_PARAM_ROTATION"):
        assert key in d, key
    assert "BRDF_CLEARCOAT" not in library.defines_for("ggx+lambert")
    g = library.defines_for("gltf+ior+specular")
    assert {"BRDF_COMPOSITION_GLTF", "BRDF_GLTF_EXTENSIONS_IOR", "BRDF_GLTF_EXTENSIONS_SPECULAR",
            "BRDF_PARAM_SPECULAR_COLOR"} <= set(g)


def test_std140_layout_by_hand():
    # ggx+lambert: albedo vec3 @0, roughness float @12 (fills the vec3's slot), f0 vec3 @16
    layout = library.param_layout("ggx+lambert")
    assert [(m.name, m.glsl_type, m.offset) for m in layout.members] == [
        ("albedo", "vec3", 0), ("roughness", "float", 12), ("f0", "vec3", 16)]
    assert layout.size == 32
    # gltf+specular: base_color @0, metallic @12, roughness @16, ior? no; specular @20, specular_color @32
    layout = library.param_layout("gltf+specular")
    assert [(m.name, m.offset) for m in layout.members] == [
        ("base_color", 0), ("metallic", 12), ("roughness", 16), ("specular", 20), ("specular_color", 32)]
    assert layout.size == 48


@pytest.mark.parametrize("model", MODEL_EXAMPLES)
def test_pack_unpack_round_trip(model):
    spec = parse_model(model)
    params = {p.name: (np.arange(p.size) + 1.0) * (i + 1) / 7.0 if p.size == 3 else (i + 1) / 7.0
              for i, p in enumerate(spec.schema())}
    data = library.pack_params(spec, params)
    assert len(data) == library.param_layout(spec).size
    back = library.unpack_params(spec, data)
    for name, value in params.items():
        np.testing.assert_allclose(back[name], value, rtol=1e-7)


def test_pack_rejects_bad_parameters():
    with pytest.raises(ValueError, match="missing.*'f0'"):
        library.pack_params("ggx+lambert", {"albedo": 0.5, "roughness": 0.3})
    with pytest.raises(ValueError, match="unexpected.*'bogus'"):
        library.pack_params("ggx+lambert", {"albedo": 0.5, "roughness": 0.3, "f0": 0.04, "bogus": 1})
    with pytest.raises(ValueError, match="albedo"):
        library.pack_params("ggx+lambert", {"albedo": [0.5, 0.4], "roughness": 0.3, "f0": 0.04})
    with pytest.raises(ValueError, match="not finite"):
        library.pack_params("ggx+lambert", {"albedo": 0.5, "roughness": np.nan, "f0": 0.04})


@needs_gl
@pytest.mark.parametrize("model", MODEL_EXAMPLES)
def test_driver_reads_the_generated_layout(model):
    """Every member read back on the GPU from the uniform block and from an
    std140 buffer array: the Python packing and the GLSL struct agree."""
    from shaders import parity
    spec = parse_model(model)
    layout = library.param_layout(spec)
    params = {p.name: (np.arange(3) + 10.0 * (i + 1)) if p.size == 3 else 10.0 * (i + 1) + 0.5
              for i, p in enumerate(spec.schema())}
    for m in layout.members:
        comp = 3 if m.size == 3 else 1
        shared = _read_member(spec, params, m.glsl_name, comp)
        np.testing.assert_array_equal(shared, np.broadcast_to(params[m.name], shared.shape))
    # per-item array: item j gets value + j
    n = 5
    batch = {k: np.asarray(v, float) + np.arange(n).reshape((n,) + (1,) * np.ndim(v)) for k, v in params.items()}
    source, line_map = parity._kernel(
        "vec4(" + ", ".join(f"harness_params[harness_i].{m.glsl_name}" + (".x" if m.size == 3 else "")
                             for m in layout.members[:4]) + (", 0.0" * (4 - min(4, len(layout.members)))) + ")",
        {"x": np.zeros((n, 1), np.float32)}, ("model.glsl",), spec=spec,
        prelude="layout(std140, binding = 2) readonly buffer HarnessParams { BrdfParams harness_params[]; };")
    out = parity._run(source, line_map, n, np.zeros((n, 1), np.float32),
                      params_bytes=library.pack_params_array(spec, batch, n))
    for k, m in enumerate(layout.members[:4]):
        expect = batch[m.name][:, 0] if m.size == 3 else batch[m.name]
        np.testing.assert_array_equal(out[:, k], expect.astype(np.float32))


def _read_member(spec, params, glsl_name, comp):
    from shaders import parity
    source, line_map = parity._kernel(f"material.{glsl_name}", {"x": np.zeros((1, 1), np.float32)},
                                      ("model.glsl",), spec=spec,
                                      prelude=library.uniform_block_source(spec))
    out = parity._run(source, line_map, 1, np.zeros((1, 1), np.float32),
                      block_bytes=library.pack_params(spec, params))
    return out[0, :comp]


def test_measured_glsl_grid_constants_match_python():
    from shaders import measured
    glsl = {name: value for name, (_, value) in _glsl_constants().items()}
    assert (glsl["MERL_THETA_H"], glsl["MERL_THETA_D"], glsl["MERL_PHI_D"]) == measured.MERL_SHAPE
    assert (glsl["UTIA_THETA"], glsl["UTIA_PHI"]) == measured.UTIA_SHAPE[1:3]


@needs_gl
def test_compile_errors_point_at_glsl_files():
    from shaders.gl import ShaderCompileError
    from shaders import parity
    with pytest.raises(ShaderCompileError, match=r"<parity kernel>:\d+"):
        parity.evaluate_glsl("ggx_ndf(nh)", nh=np.zeros(4, np.float32))
