"""Prompt, clean ends on Ctrl-C and SIGTERM, and batch workers that die with their parent.

Ctrl-C (SIGINT) stops ``brdf-fit`` within a fraction of a second, whatever it
is doing, with one line on stderr and exit code 130::

    brdf-fit fit: interrupted; finished results are on disk

SIGTERM does the same with ``terminated`` and exit code 143 (128 + 15, the
shell convention).  Results are written atomically (temp file + os.replace),
so ending the process at any point leaves every result file either complete
or absent.

Why not KeyboardInterrupt: Python runs signal handlers only in the main
thread, between bytecodes, and ``brdf-fit`` spends most of its time with the
main thread in C (XLA compiling on background threads, jitted calls, the
nlopt loop, whose callbacks may swallow exceptions).  So ``exit_on_signal``
also gives the signal module a wakeup pipe (``signal.set_wakeup_fd``): the C
signal handler writes the signal number into it the moment the signal
arrives, a daemon thread blocked on the pipe wakes, prints the line and calls
``os._exit``.  The Python-level handler does the same if the main thread gets
there first.

Batch workers (``worker_init``, the ProcessPoolExecutor initializer) ignore
SIGINT -- the parent handles Ctrl-C, and the workers must not print
KeyboardInterrupt tracebacks -- and die with their parent: on Linux the
kernel sends them SIGKILL when the parent exits (``PR_SET_PDEATHSIG``, even
after ``kill -9`` of the parent); elsewhere a daemon thread polls the parent
pid every half second.

Bookkeeping on the way out: ``before_signal_exit(action)`` registers a
callable that runs (on the watchdog thread, for at most FINAL_ACTIONS_SECONDS
in all) after the signal and before the line and the exit -- batch stops its
workers there and writes summary.csv, so that it lists every result a worker
finished.

This module imports nothing heavy: the command line uses it before JAX.
"""

import contextlib
import logging
import os
import signal
import sys
import threading
import typing

from .errors import INTERRUPTED, TERMINATED  # 130 = 128 + SIGINT, 143 = 128 + SIGTERM

ORPHANED = 1        # exit code of a worker whose parent is gone (no one reads it)

PARENT_POLL_SECONDS = 0.5
FINAL_ACTIONS_SECONDS = 3.0     # the most a signal's exit waits for the registered actions

_FINAL_ACTIONS = []             # before_signal_exit's callables, run in order

_WAKE_UP = 0        # the byte exit_on_signal.__exit__ writes to stop its watchdog (no signal is 0)


def _outcomes():
    """{signal number: (exit code, word)} for the signals the command line handles."""
    outcomes = {signal.SIGINT: (INTERRUPTED, "interrupted")}
    if hasattr(signal, "SIGTERM"):
        outcomes[signal.SIGTERM] = (TERMINATED, "terminated")
    return outcomes


def _release_semaphores(timeout=0.3):
    """Unlink the semaphores of this process's multiprocessing queues (a batch's
    ProcessPoolExecutor) before os._exit, as their finalizers would on a normal
    exit; otherwise the resource tracker prints a "leaked semaphore objects"
    warning after the one clean line.  Done on a helper thread, waited for at
    most ``timeout`` seconds: the exit must never hang on it."""
    util = sys.modules.get("multiprocessing.util")
    synchronize = sys.modules.get("multiprocessing.synchronize")
    if util is None or synchronize is None:
        return

    def release():
        try:
            cleanup = synchronize.SemLock._cleanup
            for finalizer in list(util._finalizer_registry.values()):
                if getattr(finalizer, "_callback", None) is cleanup:
                    finalizer()
        except Exception:  # noqa: BLE001 -- private API; at worst the tracker warns
            pass

    helper = threading.Thread(target=release, daemon=True, name="brdf-fit-semaphores")
    helper.start()
    helper.join(timeout)


