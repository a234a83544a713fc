"""Reading a result file's JSON: the checks made before any field is looked at.

A fit result is a few kB of UTF-8 JSON.  ``read_result_json`` refuses, with a
``ResultFileError`` naming the file: a FIFO, device or socket (before opening
it: ``open`` of a FIFO waits for a writer forever), a folder, more than
MAX_RESULT_BYTES (checked before the file is read), bytes that are not UTF-8
(saying what the file looks like, e.g. a PNG image), an empty file, invalid
JSON, integers of more than MAX_INT_DIGITS digits, JSON nested beyond Python's
recursion limit, and an object with a key twice (which value a reader takes
is undefined).  ``fitting.result.FitResult.load`` then validates the fields,
first their sizes (``check_sizes``: a string or list beyond its kind's cap,
e.g. a 10 MB material name, is refused naming the field).
"""

import json
import os
import pathlib
from collections.abc import Callable

MAX_RESULT_BYTES = 2**20     # a result is 2-20 kB (64 starts' runs included); anything this large is not one
MAX_INT_DIGITS = 40             # no result holds a longer integer

# Caps on the fields, checked by ``check_sizes`` (``FitResult.from_dict``) before a field is
# used: a command that shows a 10 MB name in a plot title takes minutes and gigabytes.
MAX_NAME_CHARS = 255    # a name: model strings, format, loss, optimizer, version, timestamp,
                        # digest -- and every object key
MAX_MATERIAL_CHARS = 1024   # provenance.material: a file name (at most NAME_MAX = 255 bytes) or a
                            # file's own `# material:` line, which may be longer; a fit keeps the
                            # first MAX_MATERIAL_CHARS of a longer one (fitting.fit), so that every
                            # result it writes is one this reader takes
MAX_PATH_CHARS = 4096   # provenance.file, model_file.path: PATH_MAX, the longest path Linux
                        # opens (and none of its parts longer than a name, MAX_NAME_CHARS)
MAX_TEXT_CHARS = 1024   # any other string (option values; fields a newer toolkit may add)
MAX_ITEMS = 1024        # entries of a list or object: optimizer.runs holds one per start (at
                        # most 64) and a few stages; parameters and errors a dozen
PATH_FIELDS = frozenset({"file", "path"})      # provenance.file, model_file.path
NAME_FIELDS = frozenset({"spec", "format", "sha256", "loss_name", "exported_model", "name",
                         "toolkit_version", "created", "loss", "optimizer"})


class ResultFileError(ValueError):
    """A result JSON that cannot be read (names the file and the problem)."""


def read_result_json(path: str | os.PathLike[str]) -> object:
    """The parsed JSON of the result file ``path`` (not yet validated as a result)."""
    path = pathlib.Path(path)
    return parse_json(read_text(path), path)


def parse_json(text: str, path: str | os.PathLike[str]) -> object:
    """``text`` (read from ``path``, named in the errors) parsed as JSON, refusing what
    ``read_result_json`` refuses: empty text, invalid JSON, oversized integers, deep
    nesting and duplicate keys (ResultFileError).  A batch's screening records are read
    through it too (brdf_fit/batch/screening_record.py)."""
    if not text.strip():
        raise ResultFileError(f"{path}: the file is empty (a fit result is a JSON object)")
    try:
        return json.loads(text, parse_int=_parse_int, object_pairs_hook=_unique_keys)
    except _DuplicateKey as err:
        raise ResultFileError(f"{path}: {err}; which value counts is undefined, refusing the file") from None
    except json.JSONDecodeError as err:
        raise ResultFileError(f"{path}: not valid JSON ({err.msg}, line {err.lineno} "
                              f"column {err.colno})") from None
    except RecursionError:
        raise ResultFileError(f"{path}: JSON nested too deeply to be a fit result") from None
    except ValueError as err:      # _parse_int's refusal
        raise ResultFileError(f"{path}: not valid JSON ({_short(err, 120)})") from None


