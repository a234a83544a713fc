"""Models of one's own on the command line (brdf/own.py, docs/models.md).

``--model PATH.py:NAME`` (in any --model / --models list) and ``--model-file
PATH.py`` are the only ways the command line imports a user's file: because
the user named it.  A result file that names a model file is refused until the
file is given so (``brdf.own.check_source``), never imported from the data.
"""

import re

from brdf import own

# PATH.py:NAME in a model list (a Windows drive's colon is before the path's end)
_FILE_MODEL = re.compile(r"^(?P<path>.+\.py):(?P<name>[A-Za-z_][A-Za-z0-9_]*)$")


def load_named(args) -> list[tuple[str, bytes]]:
    """Load the files ``args`` names (--model-file, PATH.py:NAME entries of --model /
    --models, which become own:MODEL), registering their models; returns the loaded
    files as (file name, bytes) (a batch's tasks carry them: ``brdf.own.files_of``).
    OwnModelError (a ValueError: one line, exit 2) for a file or name that cannot be used."""
    loaded = {}
    for path in getattr(args, "model_file", None) or []:
        data = own.read_file(path)
        models = own.load_bytes(path, data)
        loaded[models[0].source[1]] = (models[0].source[0], data)
    for attribute in ("model", "models"):
        text = getattr(args, attribute, None)
        if not isinstance(text, str) or ".py:" not in text:
            continue
        items = []
        for item in text.split(","):
            match = _FILE_MODEL.match(item.strip())
            if match:
                data = own.read_file(match["path"])
                model = own.load_bytes(match["path"], data, match["name"])
                loaded[model.source[1]] = (model.source[0], data)
                item = model.model_string
            items.append(item)
        setattr(args, attribute, ",".join(items))
    return list(loaded.values())
