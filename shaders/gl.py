"""The headless OpenGL context (moderngl through EGL) and a program cache.

One standalone context per process is created on first use and shared by the
parity harness and the renderer.  Without a usable driver the error says what
to install instead of showing a ctypes traceback.
"""

import re

#: What to install when EGL / Mesa is missing (Debian / Ubuntu).
INSTALL_HINT = ("install Mesa's EGL and its software rasteriser: "
                "`sudo apt-get install libegl1 libgl1-mesa-dri` "
                "(or `make sysdeps`, which does it where missing)")

#: Compute shaders and std430 buffers need OpenGL 4.3.
REQUIRED_VERSION = 430


class GLUnavailableError(RuntimeError):
    """No usable OpenGL context: the message names the fix."""


class ShaderCompileError(RuntimeError):
    """A GLSL program failed to compile or link; lines refer to the .glsl files."""


_CONTEXT = []


def get_context():
    """The process-wide moderngl context: headless (EGL, OpenGL >= 4.3), created
    on first use, unless ``adopt_current_context`` gave it a window's."""
    if not _CONTEXT:
        _CONTEXT.append(create_context())
    return _CONTEXT[0]


def adopt_current_context():
    """Render with the OpenGL context current on this thread (an interactive
    window's) instead of a headless one.  Call before any rendering: programs
    and textures belong to the context that made them."""
    import moderngl
    if _CONTEXT:
        raise RuntimeError("a rendering context already exists in this process")
    try:
        ctx = moderngl.create_context(require=REQUIRED_VERSION)
    except Exception as exc:  # noqa: BLE001 - glcontext raises plain Exception
        raise GLUnavailableError(f"the window's OpenGL context cannot run the renderer ({exc}); "
                                 f"it needs OpenGL {REQUIRED_VERSION // 100}.{REQUIRED_VERSION % 100 // 10}") from exc
    _CONTEXT.append(ctx)
    return ctx


def create_context():
    """A new headless moderngl context through EGL, or GLUnavailableError naming the fix."""
    try:
        import moderngl
    except ImportError as exc:  # pragma: no cover - moderngl is a dependency
        raise GLUnavailableError(f"moderngl is not installed ({exc}); pip install moderngl") from exc
    try:
        ctx = moderngl.create_standalone_context(backend="egl", require=REQUIRED_VERSION)
    except Exception as exc:  # noqa: BLE001 - glcontext raises plain Exception
        raise GLUnavailableError(
            f"could not create a headless OpenGL {REQUIRED_VERSION // 100}.{REQUIRED_VERSION % 100 // 10} "
            f"context through EGL ({exc}); {INSTALL_HINT}") from exc
    if ctx.version_code < REQUIRED_VERSION:
        raise GLUnavailableError(
            f"the OpenGL driver offers version {ctx.version_code}, the shaders need "
            f"{REQUIRED_VERSION} (compute shaders); {INSTALL_HINT}")
    return ctx


def gl_available():
    """(True, info) when a context can be created, else (False, reason)."""
    try:
        ctx = get_context()
    except GLUnavailableError as exc:
        return False, str(exc)
    return True, f"{ctx.info['GL_RENDERER']} / OpenGL {ctx.info['GL_VERSION']}"


def _annotate(message, line_map):
    """Replace '0:LINE(COL)' positions in a driver log by 'file.glsl:line'."""
    if not line_map:
        return message

    def where(match):
        line = int(match.group(1))
        if 1 <= line <= len(line_map):
            name, src_line = line_map[line - 1]
            return f"{name}:{src_line}"
        return match.group(0)

    return re.sub(r"\b0:(\d+)(?:\(\d+\))?", where, message)


_PROGRAMS = {}


def compute_program(source, line_map=None):
    """A compiled compute shader for ``source`` (cached by source text)."""
    ctx = get_context()
    key = ("compute", source)
    if key not in _PROGRAMS:
        try:
            _PROGRAMS[key] = ctx.compute_shader(source)
        except Exception as exc:  # moderngl.Error
            raise ShaderCompileError(_annotate(str(exc), line_map)) from None
    return _PROGRAMS[key]


def render_program(vertex_shader, fragment_shader, line_maps=(None, None)):
    """A compiled vertex + fragment program (cached by source text)."""
    ctx = get_context()
    key = ("render", vertex_shader, fragment_shader)
    if key not in _PROGRAMS:
        try:
            _PROGRAMS[key] = ctx.program(vertex_shader=vertex_shader,
                                         fragment_shader=fragment_shader)
        except Exception as exc:  # moderngl.Error
            text = str(exc)
            for lm in line_maps:
                text = _annotate(text, lm)
            raise ShaderCompileError(text) from None
    return _PROGRAMS[key]


def set_uniform(program, name, value):
    """Set a uniform if the program uses it (the compiler drops unused ones)."""
    member = program.get(name, None)
    if member is None:
        return False
    member.value = value
    return True
