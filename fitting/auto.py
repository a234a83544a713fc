"""The named model sets (``auto``, ``classic``) and model lists: what ``--model`` / ``--models`` expand to.

This module imports nothing heavy (the command line and the result schema read it).
"""

from brdf.model import model_string, parse_model

DIFFUSE_FAMILY = ("lambert", "burley", "frostbite", "cod_wwii")
# --model auto: GGX with each diffuse model, with and without energy
# compensation and clearcoat, and with a Schlick F90 below 1 (UE's and
# Filament's F90; glTF expresses it as KHR_materials_specular's factor) --
# all of them renderable by a game engine.  In the order they are fitted: the
# likeliest winners first, so that models that cannot win are cut early
# (``run_batch(cut=)``); a model with a switch more (+ms) after the one whose
# optimum it starts from (``fit.warm_start``).
AUTO_OPTIONS = ("+clearcoat+f90", "+f90", "+clearcoat", "+ms+clearcoat", "", "+ms")
AUTO_FAMILY = tuple(model_string(parse_model(f"ggx+{d}{o}")) for d in DIFFUSE_FAMILY for o in AUTO_OPTIONS)

# --model classic: the models of Ngan, Durand & Matusik 2005's study (docs/models.md), each
# with a Lambertian as they fitted them -- the half-vector lobes (Blinn-Phong, Ward,
# Ward-Duer, Ashikhmin-Shirley), the mirror lobes (modified Phong, Lafortune), Cook-Torrance
# (Beckmann with V-groove masking) -- and Beckmann with its Smith masking, GGX's classic
# rival.  Not screened or cut, even beside 'auto' (``fitted_fully``): a study wants every one
# of them fitted.
CLASSIC_FAMILY = tuple(model_string(parse_model(m)) for m in (
    "blinn_phong+lambert", "phong+lambert", "ward+lambert", "ward_duer+lambert", "ashikhmin_shirley+lambert",
    "lafortune+lambert", "beckmann+lambert+vgroove", "beckmann+lambert"))

# --model openpbr: OpenPBR Surface as MaterialX draws it: its two bases (brdf/openpbr.py), bare
# and under its coat (brdf/openpbr_coat.py), the non-metal under its fuzz (brdf/openpbr_fuzz.py),
# each with MaterialX's GGX energy compensation (+mx): what ``export --format openpbr`` fits, and
# beside 'auto' in a library its materials.mtlx.
OPENPBR_FAMILY = ("openpbr+metal+mx", "openpbr+nonmetal+mx", "openpbr+metal+coat+mx", "openpbr+nonmetal+coat+mx",
                  "openpbr+nonmetal+fuzz+mx")
# --model principled: Blender's Principled BSDF as Cycles draws it with the GGX distribution
# (brdf/principled.py): its metal (OpenPBR's bare metal, canonically ``openpbr+metal``), its dielectric
# base in Cycles' layering, each under its coat, the dielectric base under its sheen: what
# ``export --format blender`` fits, and beside 'auto' in a library its materials.blend.
PRINCIPLED_FAMILY = ("openpbr+metal", "principled+nonmetal", "principled+metal+coat", "principled+nonmetal+coat",
                     "principled+nonmetal+sheen")


def model_sets() -> dict[str, tuple[str, ...]]:
    """The named sets a --model / --models list may contain, read when called (so that a
    caller -- or a test -- that replaces AUTO_FAMILY is followed)."""
    return {"auto": AUTO_FAMILY, "classic": CLASSIC_FAMILY, "openpbr": OPENPBR_FAMILY, "principled": PRINCIPLED_FAMILY}


def expand_models(text: str) -> list[str]:
    """'a,b,c', a named set ('auto', 'classic') or a list mixing both -> list of canonical model
    strings (validated, each once, in the order asked)."""
    names = []
    for item in str(text).split(","):
        item = item.strip()
        if not item:
            continue
        sets = model_sets()
        if item in sets:
            names.extend(sets[item])
        else:
            names.append(model_string(parse_model(item)))
    if not names:
        raise ValueError("no model given")
    return list(dict.fromkeys(names))


def uses_auto(text: str) -> bool:
    """True when a --model / --models value asks for 'auto' (models that cannot win are cut)."""
    return "auto" in (item.strip() for item in str(text).split(","))


def fitted_fully(text: str) -> list[str]:
    """The models of a --model / --models value with 'auto' that its screening and cut leave
    alone: those named, or of another set ('classic'), each fitted fully even where 'auto'
    has it too -- a comparison wants every one's own errors; only 'auto' asked for a choice."""
    others = [item for item in str(text).split(",") if item.strip() and item.strip() != "auto"]
    return expand_models(",".join(others)) if others else []
