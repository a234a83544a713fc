"""Exit codes, the one-line error printer and output-path checks of ``brdf-fit``.

Every command reports a problem with its input as one line on stderr,
``brdf-fit COMMAND: error: MESSAGE`` (the message names the file), and exits
with ``BAD_INPUT``; never a traceback.  This module imports nothing heavy, so
the command line can use it before JAX is loaded.
"""

import errno
import os
import pathlib
import sys
from collections.abc import Iterable

OK = 0
FAILED = 1          # an internal error (a bug): one line, and BRDF_DEBUG=1 for the traceback
BAD_INPUT = 2       # bad input or an output that cannot be written
NO_GL = 3           # no OpenGL driver / no display
INTERRUPTED = 130   # Ctrl-C (128 + SIGINT)
OUTPUT_CLOSED = 141  # the reader of stdout went away (``| head``): 128 + SIGPIPE, silently (streams.py)
TERMINATED = 143    # SIGTERM (128 + 15)

MAX_MESSAGE = 400   # characters; longer messages (a 100 000-character model string) are cut
MAX_SHOWN_PATH = 240  # characters of a file name in a message; the middle of a longer one is cut,
                      # so that the reason after it still fits in MAX_MESSAGE

CWD_GONE = ("the working directory no longer exists (deleted or moved since the shell entered it); "
            "cd to an existing folder, or give absolute paths")


class InputError(ValueError):
    """Bad input or options given to a command (the message names the file or option)."""


def shorten(text: object, limit: int = 80) -> str:
    """``text`` cut to ``limit`` characters with an ellipsis (for echoing user input)."""
    text = str(text)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def one_line(message: object) -> str:
    """A message as one line of at most MAX_MESSAGE characters: its line breaks and runs of
    white space one space, then ``printable`` (bytes of a file name that are not UTF-8 and
    control characters shown as escapes)."""
    text = os.fspath(message) if isinstance(message, os.PathLike) else str(message)
    return shorten(printable(" ".join(text.split())), MAX_MESSAGE)


def fail(command: str, message: object, code: int = BAD_INPUT) -> int:
    """Print ``brdf-fit COMMAND: error: MESSAGE`` on stderr (one line); return ``code``."""
    _to_stderr(f"{_prog(command)}: error: {one_line(message)}")
    return code


def warn(command: str, message: object) -> None:
    """One warning line on stderr; the command goes on."""
    _to_stderr(f"{_prog(command)}: warning: {one_line(message)}")


def _prog(command):
    return f"brdf-fit {command}" if command else "brdf-fit"


def _to_stderr(line):
    try:
        print(line, file=sys.stderr, flush=True)
    except OSError:     # stderr closed or its reader gone: there is no one to tell
        pass