def read_text(path: str | os.PathLike[str]) -> str:
    """The file's text: at most MAX_RESULT_BYTES, UTF-8 (a BOM is skipped); a FIFO, device
    or socket is refused before it is opened (``open`` of a FIFO would wait forever).
    ResultFileError otherwise.  Also reads a batch's other small JSON files (its
    screening records, brdf_fit/batch/screening_record.py)."""
    from data_loaders.errors import looks_like, open_regular, special_file_kind
    try:
        special = special_file_kind(os.stat(path).st_mode)
    except OSError as err:
        raise ResultFileError(f"{path}: cannot read ({err.strerror or err})") from None
    if special == "a directory":
        raise ResultFileError(f"{path}: is a folder, not a fit result file")
    if special is not None:
        raise ResultFileError(f"{path}: is {special}, not a fit result file")
    try:
        with open_regular(path) as f:
            size = os.fstat(f.fileno()).st_size
            if size > MAX_RESULT_BYTES:
                raise ResultFileError(f"{path}: {size:,} bytes is too large for a fit result "
                                      f"(at most {MAX_RESULT_BYTES // 2**20} MiB)")
            raw = f.read(MAX_RESULT_BYTES + 1)
    except OSError as err:
        raise ResultFileError(f"{path}: cannot read ({err.strerror or err})") from None
    if len(raw) > MAX_RESULT_BYTES:
        raise ResultFileError(f"{path}: more than {MAX_RESULT_BYTES:,} bytes, too large for a fit result")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        looks = f" (it looks like {looks_like(raw)})" if looks_like(raw) else ""
        raise ResultFileError(f"{path}: not a text file{looks}: byte 0x{raw[err.start]:02x} at offset "
                              f"{err.start} is not UTF-8; a fit result is a JSON text file") from None
    return text[1:] if text.startswith("\ufeff") else text


def check_sizes(data: object, bad: Callable[[str], Exception]) -> None:
    """Refuse a string longer than its kind's cap (MAX_NAME_CHARS, MAX_MATERIAL_CHARS,
    MAX_PATH_CHARS, MAX_TEXT_CHARS; keys are names) or a list or object of more than MAX_ITEMS entries,
    anywhere in ``data``: ``raise bad(message naming the field)``.  Iterative."""
    def where(keys):
        text = "".join(f"[{k}]" if isinstance(k, int) else f".{_short(k, 40)}" for k in keys)
        return text.lstrip(".") or "the value"

    stack = [((), data)]
    while stack:
        keys, value = stack.pop()
        if isinstance(value, str):
            field = next((k for k in reversed(keys) if isinstance(k, str)), "")
            cap, kind = ((MAX_PATH_CHARS, "a file path") if field in PATH_FIELDS else
                         (MAX_MATERIAL_CHARS, "a material name") if field == "material" else
                         (MAX_NAME_CHARS, "a name") if field in NAME_FIELDS else
                         (MAX_TEXT_CHARS, "a text field"))
            if len(value) > cap:
                raise bad(f"{where(keys)} is {len(value):,} characters long, more than the {cap:,} "
                          f"of {kind} in a fit result")
            longest = max(map(len, value.replace("\\", "/").split("/"))) if field in PATH_FIELDS else 0
            if longest > MAX_NAME_CHARS:
                raise bad(f"{where(keys)} has a folder or file name of {longest:,} characters, more "
                          f"than the {MAX_NAME_CHARS} any file system allows")
        elif isinstance(value, (dict, list)):
            if len(value) > MAX_ITEMS:
                raise bad(f"{where(keys)} holds {len(value):,} entries, more than the {MAX_ITEMS:,} "
                          "of any list or object in a fit result")
            if isinstance(value, dict):
                for key in value:
                    if len(key) > MAX_NAME_CHARS:
                        raise bad(f"{where(keys)} has a key of {len(key):,} characters, more than "
                                  f"the {MAX_NAME_CHARS} of a name in a fit result")
                stack.extend(((*keys, k), v) for k, v in value.items())
            else:
                stack.extend(((*keys, i), v) for i, v in enumerate(value))


class _DuplicateKey(ValueError):
    pass


def _unique_keys(pairs):
    """json's object hook: a dict, refusing a key that appears twice in one object."""
    data = dict(pairs)
    if len(data) != len(pairs):
        seen = set()
        key = next(k for k, _ in pairs if k in seen or seen.add(k))
        raise _DuplicateKey(f"the key {_short(key, 40)!r} appears twice in one object")
    return data


def _parse_int(text):
    """json's int parser, refusing numbers longer than MAX_INT_DIGITS digits (no result has one)."""
    if len(text) > MAX_INT_DIGITS:
        raise ValueError(f"an integer of {len(text):,} digits")
    return int(text)


def _short(text, limit):
    text = str(text)
    return text if len(text) <= limit else text[:limit - 3] + "..."
