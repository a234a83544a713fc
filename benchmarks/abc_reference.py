"""The published ABC fits (Loew et al. 2012) as a reference on the ten dev tables.

    python benchmarks/abc_reference.py [TABLE...] --out DIR [--tag after] [--auto] [--fit-only]
    python benchmarks/abc_reference.py --out DIR --show TAG [TAG...]
    python benchmarks/abc_reference.py [TABLE...] --out DIR --pictures DIR [--show BEFORE AFTER]
    python benchmarks/abc_reference.py --synthetic [MODEL...]
    python benchmarks/abc_reference.py TABLE... --out DIR --methods --shipped   (the shipped glTF, per category)

ABC is not an engine model (its NDF is not normalised, its Fresnel is exact);
it is evaluated here, from ../shared/measured/abc-low2012/ (README: the
formula; dj_brdf's ``abc::eval``), on the same full sample set and the same
image scene as every fit: M1, the image error at the viewer's exposure and
at the fixed exposure 1 (docs/metrics.md).  Beside it, fitted here (saved as
DIR/TAG/METHOD/MATERIAL.json, resumable): export-first (the glTF family with
the command line's default hybrid loss, the material ``brdf-fit export``
writes), ``ggx+lambert`` with ``--loss log`` and with the default hybrid loss,
and with --auto ``auto``'s winner (staged, as ``brdf-fit fit --model auto``).  The errors are always computed by
the code running now from the saved parameters, so fits made by an older
checkout (``--fit-only`` with its PYTHONPATH) are judged by today's metric.
"""

import argparse
import csv
import json
import pathlib
import statistics
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
# the 80 materials' fits (the ten dev tables' rows are the same in abc_dev.csv, checked)
ABC_CSV = ROOT.parent / "shared" / "measured" / "abc-low2012" / "abc_wide.csv"
ABC_DEV_CSV = ABC_CSV.with_name("abc_dev.csv")      # the ten dev materials alone
DEV_TABLES = pathlib.Path("/work/devtables")
METHODS = ("export-first", "ggx+lambert log", "ggx+lambert hybrid", "auto", "auto log", "shipped", "converted",
           "shipped log")
# judged by the glTF material they write (the others by the fitted model itself)
EXPORTED = ("export-first", "shipped", "converted", "shipped log")


def abc_parameters(path=ABC_CSV):
    """{material: {"kd": (3,), "a": (3,), "b", "c", "ior"}} from the published table."""
    out = {}
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            out[row["material"]] = {"kd": np.array([float(row[f"kD_{c}"]) for c in "rgb"]),
                                    "a": np.array([float(row[f"A_{c}"]) for c in "rgb"]),
                                    "b": float(row["B"]), "c": float(row["C"]), "ior": float(row["ior"])}
    return out


def fresnel_dielectric(c, eta):
    """Unpolarised Fresnel reflectance of a dielectric of index ``eta`` at cos ``c`` (REFERENCE.md 3)."""
    g2 = eta * eta - 1.0 + c * c
    g = np.sqrt(np.maximum(g2, 0.0))
    a = ((g - c) / (g + c)) ** 2
    b = ((c * (g + c) - 1.0) / (c * (g - c) + 1.0)) ** 2
    return np.where(g2 < 0.0, 1.0, 0.5 * a * (1.0 + b))


def abc_brdf(p, n_dot_l, n_dot_v, n_dot_h, v_dot_h):
    """The ABC BRDF (N, 3) in 1/sr, no cosine, 0 below the horizon (the README's formula)."""
    nl, nv, nh, vh = (np.asarray(x, np.float64) for x in (n_dot_l, n_dot_v, n_dot_h, v_dot_h))
    above = (nl > 0.0) & (nv > 0.0)
    nl_, nv_ = np.where(above, nl, 1.0), np.where(above, nv, 1.0)
    vh_ = np.maximum(vh, 1e-12)
    d = p["a"][None, :] / (1.0 + p["b"] * (1.0 - nh[:, None])) ** p["c"]
    g = np.minimum(1.0, np.minimum(2.0 * nh * nl_ / vh_, 2.0 * nh * nv_ / vh_))
    f = fresnel_dielectric(np.clip(vh, 0.0, 1.0), p["ior"])
    spec = (f * g / (np.pi * nl_ * nv_))[:, None] * d
    return np.where(above[:, None], p["kd"][None, :] / np.pi + spec, 0.0)


