"""Headless preview renderer (moderngl through EGL) for fitted and measured BRDFs.

    >>> img = render_material("ggx+lambert", params, size=512)            # uint8 (H, W, 3)
    >>> hdr = render_hdr(Material("gltf", p), size=256, ibl="sampled")    # float32 (H, W, 4)
    >>> cmp = render_comparison("ggx+lambert", params, measured)          # measured | fitted | diff

Scene: a generated mesh (``"sphere"`` or ``"shader_ball"``, shaders/mesh.py)
at the origin, world +y up, seen by a perspective camera; point lights
(inverse-square falloff), directional lights, and an environment
(shaders/environment.py) lit either by the split-sum approximation with the
Fdez-Aguera multiple-scattering combination (``ibl="split_sum"``, models
only, real time) or by Monte-Carlo integration of the BRDF itself
(``ibl="sampled"``, any BRDF including measured tables; used for
comparisons).  A model of one's own (brdf/own.py, drawn through its ``glsl=``)
and a measured table have no terms for the split sum: they are lit by sampling.
Output is linear radiance; ``shaders.image`` tone-maps it.  The alpha channel
of an HDR render is 1 where the object covers the pixel.  The camera, the
lights' uniforms and the environment's GPU resources are shaders.scene's
(``Camera`` and ``default_environment`` are importable here).
"""

import dataclasses
import functools

import numpy as np

from brdf.model import parse_model

from . import diffuse_ibl, image, library, own_glsl, tables
from .environment import Environment
from .gl import current_framebuffer, get_context, glsl_version, render_program, set_uniform
from .measured import MeasuredTable, bind_table
from .mesh import MESHES
# The camera, lights and environment resources live in shaders.scene; the
# public ones stay importable from here.
from .scene import (MAX_LIGHTS, Camera, default_environment, environment_gpu,  # noqa: F401
                    set_lights, split_lights)

IBL_MODES = ("split_sum", "sampled", "none")
DEFAULT_SAMPLES = 64          # per strategy, sampled IBL


@dataclasses.dataclass(frozen=True)
class Material:
    """A model string / ModelSpec and its parameters {name: float or [r, g, b]}."""
    spec: object
    params: dict

    def __post_init__(self):
        object.__setattr__(self, "spec", parse_model(self.spec))
        library.pack_params(self.spec, self.params)        # validates names and shapes

    def alpha_hint(self):
        """A GGX alpha for importance sampling: the model's own (isotropic part),
        or the clearcoat's when that lobe is sharper (the cosine strategy
        covers the broader one)."""
        r = float(np.clip(np.mean(self.params.get("roughness", 0.5)), 0.03, 1.0))
        if float(np.mean(self.params.get("clearcoat", 0.0))) > 0.0:
            r = min(r, float(np.clip(self.params["clearcoat_roughness"], 0.03, 1.0)))
        return r * r


# --- the mesh and the programs ---------------------------------------------------------

@functools.lru_cache(maxsize=None)
def _mesh_vbo(name):
    ctx = get_context()
    mesh = MESHES[name]()
    return ctx.buffer(mesh.interleaved().tobytes()), ctx.buffer(mesh.indices.tobytes()), mesh


def _shading_source(shading, ibl, version):
    """(defines, fragment body, spec) for a Material or a MeasuredTable."""
    defines = {"RENDER_IBL_" + ibl.upper(): "1"} if ibl != "none" else {}
    if isinstance(shading, Material):
        spec = shading.spec
        binding = library.MATERIAL_BLOCK_BINDING if version >= EXPLICIT_BINDING_VERSION else None
        body = "\n".join(['#include "model.glsl"', library.uniform_block_source(spec, binding=binding),
                          "vec3 shade_brdf(vec3 wi, vec3 wo) { return brdf_evaluate(material, wi, wo); }",
                          '#include "render_fragment.glsl"'])
        return defines, body, spec
    fn = "merl_lookup" if shading.kind == "merl" else "utia_lookup"
    body = "\n".join(['#include "measured.glsl"',
                      f"vec3 shade_brdf(vec3 wi, vec3 wo) {{ return {fn}(wi, wo); }}",
                      '#include "render_fragment.glsl"'])
    defines[shading.define] = "1"
    return defines, body, None


#: GLSL 4.20 lets a block's layout name its binding; below, the API binds it.
EXPLICIT_BINDING_VERSION = 420


