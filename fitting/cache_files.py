"""Cache files that say what they are: every file the fitter's caches read back is untrusted input.

The fitter keeps two kinds of files on disk: its traced programs (fitting/stored.py)
and JAX's compiled executables (the persistent compilation cache, fitting/_jax.py).
Both are found by a file name made from a hash, and both folders are meant to be
shared (a cluster's home, a synced folder): a file another program's entry was
copied onto, one a sync tool left half-written, or a flipped bit would otherwise
be run as the program asked for -- wrong numbers, or an exit deep in XLA.

So every such file is *sealed*: it holds, before its content, the whole key it was
written for (for a traced program: the program, its static arguments, its
arguments' tree, shapes and dtypes, the settings, the sources' hash and the JAX
version) and the SHA-256 digest of its content.  :func:`unseal` gives the content
back only when the key is the one asked for, byte for byte, and the digest checks;
anything else is a miss (the caller traces or compiles again, and says so on the
``fitting.cache`` logger at DEBUG level, which ``brdf-fit -v`` shows).  Files are
written to a temporary name and renamed, so a reader (another process filling the
same folder) sees a whole file or none.

Layout: ``MAGIC``, the key's length (4 bytes, little endian), the key (UTF-8), the
content's length (8 bytes), the content's SHA-256 (32 bytes), the content.
"""

import hashlib
import logging
import os
import pathlib
import tempfile

MAGIC = b"brdf-fit sealed cache file 1\n"
MAX_BYTES = 1 << 30          # no cache file of ours comes near 1 GiB: a larger one is not read
_LENGTHS = 4 + 8 + 32

log = logging.getLogger("fitting.cache")


def seal(key: str, content: bytes) -> bytes:
    """``content`` with the key it is stored under and its digest before it."""
    k = key.encode()
    return b"".join([MAGIC, len(k).to_bytes(4, "little"), k, len(content).to_bytes(8, "little"),
                     hashlib.sha256(content).digest(), content])


def unseal(data: bytes, key: str) -> tuple[bytes | None, str]:
    """(the content, "") if ``data`` is a sealed file of ``key`` whose digest checks, else (None, why not)."""
    k = key.encode()
    head = len(MAGIC)
    if not data.startswith(MAGIC):
        return None, "not a sealed cache file"
    if len(data) < head + _LENGTHS or int.from_bytes(data[head:head + 4], "little") != len(k):
        return None, "written for another key"
    if data[head + 4:head + 4 + len(k)] != k:
        return None, "written for another key"
    at = head + 4 + len(k)
    size = int.from_bytes(data[at:at + 8], "little")
    digest, content = data[at + 8:at + 40], data[at + 40:]
    if len(content) != size:
        return None, f"truncated or extended ({len(content)} bytes of content, {size} declared)"
    if hashlib.sha256(content).digest() != digest:
        return None, "its content does not match its digest"
    return content, ""


def sealed_key(data: bytes) -> str | None:
    """The key a sealed file says it was written for (None if it is not a sealed file)."""
    head = len(MAGIC)
    if not data.startswith(MAGIC) or len(data) < head + 4:
        return None
    size = int.from_bytes(data[head:head + 4], "little")
    try:
        return data[head + 4:head + 4 + size].decode()
    except UnicodeDecodeError:
        return None


def read(path: pathlib.Path, key: str, what: str) -> bytes | None:
    """The content of the sealed file ``path`` if it is ``key``'s, else None (a missing file
    silently, any other miss with a DEBUG line naming ``what`` and the reason)."""
    try:
        size = path.stat().st_size
        if size > MAX_BYTES:
            log.debug("%s %s not used: %d bytes, more than any cache file of ours", what, path, size)
            return None
        data = path.read_bytes()
    except FileNotFoundError:
        return None
    except (OSError, ValueError) as err:
        log.debug("%s %s not used: cannot be read (%s)", what, path, err)
        return None
    content, why = unseal(data, key)
    if content is None:
        log.debug("%s %s not used (%s): made again", what, path, why)
    return content


def write(path: pathlib.Path, key: str, content: bytes) -> bool:
    """Write ``content`` sealed with ``key`` to ``path`` atomically (a temporary file renamed);
    False, leaving nothing behind, where the folder cannot be written (read-only, full)."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".", suffix=".tmp")
    except OSError:
        return False
    try:
        with os.fdopen(fd, "wb") as out:
            out.write(seal(key, content))
        os.replace(tmp, path)
        return True
    except OSError as err:
        pathlib.Path(tmp).unlink(missing_ok=True)
        log.debug("%s not written (%s)", path, err)
        return False
