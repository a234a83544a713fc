"""`brdf-fit demo` end to end: stand-ins written, fitted, rendered, exported, reported, and
the library of the three materials written."""

import json

import numpy as np
import pytest

from data_loaders import load
from brdf_fit.cli import main
from brdf_fit.demo import ABC_FITS, abc_brdf
from fitting.ranking import shipped_best
from fitting.result import FitResult
from model_tables import glb_material


@pytest.mark.whole_table      # three MERL-size stand-in tables fitted in this process
def test_demo_writes_every_output(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--samples", "8000"]) == 0
    text = capsys.readouterr().out
    assert "stand-in" in text and "M1 (lower is better)" in text
    for material in ABC_FITS:
        # the stand-in table holds the ABC model at the MERL cell centres
        measured = load(out / "data" / f"{material}.binary")
        rows = np.flatnonzero(measured.valid)[::50_000]
        expected = abc_brdf(measured.wi[rows], measured.wo[rows], **ABC_FITS[material])
        np.testing.assert_allclose(measured.values[rows], expected, rtol=1e-12)
        results = [FitResult.load(p) for p in (out / "results").glob(f"{material}.*.json")]
        assert sorted(r.spec for r in results) == [
            "ggx+burley", "ggx+cod_wwii", "ggx+frostbite", "ggx+lambert", "gltf+nonmetal+ior+turquin"]
        # the material written is the one export and the library ship (issue 62: one best everywhere)
        best = shipped_best(results)
        assert f"{material}: exporting {best.spec}" in text
        assert (out / "preview" / f"{material}.png").stat().st_size > 1000
        glb = (out / "gltf" / f"{material}.glb").read_bytes()
        assert glb[:4] == b"glTF"
        assert (out / "report" / f"{material}.html").exists()
    assert (out / "report" / "index.html").exists()
    gallery = (out / "library" / "index.html").read_text(encoding="utf-8")
    assert all(f'<b class="name"><span title="{material}">{material}</span></b>' in gallery for material in ABC_FITS)
    assert f"library (gallery, models compared, all materials in one .glb): {out / 'library' / 'index.html'}" in text
    from brdf_fit.library.material import library_files
    from brdf_fit.report.identity import material_stem
    pages = [library_files(material_stem(FitResult.load(p) for p in (out / "results").glob(f"{m}.*.json")))["page"]
             for m in ABC_FITS]
    for name in ("analysis.html", "materials.glb", *pages):
        assert (out / "library" / name).is_file(), name
    for material in ABC_FITS:       # the library's .glb holds the material the demo exported
        stem = material_stem(FitResult.load(p) for p in (out / "results").glob(f"{material}.*.json"))
        shipped, exported = (glb_material(f) for f in (out / "library" / library_files(stem)["glb"],
                                                         out / "gltf" / f"{material}.glb"))
        assert shipped.pop("extras")["brdf_fit"]["spec"] == exported.pop("extras")["brdf_fit"]["spec"]
        assert shipped == exported      # (the extras' honesty records name their own files)
    assert "honesty" in json.dumps(json.loads(
        glb[20:20 + int.from_bytes(glb[12:16], "little")].decode()))
