"""A FitResult in a notebook: its model, parameters, errors and provenance as HTML.

Engine-only (the models' schema and the result's own fields): parameters
with their ranges, those within 1 % of an end marked ``*`` (``at_bounds``),
M1 and the image error with their per-channel values, the loss, the errors
of the exported material, the optimizer's report and where the data came
from.  The application adds the preview renderer's measured | fitted |
difference spheres through ``extra`` (brdf_fit.notebook); without it one
line says how to get them.
"""

import html
import typing

from brdf.model import parameter_schema, parse_model



class _Result(typing.Protocol):
    """What the display reads of a fitting.result.FitResult (not imported: it imports this module)."""
    spec: str
    parameters: dict
    errors: dict
    optimizer: dict
    provenance: dict
    toolkit_version: str
    created: str

    @property
    def material(self) -> str: ...

    def at_bounds(self) -> dict[str, str]: ...

SPHERES_HINT = ("measured | fitted | difference spheres: <code>%load_ext brdf_fit.notebook</code> "
                "(the preview renderer, docs/notebooks.md)")


def _num(x) -> str:
    return f"{x:.5g}" if isinstance(x, (int, float)) and not isinstance(x, bool) else html.escape(str(x))


def _value(v) -> str:
    return "[" + ", ".join(_num(x) for x in v) + "]" if isinstance(v, (list, tuple)) else _num(v)


def _rows(rows) -> str:
    return "".join(f"<tr><th style=\"text-align:left\">{k}</th>"
                   + "".join(f"<td style=\"text-align:left\">{c}</td>" for c in cells) + "</tr>"
                   for k, *cells in rows)


def parameter_rows(result: "_Result") -> list[tuple[str, str, str, str]]:
    """[(name, value, range and unit, flag)]; flag '* at the lower / upper bound' or ''."""
    flags = result.at_bounds()
    out = []
    for p in parameter_schema(parse_model(result.spec)):
        if p.name not in result.parameters:
            continue
        flag = f"* at the {flags[p.name]} bound" if p.name in flags else ""
        name = html.escape(p.name) + ("*" if flag else "")
        span = (f"[{p.lower:.4g}, {p.upper:.4g}]" + (f" {html.escape(p.unit)}" if p.unit else "")
                + (" (log scale)" if p.scale == "log" else ""))
        out.append((f"<span title=\"{html.escape(p.description)}\">{name}</span>",
                    _value(result.parameters[p.name]), span, flag))
    return out


def error_rows(result: "_Result") -> list[tuple[str, str]]:
    """[(label, value)] of the errors the result holds, M1 first."""
    e = result.errors or {}
    out = []
    for label, key, channels in (("M1", "m1", "m1_per_channel"), ("image error", "image", "image_per_channel"),
                                 (f"loss ({html.escape(str(e.get('loss_name', '?')))})", "loss",
                                  "loss_per_channel")):
        if key in e:
            per = f" (R, G, B {_value(e[channels])})" if channels in e else ""
            out.append((label, _num(e[key]) + per))
    if "exported_model" in e or "exported_m1" in e:
        model = html.escape(str(e.get("exported_model", "the exported material")))
        for label, key in (("M1", "exported_m1"), ("image error", "exported_image")):
            if key in e:
                out.append((f"exported {label}", f"{_num(e[key])} ({model})"))
    return out


def result_html(result: "_Result", extra: str | None = None) -> str:
    """The result as HTML; ``extra`` (HTML: the spheres, or why they are absent) goes
    under the title, else a one-line hint at the application's display hook."""
    o, p = result.optimizer or {}, result.provenance or {}
    e = html.escape
    params = _rows(parameter_rows(result))
    errors = _rows(error_rows(result))
    run = [(k, _num(o[k])) for k in ("name", "seconds", "iterations", "converged", "starts", "samples",
                                     "max_theta") if k in o]
    where = [(k, e(str(p[k]))) for k in ("material", "file", "format", "sha256") if p.get(k)]
    where += [("created", e(result.created)), ("toolkit", e(result.toolkit_version))]
    note = extra if extra is not None else f"<p style=\"font-size:smaller\">{SPHERES_HINT}</p>"
    marked = any(flag for *_, flag in parameter_rows(result))
    legend = ("<p style=\"font-size:smaller\">* within 1 % of an end of its range (of log x on a log "
              "scale): the data may want a value the model cannot give</p>") if marked else ""
    return (f"<div class=\"brdf-fit-result\"><p><b>FitResult</b> <code>{e(result.spec)}</code> on "
            f"<b>{e(result.material)}</b></p>{note}"
            "<div style=\"display:flex;gap:2em;flex-wrap:wrap;align-items:flex-start\">"
            f"<table><caption style=\"text-align:left\">parameters</caption>{params}</table>"
            f"<table><caption style=\"text-align:left\">errors</caption>{errors}</table>"
            f"<table><caption style=\"text-align:left\">fit</caption>{_rows(run + where)}</table>"
            f"</div>{legend}</div>")
