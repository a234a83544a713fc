"""brdf_fit.library.study and the analysis page's study sections (issue 54, part 4): the
categories (MERL's by name, else the file's folder), per material and per category which
model wins, GGX against Beckmann, half-vector against mirror-direction lobes.

Every error below is chosen by hand, and every number a test checks is worked out in
the comments beside ERRORS from the ranking error M1 + 0.3 x image (docs/metrics.md).
"""

import html
import html.parser
import importlib.util
import json
import math
import pathlib

import numpy as np
import pytest

from brdf.spec import NDFS
from brdf_fit.library import analysis_page, categories, study
from fitting.auto import CLASSIC_FAMILY
from fitting.result import FitResult

G, B, BP, P, W, L = ("ggx+lambert", "beckmann+lambert", "blinn_phong+lambert", "phong+lambert", "ward+lambert",
                     "lafortune+lambert")
NASTY = "<b>x</b>"
# material -> model -> (M1, image error or None); ranking error = M1 + 0.3 x image:
#   alum-bronze (metal):  G 0.016, B 0.021, BP 0.042, P 0.035, W 0.034, L 0.058;  gltf, ggx+burley far behind
#   chrome-steel (metal): G 0.080, B 0.076, BP 0.090, P 0.094
#   blue-metallic-paint:  G 0.023, B 0.033, P 0.018, L 0.0172
#   red-fabric (fabric):  G 0.011, BP 0.015, P 0.016
#   NASTY (other):        G 0.005 (M1 alone)
# winners: alum G, chrome B, paint L, fabric G, NASTY G
ERRORS = {
    "alum-bronze": {G: (0.010, 0.020), B: (0.012, 0.030), BP: (0.030, 0.040), P: (0.020, 0.050),
                    W: (0.025, 0.030), L: (0.040, 0.060), "gltf": (0.5, 0.5), "ggx+burley": (0.4, 0.4)},
    "chrome-steel": {G: (0.050, 0.100), B: (0.040, 0.120), BP: (0.060, 0.100), P: (0.070, 0.080)},
    "blue-metallic-paint": {G: (0.020, 0.010), B: (0.018, 0.050), P: (0.015, 0.010), L: (0.016, 0.004)},
    "red-fabric": {G: (0.008, 0.010), BP: (0.009, 0.020), P: (0.013, 0.010)},
    NASTY: {G: (0.005, None)},
}


def _result(model, material, m1, image, file=None):
    errors = {"m1": m1} if image is None else {"m1": m1, "image": image}
    return FitResult(spec=model, parameters={}, errors=errors, optimizer={},
                     provenance={"material": material, "file": file})


@pytest.fixture(scope="module")
def groups():
    return {m: [_result(model, m, *e) for model, e in fits.items()] for m, fits in ERRORS.items()}


# --- categories -------------------------------------------------------------------------

def test_merl_names_fall_in_merl_categories():
    assert categories.category("alum-bronze") == "metal"
    assert categories.category("blue-metallic-paint") == "metallic paint"
    assert categories.category("gold-metallic-paint") == "metallic paint"      # before "gold" makes it a metal
    assert categories.category("red-fabric") == "fabric"
    assert categories.category("special-walnut-224") == "wood"
    assert categories.category("yellow-phenolic") == "phenolic"
    assert categories.category("my sample") == categories.OTHER == "other"