# ICtCp (ITU-R BT.2100) and Delta E_ITP (ITU-R BT.2124) of the tone-mapped images, shown on
# an SDR display whose white is DISPLAY_WHITE cd/m^2: a check of the image error's per-pixel
# difference (sRGB RMS per channel) against the colour difference the issue cites.
DISPLAY_WHITE = 100.0
BT709_TO_BT2020 = np.array([[0.6274, 0.3293, 0.0433], [0.0691, 0.9195, 0.0114], [0.0164, 0.0880, 0.8956]])
RGB_TO_LMS = np.array([[1688, 2146, 262], [683, 2951, 462], [99, 309, 3688]]) / 4096
LMS_TO_ICTCP = np.array([[2048, 2048, 0], [6610, -13613, 7003], [17933, -17390, -543]]) / 4096


def _pq(y):
    """The PQ inverse EOTF (SMPTE ST 2084) of absolute luminance y in cd/m^2."""
    m1, m2, c1, c2, c3 = 2610 / 16384, 2523 / 4096 * 128, 3424 / 4096, 2413 / 4096 * 32, 2392 / 4096 * 32
    x = np.clip(y / 10000.0, 0.0, None) ** m1
    return ((c1 + c2 * x) / (1.0 + c3 * x)) ** m2


def ictcp(srgb):
    """(I, T, P) of sRGB-encoded display pixels (..., 3); T = Ct / 2 (BT.2124)."""
    srgb = np.asarray(srgb, np.float64)
    linear = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
    itp = _pq(DISPLAY_WHITE * linear @ BT709_TO_BT2020.T @ RGB_TO_LMS.T) @ LMS_TO_ICTCP.T
    return itp * np.array([1.0, 0.5, 1.0])


def delta_e_itp(a, b, mask):
    """Mean Delta E_ITP = 720 |ITP_a - ITP_b| over the masked pixels (1 ~ a just noticeable difference)."""
    d = 720.0 * np.linalg.norm(ictcp(a) - ictcp(b), axis=-1)
    mask = np.asarray(mask) > 0
    return float(np.mean(d[mask]))


def image_numbers(f, target, fixed):
    """(the image error at ``target``'s exposure, at ``fixed``'s, the mean Delta E_ITP at
    ``target``'s, the second round's image error: sRGB per channel at ``fixed``'s) of BRDF
    values ``f`` at the scene's pairs."""
    import jax.numpy as jnp

    from fitting import image_error as ie
    radiance = ie.pixel_radiance(jnp.asarray(f), target)
    numbers = [float(ie.image_value(ie.pixel_errors(radiance, t))) for t in (target, fixed)]
    model = np.asarray(ie.tone_map(np.asarray(radiance), np, float(target.exposure)))
    saved, ie.DIFFERENCE = ie.DIFFERENCE, "srgb"      # the second round's error: sRGB per channel at exposure 1
    try:
        old = float(ie.image_value(ie.pixel_errors(radiance, fixed)))
        srgb = float(ie.image_value(ie.pixel_errors(radiance, target)))     # plain sRGB, the viewer's exposure
    finally:
        ie.DIFFERENCE = saved
    return numbers[0], numbers[1], delta_e_itp(model, np.asarray(target.target), target.mask), old, srgb


def abc_at(p, geo):
    """ABC ``p``'s BRDF (N, 3) at the pairs of a brdf Geometry."""
    return abc_brdf(p, geo.n_dot_l, geo.n_dot_v, geo.n_dot_h, geo.v_dot_h)


