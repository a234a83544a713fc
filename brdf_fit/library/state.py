"""What the library wrote for each material, so that the same command repairs what is missing.

``LIB/.library-state.json`` holds, for each material's page, the digest of the results
it was made from (brdf_fit.library.build) and the size of every file written for it
(its page, its spheres, its .glb and .mtlx, its viewer data).  A material's files are
written again when its results changed, or when one of those files is gone or is not
the size it was written at (a truncated copy, a file emptied): one ``stat`` a file,
no file read, so checking a library of thousands of materials costs next to nothing.
A file that was never written (no spheres without the measured table, no viewer data
without three.js) is not expected: a run does not write that material again for it.
"""

import json
import os
import pathlib

from fitting.result import atomic_write_text

from .material import library_files

STATE_NAME = ".library-state.json"      # {material page: {"digest": ..., "files": {path: bytes}}}


def material_files(stem: str) -> list[str]:
    """Every file the library may write for the material ``stem``, relative to the library."""
    return [*library_files(stem).values(), f"materials/{stem}-viewer-data.js"]


def read_state(out_dir: str | os.PathLike[str]) -> dict:
    """The state of the library in ``out_dir`` ({} when absent or unreadable)."""
    try:
        state = json.loads((pathlib.Path(out_dir) / STATE_NAME).read_text(encoding="utf-8"))
        return state if isinstance(state, dict) else {}
    except (OSError, ValueError):
        return {}


def write_state(out_dir: str | os.PathLike[str], state: dict) -> None:
    atomic_write_text(pathlib.Path(out_dir) / STATE_NAME, json.dumps(state, indent=1, sort_keys=True))


def written(out_dir: str | os.PathLike[str], stem: str, digest: str) -> dict:
    """The state entry of a material whose files were just written from results of ``digest``."""
    out_dir = pathlib.Path(out_dir)
    files = {}
    for name in material_files(stem):
        try:
            files[name] = (out_dir / name).stat().st_size
        except OSError:
            continue
    return {"digest": digest, "files": files}


def current(entry: object, digest: str, out_dir: str | os.PathLike[str], stem: str) -> bool:
    """Whether a material's state ``entry`` is of results ``digest`` and every file it
    names (its page, .glb and .mtlx at least) is there, at the size it was written."""
    if not isinstance(entry, dict) or entry.get("digest") != digest or not isinstance(entry.get("files"), dict):
        return False
    files = library_files(stem)
    if not all(files[k] in entry["files"] for k in ("page", "glb", "mtlx")):
        return False
    out_dir = pathlib.Path(out_dir)
    for name, size in entry["files"].items():
        try:
            if (out_dir / name).stat().st_size != size:
                return False
        except OSError:
            return False
    return True
