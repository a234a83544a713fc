"""The Blender half of benchmarks/engine_blender.py: Cycles draws .glb materials on the judge's lit sphere.

    BLENDER_PYTHON benchmarks/blender_scene.py CONFIG.json

Runs in Blender's own Python (pip's bpy, in the virtualenv `make blender` makes: bpy 5.0.1
requires numpy < 2, which downgrades the toolkit's JAX and nlopt until fitting fails), so it
imports nothing of the toolkit.  CONFIG (JSON): size, lights (unit directions towards the light), samples, seeds,
variants, out (a folder) and materials ({name: .glb path}).  For each material:

- the .glb is imported with Blender's bundled glTF importer (bpy.ops.import_scene.gltf) into an
  empty scene; its first mesh's material is kept as imported, the imported objects are removed,
  and the Principled BSDF's inputs (the importer's reading of the file) go to
  OUT/blender.json;
- the material is put on a grid mesh whose vertices sit on the pixel centres of a unit sphere
  seen orthographically along +z, with the exact sphere normals as custom normals (smooth
  shading), as the three.js judge draws (benchmarks/three_judge_page.py); the camera's rays go
  through the pixel centres (a Gaussian filter 0.01 px wide; Cycles' box filter ignores its
  width), so each pixel is shaded at (almost exactly) a vertex with the exact normal;
- a sun of strength 1 (irradiance 1 W/m^2 on a surface facing it), angle 0 (a delta light),
  no shadow rays (the sphere's own shadow is cos theta_i < 0; a faceted mesh would shadow itself
  at the terminator), a black world, no bounces (direct light only: a convex sphere lit by one
  sun has no indirect light), no denoising, no clamping, view transform Standard, look None,
  exposure 0; each light and variant rendered to a 32-bit float OpenEXR (linear scene values,
  Rec.709 primaries as glTF's), read back through Blender as float32 and saved as
  OUT/NAME.VARIANT.SEED.npy, (L, size, size, 4), row 0 at the bottom;
- variants (``VARIANTS``): "shipped" (as imported), and the same material with one of Blender's
  differences from the glTF BRDF taken out where a Principled input can do it: "single_ggx" (the
  distribution single-scattering GGX, where the importer leaves Blender's default
  multiple-scattering GGX), "plain_metal" (the metallic part drawn by a second Principled BSDF
  whose Specular Tint is white, mixed by metallic: Cycles gives the metallic part an F82 edge
  tint of min(Specular Tint, 1), the importer's specularColorFactor, where glTF's metal has
  Schlick's F90 = 1 and no specular colour; Principled is linear in metallic, so the mix is the
  same material otherwise) and both together;
- the normals Cycles shaded with (an emission of (N + 1) / 2, N the Geometry node's shading
  normal) once, as OUT/normals.npy.
"""

import json
import pathlib
import sys

import bpy
import numpy as np
from mathutils import Vector


def reset():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def principled_inputs(material):
    """{input name: value} of the material's Principled BSDF (linked inputs named as such)."""
    node = principled(material)
    inputs = {"distribution": node.distribution}
    for socket in node.inputs:
        if socket.is_linked:
            inputs[socket.name] = "linked to " + ", ".join(link.from_node.bl_idname for link in socket.links)
        elif hasattr(socket, "default_value"):
            value = socket.default_value
            inputs[socket.name] = [float(v) for v in value] if hasattr(value, "__len__") else float(value)
    nodes = sorted({n.bl_idname for n in material.node_tree.nodes} - {"ShaderNodeBsdfPrincipled",
                                                                     "ShaderNodeOutputMaterial"})
    return {"inputs": inputs, "other_nodes": nodes}


