"""``brdf-fit report``: pages per material, every image present, the errors
table (including the exported glTF's M1), the command, bad input."""

import dataclasses
import html
import json
import re
import sys

import pytest

from brdf_fit.export.gltf import export_gltf
from brdf_fit.report.pages import collect_results, report_main
from fitting.result import FitResult

# Parameters close to what ggx+lambert and ggx+cod_wwii fit to the red-plastic stand-in
FITS = {
    "ggx+lambert": ({"albedo": [0.2617, 0.03916, 0.005635], "roughness": 0.6077,
                     "f0": [0.03065, 0.02828, 0.02773]}, 0.0029098),
    "ggx+cod_wwii": ({"albedo": [0.2556, 0.03746, 0.004608], "roughness": 0.6157,
                      "f0": [0.06892, 0.0359, 0.03076]}, 0.0039275),
}


def make_result(spec, params, m1, provenance):
    return FitResult(spec=spec, parameters=params,
                     errors={"m1": m1, "m1_per_channel": [m1 * 0.9, m1, m1 * 1.1], "loss_name": "log",
                             "loss": m1, "loss_per_channel": [m1] * 3},
                     optimizer={"name": "lbfgs", "evaluations": 40, "converged": True, "samples": 20000,
                                "seconds_total": 1.5, "max_theta": 80.0},
                     provenance=provenance)


@pytest.fixture(scope="module")
def standin(tmp_path_factory):
    """The red-plastic MERL stand-in on disk and two results whose provenance names it."""
    from data_loaders import load
    from brdf_fit.demo import write_standins
    folder = tmp_path_factory.mktemp("report")
    (path,) = write_standins(folder, ["red-plastic"])
    measured = load(path)
    prov = {"file": str(path), "sha256": measured.provenance.sha256, "format": "merl",
            "material": "red-plastic"}
    results = folder / "results"
    for spec, (params, m1) in FITS.items():
        make_result(spec, params, m1, prov).save(results / f"red-plastic.{spec}.json")
    (results / "summary.json").write_text(json.dumps({"not": "a fit result"}))
    return folder, path, results


def _images(page):
    return re.findall(r'<img src="([^"]+)"', page)


def test_report_writes_pages_figures_and_the_command(standin, tmp_path, capsys, monkeypatch):
    from brdf_fit.cli import main
    folder, measured_path, results = standin
    out = tmp_path / "report"
    argv = ["report", str(results), "--out", str(out)]
    monkeypatch.setattr(sys, "argv", ["brdf-fit"] + argv)    # the CLI quotes sys.argv
    assert main(argv) == 0
    page = (out / "red-plastic.html").read_text()
    index = (out / "index.html").read_text()
    # the exact command
    assert html.escape("brdf-fit " + " ".join(argv)) in page
    # every referenced image exists and is a PNG; the five analysis figures are there
    images = _images(page)
    for name in ("red-plastic-lobes.png", "red-plastic-slices.png", "red-plastic-halfdiff.png",
                 "red-plastic-albedo.png", "red-plastic-errors.png"):
        assert name in images
    for name in images + _images(index):
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name
    # the models table: sorted by M1, recorded errors, the best row marked
    rows = re.findall(r"<tr( class=\"best\")?><td><span[^>]*></span><code>([^<]+)</code></td>"
                      r"<td class=\"num\">([^<]+)</td>", page)
    assert [(r[1], float(r[2])) for r in rows[:2]] == [("ggx+lambert", 0.0029098), ("ggx+cod_wwii", 0.0039275)]
    assert rows[0][0] and not rows[1][0]
    # the exported glTF's M1 equals what `brdf-fit export` reports for the same result
    info = export_gltf(FitResult.load(results / "red-plastic.ggx+lambert.json"), tmp_path / "m.glb")
    exported = info["honesty"]["m1_exported_gltf"]
    assert f"{exported:.5g}" in page and "M1 as exported glTF" in page
    # provenance and the measured file are named
    assert str(measured_path) in page
    assert 'href="red-plastic.html"' in index and "ggx+cod_wwii" in index
    # the lit spheres: shown, or the page says why not
    assert ("red-plastic-render-ggx_lambert.png" in images) or ("Lit-sphere comparison not shown" in page)
    assert "report:" in capsys.readouterr().out


