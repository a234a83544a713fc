"""brdf_fit.report.plots: the numbers the figures draw (REFERENCE.md albedos, exact
fits give zero error), colours per model, units on the axes."""

import types

import numpy as np
import pytest
from matplotlib.figure import Figure

from brdf_fit import plots
from fitting.fit import evaluate_result
from fitting.result import FitResult
from fitting.synthetic import synthetic_measured

TRUTH = {"albedo": [0.45, 0.2, 0.08], "roughness": 0.35, "f0": [0.05, 0.05, 0.05]}
OFF = {"albedo": [0.3, 0.3, 0.3], "roughness": 0.6, "f0": [0.04, 0.04, 0.04]}


def result(spec, params, m1=0.01, material="synthetic"):
    return FitResult(spec=spec, parameters=params,
                     errors={"m1": m1, "m1_per_channel": [m1] * 3, "loss_name": "log", "loss": m1},
                     optimizer={"name": "lbfgs"}, provenance={"material": material})


@pytest.fixture(scope="module")
def data():
    return synthetic_measured("ggx+lambert", TRUTH, grid=(24, 24, 48, 1))


def test_colours_are_fixed_per_model_and_distinct():
    names = ["ggx+lambert", "ggx+burley", "ggx+frostbite", "ggx+cod_wwii", "ggx+lambert+ms",
             "ggx+lambert+clearcoat", "gltf"]
    colours = [plots.model_color(n) for n in names]
    assert len(set(colours)) == len(colours)
    assert plots.model_color("ggx+lambert") == "#1f77b4"
    # unknown models hash to a stable palette entry
    assert plots.model_color("ggx+oren_nayar+ms") == plots.model_color("ggx+oren_nayar+ms")


def test_in_plane_geometry_has_the_mirror_at_plus_theta_i():
    wi, wo, to = plots.in_plane_directions(30.0, n=181)
    assert np.allclose(np.linalg.norm(wi, axis=1), 1) and np.allclose(np.linalg.norm(wo, axis=1), 1)
    h = wi + wo
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    k = np.argmax(h[:, 2])
    assert to[k] == pytest.approx(30.0, abs=0.6)


def _line(ax, label):
    for line in ax.get_lines():
        if line.get_label() == label:
            return line
    raise AssertionError(f"no line {label!r}")


def test_polar_lobes_draw_measured_and_fits_in_their_colours(data):
    exact, off = result("ggx+lambert", TRUTH), result("ggx+burley", dict(OFF))
    fig = plots.polar_lobes(data, [exact, off], incidence_deg=(0, 45))
    assert isinstance(fig, Figure)
    polar = [ax for ax in fig.axes if ax.name == "polar"]
    assert len(polar) == 2
    ax = polar[1]
    m, f, g = _line(ax, "measured"), _line(ax, "ggx+lambert"), _line(ax, "ggx+burley")
    assert m.get_color() == "black" and f.get_color() == plots.model_color("ggx+lambert")
    np.testing.assert_allclose(f.get_ydata(), m.get_ydata(), atol=1e-9)     # exact fit on its data
    assert np.max(np.abs(g.get_ydata() - m.get_ydata())) > 0.05            # another model differs
    assert "1/sr" in polar[0].get_ylabel()


def test_theta_h_slices_values_and_units(data):
    exact = result("ggx+lambert", TRUTH)
    fig = plots.theta_h_slices(data, [exact], theta_d_deg=(5, 45), n=60)
    ax = fig.axes[0]
    assert ax.get_yscale() == "log" and "1/sr" in ax.get_ylabel() and "degrees" in ax.get_xlabel()
    m, f = _line(ax, "measured"), _line(ax, "ggx+lambert")
    np.testing.assert_allclose(f.get_ydata(), m.get_ydata(), rtol=1e-9)
    # the plotted value at theta_h = 0 is the model's luminance at (theta_h 0, theta_d 5 deg)
    wi, wo = plots.half_diff_directions(0.0, 5.0, 90.0)
    expected = evaluate_result(exact, wi, wo) @ plots.LUMINANCE
    assert f.get_xdata()[0] == 0.0 and f.get_ydata()[0] == pytest.approx(expected[0], rel=1e-9)