def test_the_benchmark_reads_the_same_table():
    path = pathlib.Path(__file__).resolve().parents[1] / "benchmarks" / "abc_shipped.py"
    spec = importlib.util.spec_from_file_location("abc_shipped", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.category is categories.category


def test_an_unknown_name_takes_its_folder_when_the_files_sit_in_several():
    def lib(files):
        return {m: [_result(G, m, 0.01, 0.01, file=f)] for m, f in files.items()}
    spread = lib({"sample-a": "/d/lab/metals/sample-a.csv", "sample-b": "/d/lab/fabrics/b.csv",
                  "alum-bronze": "/d/lab/fabrics/alum-bronze.binary", "loose": None})
    assert categories.material_categories(spread) == {"sample-a": "metals", "sample-b": "fabrics",
                                                      "alum-bronze": "metal", "loose": "other"}
    one = lib({"sample-a": "/d/merl/sample-a.csv", "alum-bronze": "/d/merl/alum-bronze.binary"})
    assert categories.material_categories(one) == {"sample-a": "other", "alum-bronze": "metal"}


# --- per material and per category -------------------------------------------------------

def test_material_rows_name_each_materials_best_and_best_classic_model(groups):
    rows = study.material_rows(groups)
    assert [(r["material"], r["category"], r["best"], r["best_classic"]) for r in rows] == [
        ("red-fabric", "fabric", G, BP), ("alum-bronze", "metal", G, B), ("chrome-steel", "metal", B, B),
        ("blue-metallic-paint", "metallic paint", L, L), (NASTY, "other", G, None)]
    got = {r["material"]: r for r in rows}
    assert got["red-fabric"]["ranking"] == pytest.approx(0.008 + 0.3 * 0.010)
    assert (got["red-fabric"]["m1"], got["red-fabric"]["image"]) == (0.008, 0.010)
    assert got["red-fabric"]["classic_ratio"] == pytest.approx(0.015 / 0.011)
    assert got["alum-bronze"]["classic_ratio"] == pytest.approx(0.021 / 0.016)
    assert got["chrome-steel"]["classic_ratio"] == got["blue-metallic-paint"]["classic_ratio"] == 1.0
    assert got[NASTY]["image"] is None and got[NASTY]["classic_ratio"] is None and got[NASTY]["ranking"] == 0.005


def test_category_rows_wins_and_best_median_among_the_models_fitted_to_all(groups):
    rows = {r["category"]: r for r in study.category_rows(groups)}
    assert list(rows) == ["fabric", "metal", "metallic paint", "other"]
    assert [rows[c]["materials"] for c in rows] == [1, 2, 1, 1]
    # metal: alum won by G, chrome by B -> a tie, both listed
    assert (rows["metal"]["most_wins"], rows["metal"]["wins"]) == ([B, G], 1)
    assert (rows["metallic paint"]["most_wins"], rows["fabric"]["most_wins"]) == ([L], [G])
    # metal medians over both materials: G (0.016 + 0.080) / 2 = 0.048, B 0.0485, P 0.0645, BP 0.066;
    # W's 0.034 is over alum alone (1 of 2): not a candidate
    metal = rows["metal"]
    assert (metal["best_median"], metal["over"]) == (G, 2)
    assert metal["median_ranking"] == pytest.approx(0.048)
    assert metal["median_m1"] == pytest.approx(0.030) and metal["median_image"] == pytest.approx(0.060)
    assert (rows["metallic paint"]["best_median"], rows["metallic paint"]["median_ranking"]) == (L, pytest.approx(0.0172))
    assert rows["other"]["median_image"] is None and rows["other"]["median_m1"] == 0.005


def test_category_medians_and_the_heatmap_cells(groups):
    models, cats, medians, fitted = study.category_medians(groups)
    assert cats == ["fabric", "metal", "metallic paint", "other"] and set(models) == {G, B, BP, P, W, L, "gltf",
                                                                                       "ggx+burley"}
    at = lambda m, c: (medians[models.index(m), cats.index(c)], fitted[models.index(m), cats.index(c)])
    assert at(G, "metal") == (pytest.approx(0.048), 2)
    assert at(W, "metal") == (pytest.approx(0.034), 1)
    assert at(P, "metallic paint") == (pytest.approx(0.018), 1)
    assert math.isnan(at(W, "fabric")[0]) and at(W, "fabric")[1] == 0
    fig = study.category_heatmap(groups)
    texts = {t.get_gid(): t.get_text() for t in fig.axes[0].texts}
    assert texts[f"cell {models.index(W)} {cats.index('metal')}"] == "0.034\n1/2"
    assert texts[f"cell {models.index(G)} {cats.index('metal')}"] == "0.048"
    assert len(texts) == int(np.isfinite(medians).sum())


# --- paired comparisons ---------------------------------------------------------------------

def test_lobe_directions_are_declared_for_every_lobe_once():
    assert set(study.LOBE_DIRECTION) == set(NDFS)          # a new lobe must say where it peaks
    half = [m for m in CLASSIC_FAMILY if study.lobe_direction(m) == study.HALF_VECTOR]
    mirror = [m for m in CLASSIC_FAMILY if study.lobe_direction(m) == study.MIRROR]
    assert sorted(half) == sorted([BP, "ward+lambert", "ward_duer+lambert", "ashikhmin_shirley+lambert",
                                   "beckmann+lambert+vgroove", B])
    assert sorted(mirror) == sorted([P, L])
    assert study.lobe_direction("own:nobody") is None

    assert study.lobe_direction("blinn_phong_mf+lambert") == study.HALF_VECTOR
    assert study.lobe_direction("phong_mf+lambert") == study.MIRROR


def test_the_pair_with_the_microfacet_factor_is_compared_where_fitted(groups):
    assert "half-mirror-mf-pair" not in {c.key for c in study.comparisons(groups)}
    bpm, pm = study.MICROFACET_PAIR
    # ranking (M1 + 0.3 image): alum 0.026 / 0.032 half, chrome 0.060 / 0.054 mirror
    more = {m: rs + [_result(bpm, m, *e[0]), _result(pm, m, *e[1])] for m, rs in groups.items()
            for e in [{"alum-bronze": ((0.020, 0.020), (0.020, 0.040)),
                       "chrome-steel": ((0.030, 0.100), (0.030, 0.080))}.get(m)] if e}
    c = next(x for x in study.comparisons(more) if x.key == "half-mirror-mf-pair")
    s = study.comparison_summary(c)
    assert (c.left_models, c.right_models) == ((bpm,), (pm,)) and s["materials"] == 2
    assert (s["ranking"]["left_better"], s["ranking"]["right_better"]) == (1, 1)
    assert s["m1"]["ties"] == 2 and s["median_ratio_image"] == pytest.approx((2.0 + 0.8) / 2)
    assert [x.key for x in study.comparisons(more)][-3:] == ["half-mirror-pair", "half-mirror-mf-pair",
                                                             "half-mirror-best"]


def test_ggx_against_beckmann_counts_and_median_ratios(groups):
    assert study.ndf_pairs(groups) == [(G, B)]       # ggx+burley has no beckmann+burley here; gltf has no twin
    [c] = [x for x in study.comparisons(groups) if x.key.startswith("ggx-beckmann")]
    s = study.comparison_summary(c)
    assert s["materials"] == 3 and [r["material"] for r in s["rows"]] == ["alum-bronze", "chrome-steel",
                                                                          "blue-metallic-paint"]
    # ranking: alum G (0.016 < 0.021), chrome B (0.076 < 0.080), paint G (0.023 < 0.033)
    assert s["ranking"] == {"materials": 3, "left_better": 2, "right_better": 1, "ties": 0}
    # M1: alum G (0.010 < 0.012), chrome B (0.040 < 0.050), paint B (0.018 < 0.020)
    assert s["m1"] == {"materials": 3, "left_better": 1, "right_better": 2, "ties": 0}
    # image: G lower on all three (0.020/0.030, 0.100/0.120, 0.010/0.050)
    assert s["image"] == {"materials": 3, "left_better": 3, "right_better": 0, "ties": 0}
    # Beckmann / GGX: M1 1.2, 0.8, 0.9 -> 0.9; image 1.5, 1.2, 5.0 -> 1.5
    assert s["median_ratio_m1"] == pytest.approx(0.9) and s["median_ratio_image"] == pytest.approx(1.5)


def test_half_vector_against_mirror_direction_pair_and_best_of_each(groups):
    found = {c.key: study.comparison_summary(c) for c in study.comparisons(groups)}
    pair, best = found["half-mirror-pair"], found["half-mirror-best"]
    # BP / P on alum, chrome, fabric: ranking 0.042/0.035 P, 0.090/0.094 BP, 0.015/0.016 BP
    assert pair["materials"] == 3 and (pair["ranking"]["left_better"], pair["ranking"]["right_better"]) == (2, 1)
    assert (pair["m1"]["left_better"], pair["m1"]["right_better"]) == (2, 1)       # 0.030/0.020, 0.060/0.070, 0.009/0.013
    assert (pair["image"]["left_better"], pair["image"]["right_better"]) == (1, 2)  # 0.040/0.050, 0.100/0.080, 0.020/0.010
    # P / BP: M1 0.667, 1.167, 1.444 -> 7/6; image 1.25, 0.8, 0.5 -> 0.8
    assert pair["median_ratio_m1"] == pytest.approx(7 / 6) and pair["median_ratio_image"] == pytest.approx(0.8)
    # best of each: alum B 0.021 / P 0.035, chrome B 0.076 / P 0.094, paint B 0.033 / L 0.0172, fabric BP / P
    assert [(r["material"], r["left_model"], r["right_model"]) for r in best["rows"]] == [
        ("alum-bronze", B, P), ("chrome-steel", B, P), ("blue-metallic-paint", B, L), ("red-fabric", BP, P)]
    assert (best["ranking"]["left_better"], best["ranking"]["right_better"]) == (3, 1)
    assert (best["m1"]["left_better"], best["m1"]["right_better"]) == (3, 1)       # 0.012/0.020, 0.040/0.070, 0.018/0.016, 0.009/0.013
    assert (best["image"]["left_better"], best["image"]["right_better"]) == (1, 3)  # 0.030/0.050, 0.120/0.080, 0.050/0.004, 0.020/0.010
    # mirror / half: M1 1.667, 1.75, 0.889, 1.444 -> (1.444 + 1.667) / 2; image 1.667, 0.667, 0.08, 0.5 -> (0.5 + 0.667) / 2
    assert best["median_ratio_m1"] == pytest.approx((0.013 / 0.009 + 0.020 / 0.012) / 2)
    assert best["median_ratio_image"] == pytest.approx((0.5 + 0.080 / 0.120) / 2)


def test_comparison_figure_draws_each_pair_once_per_error(groups):
    c = next(x for x in study.comparisons(groups) if x.key.startswith("ggx-beckmann"))
    fig = study.comparison_figure(c)
    points = {col.get_gid(): np.asarray(col.get_offsets()) for ax in fig.axes for col in ax.collections}
    assert points["pairs m1"].tolist() == [[0.010, 0.012], [0.050, 0.040], [0.020, 0.018]]
    assert points["pairs image"].tolist() == [[0.020, 0.030], [0.100, 0.120], [0.010, 0.050]]


def test_no_comparison_without_a_material_fitted_on_both_sides():
    apart = {"a": [_result(G, "a", 0.01, 0.01)], "b": [_result(B, "b", 0.01, 0.01), _result(BP, "b", 0.02, 0.01)]}
    assert study.ndf_pairs(apart) == [(G, B)] and study.comparisons(apart) == []


# --- the page ---------------------------------------------------------------------------------

class _Table(html.parser.HTMLParser):
    """The body rows of one table of a page: [(attrs, text)] per cell."""

    def __init__(self, table_id):
        super().__init__(convert_charrefs=True)
        self.id, self.rows, self.inside, self.cell = table_id, [], False, None

    def handle_starttag(self, tag, attrs):
        if tag == "table":
            self.inside = dict(attrs).get("id") == self.id
        elif self.inside and tag == "tr":
            self.rows.append([])
        elif self.inside and tag == "td":
            self.cell = [dict(attrs), ""]
            self.rows[-1].append(self.cell)

    def handle_endtag(self, tag):
        self.cell = None if tag == "td" else self.cell
        self.inside = False if tag == "table" else self.inside

    def handle_data(self, data):
        if self.cell is not None:
            self.cell[1] += data


def _cells(text, table_id):
    table = _Table(table_id)
    table.feed(text)
    return [row for row in table.rows if row]          # the header row has no td


def test_the_page_has_the_study_sections_and_study_json(groups, tmp_path):
    pages = {m: f"materials/m{k}.html" for k, m in enumerate(groups)}
    text = analysis_page.write_analysis(groups, tmp_path, pages=pages).read_text(encoding="utf-8")
    for heading in ("Per category", "GGX against Beckmann", "Half vector against mirror direction", "Per material"):
        assert f"<h2>{heading}</h2>" in text
    figures = {p.name for p in (tmp_path / "analysis").iterdir()}
    assert {"categories.png", "ggx-beckmann-1.png", "half-mirror-pair.png", "half-mirror-best.png",
            "study.json"} <= figures
    numbers = json.loads((tmp_path / "analysis" / "study.json").read_text())
    assert [r["material"] for r in numbers["materials"]] == [r["material"] for r in study.material_rows(groups)]
    assert [c["key"] for c in numbers["comparisons"]] == ["ggx-beckmann-1", "half-mirror-pair", "half-mirror-best"]
    assert numbers["comparisons"][0]["m1"]["right_better"] == 2
    # the per-material table: a row each, linked to its page, the category shown, the name escaped
    rows = _cells(text, "materials")
    assert [r[0][1] for r in rows] == ["red-fabric", "alum-bronze", "chrome-steel", "blue-metallic-paint", NASTY]
    assert [r[1][1] for r in rows] == ["fabric", "metal", "metal", "metallic paint", "other"]
    assert float(rows[1][7][0]["data-value"]) == pytest.approx(0.021 / 0.016)
    assert f'<a href="materials/m4.html">{html.escape(NASTY)}</a>' in text and NASTY not in text
    # the GGX / Beckmann table's counts (ranking, M1, image)
    [ndf] = _cells(text, "ggx-beckmann")
    assert [(c[0]["data-left"], c[0]["data-right"]) for c in ndf[3:6]] == [("2", "1"), ("1", "2"), ("3", "0")]


def test_the_page_leaves_out_what_it_cannot_compare(tmp_path):
    one = {m: [_result(G, m, 0.01 * k, 0.02)] for k, m in enumerate(["alum-bronze", "chrome"], 1)}  # both metals
    text = analysis_page.write_analysis(one, tmp_path).read_text(encoding="utf-8")
    assert "<h2>Per material</h2>" in text
    for heading in ("Per category", "GGX against Beckmann", "Half vector against mirror direction"):
        assert heading not in text
    assert "best classic model" not in text and "<th>category</th>" not in text
    assert sorted(p.name for p in (tmp_path / "analysis").iterdir()) == ["errors.png", "parameters.png",
                                                                         "study.json", "wins.png"]
