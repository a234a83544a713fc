"""A library of measurements whose names collide: one card, page, sphere pair and .glb node each.

One library, built once for the module with cheap fit options, of small synthetic
tables (each of its own truth, so no two have the same data) whose names collide in
every way the issue found: the same file name in two folders, one material name in
two files, names differing by case or only by what a file name may hold, names
without one ASCII letter or digit.  Checked in the written files (the gallery's
cards and table, every page, thumbnail, .glb and materials.glb's nodes), in the
gallery's DOM in headless Chromium, and across a second run of the same command.
"""

import html.parser
import json
import pathlib
import re
import urllib.parse

import numpy as np
import pytest

from brdf_fit.cli import main
from data_loaders.samples import write_samples
from fitting.result import FitResult
from fitting.synthetic import synthetic_measured

MODELS = "ggx+lambert"
FAST = ["--samples", "400", "--starts", "1"]

# (folder, file name, material name): every name below collides with another somewhere
INPUTS = [
    ("lab1", "sample", "sample"), ("lab2", "sample", "sample"),                # one stem, two folders
    ("names", "first", "steel"), ("names", "second", "steel"),                 # one `material` in two files
    ("names", "case-upper", "Paint"), ("names", "case-lower", "paint"),        # case
    ("names", "space", "a b"), ("names", "underscore", "a_b"),                 # sanitising
    ("names", "angle", "x<1>"), ("names", "x-one", "x_1"),
    ("names", "chinese", "\u767d\u8272\u6837\u54c1"), ("names", "cyrillic", "\u041e\u0431\u0440\u0430\u0437\u0435\u0446"),
    ("names", "e-acute", "\u00e9"), ("names", "e-grave", "\u00e8"),          # no ASCII letter or digit
]
EXPECTED_NAMES = {("lab1", "sample"): "sample (lab1)", ("lab2", "sample"): "sample (lab2)",
                  ("names", "first"): "steel (first.npz)", ("names", "second"): "steel (second.npz)"}


def _table(path, material, seed):
    rng = np.random.default_rng(seed)
    truth = {"albedo": list(rng.uniform(0.05, 0.8, 3)), "roughness": float(rng.uniform(0.15, 0.8)), "f0": [0.05] * 3}
    m = synthetic_measured("ggx+lambert", truth, grid=(6, 6, 12, 1), noise=0.02, seed=seed)
    keep = np.flatnonzero(m.valid)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_samples(path, m.wi[keep], m.wo[keep], m.values[keep], weights=m.weights[keep], material=material,
                  isotropic=True)


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    root = tmp_path_factory.mktemp("colliding")
    for seed, (folder, stem, material) in enumerate(INPUTS):
        _table(root / folder / f"{stem}.npz", material, seed)
    return root


def _command(inputs, out):
    return ["library", *(str(inputs / f) for f in ("lab1", "lab2", "names")), "--out", str(out), "--models", MODELS,
            *FAST, "-q"]


@pytest.fixture(scope="module")
def library(inputs, tmp_path_factory):
    out = tmp_path_factory.mktemp("lib") / "lib"
    assert main(_command(inputs, out)) == 0
    return out


class _Gallery(html.parser.HTMLParser):
    """The cards of a gallery: {"name", "title", "page", "measured", "fitted", "glb"} each."""

    def __init__(self):
        super().__init__()
        self.cards, self._in_name = [], False

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "div" and attrs.get("class") == "card":
            self.cards.append({"name": "", "page": attrs["data-id"]})
        elif self.cards and tag == "img":
            self.cards[-1][attrs["alt"]] = attrs["src"]
        elif self.cards and tag == "a" and "download" in attrs:
            self.cards[-1]["glb"] = attrs["href"]
        elif self.cards and tag == "b" and attrs.get("class") == "name":
            self._in_name = True
        elif self._in_name and tag == "span":
            self.cards[-1]["title"] = attrs["title"]

    def handle_endtag(self, tag):
        if tag == "b":
            self._in_name = False

    def handle_data(self, data):
        if self._in_name:
            self.cards[-1]["name"] += data


def cards(library):
    parser = _Gallery()
    parser.feed((library / "index.html").read_text(encoding="utf-8"))
    return {card.get("title", card["name"]): card for card in parser.cards}


def _measurements(library):
    """{input file's sha256: its results' material name, input path} of the library's results."""
    out = {}
    for path in (library / "results").glob("*.json"):
        r = FitResult.load(path)
        out[r.provenance["sha256"]] = (r.material, pathlib.Path(r.provenance["file"]))
    return out


def _page_sha(library, page):
    """The sha256 prefix of the measured table a material page names."""
    text = (library / urllib.parse.unquote(page)).read_text(encoding="utf-8")
    return re.search(r"sha256 ([0-9a-f]{16})\.\.\.", text).group(1)


def _by_input(library):
    """{(folder, file stem): its card}, by the sha256 its page names."""
    shown = cards(library)
    sha = {m[:16]: (p.parent.name, p.stem) for m, (_, p) in _measurements(library).items()}
    return {sha[_page_sha(library, card["page"])]: card for card in shown.values()}