def _program(shading, ibl):
    """The object's program, in the context's GLSL version (430 or 330, shaders.gl)."""
    version = glsl_version()
    defines, body, spec = _shading_source(shading, ibl, version)
    fs, fs_map = library.build_source(body, spec=spec, defines=defines, version=version, name="<fragment>")
    vs, vs_map = library.build_source('#include "render_vertex.glsl"', version=version, name="<vertex>")
    with own_glsl.compile_errors(spec):      # a model of one's own: its glsl= named in one line
        prog = render_program(vs, fs, (vs_map, fs_map))
    block = prog.get(library.MATERIAL_BLOCK, None)
    if block is not None:
        block.binding = library.MATERIAL_BLOCK_BINDING
    return prog


def check_program(spec):
    """Compile the lit sphere's program of ``spec`` as ``render_hdr`` does (image lighting
    sampled, this context's GLSL version), at its parameters' defaults: OwnModelError for a
    model of one's own whose glsl= does not compile (``brdf-fit fit`` checks it so, before
    fitting), GLUnavailableError without OpenGL."""
    from brdf.model import parameter_schema
    spec = parse_model(spec)
    params = {p.name: [p.default] * 3 if p.size == 3 else p.default for p in parameter_schema(spec)}
    _program(Material(spec, params), "sampled")


def _background_program():
    version = glsl_version()
    fs, fs_map = library.build_source('#include "render_background.glsl"', version=version,
                                      name="<background>")
    vs, vs_map = library.build_source('#include "render_fullscreen.glsl"', version=version,
                                      name="<fullscreen>")
    return render_program(vs, fs, (vs_map, fs_map))


def render_hdr(shading, size=512, *, width=None, height=None, mesh="sphere", camera=None,
               env=None, lights=None, ibl="split_sum", samples=DEFAULT_SAMPLES, alpha_hint=None,
               env_intensity=1.0, background="environment", msaa=4):
    """Render linear radiance: float32 (H, W, 4), alpha 1 on the object.

    ``shading``: a Material, or a MeasuredTable (then ``ibl="split_sum"``
    falls back to ``"sampled"``, as for a model of one's own).  ``env``: an
    Environment (default: the generated sky), or None with ``ibl="none"`` for
    lights only.  ``lights``: PointLight / DirectionalLight list; None means
    the environment's own (its sun).  ``background``: "environment", "black" or an RGB triple.
    """
    if ibl not in IBL_MODES:
        raise ValueError(f"ibl must be one of {IBL_MODES}, got {ibl!r}")
    if not isinstance(shading, (Material, MeasuredTable)):
        shading = MeasuredTable.from_measured(shading)
    if ibl == "split_sum" and (isinstance(shading, MeasuredTable) or shading.spec.own is not None):
        ibl = "sampled"         # the split sum reads the terms' image-lighting functions (ibl.glsl)
    if mesh not in MESHES:
        raise ValueError(f"unknown mesh {mesh!r}; use one of {', '.join(MESHES)}")
    import moderngl
    ctx = get_context()
    width = width or size
    height = height or size
    camera = camera or Camera.framing(_mesh_vbo(mesh)[2])
    env = env if env is not None else (default_environment() if ibl != "none" or lights is None else None)
    if lights is None:
        lights = env.lights if env is not None else ()
    point_lights, dir_lights = split_lights(lights)

    samples_ms = msaa if msaa and msaa > 1 else 0
    previous = current_framebuffer(ctx)
    color = ctx.renderbuffer((width, height), 4, samples=samples_ms, dtype="f4")
    depth = ctx.depth_renderbuffer((width, height), samples=samples_ms)
    fbo = ctx.framebuffer(color_attachments=[color], depth_attachment=depth)
    resolve_tex = resolve = None
    try:
        env_gpu = environment_gpu(env) if env is not None else None    # may draw (prefilter)
        fbo.use()
        ctx.viewport = (0, 0, width, height)
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        right, up, forward = camera.basis()
        t = np.tan(np.radians(camera.fov_deg) / 2.0)

        # background
        ctx.disable(moderngl.DEPTH_TEST)
        bg = _background_program()
        if env_gpu is not None and background == "environment":
            env_gpu.bind(bg, env_intensity)
            set_uniform(bg, "background_mode", 0)
        else:
            set_uniform(bg, "background_mode", 1)
            colour = (0.0, 0.0, 0.0) if background in ("black", "environment", None) else background
            set_uniform(bg, "background_color", tuple(float(c) for c in np.broadcast_to(colour, 3)))
        set_uniform(bg, "camera_right", tuple(right * t * width / height))
        set_uniform(bg, "camera_up", tuple(up * t))
        set_uniform(bg, "camera_forward", tuple(forward))
        set_lights(bg, [], dir_lights if background == "environment" else [])
        ctx.vertex_array(bg, []).render(moderngl.TRIANGLES, vertices=3)

        # object
        ctx.enable(moderngl.DEPTH_TEST)
        prog = _program(shading, ibl)
        vbo, ibo, _ = _mesh_vbo(mesh)
        vao = ctx.vertex_array(prog, [(vbo, "3f 3f 3f", "in_position", "in_normal", "in_tangent")],
                               index_buffer=ibo, index_element_size=4)
        set_uniform(prog, "view_projection",
                    tuple(camera.view_projection(width / height).T.astype(np.float32).ravel()))
        set_uniform(prog, "camera_position", tuple(float(c) for c in camera.position))
        set_lights(prog, point_lights, dir_lights)
        tables.bind_tables(ctx, prog)
        if env_gpu is not None and ibl != "none":
            env_gpu.bind(prog, env_intensity)
        set_uniform(prog, "ibl_samples", int(samples))
        if isinstance(shading, Material):
            hint = shading.alpha_hint() if alpha_hint is None else alpha_hint
            if ibl == "split_sum":
                diffuse_ibl.bind_table(ctx, prog, shading.spec)
            block = ctx.buffer(library.pack_params(shading.spec, shading.params))
            block.bind_to_uniform_block(library.MATERIAL_BLOCK_BINDING)
        else:
            hint = 0.1 if alpha_hint is None else alpha_hint
            block = None
            bind_table(ctx, prog, shading)
        set_uniform(prog, "ibl_alpha_hint", float(max(hint, 1e-3)))
        vao.render(moderngl.TRIANGLES)
        vao.release()
        if block is not None:
            block.release()

        if samples_ms:
            resolve_tex = ctx.renderbuffer((width, height), 4, dtype="f4")
            resolve = ctx.framebuffer(color_attachments=[resolve_tex])
            ctx.copy_framebuffer(resolve, fbo)
            data = resolve.read(components=4, dtype="f4")
        else:
            data = fbo.read(components=4, dtype="f4")
    finally:
        previous.use()          # see current_framebuffer
        for obj in (fbo, color, depth, resolve, resolve_tex):
            if obj is not None:
                obj.release()
    img = np.frombuffer(data, np.float32).reshape(height, width, 4)[::-1]
    return np.ascontiguousarray(img)


