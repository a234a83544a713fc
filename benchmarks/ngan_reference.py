"""Ngan, Durand & Matusik 2005's published fits of the classic models, evaluated here (issue 54).

Reads ``../shared/measured/ngan2005/ngan_MODEL.fit`` (one line per material:
``MATERIAL = Aggregate(Lambertian(albedo = [r, g, b]), NganMODEL(name = value, ...))``,
the Lambertian albedo / pi; transcribed from the paper's supplement by the BSDF
benchmark project, bbm), maps each published fit to one of our model strings
and its parameters, and prints, per material, M1 and the image error
(docs/metrics.md) of the published fit on a MERL-like table beside those of our
own fit of the same model.  The data is not the project's: never committed.

The published models as bbm defines them (include/bsdfmodel/ngan.h and the
headers it includes), and what each is here:

    NganWard, NganWardDuer   albedo x Ward 1992 / Duer 2006, isotropic, alpha = roughness:
                             ``ward+lambert`` / ``ward_duer+lambert``, rho_s = albedo, r = sqrt(alpha)
    NganBlinnPhong           bbm evaluates it as the modified Phong mirror lobe,
                             albedo (n + 2)/(2 pi) max(0, r.wo)^n: ``phong+lambert``; the
                             paper's Blinn-Phong is a half-vector lobe, so it is also evaluated
                             as ``blinn_phong+lambert`` with the same albedo and n
    NganLafortune            albedo (n + 2)/(2 pi max(|Cz|, |Cxy|)^n) max(0, C . (wi * wo))^n:
                             ``lafortune+lambert`` exactly (the scale of C cancels: Cz / |C|)
    NganCookTorrance         albedo x D G F / (pi n.wi n.wo), D Beckmann normalised
                             (1/pi), V-groove G, Schlick F with F0 = eta: ours is
                             D G F / (4 n.wi n.wo), so it is ``beckmann+lambert+vgroove+f90``
                             with F0 = (4/pi) albedo eta, F90 = (4/pi) albedo (per channel: an
                             RGB F90, beyond the schema's scalar, for this evaluation only);
                             also evaluated with bbm's plain ``cooktorrance``'s unnormalised D
                             (x 4 instead of 4/pi), the reading docs/models.md had before

    NganAshikhminShirley     albedo x F(R_s) x the Ashikhmin-Shirley lobe, R_s grey:
                             ``ashikhmin_shirley_scaled+lambert`` exactly (rho_s = albedo,
                             fresnel_reflectance = R_s); our ``ashikhmin_shirley`` (F(rho_s),
                             F90 = 1, the 2000 paper's) is fitted beside it

For every model the Phong-type exponent n maps to our roughness by Walter et al.
2007's n = 2/alpha^2 - 2 (brdf/lobes.py): r = (2 / (n + 2))^(1/4).  Not evaluated:
NganHe (He et al. 1991 is not declared).

Our fits: made here (``fit``, with the default hybrid loss and with ``--loss log``), or
read from a library's results (``--results LIB/results``: ``brdf-fit library TABLES
--models classic,auto,ggx+lambert,beckmann+lambert+vgroove+f90``, the study of
docs/study.md; its fits are the hybrid ones).  With ``--results`` a summary follows the
table: per model, on how many materials our fit is at least as good as the published
one in M1, in the image error and in both, and the worst ratios.

    python benchmarks/ngan_reference.py [--fits DIR] [--tables DIR] [--models ward,...]
                                        [--results DIR] [MATERIAL ...]

(no MATERIAL: every material of the .fit files with a table in --tables)
"""

import argparse
import dataclasses
import math
import pathlib
import re
import sys

FITS = pathlib.Path(__file__).resolve().parents[2] / "shared" / "measured" / "ngan2005"
TABLES = pathlib.Path("/tmp/merl-wide")
COOK_OVER_WALTER = 4.0 / math.pi     # D G F / (pi ...) over D G F / (4 ...)
LINE = re.compile(r"^\s*(?P<material>[\w.-]+)\s*=\s*Aggregate\(\s*Lambertian\(\s*albedo\s*=\s*\[(?P<rho>[^\]]*)\]\s*\)"
                  r"\s*,\s*(?P<model>\w+)\((?P<params>.*)\)\s*\)\s*$")
PARAM = re.compile(r"(\w+)\s*=\s*(\[[^\]]*\]|[-+0-9.eE]+)")
# file stem -> the models we fit beside it
OURS = {"ward": ("ward+lambert",), "wardduer": ("ward_duer+lambert",),
        "blinnphong": ("phong+lambert", "blinn_phong+lambert"), "lafortune": ("lafortune+lambert",),
        "cooktorrance": ("beckmann+lambert+vgroove", "beckmann+lambert+vgroove+f90"),   # +f90: Ngan's scale ks
        "ashikhminshirley": ("ashikhmin_shirley+lambert", "ashikhmin_shirley_scaled+lambert")}   # Ngan's scale
# our fits: the command line's default (hybrid: M1 + 0.3 x image) and M1 alone (log)
LOSSES = ("hybrid", "log")


@dataclasses.dataclass(frozen=True)
class NganFit:
    """One published fit: the Lambertian albedo and the specular model's parameters."""
    material: str
    lambert: tuple
    model: str
    params: dict


def _value(text):
    text = text.strip()
    if text.startswith("["):
        return tuple(float(v) for v in text[1:-1].split(","))
    return float(text)


def parse_line(line: str) -> NganFit | None:
    """One line of a .fit file -> NganFit; None for a comment or a blank line."""
    if not line.strip() or line.lstrip().startswith("#"):
        return None
    match = LINE.match(line)
    if not match:
        raise ValueError(f"not a Ngan fit line: {line.strip()[:80]!r}")
    rho = tuple(float(v) for v in match["rho"].split(","))
    params = {k: _value(v) for k, v in PARAM.findall(match["params"])}
    return NganFit(match["material"], rho, match["model"], params)


def read_fits(path: pathlib.Path) -> dict[str, NganFit]:
    """{material: NganFit} of one .fit file."""
    fits = (parse_line(line) for line in pathlib.Path(path).read_text().splitlines())
    return {f.material: f for f in fits if f is not None}


def roughness_of_exponent(n: float) -> float:
    """Our roughness r of a Phong exponent n (n = 2/alpha^2 - 2, alpha = r^2)."""
    return (2.0 / (n + 2.0)) ** 0.25


def _rgb(x):
    return list(x) if isinstance(x, tuple) else [x] * 3


def as_ours(fit: NganFit) -> list[tuple[str, str, dict]]:
    """The published fit as (label, our model string, parameters): one or more evaluations."""
    rho = list(fit.lambert)
    p = fit.params
    if fit.model in ("NganWard", "NganWardDuer"):
        model = "ward+lambert" if fit.model == "NganWard" else "ward_duer+lambert"
        return [("published", model, {"albedo": rho, "roughness": math.sqrt(p["roughness"]),
                                      "specular_albedo": _rgb(p["albedo"])})]
    if fit.model == "NganBlinnPhong":
        params = {"albedo": rho, "roughness": roughness_of_exponent(p["sharpness"]),
                  "specular_albedo": _rgb(p["albedo"])}
        return [("published, mirror lobe (bbm)", "phong+lambert", params),
                ("published, half-vector lobe", "blinn_phong+lambert", params)]
    if fit.model == "NganLafortune":
        cxy, cz = p["Cxy"], p["Cz"]
        if cxy > 0 or cz < 0:
            raise ValueError(f"{fit.material}: not a forward lobe (Cxy {cxy}, Cz {cz})")
        return [("published", "lafortune+lambert",
                 {"albedo": rho, "roughness": roughness_of_exponent(p["sharpness"]),
                  "specular_albedo": _rgb(p["albedo"]), "lafortune_cz": cz / math.sqrt(2 * cxy * cxy + cz * cz)})]
    if fit.model == "NganAshikhminShirley":
        return [("published", "ashikhmin_shirley_scaled+lambert",
                 {"albedo": rho, "roughness": roughness_of_exponent(p["sharpness"]),
                  "specular_albedo": _rgb(p["albedo"]), "fresnel_reflectance": p["fresnelReflectance"]})]
    if fit.model == "NganCookTorrance":
        out = []
        for label, factor in (("published", COOK_OVER_WALTER), ("published, D without 1/pi (x4)", 4.0)):
            scale = [factor * a for a in _rgb(p["albedo"])]
            out.append((label, "beckmann+lambert+vgroove+f90",
                        {"albedo": rho, "roughness": math.sqrt(p["roughness"]), "f0": [s * p["eta"] for s in scale],
                         "f90": scale}))
        return out
    raise ValueError(f"{fit.material}: {fit.model} has no evaluation here")


