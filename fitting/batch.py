"""Fitting many models to many files: resumable, atomic, one bad file never ends it.

``run_batch`` turns the inputs into ``FileTask``s, hands them to an executor
(fitting.executors: local processes, or a Dask cluster) and writes the
summary as each file's ``FileOutcome`` comes back.  The work on one file is
``fit_task`` (the input read by path, results written into the output
folder) or ``fit_bytes`` (the input's bytes sent along, results returned as
JSON texts for the client to write); both run ``_fit_input``, which sees the
output folder through a ``ResultFolder`` and never raises for one input's
problems.
"""

import csv
import dataclasses
import hashlib
import inspect
import io
import os
import pathlib
import sys
import tempfile
import time
from collections.abc import Callable, Iterable
from typing import NamedTuple, TextIO

from brdf.model import model_string, parse_model
from data_loaders import MeasuredDataError, load

from .errors import InputError, one_line
from .fit import CUT_MARGIN, ModelCut, fit, fit_options_record
from .fit_models import fit_models
from .result import FitResult, ResultFileError, atomic_write_text

DIFFUSE_FAMILY = ("lambert", "burley", "frostbite", "cod_wwii")
# --model auto: GGX with each diffuse model, with and without energy
# compensation and clearcoat, and with a Schlick F90 below 1 (UE's and
# Filament's F90; glTF expresses it as KHR_materials_specular's factor) --
# all of them renderable by a game engine.  In the order they are fitted: the
# likeliest winners first, so that models that cannot win are cut early
# (``run_batch(cut=)``); a model with a switch more (+ms) after the one whose
# optimum it starts from (``fit.warm_start``).
AUTO_OPTIONS = ("+clearcoat+f90", "+f90", "+clearcoat", "+ms+clearcoat", "", "+ms")
AUTO_FAMILY = tuple(model_string(parse_model(f"ggx+{d}{o}")) for d in DIFFUSE_FAMILY for o in AUTO_OPTIONS)
MEASURED_SUFFIXES = (".binary", ".bin", ".bsdf", ".npz", ".csv")
SUMMARY_FIELDS = ("material", "file", "model", "m1", "image", "exported_m1", "exported_image", "loss",
                  "seconds", "status", "result")


def expand_models(text: str) -> list[str]:
    """'a,b,c' or 'auto' -> list of canonical model strings (validated)."""
    names = []
    for item in str(text).split(","):
        item = item.strip()
        if not item:
            continue
        if item == "auto":
            names.extend(AUTO_FAMILY)
        else:
            names.append(model_string(parse_model(item)))
    if not names:
        raise ValueError("no model given")
    return list(dict.fromkeys(names))


def uses_auto(text: str) -> bool:
    """True when a --model / --models value asks for 'auto' (models that cannot win are cut)."""
    return "auto" in (item.strip() for item in str(text).split(","))


def expand_inputs(items: Iterable[str | os.PathLike[str]]) -> list[pathlib.Path]:
    """Files and folders -> sorted list of files (folders: measured-data suffixes)."""
    files = []
    for item in items:
        p = pathlib.Path(item)
        if p.is_dir():
            files.extend(sorted(q for q in p.iterdir()
                                if q.is_file() and q.suffix.lower() in MEASURED_SUFFIXES))
        else:
            files.append(p)
    return files


def result_name(material: str, model: str) -> str:
    """The file name of a result: ``MATERIAL.MODEL.json``."""
    return f"{material}.{model}.json"


def result_path(out_dir: str | os.PathLike[str], material: str, model: str) -> pathlib.Path:
    """Where the result of ``model`` on ``material`` lives in ``out_dir``."""
    return pathlib.Path(out_dir) / result_name(material, model)


def _path_key(path):
    """A short, stable name suffix for an input path (two inputs with one base name)."""
    return hashlib.sha256(os.path.abspath(path).encode()).hexdigest()[:8]


