"""The standard streams of ``brdf-fit``: closed, cut short, or unable to show a name.

What a command does, as the standard Unix tools do:

- stdout (or stderr) closed at start (``brdf-fit fit F --json --out OUT >&-``):
  the closed descriptor is reopened on /dev/null before anything else, so the
  command runs as with ``>/dev/null``: results are still written to --out,
  what it would print is discarded, and the exit status is the command's own
  (0 when it worked).  Reopening also keeps a file the command opens from
  taking descriptor 1 and receiving the command's output.  (coreutils print
  ``write error: Bad file descriptor`` and exit 1 here; a closed stream means
  "no output wanted", and nothing is lost but what was not wanted.)
- a reader that stops early (``brdf-fit info --json F | head -c 1``): the
  write that meets the closed pipe (EPIPE) ends the command at once, without
  a message, with exit status OUTPUT_CLOSED = 141 = 128 + SIGPIPE: what a
  shell shows for coreutils, which SIGPIPE ends (``seq 1 100000 | head -1``),
  in the way brdf-fit already answers SIGINT (130) and SIGTERM (143).  Python
  ignores SIGPIPE (so a Dask socket or a worker's pipe going away cannot kill
  a batch); the EPIPE of stdout or stderr is recognised instead
  (``output_closed``).  Results written before stay on disk.
- a stream whose encoding cannot show a character (``PYTHONIOENCODING=ascii``,
  a C locale): the character is written as a backslash escape
  (``g\\xf6\\xf6d.npz``), never a codec error.

This module imports nothing heavy: the command line uses it first.
"""

import errno
import os
import sys

from .errors import OUTPUT_CLOSED


def prepare_streams() -> None:
    """Reopen closed descriptors 0, 1, 2 on /dev/null (and give Python stream objects for
    them), and have stdout and stderr write characters their encoding lacks as escapes."""
    for fd in (0, 1, 2):
        try:
            os.fstat(fd)
        except OSError:
            _to_devnull(fd)
    for name, fd, mode in (("stdin", 0, "r"), ("stdout", 1, "w"), ("stderr", 2, "w")):
        if getattr(sys, name) is None:
            setattr(sys, name, open(fd, mode, closefd=False, errors="backslashreplace"))
    for stream in (sys.stdout, sys.stderr):
        reconfigure = getattr(stream, "reconfigure", None)
        if reconfigure is not None and getattr(stream, "errors", None) != "backslashreplace":
            try:
                reconfigure(errors="backslashreplace")
            except (ValueError, OSError):      # not a text stream we may change: leave it
                pass


def output_closed(err: BaseException) -> bool:
    """True if ``err`` is the EPIPE of stdout or stderr, whose reader has gone."""
    if not isinstance(err, OSError) or err.errno != errno.EPIPE:
        return False
    return any(_reader_gone(fd) for fd in (1, 2))


def end_quietly(everything: bool = False) -> int:
    """After ``output_closed``: point the closed streams (with ``everything``, stdout in
    any case) at /dev/null, where what is still buffered is dropped silently when Python
    flushes at exit; returns OUTPUT_CLOSED."""
    for fd in (1, 2):
        if _reader_gone(fd) or (everything and fd == 1):
            _to_devnull(fd)
    return OUTPUT_CLOSED


def _reader_gone(fd):
    """Whether ``fd`` is a pipe or socket whose reading end is closed (poll says POLLERR)."""
    try:
        import select
        poller = select.poll()
        poller.register(fd, select.POLLOUT)
        return any(events & (select.POLLERR | select.POLLHUP) for _, events in poller.poll(0))
    except (ImportError, AttributeError):      # no poll() here: the EPIPE says enough
        return True
    except (OSError, ValueError):
        return False


def _to_devnull(fd):
    null = os.open(os.devnull, os.O_RDWR)
    if null != fd:
        os.dup2(null, fd)
        os.close(null)
