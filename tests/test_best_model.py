"""``auto``'s "best" is one fit wherever it is named: the report's index (bold, with the
ranking's terms beside it), the library's gallery, the analysis, ``fit``'s summary line
and the demo's tables all read fitting.ranking.ranked.  A small design where the lowest
M1 is not the best (the issue's 0.00871 against 0.00877: the image error decides) and a
tie in the ranking error, read in two orders."""

import io
import re

import pytest

from brdf_fit.commands import print_best
from brdf_fit.demo_run import print_summary
from brdf_fit.report.pages import write_report
from fitting.ranking import ranked, ranking_terms
from fitting.result import FitResult

PARAMS = {
    "ggx+lambert": {"albedo": [0.4, 0.2, 0.1], "roughness": 0.35, "f0": [0.04, 0.04, 0.04]},
    "ggx+burley": {"albedo": [0.4, 0.2, 0.1], "roughness": 0.3, "f0": [0.05, 0.05, 0.05]},
    "ggx+frostbite": {"albedo": [0.4, 0.2, 0.1], "roughness": 0.32, "f0": [0.045, 0.045, 0.045]},
}
# lowest M1: ggx+lambert; lowest M1 + 0.3 x image: ggx+burley (0.00877 + 0.3 x 0.0300 = 0.01777)
DESIGN = {"ggx+lambert": (0.00871, 0.0400), "ggx+burley": (0.00877, 0.0300), "ggx+frostbite": (0.00900, 0.0350)}
# a tie in the ranking error: the model string decides (ggx+burley before ggx+lambert)
TIE = {"ggx+lambert": (0.01, 0.02), "ggx+burley": (0.01, 0.02), "ggx+frostbite": (0.02, 0.02)}


def _results(material, design):
    return [FitResult(spec=spec, parameters=PARAMS[spec],
                      errors={"m1": m1, "m1_per_channel": [m1] * 3, "image": image, "loss_name": "hybrid",
                              "loss": m1 + 0.5 * image, "exported_m1": m1 * 1.1, "exported_image": image * 1.1},
                      optimizer={"name": "lbfgs", "evaluations": 10, "converged": True, "samples": 2000,
                                 "seconds_total": 1.0, "max_theta": 80.0},
                      provenance={"file": f"/data/{material}.binary", "sha256": material.encode().hex().ljust(64, "0"),
                                  "format": "merl", "material": material})
            for spec, (m1, image) in design.items()]


@pytest.fixture(scope="module", params=["forward", "reversed"])
def design(request):
    results = _results("blue-acrylic", DESIGN) + _results("tied-paint", TIE)
    return results if request.param == "forward" else results[::-1]


EXPECTED = {"blue-acrylic": "ggx+burley", "tied-paint": "ggx+burley"}


def test_the_ranking_names_the_design_best(design):
    for material, best in EXPECTED.items():
        assert ranked(r for r in design if r.material == material)[0].spec == best
    lowest_m1 = min((r for r in design if r.material == "blue-acrylic"), key=lambda r: r.errors["m1"])
    assert lowest_m1.spec == "ggx+lambert"          # the table's M1 column alone would say otherwise


def test_the_report_index_bolds_the_best_with_its_terms(design, tmp_path):
    paths = []
    for k, r in enumerate(design):
        paths.append((r.save(tmp_path / "results" / f"{k}-{r.material}.{r.spec}.json"), r))
    write_report(paths, tmp_path / "report", renders=False)
    index = (tmp_path / "report" / "index.html").read_text(encoding="utf-8")
    models = re.findall(r"<th><span[^>]*></span><code>([^<]+)</code></th>", index)
    for material, best in EXPECTED.items():
        row = re.search(rf">{re.escape(material)}</a></td>(.*?)</tr>", index).group(1)
        cells = re.findall(r'<td class="num">(.*?)</td>', row)
        bold = [m for m, c in zip(models, cells) if c.startswith("<b>")]
        assert bold == [best], (material, bold)
        terms = ranking_terms(next(r for r in design if r.material == material and r.spec == best).errors)
        assert f'<td class="best"><code>{best}</code>: {terms}</td>' in row
    assert "M1 0.00877 + 0.3 x image 0.03 = 0.01777" in index
    assert "not the lowest M1 alone" in index


def test_the_gallery_and_the_analysis_name_the_same_best(design, tmp_path):
    from brdf_fit.library.analysis import best_results
    from brdf_fit.library.build import write_library
    library = write_library(design, tmp_path / "lib", log=lambda m: None)
    assert {e.material: e.model for e in library.entries} == EXPECTED
    assert {m: r.spec for m, r in best_results(library.groups).items()} == EXPECTED
    gallery = (tmp_path / "lib" / "index.html").read_text(encoding="utf-8")
    for material, best in EXPECTED.items():
        assert re.search(rf'<tr [^>]*data-name="{material}" data-model="{re.escape(best)}"', gallery), material


def test_the_fit_summary_and_the_demo_tables_star_the_same_best(design):
    for material, best in EXPECTED.items():
        out = io.StringIO()
        print_best(ranked(r for r in design if r.material == material), out)
        assert out.getvalue().endswith(f"best: {best} ({ranking_terms(_errors(design, material, best))})\n")
    out = io.StringIO()
    print_summary({(r.material, r.spec): r for r in design}, list(EXPECTED), models=tuple(DESIGN), stream=out)
    tables = out.getvalue().split("(lower is better) per material and model:\n")[1:]
    assert len(tables) == 4
    for table in tables[:3]:             # the ranking, M1 and the image error: the ranking's best starred
        for material, best in EXPECTED.items():
            line = next(x for x in table.splitlines() if x.startswith(material))
            starred = [m for m, cell in zip(DESIGN, re.findall(r"\S+", line[24:])) if cell.endswith("*")]
            assert starred == [best], (material, line)


def _errors(design, material, spec):
    return next(r for r in design if r.material == material and r.spec == spec).errors