def shorten_path(path: object, limit: int = MAX_SHOWN_PATH) -> str:
    """A file name for a message: at most ``limit`` characters, the middle cut ("/a/b...z.json")."""
    text = printable(path)
    if len(text) <= limit:
        return text
    keep = limit - 3
    return text[:keep - keep // 3] + "..." + text[len(text) - keep // 3:]


def os_error_message(err: OSError, path: str | os.PathLike[str] | None = None) -> str:
    """'PATH: No space left on device' from an OSError (a very long PATH shortened, so the
    reason is always seen); CWD_GONE when the working directory was deleted."""
    where = path if path is not None else (err.filename or "")
    reason = err.strerror or str(err)
    relative = not isinstance(where, (str, bytes, os.PathLike)) or not os.path.isabs(where)
    if err.errno == errno.ENOENT and relative and cwd_gone():
        return f"{shorten_path(where)}: {CWD_GONE}" if where else CWD_GONE
    return f"{shorten_path(where)}: {reason}" if where else reason


def is_file_here(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` (a name read from a file, e.g. a result's provenance) is a file
    here; False, not an exception, for a name no file system accepts (too long, a NUL)."""
    try:
        return pathlib.Path(path).is_file()
    except (OSError, ValueError):
        return False


def cwd_gone() -> bool:
    """True if the working directory has been deleted (relative paths mean nothing then)."""
    try:
        os.getcwd()
    except FileNotFoundError:
        return True
    except OSError:
        return False
    return False


# Characters a terminal acts on or that disguise a name, shown as escapes: C0 controls (ESC
# starts a colour or cursor sequence, a newline splits a one-line message), DEL, C1 controls,
# and the bidirectional overrides and isolates (a name shown backwards).
_ESCAPED = {c: f"\\x{c:02x}" for c in (*range(0x20), 0x7F, *range(0x80, 0xA0))}
_ESCAPED.update({c: f"\\u{c:04x}" for c in (*range(0x202A, 0x202F), *range(0x2066, 0x206A))})


def printable(text: object) -> str:
    """``text`` (a path) as UTF-8-safe text for a terminal or a file: bytes of a file name
    that are not UTF-8 (``os.fsdecode``'s surrogates) shown as ``\\xff`` escapes, control
    characters and bidirectional overrides as ``\\x1b`` / ``\\u202e`` escapes (summary.csv,
    messages)."""
    text = os.fspath(text) if isinstance(text, os.PathLike) else str(text)
    try:
        text = os.fsencode(text).decode("utf-8", "backslashreplace")
    except UnicodeError:        # a surrogate that did not come from a file name
        text = text.encode("utf-8", "backslashreplace").decode("utf-8")
    return text.translate(_ESCAPED)


def alternatives(items: Iterable[str]) -> str:
    """".gltf, .glb or .mtlx" from (".gltf", ".glb", ".mtlx")."""
    items = list(items)
    return " or ".join(items) if len(items) <= 2 else ", ".join(items[:-1]) + " or " + items[-1]


def check_output_file(path: str | os.PathLike[str], suffixes: Iterable[str],
                      inputs: Iterable[str | os.PathLike[str]] = (), option: str = "--out") -> pathlib.Path:
    """An output file path that can be written: returns a pathlib.Path or raises InputError.

    The suffix must be one of ``suffixes`` (e.g. (".png",)); the path must not
    be one of the ``inputs`` (never overwrite what the command reads) nor a
    folder; missing parent folders are fine (the writer creates them), a
    parent that is a file or not writable is refused, and so is an empty path
    (``option`` names it).  Creates nothing, so a command that then fails on
    its input leaves nothing behind.
    """
    if not os.fspath(path):
        raise InputError(f"{option} is empty; give a file name ending in {alternatives(suffixes)}")
    path = pathlib.Path(path)
    suffixes = tuple(suffixes)
    if suffixes and path.suffix.lower() not in suffixes:
        raise InputError(f"{path}: the output must end in {alternatives(suffixes)}")
    if path.is_dir():
        raise InputError(f"{path}: is a folder; give a file name ending in {alternatives(suffixes)}")
    for item in inputs:
        if item is not None and _same_file(path, item):
            raise InputError(f"{path}: is an input of this command; refusing to overwrite it")
    check_output_folder(path.parent)
    return path


def check_output_folder(folder: str | os.PathLike[str], option: str = "--out") -> pathlib.Path:
    """A folder that can be written into or created: returns a pathlib.Path or raises InputError.

    The nearest existing folder on the path must be a writable folder (not a
    file); an empty path (which would mean the current folder) is refused,
    naming ``option``.  Creates nothing.
    """
    if not os.fspath(folder):
        raise InputError(f"{option} is empty; give a folder (e.g. {option} results; "
                         f"{option} . for the current folder)")
    folder = pathlib.Path(folder)
    for parent in [folder, *folder.parents]:
        if parent.exists() or parent.is_symlink():
            if not parent.is_dir():
                what = "is a file, not a folder" if parent == folder else f"{parent} is a file, not a folder"
                raise InputError(f"{folder}: {what}")
            if not os.access(parent, os.W_OK | os.X_OK):
                raise InputError(f"{folder}: {parent} is not writable")
            break
    return folder


def _same_file(a, b):
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.abspath(a) == os.path.abspath(b)