def colliding_names(files: Iterable[str | os.PathLike[str]]) -> set[str]:
    """The files of a batch whose base names (hence material names) collide."""
    seen = {}
    for f in files:
        seen.setdefault(pathlib.Path(f).stem.lower(), []).append(str(f))
    return {f for group in seen.values() if len(group) > 1 for f in group}


# --- the output folder as one file's fit sees it -----------------------------------------

class ResultFolder:
    """The output folder on disk (a local run, or Dask workers on a shared filesystem)."""

    def __init__(self, out_dir: str | os.PathLike[str]) -> None:
        self.out_dir = pathlib.Path(out_dir)

    def exists(self, name: str) -> bool:
        """Whether a file ``name`` is in the folder."""
        return (self.out_dir / name).exists()

    def load(self, name: str) -> FitResult | None:
        """The valid result ``name``, or None (absent or not a readable result)."""
        return _load_quietly(self.out_dir / name)

    def save(self, name: str, result: FitResult) -> None:
        """Write ``result`` as ``name``, atomically."""
        result.save(self.out_dir / name)


class ResultSnapshot(ResultFolder):
    """The output folder as it was when the batch began (a Dask worker that has no
    access to it: ``--send-data``).  Saved results are kept in ``written``
    ({name: JSON text, exactly what FitResult.save writes}) for the client to write."""

    def __init__(self, results: dict[str, FitResult]) -> None:
        self.results = dict(results)
        self.written: dict[str, str] = {}

    def exists(self, name: str) -> bool:
        """Whether ``name`` was in the folder (or was saved here since)."""
        return name in self.results or name in self.written

    def load(self, name: str) -> FitResult | None:
        """The result ``name`` of the snapshot, or None."""
        return self.results.get(name)

    def save(self, name: str, result: FitResult) -> None:
        """Keep ``result``'s JSON text for the client (validated as FitResult.save does)."""
        self.written[name] = result.to_json() + "\n"


def _result_name(folder, measured, path, models, collides):
    """The material part of the result file names of one input.

    Normally the material's name; ``NAME-<8 hex of the input's path>`` when
    another input of the batch has the same base name, when results under
    that name come from another input (a different file with different
    content), or when such suffixed results already exist (a resumed batch).
    """
    material = measured.material
    suffixed = f"{material}-{_path_key(path)}"
    if collides or any(folder.exists(result_name(suffixed, m)) for m in models):
        return suffixed
    for model in models:
        other = folder.load(result_name(material, model))
        other_file = (other.provenance.get("file") or "") if other is not None else ""
        if other is not None and other.provenance.get("sha256") != measured.provenance.sha256 \
                and os.path.abspath(other_file) != os.path.abspath(path):
            return suffixed
    return material


def _load_quietly(path):
    if not path.exists():
        return None
    try:
        return FitResult.load(path)
    except ResultFileError:
        return None


def _finished(result, sha256, options):
    """``result`` if it is one of the same input file with the same fit options, else None."""
    if result is None or result.provenance.get("sha256") != sha256:
        return None
    return result if result.optimizer.get("options") == options else None


_FIT_DEFAULTS = {name: p.default for name, p in inspect.signature(fit).parameters.items()
                 if p.kind is p.KEYWORD_ONLY}


def _options(fit_options):
    """The record fit() would store for these options, its own defaults filling the rest."""
    given = {**_FIT_DEFAULTS, **fit_options}
    return fit_options_record(*(given[k] for k in
                                ("loss", "optimizer", "samples", "starts", "seed", "max_theta", "polish",
                                 "image_weight")))


