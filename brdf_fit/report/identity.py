"""Which results are one material, the name shown for it, and its files' stem (the report's and the library's).

A material's identity is its measurement, not its name (docs/DESIGN): the sha256 of
the input file, which every result records (``provenance.sha256``).  Results without
one (written by hand, or by an old toolkit) fall back to their material name.  So
two files whose names collide -- ``lab1/sample.csv`` and ``lab2/sample.csv``, two
files with one ``# material:`` line -- are two materials, and one file fitted twice
(the same bytes) is one.

The name shown is the material's own name; where two measurements share one, each
is told apart by the shortest end of its input's path that differs (``sample (lab1)``,
``steel (b.csv)``), else by its sha256 (``sample (sha 1a2b3c4d)``).  Those names are
the keys of the groups (``material_groups``): a report's pages, the library's cards,
pages, .glb nodes and analysis figures.

The library names a material's files ``material_stem``: a readable ASCII part of its
name and STEM_HASH hex digits of its identity (``sample-1a2b3c4d5e``,
``material-9f8e7d6c5b`` for a name without one ASCII letter or digit).  The stem depends
on the measurement alone (its name and bytes), not on the other inputs: adding a second
``sample`` to a library changes the first one's shown name, never its files.  A report
keeps its readable names (``sample.html``) and adds the hash only where two would
meet (``report_stems``).
"""

import hashlib
import pathlib
from collections.abc import Iterable

from fitting.ranking import ranking_key
from fitting.result import FitResult

from .html import slug

STEM_CHARS = 40          # characters of the readable part of a file stem
STEM_HASH = 10           # hex digits of the identity in a file stem (40 bits: no two measurements of a
                         # library meet by chance)
SHOWN_SHA = 8            # hex digits of a sha256 in a shown name, where nothing else tells two apart

Rows = list[tuple[pathlib.Path, FitResult]]


def identity(result: FitResult) -> str:
    """What makes a result's material one: its input's sha256, else its material name."""
    sha = (result.provenance or {}).get("sha256")
    return f"sha256:{sha}" if sha else f"name:{result.material}"


def _name(results: Iterable[FitResult]) -> str:
    """The material's own name.  One measurement may carry two (a MERL file renamed: its
    name is its file's): then that of a result whose input is here, the first in sorted order."""
    from brdf_fit.errors import is_file_here
    results = list(results)
    names = {r.material for r in results}
    if len(names) > 1:
        here = {r.material for r in results if is_file_here((r.provenance or {}).get("file") or "")}
        names = here or names
    return min(names)


def _digest(key: str) -> str:
    """Hex digits of an identity: the sha256 itself, or the sha256 of a name."""
    if key.startswith("sha256:"):
        return key[len("sha256:"):].lower()
    return hashlib.sha256(key.encode("utf-8", "surrogatepass")).hexdigest()


def material_stem(results: Iterable[FitResult]) -> str:
    """The stem of one material's files in a library (module doc): unique per
    measurement, stable across runs."""
    results = list(results)
    readable = slug(_name(results))[:STEM_CHARS].rstrip("._-") or "material"
    return f"{readable}-{_digest(identity(results[0]))[:STEM_HASH]}"


def report_stems(groups: dict[str, Rows]) -> dict[str, str]:
    """{shown name: its files' stem in a report}: ``slug(name)``, with SHOWN_SHA hex digits
    of the measurement where two stems would be one (compared ignoring case, as some
    file systems do)."""
    stems = {name: slug(name) for name in groups}
    taken = [s.lower() for s in stems.values()]
    for name, rows in groups.items():
        if taken.count(stems[name].lower()) > 1:
            stems[name] = f"{stems[name][:STEM_CHARS]}-{_digest(identity(rows[0][1]))[:SHOWN_SHA]}"
    return stems


def by_measurement(found: Rows) -> dict[str, Rows]:
    """{identity: [(path, FitResult)] best first (fitting.ranking)}, in first-seen order."""
    groups: dict[str, Rows] = {}
    for path, result in found:
        groups.setdefault(identity(result), []).append((path, result))
    for rows in groups.values():
        rows.sort(key=lambda pr: ranking_key(pr[1]))
    return groups


def material_groups(found: Rows) -> dict[str, Rows]:
    """{shown name: [(path, FitResult)] best first}: one entry per measurement, every
    name different (module doc), in first-seen order."""
    groups = by_measurement(found)
    names = {key: _name(r for _, r in rows) for key, rows in groups.items()}
    shown = dict(names)
    for name in set(names.values()):
        keys = [k for k in groups if names[k] == name]
        if len(keys) > 1:
            labels = _where(groups[k][0][1] for k in keys)
            for k, label in zip(keys, labels):
                shown[k] = f"{name} ({label})" if label else f"{name} (sha {_sha(k)})"
    taken = [s for s in shown.values()]
    for key, name in shown.items():     # a name that is another's told-apart name: its sha256 too
        if taken.count(name) > 1:
            shown[key] = f"{name} (sha {_sha(key)})"
    return {shown[k]: rows for k, rows in groups.items()}


def _sha(key):
    return _digest(key)[:SHOWN_SHA]


def _where(results):
    """For results of one name, the shortest ends of their input paths that tell them
    apart (without the file name when all have the same one), or Nones."""
    paths = [(r.provenance or {}).get("file") for r in results]
    if not all(paths):
        return [None] * len(paths)
    parts = [pathlib.PurePath(p).parts for p in paths]
    if len({p[-1] for p in parts}) == 1:
        parts = [p[:-1] for p in parts]
    for k in range(1, max(len(p) for p in parts) + 1):
        labels = ["/".join(p[-k:]) for p in parts]
        if all(labels) and len(set(labels)) == len(labels):
            return labels
    return [None] * len(paths)
