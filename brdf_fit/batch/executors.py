"""Where a batch's files are fitted: local processes, or a Dask distributed cluster.

An executor has one method, ``run(tasks, out_dir, results)``, which yields
``(task, outcome)`` as each file finishes, in any order: ``outcome`` is the
file's ``brdf_fit.batch.task.FileOutcome``, or the exception that ended its task (a
worker that died, a task the cluster gave up on), which the batch turns into
that file's error rows.  ``brdf_fit.batch.run.run_batch`` does everything else
(the summary, the progress, writing results returned by workers).

- ``LocalExecutor(jobs)``: in this process (``jobs`` = 1), or in ``jobs``
  spawned worker processes that ignore Ctrl-C and die with this one, each
  kept to its own share of this process's CPUs (``worker_cpus``).
- ``DaskExecutor(address, send_data)``: on an existing Dask cluster
  (``dask scheduler`` / ``dask worker``).  By path (default) each worker
  reads the input itself and writes its results into the output folder: a
  filesystem shared at the same paths.  By bytes (``send_data``) this
  process reads each input and sends its bytes; the worker fits a private
  copy and returns the result texts, which this process writes.

dask is imported only by ``DaskExecutor.run``; this module imports nothing heavy.
``brdf_fit.batch.cluster`` watches the cluster while a batch runs on it.
"""

import asyncio
import os
import pathlib
import time
from collections.abc import Callable, Iterator

from brdf_fit.errors import InputError, one_line

from .cluster import ClusterLost, Watch, close_quietly, quiet_distributed

CONNECT_TIMEOUT = 10.0      # seconds to reach the scheduler, get its handshake, and find a worker
HANDSHAKE_FACTOR = 2.0      # the connect and the handshake together: at most 2 x CONNECT_TIMEOUT
IN_FLIGHT_PER_THREAD = 2    # tasks submitted ahead per worker thread (bounds the bytes held)
NO_WORKER_TIMEOUT = 60.0    # seconds a batch waits with no worker in the cluster, then gives up what is left
RESUBMITS = 2               # times a task lost otherwise than by its workers dying is submitted again
POLL_SECONDS = 0.2          # how often the batch looks for finished tasks
SCATTER_TIMEOUT = 2.0       # seconds the scheduler looks for a worker to hold the results snapshot

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
        ctx = multiprocessing.get_context("spawn")
        with concurrent.futures.ProcessPoolExecutor(max_workers=self.jobs, mp_context=ctx, initializer=_init_worker,
                                                    initargs=(worker_cpus(self.jobs), ctx.Value("i", 0))) as pool:
            self._pool = pool
            futures = {pool.submit(fit_task, task, str(out_dir), own_process=True): task for task in tasks}
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


FILES_PER_WORKER = 4        # --jobs by default: at most one worker per this many files ...
MERL_CELLS = 90 * 90 * 180  # ... and as many as the memory left holds fitting a MERL table with auto


