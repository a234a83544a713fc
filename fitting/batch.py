"""Fitting many models to many files: resumable, atomic, one bad file never ends it."""

import csv
import hashlib
import inspect
import io
import os
import pathlib
import sys
import time
from collections.abc import Callable, Iterable
from typing import TextIO

from brdf.model import model_string, parse_model
from data_loaders import MeasuredDataError, load

from .errors import InputError, one_line
from .fit import fit, fit_options_record, prepare
from .result import FitResult, ResultFileError, atomic_write_text

DIFFUSE_FAMILY = ("lambert", "burley", "frostbite", "cod_wwii")
# --model auto: GGX with each diffuse model, with and without energy
# compensation and clearcoat, and with a Schlick F90 below 1 (UE's and
# Filament's F90; glTF expresses it as KHR_materials_specular's factor) --
# all of them renderable by a game engine.
AUTO_OPTIONS = ("", "+ms", "+clearcoat", "+ms+clearcoat", "+f90", "+clearcoat+f90")
AUTO_FAMILY = tuple(model_string(parse_model(f"ggx+{d}{o}")) for d in DIFFUSE_FAMILY for o in AUTO_OPTIONS)
MEASURED_SUFFIXES = (".binary", ".bin", ".bsdf", ".npz", ".csv")
SUMMARY_FIELDS = ("material", "file", "model", "m1", "loss", "seconds", "status", "result")


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


def result_path(out_dir: str | os.PathLike[str], material: str, model: str) -> pathlib.Path:
    return pathlib.Path(out_dir) / f"{material}.{model}.json"


def _path_key(path):
    """A short, stable name suffix for an input path (two inputs with one base name)."""
    return hashlib.sha256(os.path.abspath(path).encode()).hexdigest()[:8]


def colliding_names(files: Iterable[str | os.PathLike[str]]) -> set[str]:
    """The files of a batch whose base names (hence material names) collide."""
    seen = {}
    for f in files:
        seen.setdefault(pathlib.Path(f).stem.lower(), []).append(str(f))
    return {f for group in seen.values() if len(group) > 1 for f in group}


def _result_name(out_dir, measured, path, models, collides):
    """The material part of the result file names of one input.

    Normally the material's name; ``NAME-<8 hex of the input's path>`` when
    another input of the batch has the same base name, when results under
    that name come from another input (a different file with different
    content), or when such suffixed results already exist (a resumed batch).
    """
    material = measured.material
    suffixed = f"{material}-{_path_key(path)}"
    if collides or any(result_path(out_dir, suffixed, m).exists() for m in models):
        return suffixed
    for model in models:
        other = _load_quietly(result_path(out_dir, material, model))
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


def _finished(path, sha256, options):
    """A result already on disk for the same input file and the same fit options."""
    result = _load_quietly(path)
    if result is None or result.provenance.get("sha256") != sha256:
        return None
    return result if result.optimizer.get("options") == options else None


_FIT_DEFAULTS = {name: p.default for name, p in inspect.signature(fit).parameters.items()
                 if p.kind is p.KEYWORD_ONLY}


def _options(fit_options):
    """The record fit() would store for these options, its own defaults filling the rest."""
    given = {**_FIT_DEFAULTS, **fit_options}
    return fit_options_record(*(given[k] for k in
                                ("loss", "optimizer", "samples", "starts", "seed", "max_theta", "polish")))



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


def _row(material, path, model, status, result=None, out=None):
    row = dict(material=material, file=str(path), model=model, m1="", loss="", seconds="",
               status=status, result=out.name if out is not None else "")
    if result is not None:
        row.update(m1=f"{result.errors['m1']:.6g}", loss=f"{result.errors['loss']:.6g}",
                   seconds=f"{result.optimizer.get('seconds_total', 0.0):.3f}")
    return row


def _problem(err):
    """One line for an exception from one input (a loader's message names the file)."""
    if isinstance(err, MeasuredDataError):
        return err.problem
    if isinstance(err, (ValueError, OSError)):
        return one_line(err)
    return one_line(f"{type(err).__name__}: {err}")


