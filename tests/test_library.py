"""``brdf-fit library``: a database fitted and written as one library (brdf_fit/library/).

One library of six materials (five small synthetic tables of different truths, and an
RGL-EPFL file where ../shared is present), built once for the module with cheap fit
options: every number on every page (gallery, material pages, analysis table) equals
its result file; every link and picture of every page resolves; the gallery, the
analysis page and a material page (its three.js viewer) draw in headless Chromium
without console errors, and sorting and filtering work in the browser's DOM;
materials.glb validates 0 errors / 0 warnings; a library killed (kill -9) in the
middle of its pages and made again by the same command gives the same pages.
"""

import html.parser
import json
import os
import pathlib
import re
import shutil
import signal
import subprocess
import sys
import time
import urllib.parse

import numpy as np
import pytest

from brdf_fit.cli import main
from brdf_fit.library.build import STATE_NAME
from brdf_fit.library.gallery import number
from data_loaders.samples import write_samples
from fitting.ranking import IMAGE_TERM, SECOND_WEIGHT, ranking_error, shipped_best
from fitting.result import FitResult
from fitting.synthetic import synthetic_measured

ROOT = pathlib.Path(__file__).resolve().parent.parent
MODELS = "ggx+lambert,gltf"
FAST = ["--samples", "2000", "--starts", "1"]
KILL_LIMIT = 120.0           # seconds for the killed run to reach its first page


def _table(path, albedo, roughness, f0):
    truth = {"albedo": albedo, "roughness": roughness, "f0": [f0] * 3}
    m = synthetic_measured("ggx+lambert", truth, grid=(12, 12, 24, 1), noise=0.02, seed=len(path.stem))
    keep = np.flatnonzero(m.valid)
    write_samples(path, m.wi[keep], m.wo[keep], m.values[keep], weights=m.weights[keep],
                  material=path.stem, isotropic=True)


TRUTHS = {
    "red-lacquer": ([0.5, 0.05, 0.03], 0.2, 0.05), "white-chalk": ([0.8, 0.8, 0.78], 0.9, 0.03),
    "dark-steel": ([0.01, 0.01, 0.012], 0.3, 0.6), "amber & <glass>": ([0.6, 0.35, 0.05], 0.1, 0.08),
    "gold-foil": ([0.05, 0.03, 0.0], 0.25, 0.9),
}


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("database")
    for name, (albedo, roughness, f0) in TRUTHS.items():
        _table(folder / f"{name}.npz", albedo, roughness, f0)
    rgl = ROOT.parent / "shared" / "measured" / "rgl-epfl-isotropic-rgb"
    if rgl.is_dir():
        first = sorted(rgl.glob("*.bsdf"))[:1]
        for path in first:
            shutil.copyfile(path, folder / path.name)
    return folder


@pytest.fixture(scope="module")
def library(inputs, tmp_path_factory):
    out = tmp_path_factory.mktemp("lib") / "lib"
    assert main(["library", str(inputs), "--out", str(out), "--models", MODELS, *FAST, "-q"]) == 0
    return out


class _Page(html.parser.HTMLParser):
    """Links, pictures, and the gallery table's rows of a page."""

    def __init__(self):
        super().__init__()
        self.links, self.rows, self._row, self._cell = [], [], None, None

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        for key in ("href", "src"):
            if attrs.get(key):
                self.links.append(attrs[key])
        if tag == "tr" and "data-id" in attrs:
            self._row = {"data": attrs, "cells": []}
        if tag == "td" and self._row is not None:
            self._cell = ""
            self._row.setdefault("titles", []).append(attrs.get("title"))

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data

    def handle_endtag(self, tag):
        if tag == "td" and self._row is not None:
            self._row["cells"].append(self._cell)
            self._cell = None
        if tag == "tr" and self._row is not None:
            self.rows.append(self._row)
            self._row = None


