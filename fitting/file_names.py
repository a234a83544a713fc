"""Material names, which come from the files' own bytes, made into safe file-name stems.

A CSV header ``# material: ../../x``, an NPZ ``material`` array or a file
name decides what a result file is called.  That name is data: ``safe_stem``
turns it into one path component that stays in the output folder, whatever
it holds.  Commands that name files after a material call it and say so on
stderr when the name was changed.
"""

import re
import unicodedata

MAX_STEM_BYTES = 100        # UTF-8 bytes; a file name may have 255, the model and suffix follow
FALLBACK_STEM = "material"

_SEPARATORS = re.compile(r"[/\\]+")
_DOTS = re.compile(r"\.{2,}")


def _unsafe(char: str) -> bool:
    """Control and format characters (NUL, newlines, bidi overrides), and lone
    surrogates (bytes that were not UTF-8 in a file name)."""
    return unicodedata.category(char) in ("Cc", "Cf", "Cs")


def safe_stem(name: object, fallback: str = FALLBACK_STEM) -> str:
    """``name`` as a file-name stem that cannot leave its folder nor hide.

    Path separators (``/``, ``\\``) and control, format and surrogate
    characters become ``_``; runs of dots become one dot; leading and
    trailing dots and spaces are removed; the result is cut to
    MAX_STEM_BYTES of UTF-8 (at a character boundary).  An empty result is
    ``fallback``.  A name that is already safe comes back unchanged, so
    ``safe_stem(name) != name`` tells a caller that it changed something.
    """
    text = str(name)
    text = "".join("_" if _unsafe(c) else c for c in text)
    text = _SEPARATORS.sub("_", text)
    text = _DOTS.sub(".", text)
    text = text.strip(" .")
    encoded = text.encode("utf-8")
    if len(encoded) > MAX_STEM_BYTES:
        text = encoded[:MAX_STEM_BYTES].decode("utf-8", "ignore")
    text = text.rstrip(" .")
    return text or fallback


def describe_renaming(name: str, stem: str) -> str:
    """The note a command prints when ``safe_stem`` changed a material name."""
    shown = repr(name) if len(name) <= 60 else repr(name[:57]) + "..."
    return f"material name {shown} is not a safe file name; its results are named {stem!r}"
