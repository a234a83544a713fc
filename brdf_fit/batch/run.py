"""Fitting many models to many files: resumable, atomic, one bad file never ends it.

``run_batch`` turns the inputs into ``FileTask``s (brdf_fit.batch.task), hands
them to an executor (brdf_fit.batch.executors: local processes, or a Dask
cluster) and writes the summary as each file's ``FileOutcome`` comes back.
"""

import errno
import os
import pathlib
from collections.abc import Callable, Iterable

from brdf_fit.errors import InputError
from brdf_fit.interrupt import before_signal_exit
from brdf_fit.progress import Progress
from data_loaders.atomic import stale_temp_files
from fitting.result import atomic_write_text

from .executors import ClusterLost
from .folder import MEASURED_SUFFIXES, colliding_names, expand_inputs, printable
from .summary import SUMMARY_FIELDS, SUMMARY_NAME, Summary  # noqa: F401 -- SUMMARY_FIELDS: its old home
from .task import failed_rows, make_task, not_fitted_rows

SIGNAL_LOCK_SECONDS = 2.0       # the summary lock waited for when a signal ends the batch


def _write_returned(out_dir, outcome):
    """Write the result texts a worker sent back (``--send-data``), atomically; a
    result that cannot be written turns its row into an error row."""
    rows, messages = list(outcome.rows), list(outcome.messages)
    disk_full = outcome.disk_full
    for name, text in outcome.written.items():
        try:
            atomic_write_text(out_dir / name, text)
        except OSError as err:
            disk_full = disk_full or err.errno == errno.ENOSPC
            problem = printable(f"cannot write {out_dir / name} ({err.strerror or err})")
            messages.append(f"skipped {name}: {problem}")
            rows = [dict(r, status=f"error: {problem}", result="", m1="", image="", exported_m1="",
                         exported_image="", loss="", seconds="")
                    if r["result"] == name else r for r in rows]
    return rows, messages, disk_full


def _outcomes(outcomes, out_dir, say):
    """``(task, summary rows, disk full)`` per outcome of an executor; its messages said."""
    for task, outcome in outcomes:
        if isinstance(outcome, BaseException):
            outcome = failed_rows(task, outcome)
        file_rows, messages, disk_full = _write_returned(out_dir, outcome)
        for m in messages:
            say(m)
        yield task, file_rows, disk_full


def run_batch(inputs: Iterable[str | os.PathLike[str]], models: list[str], out_dir: str | os.PathLike[str],
              jobs: int = 1, fit_options: dict[str, object] | None = None, log: Callable[[str], object] = print,
              progress: bool = True, executor: object | None = None, cut: bool = False,
              refit_stale: bool = False, export_first: bool = False,
              unscreened: "Iterable[str]" = ()) -> list[dict[str, str]]:
    """Fit ``models`` to every input; results and summary.csv land in ``out_dir``.

    Each result is written atomically as soon as it is done; re-running skips
    results already on disk for the same input (sha256) and the same fit
    options, so an interrupted batch resumes.  The files are fitted by
    ``executor`` (brdf_fit.batch.executors): by default ``LocalExecutor(jobs)`` --
    in this process, or with ``jobs`` > 1 in parallel processes that end
    with the parent; ``DaskExecutor(address)`` fits them on a Dask cluster.
    A worker that dies or a task that fails becomes its file's error rows.
    ``cut``: models that cannot beat the best fitted so far on a file stop
    after their coarse stage (a "cut" row, no result; ``--model auto``), but those of
    ``unscreened`` (named beside ``auto``: ``fitting.auto.fitted_fully``).
    Results resumed that another version of the toolkit fitted are kept, and one
    line says so; ``refit_stale`` fits them again.  ``export_first`` (the library): the
    glTF family is fitted beside ``models``, screened apart and never cut (``FileTask.all_models``).
    Returns this run's rows.
    """
    from .executors import LocalExecutor
    executor = executor if executor is not None else LocalExecutor(jobs)
    out_dir = pathlib.Path(out_dir)
    files = expand_inputs(inputs, exclude=[out_dir / SUMMARY_NAME])
    if not files:
        raise InputError("no measured files (" + ", ".join(MEASURED_SUFFIXES) + ") in "
                         + ", ".join(printable(i) for i in inputs))
    if hasattr(executor, "open"):
        executor.open()         # a Dask scheduler that cannot be reached: nothing is created
    try:
        return _run(executor, files, models, out_dir, fit_options, log, progress, cut, refit_stale, export_first,
                    tuple(unscreened))
    finally:
        if hasattr(executor, "close"):
            executor.close()


def _run(executor, files, models, out_dir, fit_options, log, progress, cut, refit_stale, export_first, unscreened):
    out_dir.mkdir(parents=True, exist_ok=True)
    for stale in stale_temp_files(out_dir):      # left by a writer killed in a write (not a live one)
        stale.unlink(missing_ok=True)
    summary = Summary(out_dir, files)
    bar = Progress(len(files), "materials") if progress else None
    say = bar.message if bar else log
    collide = colliding_names(files)
    tasks = [make_task(f, models, fit_options, str(f) in collide, cut,
                       getattr(executor, "fit_threads", 1), refit_stale, export_first, unscreened) for f in files]
    rows, done, full = [], set(), None      # done: ids of the tasks whose outcome came back

    def on_signal():            # a worker's finished result must not be left out of the summary
        if hasattr(executor, "stop"):
            executor.stop()
        summary.write(lock_timeout=SIGNAL_LOCK_SECONDS)

    with before_signal_exit(on_signal):
        outcomes = executor.run(tasks, out_dir, summary.results)
        try:
            for task, file_rows, disk_full in _outcomes(outcomes, out_dir, say):
                rows.extend(file_rows)
                done.add(id(task))
                try:
                    summary.add(file_rows)
                except OSError as err:      # even in place: the last write stands, the next run repairs
                    if err.errno != errno.ENOSPC:
                        raise
                    disk_full = True
                if bar:
                    bar.step(os.path.basename(printable(task.path)))
                if disk_full:
                    full = f"{out_dir}: {os.strerror(errno.ENOSPC)}"
                    say(f"stopped: {full}; the results written so far are kept")
                    break
        except ClusterLost as err:      # no worker left, the scheduler gone: the rest is not fitted
            full = str(err)
            say(f"stopped: {full}; the results written so far are kept")
        finally:
            if hasattr(outcomes, "close"):
                outcomes.close()    # stops the executor's workers (a full disk, an exception)
        left = [row for task in tasks if full and id(task) not in done for row in not_fitted_rows(task, full).rows]
        rows.extend(left)
        summary.add(left)
    for stale in stale_temp_files(out_dir):      # of a worker killed in a write meanwhile
        stale.unlink(missing_ok=True)
    note = stale_versions(rows, summary.results)
    if note:
        log(note)
    return rows


def stale_versions(rows: list[dict[str, str]], found: dict) -> str | None:
    """One line on the results resumed (``rows``) that another toolkit version fitted
    (``found``: the folder's results when the run began, by file name), or None."""
    from brdf import __version__
    versions = [found[r["result"]].toolkit_version for r in rows
                if r["status"] == "resumed" and r["result"] in found]
    old = sorted({v for v in versions if v != __version__})
    if not old:
        return None
    n = sum(v != __version__ for v in versions)
    return (f"{n} result(s) resumed were fitted by brdf-fit {', '.join(old)} (this is {__version__}): kept; "
            "--refit-stale fits them again")
