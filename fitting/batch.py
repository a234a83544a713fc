"""Fitting many models to many files: resumable, atomic, one bad file never ends it."""

import csv
import io
import os
import pathlib
import sys
import time

from brdf.model import model_string, parse_model
from data_loaders import MeasuredDataError, load

from .fit import fit, prepare
from .result import FitResult, ResultFileError, atomic_write_text

DIFFUSE_FAMILY = ("lambert", "burley", "frostbite", "cod_wwii")
# --model auto: GGX with each diffuse model, with and without energy
# compensation and clearcoat, and with a Schlick F90 below 1 (UE's and
# Filament's F90; glTF expresses it as KHR_materials_specular's factor) --
# all of them renderable by a game engine.
AUTO_OPTIONS = ("", "+ms", "+clearcoat", "+ms+clearcoat", "+f90", "+clearcoat+f90")
AUTO_FAMILY = tuple(model_string(parse_model(f"ggx+{d}{o}")) for d in DIFFUSE_FAMILY for o in AUTO_OPTIONS)
MEASURED_SUFFIXES = (".binary", ".bin", ".bsdf", ".npz", ".csv")
SUMMARY_FIELDS = ("material", "file", "model", "m1", "loss", "seconds", "status")


def expand_models(text):
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


def expand_inputs(items):
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


def result_path(out_dir, material, model):
    return pathlib.Path(out_dir) / f"{material}.{model}.json"


def _finished(path, sha256):
    """A result already on disk for the same input file (so a batch can resume)."""
    if not path.exists():
        return None
    try:
        result = FitResult.load(path)
    except ResultFileError:
        return None
    return result if result.provenance.get("sha256") == sha256 else None


class Progress:
    """A one-line progress bar on stderr: items done, elapsed, ETA."""

    def __init__(self, total, label, stream=None):
        self.total, self.label, self.stream = total, label, stream or sys.stderr
        self.done, self.start = 0, time.perf_counter()

    def step(self, note=""):
        self.done += 1
        elapsed = time.perf_counter() - self.start
        eta = elapsed / self.done * (self.total - self.done)
        width = 24
        fill = int(width * self.done / max(self.total, 1))
        self.stream.write(f"\r[{'#' * fill}{'.' * (width - fill)}] {self.done}/{self.total} "
                          f"{self.label}  {elapsed:5.1f}s elapsed, ETA {eta:5.1f}s  {note[:40]:<40}")
        if self.done == self.total:
            self.stream.write("\n")
        self.stream.flush()


def fit_file(path, models, out_dir, fit_options=None, log=print):
    """Fit every model to one file; returns summary rows.  Never raises for bad input."""
    fit_options = dict(fit_options or {})
    try:
        measured = load(path)
    except MeasuredDataError as err:
        log(f"skipped {path}: {err}")
        return [dict(material="", file=str(path), model=m, m1="", loss="", seconds="",
                     status=f"error: {err.problem}") for m in models]
    rows, data = [], None
    for model in models:
        out = result_path(out_dir, measured.material, model)
        result = _finished(out, measured.provenance.sha256)
        status = "resumed"
        if result is None:
            try:
                if data is None:
                    data = prepare(measured, fit_options.get("max_theta", 80.0),
                                   fit_options.get("samples", 100_000), fit_options.get("seed", 0))
                result = fit(measured, model, data=data, **fit_options)
            except ValueError as err:
                log(f"skipped {model} on {path}: {err}")
                rows.append(dict(material=measured.material, file=str(path), model=model, m1="",
                                 loss="", seconds="", status=f"error: {err}"))
                continue
            result.save(out)
            status = "fitted"
        rows.append(dict(material=measured.material, file=str(path), model=model,
                         m1=f"{result.errors['m1']:.6g}", loss=f"{result.errors['loss']:.6g}",
                         seconds=f"{result.optimizer['seconds_total']:.3f}", status=status))
    return rows


def write_summary(out_dir, rows):
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=SUMMARY_FIELDS)
    writer.writeheader()
    writer.writerows(rows)
    path = pathlib.Path(out_dir) / "summary.csv"
    atomic_write_text(path, buf.getvalue())
    return path


def _fit_file_job(args):
    path, models, out_dir, fit_options = args
    messages = []
    rows = fit_file(path, models, out_dir, fit_options, log=messages.append)
    return path, rows, messages


def run_batch(inputs, models, out_dir, jobs=1, fit_options=None, log=print, progress=True):
    """Fit ``models`` to every input; results and summary.csv land in ``out_dir``.

    Each result is written atomically as soon as it is done; re-running skips
    results already on disk for the same input (sha256), so an interrupted
    batch resumes.  ``jobs`` > 1 fits files in parallel processes.
    """
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    files = expand_inputs(inputs)
    bar = Progress(len(files), "materials") if progress and files else None
    rows = []
    tasks = [(str(f), list(models), str(out_dir), fit_options) for f in files]
    if jobs > 1 and len(files) > 1:
        import concurrent.futures
        import multiprocessing
        ctx = multiprocessing.get_context("spawn")
        with concurrent.futures.ProcessPoolExecutor(max_workers=jobs, mp_context=ctx) as pool:
            for path, file_rows, messages in pool.map(_fit_file_job, tasks):
                rows.extend(file_rows)
                for m in messages:
                    log(m)
                write_summary(out_dir, rows)
                if bar:
                    bar.step(os.path.basename(path))
    else:
        for task in tasks:
            path, file_rows, messages = _fit_file_job(task)
            rows.extend(file_rows)
            for m in messages:
                log(m)
            write_summary(out_dir, rows)
            if bar:
                bar.step(os.path.basename(path))
    write_summary(out_dir, rows)
    return rows