def import_material(glb):
    """The first mesh's material of ``glb`` as Blender's glTF importer makes it; the objects removed.
    A .blend (brdf-fit's ``export --format blender``): its first material, appended as it is."""
    if str(glb).endswith(".blend"):
        with bpy.data.libraries.load(str(glb)) as (source, appended):
            appended.materials = source.materials[:1]
        appended.materials[0].use_fake_user = True
        return appended.materials[0]
    bpy.ops.import_scene.gltf(filepath=str(glb))
    meshes = [o for o in bpy.data.objects if o.type == "MESH" and o.data.materials]
    material = meshes[0].data.materials[0]
    material.use_fake_user = True
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    return material


def sphere_grid(size):
    """A mesh object: vertices on the pixel centres of the unit sphere (one pixel beyond the image),
    exact sphere normals as custom normals, smooth; outside the disc z = 0 with the radial normal."""
    c = (np.arange(-1, size + 1) + 0.5) / size * 2.0 - 1.0
    x, y = np.meshgrid(c, c)                       # row i: y = c[i] (bottom to top)
    r2 = x * x + y * y
    z = np.sqrt(np.maximum(1.0 - r2, 0.0))
    r = np.sqrt(np.maximum(r2, 1e-30))
    inside = r2 < 1.0
    n = np.where(inside[..., None], np.stack([x, y, z], -1), np.stack([x / r, y / r, np.zeros_like(z)], -1))
    side = size + 2
    faces = []
    for i in range(side - 1):
        for j in range(side - 1):
            if inside[i, j] or inside[i, j + 1] or inside[i + 1, j] or inside[i + 1, j + 1]:
                a = i * side + j
                faces.append((a, a + 1, a + side + 1, a + side))    # counter-clockwise seen from +z
    verts = np.stack([x, y, z], -1).reshape(-1, 3)
    mesh = bpy.data.meshes.new("sphere_grid")
    mesh.from_pydata(verts.tolist(), [], faces)
    mesh.shade_smooth()
    mesh.normals_split_custom_set_from_vertices(n.reshape(-1, 3).tolist())
    obj = bpy.data.objects.new("sphere_grid", mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def setup_scene(size, samples):
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.render.threads_mode = "AUTO"
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.cycles.samples = samples
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.use_denoising = False
    scene.cycles.pixel_filter_type = "GAUSSIAN"     # the box filter jitters over the whole pixel, whatever its width
    scene.cycles.filter_width = 0.01               # rays through the pixel centres
    scene.cycles.max_bounces = 0                   # direct light only
    scene.cycles.sample_clamp_direct = 0.0
    scene.cycles.sample_clamp_indirect = 0.0
    scene.cycles.film_exposure = 1.0
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.render.image_settings.color_mode = "RGBA"
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world
    camera = bpy.data.cameras.new("camera")
    camera.type = "ORTHO"
    camera.ortho_scale = 2.0
    camera.clip_start, camera.clip_end = 0.1, 100.0
    cam = bpy.data.objects.new("camera", camera)
    cam.location = (0.0, 0.0, 10.0)                # looking down -z, +y up
    scene.collection.objects.link(cam)
    scene.camera = cam
    light = bpy.data.lights.new("sun", "SUN")
    light.energy = 1.0                             # W/m^2: irradiance 1 on a surface facing it
    light.angle = 0.0
    light.use_shadow = False
    sun = bpy.data.objects.new("sun", light)
    scene.collection.objects.link(sun)
    return sun


def render(path, seed):
    """Render the scene to ``path`` (.exr) and read it back: float32 (size, size, 4), row 0 at the bottom."""
    scene = bpy.context.scene
    scene.cycles.seed = seed
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(str(path))
    image.colorspace_settings.name = "Non-Color"
    pixels = np.empty(len(image.pixels), np.float32)
    image.pixels.foreach_get(pixels)
    size = image.size[0]
    bpy.data.images.remove(image)
    return pixels.reshape(size, size, 4)


def point_sun(sun, direction):
    """A sun shines along its local -z: its +z towards the light."""
    sun.rotation_mode = "QUATERNION"
    sun.rotation_quaternion = Vector((0.0, 0.0, 1.0)).rotation_difference(Vector(direction))


def normal_material():
    """Emission (N + 1) / 2 of the shading normal: the normals Cycles shades with, as colours."""
    mat = bpy.data.materials.new("normals")
    mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    for node in list(nodes):
        nodes.remove(node)
    geometry = nodes.new("ShaderNodeNewGeometry")
    half = nodes.new("ShaderNodeVectorMath")
    half.operation = "MULTIPLY_ADD"
    half.inputs[1].default_value = (0.5, 0.5, 0.5)
    half.inputs[2].default_value = (0.5, 0.5, 0.5)
    emission = nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 1.0
    out = nodes.new("ShaderNodeOutputMaterial")
    links.new(geometry.outputs["Normal"], half.inputs[0])
    links.new(half.outputs["Vector"], emission.inputs["Color"])
    links.new(emission.outputs["Emission"], out.inputs["Surface"])
    return mat


VARIANTS = ("shipped", "single_ggx", "plain_metal", "single_ggx+plain_metal")


def principled(material):
    return next(n for n in material.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")


def variant_material(material, variant):
    """A copy of the imported material with the variant's changes (module docstring)."""
    mat = material.copy()
    node = principled(mat)
    if "single_ggx" in variant:
        node.distribution = "GGX"
    if "plain_metal" in variant:
        if any(s.is_linked for s in node.inputs):
            raise ValueError(f"{material.name}: a Principled input is linked (a texture): no plain_metal variant")
        nodes, links = mat.node_tree.nodes, mat.node_tree.links
        metal = nodes.new("ShaderNodeBsdfPrincipled")
        metal.distribution = node.distribution
        for socket, copy in zip(node.inputs, metal.inputs):
            if hasattr(socket, "default_value") and socket.enabled:
                copy.default_value = socket.default_value
        metal.inputs["Metallic"].default_value = 1.0
        metal.inputs["Specular Tint"].default_value = (1.0, 1.0, 1.0, 1.0)
        mix = nodes.new("ShaderNodeMixShader")
        mix.inputs["Fac"].default_value = node.inputs["Metallic"].default_value
        node.inputs["Metallic"].default_value = 0.0
        out = next(n for n in nodes if n.bl_idname == "ShaderNodeOutputMaterial")
        links.new(node.outputs["BSDF"], mix.inputs[1])          # Fac 0: the dielectric part
        links.new(metal.outputs["BSDF"], mix.inputs[2])         # Fac 1: the metal
        links.new(mix.outputs["Shader"], out.inputs["Surface"])
    return mat


def draw(grid, sun, material, lights, seed, work):
    grid.data.materials.clear()
    grid.data.materials.append(material)
    images = []
    for k, direction in enumerate(lights):
        point_sun(sun, direction)
        images.append(render(work / f"light{k}.exr", seed))
    return np.stack(images)


def main(config_path):
    config = json.loads(pathlib.Path(config_path).read_text())
    out = pathlib.Path(config["out"])
    work = out / "exr"
    work.mkdir(parents=True, exist_ok=True)
    size, lights = config["size"], config["lights"]
    info = {"blender": bpy.app.version_string, "materials": {}}
    for name, glb in config["materials"].items():
        reset()
        material = import_material(glb)
        info["materials"][name] = principled_inputs(material)
        sun = setup_scene(size, config["samples"])
        grid = sphere_grid(size)
        if config.get("normals") and not (out / "normals.npy").exists():
            normals = draw(grid, sun, normal_material(), lights[:1], 0, work)[0]
            np.save(out / "normals.npy", normals)
        for variant in config["variants"]:
            drawn = variant_material(material, variant)
            seeds = config["seeds"] if variant == "shipped" else config["seeds"][:1]
            for seed in seeds:
                np.save(out / f"{name}.{variant}.{seed}.npy", draw(grid, sun, drawn, lights, seed, work))
        print(f"blender: {name} drawn", file=sys.stderr, flush=True)
    (out / "blender.json").write_text(json.dumps(info, indent=1))


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else sys.exit(__doc__))
