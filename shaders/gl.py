"""The headless OpenGL context (moderngl through EGL) and a program cache.

One standalone context per process is created on first use and shared by the
parity harness and the renderer.  Without a usable driver the error says what
to install instead of showing a ctypes traceback.

Versions (docs/renderer.md): the context asks for OpenGL 4.3 and falls back to
3.3 core.  The renderer (``brdf-fit render`` / ``view``) runs on either: on 4.3
it prefilters environments with a compute shader and compiles ``#version 430``,
on 3.3 it renders the prefiltered mips with a fragment shader and compiles
``#version 330`` (``glsl_version``).  Only the parity harness needs compute
shaders (``compute_available``).  ``BRDF_GL_VERSION=330`` (or ``3.3``) caps
the version the toolkit uses, whatever the driver offers; to make Mesa itself
create a 3.3 context, also set ``MESA_GL_VERSION_OVERRIDE=3.3
MESA_GLSL_VERSION_OVERRIDE=330`` (tests/test_shaders_gl33.py does).
"""

import os
import re

#: What to install when EGL / Mesa is missing (Debian / Ubuntu).
INSTALL_HINT = ("install Mesa's EGL and its software rasteriser: "
                "`sudo apt-get install libegl1 libgl1-mesa-dri` "
                "(or `make sysdeps`, which does it where missing)")

#: The renderer's minimum: OpenGL 3.3 core (fragment shaders, float textures).
REQUIRED_VERSION = 330
#: Compute shaders and std430 buffers (the parity harness, the compute prefilter) need 4.3.
COMPUTE_VERSION = 430
#: Asked for first; REQUIRED_VERSION is the fallback.
PREFERRED_VERSION = COMPUTE_VERSION
#: Environment variable capping the version the toolkit uses ("330" or "3.3").
VERSION_ENV = "BRDF_GL_VERSION"


class GLUnavailableError(RuntimeError):
    """No usable OpenGL context: the message names the fix."""


class ShaderCompileError(RuntimeError):
    """A GLSL program failed to compile or link; lines refer to the .glsl files."""


_CONTEXT = []


def _version_text(code):
    return f"{code // 100}.{code % 100 // 10}"


def version_cap():
    """The version ``BRDF_GL_VERSION`` allows (330 for "330" or "3.3"), or None."""
    text = os.environ.get(VERSION_ENV, "").strip()
    if not text:
        return None
    try:
        code = int(round(float(text) * 100)) if "." in text else int(text)
    except ValueError:
        raise GLUnavailableError(f"{VERSION_ENV}={text!r}: give an OpenGL version such as 330 or 3.3") from None
    if code < REQUIRED_VERSION:
        raise GLUnavailableError(f"{VERSION_ENV}={text!r}: the renderer needs OpenGL "
                                 f"{_version_text(REQUIRED_VERSION)} or later")
    return code


def get_context():
    """The process-wide moderngl context: headless (EGL; OpenGL 4.3, else 3.3),
    created on first use, unless ``adopt_current_context`` gave it a window's."""
    if not _CONTEXT:
        _CONTEXT.append(create_context())
    return _CONTEXT[0]


def gl_version(ctx=None):
    """The OpenGL version the toolkit uses on ``ctx`` (the process context by
    default): the driver's ``version_code``, capped by ``BRDF_GL_VERSION``."""
    ctx = ctx or get_context()
    cap = version_cap()
    return ctx.version_code if cap is None else min(ctx.version_code, cap)


def compute_available(ctx=None):
    """True when compute shaders and std430 buffers may be used (OpenGL >= 4.3)."""
    return gl_version(ctx) >= COMPUTE_VERSION


def glsl_version(ctx=None):
    """``#version`` of the renderer's shaders: 430 on a 4.3 context, 330 below."""
    return 430 if compute_available(ctx) else 330


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
                                 f"it needs OpenGL {_version_text(REQUIRED_VERSION)}") from exc
    _CONTEXT.append(ctx)
    return ctx