def abc_errors(p, full, targets):
    """(M1, image error at the viewer's exposure, at the fixed exposure, Delta E_ITP, the old
    image error) of ABC ``p``."""
    geo = full.geo
    f = abc_at(p, geo)                   # reciprocal: one evaluation
    nl, nv = np.asarray(geo.n_dot_l)[:, None], np.asarray(geo.n_dot_v)[:, None]
    r1 = np.log1p(f * nl) - np.asarray(full.log_i)
    r2 = np.log1p(f * nv) - np.asarray(full.log_o)
    m1 = float(np.mean(np.sqrt(np.asarray(full.weights) @ (r1 * r1 + r2 * r2))))
    return (m1, *image_numbers(abc_at(p, targets.report.geo), targets.report, targets.fixed))


def judged_model(result, method):
    """(ModelSpec, JAX parameters) of the material a FitResult stands for (export-first: the glTF
    material written, which the glTF family's fits are)."""
    from brdf import gltf_material, parse_model
    from fitting.transforms import to_jax
    conversion = gltf_material.convert(parse_model(result.spec), result.parameters)
    model, params = ((conversion["model"], conversion["parameters"]) if method in EXPORTED
                     else (result.spec, result.parameters))
    spec = parse_model(model)
    return spec, to_jax(spec, params)


def fitted_errors(result, method, full, targets):
    """(M1, image error, fixed-exposure image error, Delta E_ITP, old image error) of ``judged_model``."""
    from brdf.model import evaluate_geometry
    from fitting.objective import full_set_errors
    spec, jparams = judged_model(result, method)
    m1 = float(np.mean(np.sqrt(full_set_errors(spec, "log", jparams, full))))
    f = np.asarray(evaluate_geometry(spec, jparams, targets.report.geo))
    return (m1, *image_numbers(f, targets.report, targets.fixed))


def run_fits(measured, folder, methods, options):
    """Fit what is missing in ``folder``/METHOD/MATERIAL.json (``options``: the hybrid fits' own)."""
    from brdf_fit.export.export_first import family_for, fit_for_export, is_export_first
    from fitting.fit import fit
    from fitting.fit_models import fit_models
    from fitting.ranking import exported_ranking_error, ranking_error
    for method in methods:
        path = folder / method / f"{measured.material}.json"
        if path.exists():
            continue
        path.parent.mkdir(parents=True, exist_ok=True)
        if method == "export-first":       # the glTF family alone
            result = fit_for_export(measured, family_for(measured.isotropic), {"loss": "hybrid", **options})[0]
        elif method == "shipped log":       # the same with every fit for M1 alone (--loss log)
            result = fit_for_export(measured, None, {"loss": "log"}, screen=True)[0]
        elif method in ("shipped", "converted"):     # export / library: auto (screened) beside the glTF family
            results = fit_for_export(measured, None, {"loss": "hybrid", **options}, screen=True)
            converted = min((r for r in results if not is_export_first(r)),        # the library before: auto's
                            key=lambda r: exported_ranking_error(r.errors))         # fits converted, best exported
            for name, result in (("shipped", results[0]), ("converted", converted)):
                (folder / name).mkdir(parents=True, exist_ok=True)
                result.save(folder / name / f"{measured.material}.json")
            print(f"  {measured.material} shipped: {results[0].spec} exported M1 "
                  f"{results[0].errors['exported_m1']:.5f}", file=sys.stderr)
            continue
        elif method.startswith("auto"):          # auto's winner by the ranking error, hybrid (default) or log
            from fitting.auto import AUTO_FAMILY
            loss = "log" if method == "auto log" else "hybrid"
            from fitting.fit_models import FIT_THREADS
            done = [o for _, o in fit_models(measured, list(AUTO_FAMILY), cut=True, screen="fit", loss=loss,
                                             threads=FIT_THREADS, **(options if loss == "hybrid" else {}))
                    if not isinstance(o, Exception)]     # as `brdf-fit fit --model auto` runs it
            result = min(done, key=lambda r: ranking_error(r.errors))
        else:
            model, loss = method.split()
            result = fit(measured, model, loss=loss, **(options if loss == "hybrid" else {}))
        result.save(path)
        print(f"  {measured.material} {method}: {result.spec} M1 {result.errors['m1']:.5f}", file=sys.stderr)


