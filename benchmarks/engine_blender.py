"""Blender Cycles as a judge: the shipped glTF material as Blender 5 imports and renders it, against the measured table.

    python benchmarks/engine_blender.py TABLE_OR_DIR... [--glb-dir DIR] [--work DIR] [--json OUT] [--three-json ROWS]
    python benchmarks/engine_blender.py --sanity        (a plain dielectric and a plain metal: Cycles against the spec)

Blender runs in its own Python (``make blender``: pip's bpy 5.0.1 in .venv-blender; bpy pins
numpy < 2, and installed beside the toolkit it downgrades numpy, JAX and nlopt until fitting
fails), as a subprocess (benchmarks/blender_scene.py); ``--blender-python`` or
$BRDF_BLENDER_PYTHON names another interpreter with bpy.

The shipped material of each table is found as benchmarks/engine_three.py finds it (``--glb-dir``,
else ``brdf-fit export`` into WORK, kept and reused), and the scene and the error are that
judge's (its ``judge_error``, ``scene_pairs``, ``measured_images`` and ``spec_images`` are used
here): a unit sphere seen orthographically along +z, SIZE x SIZE pixel centres, one directional
light of irradiance 1 at a time from +x at ELEVATIONS degrees above the image plane, black
background, no tone mapping.  Blender's image: the .glb imported by Blender's bundled glTF
importer, its material as imported on a grid mesh whose vertices sit on the pixel centres with
the exact sphere normals (custom normals), rendered by Cycles on the CPU (a sun of strength 1 and
angle 0, direct light only, rays through the pixel centres, view transform Standard, look None,
exposure 0, read back from a float32 OpenEXR): blender_scene.py's docstring says it all.  The
normals Cycles shaded with are read back and compared with the sphere's.

Each row: the error (``judge_error``) of the spec's, Blender's and (from ``--three-json``,
engine_three.py's rows) three.js's image against the measured one; Blender's against the spec's;
the noise (Blender's image rendered with a second seed, judged against the first); where the
difference comes from: Blender with its multiple-scattering GGX and its metals' F82 edge tint
taken out of the imported material (blender_scene.VARIANTS), and the spec read the way the
importer reads the file (``blender_reading``: specularFactor becomes Specular IOR Level, which
scales F0 and leaves F90 at 1; KHR_materials_diffuse_roughness dropped); the importer's Principled
BSDF inputs, as imported.
The in-plane error: the same error on the disc pixels of the row just above the centre
(normals within 0.45 deg of the plane of the light and the view, so each light gives an in-plane
curve), with theta_i and theta_o up to 80 degrees; ``--curves DIR`` plots those curves.
"""

import argparse
import json
import os
import pathlib
import statistics
import subprocess
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
for _path in (ROOT, ROOT / "tests", ROOT / "benchmarks"):
    if str(_path) not in sys.path:
        sys.path.insert(0, str(_path))

from engine_three import (ELEVATIONS, SANITY, SIZE, difference_row, glb_material, judge_error,  # noqa: E402
                          light_direction, measured_images, measured_tables, scene_pairs, shipped_glb,
                          spec_images, write_rows)

SAMPLES = 16                    # Cycles samples per pixel (a delta light, direct light only: the noise is measured)
SEEDS = (0, 1)                  # the second seed's image measures the noise
VARIANTS = ("shipped", "single_ggx", "plain_metal", "single_ggx+plain_metal")    # blender_scene.VARIANTS
SANITY_METAL = {"base_color": [0.95, 0.64, 0.54], "metallic": 1.0, "roughness": 0.3}   # a plain copper-like metal
IN_PLANE_MAX = 80.0             # degrees: theta_i and theta_o of the in-plane curves


def blender_python(given=None):
    """The interpreter with bpy: ``given``, $BRDF_BLENDER_PYTHON, or .venv-blender's (``make blender``)."""
    path = given or os.environ.get("BRDF_BLENDER_PYTHON") or ROOT / ".venv-blender" / "bin" / "python"
    return pathlib.Path(path)


