"""Analysis plots of fits against their measurement (matplotlib, Agg backend).

Every function returns a ``matplotlib.figure.Figure`` (nothing is shown or
saved here; ``fig.savefig(path)`` writes it).  Measured values come from
``measured.lookup(wi, wo)`` (the format's own lookup), fitted ones from
``fitting.fit.evaluate_result(result, wi, wo)``.  ``measured`` may be None
wherever only the fitted models are drawn.

- ``polar_lobes``        in-plane lobes (measured vs each model) for several
                         incidence angles, log radius (1/sr);
- ``theta_h_slices``     BRDF Explorer's cartesian view: BRDF over theta_h for
                         fixed theta_d (phi_d = 90 degrees), log axis;
- ``half_diff_images``   theta_h x theta_d images at phi_d = 90 degrees of the
                         measurement, each fit, and log10(fit / measured);
- ``directional_albedo`` E(theta_o) = integral of f cos(theta_i) over wi, per
                         RGB channel, against the view angle;
- ``error_bars``         fit error (M1) per model, grouped by material;
- ``parameter_table``    the fitted parameters as a table figure.

The models of a figure have distinct colours (``model_colors`` of its models, in order:
the figures and the swatches of one report page, drawn from one list, agree), the
measurement is black; those
shared pieces and ``to_png`` / ``save`` are in ``brdf_fit.report.plot_base``.
Importing this module selects no matplotlib backend: the figures never touch
pyplot, and ``fig.savefig`` renders them with Agg.
"""

import typing
from collections.abc import Iterable

import numpy as np
import numpy.typing as npt
from jaxtyping import Float
from matplotlib.figure import Figure

from data_loaders.directions import half_diff_to_std

from .plot_base import (CEILING, CHANNELS, FLOOR, LUMINANCE, MEASURED_COLOR, _channel_name,  # noqa: F401
                        _colour_bar, _evaluate_sets, _image_limits, _fitted, _label, _log_limits, _measured, _results,
                        MAX_LABEL, short_label,
                        _scalar, _title, model_color, model_colors, save, to_png)

if typing.TYPE_CHECKING:
    from data_loaders import MeasuredBRDF

    from fitting.result import FitResult


# --- in-plane polar lobes ---------------------------------------------------------

def in_plane_directions(
    theta_i_deg: float, n: int = 181,
) -> tuple[Float[np.ndarray, "n 3"], Float[np.ndarray, "n 3"], Float[np.ndarray, " n"]]:
    """Light at theta_i in the x-z plane (phi_i = 180 deg); views over the same
    plane, signed theta_o in [-90, 90] degrees (positive: the specular side)."""
    ti = np.radians(theta_i_deg)
    to = np.radians(np.linspace(-89.5, 89.5, n))
    wi = np.tile([-np.sin(ti), 0.0, np.cos(ti)], (n, 1))
    wo = np.stack([np.sin(to), np.zeros(n), np.cos(to)], axis=-1)
    return wi, wo, np.degrees(to)