def evaluate(tables, out, tags, methods=METHODS):
    """{(tag, method): {material: (M1, image, image fixed, Delta E_ITP, old image, sRGB RMSE at the viewer's
    exposure)}}, ABC's under ("", "ABC")."""
    from data_loaders import load
    from fitting.image_error import ImageTargets
    from fitting.result import FitResult
    from fitting.samples import prepare
    abc = abc_parameters()
    rows = {}
    for table in tables:
        measured = load(table)
        full, _ = prepare(measured, samples=0)
        targets = ImageTargets.from_measured(measured)
        rows.setdefault(("", "ABC"), {})[measured.material] = abc_errors(abc[measured.material], full, targets)
        for tag in tags:
            for method in methods:
                path = out / tag / method / f"{measured.material}.json"
                if path.exists():
                    rows.setdefault((tag, method), {})[measured.material] = fitted_errors(
                        FitResult.load(path), method, full, targets)
    return rows


def show(rows, materials):
    """A markdown table per material (M1 / image error / the second round's image error (sRGB,
    exposure 1) per method), the medians, and each method's ratios to ABC."""
    abc = rows[("", "ABC")]
    names = list(rows)
    print("| material | " + " | ".join(" ".join(k).strip() for k in names) + " |")
    print("|---|" + "---|" * len(names))

    def cell(v):
        return f"{v[0]:.5f} / {v[1]:.4f} / {v[4]:.4f}"
    for m in materials:
        print(f"| {m} | " + " | ".join(cell(rows[k][m]) if m in rows[k] else "-" for k in names) + " |")
    print("| **median** | " + " | ".join(cell([statistics.median(v[i] for v in rows[k].values()) for i in range(5)])
                                        for k in names) + " |")
    print()
    for k in names[1:]:
        for i, what in ((1, "image"), (3, "mean Delta E_ITP"), (4, "old image")):
            ratios = {m: rows[k][m][i] / abc[m][i] for m in rows[k]}
            medians = statistics.median(v[i] for v in rows[k].values()) / statistics.median(
                abc[m][i] for m in rows[k])
            print(f"{' '.join(k).strip()}: {what} / ABC's: medians {medians:.3f}, per table median "
                  f"{statistics.median(ratios.values()):.3f}, max {max(ratios.values()):.3f} "
                  f"({max(ratios, key=ratios.get)})")
        m1_ratio = statistics.median(v[0] for v in rows[k].values()) / statistics.median(abc[m][0] for m in rows[k])
        print(f"{' '.join(k).strip()}: median M1 / ABC's median M1 {m1_ratio:.3f}")


# Synthetic materials for the default loss's check against --loss log (--synthetic): dark,
# saturated and specular ABC materials, and a dark, specular fabric from Bagher et al. 2012's
# Shifted Gamma Distribution fit of MERL's dark-specular-fabric (its parameters as a public GLSL
# transcription gives them): f = rho_d/pi + rho_s D G1(i) G1(o) F / (pi cos_i cos_o).
SYNTHETIC_ABC = {
    "dark-fabric-abc": dict(kd=[0.010, 0.006, 0.012], a=[0.30, 0.45, 0.60], b=1.6e6, c=0.16, ior=1.64),
    "dark-specular": dict(kd=[0.003, 0.0025, 0.002], a=[120.0, 110.0, 100.0], b=4.0e4, c=1.3, ior=1.55),
    "saturated-plastic": dict(kd=[0.55, 0.012, 0.004], a=[1.1, 1.05, 1.04], b=34.0, c=1.53, ior=1.67),
    "specular-coat": dict(kd=[0.05, 0.10, 0.02], a=[3000.0, 2900.0, 2800.0], b=2.5e5, c=1.25, ior=1.41),
}
SGD_DARK_SPECULAR_FABRIC = dict(
    rho_d=[0.0197229, 0.00949167, 0.00798414], rho_s=[0.556218, 0.401495, 0.378651],
    alpha=[0.140344, 0.106541, 0.166715], p=[0.249059, 0.177611, 0.434167],
    F0=[0.0351133, 0.0387177, 0.0370533], F1=[0.0243153, 0.0293178, 0.0264913], K=[7.60492, 9.81673, 6.19307],
    lam=[3.93869, 4.23097, 4.3775], c=[0.00122421, 0.00238545, 8.47126e-06], k=[13.889, 14.5743, 17.2049],
    theta0=[0.114655, 0.210179, -0.227628])