def leave(code: int | None) -> typing.NoReturn:
    """End the process with exit ``code`` when a command is done.  Where JAX was
    loaded, without the interpreter's teardown: JAX frees each compiled program
    and the XLA client piece by piece, 0.3-0.7 s that a process ending needs
    nothing of.  What the normal exit does that matters runs first: stdout and
    stderr flushed, logging shut down, the thread and process pools' queued work
    finished and their threads joined as ``concurrent.futures`` does at exit (the
    background compilations write the compilation cache), the semaphores of a
    batch's queues released.  A process that talked to a Dask scheduler exits
    normally (its client says goodbye at exit)."""
    if "jax" not in sys.modules or "distributed" in sys.modules:
        sys.exit(code)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):     # a closed pipe or stream: nothing more reaches it
            pass
    logging.shutdown()
    for name in ("concurrent.futures.thread", "concurrent.futures.process"):
        module = sys.modules.get(name)
        if module is not None and hasattr(module, "_python_exit"):
            module._python_exit()
    _release_semaphores()
    os._exit(0 if code is None else int(code))


@contextlib.contextmanager
def before_signal_exit(action):
    """While active, ``action()`` runs when a signal ends the process (``exit_on_signal``),
    before the process exits; bounded by FINAL_ACTIONS_SECONDS; its exceptions are ignored."""
    _FINAL_ACTIONS.append(action)
    try:
        yield action
    finally:
        _FINAL_ACTIONS.remove(action)


def _run_final_actions(timeout=FINAL_ACTIONS_SECONDS):
    """Run the registered actions on a helper thread, waited for at most ``timeout`` s."""
    actions = list(_FINAL_ACTIONS)
    if not actions:
        return

    def run():
        for action in actions:
            try:
                action()
            except Exception:  # noqa: BLE001 -- the exit goes on; the next run repairs
                pass

    helper = threading.Thread(target=run, daemon=True, name="brdf-fit-final")
    helper.start()
    helper.join(timeout)