def polar_lobes(measured: "MeasuredBRDF | None", results: "FitResult | list[FitResult] | tuple[FitResult, ...] | None",
                incidence_deg: Iterable[float] = (0, 30, 45, 60, 75), channel: str = "luminance") -> Figure:
    """In-plane reflection lobes f(theta_i, theta_o) (1/sr, log radius) for
    several incidence angles: measurement in black, each fit in its colour.

    The light comes from the left at theta_i (marked by a grey ray); theta_o
    runs over the plane of incidence, the mirror direction is at +theta_i.
    """
    results = _results(results)
    colours = model_colors(r.spec for r in results)
    n = len(incidence_deg)
    fig = Figure(figsize=(3.2 * n, 2.9), layout="constrained")
    sets = [in_plane_directions(ti) for ti in incidence_deg]
    meas_all, fits_all = _evaluate_sets(measured, results, [(a, b) for a, b, _ in sets], channel)
    curves = [(ti, s[2], meas_all[k] if meas_all else None, [f[k] for f in fits_all])
              for k, (ti, s) in enumerate(zip(incidence_deg, sets))]
    lo, hi = _log_limits([c[2] for c in curves] + [f for c in curves for f in c[3]])
    for k, (ti, to, meas, fits) in enumerate(curves):
        ax = fig.add_subplot(1, n, k + 1, projection="polar")
        ax.set_theta_zero_location("N")
        ax.set_theta_direction(-1)
        ax.set_thetamin(-90)
        ax.set_thetamax(90)
        # log radius drawn as log10(f / lo) on a linear axis (matplotlib's
        # polar log scale renders several times slower), labelled in 1/sr
        rad = lambda v: np.log10(np.clip(v, lo, None) / lo)   # noqa: E731
        ax.set_rlim(0.0, rad(hi))
        decades = np.arange(np.ceil(np.log10(lo)), np.floor(np.log10(hi)) + 1)
        decades = decades[::max(1, int(np.ceil(len(decades) / 4)))]
        ax.set_rticks(rad(10.0 ** decades), [f"{10.0 ** d:g}" for d in decades])
        th = np.radians(to)
        if meas is not None:
            ax.plot(th, rad(meas), color=MEASURED_COLOR, lw=1.8, label="measured")
        for r, f in zip(results, fits):
            ax.plot(th, rad(f), color=colours[r.spec], lw=1.2, label=_label(r))
        ax.plot([np.radians(-ti)] * 2, [0.0, rad(hi)], color="0.6", lw=0.8, ls=":")
        ax.set_title(f"theta_i = {ti:g} deg", fontsize=9)
        ax.tick_params(labelsize=7)
        if k == 0:
            ax.set_ylabel(f"BRDF {_channel_name(channel)} (1/sr, log)", fontsize=8, labelpad=18)
    handles, labels = fig.axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 5), fontsize=8)
    fig.suptitle(f"{_title(measured, results)}: in-plane lobes (theta_o in degrees, "
                 f"radius = BRDF in 1/sr, log)", fontsize=10, parse_math=False)
    return fig


# --- BRDF Explorer's theta_h slices ---------------------------------------------------

def half_diff_directions(
    theta_h_deg: Float[npt.ArrayLike, "*#batch"], theta_d_deg: Float[npt.ArrayLike, "*#batch"],
    phi_d_deg: Float[npt.ArrayLike, "*#batch"] = 90.0,
) -> tuple[Float[np.ndarray, "n 3"], Float[np.ndarray, "n 3"]]:
    """(wi, wo) of half/difference angles in degrees (phi_h = 0), broadcast."""
    th, td, pd = np.broadcast_arrays(*(np.radians(np.asarray(a, dtype=np.float64))
                                       for a in (theta_h_deg, theta_d_deg, phi_d_deg)))
    wi, wo = half_diff_to_std(th.ravel(), np.zeros(th.size), td.ravel(), pd.ravel())
    return wi, wo


