"""The library's front page, ``LIB/index.html``: one card per material and one sortable,
filterable table, both from the same entries.

A card shows the material's measured and fitted spheres (brdf_fit.library.thumbnails:
the image error's scene at the viewer's exposure), its best model, M1 and image
error and its exported glTF material's; it links to the material's page (the
report's page, with the three.js viewer: the only 3D viewer, made when that page
is opened).  The table holds the same numbers; clicking a header sorts cards and
rows alike, and the filters (name, best model, largest image error) hide both.
The page is static HTML with a few lines of inline script: it works from
``file://``, offline, and stays light (two small PNGs a material, no viewer).
"""

import dataclasses
import html

from brdf import __version__
from brdf_fit.report.html import SCROLL_CSS, scrolling
from fitting.ranking import IMAGE_TERM, IMAGE_WEIGHT

NUMBER_DIGITS = 4            # significant digits of the errors shown (the data-* attributes keep all)
SHOWN_NAME = 80              # characters of a name on a card or in the table (the whole name: its title)


@dataclasses.dataclass(frozen=True)
class Entry:
    """One material of the library: its best result's numbers and its files (relative paths)."""

    material: str
    model: str
    m1: float
    image: float | None
    exported_m1: float | None
    exported_image: float | None
    models: int                  # results fitted for the material
    page: str                    # its report page
    measured_png: str | None
    fitted_png: str | None
    glb: str | None
    shipped: str = ""            # the shipped fit's model
    export_first: bool = False   # the shipped material is the glTF family's own fit (not a converted one)
    margin: float | None = None  # the other path's best exported ranking error over the shipped one's


def shipped_text(entry: Entry) -> str:
    """Where the shipped glTF material came from, in plain words, and how much worse the other
    way's best was (the card's line and the table's cell; the precise terms: ``shipped_title``)."""
    way, other = (("fitted directly", "a converted fit") if entry.export_first else
                  ("converted from another model", "fitted directly"))
    return way + (f" ({other}: {entry.margin:.2f}\u00d7 the error)" if entry.margin is not None else "")


def shipped_title(entry: Entry) -> str:
    """``shipped_text`` in the terms of docs/library.md (the tooltip): the path, the shipped
    fit's model, and the other path's best exported ranking error over the shipped one's."""
    path, other = ("export-first", "converted") if entry.export_first else ("converted", "export-first")
    text = f"{path}: {entry.shipped}"
    if entry.margin is not None:
        text += (f"; the best {other} fit's ranking error as glTF (M1 + {IMAGE_WEIGHT:g} x {IMAGE_TERM} of the "
                 f"exported material) is {entry.margin:.3f}x the shipped one's")
    return text


def number(x) -> str:
    """An error as the pages show it (NUMBER_DIGITS significant digits; blank for none)."""
    return "" if x is None else f"{float(x):.{NUMBER_DIGITS}g}"


def _e(x):
    return html.escape(str(x), quote=True)


def shown_name(name: str, limit: int = SHOWN_NAME) -> str:
    """A material name as a card shows it: whitespace runs as one space, at most ``limit``
    characters, cut in the middle so that both ends show (two long names that differ at
    the end, a told-apart name's ``(lab1)``)."""
    text = " ".join(str(name).split())
    if len(text) <= limit:
        return text
    head = (limit - 1) // 2
    return text[:head] + "\u2026" + text[len(text) - (limit - 1 - head):]


def _name(entry):
    """The name as shown, with the whole name in a tooltip."""
    return f'<span title="{_e(entry.material)}">{_e(shown_name(entry.material))}</span>'


def _data(entry):
    """The data-* attributes sorting and filtering read (full precision)."""
    values = {"id": entry.page, "name": entry.material.lower(), "model": entry.model, "m1": repr(float(entry.m1)),
              "image": "" if entry.image is None else repr(float(entry.image)),
              "exported-m1": "" if entry.exported_m1 is None else repr(float(entry.exported_m1)),
              "exported-image": "" if entry.exported_image is None else repr(float(entry.exported_image)),
              "shipped": "export-first" if entry.export_first else "converted",
              "margin": "" if entry.margin is None else repr(float(entry.margin))}
    return " ".join(f'data-{k}="{_e(v)}"' for k, v in values.items())


