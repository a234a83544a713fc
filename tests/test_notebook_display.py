"""Fits and measurements that show themselves in notebooks (docs/notebooks.md).

- MeasuredBRDF: a one-line repr; HTML with its format, counts and ranges
  (numbers from numpy on the values); a lit sphere from its own lookup that
  equals the closed form of a Lambertian and of a cosine-weighted table,
  pixel by pixel (data_loaders/display.py's scene);
- FitResult: a one-line repr; the engine's HTML (parameters, at-bound ones
  marked, errors) without importing the application or any renderer;
- brdf_fit.notebook: ``comparison_image`` equals the PNG ``brdf-fit render
  --measured`` writes, pixel for pixel; the IPython hook adds exactly those
  spheres; without OpenGL or the measured file one line says so;
- nothing display-related is imported until asked.
"""

import base64
import io
import json
import re
import subprocess
import sys
import types

import numpy as np
import pytest

from brdf.model import parameter_schema, parse_model
from data_loaders.measured import MeasuredBRDF, Provenance
from fitting.result import FitResult

PARAMS = {"albedo": [0.30, 0.12, 0.05], "roughness": 0.4, "f0": [0.04, 0.04, 0.04]}
ALBEDO = np.array([0.5, 0.25, 0.1])


class _Table:
    """f(wi, wo) = ALBEDO / pi x (wi_z wo_z if cosine else 1)."""

    def __init__(self, cosine=False):
        self.cosine = cosine

    def lookup(self, wi, wo, method=None):
        w = wi[:, 2] * wo[:, 2] if self.cosine else np.ones(len(wi))
        return w[:, None] * ALBEDO / np.pi


def _measured(table=None, material="lambert-test"):
    rng = np.random.default_rng(1)
    wi = rng.normal(size=(500, 3))
    wi[:, 2] = np.abs(wi[:, 2])
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    wo = wi[::-1].copy()
    values = np.tile(ALBEDO / np.pi, (500, 1)) * rng.uniform(0.5, 2.0, (500, 1))
    valid = np.ones(500, bool)
    valid[:7] = False
    values[~valid] = 0.0
    prov = Provenance(path="<test>", format="samples", material=material, sha256="", units="1/sr")
    return MeasuredBRDF(wi=wi, wo=wo, values=values, weights=np.ones(500), valid=valid, isotropic=True,
                        provenance=prov, table=table or _Table())


def _result(provenance=None, **params):
    return FitResult(spec="ggx+lambert", parameters={**PARAMS, **params},
                     errors={"m1": 0.0123456, "m1_per_channel": [0.01, 0.02, 0.03], "loss_name": "log",
                             "loss": 0.011, "image": 0.0456789, "exported_model": "gltf+ior",
                             "exported_m1": 0.0134567, "exported_image": 0.0501234},
                     optimizer={"name": "lbfgs", "seconds": 1.25, "seconds_total": 2.5, "converged": True,
                                "max_theta": 80.0},
                     provenance=provenance or {"file": None, "sha256": None, "format": None,
                                               "material": "test-material"})


# --- MeasuredBRDF ---------------------------------------------------------------------------

def test_measured_repr_is_one_short_line():
    m = _measured()
    text = repr(m)
    v = m.values[m.valid]
    assert "\n" not in text and len(text) < 200
    assert f"{len(m):,} samples ({m.valid.sum():,} valid)" in text
    assert f"{v.min():.3g}..{v.max():.3g} 1/sr" in text and "'lambert-test'" in text and "samples" in text


def test_measured_html_holds_the_facts_and_the_sphere():
    m = _measured()
    page = m._repr_html_()
    v = m.values[m.valid]
    assert f"{len(m):,} ({m.valid.sum():,} valid" in page
    for j, name in enumerate("rgb"):
        assert f"{name} (1/sr)" in page
        assert f"{v[:, j].min():.4g} .. {v[:, j].max():.4g} (median {np.median(v[:, j]):.4g})" in page
    png = base64.b64decode(re.search(r'src="data:image/png;base64,([^"]+)"', page).group(1))
    assert png == m._repr_png_()


def _sphere_normals(size):
    """Pixel-centre normals of the orthographic unit sphere (the documented scene), computed here."""
    u = (np.arange(size) + 0.5) * 2.0 / size - 1.0
    y, x = -u[:, None] * np.ones(size), np.ones(size)[:, None] * u
    inside = x * x + y * y < 1.0
    return np.stack([x, y, np.sqrt(np.clip(1 - x * x - y * y, 0, None))], -1), inside


