"""MaterialX as a judge: fits of the OpenPBR models written as .mtlx, drawn by MaterialX's own GLSL.

    python benchmarks/engine_materialx.py TABLE_OR_DIR... --results DIR [--work DIR] [--json OUT]

For each measured table (MATERIAL.binary) and each fit of ``openpbr+metal`` or
``openpbr+nonmetal`` of it in ``--results`` (RESULT.json files whose provenance sha256 is the
table's; make them with ``brdf-fit fit TABLE --model openpbr+metal,openpbr+nonmetal --out DIR``):
the fit is written with ``export_materialx`` (WORK/MATERIAL.MODEL.mtlx; its ``open_pbr_surface``
carries the fitted values 1:1), and its ``open_pbr_surface`` material is drawn by MaterialX's
generated GLSL (shaders/materialx_render.py: direct lights only, linear float radiance) on
benchmarks/engine_three.py's lit sphere (``scene_pairs``, ``ELEVATIONS``, ``SIZE``), beside the
toolkit's JAX model of the fit (engine_three's ``spec_images``) and the table's own lookup
(``measured_images``).  Each row: engine_three's ``judge_error`` (issue 59's second image
error) against the measured image of MaterialX's render and of the spec, their ratio, and the
two renders against each other (the judge's error of MaterialX's image with the spec's as
reference, and their largest relative difference over the lit pixels brighter than 1 % of the
spec's maximum), and MaterialX's render against the spec with MaterialX's GGX energy
compensation applied (``compensated_images``; tests/test_materialx_render.py: they agree to 2e-5
on its materials).
"""

import argparse
import hashlib
import pathlib
import statistics
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
for _path in (ROOT, ROOT / "benchmarks"):
    if str(_path) not in sys.path:
        sys.path.insert(0, str(_path))

from engine_three import (ELEVATIONS, SIZE, judge_error, light_direction, measured_images,  # noqa: E402
                          measured_tables, scene_pairs, spec_images, write_rows)

MODELS = ("openpbr+metal", "openpbr+nonmetal")


def fits_of(results_dir):
    """{table sha256: [FitResult of an OpenPBR model, ...]} of the RESULT.json files in a folder."""
    from fitting.result import FitResult
    found = {}
    for path in sorted(pathlib.Path(results_dir).glob("*.json")):
        try:
            result = FitResult.load(path)
        except Exception as err:  # noqa: BLE001 - a folder may hold other JSON
            print(f"  {path.name}: skipped ({err})", file=sys.stderr)
            continue
        if result.spec in MODELS:
            found.setdefault((result.provenance or {}).get("sha256"), []).append(result)
    return found


def _ess_and_fresnel(spec, params, wi, wo):
    """(Ess (L, P), E at the model's F0 (L, P) or None, the lobe's Fresnel F(v.h) (L, P, 3)), float64."""
    import jax
    import jax.numpy as jnp

    from brdf.fresnel import f0_from_ior, fresnel_dielectric
    from brdf.openpbr import fresnel_f82, ggx_dir_albedo
    with jax.enable_x64(True):
        alpha = params["roughness"] ** 2
        h = wi + wo
        h /= np.linalg.norm(h, axis=-1, keepdims=True)
        v_dot_h, n_dot_v = np.sum(wo * h, axis=-1), wo[..., 2]
        ess = np.asarray(ggx_dir_albedo(jnp.asarray(n_dot_v), alpha, 1.0))
        if spec == "openpbr+metal":
            f = np.asarray(fresnel_f82(jnp.asarray(params["base_color"]), jnp.asarray(params["specular_color"]),
                                       jnp.asarray(v_dot_h)))
            return ess, None, f
        ior = params["specular_ior"]
        e = np.asarray(ggx_dir_albedo(jnp.asarray(n_dot_v), alpha, float(f0_from_ior(ior))))
        f = np.asarray(fresnel_dielectric(jnp.asarray(v_dot_h), ior))[..., None] * np.ones(3)
        return ess, e, f


def compensated_images(spec, params, wi, wo, cos_i):
    """(the radiance MaterialX's genglsl should draw (L, P, 3), its compensation comp (L, P, 3),
    the spec's image): the toolkit's OpenPBR model with MaterialX's GGX energy compensation,
    mx_ggx_energy_compensation (Turquin 2019, eq. 14 and 16): comp = 1 + F (1 - Ess) / Ess,
    Ess = mx_ggx_dir_albedo(n.v, alpha, 1, 1), F the lobe's Fresnel at v.h; the lobe times comp,
    and the non-metal's diffuse under 1 - E comp instead of 1 - E (mx_dielectric_bsdf's
    throughput).  E and Ess by brdf.openpbr.ggx_dir_albedo (MaterialX's analytic fit), the
    lobe alone as the model at base_color 0."""
    plain = spec_images(spec, params, wi, wo, cos_i)
    ess, e, f = _ess_and_fresnel(spec, params, wi, wo)
    comp = 1.0 + f * ((1.0 - ess) / ess)[..., None]
    if spec == "openpbr+metal":
        return plain * comp, comp, plain
    lobe = spec_images(spec, {**params, "base_color": [0.0, 0.0, 0.0]}, wi, wo, cos_i)
    throughput = (1.0 - e[..., None] * comp) / (1.0 - e[..., None])
    return lobe * comp + (plain - lobe) * throughput, comp, plain


