"""Watching a Dask cluster while a batch runs on it (``brdf_fit.batch.executors.DaskExecutor``).

``Watch.check`` raises ``ClusterLost`` when the scheduler is gone or no worker
has been in the cluster for a while; ``quiet_distributed`` keeps distributed's
own log records (each lost worker, a failed reconnect: tracebacks) off the
user's terminal while the batch says what matters in one line;
``close_quietly`` disconnects from a scheduler that may be gone.  Imports
nothing of dask: the client is handed in.
"""

import contextlib
import logging
import os
import time

CHECK_SECONDS = 1.0         # how often the batch asks the scheduler for its workers
CLOSE_TIMEOUT = 5.0         # seconds to disconnect from a scheduler that may be gone


class ClusterLost(Exception):
    """The Dask cluster can run none of the batch's remaining tasks: no worker for
    NO_WORKER_TIMEOUT s, or the scheduler gone.  The message says which, in one line."""


@contextlib.contextmanager
def quiet_distributed():
    """distributed's own log records (a lost worker, a reconnect that failed, each with
    a traceback) are not shown while a batch runs: the batch says what matters in one
    line.  ``BRDF_DEBUG=1`` shows them."""
    if os.environ.get("BRDF_DEBUG"):
        yield
        return
    names = ["distributed"] + [name for name in list(logging.Logger.manager.loggerDict)
                               if name.startswith("distributed.")]     # dask sets some levels of their own
    loggers = [logging.getLogger(name) for name in names]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for logger, level in zip(loggers, levels):
            logger.setLevel(level)


class Watch:
    """Watches the cluster while the batch waits: ``check()`` raises ClusterLost when the
    scheduler is gone, or when no worker has been in it for ``no_worker_timeout`` s."""

    def __init__(self, client, address, no_worker_timeout):
        self.client, self.address, self.timeout = client, address, no_worker_timeout
        self.threads, self.empty_since, self.checked = 1, None, 0.0

    def gone(self) -> bool:
        return self.client.status not in ("running", "newly-created")

    def check(self, now: float | None = None) -> None:
        now = time.monotonic() if now is None else now
        if now - self.checked < CHECK_SECONDS:
            return
        self.checked = now
        if self.gone():
            raise ClusterLost(f"the Dask scheduler at {self.address} is gone")
        try:
            threads = sum(self.client.nthreads().values())
        except Exception:  # noqa: BLE001 -- a closed comm, a timeout: the scheduler is gone
            raise ClusterLost(f"the Dask scheduler at {self.address} is gone") from None
        if threads:
            self.threads, self.empty_since = threads, None
        elif self.empty_since is None:
            self.empty_since = now
        elif now - self.empty_since >= self.timeout:
            raise ClusterLost(f"no Dask worker at {self.address} for {self.timeout:g} s "
                              f"(start some with: dask worker {self.address})")


def close_quietly(client) -> None:
    """Close a client whose scheduler may be gone, quietly and within seconds."""
    try:
        client.close(timeout=CLOSE_TIMEOUT)
    except Exception:  # noqa: BLE001 -- a scheduler gone meanwhile: nothing left to close
        pass