def fit_file(path: str | os.PathLike[str], models: list[str], out_dir: str | os.PathLike[str],
             fit_options: dict[str, object] | None = None, log: Callable[[str], object] = print,
             collides: bool = False) -> list[dict[str, str]]:
    """Fit every model to one file; returns summary rows.  Never raises for one input's problems.

    Any exception from this input (a bad file, a fit that cannot be
    determined, a reader's bug) becomes this input's error rows.
    """
    fit_options = dict(fit_options or {})
    options = _options(fit_options)
    try:
        measured = load(path)
        name = _result_name(out_dir, measured, path, models, collides)
    except Exception as err:  # noqa: BLE001 -- one bad input never ends the batch
        log(f"skipped {path}: {_problem(err)}")
        return [_row("", path, m, f"error: {_problem(err)}") for m in models]
    rows, data = [], None
    for model in models:
        out = result_path(out_dir, name, model)
        result = _finished(out, measured.provenance.sha256, options)
        status = "resumed"
        if result is None:
            try:
                if data is None:
                    data = prepare(measured, options["max_theta"], options["samples"], options["seed"])
                result = fit(measured, model, data=data, **fit_options)
                result.save(out)
            except Exception as err:  # noqa: BLE001
                log(f"skipped {model} on {path}: {_problem(err)}")
                rows.append(_row(measured.material, path, model, f"error: {_problem(err)}"))
                continue
            status = "fitted"
        rows.append(_row(measured.material, path, model, status, result, out))
    return rows


class Summary:
    """summary.csv: a row for every result in the output folder, and the errors.

    Results already in the folder (earlier runs, other inputs) are listed with
    status "earlier"; this run's rows replace them as files finish.  Error
    rows of earlier runs are kept for inputs this run does not touch.
    """

    def __init__(self, out_dir: str | os.PathLike[str], files: Iterable[str | os.PathLike[str]]) -> None:
        self.path = pathlib.Path(out_dir) / "summary.csv"
        self.rows = {}
        touched = {str(f) for f in files}
        for row in self._old_rows():
            if row.get("status", "").startswith("error") and row.get("file") not in touched:
                self.rows[("error", row["file"], row.get("model", ""))] = row
        for q in sorted(pathlib.Path(out_dir).glob("*.json")):
            result = _load_quietly(q)
            if result is not None:
                self.rows[q.name] = _row(result.material, result.provenance.get("file") or "",
                                         result.spec, "earlier", result, q)

    def _old_rows(self):
        try:
            with open(self.path, newline="") as f:
                return [dict(r) for r in csv.DictReader(f)]
        except (OSError, csv.Error, UnicodeDecodeError):
            return []

    def add(self, rows: Iterable[dict[str, str]]) -> None:
        for row in rows:
            key = row["result"] or ("error", row["file"], row["model"])
            self.rows[key] = row
        self.write()

    def write(self) -> pathlib.Path:
        buf = io.StringIO()
        writer = csv.DictWriter(buf, fieldnames=SUMMARY_FIELDS, extrasaction="ignore", restval="")
        writer.writeheader()
        writer.writerows(self.rows.values())
        atomic_write_text(self.path, buf.getvalue())
        return self.path


def _fit_file_job(args):
    path, models, out_dir, fit_options, collides = args
    messages = []
    rows = fit_file(path, models, out_dir, fit_options, log=messages.append, collides=collides)
    return path, rows, messages


def run_batch(inputs: Iterable[str | os.PathLike[str]], models: list[str], out_dir: str | os.PathLike[str],
              jobs: int = 1, fit_options: dict[str, object] | None = None, log: Callable[[str], object] = print,
              progress: bool = True) -> list[dict[str, str]]:
    """Fit ``models`` to every input; results and summary.csv land in ``out_dir``.

    Each result is written atomically as soon as it is done; re-running skips
    results already on disk for the same input (sha256) and the same fit
    options, so an interrupted batch resumes.  ``jobs`` > 1 fits files in
    parallel processes, which end with the parent.  Returns this run's rows.
    """
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
    tasks = [(str(f), list(models), str(out_dir), fit_options, str(f) in collide) for f in files]
    rows = []

    def finished(path, file_rows, messages):
        rows.extend(file_rows)
        for m in messages:
            say(m)
        summary.add(file_rows)
        if bar:
            bar.step(os.path.basename(path))

    if jobs > 1 and len(files) > 1:
        import concurrent.futures
        import multiprocessing
        from .interrupt import worker_init
        ctx = multiprocessing.get_context("spawn")
        with concurrent.futures.ProcessPoolExecutor(max_workers=jobs, mp_context=ctx,
                                                    initializer=worker_init) as pool:
            futures = {pool.submit(_fit_file_job, task): task for task in tasks}
            for future in concurrent.futures.as_completed(futures):
                path, models_, *_ = futures[future]
                try:
                    finished(*future.result())
                except Exception as err:  # noqa: BLE001 -- a worker died: this file's rows say so
                    problem = f"error: worker failed ({_problem(err)})"
                    finished(path, [_row("", path, m, problem) for m in models_],
                             [f"skipped {path}: {problem}"])
    else:
        for task in tasks:
            finished(*_fit_file_job(task))
    summary.write()
    return rows
