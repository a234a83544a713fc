"""Pages read at 1280 px: the report's material page (15 columns of errors for 24 models),
its index (a column per model), the library's gallery, material page and analysis page,
laid out by headless Chromium in a 1280 px window.  No page is wider than the window
(a table wider than the page scrolls inside its own box, brdf_fit.report.html.scrolling),
and no parameter is shown with more than 4 significant digits (every digit stays in the
result JSON and in the cell's data-value)."""

import json
import re

import numpy as np
import pytest

from brdf.spec import default_params, parse_model
from brdf_fit.library.gallery import Entry, gallery_page
from brdf_fit.report import html as report_html
from fitting.auto import AUTO_FAMILY
from fitting.ranking import IMAGE_TERM
from fitting.result import FitResult

WIDTH = 1280
LONG = "gltf+specular+clearcoat"


def _result(spec, k, material):
    params = {name: (np.asarray(v, dtype=float) * (1 - 1 / 7000)).tolist()     # every digit used
              for name, v in default_params(parse_model(spec)).items()}
    m1, image = 0.0087123456789 + 1e-4 * k, 0.04123456789 + 1e-3 * k
    return FitResult(spec=spec, parameters=params,
                     errors={"m1": m1, "m1_per_channel": [m1 * 0.9, m1, m1 * 1.1], "image": image,
                             "loss_name": "hybrid", "loss": m1 + 0.5 * image, "exported_m1": m1 * 1.3,
                             "exported_image": image * 1.2, "exported_model": LONG},
                     optimizer={"name": "lbfgs", "evaluations": 412, "converged": True, "samples": 20000,
                                "seconds_total": 12.5, "max_theta": 80.0},
                     provenance={"file": f"/data/merl/{material}.binary", "sha256": "ab" * 32, "format": "merl",
                                 "material": material})


def _rows(material):
    return [(f"results/{material}.{spec}.json", _result(spec, k, material)) for k, spec in enumerate(AUTO_FAMILY)]


@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    """The five kinds of page, written from 24 results per material (no fit, no render)."""
    from brdf_fit.library.analysis_page import write_analysis
    from brdf_fit.library.material_page import material_page as library_page
    out = tmp_path_factory.mktemp("pages")
    materials = ["blue-acrylic", "gold-metallic-paint"]
    groups = {m: _rows(m) for m in materials}
    rows = groups["blue-acrylic"]
    command = "brdf-fit report " + " ".join(p for p, _ in rows) + " --out report"
    gltf = {r.spec: (r.errors["exported_m1"], r.errors["exported_image"], LONG, "converted") for _, r in rows}
    written = {
        "report material": report_html.material_page("blue-acrylic", rows, None, [], [], "disabled", gltf, [],
                                                     command),
        "report index": report_html.index_page(groups, {m: f"{m}.html" for m in materials}, None, command),
        "library material": library_page("blue-acrylic", rows, rows[0][1], {}, "", [], "MERL table", command),
        "gallery": gallery_page([Entry(m, rows[0][1].spec, 0.0087123, 0.0412345, 0.0113, 0.0494, 24,
                                       f"materials/{m}.html", None, None, None, LONG, True, 3.2214)
                                 for m in materials], "Material library", command),
    }
    paths = {}
    for name, text in written.items():
        paths[name] = out / (name.replace(" ", "-") + ".html")
        paths[name].write_text(text, encoding="utf-8")
    paths["analysis"] = write_analysis({m: [r for _, r in rs] for m, rs in groups.items()}, out)
    return paths


LAYOUT = """(() => {
  const page = document.documentElement, tables = Array.from(document.querySelectorAll('table'));
  return {
    window: window.innerWidth, page: page.scrollWidth,
    tables: tables.map(t => ({ id: t.id, box: t.parentElement.className,
                                right: t.parentElement.getBoundingClientRect().right,
                                width: t.scrollWidth, shown: t.parentElement.clientWidth })),
    parameters: Array.from(document.querySelectorAll('#parameters td.num, table.parameters td.num'))
                     .map(td => td.innerText),
    cells: Array.from(document.querySelectorAll('td')).map(td => td.innerText),
  };
})()"""


def _digits(token):
    """Significant digits of a number as written ("0.0399999991" -> 9)."""
    return len(token.replace(".", "").lstrip("0"))


def test_every_page_fits_a_1280_px_window(pages, tmp_path):
    from headless_chromium import HeadlessChromium, find_chromium
    if find_chromium() is None:
        pytest.skip("no Chromium here: `make test` installs it")
    layouts = {}
    with HeadlessChromium(tmp_path, width=WIDTH, height=900) as browser:
        for name, path in pages.items():
            browser.open(path.as_uri())
            browser.wait_for("document.readyState === 'complete'")
            layouts[name] = browser.evaluate(LAYOUT)
    for name, layout in layouts.items():
        assert layout["window"] == WIDTH, name
        assert layout["page"] <= WIDTH, (name, layout["page"])
        assert layout["tables"], name
        for table in layout["tables"]:
            assert table["box"] == "scroll" and table["right"] <= WIDTH, (name, table)
        numbers = [t for cell in layout["cells"] for t in re.findall(r"\d+\.\d+|\d+", cell)]
        assert max(map(_digits, numbers)) <= 5, (name, max(numbers, key=_digits))
    # the errors table is the one wider than the page: it scrolls inside its box
    widest = max(layouts["report material"]["tables"], key=lambda t: t["width"])
    assert widest["width"] > widest["shown"]
    shown = layouts["library material"]["parameters"]
    assert shown and all(_digits(t) <= 4 for cell in shown for t in re.findall(r"\d+\.\d+|\d+", cell)), shown


def test_parameters_show_4_digits_and_keep_every_digit_in_data_value(pages):
    page = pages["library material"].read_text(encoding="utf-8")
    params = _rows("blue-acrylic")[0][1].parameters
    cells = dict(re.findall(r'<tr><td><code>([^<]+)</code></td><td class="num" data-value="([^"]*)">', page))
    assert {k: json.loads(v.replace("&quot;", '"')) for k, v in cells.items()} == params
    f0 = params["f0"][0]
    assert len(repr(f0)) > 12
    assert f'data-value="[{f0!r}, {f0!r}, {f0!r}]">({f0:.4g}, {f0:.4g}, {f0:.4g})</td>' in page
    for name in ("report material", "library material", "gallery", "analysis", "report index"):
        assert repr(f0) not in re.sub(r'data-value="[^"]*"', "", pages[name].read_text(encoding="utf-8")), name


def test_the_gallery_says_in_plain_words_with_the_precise_terms_in_tooltips(pages):
    import html
    page = pages["gallery"].read_text(encoding="utf-8")
    text = html.unescape(re.sub(r"<[^>]*>", " ", page.split("<script>")[0]))       # what a reader sees
    assert "glTF material: fitted directly (a converted fit: 3.22\u00d7 the error)" in text
    assert "export-first" not in text and "3.221x" not in text
    title = (f"export-first: {LONG}; the best converted fit's ranking error as glTF (M1 + 0.3 x {IMAGE_TERM} of "
             "the exported material) is 3.221x the shipped one's")
    assert page.count(f'title="{html.escape(title, quote=True)}"') == 4     # two cards, two rows
    for key in ("model", "m1", "image", "exported-m1", "exported-image", "shipped"):
        assert re.search(rf'<th data-key="{key}" title="[^"]+">', page), key