class Progress:
    """Progress on stderr: a tqdm bar on a terminal, one plain line per step otherwise
    (a log file gets readable lines, not carriage returns).

    ``message`` prints a line above the bar (never glued onto it).
    """

    def __init__(self, total: int, label: str, stream: TextIO | None = None) -> None:
        self.total, self.label, self.stream = total, label, stream or sys.stderr
        self.done, self.start = 0, time.perf_counter()
        self.bar = None
        if hasattr(self.stream, "isatty") and self.stream.isatty():
            import shutil
            from tqdm import tqdm
            width = shutil.get_terminal_size((100, 24)).columns or 100
            self.bar = tqdm(total=total, desc=label, file=self.stream, ncols=min(width, 120))

    def message(self, text: str) -> None:
        if self.bar is not None:
            self.bar.write(text, file=self.stream)
        else:
            self.stream.write(f"{text}\n")
            self.stream.flush()

    def step(self, note: str = "") -> None:
        self.done += 1
        if self.bar is not None:
            self.bar.set_postfix_str(note[:40], refresh=False)
            self.bar.update(1)
            if self.done == self.total:
                self.bar.close()
            return
        elapsed = time.perf_counter() - self.start
        eta = elapsed / self.done * (self.total - self.done)
        self.stream.write(f"[{self.done}/{self.total} {self.label}  {elapsed:5.1f}s elapsed, "
                          f"ETA {eta:5.1f}s] {note}\n")
        self.stream.flush()


def _row(material, path, model, status, result=None, name=""):
    row = dict(material=material, file=str(path), model=model, m1="", image="", exported_m1="",
               exported_image="", loss="", seconds="", status=status, result=name)
    if result is not None:
        row.update({k: f"{result.errors[k]:.6g}" for k in ("m1", "image", "exported_m1", "exported_image",
                                                           "loss") if k in result.errors},
                   seconds=f"{result.optimizer.get('seconds_total', 0.0):.3f}")
    return row


def _problem(err):
    """One line for an exception from one input (a loader's message names the file)."""
    if isinstance(err, MeasuredDataError):
        return err.problem
    if isinstance(err, (ValueError, OSError)):
        return one_line(err)
    return one_line(f"{type(err).__name__}: {err}")


# --- one input -----------------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class FileTask:
    """One input of a batch: everything a worker needs to fit it (plain, picklable).

    ``path`` is the input as given (the summary's ``file`` column and the
    messages name it); ``absolute`` is the client's absolute path of it (what
    a worker on a shared filesystem reads, and what the results' provenance
    records, as a local run does).
    """

    path: str
    absolute: str
    models: tuple[str, ...]
    fit_options: dict[str, object]
    collides: bool = False
    cut: bool = False            # cut models that cannot win (``fit(cut_above=)``)
    threads: int = 1             # fits run at once on this file (``fit_models``)


class FileOutcome(NamedTuple):
    """What the work on one input gives back: its summary rows, the messages to
    show, and (``--send-data`` only) the result files for the client to write,
    {name: JSON text}."""

    rows: list[dict[str, str]]
    messages: list[str]
    written: dict[str, str]


def _fit_input(task, source, folder, log):
    """Fit every model of ``task`` to the file at ``source`` (the input itself, or a
    private copy of its bytes); results go to ``folder``.  Returns summary rows.

    Any exception from this input (a bad file, a fit that cannot be
    determined, a reader's bug) becomes this input's error rows.
    """
    options = _options(task.fit_options)
    path = task.path

    def problem(err):           # a message naming the private copy names the input instead
        text = _problem(err)
        return text.replace(source, path) if source != path else text

    try:
        measured = load(source)
        if os.path.abspath(source) != task.absolute:    # a copy: provenance names the input
            measured = dataclasses.replace(measured, provenance=dataclasses.replace(
                measured.provenance, path=task.absolute))
        name = _result_name(folder, measured, task.absolute, task.models, task.collides)
    except Exception as err:  # noqa: BLE001 -- one bad input never ends the batch
        log(f"skipped {path}: {problem(err)}")
        return [_row("", path, m, f"error: {problem(err)}") for m in task.models]
    outs = {model: result_name(name, model) for model in task.models}
    known = {}
    for model, out in outs.items():
        result = _finished(folder.load(out), measured.provenance.sha256, options)
        if result is not None:
            known[model] = result
    rows = []
    for model, outcome in fit_models(measured, list(task.models), cut=task.cut, threads=task.threads,
                                     known=known, **task.fit_options):
        if isinstance(outcome, ModelCut):
            rows.append(_row(measured.material, path, model, cut_status(outcome)))
        elif isinstance(outcome, Exception):
            log(f"skipped {model} on {path}: {problem(outcome)}")
            rows.append(_row(measured.material, path, model, f"error: {problem(outcome)}"))
        elif model in known:
            rows.append(_row(measured.material, path, model, "resumed", outcome, outs[model]))
        else:
            folder.save(outs[model], outcome)
            rows.append(_row(measured.material, path, model, "fitted", outcome, outs[model]))
    return rows