def render_material(spec, params, size=512, env=None, lights=None, tonemap="aces", *,
                    exposure=1.0, mesh="sphere", ibl="split_sum", camera=None, linear=False, **kw):
    """Render a model with its parameters: tone-mapped sRGB uint8 (H, W, 3).

    ``env``: an Environment, a path to a Radiance .hdr file, or None for the
    generated sky.  ``linear=True`` returns the float32 (H, W, 4) radiance
    instead (before tone mapping).
    """
    if isinstance(env, (str, bytes)) or hasattr(env, "__fspath__"):
        env = Environment.from_hdr(env)
    hdr = render_hdr(Material(spec, params), size, mesh=mesh, camera=camera, env=env, lights=lights,
                     ibl=ibl, **kw)
    return hdr if linear else image.finish(hdr, tonemap, exposure)


# --- comparison and sweeps ------------------------------------------------------------

def relative_difference(measured_hdr, fitted_hdr, floor=0.02):
    """Per-pixel |L_m - L_f| / max(L_m, floor * mean L_m) of linear luminance, on the object."""
    lm, lf = image.luminance(measured_hdr), image.luminance(fitted_hdr)
    mask = (measured_hdr[..., 3] > 0.5) & (fitted_hdr[..., 3] > 0.5)
    with np.errstate(over="ignore", invalid="ignore"):
        ref = np.maximum(lm, floor * (lm[mask].mean() if mask.any() else 1.0))
        num = np.abs(lm - lf)
        # black or overflowed measured pixels (ref 0 or inf): 100 % off where the two differ
        diff = np.divide(num, ref, out=np.where(num > 0, 1.0, 0.0), where=(ref > 0) & np.isfinite(ref))
    return np.where(mask, diff, 0.0), mask


def _hstack(panels, gap=4, gap_value=255):
    h = panels[0].shape[0]
    spacer = np.full((h, gap, 3), gap_value, np.uint8)
    out = [panels[0]]
    for p in panels[1:]:
        out += [spacer, p]
    return np.concatenate(out, axis=1)


