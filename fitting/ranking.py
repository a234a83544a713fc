"""How models are ranked: the error ``--model auto``, the report and export-first sort by.

A model that wins on the table but draws a worse sphere is not what a user
wants, nor one that draws a sphere well by bending the table.  The ranking
error is (docs/metrics.md):

    ranking error = M1 + IMAGE_WEIGHT * (image error + SECOND_WEIGHT * second image error)

(M1 alone for results without an image error).  The exported ranking error is
the same sum for the glTF material ``brdf-fit export`` writes from the fit.
This module imports nothing heavy: the command line and the result reader use it.
"""

import math
import os
import sys
import typing
from collections.abc import Iterable, Mapping

if typing.TYPE_CHECKING:
    from .result import FitResult

OWN_PREFIX = "own:"      # brdf.own.PREFIX (not imported: brdf's package imports the declarations)

IMAGE_WEIGHT = 0.3       # the weight of the image error beside M1 when models are ranked
# The hybrid loss's default weight: each fit leans further towards the image than
# the ranking does.  At the viewer's exposure the image error is larger for dark and
# metallic tables than it was at exposure 1, and weight 1 cost ggx+lambert +30 % median
# M1 over its log fit (docs/metrics.md); 0.5 keeps that within +15 % (issue 24).
HYBRID_WEIGHT = 0.5
EXPORT_LOSS_WARN = 0.10  # an export that loses more than 10 % against its fit warns
# The material shipped (``shipped_best``) draws at most this x the lowest image error of
# the exported materials: the ranking's M1 never buys a visibly worse picture.
SHIPPED_IMAGE_BAND = 1.05


def _second_weight(text: str | None) -> float:
    """BRDF_SECOND_WEIGHT's weight: 1 when unset or empty; anything but a finite number >= 0
    ends the program with one line naming the variable (an environment mistake, not a fault)."""
    try:
        weight = float(text) if text and text.strip() else 1.0
    except ValueError:
        weight = math.nan
    if not 0.0 <= weight < math.inf:
        sys.exit(f"error: BRDF_SECOND_WEIGHT={text!r}: the second image error's weight must be a number "
                 "at least 0 (1 by default, 0 turns it off; docs/metrics.md)")
    return weight


# The weight of issue 59's second image error (fitting/second_error.py) beside the image error
# wherever the image is weighed -- the hybrid loss's image term, the check that a fit keeps the
# picture, this ranking (docs/metrics.md).  ``BRDF_SECOND_WEIGHT`` in the environment sets
# another; 0: the image error alone, and no second error computed (the toolkit before 2026-12-07).
SECOND_WEIGHT = _second_weight(os.environ.get("BRDF_SECOND_WEIGHT"))
# The image term in words, as the pages and the command line name the ranking: "M1 + 0.3 x " + IMAGE_TERM
IMAGE_TERM = ("image error" if not SECOND_WEIGHT else "(image error + second image error)" if SECOND_WEIGHT == 1.0
              else f"(image error + {SECOND_WEIGHT:g} x second image error)")


def image_term(errors: Mapping[str, object]) -> float:
    """The image error of a result's ``errors`` plus SECOND_WEIGHT x its second image error (0 without)."""
    return float(errors.get("image", 0.0)) + SECOND_WEIGHT * float(errors.get("second_image", 0.0))


def ranking_error(errors: Mapping[str, object]) -> float:
    """M1 + IMAGE_WEIGHT x image error of a result's ``errors`` (M1 without an image error);
    with SECOND_WEIGHT, the image error's ``image_term``."""
    return float(errors.get("m1", float("inf"))) + IMAGE_WEIGHT * image_term(errors)


def ranking_key(result: "FitResult") -> tuple[float, str]:
    """A FitResult's place in the ranking: its ranking error, ties by model string (so that every
    place that names the best -- ``fit``'s table, the report, the library, the demo -- names the
    same fit whatever order its results were read in)."""
    return ranking_error(result.errors), str(result.spec)


