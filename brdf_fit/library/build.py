"""A measured database fitted, browsed and exported as one: ``brdf-fit library DIR... --out LIB``.

The library is made of what the toolkit already has, in one folder:

- ``LIB/results/``: the fits, by ``batch`` (resumable, ``--jobs``, a Dask cluster;
  ``--models auto`` by default) and its ``summary.csv``;
- ``LIB/materials/``: each material's report page (brdf_fit.report: tables, plots,
  lit spheres, the three.js viewer) -- rewritten only when its results changed;
- ``LIB/thumbs/``: the measured and fitted spheres of each material's best fit
  (brdf_fit.library.thumbnails);
- ``LIB/gltf/``: each material's exported glTF (.glb) and MaterialX (.mtlx) file,
  and ``LIB/materials.glb``: every material on its own sphere, in one file;
- with OpenPBR's own models among the fits (``--models auto,openpbr``): ``LIB/materials.mtlx``
  and ``LIB/materials.blend`` (or the script that writes it), each material's best OpenPBR fit
  1:1 (brdf_fit.library.native);
- ``LIB/index.html``: the gallery (brdf_fit.library.gallery);
  ``LIB/analysis.html``: the models compared across the database
  (brdf_fit.library.analysis).

The fits are those of the models asked for (``auto``: screened) and, beside them, of
the glTF family, fitted in full (export-first).  The material shipped as glTF is
chosen among all of them as ``brdf-fit export`` chooses (``fitting.ranking.shipped_best``:
the best exported ranking, M1 + 0.3 x image error of the written material, among the
materials within 1.05 x the lowest exported image error); the gallery and the pages say
which path won and by how much (brdf_fit.export.export_first.Shipped).  The gallery's
"best model" is the fit that ranks best itself.  Only one measured table is held at a
time (a page's plots and the thumbnails need it), so memory stays bounded for any
number of materials.  Every file is written atomically; a library killed at any
point is completed by the same command again (fits resume, pages whose results
are unchanged are kept: ``STATE_NAME`` records the digest of each page's results and
the files written for it, so a file deleted or truncated since is written again:
brdf_fit.library.state).
"""

import dataclasses
import hashlib
import os
import pathlib
from collections.abc import Callable, Iterable

from fitting.ranking import shipped_best
from fitting.result import FitResult, atomic_write_text

from brdf_fit.errors import printable
from brdf_fit.report.identity import material_groups, material_stem

from .gallery import Entry, gallery_page, shown_name
from .material import library_files
from .native import write_native
from .state import STATE_NAME, current, read_state, write_state, written  # noqa: F401 -- STATE_NAME: its old home

PAGES_VERSION = "4"                     # bump when the pages' content changes: every page is written again
PAGES_PER_WORKER = 50                   # pages a worker process must have to pay for its start (imports,
                                        # first programs: ~3 s of a core; a page ~0.1 s): fewer stay here


@dataclasses.dataclass
class Library:
    """A written library: its folder, the gallery's entries and the results by material (best first)."""

    folder: pathlib.Path
    entries: list[Entry]
    groups: dict[str, list[FitResult]]

    def table(self):
        """The library's results as a pandas DataFrame (brdf_fit.notebook.results_table)."""
        from brdf_fit.notebook.table import results_table
        return results_table(self.folder / "results")


def build_library(inputs: Iterable[str | os.PathLike[str]], out_dir: str | os.PathLike[str],
                  models: str = "auto", *, jobs: int = 1, executor: object | None = None,
                  fit_options: dict[str, object] | None = None, keep_all: bool = False,
                  log: Callable[[str], object] = print, progress: bool = False,
                  command_line: str = "", refit_stale: bool = False) -> Library:
    """Fit ``models`` to every measured file of ``inputs`` (files or folders) into
    ``out_dir``/results, then write the library's pages and files (``write_library``)
    of the materials of ``inputs``: results in ``out_dir``/results of files not given
    this time are left out, and one line says how many."""
    from brdf_fit.batch.run import run_batch
    from fitting.auto import expand_models, fitted_fully, uses_auto
    out_dir = pathlib.Path(out_dir)
    rows = run_batch(inputs, expand_models(models), out_dir / "results", jobs=jobs, fit_options=fit_options,
                     log=log, progress=progress, executor=executor, cut=uses_auto(models) and not keep_all,
                     refit_stale=refit_stale, export_first=True, unscreened=fitted_fully(models))
    return write_library([out_dir / "results"], out_dir, jobs=jobs, log=log, progress=progress,
                         command_line=command_line, only={r["result"] for r in rows if r["result"]})


