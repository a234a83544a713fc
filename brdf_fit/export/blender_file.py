"""A fit of the Principled BSDF's models as a Blender material: ``brdf-fit export ... --format blender``.

Blender 4's and 5's Principled BSDF is built on the same pieces as OpenPBR Surface
(brdf/openpbr.py): a metal of Hoffman's F82-tint Fresnel (Base Color = F0, Specular Tint =
the F82 tint), a dielectric of the exact Fresnel of its IOR over a diffuse weighted by the
specular layer's directional albedo, and, with Diffuse Roughness, OpenPBR's energy-preserving
Oren-Nayar; its coat is OpenPBR's without the coat's effects on the base (brdf/principled.py).
A fit of ``openpbr+metal``, ``openpbr+nonmetal`` or a Principled model (its dielectric base,
either under Blender's coat, the base under its sheen: the set ``principled``) is written into
one Principled BSDF, value for value (``principled_inputs``), with the distribution the fit
evaluates: single-scattering "GGX", or for ``principled+metal+ms`` and ``principled+nonmetal+ms``
"Multiscatter GGX" (Blender's default for a new node, which brightens rough lobes).  What
Cycles then draws against the fitted BRDF is measured by benchmarks/engine_blender.py and
tests/test_export_blender.py, not assumed (docs/blender.md).

The file is a Python script that imports nothing of the toolkit (``blender_script``): run
inside Blender it adds the material to the open file, marked as an asset; run as
``blender --background --python MATERIAL.py -- OUT.blend`` (or with bpy's Python:
``python MATERIAL.py -- OUT.blend``) it writes a .blend holding that material alone.  With
``--out X.blend`` the export runs it itself with a Python that has bpy
(``blender_python``: $BRDF_BLENDER_PYTHON, the project's .venv-blender of ``make blender``,
or a ``blender`` executable on PATH).
"""

import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile

from brdf.model import model_string, parse_model
from brdf.openpbr_coat import open_pbr_surface_inputs
from brdf.principled import PRINCIPLED_BASES, PRINCIPLED_COATED, PRINCIPLED_MS

from .gltf_file import ExportError
from .other_kind import other_kind, other_kind_line, other_kind_numbers

SUFFIXES = (".py", ".blend")
#: open_pbr_surface input -> the Principled BSDF input (Blender 5.0's socket names) of the same value (the
#: fuzz's: principled+nonmetal+sheen's sheen, which has OpenPBR's fuzz's parameters, layered in Cycles' terms)
PRINCIPLED = {"base_color": "Base Color", "base_metalness": "Metallic", "specular_roughness": "Roughness",
              "specular_ior": "IOR", "specular_color": "Specular Tint", "base_diffuse_roughness": "Diffuse Roughness",
              "fuzz_weight": "Sheen Weight", "fuzz_color": "Sheen Tint", "fuzz_roughness": "Sheen Roughness"}
#: what the Principled BSDF holds at the value OpenPBR holds: Specular IOR Level 0.5 leaves F0 of the IOR as it is
PRINCIPLED_HELD = {"Specular IOR Level": 0.5, "Coat Weight": 0.0, "Sheen Weight": 0.0}
DISTRIBUTION = "GGX"            # single scattering, as the fit ...
MS_DISTRIBUTION = "MULTI_GGX"   # ... or Multiscatter GGX, as a principled+...+ms fit (brdf.principled.PRINCIPLED_MS)
#: the compositions written 1:1 into a Principled BSDF: the Principled BSDF's own (brdf/principled.py: its
#: dielectric base in Cycles' layering, its coat over either base) and OpenPBR's bare bases (the metal is
#: Blender's; the non-metal's values are, its layering drawn a little darker: docs/blender.md). Not
#: OpenPBR's coat: Blender's neither roughens nor darkens the base, nor inverts its IOR, as OpenPBR's does.
PRINCIPLED_COMPOSITIONS = ("openpbr", "openpbr_nonmetal", *PRINCIPLED_BASES)
#: a coated fit's parameter -> its Principled BSDF input (Coat Tint held white: PRINCIPLED_COAT_HELD)
PRINCIPLED_COAT = {"coat_weight": "Coat Weight", "coat_roughness": "Coat Roughness", "coat_ior": "Coat IOR"}
PRINCIPLED_COAT_HELD = {"Coat Tint": [1.0, 1.0, 1.0]}
SECONDS_MOST = 300.0            # a Blender run writing one .blend ...
SECONDS_A_MATERIAL = 20.0       # ... and for each material, its preview (Cycles: about 1 s)