class exit_on_signal:
    """Context manager: while active, SIGINT/SIGTERM print one line and end the process.

    ``prog`` begins the line (``brdf-fit fit``; it may be changed while the
    context is active, e.g. once the command line is parsed), ``note`` ends
    it.  Exit codes: 130 for SIGINT, 143 for SIGTERM.  On exit from the
    ``with`` block the previous handlers and wakeup fd are restored, so the
    command line can be called in-process (tests) any number of times.

    Outside the main thread (where signal handlers cannot be set) this does
    nothing.  A signal that is ignored (SIG_IGN, e.g. SIGINT of a command
    started with ``nohup`` or in the background by a non-interactive shell)
    stays ignored.
    """

    def __init__(self, prog: str = "brdf-fit", note: str = "finished results are on disk") -> None:
        self.prog, self.note = prog, note
        self.active = False
        self._lock = threading.Lock()
        self._previous = {}
        self._previous_fd = None
        self._read_fd = self._write_fd = None

    # --- the exit itself ---------------------------------------------------------------

    def message(self, signum: int) -> str:
        """The line printed for ``signum`` (without the newline)."""
        word = _outcomes()[signum][1]
        return f"{self.prog}: {word}; {self.note}" if self.note else f"{self.prog}: {word}"

    def _exit(self, signum):
        """Print the line and end the process now (from the watchdog or the main thread)."""
        # The first caller exits; a second one (the other thread) waits for that.
        self._lock.acquire()
        code = _outcomes()[signum][0]
        _run_final_actions()
        _release_semaphores()
        line = self.message(signum) + "\n"
        try:
            # Clear a progress bar being redrawn on a terminal so the line stands alone.
            if os.isatty(2):
                line = "\r\033[K" + line
        except OSError:
            pass
        try:
            # os.write, not sys.stderr: another thread may hold the stream's lock.
            os.write(2, line.encode("utf-8", "replace"))
        except OSError:
            pass
        os._exit(code)

    def _handler(self, signum, frame):
        """The Python-level handler, run by the main thread between bytecodes.  Where the
        watchdog thread exists, it ends the process (the wakeup fd woke it) and this does
        nothing: the main thread may be inside a final action's critical section (batch's
        summary write holds its lock), and exiting from here would make the action wait
        for the main thread, which waits for the action -- no summary at all
        (test_a_signal_while_the_main_thread_holds_a_final_actions_lock)."""
        if self._read_fd is None:
            self._exit(signum)

    def _watch(self, read_fd):
        outcomes = _outcomes()
        try:
            while True:
                try:
                    data = os.read(read_fd, 64)
                except InterruptedError:
                    continue
                if not data:
                    return
                for signum in data:
                    if signum == _WAKE_UP:
                        return
                    if signum in outcomes and signum in self._previous:
                        self._exit(signum)
        finally:
            os.close(read_fd)

    # --- installation --------------------------------------------------------------------

    def __enter__(self):
        if threading.current_thread() is not threading.main_thread():
            return self
        for signum in _outcomes():
            current = signal.getsignal(signum)
            if current == signal.SIG_IGN:
                continue
            self._previous[signum] = signal.signal(signum, self._handler)
        if not self._previous:
            return self
        self.active = True
        read_fd, write_fd = os.pipe()
        os.set_blocking(write_fd, False)     # required by set_wakeup_fd
        try:
            self._previous_fd = signal.set_wakeup_fd(write_fd, warn_on_full_buffer=False)
        except (ValueError, OSError):
            # No wakeup fd here (e.g. Windows wants a socket): the Python handler alone.
            os.close(read_fd)
            os.close(write_fd)
            return self
        self._read_fd, self._write_fd = read_fd, write_fd
        threading.Thread(target=self._watch, args=(read_fd,), daemon=True,
                         name="brdf-fit-interrupt").start()
        return self

    def __exit__(self, *exc):
        if not self.active:
            return False
        if self._write_fd is not None:
            signal.set_wakeup_fd(self._previous_fd)
            try:
                os.write(self._write_fd, bytes([_WAKE_UP]))   # the watchdog returns, closes its end
            except OSError:
                pass
            os.close(self._write_fd)
            self._read_fd = self._write_fd = None
        for signum, previous in self._previous.items():
            signal.signal(signum, previous if previous is not None else signal.SIG_DFL)
        self._previous = {}
        self.active = False
        return False


# --- batch worker processes ----------------------------------------------------------------

def _parent_pid():
    """The pid of the process that started this worker (multiprocessing knows it even
    if the parent is already gone; os.getppid() would then name the reaper)."""
    try:
        import multiprocessing
        parent = multiprocessing.parent_process()
        if parent is not None and parent.pid:
            return parent.pid
    except Exception:  # noqa: BLE001 -- fall back to the kernel's answer
        pass
    return os.getppid()


def _set_parent_death_signal(signum):
    """Linux: have the kernel send ``signum`` to this process when its parent exits.

    True when set.  (The kernel ties this to the parent *thread* that created
    the process; ProcessPoolExecutor starts its workers from the thread that
    submits the work, which lives as long as the pool.)
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes
        libc = ctypes.CDLL(None, use_errno=True)
        PR_SET_PDEATHSIG = 1
        return libc.prctl(PR_SET_PDEATHSIG, ctypes.c_ulong(signum), ctypes.c_ulong(0),
                          ctypes.c_ulong(0), ctypes.c_ulong(0)) == 0
    except (OSError, AttributeError):
        return False


def _watch_parent(parent, interval=PARENT_POLL_SECONDS):
    import time
    while True:
        time.sleep(interval)
        if os.getppid() != parent:
            os._exit(ORPHANED)


def worker_init() -> None:
    """ProcessPoolExecutor initializer: ignore SIGINT, die with the parent process."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    parent = _parent_pid()
    if not _set_parent_death_signal(signal.SIGKILL):
        threading.Thread(target=_watch_parent, args=(parent,), daemon=True,
                         name="brdf-fit-parent-watch").start()
    if os.getppid() != parent:      # the parent died before the death signal was set
        os._exit(ORPHANED)