def _parse(path):
    page = _Page()
    page.feed(path.read_text(encoding="utf-8"))
    return page


def _results_by_material(folder):
    out = {}
    for path in sorted((folder / "results").glob("*.json")):
        result = FitResult.load(path)
        out.setdefault(result.material, []).append(result)
    return out


def _path_won(shipped, results):
    """The gallery's "glTF material" in plain words and its tooltip in precise terms: the shipped
    fit's path (a glTF family fit is export-first: "fitted directly") and the other path's best
    exported ranking error (M1 + 0.3 x (image error + second image error)) over the shipped one's."""
    def rank(r):
        image_term = r.errors["exported_image"] + SECOND_WEIGHT * r.errors["exported_second_image"]
        return r.errors["exported_m1"] + 0.3 * image_term
    first = shipped.spec.startswith("gltf")
    others = [rank(r) for r in results if r.spec.startswith("gltf") != first]
    path, other = ("export-first", "converted") if first else ("converted", "export-first")
    words, other_words = ("fitted directly", "a converted fit") if first else \
        ("converted from another model", "fitted directly")
    margin = min(others) / rank(shipped) if others else None
    text = words + (f" ({other_words}: {margin:.2f}\u00d7 the error)" if others else "")
    title = f"{path}: {shipped.spec}" + (
        f"; the best {other} fit's ranking error as glTF (M1 + 0.3 x {IMAGE_TERM} of the exported material) "
        f"is {margin:.3f}x the shipped one's" if others else "")
    return text, title


def test_every_number_on_the_gallery_equals_its_result_file(library):
    results = _results_by_material(library)
    rows = _parse(library / "index.html").rows
    assert sorted(r["cells"][0] for r in rows) == sorted(results)
    assert len(results) >= len(TRUTHS)
    for row in rows:
        material = row["cells"][0]
        best = min(results[material], key=lambda r: ranking_error(r.errors))
        shipped = shipped_best(results[material])
        text, title = _path_won(shipped, results[material])
        expected = [material, best.spec, number(best.errors["m1"]), number(best.errors["image"]),
                    number(shipped.errors["exported_m1"]), number(shipped.errors["exported_image"]), text]
        assert row["cells"] == expected
        assert row["titles"][-1] == title
        assert float(row["data"]["data-m1"]) == best.errors["m1"]        # the sort key, every digit
    # the gallery lists materials by M1, best first
    m1 = [float(r["data"]["data-m1"]) for r in rows]
    assert m1 == sorted(m1)


class _Cells(html.parser.HTMLParser):
    """The data-value of every numeric cell of a table with a given id, row by row."""

    def __init__(self, table):
        super().__init__()
        self.table, self.inside, self.rows = table, False, []

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "table":
            self.inside = attrs.get("id") == self.table
        if self.inside and tag == "tr":
            self.rows.append({})
        if self.inside and tag == "td" and "data-value" in attrs:
            self.rows[-1][attrs.get("data-key", len(self.rows[-1]))] = attrs["data-value"]


def _cells(path, table):
    cells = _Cells(table)
    cells.feed(path.read_text(encoding="utf-8"))
    return [row for row in cells.rows if row]


def test_every_number_on_the_material_pages_equals_its_result_file(library):
    from brdf_fit.library.material_page import ERROR_COLUMNS, SECOND_COLUMNS
    from brdf_fit.report.identity import material_stem
    from brdf_fit.library.material import library_files
    for results in _results_by_material(library).values():
        page = library / library_files(material_stem(results))["page"]
        ranked = sorted(results, key=lambda r: ranking_error(r.errors))
        rows = _cells(page, "fits")
        assert len(rows) == len(ranked)
        columns = ERROR_COLUMNS + (SECOND_COLUMNS if any("second_image" in r.errors for r in results) else ())
        for row, result in zip(rows, ranked):
            expected = [result.errors.get(key) for _, key in columns]
            assert [float(v) if v else None for v in row.values()] == expected
        shown = _cells(page, "parameters")       # 4 significant digits shown, every digit in data-value
        assert [json.loads(row[0]) for row in shown] == list(ranked[0].parameters.values())