# (Only the model strings, which parse_model has checked, are written as text: the materials' names, sources
# and values come from data and reach the script as one string literal, ``repr`` of their JSON.)
SCRIPT = '''"""Blender materials fitted by brdf-fit ({specs}), each a Principled BSDF (their names,
sources and values: MATERIALS below).

Inside Blender (Text Editor, Run Script): adds the materials to the open file, marked as assets.
From a shell: blender --background --python THIS_FILE -- OUT.blend  (a .blend of these materials alone,
each asset with a preview Cycles renders: the interface makes its own, --background does not).
"""
import json
import os
import sys
import tempfile

import bpy
import bmesh        # (after bpy: bpy's module registers it)

MATERIALS = json.loads({payload!r})
PREVIEW = 128       # pixels a side of an asset's preview


def build(entry):
    material = bpy.data.materials.new(entry["name"])
    material.use_nodes = True
    node = next(n for n in material.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    node.distribution = entry["distribution"]
    for name, value in entry["inputs"].items():
        socket = node.inputs[name]
        socket.default_value = value + [1.0] if isinstance(value, list) and len(socket.default_value) == 4 else value
    for key, value in entry["properties"].items():
        material[key] = value
    material.asset_mark()
    material.asset_data.description = entry["description"]
    for tag in entry["tags"]:
        material.asset_data.tags.new(tag)
    return material


def add(scene, name, data):
    item = bpy.data.objects.new(name, data)
    scene.collection.objects.link(item)
    return item


def previews(materials):
    """Each material's asset preview: a sphere under a sun and a dark grey sky (a new world's colour,
    0.05), seen orthographically, rendered by Cycles into a scene of its own, which is removed with
    everything it made."""
    scene = bpy.data.scenes.new("brdf-fit preview")
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 16
    scene.render.resolution_x = scene.render.resolution_y = PREVIEW
    scene.render.film_transparent = True
    scene.render.image_settings.file_format = "PNG"
    mesh = bpy.data.meshes.new("brdf-fit preview")
    shape = bmesh.new()
    bmesh.ops.create_uvsphere(shape, u_segments=64, v_segments=32, radius=1.0)
    shape.to_mesh(mesh)
    shape.free()
    mesh.shade_smooth()
    sphere = add(scene, "sphere", mesh)
    camera = add(scene, "camera", bpy.data.cameras.new("brdf-fit preview"))
    camera.location, camera.rotation_euler = (0.0, -4.0, 0.0), (1.5708, 0.0, 0.0)
    camera.data.type, camera.data.ortho_scale = "ORTHO", 2.2
    scene.camera = camera
    sun = add(scene, "sun", bpy.data.lights.new("brdf-fit preview", "SUN"))
    sun.data.energy, sun.rotation_euler = 2.0, (0.8, 0.3, -0.6)
    scene.world = bpy.data.worlds.new("brdf-fit preview")
    scene.world.use_nodes = True
    scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 1.0
    with tempfile.TemporaryDirectory() as work:
        scene.render.filepath = os.path.join(work, "preview.png")
        for material in materials:
            mesh.materials.clear()
            mesh.materials.append(material)
            bpy.ops.render.render(write_still=True, scene=scene.name)
            image = bpy.data.images.load(scene.render.filepath)
            material.preview_ensure()
            material.preview.image_size = (PREVIEW, PREVIEW)
            material.preview.image_pixels_float = image.pixels[:]
            bpy.data.images.remove(image)
    world, sun_data, camera_data = scene.world, sun.data, camera.data
    for item in (sphere, camera, sun):
        bpy.data.objects.remove(item)
    bpy.data.scenes.remove(scene)
    bpy.data.meshes.remove(mesh)
    bpy.data.cameras.remove(camera_data)
    bpy.data.lights.remove(sun_data)
    bpy.data.worlds.remove(world)
    if "Render Result" in bpy.data.images:
        bpy.data.images.remove(bpy.data.images["Render Result"])


args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if args:
    bpy.ops.wm.read_factory_settings(use_empty=True)
materials = [build(entry) for entry in MATERIALS]
if args:
    previews(materials)
    for material in materials:
        material.use_fake_user = True
    bpy.ops.wm.save_as_mainfile(filepath=args[0])
'''


def drawn_by_principled(spec: str) -> bool:
    """Whether a model's fits are written 1:1 into a Principled BSDF: OpenPBR's bare bases, the
    Principled BSDF's coat over them (``principled+metal+coat``, ``principled+nonmetal+coat``)."""
    return parse_model(spec).composition in PRINCIPLED_COMPOSITIONS