def sgd_brdf(q, nl, nv, nh, vh):
    """Bagher et al. 2012's SGD BRDF (N, 3), 0 below the horizon (the transcription's D, G1, F)."""
    q = {k: np.asarray(v, np.float64)[None, :] for k, v in q.items()}
    nl, nv, nh, vh = (np.asarray(x, np.float64)[:, None] for x in (nl, nv, nh, vh))
    above = (nl > 0) & (nv > 0)
    nl_, nv_ = np.where(above, nl, 1.0), np.where(above, nv, 1.0)
    c2 = np.clip(nh, 1e-6, 1.0) ** 2
    ax = q["alpha"] + (1 - c2) / c2 / q["alpha"]
    d = q["K"] * np.exp(-ax) / (ax ** q["p"] * c2 * c2) / np.pi

    def g1(c):
        t = np.maximum(np.arccos(np.clip(c, -1, 1)) - q["theta0"], 0.0)
        return np.clip(1.0 + q["lam"] * (1.0 - np.exp(q["c"] * t ** q["k"])), 0.0, None)
    f = q["F0"] - vh * q["F1"] + (1 - q["F0"]) * (1 - vh) ** 5
    return np.where(above, q["rho_d"] / np.pi + q["rho_s"] * d * g1(nl_) * g1(nv_) * f / (np.pi * nl_ * nv_), 0.0)


class _FormulaTable:
    """The lookup of a synthetic measurement: its formula, exactly."""
    methods = (None,)

    def __init__(self, brdf):
        self.brdf = brdf

    def lookup(self, wi, wo, method=None):
        wi, wo = np.asarray(wi, np.float64), np.asarray(wo, np.float64)
        h = wi + wo
        h /= np.linalg.norm(h, axis=-1, keepdims=True)
        return self.brdf(wi[:, 2], wo[:, 2], h[:, 2], np.sum(wo * h, -1))


def synthetic_measurements():
    """{name: MeasuredBRDF} of the synthetic materials, on a MERL-sized half/difference grid."""
    from data_loaders.measured import MeasuredBRDF, Provenance
    from fitting.synthetic import half_diff_grid
    wi, wo, weights = half_diff_grid(90, 90, 180, 1)
    valid = (wi[:, 2] > 0) & (wo[:, 2] > 0)
    brdfs = {name: (lambda p: lambda *g: abc_brdf(p, *g))(
        {"kd": np.array(d["kd"]), "a": np.array(d["a"]), "b": d["b"], "c": d["c"], "ior": d["ior"]})
        for name, d in SYNTHETIC_ABC.items()}
    brdfs["dark-specular-fabric-sgd"] = lambda *g: sgd_brdf(SGD_DARK_SPECULAR_FABRIC, *g)
    out = {}
    for name, brdf in brdfs.items():
        table = _FormulaTable(brdf)
        values = np.where(valid[:, None], table.lookup(wi, wo), 0.0)
        prov = Provenance(path=f"<synthetic {name}>", format="synthetic", material=name, sha256="", units="1/sr")
        out[name] = MeasuredBRDF(wi=wi, wo=wo, values=values, weights=weights, valid=valid, isotropic=True,
                                 provenance=prov, table=table)
    return out