@pytest.mark.parametrize("cosine", [False, True])
def test_lit_sphere_is_the_closed_form(cosine):
    from PIL import Image

    from data_loaders.display import LIGHTS, lit_sphere, png_bytes
    m = _measured(_Table(cosine))
    size = 48
    n, inside = _sphere_normals(size)
    expected = np.zeros((size, size, 3))
    for direction, irradiance in LIGHTS:
        l = np.asarray(direction) / np.linalg.norm(direction)
        cos = np.clip(n @ l, 0.0, None)
        f = ALBEDO / np.pi * ((cos * n[..., 2])[..., None] if cosine else 1.0)   # wi_z = n.l, wo_z = n.z
        expected += f * np.asarray(irradiance) * cos[..., None]
    expected[~inside] = 0.0
    radiance, mask = lit_sphere(m, size, linear=True)
    np.testing.assert_array_equal(mask, inside)
    np.testing.assert_allclose(radiance, expected, rtol=1e-12, atol=1e-14)
    # the display curve: the viewer's exposure (0.85 / the 99th percentile of the lit pixels'
    # brightest channel), Reinhard, sRGB, 8 bits; the PNG holds exactly that
    brightest = expected[inside].max(axis=1)
    exposed = expected * 0.85 / np.percentile(brightest[brightest > 0], 99)
    x = exposed / (1 + exposed)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)
    shown = np.asarray(Image.open(io.BytesIO(png_bytes(lit_sphere(m, size)))))
    assert shown.shape == (size, size, 4)
    np.testing.assert_array_equal(shown[..., 3], np.where(inside, 255, 0))
    assert np.abs(shown[..., :3][inside].astype(int) - np.round(srgb * 255)[inside]).max() <= 1


# --- FitResult (the engine alone) -----------------------------------------------------------------

def test_result_repr_is_one_short_line():
    text = repr(_result())
    assert text == "<FitResult ggx+lambert on 'test-material': M1 0.012346, image 0.045679>"


ENGINE_ONLY = r"""
import json, sys
from fitting.result import FitResult
r = FitResult.from_dict(json.loads(sys.stdin.read()))
html = r._repr_html_()
loaded = sorted(m for m in sys.modules if m.split(".")[0] in ("brdf_fit", "shaders", "moderngl", "PIL",
                                                             "IPython", "pandas", "matplotlib"))
print(json.dumps({"html": html, "loaded": loaded}))
"""


def test_result_html_is_the_engines_own():
    lower = next(p.lower for p in parameter_schema(parse_model("ggx+lambert")) if p.name == "roughness")
    result = _result(roughness=lower)
    proc = subprocess.run([sys.executable, "-c", ENGINE_ONLY], input=json.dumps(result.to_dict()),
                          capture_output=True, text=True, check=True)
    out = json.loads(proc.stdout)
    assert out["loaded"] == []                      # no application, renderer, IPython or pandas
    page = out["html"]
    assert page == result._repr_html_()
    assert "<code>ggx+lambert</code>" in page and "test-material" in page
    assert re.search(r">roughness\*</span>", page) and "* at the lower bound" in page
    assert ">albedo</span>" in page and ">f0</span>" in page          # not marked
    assert f"[{0.30:.5g}, {0.12:.5g}, {0.05:.5g}]" in page and f"{lower:.5g}" in page
    for label, value in (("M1", 0.0123456), ("image error", 0.0456789), ("exported M1", 0.0134567),
                         ("exported image error", 0.0501234)):
        assert re.search(rf"<th[^>]*>{label}</th><td[^>]*>{value:.5g}", page), label
    assert "gltf+ior" in page and "%load_ext brdf_fit.notebook" in page


NOTHING_IMPORTED = r"""
import sys
import numpy as np
import data_loaders, fitting, fitting.result, brdf_fit, brdf_fit.notebook
from fitting.result import FitResult
r = FitResult(spec="gltf", parameters={"base_color": [0.5, 0.5, 0.5], "metallic": 0.0, "roughness": 0.5},
              errors={"m1": 0.1}, optimizer={}, provenance={})
repr(r)
from data_loaders.measured import MeasuredBRDF, Provenance
m = MeasuredBRDF(wi=np.eye(3), wo=np.eye(3), values=np.ones((3, 3)), weights=np.ones(3), valid=np.ones(3, bool),
                 isotropic=True, provenance=Provenance("x", "csv", "x", "", ""), table=None)
repr(m)
print(" ".join(sorted(m for m in sys.modules if m in DISPLAY or m.split(".")[0] in DISPLAY)))
"""


def test_nothing_for_display_is_imported_until_asked():
    display = ("data_loaders.display", "fitting.result_display", "shaders", "moderngl", "PIL", "IPython",
               "pandas", "brdf_fit.render", "brdf_fit.report", "brdf_fit.export")
    code = f"DISPLAY = {display!r}\n" + NOTHING_IMPORTED
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert proc.stdout.split() == []


# --- the application: renders, the hook -------------------------------------------------------