def principled_inputs(spec: str, parameters: dict) -> dict[str, float | list[float]]:
    """The Principled BSDF inputs ({socket name: value}) of a fit of an OpenPBR base or a Principled
    model (its coat: Coat Weight, Coat Roughness, Coat IOR, Coat Tint white; its sheen: Sheen Weight,
    Tint, Roughness)."""
    composition = parse_model(spec).composition
    values = open_pbr_surface_inputs(parameters, PRINCIPLED_BASES.get(composition, composition))
    out = {PRINCIPLED[key]: value for key, value in values.items() if key in PRINCIPLED}
    if values["base_metalness"] == 1.0:
        out.pop("IOR", None)                # a metal's Fresnel is its F82 form: no IOR
    else:
        out["Specular Tint"] = [1.0, 1.0, 1.0]
    if composition not in PRINCIPLED_COATED:
        return {**PRINCIPLED_HELD, **out}
    coat = {key: float(parameters[name]) for name, key in PRINCIPLED_COAT.items()}
    return {**PRINCIPLED_HELD, **out, **coat, **PRINCIPLED_COAT_HELD}


def distribution(spec: str) -> str:
    """The Principled BSDF's distribution a model is drawn with: Multiscatter GGX for ``principled+...+ms``,
    single-scattering GGX for the rest."""
    return MS_DISTRIBUTION if parse_model(spec).composition in PRINCIPLED_MS else DISTRIBUTION


def material_entry(result, other=None) -> dict[str, object]:
    """What the script makes of one fit: its name, distribution, Principled inputs, custom
    properties, asset description and tags.  ``other``: the best fit of the other kind
    (brdf_fit.export.other_kind), named with its ranking error beside the written one's."""
    prov = result.provenance or {}
    name = result.material or "material"
    inputs = principled_inputs(result.spec, result.parameters)
    errors = {k: float(result.errors[k]) for k in ("m1", "image") if k in result.errors}
    kind = "metal" if inputs["Metallic"] == 1.0 else "non-metal"
    description = (f"{name}: measured, fitted by brdf-fit with {result.spec} "
                   + " ".join(f"({k} {v:.4g})" for k, v in errors.items()))
    properties = {"brdf_fit_spec": result.spec, "brdf_fit_source": str(prov.get("file") or ""),
                  "brdf_fit_sha256": str(prov.get("sha256") or ""),
                  "brdf_fit_version": str(result.toolkit_version or ""),
                  **{f"brdf_fit_{k}": v for k, v in errors.items()}}
    if other is not None:
        numbers = other_kind_numbers(result, other)
        line = other_kind_line(kind == "metal", numbers)
        description += ". " + line[:1].upper() + line[1:]
        properties.update({"brdf_fit_ranking_error": numbers["written_ranking_error"],
                           "brdf_fit_other_kind": other.spec,
                           "brdf_fit_other_kind_ranking_error": numbers["ranking_error"]})
    return {"name": name, "distribution": distribution(result.spec), "inputs": inputs, "properties": properties,
            "description": description, "tags": ["brdf-fit", "measured", kind]}


def blender_script(results, others=None) -> str:
    """The Python script (text) that makes the Blender materials of ``results`` (one fit or a list
    of fits of OpenPBR's models; module docstring); ``others``: each one's best fit of the other
    kind or None (brdf_fit.export.other_kind), in the same order."""
    results = results if isinstance(results, list) else [results]
    others = others or [None] * len(results)
    specs = ", ".join(sorted({model_string(parse_model(r.spec)) for r in results}))
    return SCRIPT.format(specs=specs, payload=json.dumps([material_entry(r, o) for r, o in zip(results, others)]))


def blender_python() -> list[str] | None:
    """The command that runs a script with bpy: [python] or [blender, --background, --python]
    (module docstring), or None."""
    venv = pathlib.Path(__file__).resolve().parents[2] / ".venv-blender" / "bin" / "python"   # in a checkout
    for python in (os.environ.get("BRDF_BLENDER_PYTHON"), venv):
        if python and pathlib.Path(python).is_file():
            return [str(python)]
    blender = shutil.which("blender")
    return [blender, "--background", "--python"] if blender else None