def test_each_measurement_is_one_card_page_sphere_pair_and_glb_node(library):
    shown = cards(library)
    assert len(_measurements(library)) == len(INPUTS)
    assert len(shown) == len(INPUTS)
    for key in ("page", "measured", "fitted", "glb"):
        files = [card[key] for card in shown.values()]
        assert len(set(files)) == len(INPUTS), key
        for f in files:
            assert (library / urllib.parse.unquote(f)).is_file(), f
    assert len({(library / c["measured"]).read_bytes() for c in shown.values()}) == len(INPUTS)
    assert len({_page_sha(library, c["page"]) for c in shown.values()}) == len(INPUTS)
    for name, card in shown.items():          # each page is headed by its card's name
        text = (library / card["page"]).read_text(encoding="utf-8")
        assert f"<h1>{html.escape(name)}</h1>" in text, name
    from test_library_glb import read_glb
    doc, _ = read_glb(library / "materials.glb")
    assert sorted(n["name"] for n in doc["nodes"]) == sorted(shown)
    assert len({json.dumps(m, sort_keys=True) for m in doc["materials"]}) == len(INPUTS)


def test_one_stem_in_two_folders_is_told_apart_by_its_folder(library):
    by_input = _by_input(library)
    for key in (("lab1", "sample"), ("lab2", "sample")):
        assert by_input[key].get("title", by_input[key]["name"]) == EXPECTED_NAMES[key]


def test_one_material_line_in_two_files_is_told_apart_by_its_file(library):
    by_input = _by_input(library)
    for key in (("names", "first"), ("names", "second")):
        assert by_input[key].get("title", by_input[key]["name"]) == EXPECTED_NAMES[key]


@pytest.mark.parametrize("pair", [("Paint", "paint"), ("a b", "a_b"), ("x<1>", "x_1"),
                                  ("\u767d\u8272\u6837\u54c1", "\u041e\u0431\u0440\u0430\u0437\u0435\u0446"),
                                  ("\u00e9", "\u00e8")])
def test_names_that_make_one_file_name_keep_their_names_and_files_apart(library, pair):
    shown = cards(library)
    first, second = (shown[name] for name in pair)      # shown as they are, nothing added
    for key in ("page", "measured", "fitted", "glb"):
        assert first[key] != second[key], key
    assert not any(pathlib.PurePath(c["page"]).name == "material.html" for c in shown.values())


def _files(library):
    """{file of the materials', thumbs' and gltf folders: (bytes, mtime in ns)}."""
    return {p.relative_to(library): (p.read_bytes(), p.stat().st_mtime_ns) for p in library.rglob("*")
            if p.is_file() and p.parts[-2] in ("materials", "thumbs", "gltf")}


def test_a_second_run_keeps_every_file_name_and_writes_no_page(inputs, library):
    before = _files(library)
    assert main(_command(inputs, library)) == 0
    after = _files(library)
    assert sorted(after) == sorted(before)
    for name in before:
        assert after[name][0] == before[name][0], name
        if name.suffix == ".html":
            assert after[name][1] == before[name][1], name


def test_the_gallery_shows_every_measurement_in_the_browser(library, tmp_path):
    from headless_chromium import HeadlessChromium, find_chromium
    if find_chromium() is None:
        pytest.skip("no Chromium here: `make test` installs it")
    shown = cards(library)
    with HeadlessChromium(tmp_path, width=1200, height=900) as browser:
        browser.open((library / "index.html").as_uri())
        browser.wait_for("document.readyState === 'complete' && typeof window.libraryFilter === 'function'")
        names = "Array.from(document.querySelectorAll('#cards .card:not(.hidden) .name')).map(t => t.textContent)"
        assert sorted(browser.evaluate(names)) == sorted(shown)
        assert browser.evaluate("Array.from(document.images).every(i => i.complete && i.naturalWidth > 0)")
        browser.evaluate("{ const n = document.getElementById('filter-name'); n.value = 'LAB1';"
                         "n.dispatchEvent(new Event('input')); }")
        assert browser.evaluate(names) == [EXPECTED_NAMES["lab1", "sample"]]
        assert not browser.errors, browser.errors


def test_a_report_of_the_results_has_one_page_per_measurement(library, tmp_path):
    """``brdf-fit report`` of the library's results: the same grouping, its readable file
    names kept where they do not meet (a hash added where they would)."""
    from brdf_fit.report.pages import collect_results, write_report
    chinese, cyrillic = INPUTS[10][2], INPUTS[11][2]
    shown = {"sample (lab1)", "sample (lab2)", "a b", "a_b", chinese, cyrillic}
    found = [(p, r) for p, r in collect_results([library / "results"])
             if r.material in {"sample", "a b", "a_b", chinese, cyrillic}]
    pages = write_report(found, tmp_path / "report", renders=False)[1:]
    assert len(set(pages)) == len(shown)
    heads = {re.search(r"<h1>(.*?)</h1>", p.read_text(encoding="utf-8")).group(1) for p in pages}
    assert heads == {html.escape(name) for name in shown}
    lobes = {re.search(r'src="([^"]*-lobes\.png)"', p.read_text(encoding="utf-8")).group(1) for p in pages}
    assert len(lobes) == len(shown) and all((tmp_path / "report" / name).is_file() for name in lobes)