def create_context():
    """A new headless moderngl context through EGL: OpenGL 4.3 if the driver
    offers it (and BRDF_GL_VERSION allows), else 3.3 core; GLUnavailableError
    naming the fix when neither can be made."""
    try:
        import moderngl
    except ImportError as exc:  # pragma: no cover - moderngl is a dependency
        raise GLUnavailableError(f"moderngl is not installed ({exc}); pip install moderngl") from exc
    cap = version_cap()
    wanted = [v for v in (PREFERRED_VERSION, REQUIRED_VERSION) if cap is None or v <= cap]
    errors = []
    for require in wanted:
        try:
            ctx = moderngl.create_standalone_context(backend="egl", require=require)
        except Exception as exc:  # noqa: BLE001 - glcontext raises plain Exception
            errors.append(f"{_version_text(require)}: {exc}")
            continue
        if ctx.version_code >= REQUIRED_VERSION:
            return ctx
        errors.append(f"{_version_text(require)}: the driver offers only {ctx.version_code}")
        ctx.release()
    raise GLUnavailableError(
        f"could not create a headless OpenGL {_version_text(REQUIRED_VERSION)} (or later) context "
        f"through EGL ({'; '.join(errors)}); {INSTALL_HINT}")


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


_CACHES = []


def gl_cache():
    """A new dict for GL objects a module keeps for the process (a value: a moderngl object,
    or a tuple holding some), emptied by :func:`release_cached`."""
    cache = {}
    _CACHES.append(cache)
    return cache


def release_cached():
    """Release every program and texture the toolkit keeps for the process; they are made
    again on next use.

    Mesa's llvmpipe keeps a linked program's compiled code (0.6-1.6 MB a program) and a
    MERL table's texture (17.5 MB) in this process's memory until released (moderngl frees
    nothing by itself): four test modules left 171 programs and five tables, 274 MiB
    (issue 62).  For a process that goes on to other work (the test suite between modules)."""
    for cache in _CACHES:
        for value in cache.values():
            for item in value if isinstance(value, tuple) else (value,):
                if hasattr(item, "release"):
                    item.release()
        cache.clear()


_PROGRAMS = gl_cache()
#: Programs compiled in this process, by kind ("compute", "render"): tests
#: check that a 3.3 context never made a compute shader.
PROGRAM_COUNTS = {"compute": 0, "render": 0}


def compute_program(source, line_map=None):
    """A compiled compute shader for ``source`` (cached by source text); needs OpenGL 4.3."""
    ctx = get_context()
    key = ("compute", source)
    if key not in _PROGRAMS:
        if not compute_available(ctx):
            raise GLUnavailableError(
                f"compute shaders need OpenGL {_version_text(COMPUTE_VERSION)}; this context is "
                f"{_version_text(gl_version(ctx))} (the renderer runs without them, the parity harness does not)")
        try:
            _PROGRAMS[key] = ctx.compute_shader(source)
        except Exception as exc:  # moderngl.Error
            raise ShaderCompileError(_annotate(str(exc), line_map)) from None
        PROGRAM_COUNTS["compute"] += 1
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
        PROGRAM_COUNTS["render"] += 1
    return _PROGRAMS[key]


def current_framebuffer(ctx):
    """The framebuffer bound now (the default one, id 0, when moderngl bound none).

    Offscreen renders bind it again before releasing their own: moderngl
    re-binds the last framebuffer it used after creating another, and a
    released one there is a GL_INVALID_OPERATION that a window toolkit
    checking glGetError (pyglet) reports much later.
    """
    return ctx.fbo if ctx.fbo is not None else ctx.detect_framebuffer(0)


def set_uniform(program, name, value):
    """Set a uniform if the program uses it (the compiler drops unused ones)."""
    member = program.get(name, None)
    if member is None:
        return False
    member.value = value
    return True