def test_every_number_of_the_analysis_table_equals_the_result_files(library):
    from brdf_fit.library.analysis import analysis_table
    rows = analysis_table(_results_by_material(library))
    shown = _cells(library / "analysis.html", "models")
    assert len(shown) == len(rows)
    for cells, row in zip(shown, rows):
        for key, value in cells.items():
            expected = row[key]
            assert (value == "" and expected is None) or float(value) == expected, key


def test_every_link_and_picture_resolves(library):
    pages = [library / "index.html", library / "analysis.html", *sorted((library / "materials").glob("*.html"))]
    assert len(pages) >= 2 + len(TRUTHS)
    for page in pages:
        for link in _parse(page).links:
            if re.match(r"^[a-z]+:", link) or link.startswith("#"):
                continue
            target = (page.parent / urllib.parse.unquote(link.split("#")[0])).resolve()
            assert target.is_file(), f"{page.name}: {link}"
    for name in ("materials.glb", "results/summary.csv"):
        assert (library / name).is_file()
    from brdf_fit.report.identity import material_stem
    from brdf_fit.library.material import library_files
    for results in _results_by_material(library).values():
        for kind in ("glb", "mtlx"):
            assert (library / library_files(material_stem(results))[kind]).is_file()


def test_a_names_markup_is_shown_as_text(library):
    text = (library / "index.html").read_text(encoding="utf-8")
    assert "amber &amp; &lt;glass&gt;" in text and "<glass>" not in text


def test_the_library_glb_validates_without_errors_or_warnings(library):
    from test_export import _validator, run_validator
    _validator()
    [report] = run_validator([library / "materials.glb"])
    assert report["numErrors"] == 0 and report["numWarnings"] == 0, report


def test_the_gallery_sorts_and_filters_in_the_browser(library, tmp_path):
    from headless_chromium import HeadlessChromium, find_chromium
    if find_chromium() is None:
        pytest.skip("no Chromium here: `make test` installs it")
    results = _results_by_material(library)
    best = {m: min(rs, key=lambda r: ranking_error(r.errors)) for m, rs in results.items()}
    with HeadlessChromium(tmp_path, width=1200, height=900) as browser:
        browser.open((library / "index.html").as_uri())
        browser.wait_for("document.readyState === 'complete' && typeof window.librarySort === 'function'")
        order = "Array.from(document.querySelectorAll('#table tbody tr:not(.hidden) td.name')).map(t => t.textContent)"
        cards = "Array.from(document.querySelectorAll('#cards .card:not(.hidden) .name')).map(t => t.textContent)"
        browser.evaluate("document.querySelector('th[data-key=image]').click()")
        by_image = sorted(best, key=lambda m: (best[m].errors["image"], m))
        assert browser.evaluate(order) == by_image and browser.evaluate(cards) == by_image
        browser.evaluate("document.querySelector('th[data-key=image]').click()")      # again: descending
        assert browser.evaluate(order) == sorted(best, key=lambda m: best[m].errors["image"], reverse=True)
        limit = float(np.median([r.errors["image"] for r in best.values()]))
        browser.evaluate(f"{{ const f = document.getElementById('filter-image'); f.value = '{limit!r}';"
                         "f.dispatchEvent(new Event('input')); }")
        kept = sorted(m for m in best if best[m].errors["image"] <= limit)
        assert sorted(browser.evaluate(order)) == kept and sorted(browser.evaluate(cards)) == kept
        assert browser.evaluate("document.getElementById('shown').textContent") == str(len(kept))
        browser.evaluate("{ const f = document.getElementById('filter-image'); f.value = '';"
                         "f.dispatchEvent(new Event('input'));"
                         "const n = document.getElementById('filter-name'); n.value = 'E';"
                         "n.dispatchEvent(new Event('input')); }")
        assert sorted(browser.evaluate(order)) == sorted(m for m in best if "e" in m.lower())
        model = sorted({b.spec for b in best.values()})[0]
        browser.evaluate("{ const n = document.getElementById('filter-name'); n.value = '';"
                         "n.dispatchEvent(new Event('input'));"
                         f"const s = document.getElementById('filter-model'); s.value = {json.dumps(model)};"
                         "s.dispatchEvent(new Event('input')); }")
        assert sorted(browser.evaluate(order)) == sorted(m for m in best if best[m].spec == model)
        assert not browser.errors, browser.errors
        browser.open((library / "analysis.html").as_uri())
        browser.wait_for("document.readyState === 'complete'")
        assert browser.evaluate("Array.from(document.images).every(i => i.complete && i.naturalWidth > 0)")
        assert not browser.errors, browser.errors
        # the gallery again, then a click opens a material's page: each navigation starts after the evaluation
        # that asks for it has returned (an evaluation the navigation overtakes is cut off by Chromium)
        browser.evaluate("setTimeout(() => history.back(), 0)")
        browser.wait_for("document.readyState === 'complete' && !!document.querySelector('#cards .card a.open')")
        browser.evaluate("setTimeout(() => document.querySelector('#cards .card a.open').click(), 0)")
        browser.wait_for("window.brdfViewerRendered === true || !!window.brdfViewerError", timeout=120)
        assert browser.evaluate("window.brdfViewerError || null") is None
        assert browser.evaluate("Array.from(document.images).every(i => i.complete && i.naturalWidth > 0)")
        assert not browser.errors, browser.errors


