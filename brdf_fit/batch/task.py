"""The work of a batch on one input: fit every model of a ``FileTask``, never raising for its problems.

``fit_task`` reads the input by path and writes its results into the output
folder; ``fit_bytes`` gets the input's bytes (``--send-data``) and returns
the result files as JSON texts for the client to write.  Both run
``_fit_input``, which sees the output folder through a ``ResultFolder``.
"""

import dataclasses
import errno
import inspect
import os
import pathlib
import shutil
import tempfile
from collections.abc import Callable
from typing import NamedTuple

from brdf.own import load_sources
from data_loaders import MeasuredDataError, load

from brdf_fit.errors import one_line
from data_loaders.atomic import owner_gone, owner_tag
from fitting.fit import CUT_MARGIN, ModelCut, fit, fit_options_record
from fitting.file_names import describe_renaming, safe_stem
from fitting.fit_models import fit_models
from fitting.result import FitResult
from fitting.screen import ModelScreened

from brdf_fit.export.export_first import candidates, family_for

from .folder import ResultFolder, ResultSnapshot, finished, material_name, moved, printable, result_name
from .memory import give_back_memory, reuse_large_blocks
from .screening_record import ScreeningRecord

COPY_PREFIX = "brdf-fit-copy-"     # a --send-data input's private copy: COPY_PREFIX + HOST-PID.RANDOM

_FIT_DEFAULTS = {name: p.default for name, p in inspect.signature(fit).parameters.items()
                 if p.kind is p.KEYWORD_ONLY}


def _options(fit_options):
    """The record fit() would store for these options, its own defaults filling the rest."""
    given = {**_FIT_DEFAULTS, **fit_options}
    return fit_options_record(*(given[k] for k in
                                ("loss", "optimizer", "samples", "starts", "seed", "max_theta", "polish",
                                 "image_weight")))


def summary_row(material, path, model, status, result=None, name=""):
    row = dict(material=printable(material), file=printable(path), model=model, m1="", image="", exported_m1="",
               exported_image="", loss="", seconds="", status=status, result=name)
    if result is not None:
        row.update({k: f"{result.errors[k]:.6g}" for k in ("m1", "image", "exported_m1", "exported_image",
                                                           "loss") if k in result.errors},
                   seconds=f"{result.optimizer.get('seconds_total', 0.0):.3f}")
    return row


def _problem(err):
    """One line for an exception from one input (a loader's message names the file)."""
    if isinstance(err, MeasuredDataError):
        return printable(err.problem)
    if isinstance(err, (ValueError, OSError)):
        return printable(one_line(err))
    return printable(one_line(f"{type(err).__name__}: {err}"))


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
    cut: bool = False            # auto: screen the models, refine the contenders (``fit_models(screen=)``)
    threads: int = 1             # fits run at once on this file (``fit_models``)
    refit_stale: bool = False    # results of another toolkit version are fitted again
    export_first: bool = False   # the library: the glTF family fitted beside ``models``, screened apart
    model_files: tuple = ()      # (path as typed, bytes) of the own models' files (brdf.own.files_of)
    unscreened: tuple[str, ...] = ()   # with ``cut``: models fitted fully (fitting.auto.fitted_fully)

    def all_models(self, isotropic: bool = True) -> list[str]:
        """Every model fitted to the input: ``models`` and, with ``export_first``, the glTF
        family of an ``isotropic`` (or not) measurement (brdf_fit.export.export_first.candidates)."""
        return candidates(list(self.models), isotropic)[0] if self.export_first else list(self.models)


class FileOutcome(NamedTuple):
    """What the work on one input gives back: its summary rows, the messages to
    show, and (``--send-data`` only) the result files for the client to write,
    {name: JSON text}."""

    rows: list[dict[str, str]]
    messages: list[str]
    written: dict[str, str]
    disk_full: bool = False     # a result could not be written: no space left on the device


