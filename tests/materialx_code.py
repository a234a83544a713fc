"""MaterialX's own code and documents for the tests of the OpenPBR models (test_openpbr.py,
test_openpbr_nonmetal.py, test_openpbr_coat.py): its genglsl functions cut from the installed ``materialx`` package,
and a fit's .mtlx export read back and validated by MaterialX."""

import pathlib

import pytest


def cut(text, name):
    """From ``name`` in ``text`` to the closing brace of the function it begins."""
    start = text.index(name)
    depth, i = 0, text.index("{", start)
    while True:
        depth += {"{": 1, "}": -1}.get(text[i], 0)
        if depth == 0:
            return text[start:i + 1]
        i += 1


def materialx_files():
    """(MaterialX module, {short name: text}) of the genglsl files the tests cut from, and
    "_dir": pbrlib's genglsl folder (the path)."""
    materialx = pytest.importorskip("MaterialX")
    libraries = pathlib.Path(materialx.__file__).parent / "libraries"
    lib = libraries / "pbrlib" / "genglsl" / "lib"
    return materialx, {"math": (libraries / "stdlib" / "genglsl" / "lib" / "mx_math.glsl").read_text(),
                       "microfacet": (lib / "mx_microfacet.glsl").read_text(),
                       "specular": (lib / "mx_microfacet_specular.glsl").read_text(),
                       "diffuse": (lib / "mx_microfacet_diffuse.glsl").read_text(),
                       "_dir": lib.parent}


def written_open_pbr_surface(spec, parameters, material, path):
    """Export a fit of ``spec`` at ``parameters`` as MaterialX to ``path``, check the document
    validates against MaterialX's own libraries and holds one open_pbr_surface: ({input name:
    value} of that shader's set inputs, the export's info)."""
    pytest.importorskip("MaterialX")
    from brdf_fit.export.materialx_file import export_materialx
    from fitting.result import FitResult
    fitted = FitResult(spec=spec, parameters=parameters, errors={"m1": 0.0}, optimizer={"max_theta": 80.0},
                       provenance={"file": None, "sha256": None, "format": None, "material": material})
    info = export_materialx(fitted, path)
    return validated_open_pbr_surface(path, info), info


def validated_open_pbr_surface(path, info):
    """Check the MaterialX document at ``path`` validates against MaterialX's own libraries
    and that its open_pbr_surface material (``info["materials"]``, as an export returns it) is
    OpenPBR's node: {input name: value} of that shader's set inputs."""
    materialx = pytest.importorskip("MaterialX")
    libraries = materialx.createDocument()
    materialx.loadLibraries(["libraries"], materialx.FileSearchPath(str(pathlib.Path(materialx.__file__).parent)),
                            libraries)
    doc = materialx.createDocument()
    materialx.readFromXmlFile(doc, str(path))
    doc.setDataLibrary(libraries)
    valid, message = doc.validate()
    assert valid and message == ""
    (name,) = [m for m, category in info["materials"].items() if category == "open_pbr_surface"]
    shader = doc.getNode(name).getInput("surfaceshader").getConnectedNode()
    assert shader.getNodeDef().getName() == "ND_open_pbr_surface_surfaceshader"
    return {i.getName(): i.getValue() for i in shader.getInputs() if i.hasValueString()}
