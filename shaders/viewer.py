"""Interactive preview window: orbit camera, a movable key light, exposure.

    brdf-fit view RESULT.json [--measured FILE] [--env FILE.hdr]

The window (pyglet, the ``viewer`` extra) shows what ``brdf-fit render``
writes, re-rendered when the view changes: each frame is rendered off-screen
by shaders.render (the same programs, lights and tone mapping as the PNGs)
and drawn into the window, so the window adds no second shading path.

Controls
    drag           orbit the camera          scroll       zoom
    arrow keys     move the key light        + / -        exposure (1/2 stop)
    T              next tone map             M            fitted / measured / comparison
    E              environment on / off      R            reset the view
    S              save the frame as PNG     Esc, Q       quit

``ViewState`` holds everything the controls change and turns it into the
renderer's camera, lights and tone mapping; ``frame`` renders one image.
Both are independent of the window, and tested headless.  The renderer runs
in the window's own OpenGL context (``shaders.gl.adopt_current_context``), so
one context serves both; the window asks for OpenGL 4.3 and falls back to 3.3
core, which the renderer runs on too (docs/renderer.md).
"""

import dataclasses
import math
import os
import sys

import numpy as np

from . import image
from .environment import DirectionalLight

MODES = ("fitted", "measured", "comparison")
EXPOSURE_STEP = 0.5           # stops per key press
ORBIT_DEGREES_PER_PIXEL = 0.4
LIGHT_STEP = 15.0             # degrees per arrow key press
ZOOM_FACTOR = 1.1             # per scroll step
DISTANCE_RANGE = (2.0, 12.0)
ELEVATION_LIMIT = 85.0
KEY_LIGHT_IRRADIANCE = 3.0    # W/m^2 per channel


class ViewerUnavailableError(RuntimeError):
    """No display, or pyglet missing: the message says what to do instead."""


@dataclasses.dataclass
class ViewState:
    """What the controls change.  Angles in degrees, exposure in stops."""
    azimuth: float = 0.0
    elevation: float = 10.0
    distance: float = 4.25
    light_azimuth: float = 45.0
    light_elevation: float = 40.0
    exposure_stops: float = 0.0
    tonemap: str = "aces"
    mode: str = "fitted"
    environment: bool = True
    has_measured: bool = False

    def drag(self, dx, dy):
        """Orbit by a mouse drag of (dx, dy) pixels (y up, as pyglet reports it)."""
        self.azimuth = (self.azimuth - dx * ORBIT_DEGREES_PER_PIXEL) % 360.0
        self.elevation = float(np.clip(self.elevation - dy * ORBIT_DEGREES_PER_PIXEL,
                                       -ELEVATION_LIMIT, ELEVATION_LIMIT))

    def scroll(self, steps):
        """Zoom in (steps > 0) or out, within DISTANCE_RANGE."""
        self.distance = float(np.clip(self.distance * ZOOM_FACTOR ** -steps, *DISTANCE_RANGE))

    def key(self, name):
        """Apply a key (pyglet's symbol name: "LEFT", "PLUS", "T"...); True if the view changed."""
        before = dataclasses.replace(self)
        if name == "LEFT":
            self.light_azimuth = (self.light_azimuth - LIGHT_STEP) % 360.0
        elif name == "RIGHT":
            self.light_azimuth = (self.light_azimuth + LIGHT_STEP) % 360.0
        elif name in ("UP", "DOWN"):
            step = LIGHT_STEP if name == "UP" else -LIGHT_STEP
            self.light_elevation = float(np.clip(self.light_elevation + step, -ELEVATION_LIMIT,
                                                 ELEVATION_LIMIT))
        elif name in ("PLUS", "EQUAL", "NUM_ADD"):
            self.exposure_stops += EXPOSURE_STEP
        elif name in ("MINUS", "NUM_SUBTRACT"):
            self.exposure_stops -= EXPOSURE_STEP
        elif name == "T":
            self.tonemap = image.TONEMAPS[(image.TONEMAPS.index(self.tonemap) + 1) % len(image.TONEMAPS)]
        elif name == "M":
            modes = MODES if self.has_measured else MODES[:1]
            self.mode = modes[(modes.index(self.mode) + 1) % len(modes)]
        elif name == "E":
            self.environment = not self.environment
        elif name == "R":
            fresh = ViewState(has_measured=self.has_measured, mode=self.mode)
            self.__dict__.update(fresh.__dict__)
        return self != before

    @property
    def exposure(self):
        return 2.0 ** self.exposure_stops

    def camera(self):
        from .render import Camera
        return Camera.orbit(self.distance, self.elevation, self.azimuth)

    def key_light(self):
        """The movable directional light (world +y up, azimuth 0 towards +z)."""
        e, a = math.radians(self.light_elevation), math.radians(self.light_azimuth)
        direction = (math.cos(e) * math.sin(a), math.sin(e), math.cos(e) * math.cos(a))
        return DirectionalLight(direction, (KEY_LIGHT_IRRADIANCE,) * 3, angular_radius=0.02)

    def title(self, spec):
        return (f"{spec} - {self.mode} - exposure {self.exposure_stops:+.1f} EV - {self.tonemap}"
                f"{'' if self.environment else ' - no environment'}")


