"""The GLSL library: include resolution, ModelSpec #defines and the parameter block.

- ``#include "x.glsl"`` lines are resolved here, in Python (no external
  preprocessor); each file is included once, wherever it is asked for first.
- ``defines_for(spec)`` turns a ModelSpec into #defines (``BRDF_<FIELD>_<VALUE>``
  for every field, ``BRDF_PARAM_<NAME>`` for every schema entry).
- ``struct BrdfParams`` and its std140 layout are generated from
  ``spec.schema()``: size-1 parameters are ``float`` (4-byte aligned), size-3
  parameters ``vec3`` (16-byte aligned, 12 bytes, a float may follow in the
  last 4).  ``pack_params`` writes the bytes for that layout, so the layout is
  written down exactly once.
- shaders/tables.py uploads brdf.energy.tables() for ``energy.glsl``,
  brdf.sheen.sheen_table() for ``sheen.glsl`` and brdf.cycles' tables for
  ``principled.glsl`` (``bind_tables``: those a program reads).
- A model of one's own (brdf/own.py) with ``glsl=`` goes through the same
  functions: ``BRDF_OWN_MODEL``, its BrdfParams from its Params, its source
  appended by ``build_source`` (shaders/own_glsl.py says how).
"""

import dataclasses
import functools
import pathlib
import re

import numpy as np

from brdf.model import ModelSpec, parameter_schema, parse_model

from . import own_glsl

SHADER_DIR = pathlib.Path(__file__).resolve().parent
GLSL_VERSION = 430

#: The group files, in dependency order (``model.glsl`` includes them all).
LIBRARY_FILES = ("common.glsl", "geometry.glsl", "specular.glsl", "beckmann.glsl", "lobes.glsl", "fresnel.glsl",
                 "diffuse.glsl", "energy.glsl", "clearcoat.glsl", "sheen.glsl", "gltf.glsl", "openpbr.glsl",
                 "principled.glsl", "model.glsl", "measured.glsl", "sampling.glsl", "ibl.glsl", "lights.glsl")

_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$')

# GLSL keywords (reserved or built-in type names) a parameter name must avoid.
_GLSL_RESERVED = frozenset("""
attribute const uniform varying buffer shared coherent volatile restrict readonly
writeonly atomic_uint layout centroid flat smooth noperspective patch sample break
continue do for while switch case default if else subroutine in out inout float
double int void bool true false invariant precise discard return mat2 mat3 mat4
vec2 vec3 vec4 ivec2 ivec3 ivec4 bvec2 bvec3 bvec4 uint uvec2 uvec3 uvec4 lowp
mediump highp precision struct common partition active asm class union enum
typedef template this resource goto inline noinline public static extern external
interface long short half fixed unsigned superp input output filter sizeof cast
namespace using sampler2D texture
""".split())


class GLSLSourceError(ValueError):
    """A missing or circular #include."""


# --- include mechanism ---------------------------------------------------------

def read_glsl(name, search=(SHADER_DIR,)):
    """Text of a .glsl file found in ``search`` (the package folder by default)."""
    for folder in search:
        path = pathlib.Path(folder) / name
        if path.is_file():
            return path.read_text()
    raise GLSLSourceError(f"GLSL file {name!r} not found in {', '.join(map(str, search))}")


def resolve_includes(text, name="<source>", search=(SHADER_DIR,), _seen=None):
    """Expand ``#include "x.glsl"`` recursively, each file once.

    The expansion knows nothing of ``#ifdef``: a file first included inside a
    conditional block (ibl.glsl includes model.glsl only with a spec) is not
    expanded again by a later unconditional #include.

    Returns (source, line_map) where line_map[i] = (file name, line number) of
    output line i + 1, used to point compile errors at the .glsl files.
    """
    seen = set() if _seen is None else _seen
    out, line_map = [], []
    for number, line in enumerate(text.splitlines(), 1):
        match = _INCLUDE.match(line)
        if not match:
            out.append(line)
            line_map.append((name, number))
            continue
        child = match.group(1)
        if child in seen:
            continue
        seen.add(child)
        child_text, child_map = resolve_includes(read_glsl(child, search), child, search, seen)
        out.append(child_text)
        line_map.extend(child_map)
    return "\n".join(out), line_map


# --- defines from a ModelSpec ----------------------------------------------------

def _token(value):
    return re.sub(r"[^A-Za-z0-9]+", "_", str(value)).upper()


def option_define(field, value=None):
    """The symbol that selects ``value`` of the ModelSpec field ``field``:
    ``BRDF_<FIELD>_<VALUE>`` (``option_define("diffuse", "cod_wwii")`` is
    ``BRDF_DIFFUSE_COD_WWII``), or ``BRDF_<FIELD>`` for a boolean field.

    Each term's .glsl file holds one ``#if defined(...)`` block per symbol of
    its field (tests/test_shaders_library.py checks them against the value
    lists of brdf.model), so a new value needs no change here.
    """
    key = "BRDF_" + _token(field)
    return key if value is None else f"{key}_{_token(value)}"