def materialx_image(result, measured, work, normals, cos_i, size, elevations):
    """The fit written as .mtlx and its open_pbr_surface as MaterialX's GLSL draws it (L, P, 3),
    zero where the light is below the horizon (as the spec's image)."""
    from brdf_fit.export.materialx_file import export_materialx
    from shaders.materialx_render import materialx_radiance
    path = pathlib.Path(work) / f"{pathlib.Path(result.provenance['file']).stem}.{result.spec}.mtlx"
    info = export_materialx(result, path, measured=measured, just_fitted=True)
    (name,) = [m for m, category in info["materials"].items() if category == "open_pbr_surface"]
    radiance = materialx_radiance(path, name, normals, [light_direction(e) for e in elevations])
    return np.where(cos_i[..., None] > 0.0, radiance, 0.0), path


def judge(tables, results_dir, work, size=SIZE, elevations=ELEVATIONS):
    from data_loaders import load
    work = pathlib.Path(work)
    work.mkdir(parents=True, exist_ok=True)
    fits = fits_of(results_dir)
    _, normals, wi, wo, cos_i = scene_pairs(size, elevations)
    lit = cos_i > 0.0
    rows = []
    for table in tables:
        sha = hashlib.sha256(pathlib.Path(table).read_bytes()).hexdigest()
        if not fits.get(sha):
            print(f"  {pathlib.Path(table).name}: no OpenPBR fit in {results_dir}", file=sys.stderr)
            continue
        measured = load(table)
        meas, valid = measured_images(measured, wi, wo, cos_i)
        for result in sorted(fits[sha], key=lambda r: r.spec):
            spec = spec_images(result.spec, result.parameters, wi, wo, cos_i)
            mx, path = materialx_image(result, measured, work, normals, cos_i, size, elevations)
            bright = lit[..., None] & (spec > 0.01 * spec.max())
            rel = np.abs(mx - spec)[bright] / spec[bright]
            want, _, _ = compensated_images(result.spec, result.parameters, wi, wo, cos_i)
            rel_comp = np.abs(mx - want)[bright] / want[bright]
            row = {"material": measured.material, "table": str(table), "model": result.spec, "mtlx": str(path),
                   "parameters": result.parameters, "m1": result.errors.get("m1"),
                   "spec": judge_error(meas, spec, valid), "materialx": judge_error(meas, mx, valid),
                   "materialx_vs_spec": judge_error(spec, mx, lit),
                   "max_relative_vs_spec": float(rel.max()),
                   "mean_ratio_vs_spec": float(mx[lit].sum() / spec[lit].sum()),
                   "max_relative_vs_compensated": float(rel_comp.max())}
            rows.append(row)
            print(f"  {measured.material} {result.spec}: spec {row['spec']:.4f}  MaterialX {row['materialx']:.4f}",
                  file=sys.stderr)
    return rows


def show(rows):
    print("| material | model | roughness | spec | MaterialX | MaterialX / spec | MaterialX vs spec "
          "| max relative difference | radiance ratio | max relative vs spec x comp |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['material']} | {r['model']} | {r['parameters']['roughness']:.3f} | {r['spec']:.4f} "
              f"| {r['materialx']:.4f} | {r['materialx'] / r['spec']:.3f} | {r['materialx_vs_spec']:.4f} "
              f"| {r['max_relative_vs_spec']:.3f} | {r['mean_ratio_vs_spec']:.3f} "
              f"| {r['max_relative_vs_compensated']:.1e} |")
    for model in MODELS:
        some = [r for r in rows if r["model"] == model]
        if some:
            print(f"| **median** | {model} | | {statistics.median(r['spec'] for r in some):.4f} "
                  f"| {statistics.median(r['materialx'] for r in some):.4f} "
                  f"| {statistics.median(r['materialx'] / r['spec'] for r in some):.3f} "
                  f"| {statistics.median(r['materialx_vs_spec'] for r in some):.4f} | | | |")
    print("\nmax relative difference: over the lit pixels where the spec is above 1 % of its maximum; "
          "radiance ratio: MaterialX's radiance summed over the lit pixels / the spec's; spec x comp: "
          "the spec with MaterialX's GGX energy compensation (compensated_images)")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("tables", nargs="+", help="measured tables, or folders of them (*.binary)")
    parser.add_argument("--results", required=True, help="a folder of RESULT.json fits of the OpenPBR models")
    parser.add_argument("--work", default="engine-materialx", help="where the .mtlx documents are written")
    parser.add_argument("--json", help="write the rows here")
    parser.add_argument("--size", type=int, default=SIZE)
    args = parser.parse_args(argv)
    rows = judge(measured_tables(args.tables, parser), args.results, args.work, args.size)
    show(rows)
    write_rows(rows, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