def export_blender(result, path: str | os.PathLike[str], measured: object = None,
                   candidates: list | tuple = ()) -> dict[str, object]:
    """Write ``result`` (a FitResult or RESULT.json of an OpenPBR model) as a Blender material: the
    script (.py), or the .blend it writes (.blend: needs bpy, ``blender_python``).  ``measured``
    is not read: Cycles draws the material, and what it draws is measured by the benchmark
    (docs/blender.md).  ``candidates``: the other fits of the measurement; the best of the other
    kind among them (brdf_fit.export.other_kind) is named in the asset's description.  Returns {"model", "path",
    "principled", "distribution", "errors", "other_kind", "script"}."""
    from fitting.auto import PRINCIPLED_FAMILY
    from fitting.result import FitResult, first_non_finite
    if not isinstance(result, FitResult):
        result = FitResult.load(result)
    path = pathlib.Path(path)
    if path.suffix.lower() not in SUFFIXES:
        raise ExportError(f"{path}: a Blender material is a .py script or a .blend file")
    if not drawn_by_principled(result.spec):
        raise ExportError(f"{result.spec}: --format blender writes a fit of the models a Principled BSDF draws as "
                          f"fitted ('principled': {', '.join(PRINCIPLED_FAMILY)}); OpenPBR's coat is not Blender's "
                          "(Blender's neither roughens nor darkens the base), nor its fuzz Blender's sheen (layered "
                          "otherwise: principled+nonmetal+sheen is): `brdf-fit export MEASURED_FILE --format "
                          "blender` fits them; a glTF material goes to Blender through its glTF importer")
    bad = first_non_finite(result.parameters)
    if bad is not None:
        raise ExportError(f"{path}: not written: {bad[0]} would be {bad[1]}")
    info = {"model": result.spec, "path": str(path), "principled": principled_inputs(result.spec, result.parameters),
            "distribution": distribution(result.spec),
            "errors": {k: v for k, v in result.errors.items() if k in ("m1", "image")},
            "other_kind": None}
    other = other_kind(result, candidates, drawn_by_principled)
    if other is not None:
        info["other_kind"] = other_kind_numbers(result, other)
    return {**info, "script": write_blender([result], path, [other])}


def write_blender(results: list, path: pathlib.Path, others: list | None = None) -> str | None:
    """Write the Blender materials of ``results`` (fits of OpenPBR's models) to ``path``: the script
    (.py; its path is returned) or the .blend it writes with ``blender_python`` (None returned).
    ``others``: each one's best fit of the other kind or None (brdf_fit.export.other_kind)."""
    from data_loaders.measured import write_file_atomic
    script = blender_script(results, others)
    if path.suffix.lower() == ".py":
        write_file_atomic(path, script)
        return str(path)
    command = blender_python()
    if command is None:
        raise ExportError(f"{path}: writing a .blend needs Blender's Python (bpy): `make blender`, "
                          "$BRDF_BLENDER_PYTHON or `blender` on PATH; or write the script (--out X.py) "
                          "and run it with `blender --background --python X.py -- OUT.blend`")
    with tempfile.TemporaryDirectory() as work:
        source, written = pathlib.Path(work) / "material.py", pathlib.Path(work) / "material.blend"
        source.write_text(script)
        seconds = SECONDS_MOST + SECONDS_A_MATERIAL * len(results)
        try:
            run = subprocess.run(command + [str(source), "--", str(written)], capture_output=True, text=True,
                                 timeout=seconds)
        except subprocess.TimeoutExpired:
            raise ExportError(f"{path}: Blender did not finish within {seconds:g} s") from None
        if run.returncode != 0 or not written.is_file():
            last = (run.stderr.strip().splitlines() or ["(no message)"])[-1]
            raise ExportError(f"{path}: Blender could not write the material (exit {run.returncode}): {last}")
        write_file_atomic(path, written.read_bytes())
    return None


def describe_blender(info: dict[str, object], stream=None) -> None:
    """Print what ``export_blender`` wrote."""
    stream = stream or sys.stdout
    print(f"wrote {info['path']}: {info['model']} as a Principled BSDF (distribution {info['distribution']}, "
          "single scattering as fitted; marked as an asset)", file=stream)
    for name, value in info["principled"].items():
        shown = ", ".join(f"{v:.4g}" for v in value) if isinstance(value, list) else f"{value:.4g}"
        print(f"  {name}: {shown}", file=stream)
    fit = ", ".join(f"{k} {v:.4g}" for k, v in info["errors"].items())
    print(f"  the fit's errors: {fit or '(none recorded)'}; as Cycles draws it: docs/blender.md", file=stream)
    if info.get("other_kind"):
        print("  " + other_kind_line(info["principled"]["Metallic"] == 1.0, info["other_kind"]), file=stream)
    if info["script"]:
        print(f"  make a .blend: blender --background --python {info['path']} -- material.blend", file=stream)
