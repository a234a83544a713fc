"""Where each option of a ModelSpec lives in the GLSL library.

Every value of a ModelSpec field (the lists of brdf.model: DIFFUSES,
FRESNELS, ENERGIES, ...) is one ``#if defined(BRDF_<FIELD>_<VALUE>)`` block in
its term's file, which defines the function of a fixed signature that
model.glsl's brdf_evaluate and ibl.glsl's ibl_material call.  So a new diffuse
model needs its JAX function in brdf/ and one block in diffuse.glsl, nothing
in model.glsl, ibl.glsl or shaders/library.py; these tests hold the files to it.
"""

import dataclasses
import re

import numpy as np
import pytest

from brdf import MODEL_EXAMPLES, model
from shaders import library
from shaders.gl import gl_available

ok, reason = gl_available()
needs_gl = pytest.mark.skipif(not ok, reason=f"no OpenGL 4.3 context: {reason}")

#: field -> (its values, the files holding one block per value, other files that may test
#: its symbols).  The glTF composition is gltf.glsl's, the OpenPBR ones openpbr.glsl's, the
#: Principled BSDF's principled.glsl's; fresnel.glsl and diffuse.glsl step aside for them (they
#: fix those terms), through common.glsl's classes of them (FIXED_CLASSES).
FIELDS = {
    "ndf": (model.NDFS, ("specular.glsl",), ()),
    "masking": (model.MASKINGS, ("specular.glsl",), ()),
    "anisotropy": (model.ANISOTROPY_REMAPS, ("specular.glsl",), ()),
    "fresnel": (model.FRESNELS, ("fresnel.glsl",), ()),
    "diffuse": (model.DIFFUSES, ("diffuse.glsl",), ()),
    "energy": (model.ENERGIES, ("energy.glsl",), ()),
    "clearcoat": ((None,), ("clearcoat.glsl",), ()),
    "gltf_extensions": (model.GLTF_EXTENSIONS, ("gltf.glsl",), ()),
    # (guests: the compositions that bring their own Fresnel, diffuse or, OpenPBR's coat, the
    # coat's image-lighting pair clearcoat.glsl otherwise defines)
    "composition": (model.COMPOSITIONS, ("model.glsl", "gltf.glsl", "openpbr.glsl", "principled.glsl"),
                    ("common.glsl", "fresnel.glsl", "diffuse.glsl")),
}
#: common.glsl's classes of the compositions that fix their terms (defined from BRDF_COMPOSITION_*)
FIXED_CLASSES = ("BRDF_FIXED_NONMETAL", "BRDF_FIXED_COAT", "BRDF_FIXED_LOBES")

#: Symbols that select nothing: the generated struct's marker, the schema's entries, a model
#: of one's own (its glsl= is its brdf_evaluate: shaders/own_glsl.py).
NOT_OPTIONS = re.compile(r"BRDF_PARAMS_DECLARED$|BRDF_PARAM_\w+$|BRDF_ANISOTROPIC$|BRDF_LOBE_MODEL$|BRDF_OWN_MODEL$"
                         r"|BRDF_FIXED_\w+$")

_COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/|\"[^\"\n]*\"", re.S)
_SYMBOL = re.compile(r"\bBRDF_[A-Z0-9_]+\b")


def _code(name):
    """A .glsl file without its comments and strings (#error messages)."""
    return _COMMENT.sub("", library.read_glsl(name))


def _glsl_files():
    return sorted(p.name for p in library.SHADER_DIR.glob("*.glsl"))


def _symbols():
    """{symbol: field} for every value of every field."""
    return {library.option_define(field, value): field
            for field, (values, _, _) in FIELDS.items() for value in values}


def _has_block(code, symbol):
    return re.search(rf"^\s*#\s*(ifdef\s+{symbol}\b|(el)?if\b.*\bdefined\(\s*{symbol}\s*\))", code, re.M)


def test_every_field_of_modelspec_has_its_terms_file():
    # ``own`` holds a model of one's own (brdf/own.py): declared in the user's file, no GLSL terms file
    assert {f.name for f in dataclasses.fields(model.ModelSpec)} - {"own"} == set(FIELDS)


@pytest.mark.parametrize("field", list(FIELDS))
def test_every_value_has_its_block_in_its_terms_file(field):
    values, homes, _ = FIELDS[field]
    for value in values:
        symbol = library.option_define(field, value)
        assert any(_has_block(_code(f), symbol) for f in homes), f"no #if block for {symbol} in {homes}"


def test_option_symbols_appear_only_in_their_terms_files():
    symbols = _symbols()
    wrong = []
    for name in _glsl_files():
        for symbol in set(_SYMBOL.findall(_code(name))):
            if NOT_OPTIONS.match(symbol):
                continue
            if symbol not in symbols:
                wrong.append(f"{name}: {symbol} selects no value of any ModelSpec field")
                continue
            _, homes, guests = FIELDS[symbols[symbol]]
            if name not in homes + guests:
                wrong.append(f"{name}: {symbol} belongs in {homes}")
    assert not wrong, wrong


