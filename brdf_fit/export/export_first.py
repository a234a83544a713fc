"""Export-first: a measured file in, the best glTF material out.

``brdf-fit export MEASURED_FILE --out material.glb`` and ``brdf-fit library``
ship a material by one rule (``candidates``): the models asked for (``auto``
by default: the engine family, screened, only its contenders fitted) and,
beside them, the glTF family -- models whose glTF material is the fitted BRDF
itself, so nothing is lost on the way to the file -- screened as a group of its
own with ``auto`` (by the exported material's ranking; at most its three best
screened fitted: ``fitting.fit_models.APART_MOST``), fitted in full without it.
The one written is the fit whose *exported* material ranks best
(``fitting.ranking``: M1 + 0.3 x the image error, both of the material as a
viewer evaluates it), so a converted fit only wins where its export beats the
glTF family's own fit.  The same table, samples and screening give the same
fits in both commands, so ``export`` writes what the library ships.
"""

import dataclasses
import typing

from brdf.model import model_string, parse_model

from fitting.ranking import (IMAGE_TERM, IMAGE_WEIGHT, OWN_PREFIX, SHIPPED_IMAGE_BAND, exported_ranking_error,
                             portable_export, shipped_best)

if typing.TYPE_CHECKING:
    from data_loaders import MeasuredBRDF

    from fitting.result import FitResult

#: The portable glTF materials (docs/gltf.md, "Portable"), with and without
#: KHR_materials_clearcoat: a dielectric (metallic 0) whose Fresnel is an IOR's, grey,
#: below F90 = 1, and a metal (metallic 1, F0 = baseColor); anisotropic measurements add
#: KHR_materials_anisotropy (``family_for``).  (A tint was tried: three.js weights the
#: diffuse by 1 - F per channel, so a coloured F0 draws otherwise there.)  Each is fitted
#: in the engines' reading (+turquin: the multiple scattering three.js and Cycles add to
#: the specular lobe; docs/gltf.md, "The engines' reading"), the file is the same.
GLTF_FAMILY = tuple(model_string(parse_model(m)) for m in (
    "gltf+nonmetal+ior+turquin", "gltf+nonmetal+ior+turquin+clearcoat", "gltf+metal+turquin",
    "gltf+metal+turquin+clearcoat"))
GLTF_ANISO_FAMILY = tuple(model_string(parse_model(m)) for m in (
    "gltf+nonmetal+ior+turquin+aniso", "gltf+nonmetal+ior+turquin+aniso+clearcoat", "gltf+metal+turquin+aniso"))
#: The family before (issue 59): free metallic, F90 and a specular colour up to 10, the
#: specification's corners engines draw otherwise.  Named with --model, they may ship.
#: (KHR_materials_ior is left out: with specular, its F0 = ((ior-1)/(ior+1))^2 x
#: specularColor can already be any value, so +ior fits the same BRDF again.)
SPEC_ONLY_FAMILY = ("gltf", "gltf+specular", "gltf+clearcoat", "gltf+specular+clearcoat")
#: The highest index of refraction of a common dielectric (diamond, 2.42 at 589 nm): a shipped
#: non-metal above it says so on its page (``Shipped``).
DIELECTRIC_IOR_MOST = 2.42


def family_for(isotropic: bool) -> list[str]:
    """The glTF family for a measurement (with the anisotropic variants when it is not isotropic)."""
    return list(GLTF_FAMILY) + ([] if isotropic else list(GLTF_ANISO_FAMILY))


def candidates(models: list[str], isotropic: bool) -> tuple[list[str], list[str]]:
    """(every model a shipped material is chosen among, the glTF family of them): ``models``
    (those asked for) first, then the glTF family (``family_for``) not among them."""
    family = family_for(isotropic)
    return [m for m in models if m not in family] + family, family


def fit_for_export(measured: "MeasuredBRDF", models: list[str] | None = None,
                   fit_options: dict[str, object] | None = None,
                   progress: typing.Callable[[str], object] | None = None, screen: bool = False,
                   screened: list | None = None, family: bool = True,
                   unscreened: list[str] | None = None) -> "list[FitResult]":
    """Fit ``models`` (default: ``auto``'s) and, with ``family``, the glTF family
    (``candidates``: what the library fits) to a measurement; the results, the shipped
    one first (``fitting.ranking.shipped_best``), then by their exported ranking error.
    ``screen`` (``auto``): the models asked for are screened as a batch screens them,
    only the contenders fitted (fitting/screen.py), but those of ``unscreened`` (named
    beside ``auto``: ``fitting.auto.fitted_fully``), and the glTF family is screened
    apart (``fit_models(apart=)``); the screened ones' ``ModelScreened`` go to ``screened``."""
    from fitting.auto import AUTO_FAMILY
    from fitting.fit_models import FIT_THREADS, fit_models
    from fitting.screen import ModelScreened
    asked = list(models or AUTO_FAMILY)
    everything, apart = candidates(asked, measured.isotropic) if family else (asked, [])
    results = []
    for model, outcome in fit_models(measured, everything, threads=FIT_THREADS, apart=apart,
                                     unscreened=unscreened or (),
                                     screen="fit" if screen else None, **(fit_options or {})):
        if isinstance(outcome, ModelScreened):
            if screened is not None:
                screened.append(outcome)
            if progress:
                progress(f"{model}: screened")
            continue
        if isinstance(outcome, Exception):
            raise outcome
        results.append(outcome)
        if progress:
            progress(f"{model}: exported M1 {outcome.errors['exported_m1']:.4g}")
    results.sort(key=lambda r: exported_ranking_error(r.errors))
    best = shipped_best(results)
    return [best] + [r for r in results if r is not best]