def _fit_input(task, source, folder, log, on_row=None):
    """Fit every model of ``task`` to the file at ``source`` (the input itself, or a
    private copy of its bytes); results go to ``folder``.  Returns (summary rows,
    whether a result could not be written for want of space); ``on_row``
    (in-process runs) is called with each model's row as it is done.
    With ``task.cut`` (auto) the screening is recorded beside the results
    (screening_record.py) and a re-run takes it from there.

    Any exception from this input (a bad file, a fit that cannot be
    determined, a reader's bug, a result that cannot be written) becomes
    this input's error rows.
    """
    options = _options(task.fit_options)
    path = printable(task.path)
    disk_full = False

    def problem(err):           # a message naming the private copy names the input instead
        text = _problem(err)
        return text.replace(printable(source), path) if source != path else text

    try:
        load_sources(task.model_files)      # models of one's own: the client's files, as it loaded them
        measured = load(source)
        if os.path.abspath(source) != task.absolute:    # a copy: provenance names the input
            measured = dataclasses.replace(measured, provenance=dataclasses.replace(
                measured.provenance, path=task.absolute))
        models = task.all_models(measured.isotropic)
        name = material_name(folder, measured, task.absolute, models, task.collides)
    except Exception as err:  # noqa: BLE001 -- one bad input never ends the batch
        log(f"skipped {path}: {problem(err)}")
        return [summary_row("", path, m, f"error: {problem(err)}") for m in task.all_models()], disk_full
    if safe_stem(measured.material) != measured.material:
        log(f"{path}: {printable(describe_renaming(measured.material, safe_stem(measured.material)))}")
    outs = {model: result_name(name, model) for model in models}
    known, olds = {}, set()
    for model, out in outs.items():
        result = finished(folder.load(out), measured.provenance.sha256, options, task.refit_stale)
        if result is not None:
            known[model] = _moved(result, task.absolute, folder, out, olds)
    if olds:
        log(f"{path}: found by its sha256 in the results of {printable(', '.join(sorted(olds)))}, "
            "which is gone: their provenance names this file now")
    family = family_for(measured.isotropic) if task.export_first else []
    record = ScreeningRecord(folder, name, measured.provenance.sha256, options, models)   # the glTF family too
    rows = []
    for model, outcome in fit_models(measured, models, cut=task.cut, threads=task.threads,
                                     unscreened=task.unscreened, apart=family,
                                     screen="fit" if task.cut else None, known=known,
                                     screened=record.load() if task.cut else None, on_screened=record.save,
                                     **task.fit_options):
        if isinstance(outcome, ModelScreened):     # its screening errors, no result
            rows.append(summary_row(measured.material, path, model, "screened", outcome))
        elif isinstance(outcome, ModelCut):
            rows.append(summary_row(measured.material, path, model, cut_status(outcome)))
        elif isinstance(outcome, Exception):
            log(f"skipped {model} on {path}: {problem(outcome)}")
            rows.append(summary_row(measured.material, path, model, f"error: {problem(outcome)}"))
        elif model in known:
            rows.append(summary_row(measured.material, path, model, "resumed", outcome, outs[model]))
        else:
            try:
                folder.save(outs[model], outcome)
            except OSError as err:      # a full disk, a folder made read-only meanwhile
                disk_full = disk_full or err.errno == errno.ENOSPC
                reason = printable(f"cannot write {err.filename or outs[model]} ({err.strerror or err})")
                log(f"skipped {model} on {path}: {reason}")
                rows.append(summary_row(measured.material, path, model, f"error: {reason}"))
            else:
                rows.append(summary_row(measured.material, path, model, "fitted", outcome, outs[model]))
        if on_row is not None:
            on_row(rows[-1])
    return rows, disk_full


def _moved(result, absolute, folder, name, olds):
    """``result``, its provenance set to the input at ``absolute`` (and saved as ``name``)
    where the file it names is gone (folder.moved); the old file name added to ``olds``."""
    again = moved(result, absolute)
    if again is None:
        return result
    try:
        folder.save(name, again)
    except OSError:             # a read-only folder: the result stands as it is
        return result
    olds.add(result.provenance["file"])
    return again


def cut_status(cut: ModelCut) -> str:
    """The summary's status of a model cut after its coarse stage."""
    return f"cut: coarse M1 {cut.coarse_m1:.4g} > {CUT_MARGIN:g} x best {cut.bound:.4g}"


def make_task(path, models, fit_options, collides, cut=False, threads=1, refit_stale=False,
              export_first=False, unscreened=()):
    from brdf.own import files_of
    return FileTask(str(path), os.path.abspath(path), tuple(models), dict(fit_options or {}), collides, cut,
                    threads, refit_stale, export_first, files_of(models), tuple(unscreened) if cut else ())