@pytest.fixture(scope="module")
def lambert_file(tmp_path_factory):
    """A MERL file of a Lambertian table and a ggx+lambert result whose provenance names it."""
    from data_loaders.merl import MERL_SHAPE, write_merl
    folder = tmp_path_factory.mktemp("notebook-display")
    path = folder / "matte.binary"
    rgb = np.broadcast_to(ALBEDO / np.pi, MERL_SHAPE + (3,))
    write_merl(path, rgb, np.ones(MERL_SHAPE, bool))
    result = _result({"file": str(path), "sha256": None, "format": "merl", "material": "matte"})
    result.save(folder / "matte.ggx_lambert.json")
    return path, folder / "matte.ggx_lambert.json", result


def _need_gl():
    pytest.importorskip("moderngl")
    from shaders.gl import gl_available
    ok, why = gl_available()
    if not ok:
        pytest.skip(f"no OpenGL here: {why}")


def test_comparison_image_is_what_render_writes(lambert_file, tmp_path):
    _need_gl()
    from PIL import Image

    from brdf_fit.notebook import comparison_image
    measured, result_file, _ = lambert_file
    out = tmp_path / "cmp.png"
    proc = subprocess.run([sys.executable, "-m", "brdf_fit", "render", str(result_file), "--measured",
                           str(measured), "--size", "256", "--out", str(out)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    written = np.asarray(Image.open(out).convert("RGB"))
    image = comparison_image(result_file, measured, size=256)
    assert image.mode == "RGB" and image.size == (written.shape[1], written.shape[0])
    np.testing.assert_array_equal(np.asarray(image), written)
    # the provenance file is the default measurement
    np.testing.assert_array_equal(np.asarray(comparison_image(result_file, size=256)), written)


def _formatter_shell():
    pytest.importorskip("IPython")
    from IPython.core.formatters import DisplayFormatter
    return types.SimpleNamespace(display_formatter=DisplayFormatter())


def test_hook_adds_the_render_and_undoes_cleanly(lambert_file):
    _need_gl()
    from PIL import Image

    import brdf_fit.notebook as nb
    _, _, result = lambert_file
    ip = _formatter_shell()
    plain, _ = ip.display_formatter.format(result)
    assert "%load_ext brdf_fit.notebook" in plain["text/html"] and "image/png" not in plain
    nb.load_ipython_extension(ip)
    data, _ = ip.display_formatter.format(result)
    expected = np.asarray(nb.comparison_image(result, size=nb.DISPLAY_SIZE))
    np.testing.assert_array_equal(np.asarray(Image.open(io.BytesIO(data["image/png"])).convert("RGB")), expected)
    inline = re.search(r'alt="measured \| fitted \| difference" src="data:image/png;base64,([^"]+)"',
                       data["text/html"]).group(1)
    assert base64.b64decode(inline) == data["image/png"]
    assert ">roughness</span>" in data["text/html"] and data["text/plain"] == repr(result)
    nb.unload_ipython_extension(ip)
    assert ip.display_formatter.format(result)[0] == plain


def test_register_needs_a_running_ipython():
    pytest.importorskip("IPython")
    from brdf_fit.notebook import register
    with pytest.raises(RuntimeError, match="running IPython"):
        register()


def test_without_gl_or_data_one_line_says_so(lambert_file, monkeypatch, tmp_path):
    import brdf_fit.notebook.display as display
    from shaders.gl import GLUnavailableError
    _, _, result = lambert_file

    def no_gl(*args, **kwargs):
        raise GLUnavailableError("could not create a headless OpenGL context\nthrough EGL; install libegl1")

    monkeypatch.setattr(display, "comparison_image", no_gl)
    monkeypatch.setattr(display, "_renders", type(display._renders)())
    monkeypatch.setattr(display, "_gl_problem", [])
    view = display.show(result)
    page = view._repr_html_()
    notes = re.findall(r"<p[^>]*>spheres not shown: ([^<]*)</p>", page)
    assert notes == ["no OpenGL here: could not create a headless OpenGL context through EGL; install libegl1"]
    assert view._repr_png_() is None and ">roughness</span>" in page and "M1" in page
    # no measured file on this machine: one line naming it
    gone = _result({"file": str(tmp_path / "gone.binary"), "sha256": None, "format": "merl", "material": "m"})
    notes = re.findall(r"spheres not shown: ([^<]*)</p>", display.show(gone)._repr_html_())
    assert len(notes) == 1 and "gone.binary is not on this machine" in notes[0]


def test_lit_sphere_of_a_merl_file_is_the_closed_form(lambert_file):
    """Through the loader and MERL's own lookup: a Lambertian table gives albedo / pi x sum E cos."""
    from data_loaders import load
    from data_loaders.display import LIGHTS, lit_sphere
    measured = load(lambert_file[0])
    size = 40
    n, inside = _sphere_normals(size)
    expected = sum(ALBEDO / np.pi * np.asarray(e) * np.clip(n @ (np.asarray(d) / np.linalg.norm(d)), 0, None)[..., None]
                   for d, e in LIGHTS)
    radiance, mask = lit_sphere(measured, size, linear=True)
    np.testing.assert_array_equal(mask, inside)
    np.testing.assert_allclose(radiance[inside], expected[inside], rtol=1e-6)