def frame(state, material, table=None, env=None, size=512):
    """One uint8 (H, W, 3) image of the current view.

    ``material``: a shaders.render.Material; ``table``: a MeasuredTable for
    the measured and comparison modes; ``env``: an Environment or None (the
    generated sky).
    """
    from . import render
    lit = state.environment
    env = (env if env is not None else render.default_environment()) if lit else None
    common = dict(camera=state.camera(), lights=[state.key_light()], env=env)
    if state.mode == "fitted" or table is None:
        hdr = render.render_hdr(material, size, ibl="split_sum" if lit else "none",
                                background="environment" if lit else "black", **common)
        return image.finish(hdr, state.tonemap, state.exposure)
    ibl = "sampled" if lit else "none"
    if state.mode == "measured":
        hdr = render.render_hdr(table, size, ibl=ibl, alpha_hint=material.alpha_hint(), samples=16,
                                msaa=0, background="environment" if lit else "black", **common)
        return image.finish(hdr, state.tonemap, state.exposure)
    return render.render_comparison(material.spec, material.params, table, size=max(128, size // 2),
                                    tonemap=state.tonemap, exposure=state.exposure, ibl=ibl,
                                    samples=16, **common)


def display_available():
    """True when a window can be opened (an X11 or Wayland display, or not Linux)."""
    if not sys.platform.startswith("linux"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def load_pyglet():
    if not display_available():
        raise ViewerUnavailableError(
            "no display (DISPLAY and WAYLAND_DISPLAY are unset): the interactive viewer needs one; "
            "write images instead with `brdf-fit render RESULT.json --out preview.png`")
    try:
        import pyglet
    except ImportError:
        raise ViewerUnavailableError(
            "the interactive viewer needs pyglet: pip install 'brdf-toolkit[viewer]' "
            "(or pip install pyglet)") from None
    return pyglet


def run(material, table=None, env=None, size=512, screenshot_dir="."):
    """Open the window and run until it is closed (blocks)."""
    pyglet = load_pyglet()
    from .gl import adopt_current_context
    state = ViewState(has_measured=table is not None)
    window = _open_window(pyglet, size * (2 if table is not None else 1), size, state.title(material.spec))
    window.switch_to()
    ctx = adopt_current_context()     # the renderer draws off-screen in the window's own context
    blit = ctx.program(vertex_shader=_BLIT_VERTEX, fragment_shader=_BLIT_FRAGMENT)
    quad = ctx.vertex_array(blit, [])
    picture = {"image": None, "texture": None, "dirty": True}

    def refresh():
        img = frame(state, material, table, env, size)
        h, w = img.shape[:2]
        if picture["texture"] is None or picture["texture"].size != (w, h):
            if picture["texture"] is not None:
                picture["texture"].release()
            picture["texture"] = ctx.texture((w, h), 3)
        picture["texture"].write(np.ascontiguousarray(img[::-1]).tobytes())   # GL rows are bottom-up
        picture["image"] = img
        window.set_caption(state.title(material.spec))
        picture["dirty"] = False

    @window.event
    def on_draw():
        if picture["dirty"]:
            refresh()
        ctx.screen.use()
        ctx.disable(ctx.DEPTH_TEST | ctx.BLEND)
        width, height = window.get_framebuffer_size()
        ctx.viewport = (0, 0, width, height)
        ctx.clear(0.0, 0.0, 0.0)
        w, h = picture["texture"].size
        scale = min(width / w, height / h)       # keep the aspect (high-DPI framebuffers are larger)
        ctx.viewport = ((width - int(w * scale)) // 2, (height - int(h * scale)) // 2,
                        int(w * scale), int(h * scale))
        picture["texture"].use(0)
        blit["image"] = 0
        quad.render(vertices=3)

    @window.event
    def on_mouse_drag(x, y, dx, dy, buttons, modifiers):
        state.drag(dx, dy)
        picture["dirty"] = True

    @window.event
    def on_mouse_scroll(x, y, scroll_x, scroll_y):
        state.scroll(scroll_y)
        picture["dirty"] = True

    @window.event
    def on_key_press(symbol, modifiers):
        name = pyglet.window.key.symbol_string(symbol)
        if name in ("ESCAPE", "Q"):
            window.close()
            return pyglet.event.EVENT_HANDLED
        if name == "S" and picture["image"] is not None:
            path = _next_screenshot(screenshot_dir)
            image.write_png(path, picture["image"])
            print(f"wrote {path}")
            return pyglet.event.EVENT_HANDLED
        if state.key(name):
            picture["dirty"] = True
        return pyglet.event.EVENT_HANDLED

    pyglet.app.run()


def _open_window(pyglet, width, height, caption):
    """A window with an OpenGL 4.3 core context, else 3.3 core (shaders.gl's versions)."""
    from .gl import GLUnavailableError, PREFERRED_VERSION, REQUIRED_VERSION, version_cap
    cap = version_cap()
    errors = []
    for version in (PREFERRED_VERSION, REQUIRED_VERSION):
        if cap is not None and version > cap:
            continue
        config = pyglet.gl.Config(major_version=version // 100, minor_version=version % 100 // 10,
                                  forward_compatible=True, double_buffer=True, depth_size=24)
        try:
            return pyglet.window.Window(width, height, resizable=False, caption=caption, config=config)
        except (pyglet.window.NoSuchConfigException, pyglet.gl.ContextException) as exc:
            errors.append(f"{version}: {exc}")
    raise GLUnavailableError(f"the display offers no OpenGL 3.3 core context ({'; '.join(errors)})")


# A full-viewport triangle showing the frame texture (drawn with moderngl, so
# pyglet only provides the window and its events).
_BLIT_VERTEX = """
#version 330
out vec2 uv;
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    uv = p;
    gl_Position = vec4(2.0 * p - 1.0, 0.0, 1.0);
}
"""
_BLIT_FRAGMENT = """
#version 330
uniform sampler2D image;
in vec2 uv;
out vec4 colour;
void main() { colour = vec4(texture(image, uv).rgb, 1.0); }
"""


def _next_screenshot(folder):
    n = 0
    while os.path.exists(os.path.join(folder, f"brdf-view-{n:03d}.png")):
        n += 1
    return os.path.join(folder, f"brdf-view-{n:03d}.png")