def theta_h_slices(measured: "MeasuredBRDF | None",
                   results: "FitResult | list[FitResult] | tuple[FitResult, ...] | None",
                   theta_d_deg: Iterable[float] = (2, 20, 45, 70), phi_d_deg: float = 90.0, channel: str = "luminance",
                   n: int = 200) -> Figure:
    """Cartesian slices f(theta_h) at fixed theta_d (BRDF Explorer): log BRDF
    axis (1/sr), theta_h in degrees on a square-root axis like MERL's grid
    (the specular peak is at theta_h = 0; small theta_d is the retro-reflection
    direction)."""
    results = _results(results)
    colours = model_colors(r.spec for r in results)
    th = (np.linspace(0.0, 1.0, n) ** 2) * 89.5
    fig = Figure(figsize=(3.3 * len(theta_d_deg), 3.4), layout="constrained")
    sets = [half_diff_directions(th, td, phi_d_deg) for td in theta_d_deg]
    meas_all, fits_all = _evaluate_sets(measured, results, sets, channel)
    data = []
    for k, (td, (wi, wo)) in enumerate(zip(theta_d_deg, sets)):
        valid = (wi[:, 2] > 1e-6) & (wo[:, 2] > 1e-6)
        # held at CEILING (a table in wrong units): matplotlib's log axis overflows beyond ~1e300
        meas = np.where(valid, np.minimum(meas_all[k], CEILING), np.nan) if meas_all else None
        data.append((td, meas, [np.where(valid, np.minimum(f[k], CEILING), np.nan) for f in fits_all]))
    lo, hi = _log_limits([d[1] for d in data] + [f for d in data for f in d[2]])
    axes = fig.subplots(1, len(theta_d_deg), sharey=True, squeeze=False)[0]
    for ax, (td, meas, fits) in zip(axes, data):
        if meas is not None:
            ax.plot(th, meas, color=MEASURED_COLOR, lw=1.8, label="measured")
        for r, f in zip(results, fits):
            ax.plot(th, f, color=colours[r.spec], lw=1.2, label=_label(r))
        ax.set_yscale("log")
        ax.set_ylim(lo, hi)
        ax.set_xscale("function", functions=(lambda x: np.sqrt(np.clip(x, 0, None)), lambda x: x ** 2))
        ax.set_xlim(0, 90)
        ax.set_xticks([0, 1, 5, 10, 20, 40, 60, 90])
        ax.set_xlabel("theta_h (degrees, sqrt axis)")
        ax.set_title(f"theta_d = {td:g} deg, phi_d = {phi_d_deg:g} deg", fontsize=9)
        ax.grid(True, which="both", alpha=0.25)
    axes[0].set_ylabel(f"BRDF {_channel_name(channel)} (1/sr)")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 5), fontsize=8)
    fig.suptitle(f"{_title(measured, results)}: slices over theta_h", fontsize=10, parse_math=False)
    return fig


# --- half/difference images -------------------------------------------------------------