def _picture(src, alt):
    return f'<img src="{_e(src)}" alt="{_e(alt)}" width="96" height="96">' if src else \
        '<span class="none">no picture</span>'


def _card(entry):
    glb = f' · <a href="{_e(entry.glb)}" download>.glb</a>' if entry.glb else ""
    return (f'<div class="card" {_data(entry)}><a class="open" href="{_e(entry.page)}">'
            f'{_picture(entry.measured_png, "measured")}{_picture(entry.fitted_png, "fitted")}'
            f'<b class="name">{_name(entry)}</b></a>'
            f'<span class="model">{_e(entry.model)}</span>'
            f'<span class="errors">M1 <span class="m1">{number(entry.m1)}</span> · image '
            f'<span class="image">{number(entry.image)}</span></span>'
            f'<span class="errors">glTF M1 <span class="exported-m1">{number(entry.exported_m1)}</span> · '
            f'image <span class="exported-image">{number(entry.exported_image)}</span>{glb}</span>'
            f'<span class="shipped" title="{_e(shipped_title(entry))}">glTF material: {_e(shipped_text(entry))}</span>'
            '</div>')


COLUMNS = (("name", "material"), ("model", "best model"), ("m1", "M1"), ("image", "image error"),
           ("exported-m1", "glTF M1"), ("exported-image", "glTF image error"), ("shipped", "glTF material"))
# The precise terms of each column, in its header's tooltip (docs/metrics.md, docs/library.md).
COLUMN_TERMS = {
    "model": f"the fit of lowest ranking error, M1 + {IMAGE_WEIGHT:g} x {IMAGE_TERM} (fitting.ranking.ranked)",
    "m1": "the table error: weighted RMS of log(1 + BRDF x cos theta_i) differences, mean over RGB",
    "image": "RMS over the lit sphere of the per-pixel Delta E_ITP between the tone-mapped measured and fitted "
             "images at the viewer's exposure, in units of 325 Delta E_ITP",
    "exported-m1": "M1 of the glTF material written (gltf/, materials.glb)",
    "exported-image": "the image error of the glTF material written",
    "shipped": "export-first (the glTF family fitted to the measurement) or converted (another model's fit "
               "converted to glTF), and the other path's best ranking error as glTF over the shipped one's",
}


def _row(entry):
    cells = [f'<td class="name"><a href="{_e(entry.page)}">{_name(entry)}</a></td>',
             f'<td class="model">{_e(entry.model)}</td>']
    for key, value in (("m1", entry.m1), ("image", entry.image), ("exported-m1", entry.exported_m1),
                       ("exported-image", entry.exported_image)):
        cells.append(f'<td class="num {key}">{number(value)}</td>')
    cells.append(f'<td class="shipped" title="{_e(shipped_title(entry))}">{_e(shipped_text(entry))}</td>')
    return f'<tr {_data(entry)}>{"".join(cells)}</tr>'


_CSS = """
body { font-family: system-ui, sans-serif; margin: 1.5em auto; max-width: 1400px; padding: 0 1em; color: #222; }
nav a { margin-right: 1em; } .controls { margin: 1em 0; } .controls label { margin-right: 1.2em; }
#cards { display: flex; flex-wrap: wrap; gap: 0.8em; }
.card { width: 200px; border: 1px solid #ddd; border-radius: 6px; padding: 0.4em; font-size: 0.85em; }
.card a.open { text-decoration: none; color: inherit; } .card img { border-radius: 4px; }
.card .name { display: block; margin: 0.2em 0; overflow-wrap: anywhere; } .card > span { display: block; color: #444; }
.none { display: inline-block; width: 96px; color: #999; }
table { border-collapse: collapse; font-size: 0.9em; margin-top: 1.5em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; } th { background: #f3f3f3; cursor: pointer; }
td.num { text-align: right; font-variant-numeric: tabular-nums; } .hidden { display: none !important; }
.meta { color: #555; font-size: 0.9em; } pre { background: #f6f6f6; padding: 0.6em; overflow-x: auto; }
""" + SCROLL_CSS