def synthetic_check(models=("ggx+lambert",)):
    """Each model's default (hybrid) fit against its --loss log fit on the synthetic materials."""
    from fitting.fit import fit
    print("| material | model | log M1 / image | hybrid M1 / image | image ratio | M1 ratio |")
    print("|---|---|---|---|---|---|")
    for name, measured in synthetic_measurements().items():
        for model in models:
            r = {loss: fit(measured, model, loss=loss).errors for loss in ("log", "hybrid")}
            print(f"| {name} | {model} | {r['log']['m1']:.5f} / {r['log']['image']:.4f} | {r['hybrid']['m1']:.5f} / "
                  f"{r['hybrid']['image']:.4f} | {r['hybrid']['image'] / r['log']['image']:.3f} | "
                  f"{r['hybrid']['m1'] / r['log']['m1']:.3f} |", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("tables", nargs="*")
    ap.add_argument("--out", default="abc-reference")
    ap.add_argument("--tag", default="after", help="the folder of this checkout's fits")
    ap.add_argument("--auto", action="store_true", help="also fit auto's winner, hybrid and log (10-30 s a table each)")
    ap.add_argument("--methods", nargs="*", default=list(METHODS[:3]), choices=METHODS)
    ap.add_argument("--shipped", action="store_true",
                    help="fit what export and library ship (auto screened beside the glTF family) and show it "
                         "against ABC and against the library's converted material before, per category")
    ap.add_argument("--image-weight", type=float, help="the hybrid fits' image weight (default: the toolkit's)")
    ap.add_argument("--difference", choices=("srgb", "itp"),
                    help="the image error's per-pixel difference the hybrid fits minimise (default: the toolkit's)")
    ap.add_argument("--fit-only", action="store_true", help="fit and save; evaluate later")
    ap.add_argument("--show", nargs="*", help="evaluate these tags' saved fits (default: --tag)")
    ap.add_argument("--json", help="also write the numbers here")
    ap.add_argument("--pictures", metavar="DIR",
                    help="instead: write DIR/abc-gap-MATERIAL.png of the tables (default: the three whose "
                         "export-first image error over ABC's is largest in the first --show tag): measured, ABC "
                         "and each --show tag's export-first (default tags: before after)")
    ap.add_argument("--picture-method", default="export-first", choices=METHODS,
                    help="with --pictures: the method pictured beside ABC (default export-first; shipped: what "
                         "export and library ship)")
    ap.add_argument("--synthetic", nargs="*", metavar="MODEL",
                    help="instead: the default loss against --loss log on synthetic dark, saturated and specular "
                         "materials (default model: ggx+lambert)")
    args = ap.parse_args()
    import jax
    jax.config.update("jax_enable_x64", True)     # a script: the fitter's float64 throughout
    if args.synthetic is not None:
        synthetic_check(args.synthetic or ("ggx+lambert",))
        return
    tables = [pathlib.Path(t) for t in args.tables] or sorted(DEV_TABLES.glob("*.binary"))
    out = pathlib.Path(args.out)
    if args.pictures:
        from abc_pictures import write_pictures     # benchmarks/ is on sys.path when run as a script
        write_pictures(tables if args.tables else None, tables, out, args.show or ["before", "after"], args.pictures,
                       args.picture_method)
        return
    if args.show is None:
        from data_loaders import load
        from fitting import image_error
        saved = image_error.DIFFERENCE
        image_error.DIFFERENCE = args.difference or saved
        methods = list(args.methods) + (["auto", "auto log"] if args.auto else []) + (
            ["shipped"] if args.shipped else [])
        options = {} if args.image_weight is None else {"image_weight": args.image_weight}
        for table in tables:
            run_fits(load(table), out / args.tag, methods, options)
        image_error.DIFFERENCE = saved
        if args.fit_only:
            return
    rows = evaluate(tables, out, args.show or [args.tag])
    show(rows, [t.stem for t in tables])
    if "shipped" in args.methods or args.shipped:
        print()
        from abc_shipped import show_shipped     # benchmarks/ is on sys.path when run as a script
        show_shipped(rows, (args.show or [args.tag])[0])
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps({" ".join(k).strip(): v for k, v in rows.items()}, indent=1))


if __name__ == "__main__":
    main()