def _pages(folder):
    """Every page of a library, with its folder's path taken out."""
    out = {}
    for page in [folder / "index.html", folder / "analysis.html", *(folder / "materials").glob("*.html")]:
        out[page.relative_to(folder).as_posix()] = page.read_text(encoding="utf-8").replace(str(folder), "LIB")
    return out


def test_a_library_killed_in_the_middle_is_completed_by_the_same_command(inputs, library, tmp_path):
    """Killed while it writes its pages (the fits, the expensive part, copied from the module's
    library: the batch resumes them, as it would after a kill during the fits)."""
    out = tmp_path / "lib"
    shutil.copytree(library / "results", out / "results")
    command = [sys.executable, "-m", "brdf_fit", "library", str(inputs), "--out", str(out), "--models", MODELS,
               *FAST, "-q"]
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen(command, env=env, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + KILL_LIMIT
        while time.monotonic() < deadline and proc.poll() is None and not (out / STATE_NAME).is_file():
            time.sleep(0.01)
        assert proc.poll() is None, "the library was done before it could be killed"
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.stderr.close()
    assert not (out / "index.html").exists()
    assert 1 <= len(json.loads((out / STATE_NAME).read_text())) < len(_results_by_material(library))
    done = subprocess.run(command, env=env, capture_output=True, text=True, timeout=KILL_LIMIT * 2)
    assert done.returncode == 0, done.stderr[-3000:]
    ours, reference = _pages(out), _pages(library)
    assert sorted(ours) == sorted(reference)
    for name in ours:
        assert ours[name] == reference[name], name


def _merl_file(path):
    """A MERL table of smooth values with a block of unmeasured (negative) cells."""
    from data_loaders.merl import MERL_SHAPE, write_merl
    th, td, pd = np.meshgrid(np.linspace(0, 1, 90), np.linspace(0, 1, 90), np.linspace(0, 1, 180), indexing="ij")
    rgb = (0.2 + np.exp(-8 * th) * (1 + td) * (1.5 + np.cos(np.pi * pd)))[..., None] * np.array([1.0, 0.7, 0.4])
    valid = np.ones(MERL_SHAPE, bool)
    valid[:, 80:, :40] = False
    write_merl(path, rgb, valid)
    return path


def test_a_merl_file_read_for_lookups_gives_read_merls_numbers(tmp_path):
    """The library reads MERL files for lookups only (data_loaders.merl.read_merl_table)."""
    from data_loaders import MeasuredDataError
    from data_loaders.merl import MerlTable, read_merl, read_merl_table
    path = _merl_file(tmp_path / "smooth.binary")
    full, (light, n_valid) = read_merl(path), read_merl_table(path)
    assert len(light) == 0 and n_valid == full.n_valid and light.provenance == full.provenance
    rng = np.random.default_rng(1)
    wi, wo = rng.normal(size=(2, 5000, 3))
    wo[:4000, 2] = np.abs(wo[:4000, 2])
    wi[:4500, 2] = np.abs(wi[:4500, 2])
    for method in MerlTable.methods:
        assert np.array_equal(light.lookup(wi, wo, method), full.lookup(wi, wo, method)), method
    (tmp_path / "short.binary").write_bytes(path.read_bytes()[:-8])
    errors = []
    for reader in (read_merl, read_merl_table):
        with pytest.raises(MeasuredDataError) as err:
            reader(tmp_path / "short.binary")
        errors.append(str(err.value))
    assert errors[0] == errors[1]


def test_a_merl_materials_page_and_pictures_are_those_of_the_whole_table(library, tmp_path):
    """write_material on a MERL file: the pictures equal those of the loaded table, the
    page names its valid samples, the recorded honesty check is used (no evaluation)."""
    import dataclasses

    from brdf_fit.report.identity import material_stem
    from brdf_fit.library.material import library_files, write_material
    from brdf_fit.library.thumbnails import sphere_pair
    from data_loaders.merl import read_merl
    from shaders.image import png_bytes
    path = _merl_file(tmp_path / "smooth.binary")
    full = read_merl(path)
    result = next(r for rs in _results_by_material(library).values() for r in rs if "exported_m1" in r.errors)
    result = dataclasses.replace(result, provenance={
        **result.provenance, "material": "smooth", "file": str(path), "sha256": full.provenance.sha256})
    out = tmp_path / "lib"
    for folder in ("materials", "thumbs", "gltf"):
        (out / folder).mkdir(parents=True)
    assert write_material("smooth", [(tmp_path / "smooth.json", result)], result, out) is None
    files = library_files(material_stem([result]))
    for kind, image in zip(("measured", "fitted"), sphere_pair(full, result)):
        assert (out / files[kind]).read_bytes() == png_bytes(image), kind
    assert f"(merl, {full.n_valid:,} valid samples, sha256 {full.provenance.sha256[:16]}" in \
        (out / files["page"]).read_text(encoding="utf-8")
    glb = (out / files["glb"]).read_bytes()
    assert b'"sha256_matches":true' in glb.replace(b" ", b"")


def test_pages_written_in_worker_processes_equal_those_written_here(library, tmp_path, monkeypatch):
    """The pages' worker processes (used from PAGES_PER_WORKER pages a worker) write the same files."""
    from brdf_fit.library import build
    monkeypatch.setattr(build, "PAGES_PER_WORKER", 1)
    out = tmp_path / "lib"
    shutil.copytree(library / "results", out / "results")
    build.write_library([out / "results"], out, jobs=2, log=lambda s: None)

    def without_command(pages):
        return {k: re.sub(r"<h2>Command</h2><pre>[^<]*</pre>", "", v) for k, v in pages.items()}
    assert without_command(_pages(out)) == without_command(_pages(library))
    for name in ("thumbs", "gltf"):
        files = sorted(p.relative_to(library).as_posix() for p in (library / name).iterdir())
        assert files == sorted(p.relative_to(out).as_posix() for p in (out / name).iterdir())
        for f in files:
            assert (out / f).read_bytes() == (library / f).read_bytes(), f