def test_half_diff_error_image_is_zero_for_the_exact_fit(data):
    exact, off = result("ggx+lambert", TRUTH), result("ggx+lambert", OFF)
    fig = plots.half_diff_images(data, [exact, off], n=30)
    titles = [ax.get_title() for ax in fig.axes]
    err_axes = [ax for ax in fig.axes if ax.get_title().startswith("log error")]
    assert len(err_axes) == 2 and "measured" in titles
    err0 = np.ma.filled(err_axes[0].images[0].get_array(), np.nan)
    err1 = np.ma.filled(err_axes[1].images[0].get_array(), np.nan)
    assert np.nanmax(np.abs(err0)) < 1e-9 and np.nanmax(np.abs(err1)) > 0.05
    assert not np.isnan(err0).any()         # at phi_d = 90 deg no direction is below the horizon
    # at phi_d = 0, theta_h + theta_d > 90 deg puts wi below the horizon: blank, not zero
    low = plots.half_diff_images(data, [exact], phi_d_deg=0.0, n=30)
    img = np.ma.filled([ax for ax in low.axes if ax.get_title() == "measured"][0].images[0].get_array(), np.nan)
    th = ((np.arange(30) + 0.5) / 30) ** 2 * 90.0
    td = (np.arange(30) + 0.5) / 30 * 90.0
    np.testing.assert_array_equal(np.isnan(img), (th[None, :] + td[:, None]) >= 90.0)
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert "log10(fitted / measured)" in labels and "log10 BRDF (1/sr)" in labels


# REFERENCE.md s.4 (white furnace, rho = 1) and s.5 (GGX + height-correlated Smith, F = 1)
ALBEDO_REFS = [
    ("ggx+lambert+f90", {"albedo": [1.0] * 3, "roughness": 0.5, "f0": [0.0] * 3, "f90": 0.0},
     (1.0, 1.0), 1e-3),
    ("ggx+burley+f90", {"albedo": [1.0] * 3, "roughness": 0.5, "f0": [0.0] * 3, "f90": 0.0},
     (1.0060, 1.0083), 1e-3),
    ("ggx+frostbite+f90", {"albedo": [1.0] * 3, "roughness": 0.5, "f0": [0.0] * 3, "f90": 0.0},
     (0.8262, 0.8217), 1e-3),
    ("ggx+cod_wwii+f90", {"albedo": [1.0] * 3, "roughness": 0.5, "f0": [0.0] * 3, "f90": 0.0},
     (0.9440, 0.8800), 1e-3),
    ("ggx", {"roughness": 0.5, "f0": [1.0] * 3}, (0.91581, 0.85726), 2e-3),
    ("ggx", {"roughness": 0.25, "f0": [1.0] * 3}, (0.99571, 0.98832), 2e-3),
]


@pytest.mark.parametrize("spec, params, expected, tol", ALBEDO_REFS)
def test_directional_albedo_matches_reference_tables(spec, params, expected, tol):
    """E(mu = 1) and E(mu = 0.5): view angles 0 and 60 degrees."""
    e = plots.directional_albedo_values(result(spec, params), [0.0, 60.0])
    np.testing.assert_allclose(e[:, 0], expected, atol=tol)
    np.testing.assert_allclose(e[:, 0], e[:, 2], rtol=1e-12)      # grey in, grey out


def test_directional_albedo_figure_uses_the_measurement(data):
    exact = result("ggx+lambert", TRUTH)
    fig = plots.directional_albedo(data, [exact], theta_o_deg=[0, 30, 60])
    assert len(fig.axes) == 3 and "degrees" in fig.axes[0].get_xlabel()
    m, f = _line(fig.axes[0], "measured"), _line(fig.axes[0], "ggx+lambert")
    np.testing.assert_allclose(m.get_ydata(), f.get_ydata(), rtol=1e-9)
    # red albedo 0.45 plus a specular part: between 0.45 and 0.6
    assert 0.45 < m.get_ydata()[0] < 0.6


def test_error_bars_heights_and_log_scale():
    rs = [result("ggx+lambert", TRUTH, 0.002, "a"), result("ggx+burley", TRUTH, 0.05, "a"),
          result("ggx+lambert", TRUTH, 0.004, "b"), result("ggx+burley", TRUTH, 0.003, "b")]
    fig = plots.error_bars(rs)
    ax = fig.axes[0]
    heights = sorted(round(p.get_height(), 6) for p in ax.patches)
    assert heights == [0.002, 0.003, 0.004, 0.05]
    assert ax.get_yscale() == "log"                 # 0.002 .. 0.05 spans more than a decade
    assert [t.get_text() for t in ax.get_xticklabels()] == ["a", "b"]
    colours = {p.get_facecolor()[:3] for p in ax.patches}
    assert len(colours) == 2
    narrow = plots.error_bars([result("ggx+lambert", TRUTH, 0.01, "a"), result("ggx+burley", TRUTH, 0.02, "a")])
    assert narrow.axes[0].get_yscale() == "linear"