def half_diff_images(measured: "MeasuredBRDF | None",
                     results: "FitResult | list[FitResult] | tuple[FitResult, ...] | None", phi_d_deg: float = 90.0,
                     n: int = 90, channel: str = "luminance") -> Figure:
    """Images over (theta_h, theta_d) at phi_d = 90 degrees: log10 of the
    measurement and of each fit (1/sr), and the log error log10(fit / measured)
    (0 = exact, +1 = ten times too bright).  One row per fitted model; cells
    with a direction below the horizon are blank."""
    results = _results(results)
    th = ((np.arange(n) + 0.5) / n) ** 2 * 90.0          # MERL's sqrt spacing
    td = (np.arange(n) + 0.5) / n * 90.0
    TH, TD = np.meshgrid(th, td, indexing="xy")           # rows: theta_d, columns: theta_h
    wi, wo = half_diff_directions(TH, TD, phi_d_deg)
    valid = ((wi[:, 2] > 1e-6) & (wo[:, 2] > 1e-6)).reshape(TH.shape)

    def img(values):
        v = _scalar(values, channel).reshape(TH.shape)
        return np.where(valid & (v > 0), np.log10(np.maximum(v, 1e-300)), np.nan)
    meas = img(_measured(measured, wi, wo)) if measured is not None else None
    fits = [img(_fitted(r, wi, wo)) for r in results]
    stack = [a for a in [meas] + fits if a is not None]
    finite = np.concatenate([a[np.isfinite(a)] for a in stack]) if stack else np.zeros(1)
    vmin, vmax = _image_limits(finite)
    rows = max(1, len(results))
    cols = 3 if measured is not None else 1
    errors = [f - meas for f in fits] if measured is not None else []
    finite_err = np.concatenate([np.abs(e[np.isfinite(e)]) for e in errors]) if errors else np.zeros(0)
    lim = max(0.05, float(np.percentile(finite_err, 99))) if finite_err.size else 1.0
    fig = Figure(figsize=(3.6 * cols, 3.0 * rows + 0.6), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False)
    # the x axis shows sqrt(theta_h) spacing: label it with theta_h values
    extent = (0, 1, 0, 90)
    ticks = [0, 1, 5, 10, 20, 45, 90]

    def style(ax, title):
        ax.set_title(title, fontsize=9)
        ax.set_xticks([np.sqrt(t / 90.0) for t in ticks], [str(t) for t in ticks])
        ax.set_xlabel("theta_h (degrees)")
        ax.set_ylabel("theta_d (degrees)")

    for row in range(rows):
        k = 0
        if measured is not None and row > 0:
            axes[row, 0].axis("off")           # the measurement is drawn once, top left
            k = 1
        elif measured is not None:
            im = axes[row, 0].imshow(meas, origin="lower", extent=extent, aspect="auto",
                                     vmin=vmin, vmax=vmax, cmap="magma")
            style(axes[row, 0], "measured")
            _colour_bar(fig, im, axes[row, 0], "log10 BRDF (1/sr)")
            k = 1
        if results:
            r = results[row]
            im = axes[row, k].imshow(fits[row], origin="lower", extent=extent, aspect="auto",
                                     vmin=vmin, vmax=vmax, cmap="magma")
            style(axes[row, k], r.spec)
            _colour_bar(fig, im, axes[row, k], "log10 BRDF (1/sr)")
            if measured is not None:
                im = axes[row, k + 1].imshow(errors[row], origin="lower", extent=extent, aspect="auto",
                                             vmin=-lim, vmax=lim, cmap="RdBu_r")
                style(axes[row, k + 1], f"log error, {r.spec}")
                _colour_bar(fig, im, axes[row, k + 1], "log10(fitted / measured)")
    fig.suptitle(f"{_title(measured, results)}: half/difference images at phi_d = {phi_d_deg:g} deg "
                 f"({_channel_name(channel)})", fontsize=10, parse_math=False)
    return fig


# --- directional albedo ---------------------------------------------------------------------

def albedo_directions(
    theta_o_deg: Float[npt.ArrayLike, " v"], n_theta: int = 64, n_phi: int = 64,
) -> tuple[Float[np.ndarray, "v m 3"], Float[np.ndarray, "v m 3"], Float[np.ndarray, "v m"]]:
    """Quadrature over wi for each view angle, in half-vector space with MERL's
    sqrt spacing in theta_h (resolves a sharp specular peak and the diffuse
    part alike).  Returns wi, wo (V, M, 3) and weights (V, M) such that
    E(theta_o) ~ sum_j f(wi_j, wo) cos(theta_i_j) w_j (the weight includes
    d omega_i = 4 |wo . h| d omega_h)."""
    u = (np.arange(n_theta) + 0.5) / n_theta
    th = u * u * (np.pi / 2)
    dth = 2 * u * (np.pi / 2) / n_theta
    ph = (np.arange(n_phi) + 0.5) / n_phi * 2 * np.pi
    TH, PH = np.meshgrid(th, ph, indexing="ij")
    h = np.stack([np.sin(TH) * np.cos(PH), np.sin(TH) * np.sin(PH), np.cos(TH)], axis=-1).reshape(-1, 3)
    dwh = (np.sin(TH) * dth[:, None] * (2 * np.pi / n_phi)).ravel()
    to = np.radians(np.asarray(theta_o_deg, dtype=np.float64))
    wo = np.stack([np.sin(to), np.zeros_like(to), np.cos(to)], axis=-1)       # (V, 3)
    wo_b = np.broadcast_to(wo[:, None, :], (to.size, h.shape[0], 3))
    oh = np.sum(wo_b * h[None], axis=-1)
    wi = 2 * oh[..., None] * h[None] - wo_b
    weight = np.where((oh > 0) & (wi[..., 2] > 0), 4 * oh * dwh[None] * np.clip(wi[..., 2], 0, None), 0.0)
    return wi, wo_b, weight


