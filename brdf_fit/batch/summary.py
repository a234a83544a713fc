"""summary.csv: a row for every result file in a batch's output folder, and the errors.

The summary is rebuilt from the folder each time it is written, under a lock
file (``.summary.lock``, ``fcntl.flock``), and written atomically: two batches
running into one folder, a batch killed between two writes, a result written
by a worker whose parent was then terminated -- the next write lists every
result in the folder, whoever wrote it.  Rows:

- this run's rows for its inputs (``fitted``, ``resumed``, ``error: ...``,
  ``cut: ...``);
- results that were in the folder when the run began: ``earlier``;
- results that appeared since, written by another process (a concurrent
  batch): the status that process gave them, else ``fitted``;
- error, cut and screened rows of other runs, for inputs this run does not touch.

A full disk: when the atomic write cannot get space for its temporary copy,
the summary is rewritten in place (its own space reused) rather than left out
of date; if even that fails the OSError names summary.csv.
"""

import contextlib
import csv
import errno
import io
import os
import pathlib
import threading
import time
from collections.abc import Iterable

from fitting.result import FitResult, atomic_write_text

from .folder import load_quietly, printable
from .task import summary_row

SUMMARY_NAME = "summary.csv"
LOCK_NAME = ".summary.lock"
SUMMARY_FIELDS = ("material", "file", "model", "m1", "image", "exported_m1", "exported_image", "loss",
                  "seconds", "status", "result")
_KEPT_STATUS = ("fitted", "resumed", "earlier")


@contextlib.contextmanager
def folder_lock(path: str | os.PathLike[str], timeout: float | None = None):
    """Hold an exclusive ``flock`` on the lock file ``path`` (created if missing).

    ``timeout``: give up after that many seconds (TimeoutError); None waits.
    Where there is no ``fcntl`` (Windows) the lock is a no-op.
    """
    try:
        import fcntl
    except ImportError:         # no flock: concurrent batches may lose rows until the next write
        yield
        return
    fd = os.open(path, os.O_RDWR | os.O_CREAT | getattr(os, "O_CLOEXEC", 0), 0o666)
    try:
        if timeout is None:
            fcntl.flock(fd, fcntl.LOCK_EX)
        else:
            deadline = time.monotonic() + timeout
            while True:
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                    break
                except BlockingIOError:
                    if time.monotonic() > deadline:
                        raise TimeoutError(f"{path}: locked by another process") from None
                    time.sleep(0.02)
        yield
    finally:
        os.close(fd)            # releases the lock


def scan_results(out_dir: str | os.PathLike[str], cache: dict | None = None) -> dict[str, FitResult]:
    """{file name: FitResult} of the valid results in ``out_dir`` (others are passed over).

    ``cache`` ({name: ((mtime_ns, size, inode), FitResult or None)}, updated):
    a file whose stat is unchanged is not read again, so rebuilding the
    summary after every file costs a ``stat`` per result, not a parse.
    """
    cache = {} if cache is None else cache
    found = {}
    for q in sorted(pathlib.Path(out_dir).glob("*.json")):
        try:
            st = q.stat()
        except OSError:             # removed meanwhile
            continue
        key = (st.st_mtime_ns, st.st_size, st.st_ino)
        known = cache.get(q.name)
        result = known[1] if known is not None and known[0] == key else load_quietly(q)
        cache[q.name] = (key, result)
        if result is not None:
            found[q.name] = result
    return found


class Summary:
    """summary.csv of ``out_dir`` for a run over ``files``.

    ``results`` holds the valid results found in the folder when the run
    began, {name: FitResult} (what executors resume from).  ``add`` records
    this run's rows and writes the summary; ``write`` rebuilds it.
    """

    def __init__(self, out_dir: str | os.PathLike[str], files: Iterable[str | os.PathLike[str]]) -> None:
        self.out_dir = pathlib.Path(out_dir)
        self.path = self.out_dir / SUMMARY_NAME
        self.touched = {printable(f) for f in files}
        self.mine: dict[object, dict[str, str]] = {}
        self._cache: dict = {}
        self._writing = threading.Lock()        # one write at a time in this process
        self.results: dict[str, FitResult] = scan_results(self.out_dir, self._cache)

    def add(self, rows: Iterable[dict[str, str]]) -> None:
        for row in rows:
            self.mine[_key(row)] = row
        self.write()

    def write(self, lock_timeout: float | None = None) -> pathlib.Path:
        """Rebuild summary.csv from the folder and this run's rows, under the lock.

        ``lock_timeout``: the most to wait for another process's lock and for a write of this
        run in progress on another thread (a signal's write waits for the run's own, which
        the exit would cut short: then the last write lists every result on disk)."""
        if not self._writing.acquire(timeout=-1 if lock_timeout is None else lock_timeout):
            raise TimeoutError(f"{self.path}: this run's write did not end")
        try:
            with folder_lock(self.out_dir / LOCK_NAME, lock_timeout):
                old = _read_rows(self.path)
                # a copy of this run's rows (one step, atomic under the GIL): the main thread
                # adds rows while a signal's write runs on another (iterating the dict itself
                # would then fail, and the exit leave no summary)
                mine = dict(self.mine)
                rows = self._rows(old, scan_results(self.out_dir, self._cache), mine)
                buf = io.StringIO()
                writer = csv.DictWriter(buf, fieldnames=SUMMARY_FIELDS, extrasaction="ignore", restval="")
                writer.writeheader()
                writer.writerows(rows)
                _write(self.path, buf.getvalue())
        finally:
            self._writing.release()
        return self.path

    def _rows(self, old, results, mine):
        old_status = {r.get("result"): r.get("status", "") for r in old if r.get("result")}
        ours = {}        # result name -> this run's rows for it: one per input file (two copies of
        for key, row in mine.items():        # one measurement in two folders share one result)
            if row.get("result"):
                ours.setdefault(row["result"], []).append((key, row))
        rows = {}
        for name, result in results.items():
            if name in ours:
                rows.update(ours[name])
                continue
            status = "earlier" if name in self.results else old_status.get(name, "fitted")
            status = status if status in _KEPT_STATUS else "fitted"
            rows[name] = summary_row(result.material, result.provenance.get("file") or "", result.spec,
                                     status, result, name)
        for key, row in mine.items():            # this run's errors, cuts (and a result since removed)
            rows.setdefault(key, row)
        for row in old:                           # other runs' errors and cuts, for inputs not touched here
            if row.get("status", "").startswith(("error", "cut", "screened")) and row.get("file") not in self.touched:
                rows.setdefault(("no result", row.get("file"), row.get("model", "")), row)
        return list(rows.values())


def _key(row):
    """A row's place in the summary: its result file and input file (two inputs of one
    measurement share a result and keep a row each), or the input and model of a row
    without a result (an error, a cut)."""
    return (row["result"], row["file"]) if row["result"] else ("no result", row["file"], row["model"])


def _read_rows(path):
    try:
        with open(path, newline="", encoding="utf-8") as f:
            return [dict(r) for r in csv.DictReader(f)]
    except (OSError, csv.Error, UnicodeDecodeError):
        return []


def _write(path, text):
    """Atomically; on a full disk, in place (the old summary's space is reused)."""
    try:
        atomic_write_text(path, text)
    except OSError as err:
        if err.errno != errno.ENOSPC or not path.is_file():
            raise
        data = text.encode("utf-8")
        try:
            with open(path, "r+b") as f:
                f.truncate(0)
                f.write(data)
        except OSError as again:
            raise OSError(again.errno, again.strerror or str(again), str(path)) from None