def blender_available(python=None):
    """True when ``blender_python(python)`` exists and imports bpy."""
    path = blender_python(python)
    if not path.exists():
        return False
    return subprocess.run([str(path), "-c", "import bpy"], capture_output=True).returncode == 0


def blender_images(glbs, size, elevations, work, python=None, samples=SAMPLES, seeds=SEEDS, variants=VARIANTS):
    """Run blender_scene.py on ``glbs`` ({name: .glb}); returns (images {name: {variant: (L, size, size, 4)}},
    images of the second seed {name: ...}, normals (size, size, 4), info (blender.json))."""
    out = pathlib.Path(work) / "blender"
    out.mkdir(parents=True, exist_ok=True)
    for old in out.glob("*.npy"):
        old.unlink()
    config = {"size": size, "lights": [light_direction(e).tolist() for e in elevations], "samples": samples,
              "seeds": list(seeds), "variants": list(variants), "out": str(out), "normals": True,
              "materials": {name: str(glb) for name, glb in glbs.items()}}
    (out / "config.json").write_text(json.dumps(config, indent=1))
    run = subprocess.run([str(blender_python(python)), str(ROOT / "benchmarks" / "blender_scene.py"),
                          str(out / "config.json")], capture_output=True, text=True)
    if run.returncode != 0:
        raise RuntimeError(f"blender_scene.py failed ({run.returncode}):\n{run.stderr[-3000:]}")
    images = {name: {v: np.load(out / f"{name}.{v}.{seeds[0]}.npy") for v in variants} for name in glbs}
    second = {name: np.load(out / f"{name}.shipped.{seeds[1]}.npy") for name in glbs} if len(seeds) > 1 else {}
    return images, second, np.load(out / "normals.npy"), json.loads((out / "blender.json").read_text())


def pixels(image, index):
    """(L, size, size, 4), row 0 at the bottom (Blender's) -> (L, P, 3) at the disc's pixels (row 0 at the top)."""
    return image[:, ::-1].reshape(image.shape[0], -1, 4)[:, index, :3].astype(np.float64)


def normal_check(normals_image, index, normals):
    """(largest, 99th percentile) angle in degrees between the normal Cycles shaded a disc pixel with and the
    exact sphere normal."""
    n = normals_image[::-1].reshape(-1, 4)[index, :3].astype(np.float64) * 2.0 - 1.0
    n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)
    angle = np.degrees(np.arcsin(np.clip(np.linalg.norm(np.cross(n, normals), axis=-1), 0.0, 1.0)))
    return float(angle.max()), float(np.percentile(angle, 99))


def blender_reading(model, params, inputs=None):
    """(model, parameters) of the spec as Blender's importer reads the file, or None when it reads it as
    written.  specularFactor becomes Specular IOR Level, which scales F0 (with the colour, Specular Tint)
    and leaves F90 at 1: the glTF BRDF with specular = 1 and specularColorFactor x specularFactor draws
    that.  KHR_materials_diffuse_roughness is dropped by Blender 5.0.1's importer (Diffuse Roughness
    left at 0, Lambert; ``inputs``, the imported Principled BSDF's, say so): the model without it."""
    read, changed = dict(params), False
    if read.get("specular", 1.0) != 1.0:
        read.update(specular=1.0, specular_color=[c * params["specular"] for c in params["specular_color"]])
        changed = True
    if "diffuse_roughness" in read and (inputs or {}).get("Diffuse Roughness", 0.0) == 0.0:
        del read["diffuse_roughness"]
        model = "+".join(t for t in model.split("+") if t != "diffuse_roughness")
        changed = True
    return (model, read) if changed else None


def in_plane(size, normals, cos_i, max_theta=IN_PLANE_MAX):
    """(L, P) mask of the in-plane pixels: the disc pixels of the row just above the centre (normal's
    y = 1 / size), theta_o and theta_i up to ``max_theta`` degrees."""
    row = np.isclose(normals[:, 1], 1.0 / size)
    cut = np.cos(np.radians(max_theta)) - 1e-12
    return row[None, :] & (normals[None, :, 2] >= cut) & (cos_i >= cut)