def describe_candidates(results: "list[FitResult]", stream: typing.TextIO) -> None:
    """The fitted models with their own and their exported errors (best export first)."""
    width = max(len(r.spec) for r in results)
    print(f"{'model':<{width}}  {'M1':>9}  {'image':>7}  {'glTF M1':>9}  {'glTF image':>10}", file=stream)
    for i, r in enumerate(results):
        e = r.errors
        print(f"{r.spec:<{width}}  {e['m1']:9.5f}  {e.get('image', float('nan')):7.4f}  "
              f"{e['exported_m1']:9.5f}  {e.get('exported_image', float('nan')):10.4f}"
              + ("  <- written" if i == 0 else ""), file=stream)


def is_export_first(result: "FitResult") -> bool:
    """Whether a fit is of the glTF family itself (its material exported 1:1), not converted."""
    return parse_model(result.spec).composition == "gltf"      # (openpbr brings its own lobes: not glTF's)


@dataclasses.dataclass(frozen=True)
class Shipped:
    """Which fit of a material is shipped as glTF, and how it compares (the library's pages).

    result        the fit whose exported material is shipped
    export_first  it is a fit of the glTF family (exported 1:1), not a converted one
    other         the best exported fit of the other path (None: no fit of that path)
    margin        ``other``'s exported ranking error over the shipped one's
    best_image    the fit with the lowest image error of its own (any model)
    image_ratio   the shipped material's image error over ``best_image``'s (None: no image errors)
    lacking       where ``image_ratio`` > SHIPPED_IMAGE_BAND: what glTF cannot carry of
                  ``best_image`` (its conversion's notes)
    corner        where the shipped material is portable: the best fit whose exported material
                  is not (a spec-only corner), if it ranks better by the specification (else None)
    other_kind    the best fit of the glTF family of the other kind (a metal where a non-metal
                  is shipped, or the reverse), if one was fitted: why the shipped one is the
                  kind it is, in numbers (issue 59: "metals as metals ... unless the page says why")
    """
    result: "FitResult"
    export_first: bool
    other: "FitResult | None"
    margin: float | None
    best_image: "FitResult"
    image_ratio: float | None
    lacking: tuple[str, ...]
    corner: "FitResult | None" = None
    other_kind: "FitResult | None" = None

    def sentences(self) -> list[str]:
        """What the pages say of it: the path that won, by how much, and any lobe glTF lacks."""
        r, path = self.result, "the export-first fit of the glTF family" if self.export_first else "a converted fit"
        out = [f"Shipped: {path}, {r.spec}" + ("" if self.export_first else f" as {r.errors.get('exported_model')}")
               + "."]
        if self.other is not None:
            kind = "converted fit" if self.export_first else "export-first fit"
            out.append(f"The best {kind}, {self.other.spec}, has {self.margin:.3f}x the shipped material's ranking "
                       f"error as glTF (M1 + {IMAGE_WEIGHT:g} x {IMAGE_TERM} of the exported material).")
        if self.image_ratio is not None and self.image_ratio > SHIPPED_IMAGE_BAND:
            out.append(f"The shipped material's image error is {self.image_ratio:.3g}x that of the best fit, "
                       f"{self.best_image.spec} ({float(r.errors['exported_image']):.4g} against "
                       f"{float(self.best_image.errors['image']):.4g}); what glTF lacks of that fit, as its conversion "
                       "says: " + ("; ".join(self.lacking) or "(no note)") + ".")
        if self.corner is not None:
            out.append(self._corner_sentence())
        out.extend(self._readable_sentences())
        return out

    def _readable_sentences(self) -> list[str]:
        """The shipped material's kind (metal or not) against the other kind's best fit, and an IOR
        above any common dielectric's, each with its numbers (docs/gltf.md, "Readable values")."""
        from brdf.fresnel import f0_from_ior
        from brdf.gltf_material import convert
        values = convert(self.result.spec, self.result.parameters)["parameters"]
        metal = float(values.get("metallic", 0.0)) >= 1.0
        out = []
        if self.other_kind is not None:
            o = self.other_kind
            out.append(f"Shipped as a {'metal' if metal else 'non-metal'} (metallic {int(metal)}): as a "
                       f"{'non-metal' if metal else 'metal'}, the best fit, {o.spec}, draws the table at image "
                       f"error {float(o.errors.get('exported_image', float('nan'))):.4g} and M1 "
                       f"{float(o.errors['exported_m1']):.4g}, against "
                       f"{float(self.result.errors.get('exported_image', float('nan'))):.4g} and "
                       f"{float(self.result.errors['exported_m1']):.4g} shipped.")
        ior = float(values.get("ior", 1.5))
        if not metal and ior > DIELECTRIC_IOR_MOST:
            out.append(f"Its ior, {ior:.3g}, is above any common dielectric's (diamond's {DIELECTRIC_IOR_MOST}): "
                       f"the table's reflectance at normal incidence, F0 {float(f0_from_ior(ior)):.3g}, is more than "
                       f"one clear interface gives (at most {float(f0_from_ior(DIELECTRIC_IOR_MOST)):.3g}), as fibres "
                       "and layers give; the value is the fit's, not a material's index.")
        return out

    def _corner_sentence(self) -> str:
        """Why the portable material was shipped over a spec-only corner that ranks better by the specification."""
        r, c = self.result, self.corner
        return (f"Shipped portable (docs/gltf.md, Portable): {_named(c)} ranks better by the specification "
                "but is not portable (F90 below 1, a coloured specular or a partial metal): it "
                f"{_readings(c.errors)}; the shipped material {_readings(r.errors)}. Name a spec-only glTF "
                "model (e.g. --model auto,gltf+specular+clearcoat) to ship it.")