def render_comparison(spec, params, measured, size=256, env=None, lights=None, tonemap="aces", *,
                      exposure=1.0, mesh="sphere", ibl="sampled", samples=32,
                      diff_scale=0.5, camera=None, msaa=0, return_data=False, labels=False):
    """measured | fitted | difference (false colour), one uint8 (H, 3W + gaps, 3) image.

    With ``labels`` the image gets a title above each panel and the
    difference's colour bar with its scale below (``shaders.annotate``).

    ``measured``: a MeasuredTable, a data_loaders MeasuredBRDF (its native MERL
    or UTIA table is used), an object with ``lookup(wi, wo) -> (N, 3)`` or a
    callable (resampled on the MERL grid).  Both sides are rendered with the
    same sampled environment lighting and lights (same per-pixel samples,
    importance-sampled with the fitted roughness, ``samples`` per strategy;
    no MSAA by default, so both panels cover the same pixels), so the difference panel
    shows BRDF differences: |L_m - L_f| / L_m of luminance, colour map
    inferno, full scale at ``diff_scale`` (50 % by default).  ``exposure``: a
    factor, or a function (measured HDR (H, W, 4), object mask (H, W)) -> factor
    taken from the measured image, one factor for both panels (the application's
    viewer exposure, brdf_fit.render.viewer_exposure).  With
    ``return_data`` also returns {"measured", "fitted" (HDR), "difference",
    "mask", "median_difference", "mean_difference", "exposure"}.
    """
    material = Material(spec, params)
    table = MeasuredTable.from_measured(measured)
    if isinstance(env, (str, bytes)) or hasattr(env, "__fspath__"):
        env = Environment.from_hdr(env)
    common = dict(mesh=mesh, camera=camera, env=env, lights=lights, ibl=ibl, samples=samples,
                  alpha_hint=material.alpha_hint(), msaa=msaa)
    hdr_m = render_hdr(table, size, **common)
    hdr_f = render_hdr(material, size, **common)
    diff, mask = relative_difference(hdr_m, hdr_f)
    if callable(exposure):
        exposure = float(exposure(hdr_m, mask))
    panels = [image.finish(hdr_m, tonemap, exposure), image.finish(hdr_f, tonemap, exposure),
              image.false_colour(diff, diff_scale, mask=mask)]
    if labels:
        from .annotate import labelled_comparison
        panel = labelled_comparison(panels, ["measured", f"fitted: {material.spec}", "difference |dL| / L"],
                                    diff_scale)
    else:
        panel = _hstack(panels)
    if not return_data:
        return panel
    return panel, {"measured": hdr_m, "fitted": hdr_f, "difference": diff, "mask": mask,
                   "median_difference": float(np.median(diff[mask])) if mask.any() else 0.0,
                   "mean_difference": float(diff[mask].mean()) if mask.any() else 0.0, "exposure": exposure}


def render_sweep(spec="gltf", params=None, sweep="roughness", values=(0.05, 0.25, 0.5, 0.75, 1.0),
                 rows=None, size=128, env=None, lights=None, tonemap="aces", *, exposure=1.0,
                 ibl="split_sum", gap=2):
    """A row of spheres over one parameter (default roughness), optionally one
    row per value of another (``rows=("metallic", (0.0, 1.0))``): uint8 image.

    ``params`` fills the other parameters (schema defaults where missing).
    """
    spec = parse_model(spec)
    base = {p.name: p.default if p.size == 1 else [p.default] * 3 for p in spec.schema()}
    if spec.composition == "gltf":
        base["base_color"] = [0.8, 0.35, 0.12]
    base.update(params or {})
    row_name, row_values = rows if rows else (None, (None,))
    lines = []
    for rv in row_values:
        panels = []
        for v in values:
            p = dict(base)
            p[sweep] = v
            if row_name is not None:
                p[row_name] = rv
            panels.append(render_material(spec, p, size, env, lights, tonemap, exposure=exposure, ibl=ibl))
        lines.append(_hstack(panels, gap))
    if len(lines) == 1:
        return lines[0]
    spacer = np.full((gap, lines[0].shape[1], 3), 255, np.uint8)
    out = [lines[0]]
    for line in lines[1:]:
        out += [spacer, line]
    return np.concatenate(out, axis=0)


def save_png(path, img):
    """Write a uint8 render as PNG (atomically)."""
    return image.write_png(path, img)
