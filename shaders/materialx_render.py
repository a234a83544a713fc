"""A MaterialX material drawn by MaterialX's own generated GLSL (issue 61 item 3).

``materialx_radiance(path, material, normals, lights)`` reads a .mtlx document, generates
MaterialX's GLSL fragment shader for the material's surface shader (the MaterialX python
package's ``GlslShaderGenerator``, 1.39), compiles it with moderngl on the toolkit's headless
context (shaders/gl.py) and draws one fragment per given surface point into a float render
target: the linear radiance MaterialX's code returns (no tone mapping, no sRGB encoding), per
point and light.  It is a judge of a written document, not part of the toolkit's renderer:
MaterialX is optional (the dev extra) and imported only here, only when called.

What MaterialX is told (its GenContext options and uniforms, as its generated code reads them):

- ``hwSpecularEnvironmentMethod = SPECULAR_ENVIRONMENT_NONE`` and no transmission: the
  environment contributes nothing; ``ND_directional_light`` bound as light type 1
  (``mx_directional_light``: the light shader's direction is -light.direction, its
  intensity light.color x light.intensity); one light at a time, ``u_numActiveLightSources``
  = 1, ``u_lightData[0]`` = (1, -l, white, 1): a white directional light from the unit
  direction l with irradiance 1 on a surface facing it.  MaterialX's light loop adds
  intensity x the BSDF's response, and its responses carry n.l: the output is radiance.
- The view is orthographic along -z (towards the viewer at +z), every point seen from
  V = +z: MaterialX takes V = normalize(u_viewPosition - positionWorld), so each fragment's
  positionWorld is u_viewPosition - V (directional lights do not read the position).
- The generated code reads its geometry from the vertex stage's ``VertexData`` block
  (normalWorld, tangentWorld, positionWorld); here the block becomes a plain global that
  a small ``main`` fills per fragment from float textures holding the given normals and
  tangents, then runs the generated ``main`` (renamed).  Nothing else of MaterialX's code
  is changed.  Fragment k of the target is point k (row-major over a ROW_WIDTH-wide target).
"""

from __future__ import annotations

import math
import pathlib
import re

import numpy as np

from .gl import current_framebuffer, get_context, render_program

#: MaterialX's light type id the directional light is bound to (any id > 0 works; 0 is none)
DIRECTIONAL_LIGHT_TYPE = 1
#: points per row of the render target
ROW_WIDTH = 256
#: the view direction, world space (the lit sphere is seen along -z from +z)
VIEW = (0.0, 0.0, 1.0)

_VERTEX = """#version 400
void main() {
    vec2 corner = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(corner * 2.0 - 1.0, 0.0, 1.0);
}
"""

_DRIVER = """
// --- brdf_fit: one fragment per given surface point (shaders/materialx_render.py) ---
uniform sampler2D brdf_fit_normals;
uniform sampler2D brdf_fit_tangents;
uniform vec3 brdf_fit_view;

void main()
{
    ivec2 texel = ivec2(gl_FragCoord.xy);
    vd.normalWorld = texelFetch(brdf_fit_normals, texel, 0).xyz;
    vd.tangentWorld = texelFetch(brdf_fit_tangents, texel, 0).xyz;
    vd.positionWorld = u_viewPosition - brdf_fit_view;
    materialx_main();
}
"""


class MaterialXRenderError(RuntimeError):
    """The document, the material or MaterialX's generated code cannot be drawn."""


def _materialx():
    try:
        import MaterialX
        from MaterialX import PyMaterialXGenGlsl, PyMaterialXGenShader
    except ImportError as exc:
        raise MaterialXRenderError(f"MaterialX is not installed ({exc}); pip install materialx") from exc
    return MaterialX, PyMaterialXGenGlsl, PyMaterialXGenShader


def generated_fragment_shader(path: str | pathlib.Path, material: str) -> str:
    """MaterialX's GLSL pixel stage for ``material`` (a surfacematerial of the document at
    ``path``), generated with direct lights only (module docstring)."""
    mx, gen_glsl, gen_shader = _materialx()
    package = pathlib.Path(mx.__file__).resolve().parent
    libraries = mx.createDocument()
    mx.loadLibraries(["libraries"], mx.FileSearchPath(str(package)), libraries)
    doc = mx.createDocument()
    mx.readFromXmlFile(doc, str(path))
    doc.setDataLibrary(libraries)
    node = doc.getNode(material)
    if node is None:
        names = [m.getName() for m in doc.getMaterialNodes()]
        raise MaterialXRenderError(f"{path}: no material {material!r} (materials: {', '.join(names)})")
    generator = gen_glsl.GlslShaderGenerator.create()
    context = gen_shader.GenContext(generator)
    context.registerSourceCodeSearchPath(mx.FileSearchPath(str(package)))
    options = context.getOptions()
    options.hwSpecularEnvironmentMethod = gen_shader.HwSpecularEnvironmentMethod.SPECULAR_ENVIRONMENT_NONE
    options.hwSrgbEncodeOutput = False
    options.hwTransparency = False
    options.hwShadowMap = False
    options.hwAmbientOcclusion = False
    gen_glsl.GlslShaderGenerator.bindLightShader(libraries.getNodeDef("ND_directional_light"),
                                                 DIRECTIONAL_LIGHT_TYPE, context)
    shader = generator.generate(material, node, context)
    return shader.getSourceCode(gen_shader.PIXEL_STAGE)


