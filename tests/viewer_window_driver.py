"""Drives the interactive viewer in a real window (run under xvfb-run by
tests/test_shaders_viewer.py): a drag, +1/2 stop of exposure, the key light
moved, a screenshot, the window's framebuffer read back, then Esc.

    python tests/viewer_window_driver.py OUT_DIR
"""

import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import pyglet  # noqa: E402
from pyglet.window import key  # noqa: E402

from shaders import viewer  # noqa: E402
from shaders.render import Material  # noqa: E402

out = pathlib.Path(sys.argv[1])
windows = []


class RecordingWindow(pyglet.window.Window):
    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        windows.append(self)


pyglet.window.Window = RecordingWindow


def read_window():
    w = windows[0]
    w.switch_to()
    w.dispatch_event("on_draw")
    pyglet.image.get_buffer_manager().get_color_buffer().save(str(out / "window.png"))
    (out / "caption.txt").write_text(w.caption)


def script(_dt):
    w = windows[0]
    steps = [lambda: w.dispatch_event("on_mouse_drag", 10, 10, 60, 20, 1, 0),
             lambda: w.dispatch_event("on_key_press", key.PLUS, 0),
             lambda: w.dispatch_event("on_key_press", key.RIGHT, 0),
             lambda: w.dispatch_event("on_key_press", key.S, 0),
             read_window,
             lambda: w.dispatch_event("on_key_press", key.ESCAPE, 0)]

    def run(i):
        steps[i]()
        if i + 1 < len(steps):
            pyglet.clock.schedule_once(lambda _dt: run(i + 1), 0.3)
    run(0)


pyglet.clock.schedule_once(script, 0.5)
material = Material("ggx+lambert", {"albedo": [0.5, 0.2, 0.1], "roughness": 0.3, "f0": [0.04] * 3})
viewer.run(material, size=128, screenshot_dir=str(out))
