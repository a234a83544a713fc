"""Material names are data wherever they are drawn or read back (issue 53, items 3 and 4).

A name with ``$...$`` never reaches matplotlib's mathtext, a name with a tab, CJK
characters or 470 characters draws without a raw ``UserWarning``, and a 470-character
name survives the library's own result reader: in the figures of the report and of the
analysis page, drawn alone (warnings as errors), and in a whole library built from
tables of those names, checked in its pages and its materials.glb.
"""

import html
import urllib.parse
import warnings

import numpy as np
import pytest

from brdf_fit.cli import main
from fitting.result import FitResult

MATH = "a $\\frac{1}{$ b"
LONG = "long " + "x" * 460 + " name"               # 470 characters, more than a file name's 255
NAMES = {"math": MATH, "dollars": "$$", "long": LONG, "tab": "tab\there", "cjk": "\u767d\u8272\u6837\u54c1"}


def _result(material, seed=0):
    rng = np.random.default_rng(seed)
    return FitResult(spec="ggx+lambert", parameters={"albedo": list(rng.uniform(0.1, 0.8, 3)),
                                                     "roughness": float(rng.uniform(0.2, 0.8)), "f0": [0.04] * 3},
                     errors={"m1": float(rng.uniform(0.01, 0.1)), "image": float(rng.uniform(0.01, 0.05))},
                     optimizer={}, provenance={"material": material})


@pytest.mark.parametrize("figure", ["error_bars", "parameter_table", "parameters"])
def test_hostile_names_draw_as_text_without_warnings(figure):
    from brdf_fit.library import analysis
    from brdf_fit.report import plots
    results = [_result(name, k) for k, name in enumerate(NAMES.values())]
    draw = {"error_bars": lambda: plots.error_bars(results, title=f"{MATH}: M1 per model"),
            "parameter_table": lambda: plots.parameter_table(results),
            "parameters": lambda: analysis.parameters({r.material: [r] for r in results})}[figure]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        png = plots.to_png(draw())
    assert png.startswith(b"\x89PNG")


def test_a_short_label_is_drawable_text():
    from brdf_fit.report.plot_base import MAX_LABEL, short_label
    assert short_label("tab\there\nnew  line") == "tab here new line"
    assert short_label(MATH) == MATH                       # kept: drawn with parse_math=False
    assert short_label("\u767d\u8272") in ("\u767d\u8272", "??")      # "?" where no font here draws it
    assert len(short_label(LONG)) == MAX_LABEL and short_label(short_label(LONG)) == short_label(LONG)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """A library of the hostile names: (its folder, the warnings raised, what stderr said)."""
    from test_library_names import _table
    root = tmp_path_factory.mktemp("hostile-text")
    for seed, (stem, name) in enumerate(NAMES.items()):
        _table(root / "in" / f"{stem}.npz", name, seed)
    out = root / "lib"
    import contextlib
    import io
    err = io.StringIO()
    with warnings.catch_warnings(record=True) as caught, contextlib.redirect_stderr(err):
        warnings.simplefilter("always")
        code = main(["library", str(root / "in"), "--out", str(out), "--models", "ggx+lambert",
                     "--samples", "400", "--starts", "1", "-q"])
    assert code == 0, err.getvalue()
    return out, [str(w.message) for w in caught], err.getvalue()


def test_a_library_of_hostile_names_has_every_material(built):
    from test_library_names import cards
    out, _, _ = built
    shown = cards(out)
    assert sorted(shown) == sorted(NAMES.values())
    for name, card in shown.items():
        page = (out / urllib.parse.unquote(card["page"])).read_text(encoding="utf-8")
        assert f"<h1>{html.escape(name)}</h1>" in page, name
    assert (out / "analysis.html").is_file()
    for png in (out / "analysis").glob("*.png"):
        assert png.stat().st_size > 0


def test_a_long_name_is_kept_whole_and_shown_short(built):
    from test_library_glb import read_glb
    from test_library_names import cards
    out, _, _ = built
    [result] = [FitResult.load(p) for p in (out / "results").glob("long*.ggx+lambert.json")]
    assert result.material == LONG
    card = cards(out)[LONG]
    assert len(card["name"]) <= 80 and card["name"] != LONG
    doc, _ = read_glb(out / "materials.glb")
    assert LONG in [n["name"] for n in doc["nodes"]]
    for folder in ("materials", "thumbs", "gltf"):     # the library's own file names stay short
        assert all(len(p.name) < 100 for p in (out / folder).iterdir()), folder


def test_no_raw_warning_is_printed(built):
    _, caught, stderr = built
    assert caught == []
    assert "UserWarning" not in stderr and "warning" not in stderr.lower(), stderr


def test_a_fit_keeps_as_much_of_a_name_as_a_result_file_holds():
    """A `# material:` line longer than a result may hold is cut, so that the result is read back."""
    import dataclasses
    import types

    from fitting.fit import _provenance
    from fitting.result_file import MAX_MATERIAL_CHARS
    name = "n" * (3 * MAX_MATERIAL_CHARS)
    provenance = _provenance(types.SimpleNamespace(provenance={"material": name, "path": "/x.csv", "format": "csv",
                                                               "sha256": "0" * 64}))
    assert provenance["material"] == name[:MAX_MATERIAL_CHARS]
    result = dataclasses.replace(_result(LONG), provenance=provenance)
    assert FitResult.from_dict(result.to_dict()).material == name[:MAX_MATERIAL_CHARS]


def test_a_long_name_on_a_card_keeps_both_ends():
    from brdf_fit.library.gallery import SHOWN_NAME, shown_name
    a, b = shown_name(LONG + " (lab1)"), shown_name(LONG + " (lab2)")
    assert a != b and len(a) == len(b) == SHOWN_NAME
    assert a.startswith("long xxx") and a.endswith("name (lab1)")
    assert shown_name("tab\there") == "tab here" and shown_name("short") == "short"