def test_report_without_renderer_and_without_measurement(standin, tmp_path, monkeypatch):
    """The report must work when shaders.render cannot be imported and when the
    measured file of a material is gone (fitted curves only, with a note)."""
    folder, measured_path, results = standin
    monkeypatch.setitem(sys.modules, "shaders.render", None)       # import raises ImportError
    gone = dict(FitResult.load(results / "red-plastic.ggx+lambert.json").provenance,
                file=str(tmp_path / "moved-away.binary"), material="lost-material",
                sha256="f" * 64)      # another measurement: one sha256 is one material (brdf_fit.report.identity)
    lost = make_result("ggx+lambert", FITS["ggx+lambert"][0], 0.01, gone).save(tmp_path / "lost.json")
    out = tmp_path / "report"
    assert report_main([str(results / "red-plastic.ggx+lambert.json"), str(lost)], str(out),
                       command_line="brdf-fit report two files") == 0
    page = (out / "red-plastic.html").read_text()
    assert "Lit-sphere comparison not shown" in page and "not available" in page
    lost_page = (out / "lost-material.html").read_text()
    assert "moved-away.binary" in lost_page and "pass --measured" in lost_page
    assert "lost-material-lobes.png" in _images(lost_page)
    assert "M1 as exported glTF" not in lost_page
    index = (out / "index.html").read_text()
    assert 'href="lost-material.html"' in index and 'href="red-plastic.html"' in index
    assert "brdf-fit report two files" in index


def test_explicit_measured_file_is_used_and_checked(standin, tmp_path):
    """--measured overrides the provenance; a different file is flagged (sha256)."""
    from brdf_fit.demo import write_standins
    folder, measured_path, results = standin
    (other,) = write_standins(tmp_path, ["blue-acrylic"])
    out = tmp_path / "report"
    assert report_main([str(results / "red-plastic.ggx+lambert.json")], str(out),
                       measured_path=str(other)) == 0
    page = (out / "red-plastic.html").read_text()
    assert str(other) in page and "differs from the one these fits were made on" in page


def test_folders_skip_non_results_but_files_must_be_results(standin, tmp_path):
    folder, _, results = standin
    found = collect_results([results])
    assert sorted(r.spec for _, r in found) == ["ggx+cod_wwii", "ggx+lambert"]


@pytest.mark.parametrize("case", ["missing", "not-a-result", "empty-folder", "bad-measured"])
def test_report_bad_input_is_one_line(standin, tmp_path, capsys, case):
    folder, _, results = standin
    (tmp_path / "empty").mkdir()
    args = {"missing": ([str(tmp_path / "nope.json")], None),
            "not-a-result": ([str(results / "summary.json")], None),
            "empty-folder": ([str(tmp_path / "empty")], None),
            "bad-measured": ([str(results)], str(tmp_path / "nope.binary"))}[case]
    assert report_main(args[0], str(tmp_path / "out"), measured_path=args[1]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("brdf-fit report: error:") and "Traceback" not in err[0]
    assert not (tmp_path / "out" / "index.html").exists()


def test_a_fit_whose_gltf_loses_more_than_the_shipped_rule_says_so(standin, tmp_path):
    """Issue 62: a result whose exported glTF draws 2.29x its fit's image error (more than the
    shipped rule's 1.05) gets a note on its page pointing to export-first; one within it does not."""
    from brdf_fit.report.pages import write_report
    folder, measured_path, results = standin
    base = FitResult.load(results / "red-plastic.ggx+lambert.json")
    lossy = dataclasses.replace(base, errors=dict(base.errors, image=0.01, exported_m1=0.012,
                                                  exported_image=0.0229, exported_model="gltf+specular"))
    fine = dataclasses.replace(lossy, errors=dict(lossy.errors, exported_image=0.0104))
    for result, expected in ((lossy, True), (fine, False)):
        out = tmp_path / f"report-{expected}"
        path = result.save(tmp_path / f"in-{expected}" / "red-plastic.ggx+lambert.json")
        (page,) = write_report([(path, result)], out, renders=False, index=False)
        text = page.read_text()
        assert (html.escape("ggx+lambert's glTF material draws 2.29x its fit's image error") in text) == expected
        assert ("brdf-fit export MEASURED_FILE --out material.glb" in text) == expected