# Sorting and filtering: cards and rows carry the same data-* attributes and move together.
_SCRIPT = """
(function () {
  const cards = document.getElementById('cards'), body = document.querySelector('#table tbody');
  const byName = {};
  for (const c of cards.children) byName[c.dataset.id] = c;
  let key = null, ascending = true;
  function value(el, k) {
    const v = el.dataset[k.replace(/-(.)/g, (m, c) => c.toUpperCase())];
    if (k === 'name' || k === 'model' || k === 'shipped') return v;
    return v === '' ? Infinity : parseFloat(v);
  }
  function sort(k) {
    ascending = key === k ? !ascending : true; key = k;
    const rows = Array.from(body.children);
    rows.sort((a, b) => { const x = value(a, k), y = value(b, k);
      return (x < y ? -1 : x > y ? 1 : 0) * (ascending ? 1 : -1); });
    for (const r of rows) { body.appendChild(r); cards.appendChild(byName[r.dataset.id]); }
    document.querySelectorAll('th').forEach(th => th.dataset.sorted =
      th.dataset.key === k ? (ascending ? 'ascending' : 'descending') : '');
  }
  function filter() {
    const text = document.getElementById('filter-name').value.toLowerCase();
    const model = document.getElementById('filter-model').value;
    const limit = parseFloat(document.getElementById('filter-image').value);
    let shown = 0;
    for (const r of body.children) {
      const image = value(r, 'image');
      const keep = r.dataset.name.includes(text) && (!model || r.dataset.model === model)
        && (isNaN(limit) || image <= limit);
      r.classList.toggle('hidden', !keep); byName[r.dataset.id].classList.toggle('hidden', !keep);
      shown += keep ? 1 : 0;
    }
    document.getElementById('shown').textContent = shown;
  }
  document.querySelectorAll('th').forEach(th => th.addEventListener('click', () => sort(th.dataset.key)));
  for (const id of ['filter-name', 'filter-model', 'filter-image'])
    document.getElementById(id).addEventListener('input', filter);
  window.librarySort = sort; window.libraryFilter = filter;
})();
"""


def gallery_page(entries: list[Entry], title: str, command_line: str, extra_links=()) -> str:
    """The HTML of ``LIB/index.html`` for ``entries`` (in the order given: best M1 first by default)."""
    models = sorted({e.model for e in entries})
    options = "".join(f'<option value="{_e(m)}">{_e(m)}</option>' for m in models)
    links = "".join(f'<a href="{_e(href)}">{_e(text)}</a>' for href, text in extra_links)
    head = "".join(f'<th data-key="{key}"' + (f' title="{_e(COLUMN_TERMS[key])}"' if key in COLUMN_TERMS else "")
                   + f">{_e(label)}</th>" for key, label in COLUMNS)
    body = (f"<h1>{_e(title)}</h1><nav>{links}</nav>"
            f'<p class="meta"><span id="shown">{len(entries)}</span> of {len(entries)} materials shown. '
            "Spheres: measured (left) and the best model (right), lit by four lights, at the brightness a "
            "viewer would set for the measurement. M1: how far the model is from the measured numbers; image "
            "error: how different the two spheres look (both: 0 is identical, lower is better; docs/metrics.md). "
            "glTF material: the one in gltf/ and materials.glb, either fitted directly as a glTF material or "
            "converted from another model's fit, whichever looks closest to the measurement (M1 + "
            f"{IMAGE_WEIGHT:g} &times; {IMAGE_TERM} of the written material); &ldquo;the error&rdquo; beside it "
            "is the other way's best, as a multiple of the shipped one's (hover for the precise terms). "
            "Click a card for its page and 3D viewer.</p>"
            '<div class="controls"><label>name <input id="filter-name" type="search"></label>'
            f'<label>best model <select id="filter-model"><option value="">any</option>{options}</select></label>'
            '<label>image error at most <input id="filter-image" type="number" step="any" min="0"></label></div>'
            f'<div id="cards">{"".join(_card(e) for e in entries)}</div>'
            f'<table id="table"><thead><tr>{head}</tr></thead>'
            f'<tbody>{"".join(_row(e) for e in entries)}</tbody></table>'
            + (f"<h2>Command</h2><pre>{_e(command_line)}</pre>" if command_line else "")
            + f"<p class=\"meta\">brdf-fit {_e(__version__)}</p>"
            f"<script>{_SCRIPT}</script>")
    return ("<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{_e(title)}</title><style>{_CSS}</style></head>\n<body>\n{scrolling(body)}\n</body></html>\n")
