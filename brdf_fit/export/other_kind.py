"""Why a native material is written as the kind it is (issue 61): the best fit of the other kind
(a metal where a non-metal is written, or the reverse) and both ranking errors, which the Blender
asset (blender_file), the MaterialX document (openpbr_first) and the library's files
(brdf_fit/library/native.py) all name, in numbers."""

from brdf.model import parse_model
from brdf.openpbr_coat import OPEN_PBR_SURFACE_HELD
from brdf.principled import PRINCIPLED_BASES


def is_metal(spec: str) -> bool:
    """Whether a fit of an OpenPBR or a Principled model is written as a metal (base_metalness and
    Metallic 1; each model holds it: brdf.openpbr_coat.OPEN_PBR_SURFACE_HELD)."""
    composition = parse_model(spec).composition
    return OPEN_PBR_SURFACE_HELD[PRINCIPLED_BASES.get(composition, composition)]["base_metalness"] == 1.0


def other_kind(result, results, keep) -> "object | None":
    """The best fit (fitting.ranking.ranked) among ``results`` that ``keep`` takes (a model string ->
    bool: the models the format writes 1:1) and that is of the other kind than ``result`` (a metal
    where it is a non-metal, or the reverse): why ``result`` is written as the kind it is, in
    numbers.  None where there is none."""
    from fitting.ranking import ranked
    others = [r for r in results if keep(r.spec) and is_metal(r.spec) != is_metal(result.spec)]
    return ranked(others)[0] if others else None


def other_kind_numbers(result, other) -> dict[str, object]:
    """{"model", "ranking_error", "written_ranking_error"}: ``other_kind``'s fit beside ``result``."""
    from fitting.ranking import ranking_error
    return {"model": other.spec, "ranking_error": ranking_error(other.errors),
            "written_ranking_error": ranking_error(result.errors)}


def other_kind_line(written_is_metal: bool, numbers: dict[str, object]) -> str:
    """The sentence the asset, the document and the command print (``other_kind_numbers``)."""
    from fitting.ranking import IMAGE_TERM, IMAGE_WEIGHT
    kind, other = ("metal", "non-metal") if written_is_metal else ("non-metal", "metal")
    return (f"written as a {kind}: as a {other} its best fit, {numbers['model']}, ranks "
            f"{numbers['ranking_error']:.4g} against {numbers['written_ranking_error']:.4g} "
            f"(M1 + {IMAGE_WEIGHT:g} x {IMAGE_TERM}; lower is better)")