def shipped(results: "list[FitResult]") -> Shipped:
    """The Shipped summary of a material's fits (at least one)."""
    from brdf.gltf_material import convert
    best = shipped_best(results)
    others = [r for r in results if is_export_first(r) != is_export_first(best)]
    other = min(others, key=lambda r: exported_ranking_error(r.errors), default=None)
    margin = None if other is None else exported_ranking_error(other.errors) / exported_ranking_error(best.errors)
    imaged = [r for r in results if "image" in r.errors]
    best_image = min(imaged, key=lambda r: float(r.errors["image"]), default=best)
    ratio = (float(best.errors["exported_image"]) / float(best_image.errors["image"])
             if "exported_image" in best.errors and "image" in best_image.errors
             and float(best_image.errors["image"]) > 0 else None)
    lacking = ()
    if ratio is not None and ratio > SHIPPED_IMAGE_BAND and not is_export_first(best_image):
        lacking = tuple(convert(best_image.spec, best_image.parameters)["notes"])
    corners = [r for r in results if not str(r.spec).startswith(OWN_PREFIX) and not portable_export(r)]
    corner = min(corners, key=lambda r: exported_ranking_error(r.errors), default=None)
    if not portable_export(best) or corner is None or \
            exported_ranking_error(corner.errors) >= exported_ranking_error(best.errors):
        corner = None       # shipped by the specification alone, or no corner ranks better: nothing to say
    return Shipped(best, is_export_first(best), other, margin, best_image, ratio, lacking, corner,
                   _other_kind(best, results))


def _other_kind(best: "FitResult", results: "list[FitResult]") -> "FitResult | None":
    """The best portable fit of the glTF family whose kind (metal or not) is not the shipped
    material's, or None (a non-portable material shipped, or no such fit)."""
    from brdf.gltf_material import convert

    def kind(r):
        return float(convert(r.spec, r.parameters)["parameters"].get("metallic", 0.0)) >= 1.0
    if not portable_export(best):
        return None
    others = [r for r in results if is_export_first(r) and portable_export(r) and kind(r) != kind(best)]
    return min(others, key=lambda r: exported_ranking_error(r.errors), default=None)


def _named(result: "FitResult") -> str:
    return result.spec + ("" if is_export_first(result) else f" as {result.errors.get('exported_model')}")


def _readings(errors: dict) -> str:
    """How an exported material ranks (and its image error) by the specification, and as Blender reads it."""
    spec = f"{exported_ranking_error(errors):.4g} (image error {float(errors.get('exported_image', float('nan'))):.4g})"
    if "blender_m1" not in errors:
        return f"ranks {spec} by the specification"
    blender = {"exported_m1": errors["blender_m1"], "exported_image": errors.get("blender_image", 0.0)}
    return (f"ranks {spec} by the specification and {exported_ranking_error(blender):.4g} (image error "
            f"{float(errors.get('blender_image', float('nan'))):.4g}) as Blender's importer reads it (F90 = 1)")