def directional_albedo_values(measured_or_result: "MeasuredBRDF | FitResult", theta_o_deg: Float[npt.ArrayLike, " v"],
                              n_theta: int = 64, n_phi: int = 64) -> Float[np.ndarray, "v 3"]:
    """E(theta_o) per RGB channel, (V, 3), of a MeasuredBRDF or a FitResult."""
    wi, wo, w = albedo_directions(theta_o_deg, n_theta, n_phi)
    shape = wi.shape[:2]
    a, b = wi.reshape(-1, 3), wo.reshape(-1, 3)
    keep = w.ravel() > 0
    f = np.zeros((a.shape[0], 3))
    if hasattr(measured_or_result, "lookup"):
        f[keep] = _measured(measured_or_result, a[keep], b[keep])
    else:
        f[keep] = _fitted(measured_or_result, a[keep], b[keep])
    return np.einsum("vmc,vm->vc", f.reshape(shape + (3,)), w)


def directional_albedo(measured: "MeasuredBRDF | None",
                       results: "FitResult | list[FitResult] | tuple[FitResult, ...] | None",
                       theta_o_deg: Float[npt.ArrayLike, " v"] | None = None) -> Figure:
    """Directional albedo E(theta_o) = integral of f cos(theta_i) d omega_i over
    the view angle, one panel per RGB channel (unitless; 1 = all light
    reflected).  Energy gains or losses of the models (Burley brightening,
    missing multiple scattering at high roughness) show here."""
    results = _results(results)
    colours = model_colors(r.spec for r in results)
    theta_o_deg = np.arange(0, 86, 5.0) if theta_o_deg is None else np.asarray(theta_o_deg, float)
    meas = directional_albedo_values(measured, theta_o_deg) if measured is not None else None
    meas = np.minimum(meas, CEILING) if meas is not None else None     # a log axis overflows beyond ~1e300
    fits = [np.minimum(directional_albedo_values(r, theta_o_deg), CEILING) for r in results]
    fig = Figure(figsize=(10, 3.4), layout="constrained")
    axes = fig.subplots(1, 3, sharey=True)
    values = [v for v in [meas] + fits if v is not None]
    span = max(np.max(v) for v in values) / max(min(np.min(v[v > 0]) if np.any(v > 0) else 1 for v in values),
                                                 1e-12)
    for c, ax in enumerate(axes):
        if meas is not None:
            ax.plot(theta_o_deg, meas[:, c], color=MEASURED_COLOR, lw=1.8, marker="o", ms=3, label="measured")
        for r, e in zip(results, fits):
            ax.plot(theta_o_deg, e[:, c], color=colours[r.spec], lw=1.2, label=_label(r))
        ax.set_title(f"channel {CHANNELS[c]}", fontsize=9)
        ax.set_xlabel("view angle theta_o (degrees)")
        ax.set_xlim(0, 90)
        if span > 30:
            ax.set_yscale("log")
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("directional albedo E (unitless)")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 5), fontsize=8)
    fig.suptitle(f"{_title(measured, results)}: directional albedo "
                 f"(integral of BRDF x cos theta_i over the light hemisphere)", fontsize=10,
                 parse_math=False)
    return fig


# --- error bars and parameter table ----------------------------------------------------------