def write_library(results: Iterable["str | os.PathLike[str] | FitResult"], out_dir: str | os.PathLike[str],
                  *, jobs: int = 1, log: Callable[[str], object] = print, progress: bool = False,
                  command_line: str = "", only: set[str] | None = None) -> Library:
    """The library of ``results`` (result files, folders of them, or FitResults: those are
    saved into ``out_dir``/results first) in ``out_dir``; the materials' pages are
    written in this process, or in up to ``jobs`` worker processes when there are
    PAGES_PER_WORKER pages or more for each (brdf_fit.library.material).  ``only``: the
    result file names of this run's inputs; a material without one is left out."""
    from brdf_fit.report.pages import collect_results
    out_dir = pathlib.Path(out_dir)
    for folder in ("results", "materials", "thumbs", "gltf"):
        (out_dir / folder).mkdir(parents=True, exist_ok=True)
    found = collect_results(_as_paths(results, out_dir / "results"), "library")
    groups = material_groups(found if only is None else _given(found, only, log))     # one per measurement
    state = read_state(out_dir)
    _viewer_files(out_dir, log)
    copied = _model_files(found, out_dir)
    todo = {m: _digest(rows) for m, rows in groups.items() if _stale(m, rows, out_dir, state)}
    for material, note in _run_pages(todo, groups, out_dir, command_line, jobs, progress, copied):
        log(printable(f"{shown_name(material)}: page" + (f" ({note})" if note else "")))
        stem = _stem(groups[material])
        state[library_files(stem)["page"]] = written(out_dir, stem, todo[material])
        write_state(out_dir, state)
    entries = sorted((_entry(m, rows, out_dir) for m, rows in groups.items()), key=lambda e: (e.m1, e.material))
    by_material = {m: [r for _, r in rows] for m, rows in groups.items()}
    if by_material:
        _write_glb(by_material, out_dir)
    _write_analysis(by_material, entries, out_dir)
    links = [("analysis.html", "analysis across models"), ("materials.glb", "all materials (.glb)"),
             *write_native(by_material, out_dir, log), ("results/summary.csv", "summary.csv")]
    atomic_write_text(out_dir / "index.html", gallery_page(
        entries, f"Material library: {len(entries)} materials", command_line, links))
    return Library(out_dir, entries, by_material)


def _model_files(found, out_dir):
    """Copy the files of the models of one's own among the results into ``out_dir``/models (by
    the names they were loaded under here), so that the pages' report command
    (``--model-file models/NAME.py``) reads them from the library's folder, wherever it is
    moved.  Returns {sha256: NAME.py}: a page names the copy of its results' sha256, never a
    name read from a result (data)."""
    from brdf import own
    from data_loaders.atomic import write_file_atomic
    copied = {}
    for given, data in own.files_of(r.spec for _, r in found):
        path = out_dir / "models" / pathlib.Path(given).name
        if not path.is_file() or path.read_bytes() != data:
            write_file_atomic(path, data)
        copied[hashlib.sha256(data).hexdigest()] = path.name
    return copied


def _given(found, only, log):
    """The results of the measurements with a result of this run's inputs (file names
    ``only``); one line on the others."""
    from brdf_fit.report.identity import identity
    given = {identity(r) for p, r in found if pathlib.Path(p).name in only}
    left = {identity(r) for _, r in found} - given
    if left:
        log(f"{len(left)} material(s) of results/ not among the inputs given this time left out "
            "of the library (their results are kept: give their files again to show them)")
    return [(p, r) for p, r in found if identity(r) in given]


def _run_pages(todo, groups, out_dir, command_line, jobs, progress, model_files):
    """Write the pages of the materials ``todo``; yield (material, note) as each is done,
    with a progress bar over them when ``progress`` (``model_files``: ``_model_files``)."""
    from brdf_fit.progress import Progress
    from .material import write_material
    bar = Progress(len(todo), "pages") if progress and todo else None
    calls = {m: (m, groups[m], shipped_best([r for _, r in groups[m]]), str(out_dir), command_line, model_files)
             for m in todo}
    for material, note in _in_workers(write_material, calls, jobs):
        if bar:
            bar.step(material)
        yield material, note