def cut_status(cut: ModelCut) -> str:
    """The summary's status of a model cut after its coarse stage."""
    return f"cut: coarse M1 {cut.coarse_m1:.4g} > {CUT_MARGIN:g} x best {cut.bound:.4g}"


def _task(path, models, fit_options, collides, cut=False, threads=1):
    return FileTask(str(path), os.path.abspath(path), tuple(models), dict(fit_options or {}), collides, cut,
                    threads)


def fit_file(path: str | os.PathLike[str], models: list[str], out_dir: str | os.PathLike[str],
             fit_options: dict[str, object] | None = None, log: Callable[[str], object] = print,
             collides: bool = False) -> list[dict[str, str]]:
    """Fit every model to one file; returns summary rows.  Never raises for one input's problems.

    Any exception from this input (a bad file, a fit that cannot be
    determined, a reader's bug) becomes this input's error rows.
    """
    return _fit_input(_task(path, models, fit_options, collides), str(path), ResultFolder(out_dir), log)


def fit_task(task: FileTask, out_dir: str, read_absolute: bool = False) -> FileOutcome:
    """The work on one input, by path: read it, write its results into ``out_dir``.

    ``read_absolute``: read ``task.absolute`` (a worker elsewhere, whose
    working folder is not the client's) rather than the path as given.
    """
    messages: list[str] = []
    source = task.absolute if read_absolute else task.path
    rows = _fit_input(task, source, ResultFolder(out_dir), messages.append)
    return FileOutcome(rows, messages, {})


def fit_bytes(data: bytes, task: FileTask, results: dict[str, FitResult]) -> FileOutcome:
    """The work on one input, by bytes (``--send-data``): no file is shared.

    The bytes are written to a private temporary file with the input's base
    name (loaders take paths; the name gives the material), loaded, and the
    provenance set back to the input's real path -- the sha256 is of the same
    bytes -- so the results equal a local run's.  ``results`` is the output
    folder's results when the batch began (resume, name collisions); the new
    results come back as JSON texts in ``FileOutcome.written``.
    """
    messages: list[str] = []
    folder = ResultSnapshot(results)
    with tempfile.TemporaryDirectory(prefix="brdf-fit-") as tmp:
        source = os.path.join(tmp, os.path.basename(task.absolute) or "input")
        with open(source, "wb") as f:
            f.write(data)
        rows = _fit_input(task, source, folder, messages.append)
    return FileOutcome(rows, messages, folder.written)


def failed_rows(task: FileTask, err: BaseException) -> FileOutcome:
    """The outcome of an input whose worker died or whose task failed: its error rows."""
    problem = f"error: worker failed ({_problem(err)})"
    return FileOutcome([_row("", task.path, m, problem) for m in task.models],
                       [f"skipped {task.path}: {problem}"], {})


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
            if row.get("status", "").startswith(("error", "cut")) and row.get("file") not in touched:
                self.rows[("no result", row["file"], row.get("model", ""))] = row
        for q in sorted(pathlib.Path(out_dir).glob("*.json")):
            result = _load_quietly(q)
            if result is not None:
                self.results[q.name] = result
                self.rows[q.name] = _row(result.material, result.provenance.get("file") or "",
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
    ``executor`` (fitting.executors): by default ``LocalExecutor(jobs)`` --
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
    tasks = [_task(f, models, fit_options, str(f) in collide, cut,
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
