"""Fitting many models to many files: resumable, atomic, one bad file never ends it.

``run_batch`` turns the inputs into ``FileTask``s (brdf_fit.batch.task), hands
them to an executor (brdf_fit.batch.executors: local processes, or a Dask
cluster) and writes the summary as each file's ``FileOutcome`` comes back.
"""

import csv
import io
import os
import pathlib
from collections.abc import Callable, Iterable

from brdf_fit.errors import InputError
from brdf_fit.progress import Progress
from fitting.result import FitResult, atomic_write_text

from .folder import MEASURED_SUFFIXES, colliding_names, expand_inputs, load_quietly
from .task import failed_rows, make_task, summary_row

SUMMARY_FIELDS = ("material", "file", "model", "m1", "image", "exported_m1", "exported_image", "loss",
                  "seconds", "status", "result")


# --- the summary ---------------------------------------------------------------------------

class Summary:
    """summary.csv: a row for every result in the output folder, and the errors.

    Results already in the folder (earlier runs, other inputs) are listed with
    status "earlier"; this run's rows replace them as files finish.  Error
    rows of earlier runs are kept for inputs this run does not touch.
    ``results`` holds the valid results found in the folder, {name: FitResult}.
    """

    def __init__(self, out_dir: str | os.PathLike[str], files: Iterable[str | os.PathLike[str]]) -> None:
        self.path = pathlib.Path(out_dir) / "summary.csv"
        self.rows = {}
        self.results: dict[str, FitResult] = {}
        touched = {str(f) for f in files}
        for row in self._old_rows():
            if row.get("status", "").startswith(("error", "cut", "screened")) and row.get("file") not in touched:
                self.rows[("no result", row["file"], row.get("model", ""))] = row
        for q in sorted(pathlib.Path(out_dir).glob("*.json")):
            result = load_quietly(q)
            if result is not None:
                self.results[q.name] = result
                self.rows[q.name] = summary_row(result.material, result.provenance.get("file") or "",
                                         result.spec, "earlier", result, q.name)

    def _old_rows(self):
        try:
            with open(self.path, newline="") as f:
                return [dict(r) for r in csv.DictReader(f)]
        except (OSError, csv.Error, UnicodeDecodeError):
            return []

    def add(self, rows: Iterable[dict[str, str]]) -> None:
        for row in rows:
            key = row["result"] or ("no result", row["file"], row["model"])
            self.rows[key] = row
        self.write()

    def write(self) -> pathlib.Path:
        buf = io.StringIO()
        writer = csv.DictWriter(buf, fieldnames=SUMMARY_FIELDS, extrasaction="ignore", restval="")
        writer.writeheader()
        writer.writerows(self.rows.values())
        atomic_write_text(self.path, buf.getvalue())
        return self.path


def _write_returned(out_dir, outcome):
    """Write the result texts a worker sent back (``--send-data``), atomically; a
    result that cannot be written turns its row into an error row."""
    rows, messages = list(outcome.rows), list(outcome.messages)
    for name, text in outcome.written.items():
        try:
            atomic_write_text(out_dir / name, text)
        except OSError as err:
            problem = f"cannot write {out_dir / name} ({err.strerror or err})"
            messages.append(f"skipped {name}: {problem}")
            rows = [dict(r, status=f"error: {problem}", result="", m1="", image="", exported_m1="",
                         exported_image="", loss="", seconds="")
                    if r["result"] == name else r for r in rows]
    return rows, messages


def run_batch(inputs: Iterable[str | os.PathLike[str]], models: list[str], out_dir: str | os.PathLike[str],
              jobs: int = 1, fit_options: dict[str, object] | None = None, log: Callable[[str], object] = print,
              progress: bool = True, executor: object | None = None, cut: bool = False) -> list[dict[str, str]]:
    """Fit ``models`` to every input; results and summary.csv land in ``out_dir``.

    Each result is written atomically as soon as it is done; re-running skips
    results already on disk for the same input (sha256) and the same fit
    options, so an interrupted batch resumes.  The files are fitted by
    ``executor`` (brdf_fit.batch.executors): by default ``LocalExecutor(jobs)`` --
    in this process, or with ``jobs`` > 1 in parallel processes that end
    with the parent; ``DaskExecutor(address)`` fits them on a Dask cluster.
    A worker that dies or a task that fails becomes its file's error rows.
    ``cut``: models that cannot beat the best fitted so far on a file stop
    after their coarse stage (a "cut" row, no result; ``--model auto``).
    Returns this run's rows.
    """
    from .executors import LocalExecutor
    executor = executor if executor is not None else LocalExecutor(jobs)
    out_dir = pathlib.Path(out_dir)
    files = expand_inputs(inputs)
    if not files:
        raise InputError("no measured files (" + ", ".join(MEASURED_SUFFIXES) + ") in "
                         + ", ".join(str(i) for i in inputs))
    out_dir.mkdir(parents=True, exist_ok=True)
    for stale in out_dir.glob(".*.tmp"):      # left by a run killed in the middle of a write
        stale.unlink(missing_ok=True)
    summary = Summary(out_dir, files)
    bar = Progress(len(files), "materials") if progress else None
    say = bar.message if bar else log
    collide = colliding_names(files)
    tasks = [make_task(f, models, fit_options, str(f) in collide, cut,
                   getattr(executor, "fit_threads", 1)) for f in files]
    rows = []
    for task, outcome in executor.run(tasks, out_dir, summary.results):
        if isinstance(outcome, BaseException):
            outcome = failed_rows(task, outcome)
        file_rows, messages = _write_returned(out_dir, outcome)
        rows.extend(file_rows)
        for m in messages:
            say(m)
        summary.add(file_rows)
        if bar:
            bar.step(os.path.basename(task.path))
    summary.write()
    return rows