def defines_for(spec):
    """{name: value} of the preprocessor symbols that select the spec's terms.

    Generated from the dataclass fields, so a new option of ModelSpec gets its
    symbol without touching this function: string fields give
    ``BRDF_<FIELD>_<VALUE>``, booleans ``BRDF_<FIELD>`` when true, tuples one
    ``BRDF_<FIELD>_<ITEM>`` per item (see option_define); every schema entry
    gives ``BRDF_PARAM_<NAME>``.  A model of one's own has no fields but its
    function: ``BRDF_OWN_MODEL`` (shaders/own_glsl.py), or GLSLSourceError when
    it declares no ``glsl=``.
    """
    spec = parse_model(spec)
    params = {"BRDF_PARAM_" + _token(param.name): "1" for param in parameter_schema(spec)}
    if spec.own is not None:        # its fields are unused (brdf/spec.py)
        if spec.own.glsl is None:
            raise GLSLSourceError(f"{spec} is a model of your own: the preview renderer does not draw it")
        return {own_glsl.DEFINE: "1", **params}
    out = {}
    for field in dataclasses.fields(ModelSpec):
        value = getattr(spec, field.name)
        if value is None:               # own (None here): no symbol, not BRDF_OWN
            continue
        if isinstance(value, bool):
            if value:
                out[option_define(field.name)] = "1"
        elif isinstance(value, tuple):
            for item in value:
                out[option_define(field.name, item)] = "1"
        else:
            out[option_define(field.name, value)] = "1"
    if spec.anisotropic:
        out["BRDF_ANISOTROPIC"] = "1"
    if spec.lobe_model:                 # a classic lobe model (brdf/lobes.py): no Fresnel term
        out["BRDF_LOBE_MODEL"] = "1"
    out.update(params)
    return out


def define_lines(defines):
    return "\n".join(f"#define {k} {v}" for k, v in defines.items())


# --- the parameter struct and its std140 layout ----------------------------------

@dataclasses.dataclass(frozen=True)
class Member:
    """One member of the generated ``struct BrdfParams``."""
    name: str          # the schema name
    glsl_name: str     # the member name in GLSL (the schema name unless reserved)
    glsl_type: str     # float | vec3
    size: int          # 1 | 3 (floats)
    offset: int        # bytes, std140


@dataclasses.dataclass(frozen=True)
class ParamLayout:
    """The std140 layout of ``struct BrdfParams`` for one ModelSpec."""
    members: tuple
    size: int          # bytes, a multiple of 16 (std140 struct / array stride)

    def member(self, name):
        for m in self.members:
            if m.name == name:
                return m
        raise KeyError(name)


def _align(offset, alignment):
    return (offset + alignment - 1) // alignment * alignment


@functools.lru_cache(maxsize=None)
def _layout(spec):
    members, offset = [], 0
    for param in parameter_schema(spec):
        if param.size == 1:
            glsl_type, align, nbytes = "float", 4, 4
        elif param.size == 3:
            glsl_type, align, nbytes = "vec3", 16, 12
        else:  # pragma: no cover - the schema only has sizes 1 and 3
            raise ValueError(f"parameter {param.name}: unsupported size {param.size}")
        offset = _align(offset, align)
        glsl_name = param.name + "_" if param.name in _GLSL_RESERVED else param.name
        members.append(Member(param.name, glsl_name, glsl_type, param.size, offset))
        offset += nbytes
    return ParamLayout(tuple(members), _align(max(offset, 4), 16))


def param_layout(spec):
    """The std140 ParamLayout of ``struct BrdfParams`` generated from spec.schema()."""
    return _layout(parse_model(spec))


def struct_source(spec):
    """GLSL ``struct BrdfParams { ... };`` with explicit offsets in comments.

    ``BRDF_PARAMS_DECLARED`` marks the struct of a built-in model: the term files'
    blocks for its options key on it.  A model of one's own has no such blocks
    (its own_brdf takes the struct), so its struct comes without the symbol.
    """
    spec = parse_model(spec)
    layout = param_layout(spec)
    lines = ([] if spec.own is not None else ["#define BRDF_PARAMS_DECLARED 1"]) + [
             f"// Generated by shaders.library from the schema of {spec} "
             f"(std140, {layout.size} bytes).",
             "struct BrdfParams {"]
    for m in layout.members:
        lines.append(f"    {m.glsl_type} {m.glsl_name};  // offset {m.offset}")
    lines.append("};")
    return "\n".join(lines)


#: Binding point of the material uniform block in the renderer.
MATERIAL_BLOCK_BINDING = 0


#: Name of the material uniform block (renderers set its binding through the API on GLSL 3.30).
MATERIAL_BLOCK = "BrdfMaterial"


