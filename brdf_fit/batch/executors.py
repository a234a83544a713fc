"""Where a batch's files are fitted: local processes, or a Dask distributed cluster.

An executor has one method, ``run(tasks, out_dir, results)``, which yields
``(task, outcome)`` as each file finishes, in any order: ``outcome`` is the
file's ``brdf_fit.batch.task.FileOutcome``, or the exception that ended its task (a
worker that died, a task the cluster gave up on), which the batch turns into
that file's error rows.  ``brdf_fit.batch.run.run_batch`` does everything else
(the summary, the progress, writing results returned by workers).

- ``LocalExecutor(jobs)``: in this process (``jobs`` = 1), or in ``jobs``
  spawned worker processes that ignore Ctrl-C and die with this one.
- ``DaskExecutor(address, send_data)``: on an existing Dask cluster
  (``dask scheduler`` / ``dask worker``).  By path (default) each worker
  reads the input itself and writes its results into the output folder: a
  filesystem shared at the same paths.  By bytes (``send_data``) this
  process reads each input and sends its bytes; the worker fits a private
  copy and returns the result texts, which this process writes.

dask is imported only by ``DaskExecutor.run``; this module imports nothing heavy.
"""

import asyncio
import os
import pathlib
from collections.abc import Callable, Iterator

from brdf_fit.errors import InputError, one_line

CONNECT_TIMEOUT = 10.0      # seconds to reach the scheduler, get its handshake, and find a worker
HANDSHAKE_FACTOR = 2.0      # the connect and the handshake together: at most 2 x CONNECT_TIMEOUT
IN_FLIGHT_PER_THREAD = 2    # tasks submitted ahead per worker thread (bounds the bytes held)

Outcome = object            # brdf_fit.batch.task.FileOutcome, or the exception that ended the task


class Executor:
    """Runs the per-file work of a batch; yields ``(task, outcome)`` as files finish."""

    fit_threads = 1     # fits of one file run at once (``fitting.fit_models``): one where files run side by side

    def run(self, tasks: list, out_dir: pathlib.Path,
            results: dict) -> Iterator[tuple[object, Outcome]]:
        """Fit ``tasks`` (``brdf_fit.batch.task.FileTask``) with ``out_dir`` as the output folder
        (``results``: its results when the batch began, {name: FitResult})."""
        raise NotImplementedError


class LocalExecutor(Executor):
    """Files fitted in this process, or in ``jobs`` local worker processes.

    ``on_row``: in this process (``jobs`` 1), called with each model's summary
    row as soon as its fit is done (``brdf-fit demo`` shows its fits so).
    """

    def __init__(self, jobs: int = 1, on_row: Callable[[dict[str, str]], object] | None = None) -> None:
        from fitting.fit_models import FIT_THREADS
        self.jobs, self.on_row = jobs, on_row
        self.fit_threads = FIT_THREADS if jobs <= 1 else 1    # in this process: two fits of a file at once

    def run(self, tasks: list, out_dir: pathlib.Path,
            results: dict) -> Iterator[tuple[object, Outcome]]:
        """Yield ``(task, FileOutcome)`` per file (an exception if its worker died)."""
        from .task import fit_task
        if self.jobs <= 1 or len(tasks) <= 1:
            for task in tasks:
                yield task, fit_task(task, str(out_dir), on_row=self.on_row)
            return
        import concurrent.futures
        import multiprocessing
        from brdf_fit.interrupt import worker_init
        ctx = multiprocessing.get_context("spawn")
        with concurrent.futures.ProcessPoolExecutor(max_workers=self.jobs, mp_context=ctx,
                                                    initializer=worker_init) as pool:
            self._pool = pool
            futures = {pool.submit(fit_task, task, str(out_dir)): task for task in tasks}
            try:
                for future in concurrent.futures.as_completed(futures):
                    try:
                        outcome = future.result()
                    except Exception as err:  # noqa: BLE001 -- a worker died: this file's rows say so
                        outcome = err
                    yield futures[future], outcome
            finally:            # the batch stopped early (a full disk): files not started are not
                pool.shutdown(wait=True, cancel_futures=True)
                self._pool = None

    def stop(self) -> None:
        """Kill the worker processes now (a signal ends the batch: no result is written after
        the summary's last write).  From any thread."""
        pool = getattr(self, "_pool", None)
        try:
            processes = list((getattr(pool, "_processes", None) or {}).values())
        except RuntimeError:        # changed meanwhile; the kernel ends them with this process
            processes = []
        for process in processes:
            try:
                process.kill()
            except (OSError, ValueError, AttributeError):
                pass


def _distributed():
    """The distributed package, or InputError if dask is not installed."""
    try:
        import distributed
    except ImportError as err:
        raise InputError(f"--scheduler needs dask's distributed package ({one_line(err)}); "
                         "install it with: pip install 'brdf-fit[dask]'") from None
    return distributed


