"""The toolkit's own error and warning types for measured-data files."""

import errno
import os
import stat
import typing
import warnings


class MeasuredDataError(Exception):
    """A measured-data file could not be read.

    The message always names the file and says what is wrong with it, so a
    command line can print it as is (no traceback needed).
    """

    def __init__(self, path: str | os.PathLike[str] | None, problem: str) -> None:
        self.path = os.fspath(path) if path is not None else "<memory>"
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")


class MeasuredDataWarning(UserWarning):
    """A measured-data file was read but its content looks implausible (all
    zeros, values far above any measured BRDF, directions that were not unit
    length). The message names the file and says what looks wrong, in one
    short sentence."""


def warn_data(path: str | os.PathLike[str] | None, problem: str, stacklevel: int = 2) -> None:
    """Emit a :class:`MeasuredDataWarning` ``"{path}: {problem}"``.

    ``stacklevel`` counts from the caller of this function (2 = the caller's caller).
    """
    path = os.fspath(path) if path is not None else "<memory>"
    warnings.warn(MeasuredDataWarning(f"{path}: {problem}"), stacklevel=stacklevel + 1)


# The first bytes of file types that are often given by mistake, and what they are.
FILE_SIGNATURES = ((b"\x89PNG\r\n\x1a\n", "a PNG image"), (b"glTF", "a binary glTF (.glb)"),
                   (b"\x1f\x8b", "gzip-compressed"), (b"PK\x03\x04", "a zip / .npz archive"),
                   (b"\x93NUMPY", "a .npy array"), (b"#?RADIANCE", "a Radiance .hdr image"),
                   (b"\xff\xd8\xff", "a JPEG image"), (b"%PDF-", "a PDF document"),
                   (b"\x7fELF", "an executable (ELF)"))


def looks_like(head: bytes) -> str | None:
    """What the bytes ``head`` (a file's start) look like ("a PNG image", ...), or None."""
    return next((name for magic, name in FILE_SIGNATURES if head.startswith(magic)), None)


def special_file_kind(mode: int) -> str | None:
    """What a file that is not a regular file is, from its ``st_mode`` ("a FIFO (named
    pipe)", "a character device", ...); None for a regular file.  Opening a FIFO
    blocks until a writer comes, reading a device may never end: readers refuse them."""
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "a directory"
    for test, name in ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a regular file"


def require_file(path: str | os.PathLike[str], kind: str = "measured-data file") -> str:
    """``path`` as a str if it names an existing regular file; else MeasuredDataError
    ("no such file", "is a symbolic link to .., which does not exist", "is a symbolic link loop",
    "is a directory, not a KIND", "is a FIFO (named pipe), not a KIND").

    Checked with ``os.stat``, which never blocks: a FIFO, a device or a socket
    is refused before anything opens it (``open`` of a FIFO would wait for a
    writer forever).
    """
    path = os.fspath(path)
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        raise MeasuredDataError(path, _link_problem(path) or "no such file") from None
    except (OSError, ValueError) as e:    # ValueError: an embedded NUL byte
        if getattr(e, "errno", None) == errno.ELOOP:
            raise MeasuredDataError(path, "is a symbolic link loop (it never reaches a file)") from None
        raise MeasuredDataError(path, f"cannot read the file ({getattr(e, 'strerror', None) or e})") from None
    special = special_file_kind(mode)
    if special is not None:
        raise MeasuredDataError(path, f"is {special}, not a {kind}")
    return path


def _link_problem(path: str) -> str | None:
    """For a path that names no file: what a symbolic link there points to, or None."""
    try:
        target = os.readlink(path)
    except (OSError, ValueError):
        return None
    return f"is a symbolic link to {target!r}, which does not exist"


def open_regular(path: str | os.PathLike[str]) -> typing.BinaryIO:
    """``open(path, "rb")`` of a regular file, never blocking on a FIFO: the file is
    opened with O_NONBLOCK (which returns at once for a FIFO), checked with
    ``fstat`` and only then read in blocking mode.  Raises OSError like ``open``;
    for a special file (even one swapped in after ``require_file``), an OSError
    whose strerror says what it is (EINVAL, "is a FIFO (named pipe), not a regular file")."""
    path = os.fspath(path)
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    try:
        special = special_file_kind(os.fstat(fd).st_mode)
        if special is not None:
            import errno
            raise OSError(errno.EINVAL, f"is {special}, not a regular file", path)
        os.set_blocking(fd, True)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise
