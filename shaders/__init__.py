"""The GLSL twin of ``brdf/`` and the headless preview renderer (docs/models.md#glsl-twins).

GLSL library (``*.glsl``, one file per group of brdf/, same names and
argument conventions): common (constants), geometry, specular, fresnel,
diffuse, energy, clearcoat, gltf, model (composition from a ModelSpec's
#defines), measured (MERL / UTIA lookups), ibl / sampling (image lighting).

Python modules:

- ``library``     #include resolution, ``defines_for(spec)``, the generated
                  ``struct BrdfParams`` / std140 uniform block, ``pack_params``
- ``own_glsl``    a model of one's own's ``glsl=`` in a program, its compile
                  errors as one OwnModelError line (brdf/own.py)
- ``parity``      evaluate GLSL terms and ModelSpecs on N direction pairs
                  (compute shader) -> numpy; ``python -m shaders.parity``
- ``render``      ``render_material``, ``render_hdr``, ``render_comparison``,
                  ``render_sweep`` (moderngl, EGL)
- ``environment`` generated skies / studio, .hdr maps, lights, SH irradiance
- ``scene``       camera, lights' uniforms, an environment's GPU resources
                  (prefiltered mips: compute on OpenGL 4.3, fragment on 3.3)
- ``diffuse_ibl`` moment tables of each diffuse lobe for split-sum lighting
- ``measured``    ``MeasuredTable``: MERL / UTIA tables for the GPU
- ``hdr``, ``image``, ``mesh``   RGBE files, tone mapping + PNG, meshes
- ``cli``         ``render_main`` behind ``brdf-fit render``
- ``gl``          the EGL context (OpenGL 4.3, else 3.3; docs/renderer.md);
                  ``GLUnavailableError`` names the fix

Nothing here imports moderngl or creates a context until it is used.
"""

_LAZY = {
    "render_material": "render", "render_hdr": "render", "render_comparison": "render",
    "render_sweep": "render", "Material": "render", "Camera": "render",
    "Environment": "environment", "PointLight": "environment", "DirectionalLight": "environment",
    "MeasuredTable": "measured", "evaluate_glsl": "parity", "evaluate_model": "parity",
    "defines_for": "library", "pack_params": "library",
}

__all__ = sorted(_LAZY)


def __getattr__(name):
    if name in _LAZY:
        import importlib
        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module 'shaders' has no attribute {name!r}")