def test_parameter_table_lists_values():
    rs = [result("ggx+lambert", TRUTH, 0.0123), result("gltf", {"base_color": [0.5, 0.4, 0.3],
                                                                "metallic": 0.0, "roughness": 0.7}, 0.02)]
    header, rows = plots.parameter_rows(rs)
    assert header[:3] == ["material", "model", "M1"]
    assert "base_color" in header and "f0" in header
    assert rows[0][2] == "0.0123" and rows[0][header.index("roughness")] == "0.35"
    assert rows[1][header.index("albedo")] == ""
    fig = plots.parameter_table(rs)
    texts = {t.get_text() for t in fig.axes[0].tables[0].get_celld().values() for t in [t.get_text()]}
    assert "(0.45, 0.2, 0.08)" in texts and "gltf" in texts


def test_figures_render_to_png(tmp_path, data):
    exact = result("ggx+lambert", TRUTH)
    png = plots.to_png(plots.polar_lobes(data, [exact], incidence_deg=(30,)))
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 5000
    path = plots.save(plots.parameter_table([exact]), tmp_path / "t.png")
    assert path.stat().st_size > 1000


def test_plots_without_measurement_show_fits_only():
    fig = plots.theta_h_slices(None, [result("ggx+lambert", TRUTH)], theta_d_deg=(10,), n=20)
    assert [line.get_label() for line in fig.axes[0].get_lines()] == ["ggx+lambert"]


def _texts(fig):
    """[(axes index, text, box)] of what the figure draws: each visible axes' (colour bars'
    too) tick labels within its limits, axis labels, title and offset text, in pixels."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    out = []
    for k, ax in enumerate(a for a in fig.axes if a.get_visible() and a.axison):
        texts = [ax.xaxis.label, ax.yaxis.label, ax.title, ax.xaxis.get_offset_text(), ax.yaxis.get_offset_text()]
        for axis in (ax.xaxis, ax.yaxis):
            low, high = sorted(axis.get_view_interval())
            texts += [t for at, t in zip(axis.get_majorticklocs(), axis.get_majorticklabels()) if low <= at <= high]
        out += [(k, t.get_text(), t.get_window_extent(renderer)) for t in texts if t.get_visible() and t.get_text()]
        out.append((k, None, ax.get_window_extent(renderer)))      # the axes' own box
    return out


def _overlaps(fig):
    """Pairs of drawn texts (or a text and another axes' box) that overlap: any two of
    different axes, and two tick labels of one axes."""
    items = _texts(fig)
    return [(a[:2], b[:2]) for i, a in enumerate(items) for b in items[i + 1:]
            if (a[0] != b[0] or (a[1] is not None and b[1] is not None)) and a[2].overlaps(b[2])]


@pytest.mark.parametrize("case", ["near-constant", "wide"])
def test_half_diff_labels_do_not_overlap(case, monkeypatch):
    """Issue 62: the half/difference figure's colour-bar labels ran into the next panel.  A
    nearly constant table (a Lambertian measured, two fits a millionth apart) had colour bars
    of a millionth of a decade whose offset text took the panels' width; a wide one spans 1e-12
    to 1e14 (1/sr) with fits 1e6 too dark and 3x too bright."""
    from brdf_fit.report import plots as report_plots
    lambert = 1 / np.pi
    if case == "near-constant":
        measured = lambda m, wi, wo: np.full((len(wi), 3), lambert)                     # noqa: E731
        fitted = lambda r, wi, wo: np.full((len(wi), 3), lambert * (1 + 1e-6 * (r.spec == "ggx+burley")))  # noqa: E731
    else:
        measured = lambda m, wi, wo: 1e-12 * np.exp(60 * wi[:, :1] ** 2) * np.ones(3)   # noqa: E731
        fitted = lambda r, wi, wo: measured(None, wi, wo) * (3.0 if r.spec == "ggx+burley" else 1e-6)  # noqa: E731
    monkeypatch.setattr(report_plots, "_measured", measured)
    monkeypatch.setattr(report_plots, "_fitted", fitted)
    table = types.SimpleNamespace(material=f"a {case} table")
    fig = report_plots.half_diff_images(table, [result("ggx+lambert", TRUTH), result("ggx+burley", OFF)], n=30)
    assert len(fig.axes) == 6 + 5               # six panels (one blank) and five colour bars
    assert _overlaps(fig) == []