def _in_workers(function, calls, jobs):
    """Yield (key, function(*args)) for {key: args}: in this process, or in up to ``jobs``
    spawned worker processes, one per PAGES_PER_WORKER calls (as batch's: they ignore
    Ctrl-C and die with this one), as they finish."""
    jobs = min(jobs, len(calls) // PAGES_PER_WORKER)
    if jobs <= 1:
        for key, args in calls.items():
            yield key, function(*args)
        return
    import concurrent.futures
    import multiprocessing
    from brdf_fit.interrupt import worker_init
    with concurrent.futures.ProcessPoolExecutor(max_workers=jobs, initializer=worker_init,
                                                mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = {pool.submit(function, *args): key for key, args in calls.items()}
        try:
            for future in concurrent.futures.as_completed(futures):
                yield futures[future], future.result()
        finally:
            pool.shutdown(wait=True, cancel_futures=True)


def _as_paths(results, results_dir):
    paths = []
    for item in results:
        if isinstance(item, FitResult):
            paths.append(item.save(_result_path(item, results_dir)))
        else:
            paths.append(pathlib.Path(item))
    return paths


def _result_path(result, results_dir):
    """Where a FitResult given to ``write_library`` is saved: under its material's name, or
    with its measurement's hash where that file holds another measurement's result."""
    from brdf_fit.batch.folder import load_quietly, result_path
    from fitting.file_names import safe_stem
    from brdf_fit.report.identity import STEM_HASH, identity
    path = result_path(results_dir, safe_stem(result.material), result.spec)
    there = load_quietly(path)
    if there is None or identity(there) == identity(result):
        return path
    return result_path(results_dir, f"{safe_stem(result.material)}-{material_stem([result])[-STEM_HASH:]}",
                       result.spec)


def _digest(rows):
    """A digest of a material's result files and of the pages' version."""
    h = hashlib.sha256(PAGES_VERSION.encode())
    for path, _ in sorted(rows, key=lambda pr: str(pr[0])):
        h.update(str(path.name).encode() + b"\0" + pathlib.Path(path).read_bytes() + b"\0")
    return h.hexdigest()


def _stale(material, rows, out_dir, state):
    """Whether a material's files must be written: its results changed, or a file written
    for it is missing or damaged (brdf_fit.library.state: a stat a file)."""
    stem = _stem(rows)
    return not current(state.get(library_files(stem)["page"]), _digest(rows), out_dir, stem)


def _viewer_files(out_dir, log):
    """The files every material page's viewer shares, written where missing or stale
    (a page written again writes them too: this restores them when none is); without
    three.js, one line saying how to get it (as ``brdf-fit report`` prints; each page says it too)."""
    from brdf_fit.report.web_viewer import ViewerUnavailable, write_viewer_files
    try:
        write_viewer_files(out_dir / "materials")
    except ViewerUnavailable as err:
        log(f"3D viewer not shown: {err}")


def _entry(material, rows, out_dir):
    """A material's gallery Entry, from its results and the files written."""
    from brdf_fit.export.export_first import shipped as shipped_summary
    files = library_files(_stem(rows))
    best, summary = rows[0][1], shipped_summary([r for _, r in rows])
    pictures = {k: files[k] if (out_dir / files[k]).is_file() else None for k in ("measured", "fitted", "glb")}
    errors = summary.result.errors
    return Entry(material, best.spec, float(best.errors["m1"]), _maybe(best.errors.get("image")),
                 _maybe(errors.get("exported_m1")), _maybe(errors.get("exported_image")), len(rows),
                 files["page"], pictures["measured"], pictures["fitted"], pictures["glb"],
                 summary.result.spec, summary.export_first, summary.margin)


def _stem(rows):
    return material_stem(r for _, r in rows)


def _maybe(x):
    return None if x is None else float(x)


def _write_glb(by_material, out_dir):
    from .glb import write_materials_glb
    write_materials_glb([(m, shipped_best(results)) for m, results in by_material.items()],
                        out_dir / "materials.glb",
                        exported={m: out_dir / library_files(material_stem(rs))["glb"]
                                  for m, rs in by_material.items()})


def _write_analysis(by_material, entries, out_dir):
    from .analysis_page import write_analysis
    thumbnails = {e.material: e.measured_png for e in entries if e.measured_png}
    pages = {e.material: e.page for e in entries}
    write_analysis(by_material, out_dir, thumbnails=thumbnails, pages=pages, index="index.html")