def judge(tables, glb_dir, work, size=SIZE, elevations=ELEVATIONS, python=None, samples=SAMPLES, three=None,
          curves=None):
    """A row per table (module docstring); ``three``: engine_three.py's rows, by material."""
    from data_loaders import load
    work = pathlib.Path(work)
    work.mkdir(parents=True, exist_ok=True)
    glbs = {pathlib.Path(t).stem: shipped_glb(t, glb_dir, work) for t in tables}
    images, second, normals_image, info = blender_images(glbs, size, elevations, work, python, samples)
    index, normals, wi, wo, cos_i = scene_pairs(size, elevations)
    largest, p99 = normal_check(normals_image, index, normals)
    print(f"Blender {info['blender']}: normals within {largest:.2e} deg of the sphere's ({p99:.2e} for 99 %)",
          file=sys.stderr)
    plane = in_plane(size, normals, cos_i)
    rows = []
    for table in tables:
        name = pathlib.Path(table).stem
        measured = load(table)
        meas, valid = measured_images(measured, wi, wo, cos_i)
        model, params = glb_material(glbs[name])
        spec = spec_images(model, params, wi, wo, cos_i)
        drawn = {v: pixels(images[name][v], index) for v in VARIANTS}
        blender = drawn["shipped"]
        row = {"material": measured.material, "table": str(table), "glb": str(glbs[name]), "model": model,
               "parameters": params, "principled": info["materials"][name], "blender_version": info["blender"],
               "samples": samples, "valid_pixels": [int(v.sum()) for v in valid],
               "spec": judge_error(meas, spec, valid),
               "blender": judge_error(meas, blender, valid),
               "blender_vs_spec": judge_error(spec, blender, valid),
               "noise": judge_error(blender, pixels(second[name], index), valid) if second else None,
               "variants": {v: judge_error(meas, drawn[v], valid) for v in VARIANTS if v != "shipped"},
               "variants_vs_spec": {v: judge_error(spec, drawn[v], valid) for v in VARIANTS if v != "shipped"},
               "in_plane": {"spec": judge_error(meas, spec, valid & plane),
                            "blender": judge_error(meas, blender, valid & plane),
                            "pixels": int((valid & plane).sum())}}
        reading = blender_reading(model, params, info["materials"][name]["inputs"])
        if reading:
            read = spec_images(*reading, wi, wo, cos_i)
            row["spec_as_blender_reads"] = judge_error(meas, read, valid)
            row["blender_vs_spec_as_blender_reads"] = judge_error(read, blender, valid)
        if three and measured.material in three:
            row["three"] = three[measured.material]["three"]
            if "abc" in three[measured.material]:
                row["abc"] = three[measured.material]["abc"]
        rows.append(row)
        if curves:
            plot_curves(pathlib.Path(curves) / f"{name}.png", measured.material, normals, cos_i, valid & plane,
                        {"measured": meas, "spec": spec, "Blender": blender}, elevations)
        print(f"  {name}: spec {row['spec']:.4f}  Blender {row['blender']:.4f}  noise {row['noise']:.1e}",
              file=sys.stderr)
    return rows