def uniform_block_source(spec, block=MATERIAL_BLOCK, instance="material",
                         binding=MATERIAL_BLOCK_BINDING):
    """``layout(std140) uniform`` block holding one BrdfParams (after struct_source).

    ``binding=None`` leaves the binding out of the layout (GLSL 3.30 has no
    ``binding =``; the program's block is then bound through the API).
    """
    layout = "std140" if binding is None else f"std140, binding = {binding}"
    return (f"layout({layout}) uniform {block} {{\n"
            f"    BrdfParams {instance};\n}};")


def _as_floats(spec, params, batch=None):
    """params -> {name: float64 array (batch?, size)} with checks and broadcasting."""
    schema = parameter_schema(spec)
    names = [p.name for p in schema]
    missing = [n for n in names if n not in params]
    extra = [n for n in params if n not in names]
    if missing or extra:
        raise ValueError(f"parameters for {spec}: missing {missing}, unexpected {extra}")
    out = {}
    for p in schema:
        value = np.asarray(params[p.name], dtype=np.float64)
        shape = (p.size,) if batch is None else (batch, p.size)
        try:
            if p.size == 1 and batch is not None and value.ndim >= 1 and value.shape[-1:] != (1,):
                value = value[..., None]
            out[p.name] = np.broadcast_to(value, shape)
        except ValueError:
            raise ValueError(f"parameter {p.name!r} of {spec}: shape {value.shape} does not fit "
                             f"{'a scalar' if p.size == 1 else '3 values (RGB) or a scalar'}"
                             + ("" if batch is None else f" per pair (batch {batch})")) from None
        if not np.all(np.isfinite(out[p.name])):
            raise ValueError(f"parameter {p.name!r} of {spec} is not finite")
    return out


def pack_params(spec, params):
    """bytes of one ``BrdfParams`` (std140) for a {name: value} dict.

    Size-3 parameters take 3 values or one (broadcast to RGB).
    """
    spec = parse_model(spec)
    layout = param_layout(spec)
    values = _as_floats(spec, params)
    buf = np.zeros(layout.size // 4, dtype=np.float32)
    for m in layout.members:
        buf[m.offset // 4: m.offset // 4 + m.size] = values[m.name]
    return buf.tobytes()


def pack_params_array(spec, params, count):
    """bytes of ``BrdfParams[count]`` (std140 array, stride = struct size).

    Each value may be shared (scalar / RGB) or given per element ((count,) or
    (count, 3)).
    """
    spec = parse_model(spec)
    layout = param_layout(spec)
    values = _as_floats(spec, params, batch=count)
    buf = np.zeros((count, layout.size // 4), dtype=np.float32)
    for m in layout.members:
        buf[:, m.offset // 4: m.offset // 4 + m.size] = values[m.name]
    return buf.tobytes()


def unpack_params(spec, data):
    """Inverse of pack_params (for tests and debugging): bytes -> {name: array}."""
    layout = param_layout(spec)
    buf = np.frombuffer(data, dtype=np.float32)
    return {m.name: (buf[m.offset // 4] if m.size == 1 else buf[m.offset // 4: m.offset // 4 + 3].copy())
            for m in layout.members}


# --- putting a program together ----------------------------------------------------

#: The first GLSL version with the ``precise`` qualifier (energy.glsl uses it
#: to keep the parity harness's roundings; below it is defined away).
PRECISE_VERSION = 400


def header(spec=None, defines=None, version=GLSL_VERSION):
    """``#version``, the spec's #defines and its BrdfParams struct (if a spec is given).

    ``version`` 330 (OpenGL 3.3, the renderer's fallback) defines ``precise``
    away; the library uses nothing else beyond GLSL 3.30 outside the parity
    harness's compute kernels.
    """
    parts = [f"#version {version}"]
    if version < PRECISE_VERSION:
        parts.append("#define precise")
    all_defines = dict(defines_for(spec)) if spec is not None else {}
    all_defines.update(defines or {})
    if all_defines:
        parts.append(define_lines(all_defines))
    if spec is not None:
        parts.append(struct_source(spec))
    return "\n".join(parts)


def build_source(body, spec=None, defines=None, version=GLSL_VERSION, name="<main>"):
    """A complete shader: header(spec, defines) followed by ``body`` with its
    includes resolved, then a model of one's own's ``glsl=`` (own_glsl.source:
    after everything, so model.glsl's declaration of own_brdf comes first).
    Returns (source, line_map)."""
    head = header(spec, defines, version)
    head_lines = head.count("\n") + 1
    text, line_map = resolve_includes(body, name)
    own_text, own_map = own_glsl.source(parse_model(spec) if spec is not None else None)
    if own_text:
        text, line_map = text + "\n" + own_text, line_map + own_map
    return head + "\n" + text, [("<generated header>", i + 1) for i in range(head_lines)] + line_map