def test_model_and_ibl_name_no_term_option():
    """model.glsl names only compositions (and BRDF_LOBE_MODEL, the kind of model whose
    NDF is the whole specular term, which shaders.library derives from the spec, and
    BRDF_OWN_MODEL, a model of one's own), ibl.glsl nothing: no BRDF_DIFFUSE_,
    BRDF_FRESNEL_, BRDF_ENERGY_, ... and no magic integers standing for them."""
    model_symbols = set(_SYMBOL.findall(_code("model.glsl"))) - {"BRDF_PARAMS_DECLARED", "BRDF_LOBE_MODEL",
                                                                  "BRDF_OWN_MODEL", *FIXED_CLASSES}
    assert model_symbols and all(s.startswith("BRDF_COMPOSITION_") for s in model_symbols), model_symbols
    assert set(_SYMBOL.findall(_code("ibl.glsl"))) == {"BRDF_PARAMS_DECLARED"}
    assert not re.search(r"\.(energy|coupled)\b|==\s*\d", _code("ibl.glsl"))


def test_the_fixed_classes_name_every_composition_that_fixes_its_terms():
    """common.glsl's BRDF_FIXED_NONMETAL, _COAT and _LOBES hold exactly the compositions of
    brdf.principled.FIXED_COMPOSITIONS (OpenPBR's and the Principled BSDF's) with a dielectric
    base (specular_ior), a coat (coat_weight), and all of them: a new one missing from a list
    would be drawn with another composition's Fresnel or diffuse."""
    from brdf.principled import FIXED_COMPOSITIONS
    blocks = re.findall(r"^\s*#\s*if\b(.*?)^\s*#\s*define\s+(BRDF_FIXED_\w+)", _code("common.glsl"), re.M | re.S)
    classes = {}
    for condition, name in blocks:
        symbols = set(_SYMBOL.findall(condition))
        classes[name] = {s for s in symbols if s.startswith("BRDF_COMPOSITION_")}.union(
            *(classes[s] for s in symbols if s in classes))
    assert set(classes) == set(FIXED_CLASSES), classes

    def having(param):
        return {library.option_define("composition", name) for name, c in FIXED_COMPOSITIONS.items()
                if param is None or any(p.name == param for p in c.params)}
    assert classes["BRDF_FIXED_NONMETAL"] == having("specular_ior")
    assert classes["BRDF_FIXED_COAT"] == having("coat_weight")
    assert classes["BRDF_FIXED_LOBES"] == having(None)


def _max_depth(code):
    depth = deepest = 0
    for directive in re.findall(r"^\s*#\s*(if|ifdef|ifndef|endif)\b", code, re.M):
        depth += -1 if directive == "endif" else 1
        deepest = max(deepest, depth)
    assert depth == 0
    return deepest


def test_dispatch_is_flat():
    """model.glsl and a term's file: at most a section guard and one chain (model.glsl's
    guard keeps a built-in model's composition from a model of one's own)."""
    assert _max_depth(_code("model.glsl")) <= 2
    assert _max_depth(_code("ibl.glsl")) == 1
    for name in ("specular.glsl", "fresnel.glsl", "diffuse.glsl", "energy.glsl", "clearcoat.glsl", "gltf.glsl",
                 "openpbr.glsl", "principled.glsl"):
        assert _max_depth(_code(name)) <= 2, name


def _compile_model(spec, expression="brdf_evaluate(material, wi, wo)", includes=("model.glsl",), edit=None):
    from shaders import gl, parity
    x = np.zeros((1, 3), np.float32)
    source, line_map = parity._kernel(expression, {"wi": x, "wo": x}, includes, spec=spec,
                                      prelude=library.uniform_block_source(spec))
    if edit is not None:
        source = source.replace(*edit)
    return gl.compute_program(source, line_map)


@needs_gl
@pytest.mark.parametrize("field, spec, file", [
    ("ndf", "ggx+lambert", "specular.glsl"), ("masking", "ggx+lambert", "specular.glsl"),
    ("anisotropy", "ggx+lambert", "specular.glsl"), ("fresnel", "ggx+lambert", "fresnel.glsl"),
    ("diffuse", "ggx+lambert", "diffuse.glsl"), ("energy", "ggx+lambert", "energy.glsl"),
    ("composition", "ggx+lambert", "model.glsl")])
def test_a_value_without_its_block_is_a_compile_error(field, spec, file):
    from shaders.gl import ShaderCompileError
    value = getattr(model.parse_model(spec), field)
    edit = (f"#define {library.option_define(field, value)} 1", f"#define {library.option_define(field, 'new')} 1")
    _compile_model(spec)
    with pytest.raises(ShaderCompileError, match=rf"{re.escape(file)}:\d+.*has no block"):
        _compile_model(spec, edit=edit)


@needs_gl
@pytest.mark.parametrize("spec", MODEL_EXAMPLES)
def test_split_sum_material_compiles_for_every_example(spec):
    """ibl_material / ibl_split_sum of every example (the renderer's split-sum path)."""
    _compile_model(spec, "ibl_split_sum(ibl_material(material), vec3(0.0, 0.0, 1.0), wo)",
                   includes=("model.glsl", "ibl.glsl"))
    _compile_model(spec, "ibl_split_sum(ibl_material(material), vec3(0.0, 0.0, 1.0), wo)",
                   includes=("ibl.glsl",))
