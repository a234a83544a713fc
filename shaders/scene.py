"""What a preview render sees besides the material: the camera, the lights'
uniforms and the environment's GPU resources (shaders.render draws with them).

- ``Camera``: a perspective camera (world +y up), its matrices and rays.
- ``set_lights`` / ``split_lights``: PointLight / DirectionalLight lists into
  lights.glsl's uniform arrays (``MAX_LIGHTS`` of each, read from that file).
- ``environment_gpu(env)``: an Environment's radiance texture with its mips,
  its GGX-prefiltered mips (ibl_prefilter.glsl) and SH irradiance, with the
  split sum's DFG table (``dfg_texture``), cached per environment;
  ``default_environment()`` the generated sky.
"""

import dataclasses
import functools
import re

import numpy as np

from . import library
from .environment import DirectionalLight, Environment, PointLight, sh_irradiance_coefficients
from .gl import (compute_available, compute_program, current_framebuffer, get_context, gl_cache, glsl_version,
                 render_program, set_uniform)

MAX_LIGHTS = int(re.search(r"const int MAX_LIGHTS = (\d+);", library.read_glsl("lights.glsl")).group(1))
PREFILTER_LEVELS = 6          # roughness m / 5 at mip m
PREFILTER_SAMPLES = 192       # per texel (level 0, roughness 0, takes one)
PREFILTER_MAX_WIDTH = 256
#: How the prefiltered mips are made: a compute shader (OpenGL 4.3) or a
#: fragment shader rendering each level into a float target (OpenGL 3.3).
PREFILTER_METHODS = ("compute", "fragment")


@dataclasses.dataclass(frozen=True)
class Camera:
    """Perspective camera looking at ``target`` from ``position`` (world, +y up)."""
    position: tuple = (0.0, 0.7, 4.2)
    target: tuple = (0.0, 0.0, 0.0)
    fov_deg: float = 30.0
    up: tuple = (0.0, 1.0, 0.0)

    @classmethod
    def orbit(cls, distance=4.25, elevation=10.0, azimuth=0.0, target=(0.0, 0.0, 0.0), fov_deg=30.0):
        e, a = np.radians(elevation), np.radians(azimuth)
        offset = distance * np.array([np.cos(e) * np.sin(a), np.sin(e), np.cos(e) * np.cos(a)])
        return cls(tuple(np.asarray(target) + offset), tuple(target), fov_deg)

    @classmethod
    def framing(cls, mesh, elevation=10.0, azimuth=0.0, fov_deg=30.0, margin=1.04):
        """An orbit camera that fits the mesh's bounding sphere in the frame."""
        lo, hi = mesh.bounds
        center = 0.5 * (lo + hi)
        radius = float(np.linalg.norm(mesh.positions - center, axis=1).max())
        distance = margin * radius / np.sin(np.radians(fov_deg) / 2.0)
        return cls.orbit(distance, elevation, azimuth, tuple(center), fov_deg)

    def basis(self):
        """(right, up, forward) unit vectors."""
        f = np.asarray(self.target, float) - np.asarray(self.position, float)
        f /= np.linalg.norm(f)
        r = np.cross(f, self.up)
        r /= np.linalg.norm(r)
        return r, np.cross(r, f), f

    def view_projection(self, aspect=1.0, near=0.1, far=100.0):
        r, u, f = self.basis()
        p = np.asarray(self.position, float)
        view = np.eye(4)
        view[0, :3], view[1, :3], view[2, :3] = r, u, -f
        view[:3, 3] = -view[:3, :3] @ p
        t = 1.0 / np.tan(np.radians(self.fov_deg) / 2.0)
        proj = np.zeros((4, 4))
        proj[0, 0], proj[1, 1] = t / aspect, t
        proj[2, 2], proj[2, 3] = (far + near) / (near - far), 2.0 * far * near / (near - far)
        proj[3, 2] = -1.0
        return proj @ view

    def rays(self, width, height):
        """Unit ray directions (H, W, 3) through the pixel centres, top row first."""
        r, u, f = self.basis()
        t = np.tan(np.radians(self.fov_deg) / 2.0)
        x = ((np.arange(width) + 0.5) / width * 2.0 - 1.0) * t * width / height
        y = (1.0 - (np.arange(height) + 0.5) / height * 2.0) * t
        d = f + x[None, :, None] * r + y[:, None, None] * u
        return d / np.linalg.norm(d, axis=-1, keepdims=True)



