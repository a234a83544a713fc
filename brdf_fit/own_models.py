"""Models of one's own on the command line (brdf/own.py, docs/models.md).

``--model PATH.py:NAME`` (in any --model / --models list) and ``--model-file
PATH.py`` are the only ways the command line imports a user's file: because
the user named it.  A result file that names a model file is refused until the
file is given so (``brdf.own.check_source``), never imported from the data.

A model list is split at its commas; a path that holds a comma is still one item
when the text up to ``.py:NAME`` names an existing file (``a,b/m.py:X`` with a
folder ``a,b``); otherwise give such a file with ``--model-file`` and name its
model ``own:NAME`` in the list.  Two files that declare the same ``own:NAME``
are refused, naming both: a result is never attributed to the other file.  The
glsl= of an own model in a list of models to fit is compiled first (``check_glsl``).
"""

import pathlib
import re

from brdf import own

# PATH.py:NAME in a model list (a Windows drive's colon is before the path's end)
_FILE_MODEL = re.compile(r"^(?P<path>.+\.py):(?P<name>[A-Za-z_][A-Za-z0-9_]*)$")


def load_named(args) -> list[tuple[str, bytes]]:
    """Load the files ``args`` names (--model-file, PATH.py:NAME entries of --model /
    --models, which become own:MODEL), registering their models under the paths as typed
    (a result records them: ``OwnModel.path``); returns the loaded files as (path, bytes)
    (as a batch's tasks carry them: ``brdf.own.files_of``).
    OwnModelError (a ValueError: one line, exit 2) for a file or name that cannot be used,
    and for two files declaring one model name."""
    loaded, declared = {}, {}

    def keep(path, data, models):
        for model in models:
            other = declared.setdefault(model.name, (str(path), model.source[1]))
            if other[1] != model.source[1]:
                raise own.OwnModelError(f"{model.model_string} is declared in two model files, {other[0]} and "
                                        f"{path}: rename one of the models (a result names its model by "
                                        "own:NAME, so one of the two fits would be lost)")
        loaded[models[0].source[1]] = (models[0].path, data)

    for path in getattr(args, "model_file", None) or []:
        data = own.read_file(path)
        keep(path, data, own.load_bytes(path, data))
    for attribute in ("model", "models"):
        text = getattr(args, attribute, None)
        if not isinstance(text, str) or ".py:" not in text:
            continue
        items = []
        for item in split_models(text):
            match = _FILE_MODEL.match(item.strip())
            if match:
                data = own.read_file(match["path"])
                model = own.load_bytes(match["path"], data, match["name"])
                keep(match["path"], data, [model])
                item = model.model_string
            items.append(item)
        setattr(args, attribute, ",".join(items))
    known = {model.model_string: model for model in own.registered()}
    for attribute in ("model", "models"):       # the models to fit: their glsl= compiles, or exit 2 now
        text = getattr(args, attribute, None)
        if isinstance(text, str):
            check_glsl([known[item.strip()] for item in split_models(text) if item.strip() in known])
    return list(loaded.values())


def check_glsl(models) -> None:
    """Compile the glsl= of each of ``models`` (OwnModel) as the preview renderer will
    (``shaders.render.check_program``): OwnModelError (one line: the file, the model, the
    line of its glsl) when it does not compile, caught before a fit rather than at the
    report.  Without OpenGL here nothing is checked (the renderer cannot run either)."""
    todo = [m for m in models if m.glsl is not None]
    if not todo:
        return
    try:
        from shaders.gl import GLUnavailableError, gl_available
        from shaders.render import check_program
    except Exception:  # noqa: BLE001 -- no renderer here (moderngl missing or failing to load)
        return
    if not gl_available()[0]:
        return
    for model in todo:
        try:
            check_program(model)
        except GLUnavailableError:
            return


def split_models(text: str) -> list[str]:
    """The items of a model list: split at commas, but the longest run of pieces that reads
    ``PATH.py:NAME`` with PATH an existing file is one item (a folder named ``a,b``)."""
    pieces, out, i = text.split(","), [], 0
    while i < len(pieces):
        for j in range(len(pieces), i + 1, -1):       # longest first; a single piece is the default
            match = _FILE_MODEL.match(",".join(pieces[i:j]).strip())
            if match and _is_file(match["path"]):
                out.append(",".join(pieces[i:j]))
                i = j
                break
        else:
            out.append(pieces[i])
            i += 1
    return out


def _is_file(path: str) -> bool:
    try:
        return pathlib.Path(path).is_file()
    except (OSError, ValueError):
        return False
