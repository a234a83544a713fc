"""Reading a result file's JSON: the checks made before any field is looked at.

A fit result is a few kB of UTF-8 JSON.  ``read_result_json`` refuses, with a
``ResultFileError`` naming the file: a FIFO, device or socket (before opening
it: ``open`` of a FIFO waits for a writer forever), a folder, more than
MAX_RESULT_BYTES, bytes that are not UTF-8 (saying what the file looks like,
e.g. a PNG image), an empty file, invalid JSON, integers of more than
MAX_INT_DIGITS digits, JSON nested beyond Python's recursion limit, and an
object with a key twice (which value a reader takes is undefined).
``fitting.result.FitResult.load`` then validates the fields.
"""

import json
import os
import pathlib

MAX_RESULT_BYTES = 16 * 2**20   # a result is a few kB; anything this large is not one
MAX_INT_DIGITS = 40             # no result holds a longer integer


class ResultFileError(ValueError):
    """A result JSON that cannot be read (names the file and the problem)."""


def read_result_json(path: str | os.PathLike[str]) -> object:
    """The parsed JSON of the result file ``path`` (not yet validated as a result)."""
    path = pathlib.Path(path)
    text = _read_text(path)
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


def _read_text(path):
    """The file's text: at most MAX_RESULT_BYTES, UTF-8 (a BOM is skipped); a FIFO, device
    or socket is refused before it is opened (``open`` of a FIFO would wait forever)."""
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