# --- lights ---------------------------------------------------------------------------

def set_lights(program, point_lights, directional_lights):
    if len(point_lights) > MAX_LIGHTS or len(directional_lights) > MAX_LIGHTS:
        raise ValueError(f"at most {MAX_LIGHTS} point and {MAX_LIGHTS} directional lights")
    set_uniform(program, "n_point_lights", len(point_lights))
    set_uniform(program, "n_directional_lights", len(directional_lights))

    def write(name, rows, dim=3):
        member = program.get(name, None) or program.get(name + "[0]", None)
        if member is not None and rows:
            data = np.zeros((member.array_length, dim), np.float32)   # uniform arrays are written whole
            data[:len(rows)] = np.asarray(rows, np.float32).reshape(-1, dim)
            member.write(data.tobytes())

    write("point_light_position", [p.position for p in point_lights])
    write("point_light_intensity", [np.broadcast_to(p.intensity, 3) for p in point_lights])
    write("directional_light_direction", [d.unit_direction for d in directional_lights])
    write("directional_light_irradiance", [np.broadcast_to(d.irradiance, 3) for d in directional_lights])
    write("directional_light_radius", [[d.angular_radius] for d in directional_lights], dim=1)


def split_lights(lights):
    points = [l for l in lights if isinstance(l, PointLight)]
    dirs = [l for l in lights if isinstance(l, DirectionalLight)]
    other = [l for l in lights if not isinstance(l, (PointLight, DirectionalLight))]
    if other:
        raise TypeError(f"lights must be PointLight or DirectionalLight, got {type(other[0]).__name__}")
    return points, dirs



# --- the environment on the GPU -----------------------------------------------------

_DFG = gl_cache()


def dfg_texture():
    if "dfg" not in _DFG:
        import moderngl
        from brdf.energy import tables
        t = tables()
        ab = np.stack([t["A"], t["B"]], axis=-1).astype(np.float32)       # [mu, r, 2]
        tex = get_context().texture((ab.shape[1], ab.shape[0]), 2, ab.tobytes(), dtype="f4")
        tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        _DFG["dfg"] = tex
    return _DFG["dfg"]