def error_bars(results: "FitResult | list[FitResult] | tuple[FitResult, ...] | None", metric: str = "m1",
               title: str | None = None) -> Figure:
    """Grouped bars: the fit error (M1 by default) of each model, per material.
    Log scale when the errors span more than a decade."""
    results = _results(results)
    materials = list(dict.fromkeys(r.material for r in results))
    models = list(dict.fromkeys(r.spec for r in results))
    colours = model_colors(models)
    table = {(r.material, r.spec): float(r.errors[metric]) for r in results}
    width = 0.8 / max(len(models), 1)
    fig = Figure(figsize=(max(5.0, 1.0 + 0.25 * len(models) * len(materials) + 0.8 * len(materials)), 4.0),
                 layout="constrained")
    ax = fig.subplots()
    x = np.arange(len(materials))
    for k, model in enumerate(models):
        vals = [table.get((m, model), np.nan) for m in materials]
        ax.bar(x + (k - (len(models) - 1) / 2) * width, vals, width, color=colours[model], label=model)
    vals = np.array([v for v in table.values() if np.isfinite(v) and v > 0])
    if vals.size and vals.max() / vals.min() > 10:
        ax.set_yscale("log")
    many = len(materials) > 4
    ax.set_xticks(x, [short_label(m, MAX_LABEL // 2) for m in materials], rotation=30 if many else 0,
                  ha="right" if many else "center", parse_math=False)
    ax.set_ylabel(f"{metric.upper()} (lower is better)" if metric == "m1" else metric)
    ax.grid(True, axis="y", which="both", alpha=0.3)
    ax.legend(fontsize=8, ncol=2 if len(models) > 5 else 1)
    ax.set_title(short_label(title, 2 * MAX_LABEL) if title else f"fit error ({metric}) per material and model",
                 fontsize=10, parse_math=False)
    return fig


def _format(value):
    if isinstance(value, (list, tuple)):
        return "(" + ", ".join(f"{v:.3g}" for v in value) + ")"
    return f"{value:.4g}"


def parameter_rows(
    results: "FitResult | list[FitResult] | tuple[FitResult, ...] | None",
) -> tuple[list[str], list[list[str]]]:
    """(header, rows) of the parameter table: model, M1, then the union of
    parameter names (blank where a model has no such parameter)."""
    results = _results(results)
    names = list(dict.fromkeys(k for r in results for k in r.parameters))
    header = ["material", "model", "M1"] + names
    rows = [[r.material, r.spec, f"{r.errors['m1']:.5g}"]
            + [_format(r.parameters[k]) if k in r.parameters else "" for k in names] for r in results]
    return header, rows


def parameter_table(results: "FitResult | list[FitResult] | tuple[FitResult, ...] | None") -> Figure:
    """The fitted parameters of each result as a table figure (RGB as (r, g, b);
    roughness perceptual, alpha = roughness^2)."""
    header, rows = parameter_rows(results)
    rows = [[short_label(row[0]), *row[1:]] for row in rows]
    widths = [max(len(str(c)) for c in col) for col in zip(header, *rows)] if rows else [8] * len(header)
    fig = Figure(figsize=(min(24.0, 1.0 + 0.085 * sum(widths) + 0.3 * len(header)), 0.6 + 0.3 * (len(rows) + 1)),
                 layout="constrained")
    ax = fig.subplots()
    ax.axis("off")
    if rows:
        tab = ax.table(cellText=rows, colLabels=header, loc="center", cellLoc="left",
                       colWidths=[w / max(sum(widths), 1) for w in widths])
        tab.auto_set_font_size(False)
        tab.set_fontsize(8)
        tab.scale(1.0, 1.3)
        colours = model_colors(row[1] for row in rows)
        for i, row in enumerate(rows):
            tab[i + 1, 1].set_text_props(color=colours[row[1]], fontweight="bold")
        for cell in tab.get_celld().values():       # names are data, not mathtext
            cell.get_text().set_parse_math(False)
    ax.set_title("fitted parameters", fontsize=10)
    return fig


__all__ = ["model_color", "model_colors", "polar_lobes", "theta_h_slices", "half_diff_images", "directional_albedo",
           "directional_albedo_values", "error_bars", "parameter_table", "parameter_rows",
           "in_plane_directions", "half_diff_directions", "albedo_directions", "to_png", "save"]