def compare(material: str, stems: list[str], fits_dir: pathlib.Path, tables: pathlib.Path,
            fit_ours: bool = True, results: pathlib.Path | None = None, log_behind: bool = False) -> list[dict]:
    """Rows (model, label, M1, image) of the published fits and of our fits on one table
    (read from ``results``, a library's results folder, where given; with ``log_behind``,
    where that fit's M1 is above the published one's, our --loss log fit beside it)."""
    import data_loaders
    from fitting.fit import fit
    from fitting.material_errors import image_errors, m1_errors
    from fitting.result import FitResult
    measured = data_loaders.load(tables / f"{material}.binary")
    rows, evaluated = [], []        # evaluated: (row, model, parameters), Ngan's L2 computed at the end

    def add(row, model, params):
        rows.append(row)
        evaluated.append((row, model, params))

    def ours_row(stem, label, model, result):
        image = result.errors["image"] if "image" in result.errors else image_errors(
            measured, [(model, result.parameters)])[0]
        add(dict(material=material, model=stem, label=label, spec=model, m1=result.errors["m1"], image=image),
            model, result.parameters)

    for stem in stems:
        published = read_fits(fits_dir / f"ngan_{stem}.fit").get(material)
        if published is None:
            continue
        evaluations = as_ours(published)
        pairs = [(model, params) for _, model, params in evaluations]
        m1s = [m1 for m1, _ in m1_errors(measured, pairs)]
        for (label, model, params), m1, image in zip(evaluations, m1s, image_errors(measured, pairs)):
            add(dict(material=material, model=stem, label=label, spec=model, m1=m1, image=image), model, params)
        published_m1 = min(m1s, default=math.inf)
        for model in OURS[stem] if fit_ours and results is not None else ():
            path = results / f"{material}.{model}.json"
            if path.exists():
                ours = FitResult.load(path)
                ours_row(stem, "ours (library)", model, ours)
                if log_behind and ours.errors["m1"] > published_m1:
                    ours_row(stem, "ours (log fit)", model, fit(measured, model, loss="log"))
        for model in OURS[stem] if fit_ours and results is None else ():
            for loss in LOSSES:
                ours_row(stem, f"ours ({loss} fit)", model, fit(measured, model, loss=loss))
    ngan = m1_errors(measured, [(model, params) for _, model, params in evaluated], loss="ngan")
    for (row, _, _), (l2, _) in zip(evaluated, ngan):
        row["ngan"] = l2
    return rows


def summary(rows: list[dict]) -> list[str]:
    """Per model (a published fit beside our fit of the same model string): on how many
    materials ours is at least as good in M1, in the image error and in both, and the
    worst ratios (ours over published).  The published fit's best evaluation is taken
    where it has several (Blinn-Phong's two lobes, Cook-Torrance's two normalisations)."""
    out = ["| model | ours (model string) | materials | M1 at least as good | image at least as good | both | "
           "worst M1 ratio | worst image ratio | Ngan's L2 at least as good | median L2 ratio |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    keys = sorted({(r["model"], r["spec"], r["label"]) for r in rows if r["label"].startswith("ours")})
    for stem, spec, label in keys:
        m1, image, both, names, l2 = [], [], 0, [], []
        for material in sorted({r["material"] for r in rows if r["model"] == stem}):
            ours = [r for r in rows
                    if (r["material"], r["model"], r["spec"], r["label"]) == (material, stem, spec, label)]
            published = [r for r in rows if (r["material"], r["model"]) == (material, stem)
                         and r["label"].startswith("published")]
            if not ours or not published:
                continue
            best_m1, best_image = min(p["m1"] for p in published), min(p["image"] for p in published)
            m1.append(ours[0]["m1"] / best_m1)
            image.append(ours[0]["image"] / best_image)
            l2.append(ours[0]["ngan"] / min(p["ngan"] for p in published))
            both += m1[-1] <= 1 and image[-1] <= 1
            names.append(material)
        if not names:
            continue
        worst_m1, worst_image = max(zip(m1, names)), max(zip(image, names))
        out.append(f"| {stem} | `{spec}`, {label} | {len(names)} | {sum(x <= 1 for x in m1)} | "
                   f"{sum(x <= 1 for x in image)} | "
                   f"{both} | {worst_m1[0]:.3f} ({worst_m1[1]}) | {worst_image[0]:.3f} ({worst_image[1]}) | "
                   f"{sum(x <= 1 for x in l2)} | {sorted(l2)[len(l2) // 2]:.3f} |")
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("materials", nargs="*")
    parser.add_argument("--fits", type=pathlib.Path, default=FITS)
    parser.add_argument("--tables", type=pathlib.Path, default=TABLES)
    parser.add_argument("--models", default=",".join(OURS))
    parser.add_argument("--results", type=pathlib.Path, help="our fits: a library's results folder (not fitted here)")
    parser.add_argument("--log-behind", action="store_true",
                        help="with --results: where our fit's M1 is above the published one's, "
                        "fit --loss log beside it")
    parser.add_argument("--published-only", action="store_true", help="evaluate the published fits, fit nothing")
    args = parser.parse_args(argv)
    stems = args.models.split(",")
    materials = args.materials or sorted(
        {m for stem in stems for m in read_fits(args.fits / f"ngan_{stem}.fit")
         if (args.tables / f"{m}.binary").exists()})
    print("| material | model | evaluation | model string | M1 | image | Ngan's L2 |")
    print("|---|---|---|---|---|---|---|")
    rows = []
    for material in materials:
        for r in compare(material, stems, args.fits, args.tables, fit_ours=not args.published_only,
                         results=args.results, log_behind=args.log_behind):
            rows.append(r)
            print(f"| {r['material']} | {r['model']} | {r['label']} | `{r['spec']}` | {r['m1']:.4f} | "
                  f"{r['image']:.4f} | {r['ngan']:.4f} |", flush=True)
    if args.results is not None:
        print()
        print("\n".join(summary(rows)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