def check_scheduler(address: str, timeout: float) -> None:
    """Parse ``address`` and shake hands with the server there; InputError (one line) if
    the address is malformed, nothing answers within ``timeout`` s, or the server
    accepts the connection but sends no Dask handshake (a silent server, a web
    server) within ``timeout`` s more.

    ``distributed.Client`` bounds the connect only; its handshake waits for the
    reply forever, and a Client whose construction failed prints a traceback
    from ``__del__`` at exit.  So the handshake is tried here first, in an
    event loop of its own, bounded as a whole; no Client is made for an
    address that fails it.
    """
    from distributed.comm import connect as comm_connect
    from distributed.comm.addressing import parse_address, parse_host_port
    try:
        scheme, location = parse_address(address)
        if scheme in ("tcp", "tls"):
            parse_host_port(location)
    except (ValueError, TypeError) as err:
        raise InputError(f"--scheduler {address}: {one_line(err)}") from None

    async def shake_hands():
        comm = await comm_connect(address, timeout=timeout)
        await comm.close()

    try:
        _in_a_thread(lambda: asyncio.run(asyncio.wait_for(shake_hands(), HANDSHAKE_FACTOR * timeout)))
    except (TimeoutError, asyncio.TimeoutError):
        raise InputError(f"no answer from a Dask scheduler at {address} within {timeout:g} s of "
                         "connecting (is another kind of server listening there?)") from None
    except OSError as err:
        raise InputError(f"cannot reach the Dask scheduler at {address} within {timeout:g} s "
                         f"({one_line(err)})") from None
    except Exception as err:  # noqa: BLE001 -- a garbled reply, an unsupported scheme: one line
        raise InputError(f"--scheduler {address}: {one_line(f'{type(err).__name__}: {err}')}") from None


def _in_a_thread(call):
    """``call()`` on a thread of its own (its own event loop, even when the caller runs
    one: a notebook); its exception is raised here."""
    import threading
    failure = []

    def run():
        try:
            call()
        except BaseException as err:  # noqa: BLE001 -- handed to the caller
            failure.append(err)

    thread = threading.Thread(target=run, daemon=True, name="brdf-fit-dask-check")
    thread.start()
    thread.join()
    if failure:
        raise failure[0]


def connect(address: str, timeout: float | None = None) -> object:
    """A ``distributed.Client`` of the scheduler at ``address`` with at least one worker.

    InputError (one line) if dask is missing, the address is malformed, or
    the scheduler or a worker cannot be reached within ``timeout`` seconds
    (default CONNECT_TIMEOUT; the handshake is bounded too: ``check_scheduler``).
    """
    distributed = _distributed()
    timeout = CONNECT_TIMEOUT if timeout is None else timeout
    check_scheduler(address, timeout)
    try:
        client = distributed.Client(address, timeout=f"{timeout}s", set_as_default=False)
    except (OSError, TimeoutError, asyncio.TimeoutError) as err:
        raise InputError(f"cannot reach the Dask scheduler at {address} within {timeout:g} s "
                         f"({one_line(err)})") from None
    except ValueError as err:
        raise InputError(f"--scheduler {address}: {one_line(err)}") from None
    try:
        client.wait_for_workers(1, timeout=timeout)
    except (OSError, TimeoutError, asyncio.TimeoutError):
        client.close()
        raise InputError(f"the Dask scheduler at {address} has no worker (none joined within "
                         f"{timeout:g} s); start some with: dask worker {address}") from None
    return client


class DaskExecutor(Executor):
    """Files fitted on the Dask cluster whose scheduler is at ``address``.

    By path (default): a worker reads ``task.absolute`` and writes the
    results into ``out_dir`` (which must be on a filesystem the workers share
    at the same path).  By bytes (``send_data``): the input's bytes go to the
    worker, the result texts come back and are written here.  At most
    IN_FLIGHT_PER_THREAD tasks per worker thread are submitted ahead, so a
    library of large tables is never held in memory at once.
    """

    def __init__(self, address: str, send_data: bool = False, timeout: float | None = None) -> None:
        self.address, self.send_data, self.timeout = address, send_data, timeout
        self.client = None

    def open(self) -> None:
        """Connect now (InputError if the cluster cannot be used), before the batch
        creates its output folder."""
        if self.client is None:
            self.client = connect(self.address, self.timeout)

    def close(self) -> None:
        """Disconnect (if ``run`` did not already)."""
        client, self.client = self.client, None
        if client is not None:
            client.close()

    def run(self, tasks: list, out_dir: pathlib.Path,
            results: dict) -> Iterator[tuple[object, Outcome]]:
        """Yield ``(task, FileOutcome)`` per file as the cluster finishes it (an exception
        if the cluster gave up on its task, e.g. its workers died)."""
        from data_loaders.errors import open_regular
        from .task import fit_bytes, fit_task
        distributed = _distributed()
        self.open()
        client, self.client = self.client, None
        out_dir = os.path.abspath(out_dir)
        try:
            snapshot = client.scatter([results], hash=False)[0] if self.send_data else None
            pending = iter(tasks)
            submitted = {}
            local = []          # inputs this process cannot read (by bytes): their outcome here

            def submit(task):
                if not self.send_data:
                    future = client.submit(fit_task, task, out_dir, True, pure=False)
                else:
                    try:
                        with open_regular(task.absolute) as f:      # a FIFO: refused, not waited on
                            data = f.read()
                    except OSError:
                        local.append(task)      # the loader says what is wrong, as in a local run
                        return None
                    future = client.submit(fit_bytes, client.scatter(data, hash=False), task, snapshot,
                                           pure=False)
                submitted[future] = task
                return future

            running = distributed.as_completed(loop=client.loop)
            window = IN_FLIGHT_PER_THREAD * (sum(client.nthreads().values()) or 1)
            while True:
                while len(submitted) < window:      # keep the cluster busy, the bytes held bounded
                    task = next(pending, None)
                    if task is None:
                        break
                    future = submit(task)
                    if future is not None:
                        running.add(future)
                while local:
                    task = local.pop()
                    yield task, fit_task(task, out_dir, True)
                if not submitted:
                    break
                future = next(running)
                task = submitted.pop(future)
                try:
                    outcome = future.result()
                except (Exception, asyncio.CancelledError) as err:  # noqa: BLE001 -- the file's rows
                    outcome = err
                future.release()
                yield task, outcome
        finally:
            client.close()