def default_jobs(inputs: list[str]) -> int:
    """The worker processes of a local batch when ``--jobs`` is not given: one per CPU this
    process may use, at most one per FILES_PER_WORKER files of ``inputs`` (a worker's start --
    JAX, its programs from the cache -- costs about a small table's fits) and at most as many
    as the memory left holds (``fitting.memory``: a MERL table with ``auto`` each); 1 (this
    process, two fits at once) where that is fewer than two.  On two cores a library of ten
    MERL tables took 125 s in this process and 90 s in two workers (docs/batch.md)."""
    from fitting.memory import available, needed

    from .folder import expand_inputs
    try:
        files = len(expand_inputs(inputs))
    except (InputError, OSError):       # the batch says what is wrong with them
        return 1
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    left = available()
    memory = cpus if left is None else int(left // needed(MERL_CELLS, auto=True)[1])
    return max(1, min(cpus, files // FILES_PER_WORKER, memory))


def worker_cpus(jobs: int) -> list[set[int]] | None:
    """The CPUs of each of ``jobs`` worker processes: this process's CPUs dealt out, every
    worker a share of its own (jobs > CPUs: one CPU each, shared round the CPUs); None where
    the system cannot say or keep a process to CPUs (macOS), or there is nothing to deal.

    Why: XLA runs each program on as many threads as its process may use CPUs.  Two
    workers on two cores then each run two threads, and every parallel step waits for a
    thread the other worker holds: one fit repeated in two processes at once took 6.8-7.2 s
    each, 5.3-5.8 s with each kept to a core (the same numbers bit for bit; docs/performance.md)."""
    if not hasattr(os, "sched_getaffinity") or jobs < 2:
        return None
    cpus = sorted(os.sched_getaffinity(0))
    if len(cpus) < 2:
        return None
    if jobs >= len(cpus):
        return [{cpus[k % len(cpus)]} for k in range(jobs)]
    return [set(cpus[k::jobs]) for k in range(jobs)]


def _init_worker(cpus: list[set[int]] | None, started) -> None:
    """A local worker process's initializer: ``interrupt.worker_init``, then the worker's share
    of the CPUs (``worker_cpus``; ``started`` counts the workers started, the k-th takes the
    k-th share), before anything imports JAX."""
    from brdf_fit.interrupt import worker_init
    worker_init()
    if cpus:
        with started.get_lock():
            k, started.value = started.value, started.value + 1
        try:
            os.sched_setaffinity(0, cpus[k % len(cpus)])
        except OSError:         # the CPUs were taken from this process meanwhile: any will do
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
    server) within ``timeout`` s more, or replies with something else (an
    HTTP error page, read as a frame of exabytes: a MemoryError).

    ``distributed.Client`` bounds the connect only; its handshake waits for the
    reply forever, and a Client whose construction failed prints a traceback
    from ``__del__`` at exit.  So the handshake is tried here first, in an
    event loop of its own, bounded as a whole; no Client is made for an
    address that fails it.
    """
    from distributed.comm import connect as comm_connect
    from distributed.comm.addressing import parse_address, parse_host_port
    from distributed.comm.registry import get_backend
    try:
        scheme, location = parse_address(address)
        if scheme in ("tcp", "tls"):
            parse_host_port(location)
        get_backend(scheme)         # an unknown scheme
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
    except Exception:  # noqa: BLE001 -- a reply that is not Dask's (an HTTP server's: a "frame" of EiBs)
        raise InputError(f"no Dask scheduler at {address}: the server there answered, but not in "
                         "Dask's protocol (is another kind of server listening there?)") from None


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
    worker inside its task, the result texts come back and are written here.
    At most IN_FLIGHT_PER_THREAD tasks per worker thread are submitted ahead,
    so a library of large tables is never held in memory at once.

    A task whose worker dies is run again on another worker by the scheduler
    (its ``allowed-failures``, 3 by default, then KilledWorker: that file's
    error rows); a task lost otherwise (its data lost with a worker) is
    submitted again, at most RESUBMITS times.  ``run`` raises ClusterLost
    when the scheduler is gone or no worker has been in the cluster for
    ``no_worker_timeout`` s (default NO_WORKER_TIMEOUT).
    """

    def __init__(self, address: str, send_data: bool = False, timeout: float | None = None,
                 no_worker_timeout: float | None = None) -> None:
        self.address, self.send_data, self.timeout = address, send_data, timeout
        self.no_worker_timeout = no_worker_timeout
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
            close_quietly(client)

    def run(self, tasks: list, out_dir: pathlib.Path,
            results: dict) -> Iterator[tuple[object, Outcome]]:
        """Yield ``(task, FileOutcome)`` per file as the cluster finishes it (an exception
        if the cluster gave up on its task); ClusterLost ends it (see the class)."""
        self.open()
        client, self.client = self.client, None
        timeout = NO_WORKER_TIMEOUT if self.no_worker_timeout is None else self.no_worker_timeout
        cluster = Watch(client, self.address, timeout)
        try:
            with quiet_distributed():
                yield from self._run(client, cluster, tasks, os.path.abspath(out_dir), results)
        finally:
            with quiet_distributed():
                close_quietly(client)
            if self.send_data:              # copies of workers killed on this machine
                from .task import remove_stale_copies
                remove_stale_copies()

    def _run(self, client, cluster, tasks, out_dir, results):
        from data_loaders.errors import open_regular
        from .task import fit_bytes, fit_task
        distributed = _distributed()
        snapshot = [None]
        pending, submitted, local, resubmitted = list(reversed(tasks)), {}, [], {}

        def snapshot_held():        # on every worker; scattered again if lost with its workers
            if snapshot[0] is None or snapshot[0].status != "finished":
                try:
                    snapshot[0] = client.scatter([results], hash=False, broadcast=True,
                                                 timeout=SCATTER_TIMEOUT)[0]
                except (ValueError, OSError):   # no worker to hold it (a timeout): wait for one
                    return False
            return True

        def submit(task):
            if not self.send_data:
                return client.submit(fit_task, task, out_dir, True, pure=False)
            try:
                with open_regular(task.absolute) as f:      # a FIFO: refused, not waited on
                    data = f.read()
            except OSError:
                local.append(task)      # the loader says what is wrong, as in a local run
                return None
            import dask
            with dask.config.set({"distributed.admin.large-graph-warning-threshold": "1 PiB"}):
                return client.submit(fit_bytes, data, task, snapshot[0], pure=False)    # bytes in the task

        cluster.check()
        while True:
            while pending and len(submitted) < IN_FLIGHT_PER_THREAD * cluster.threads:
                if self.send_data and not snapshot_held():
                    break
                task = pending.pop()
                try:
                    future = submit(task)
                except Exception:
                    if not cluster.gone():
                        raise
                    pending.append(task)
                    raise ClusterLost(f"the Dask scheduler at {self.address} is gone") from None
                if future is not None:
                    submitted[future] = task
            while local:
                task = local.pop()
                yield task, fit_task(task, out_dir, True)
            if not submitted and not pending:
                return
            done = [future for future in submitted if future.done()]
            if not done:
                cluster.check()
                time.sleep(POLL_SECONDS)
                continue
            for future in done:
                task = submitted.pop(future)
                try:
                    outcome = future.result()
                except (Exception, asyncio.CancelledError) as err:  # noqa: BLE001 -- the file's rows
                    outcome = err
                future.release()
                if isinstance(outcome, BaseException):
                    if cluster.gone():      # not this task's fault: every task left is lost
                        pending.append(task)
                        raise ClusterLost(f"the Dask scheduler at {self.address} is gone")
                    if (not isinstance(outcome, distributed.KilledWorker)
                            and resubmitted.get(id(task), 0) < RESUBMITS):
                        resubmitted[id(task)] = resubmitted.get(id(task), 0) + 1
                        pending.append(task)
                        continue
                yield task, outcome