def fit_file(path: str | os.PathLike[str], models: list[str], out_dir: str | os.PathLike[str],
             fit_options: dict[str, object] | None = None, log: Callable[[str], object] = print,
             collides: bool = False) -> list[dict[str, str]]:
    """Fit every model to one file; returns summary rows.  Never raises for one input's problems.

    Any exception from this input (a bad file, a fit that cannot be
    determined, a reader's bug) becomes this input's error rows.
    """
    return _fit_input(make_task(path, models, fit_options, collides), str(path), ResultFolder(out_dir), log)[0]


def fit_task(task: FileTask, out_dir: str, read_absolute: bool = False,
             on_row: Callable[[dict[str, str]], object] | None = None, own_process: bool = False) -> FileOutcome:
    """The work on one input, by path: read it, write its results into ``out_dir``.

    ``read_absolute``: read ``task.absolute`` (a worker elsewhere, whose
    working folder is not the client's) rather than the path as given.
    ``on_row``: called with each model's summary row as it is done (in-process runs).
    ``own_process``: this runs in a batch's own worker process (``memory.give_back_memory``).
    """
    reuse_large_blocks()        # a Dask worker's allocator (memory.py)
    messages: list[str] = []
    source = task.absolute if read_absolute else task.path
    rows, disk_full = _fit_input(task, source, ResultFolder(out_dir), messages.append, on_row)
    give_back_memory(own_process)   # the table and its fits' buffers: the next file starts from what is held
    return FileOutcome(rows, messages, {}, disk_full)


def fit_bytes(data: bytes, task: FileTask, results: dict[str, FitResult]) -> FileOutcome:
    """The work on one input, by bytes (``--send-data``): no file is shared.

    The bytes are written to a private temporary file with the input's base
    name (loaders take paths; the name gives the material), loaded, and the
    provenance set back to the input's real path -- the sha256 is of the same
    bytes -- so the results equal a local run's.  ``results`` is the output
    folder's results when the batch began (resume, name collisions); the new
    results come back as JSON texts in ``FileOutcome.written``.
    """
    reuse_large_blocks()
    remove_stale_copies()       # of a worker killed in a fit on this machine (its task runs again here)
    messages: list[str] = []
    folder = ResultSnapshot(results)
    with tempfile.TemporaryDirectory(prefix=f"{COPY_PREFIX}{owner_tag()}.") as tmp:
        source = os.path.join(tmp, os.path.basename(task.absolute) or "input")
        with open(source, "wb") as f:
            f.write(data)
        rows, _ = _fit_input(task, source, folder, messages.append)
    return FileOutcome(rows, messages, folder.written)


def remove_stale_copies(folder: str | None = None) -> list[str]:
    """Remove the private copies (``fit_bytes``) in ``folder`` (default: the temporary
    folder) whose process is gone -- a worker killed in a fit cannot remove its own --
    never those of a live one.  Returns the names removed."""
    removed = []
    for path in pathlib.Path(folder or tempfile.gettempdir()).glob(COPY_PREFIX + "*"):
        tag = path.name[len(COPY_PREFIX):].rpartition(".")[0]
        if tag and owner_gone(tag):
            shutil.rmtree(path, ignore_errors=True)
            removed.append(path.name)
    return removed


def failed_rows(task: FileTask, err: BaseException) -> FileOutcome:
    """The outcome of an input whose worker died or whose task failed: its error rows."""
    if type(err).__name__ == "KilledWorker":      # Dask's message is a paragraph with a link
        tries = getattr(err, "allowed_failures", None)
        where = getattr(getattr(err, "last_worker", None), "address", None)
        problem = ("error: worker failed (KilledWorker: the workers that ran it died"
                   + (f" {tries + 1} time(s)" if isinstance(tries, int) else "")
                   + (f", the last {printable(where)}" if isinstance(where, str) else "") + ")")
    else:
        problem = f"error: worker failed ({_problem(err)})"
    return FileOutcome([summary_row("", task.path, m, problem) for m in task.all_models()],
                       [f"skipped {printable(task.path)}: {problem}"], {})


def not_fitted_rows(task: FileTask, reason: str) -> FileOutcome:
    """The outcome of an input the batch did not fit (it stopped: the disk is full)."""
    problem = f"error: not fitted ({reason})"
    return FileOutcome([summary_row("", task.path, m, problem) for m in task.all_models()], [], {})
