"""The address of a Dask scheduler started by a test, read from its --scheduler-file."""

import json
import time


def scheduler_address(scheduler_file, process, deadline, log_path):
    """The address the scheduler wrote to ``scheduler_file``, once the file holds it.

    dask creates the file before it writes it (not atomically): a read as soon as the
    file exists found it empty under load (json: "Expecting value", test_dask_worker_death
    on 2026-12-06), so the file is read until it parses or ``deadline`` (monotonic) passes."""
    while True:
        assert process.poll() is None, log_path.read_text()
        try:
            return json.loads(scheduler_file.read_text())["address"]
        except (FileNotFoundError, ValueError, KeyError):
            if time.monotonic() > deadline:
                raise
            time.sleep(0.1)