def ranked(results: Iterable) -> list:
    """FitResults best first (``ranking_key``); the first is ``auto``'s "best" everywhere it is shown."""
    return sorted(results, key=ranking_key)


def ranking_terms(errors: Mapping[str, object]) -> str:
    """The ranking error with its terms, as the places that name the best show it beside the
    name: "M1 0.008770 + 0.3 x image 0.04123 = 0.02114" (M1 alone without an image error)."""
    m1 = float(errors.get("m1", float("inf")))
    if "image" not in errors:
        return f"M1 {m1:.4g} (no image error)"
    image = f"image {float(errors['image']):.4g}"
    if SECOND_WEIGHT and "second_image" in errors:
        image = f"(image {float(errors['image']):.4g} + {SECOND_WEIGHT:g} x second {float(errors['second_image']):.4g})"
    return f"M1 {m1:.4g} + {IMAGE_WEIGHT:g} x {image} = {ranking_error(errors):.4g}"


def best_ranking_error(results: Iterable) -> float | None:
    """The lowest ranking error among FitResults (None for none): what ``--model
    auto`` hands each next fit as ``cut_above``."""
    return min((ranking_error(r.errors) for r in results), default=None)


def exported_ranking_error(errors: Mapping[str, object]) -> float:
    """The ranking error of the exported glTF material (the fit's own when it was not measured)."""
    if "exported_m1" not in errors:
        return ranking_error(errors)
    return ranking_error({"m1": errors["exported_m1"], "image": errors.get("exported_image", 0.0),
                          "second_image": errors.get("exported_second_image", 0.0)})


def export_loss(errors: Mapping[str, object]) -> float:
    """How much worse the exported material ranks than its fit (0.12 = 12 % worse)."""
    fitted = ranking_error(errors)
    return exported_ranking_error(errors) / fitted - 1.0 if fitted > 0 else 0.0


def portable_export(result: "FitResult") -> bool:
    """Whether a fit's exported glTF material is portable (brdf.gltf_material.portable)."""
    from brdf.gltf_material import convert, portable
    return portable(convert(result.spec, result.parameters))


def spec_only_named(results: Iterable) -> bool:
    """Whether a glTF model with a spec-only corner was fitted (named by the user: the
    export-first family is portable), so that such a material may be shipped."""
    return any(str(r.spec).startswith("gltf") and not portable_export(r) for r in results)


def shipped_best(results: Iterable) -> object:
    """The FitResult whose exported glTF material is shipped (``export``, the library).

    Which materials may ship: the portable ones (``portable_export``; all when none is),
    unless a glTF model that is not portable was named (``spec_only_named``): then all.
    Among them, those whose exported image error is within SHIPPED_IMAGE_BAND x the lowest
    one's, the best exported ranking error (results without exported errors are ranked by
    their own; without image errors, by the ranking alone).

    (A spec-only corner that ranks better than the best portable material in both the
    specification's reading and Blender's importer's -- F90 = 1, "blender_m1" and
    "blender_image" -- was shipped in a trial: on 4 of 15 MERL tables, three.js and Blender
    drew 3 of the 4 worse than the portable material, their multiple scattering and
    three.js's per-channel diffuse weight being outside that reading: docs/gltf.md.)"""
    results = list(results)
    results = [r for r in results if not str(r.spec).startswith(OWN_PREFIX)] or results   # own: no glTF
    if not spec_only_named(results):
        results = [r for r in results if portable_export(r)] or results
    return _by_rule(results)


def _by_rule(results: list) -> object:
    """The shipped rule's choice among ``results``: within SHIPPED_IMAGE_BAND x the lowest
    exported image error, the best exported ranking error."""
    images = [float(r.errors["exported_image"]) for r in results if "exported_image" in r.errors]
    if images:
        band = SHIPPED_IMAGE_BAND * min(images)
        results = [r for r in results if float(r.errors.get("exported_image", band)) <= band] or results
    return min(results, key=lambda r: exported_ranking_error(r.errors))
