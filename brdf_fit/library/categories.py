"""A material's category, for the analysis page's per-category study and the benchmarks.

Ngan et al. 2005 and Matusik et al. 2003 group MERL's 100 materials by what they
are (metals, paints, plastics, fabrics, ...), and a model's strengths differ
between the groups: a category is where "which model reproduces it" is asked.
The results carry no category, so it is read from the material's name with
``CATEGORIES``, a table of MERL name fragments.  A name the table does not know
falls back to the folder its measured file sat in, when the library's files sit
in more than one folder (a user who sorted a database into ``metals/``,
``fabrics/`` said what the categories are); otherwise it is "other".
"""

import pathlib
from collections.abc import Iterable, Mapping

OTHER = "other"

# MERL's categories by name (Ngan et al. 2005 and Matusik et al. 2003 group them so); the
# first match wins: "gold-metallic-paint" is a metallic paint before "gold" makes it a
# metal, "natural-209" a wood by "-2" before "paint" is looked for.
CATEGORIES = (("metallic paint", ("metallic-paint", "pearl-paint", "color-changing", "two-layer", "gold-paint",
                                   "silver-paint")),
              ("stone", ("marble", "jasper", "obsidian", "aventurnine", "alumina", "silicon", "granite")),
              ("metal", ("bronze", "chrome", "steel", "ss440", "nickel", "brass", "aluminium", "silver", "gold",
                         "tungsten", "hematite")),
              ("phenolic", ("phenolic",)), ("fabric", ("fabric", "felt", "nylon", "polyurethane-foam")),
              ("wood", ("-2", "oak", "pine", "maple", "fruitwood", "cherry", "natural")),
              ("rubber", ("rubber", "latex", "neoprene")),
              ("paint", ("paint", "bball")),
              ("plastic", ("plastic", "acrylic", "delrin", "pvc", "polyethylene", "teflon", "resin")))


def category(material: str) -> str:
    """The MERL category of a material's name (CATEGORIES; OTHER for none)."""
    return next((c for c, keys in CATEGORIES if any(k in material for k in keys)), OTHER)


def _folder(results: Iterable) -> str | None:
    """The name of the folder a material's measured file sat in (its first result's
    provenance ``file``), or None when no result records a file."""
    for r in results:
        path = (getattr(r, "provenance", None) or {}).get("file")
        if path:
            return pathlib.PurePath(str(path)).parent.name or None
    return None


def material_categories(groups: Mapping[str, Iterable]) -> dict[str, str]:
    """material -> category for a library's ``groups`` (material -> FitResults): the
    name's MERL category; for a name no fragment matches, its file's folder when the
    materials' files sit in more than one folder, else OTHER."""
    folders = {m: _folder(rs) for m, rs in groups.items()}
    several = len({f for f in folders.values() if f}) > 1
    out = {}
    for material in groups:
        merl = category(material)
        out[material] = folders[material] if merl == OTHER and several and folders[material] else merl
    return out


__all__ = ["CATEGORIES", "OTHER", "category", "material_categories"]