def driven(source: str) -> str:
    """MaterialX's pixel stage with its ``VertexData`` input block made a global and its
    ``main`` renamed ``materialx_main``, followed by the per-fragment driver."""
    block = re.compile(r"\bin\s+VertexData\s*\{(?P<members>[^}]*)\}\s*vd\s*;")
    members = block.search(source)
    if members is None or len(re.findall(r"\bvoid\s+main\s*\(\s*\)", source)) != 1:
        raise MaterialXRenderError("MaterialX's generated pixel stage has no VertexData block vd "
                                   "or not one main(): this MaterialX version is not supported")
    missing = [m for m in ("normalWorld", "tangentWorld", "positionWorld") if m not in members.group("members")]
    if missing:
        raise MaterialXRenderError(f"MaterialX's VertexData block has no {', '.join(missing)}")
    text = block.sub(lambda m: f"struct VertexData {{{m.group('members')}}};\nVertexData vd;", source)
    text = re.sub(r"\bvoid\s+main\s*\(\s*\)", "void materialx_main()", text)
    if "u_refractionTwoSided" in text and not re.search(r"uniform\s+bool\s+u_refractionTwoSided", text):
        # MaterialX 1.39.5 leaves this out without an environment; only environment code reads it
        version, _, rest = text.partition("\n")
        text = f"{version}\nuniform bool u_refractionTwoSided = false;   // brdf_fit: undeclared\n{rest}"
    return text + _DRIVER


def _texture(ctx, rows):
    """A float RGB texture of ROW_WIDTH x H texels holding ``rows`` (P, 3), zero-padded."""
    height = max(1, math.ceil(len(rows) / ROW_WIDTH))
    data = np.zeros((height * ROW_WIDTH, 3), np.float32)
    data[:len(rows)] = rows
    texture = ctx.texture((ROW_WIDTH, height), 3, data.tobytes(), dtype="f4")
    texture.filter = (ctx.NEAREST, ctx.NEAREST)
    return texture


def _azimuth_tangents(normals):
    """normalize(+y x n): the lit sphere's tangent along the azimuth around y."""
    t = np.cross(np.array([0.0, 1.0, 0.0]), normals)
    return t / np.maximum(np.linalg.norm(t, axis=-1, keepdims=True), 1e-12)


def materialx_radiance(path: str | pathlib.Path, material: str, normals, lights, tangents=None) -> np.ndarray:
    """Radiance (L, P, 3), float64 of float32 values, that MaterialX's generated GLSL of
    ``material`` returns at P surface points with world ``normals`` (P, 3) (and ``tangents``,
    default normalize(+y x n)), seen from +z, under each of the L white directional lights of
    irradiance 1 from the unit directions ``lights`` (L, 3), one at a time."""
    normals = np.asarray(normals, np.float64).reshape(-1, 3)
    tangents = _azimuth_tangents(normals) if tangents is None else np.asarray(tangents, np.float64).reshape(-1, 3)
    lights = np.asarray(lights, np.float64).reshape(-1, 3)
    program = render_program(_VERTEX, driven(generated_fragment_shader(path, material)))
    ctx = get_context()
    height = max(1, math.ceil(len(normals) / ROW_WIDTH))
    normal_tex, tangent_tex = _texture(ctx, normals), _texture(ctx, tangents)
    target = ctx.texture((ROW_WIDTH, height), 4, dtype="f4")
    fbo = ctx.framebuffer(color_attachments=[target])
    vao = ctx.vertex_array(program, [])
    previous = current_framebuffer(ctx)
    out = []
    try:
        fbo.use()
        ctx.viewport = (0, 0, ROW_WIDTH, height)
        normal_tex.use(0)
        tangent_tex.use(1)
        values = {"brdf_fit_normals": 0, "brdf_fit_tangents": 1, "brdf_fit_view": VIEW,
                  "u_viewPosition": (0.0, 0.0, 0.0), "u_numActiveLightSources": 1,
                  "u_lightData[0].type": DIRECTIONAL_LIGHT_TYPE, "u_lightData[0].color": (1.0, 1.0, 1.0),
                  "u_lightData[0].intensity": 1.0}
        for name, value in values.items():
            if name in program:
                program[name].value = value
        for light in lights:
            program["u_lightData[0].direction"].value = tuple(-light / np.linalg.norm(light))
            ctx.clear(0.0, 0.0, 0.0, 0.0)
            vao.render(mode=ctx.TRIANGLES, vertices=3)
            pixels = np.frombuffer(fbo.read(components=4, dtype="f4"), np.float32)
            out.append(pixels.reshape(-1, 4)[:len(normals), :3])
    finally:
        previous.use()          # see shaders.gl.current_framebuffer
        for resource in (vao, fbo, target, normal_tex, tangent_tex):
            resource.release()
    return np.asarray(out, np.float64)
