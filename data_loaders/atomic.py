"""The toolkit's one atomic file writer, and the temporary files it leaves behind.

``write_file_atomic`` writes a temporary file next to the target and renames
it over the target: a reader never sees half a file.  A process killed in
the middle of a write (SIGKILL, a power cut) leaves its temporary file; the
name says who wrote it, ``.NAME.HOST-PID.RANDOM.tmp``, so that a later run
(``stale_temp_files``) removes only those whose writer is gone -- never the
file another live process (a second batch into the same folder) is writing.
"""

import os
import pathlib
import re
import platform
import tempfile
import time

STALE_TEMP_SECONDS = 3600.0     # a temp file of another host (shared folder), or unnamed, this old is stale
_HOST_CHARS = re.compile(r"[^A-Za-z0-9_]+")
_TEMP_NAME = re.compile(r"^\.(?P<target>.+)\.(?P<host>[A-Za-z0-9_]*)-(?P<pid>\d+)\.[A-Za-z0-9_]+\.tmp$", re.S)


def _host() -> str:
    """This machine's name as it appears in temporary file names (letters, digits, _)."""
    return _HOST_CHARS.sub("_", platform.node())[:32]


def owner_tag() -> str:
    """``HOST-PID`` of this process, as temporary files and folders are tagged."""
    return f"{_host()}-{os.getpid()}"


def owner_gone(tag: str) -> bool:
    """Whether the writer a ``HOST-PID`` tag names is known to be gone (this host, dead pid)."""
    host, _, pid = tag.rpartition("-")
    return host == _host() and pid.isdigit() and not _alive(int(pid))


def write_file_atomic(path: str | os.PathLike[str], data: bytes | str) -> None:
    """Write ``data`` (bytes, or str as UTF-8) to ``path`` atomically; the toolkit's one writer.

    A temporary file in the same folder (``.NAME.HOST-PID.RANDOM.tmp``) is
    written, flushed and renamed over ``path``, so a reader (or a resumed
    batch) never sees half a file and an interrupted or failed write leaves
    nothing behind; missing folders are created.  The file gets the usual
    permissions (0666 minus the umask).  A failed write (a full disk, a
    read-only folder) raises an OSError of the same errno whose filename is
    ``path``: the message names the file the user asked for, not the
    temporary one.
    """
    path = os.fspath(path)
    if isinstance(data, str):
        data = data.encode("utf-8")
    folder = os.path.dirname(path) or "."
    os.makedirs(folder, exist_ok=True)
    tmp = None
    try:
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{os.path.basename(path)}.{owner_tag()}.",
                                   suffix=".tmp")
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fchmod(f.fileno(), 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException as err:
        if tmp is not None and os.path.lexists(tmp):
            os.remove(tmp)
        if isinstance(err, OSError):
            raise OSError(err.errno, err.strerror or str(err), path) from None
        raise


def stale_temp_files(folder: str | os.PathLike[str], now: float | None = None) -> list[pathlib.Path]:
    """The temporary files of ``write_file_atomic`` in ``folder`` that no live writer owns.

    One written on this host is stale when its process is gone; one written
    on another host (a folder shared with Dask workers), or named in an older
    way, when it is older than STALE_TEMP_SECONDS (no write takes that long).
    """
    now = time.time() if now is None else now
    host = _host()
    stale = []
    for p in pathlib.Path(folder).glob(".*.tmp"):
        found = _TEMP_NAME.match(p.name)
        if found and found["host"] == host:
            if not _alive(int(found["pid"])):
                stale.append(p)
            continue
        try:
            if now - p.lstat().st_mtime > STALE_TEMP_SECONDS:
                stale.append(p)
        except OSError:         # removed meanwhile
            continue
    return sorted(stale)


def _alive(pid: int) -> bool:
    """Whether a process ``pid`` exists on this machine."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:     # someone else's process
        return True
    except OSError:
        return False
    return True


def _umask():
    mask = os.umask(0o022)      # reading the umask means setting it; put it back at once
    os.umask(mask)
    return mask
