"""A model of one's own in GLSL: where its ``glsl=`` goes in a program, and what a compile error says.

brdf/own.py states the contract: the source defines ``vec3 own_brdf(BrdfParams p,
vec3 wi, vec3 wo)``.  It fits the machinery of every model with three small steps:

- ``shaders.library.defines_for`` gives the spec ``BRDF_OWN_MODEL`` (and its
  ``BRDF_PARAM_<NAME>``), and ``struct_source`` generates its BrdfParams from its
  Params as for any model, without ``BRDF_PARAMS_DECLARED`` (that symbol selects
  the built-in terms' blocks, which an own model has none of);
- model.glsl declares ``own_brdf`` under ``BRDF_OWN_MODEL`` and makes it the
  spec's ``brdf_evaluate`` (0 below the horizon, as brdf.model.evaluate);
- ``shaders.library.build_source`` appends the source (``source``) after the
  whole program, so the declaration comes first and the user's code may call
  every library function.

Everything that compiles a spec's program (the renderer, the parity harness) then
works unchanged; ``compile_errors`` turns a failed compile of a program holding an
own model's source into one OwnModelError line naming the model, its file and the
line of its ``glsl``, instead of the driver's log of a generated shader.
"""

import contextlib
import re

from brdf.own import GLSL_SIGNATURE, OwnModelError

from .gl import ShaderCompileError

DEFINE = "BRDF_OWN_MODEL"
#: The line map's file name of the user's source (shaders.gl._annotate writes "glsl=:LINE").
SOURCE_NAME = "glsl="
MAX_ERRORS = 3          # driver messages quoted in the one line


def source(spec):
    """(text, line_map) of an own model's glsl= to append after a program, or ("", [])."""
    if spec is None or spec.own is None or spec.own.glsl is None:
        return "", []
    lines = spec.own.glsl.splitlines()
    return "\n".join(lines), [(SOURCE_NAME, i + 1) for i in range(len(lines))]


def _where(model):
    return f"{model.source[0]}: " if model.source else ""


_POSITION = re.compile(rf"{re.escape(SOURCE_NAME)}:(\d+)")


def error_message(model, log):
    """One line from the annotated driver ``log`` of a program holding ``model``'s glsl=:
    its error lines (those in the user's source first), positions as "line N of its glsl"."""
    errors = [line.strip() for line in log.splitlines() if "error" in line.lower() and ":" in line]
    mine = [line for line in errors if SOURCE_NAME + ":" in line]
    quoted = [_POSITION.sub(r"line \1 of its glsl", line) for line in (mine or errors)[:MAX_ERRORS]]
    what = "; ".join(quoted) if quoted else " ".join(log.split())[:300]
    hint = "" if mine else f" (its glsl must define {GLSL_SIGNATURE})"
    return f"{_where(model)}{model.name}: its glsl does not compile: {what}{hint}"


@contextlib.contextmanager
def compile_errors(spec):
    """Inside: a ShaderCompileError of a program made for ``spec`` becomes OwnModelError
    (error_message) when ``spec`` is a model of one's own; other errors pass unchanged."""
    try:
        yield
    except ShaderCompileError as err:
        if spec is None or spec.own is None:
            raise
        raise OwnModelError(error_message(spec.own, str(err))) from None