class EnvironmentGPU:
    """Radiance texture with mips, prefiltered mips and SH of one Environment.

    ``method``: "compute" or "fragment" (PREFILTER_METHODS); None picks
    compute where the context has OpenGL 4.3, the fragment path below.
    """

    def __init__(self, env, method=None):
        import moderngl
        ctx = get_context()
        rad = np.asarray(env.radiance, np.float32)
        h, w, _ = rad.shape
        rgba = np.concatenate([rad, np.ones((h, w, 1), np.float32)], axis=-1)
        self.texture = ctx.texture((w, h), 4, rgba.tobytes(), dtype="f4")
        self.texture.build_mipmaps()
        self.texture.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
        self.texture.repeat_x, self.texture.repeat_y = True, False
        self.max_lod = float(int(np.floor(np.log2(max(w, h)))))
        self.texel_solid_angle = 4.0 * np.pi / (w * h)
        self.sh = sh_irradiance_coefficients(rad).astype(np.float32)
        if method is None:
            method = "compute" if compute_available(ctx) else "fragment"
        if method not in PREFILTER_METHODS:
            raise ValueError(f"prefilter method must be one of {PREFILTER_METHODS}, got {method!r}")
        self.method = method
        self.prefiltered = self._prefilter(ctx, w, h)

    def _prefilter(self, ctx, w, h):
        import moderngl
        pw = min(w, PREFILTER_MAX_WIDTH)
        ph = max(1, pw * h // w)
        levels = min(PREFILTER_LEVELS, int(np.log2(min(pw, ph))) + 1)
        tex = ctx.texture((pw, ph), 4, dtype="f4")
        tex.build_mipmaps(0, levels - 1)                 # allocates the mip levels
        tex.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
        tex.repeat_x, tex.repeat_y = True, False
        compute = self.method == "compute"
        defines = {"PREFILTER_COMPUTE": "1"} if compute else None
        version = library.GLSL_VERSION if compute else glsl_version(ctx)
        source, line_map = library.build_source('#include "ibl_prefilter.glsl"', defines=defines,
                                                version=version, name="<prefilter>")
        if compute:
            prog = compute_program(source, line_map)
        else:
            vs, vs_map = library.build_source('#include "render_fullscreen.glsl"', version=version,
                                              name="<fullscreen>")
            prog = render_program(vs, source, (vs_map, line_map))
        self.texture.use(location=0)
        set_uniform(prog, "ibl_environment", 0)
        set_uniform(prog, "prefilter_source_texel_solid_angle", self.texel_solid_angle)
        set_uniform(prog, "prefilter_source_max_lod", self.max_lod)
        for level in range(levels):
            lw, lh = max(1, pw >> level), max(1, ph >> level)
            roughness = level / (PREFILTER_LEVELS - 1)
            set_uniform(prog, "prefilter_roughness", max(roughness, 1e-3))
            set_uniform(prog, "prefilter_samples", PREFILTER_SAMPLES if level else 1)
            if compute:
                tex.bind_to_image(0, read=False, write=True, level=level)
                prog.run((lw + 7) // 8, (lh + 7) // 8)
            else:
                tex.write(_draw_level(ctx, prog, lw, lh), level=level)
        if compute:
            ctx.memory_barrier()
        self.levels = levels
        return tex

    def release(self):
        """Free its two textures (moderngl frees nothing by itself)."""
        self.texture.release()
        self.prefiltered.release()

    def bind(self, program, intensity=1.0):
        self.texture.use(location=0)
        self.prefiltered.use(location=1)
        dfg_texture().use(location=2)
        set_uniform(program, "ibl_environment", 0)
        set_uniform(program, "ibl_prefiltered", 1)
        set_uniform(program, "ibl_dfg", 2)
        set_uniform(program, "ibl_prefiltered_max_lod", float(PREFILTER_LEVELS - 1))
        set_uniform(program, "ibl_intensity", float(intensity))
        set_uniform(program, "env_texel_solid_angle", float(self.texel_solid_angle))
        set_uniform(program, "env_max_lod", self.max_lod)
        member = program.get("ibl_sh", None) or program.get("ibl_sh[0]", None)
        if member is not None:
            member.write(np.ascontiguousarray(self.sh, np.float32).tobytes())


def _draw_level(ctx, program, width, height):
    """RGBA32F bytes of one prefiltered level drawn by the fragment path (OpenGL
    3.3 cannot attach a mip level through moderngl: the level is drawn into its
    own target, read back and written into the mip chain)."""
    import moderngl
    previous = current_framebuffer(ctx)
    target = ctx.renderbuffer((width, height), 4, dtype="f4")
    fbo = ctx.framebuffer(color_attachments=[target])
    vao = ctx.vertex_array(program, [])
    try:
        fbo.use()
        ctx.viewport = (0, 0, width, height)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        set_uniform(program, "prefilter_size", (width, height))
        vao.render(moderngl.TRIANGLES, vertices=3)
        return fbo.read(components=4, dtype="f4")
    finally:
        previous.use()          # see current_framebuffer
        for obj in (vao, fbo, target):
            obj.release()


_ENV_CACHE = gl_cache()


def environment_gpu(env):
    key = id(env)
    if key not in _ENV_CACHE:
        if len(_ENV_CACHE) >= 4:
            _ENV_CACHE.pop(next(iter(_ENV_CACHE)))[1].release()
        _ENV_CACHE[key] = (env, EnvironmentGPU(env))
    return _ENV_CACHE[key][1]


@functools.lru_cache(maxsize=None)
def default_environment():
    """The generated clear sky with a sun (shaders.environment.Environment.sky)."""
    return Environment.sky()