def plot_curves(path, title, normals, cos_i, mask, images, elevations):
    """Radiance (green channel, log scale) along the in-plane row against the signed theta_o, one panel a light."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    path.parent.mkdir(parents=True, exist_ok=True)
    theta_o = np.degrees(np.arctan2(normals[:, 0], normals[:, 2]))      # signed: + towards the light
    fig, axes = plt.subplots(1, len(elevations), figsize=(4 * len(elevations), 3.2), sharey=True)
    for k, (ax, e) in enumerate(zip(np.atleast_1d(axes), elevations)):
        order = np.argsort(theta_o[mask[k]])
        for label, image in images.items():
            ax.semilogy(theta_o[mask[k]][order], image[k, mask[k], 1][order], label=label)
        ax.set_title(f"light {e:g} deg above the image plane")
        ax.set_xlabel("theta_o (deg, + towards the light)")
    np.atleast_1d(axes)[0].set_ylabel("radiance (G)")
    np.atleast_1d(axes)[0].legend()
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def sanity(work, size=SIZE, elevations=ELEVATIONS, python=None, samples=SAMPLES):
    """A plain dielectric and a plain metal glTF: Cycles's radiance against the spec's, as imported and with
    the variants (the same table as engine_three.py's --sanity)."""
    from brdf_fit.export.gltf import export_gltf
    from fitting.result import FitResult
    work = pathlib.Path(work) / "sanity"
    work.mkdir(parents=True, exist_ok=True)
    glbs = {}
    for name, params in (("sanity-dielectric", SANITY), ("sanity-metal", SANITY_METAL)):
        result = FitResult(spec="gltf", parameters=params, errors={"m1": 0.0}, optimizer={"max_theta": 80.0},
                           provenance={"file": None, "sha256": None, "format": None, "material": name})
        export_gltf(result, work / f"{name}.glb")
        glbs[name] = work / f"{name}.glb"
    images, second, normals_image, info = blender_images(glbs, size, elevations, work, python, samples)
    index, normals, wi, wo, cos_i = scene_pairs(size, elevations)
    largest, p99 = normal_check(normals_image, index, normals)
    lit = cos_i > 0.0
    within = lit & (normals[None, :, 2] >= np.cos(np.radians(80.0)) - 1e-12)      # the toolkit's image error's cut
    print(f"Blender {info['blender']}, Cycles CPU, {samples} samples; normals within {largest:.2e} deg "
          f"({p99:.2e} for 99 % of the disc pixels)")
    for name, glb in glbs.items():
        model, params = glb_material(glb)
        spec = spec_images(model, params, wi, wo, cos_i)
        noise = judge_error(pixels(images[name]["shipped"], index), pixels(second[name], index), lit)
        print(f"\n{name}: {model} {params}; the importer's Principled BSDF: "
              f"{json.dumps(info['materials'][name]['inputs'])}\nnoise (2nd seed against the 1st): {noise:.2e}\n")
        print("| Blender, variant | max abs. difference | where (n_z, light) | max relative (radiance > 1 %) "
              "| where (n_z) | mean signed | 2nd image error vs spec | the same within 80 deg of the view |")
        print("|---|---|---|---|---|---|---|---|")
        for variant in VARIANTS:
            got = pixels(images[name][variant], index)
            print(difference_row(variant, got, spec, lit, normals, elevations)
                  + f" {judge_error(spec, got, within):.2e} |")
        print(f"(radiance up to {spec.max():.3f})")


def _median(values):
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else float("nan")


def show(rows):
    """The markdown tables and the medians."""
    three = any("three" in r for r in rows)
    print("| material | shipped model | spec | Blender | Blender / spec | Blender vs spec | "
          + ("three.js | ABC | " if three else "") + "noise | in-plane: spec | in-plane: Blender |")
    print("|---|---|---|---|---|---|" + ("---|---|" if three else "") + "---|---|---|")
    for r in rows:
        print(f"| {r['material']} | {r['model']} | {r['spec']:.4f} | {r['blender']:.4f} "
              f"| {r['blender'] / r['spec']:.2f} | {r['blender_vs_spec']:.4f} | "
              + (f"{r.get('three', float('nan')):.4f} | {r.get('abc', float('nan')):.4f} | " if three else "")
              + f"{r['noise']:.1e} | {r['in_plane']['spec']:.4f} | {r['in_plane']['blender']:.4f} |")
    print(f"| **median** | | {_median(r['spec'] for r in rows):.4f} | {_median(r['blender'] for r in rows):.4f} "
          f"| {_median(r['blender'] / r['spec'] for r in rows):.2f} "
          f"| {_median(r['blender_vs_spec'] for r in rows):.4f} "
          f"| " + (f"{_median(r.get('three') for r in rows):.4f} | {_median(r.get('abc') for r in rows):.4f} | "
                   if three else "")
          + f"{max(r['noise'] for r in rows):.1e} (max) | {_median(r['in_plane']['spec'] for r in rows):.4f} "
          f"| {_median(r['in_plane']['blender'] for r in rows):.4f} |")
    print("\nWhere Blender's difference from the spec comes from: Blender's error against the measurement with one "
          "of its differences taken out of the imported material, and the spec read as the importer reads it:\n")
    print("| material | Blender | without multiple scattering | without the metals' F82 tint | without both "
          "| spec | spec as Blender's importer reads it | Blender without both vs spec "
          "| Principled: Specular IOR Level, Specular Tint, Metallic, Coat Weight |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        p = r["principled"]["inputs"]
        tint = ", ".join(f"{c:.3g}" for c in p["Specular Tint"][:3])
        read = r.get("spec_as_blender_reads")
        print(f"| {r['material']} | {r['blender']:.4f} | {r['variants']['single_ggx']:.4f} "
              f"| {r['variants']['plain_metal']:.4f} | {r['variants']['single_ggx+plain_metal']:.4f} | {r['spec']:.4f} "
              f"| {'-' if read is None else f'{read:.4f}'} "
              f"| {r['variants_vs_spec']['single_ggx+plain_metal']:.4f} | {p['Specular IOR Level']:.3g}, ({tint}), "
              f"{p['Metallic']:.3g}, {p['Coat Weight']:.3g} |")
    ratio = [r["blender"] / r["spec"] for r in rows]
    with_abc = [r for r in rows if "abc" in r]
    if with_abc:
        print(f"\nat or below ABC: Blender {sum(r['blender'] <= r['abc'] for r in with_abc)} of {len(with_abc)}, "
              f"three.js {sum(r['three'] <= r['abc'] for r in with_abc)}, "
              f"the spec {sum(r['spec'] <= r['abc'] for r in with_abc)}")
    print(f"\nBlender / spec above 1.1: {sum(x > 1.1 for x in ratio)} of {len(rows)}; "
          f"without multiple scattering: {sum(r['variants']['single_ggx'] > 1.1 * r['spec'] for r in rows)}; "
          f"without both: {sum(r['variants']['single_ggx+plain_metal'] > 1.1 * r['spec'] for r in rows)}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("tables", nargs="*", help="measured tables, or folders of them (*.binary)")
    parser.add_argument("--glb-dir", help="the shipped .glb files, named after the tables (MATERIAL.glb)")
    parser.add_argument("--work", default="engine-blender", help="exported .glb files and Blender's renders")
    parser.add_argument("--json", help="write the rows here")
    parser.add_argument("--three-json", help="engine_three.py's --json rows of the same .glb files: a three.js column")
    parser.add_argument("--curves", help="write the in-plane curves here (a PNG per table)")
    parser.add_argument("--sanity", action="store_true", help="a plain dielectric and metal: Cycles against the spec")
    parser.add_argument("--size", type=int, default=SIZE)
    parser.add_argument("--samples", type=int, default=SAMPLES)
    parser.add_argument("--blender-python", help="a Python with bpy (default: $BRDF_BLENDER_PYTHON, .venv-blender)")
    args = parser.parse_args(argv)
    if not blender_available(args.blender_python):
        parser.error(f"no bpy at {blender_python(args.blender_python)}: run `make blender` (or --blender-python)")
    if args.sanity:
        sanity(args.work, args.size, python=args.blender_python, samples=args.samples)
        return 0
    tables = measured_tables(args.tables, parser)
    three = None
    if args.three_json:
        three = {r["material"]: r for r in json.loads(pathlib.Path(args.three_json).read_text())}
    rows = judge(tables, args.glb_dir, args.work, args.size, python=args.blender_python, samples=args.samples,
                 three=three, curves=args.curves)
    show(rows)
    write_rows(rows, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
