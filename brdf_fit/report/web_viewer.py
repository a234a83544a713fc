"""The report's interactive 3D viewer: each fit's exported .glb in three.js.

``write_viewer(material, rows, measured, renders, out_dir)`` writes, next to
a material page, everything its viewer needs and returns the HTML section:

- ``three-bundle.js``: three.js (core, GLTFLoader, OrbitControls, HDRLoader)
  from the project's ``node_modules/three`` (or ``$BRDF_FIT_THREE_DIR``),
  rewritten from ES modules into one classic script.  Browsers refuse module
  scripts and fetch() over ``file://``, so a classic ``<script src>`` is the
  one way a page opened from disk can load code; for the same reason the
  model and the environment are embedded as base64 in two more classic
  scripts (``<material>-viewer-data.js``, ``viewer-environment.js``);
- ``<material>-<model>.glb`` for every fit (``brdf_fit.export.gltf.export_gltf``)
  and ``environment-sky.hdr``: the preview renderer's environment (the
  generated sky, ``shaders.render.default_environment``), whose sun, kept
  out of the map, becomes a three.js DirectionalLight;
- ``viewer.js`` (brdf_fit/report/web/viewer.js): the scene, with the preview
  renderer's camera, tone-mapped as the report's stills (PBR Neutral at the
  measured still's exposure, the sky at exposure 1: docs/colour.md);
- ``<material>-measured.png``: the measured sphere from the report's lit-sphere
  comparison (the same render, not a new one), shown beside the viewer.

Without three.js the section is one line saying why.  docs/web-viewer.md
describes the page and the comparison with the toolkit's renderer.
"""

import base64
import json
import os
import pathlib
import posixpath
import re
import typing

from fitting.result import FitResult, atomic_write_text

if typing.TYPE_CHECKING:
    from data_loaders import MeasuredBRDF

THREE_DIR_VARIABLE = "BRDF_FIT_THREE_DIR"
THREE_TESTED = "0.187.0"        # the three.js the viewer is tested with (package.json's devDependencies)
PROJECT_ROOT = pathlib.Path(__file__).resolve().parents[2]
VIEWER_JS = pathlib.Path(__file__).resolve().parent / "web" / "viewer.js"
BUNDLE_NAME = "three-bundle.js"
ENVIRONMENT_HDR = "environment-sky.hdr"
ENVIRONMENT_JS = "viewer-environment.js"

# The ES modules the viewer uses, relative to the three package (HDRLoader is
# called RGBELoader before r169: the first file found is used).
THREE_ENTRY = "build/three.module.js"
THREE_ADDONS = {
    "GLTFLoader": ("examples/jsm/loaders/GLTFLoader.js",),
    "OrbitControls": ("examples/jsm/controls/OrbitControls.js",),
    "HDRLoader": ("examples/jsm/loaders/HDRLoader.js", "examples/jsm/loaders/RGBELoader.js"),
}

# Top-level import / export statements as Rollup and the three.js addons write them.
_IMPORT = re.compile(r"^import\s*\{([^}]*)\}\s*from\s*'([^']+)'\s*;", re.M)
_EXPORT_FROM = re.compile(r"^export\s*\{([^}]*)\}\s*from\s*'([^']+)'\s*;", re.M)
_EXPORT = re.compile(r"^export\s*\{([^}]*)\}\s*;", re.M)
_LEFTOVER = re.compile(r"^(import|export)\b.*", re.M)


class ViewerUnavailable(RuntimeError):
    """three.js is missing or not in the expected shape (the message says which)."""


def _override() -> pathlib.Path | None:
    """``$BRDF_FIT_THREE_DIR`` with a leading ``~`` expanded (a quoted ``'~/...'`` reaches the
    toolkit unexpanded by the shell), or None when unset or empty."""
    override = os.environ.get(THREE_DIR_VARIABLE)
    return pathlib.Path(os.path.expanduser(override)) if override else None


def three_dir() -> pathlib.Path | None:
    """The three.js package: ``$BRDF_FIT_THREE_DIR`` if set (``~`` expanded), else
    ``node_modules/three`` at the project root; None when it is not there."""
    folder = _override() or PROJECT_ROOT / "node_modules" / "three"
    return folder if (folder / THREE_ENTRY).is_file() else None


def install_hint() -> str:
    """One line saying exactly how to get three.js: ``npm ci`` in a repository checkout (its
    package.json pins it); for an installed package (a wheel: no package.json beside it) the
    npm command and the variable that points the toolkit at it.  When that variable is set
    but its folder holds no three.js, the line says so first, with the folder as read."""
    folder = _override()
    missing = (f"three.js is not installed where {THREE_DIR_VARIABLE} points: {folder} has no {THREE_ENTRY}"
               if folder is not None else "three.js is not installed")
    if (PROJECT_ROOT / "package.json").is_file():
        return (f"{missing} (no node_modules/three at {PROJECT_ROOT}; run `npm ci` there, or set "
                f"{THREE_DIR_VARIABLE} to a three.js package folder)")
    return (f"{missing}: run `npm install --prefix ~/.brdf-fit three@{THREE_TESTED}` and set "
            f"{THREE_DIR_VARIABLE}=~/.brdf-fit/node_modules/three (the 3D viewer needs it; node's npm is required)")


def three_version(folder: pathlib.Path) -> str:
    """The version in the package's package.json ("?" if unreadable)."""
    try:
        return str(json.loads((folder / "package.json").read_text())["version"])
    except (OSError, ValueError, KeyError):
        return "?"


# --- ES modules -> one classic script ---------------------------------------------------

def _names(clause: str) -> list[tuple[str, str]]:
    """'a, b as c' -> [("a", "a"), ("b", "c")] (imported or local name, bound name)."""
    out = []
    for item in clause.split(","):
        words = item.split()
        if not words:
            continue
        if len(words) == 3 and words[1] == "as":
            out.append((words[0], words[2]))
        elif len(words) == 1:
            out.append((words[0], words[0]))
        else:
            raise ViewerUnavailable(f"cannot read the import/export clause {item.strip()!r}")
    return out


def _resolve(specifier: str, importer: str) -> str:
    if specifier == "three":
        return THREE_ENTRY
    if specifier.startswith("."):
        return posixpath.normpath(posixpath.join(posixpath.dirname(importer), specifier))
    raise ViewerUnavailable(f"{importer}: cannot bundle the import of {specifier!r}")


def _wrap_module(key: str, source: str) -> tuple[str, list[str]]:
    """One ES module as ``__modules[key] = (function () {...; return {exports}; })();``
    and the modules it imports."""
    deps = []
    exports = []

    def imported(match):
        dep = _resolve(match.group(2), key)
        deps.append(dep)
        pairs = ", ".join(f"{a}: {b}" if a != b else a for a, b in _names(match.group(1)))
        return f"const {{ {pairs} }} = __modules[{json.dumps(dep)}];"

    def reexported(match):
        dep = _resolve(match.group(2), key)
        deps.append(dep)
        exports.extend((b, f"__modules[{json.dumps(dep)}].{a}") for a, b in _names(match.group(1)))
        return ""

    def exported(match):
        exports.extend((b, a) for a, b in _names(match.group(1)))
        return ""

    body = _EXPORT_FROM.sub(reexported, source)
    body = _IMPORT.sub(imported, body)
    body = _EXPORT.sub(exported, body)
    leftover = _LEFTOVER.search(body)
    if leftover:
        raise ViewerUnavailable(f"{key}: cannot bundle the statement {leftover.group(0)[:80]!r}")
    table = ",\n".join(f"  {name}: {value}" for name, value in exports)
    return (f"__modules[{json.dumps(key)}] = (function () {{\n\"use strict\";\n{body}\n"
            f"return {{\n{table}\n}};\n}})();\n"), deps


def bundle_three(folder: pathlib.Path) -> str:
    """three.js and the viewer's addons as one classic script that sets
    ``window.BRDF_THREE = {THREE, GLTFLoader, OrbitControls, HDRLoader, version}``.

    Each module becomes a function whose return value is its exports, run
    after the modules it imports (depth-first order), so a page opened from
    ``file://`` can load it with a plain ``<script src>``.
    """
    addons = {}
    for name, candidates in THREE_ADDONS.items():
        found = next((c for c in candidates if (folder / c).is_file()), None)
        if found is None:
            raise ViewerUnavailable(f"{folder} has no {' or '.join(candidates)}")
        addons[name] = found
    wrapped, order = {}, []

    def visit(key, stack=()):
        if key in wrapped:
            return
        if key in stack:
            raise ViewerUnavailable(f"circular import through {key}")
        path = folder / key
        if not path.is_file():
            raise ViewerUnavailable(f"{folder}: {key} is missing")
        code, deps = _wrap_module(key, path.read_text(encoding="utf-8"))
        for dep in deps:
            visit(dep, stack + (key,))
        wrapped[key] = code
        order.append(key)

    for key in [THREE_ENTRY, *addons.values()]:
        visit(key)
    exports = ", ".join(f"{name}: __modules[{json.dumps(key)}].{name}"
                        + (f" || __modules[{json.dumps(key)}].RGBELoader" if name == "HDRLoader" else "")
                        for name, key in addons.items())
    head = (f"// three.js {three_version(folder)} (MIT licence, https://threejs.org) and the addons\n"
            f"// {', '.join(addons.values())}, rewritten by brdf-fit's brdf_fit/report/web_viewer.py\n"
            "// from ES modules into one classic script (pages opened from disk cannot load modules).\n")
    return (head + "(function () {\nconst __modules = {};\n" + "".join(wrapped[k] for k in order)
            + f"window.BRDF_THREE = {{ THREE: __modules[{json.dumps(THREE_ENTRY)}], {exports}, "
              f"version: {json.dumps(three_version(folder))} }};\n}})();\n")


def write_three_bundle(out_dir: pathlib.Path, folder: pathlib.Path | None = None) -> pathlib.Path:
    """Write ``three-bundle.js`` (and three's LICENSE) into ``out_dir``; raises
    ViewerUnavailable when three.js is absent."""
    folder = folder or three_dir()
    if folder is None:
        raise ViewerUnavailable(install_hint())
    target = out_dir / BUNDLE_NAME
    atomic_write_text(target, bundle_three(folder))
    if (folder / "LICENSE").is_file():
        _copy(folder / "LICENSE", out_dir / "three-LICENSE.txt")
    return target


def _copy(source: pathlib.Path, target: pathlib.Path) -> None:
    """Copy atomically; a failed write (a full disk) names ``target``, not the source."""
    from data_loaders.measured import write_file_atomic
    write_file_atomic(target, source.read_bytes())


def _bundle_version(bundle: pathlib.Path) -> str | None:
    """The three.js version named on the first line of a written bundle."""
    with open(bundle, encoding="utf-8") as f:
        match = re.match(r"// three\.js (\S+) ", f.readline())
    return match.group(1) if match else None


# --- the environment, the camera and the data files ------------------------------------------

def _b64(path: pathlib.Path) -> str:
    return base64.b64encode(path.read_bytes()).decode("ascii")


def write_environment(out_dir: pathlib.Path) -> dict[str, object]:
    """Write the preview renderer's default environment as ``environment-sky.hdr``
    and ``viewer-environment.js`` (the .hdr embedded, its sun as a light);
    returns the JSON written."""
    from shaders.hdr import write_hdr
    from shaders.render import default_environment
    env = default_environment()
    write_hdr(out_dir / ENVIRONMENT_HDR, env.radiance)
    suns = [{"direction": [float(x) for x in light.unit_direction],
             "irradiance": [float(x) for x in light.irradiance]} for light in env.lights]
    data = {"name": env.name, "file": ENVIRONMENT_HDR, "hdr_base64": _b64(out_dir / ENVIRONMENT_HDR),
            "directional_lights": suns}
    atomic_write_text(out_dir / ENVIRONMENT_JS, "window.BRDF_VIEWER_ENVIRONMENT = " + json.dumps(data) + ";\n")
    return data


def preview_camera() -> dict[str, object]:
    """The preview renderer's camera for the exported sphere (``Camera.framing``)."""
    from shaders.render import Camera

    from brdf_fit.export.gltf_file import sphere
    cam = Camera.framing(sphere())
    return {"position": [float(x) for x in cam.position], "target": [float(x) for x in cam.target],
            "fov_deg": float(cam.fov_deg)}


def _slug(text: object) -> str:
    from .html import slug
    return slug(text)


def _measured_still(stem: str, renders: list, out_dir: pathlib.Path) -> tuple[str | None, float]:
    """The measured panel of the report's first lit-sphere comparison as its own PNG, and
    its exposure: (file name or None, exposure)."""
    for _, _, data in renders:
        hdr = data.get("measured") if isinstance(data, dict) else None
        if hdr is not None:
            from brdf_fit.render import DISPLAY_TONEMAP
            from shaders.image import finish, write_png
            name, exposure = f"{stem}-measured.png", float(data.get("exposure", 1.0))
            write_png(out_dir / name, finish(hdr, DISPLAY_TONEMAP, exposure))
            return name, exposure
    return None, 1.0


def write_viewer(material: str, rows: list[tuple[pathlib.Path, FitResult]],
                 measured: "MeasuredBRDF | None", renders: list, out_dir: str | os.PathLike[str],
                 render_note: str | None = None, stem: str | None = None) -> str:
    """Write the viewer's files for one material (named ``stem``-..., by default the
    material's slug); returns the page's HTML section.

    ``rows``: [(path, FitResult)] best first; ``renders``: the report's
    lit-sphere comparisons [(file, model, data)] (data["measured"] is the
    measured sphere's HDR render).  Raises ViewerUnavailable without three.js.
    """
    from html import escape

    from brdf_fit.export.gltf import export_gltf
    out_dir = pathlib.Path(out_dir)
    write_viewer_files(out_dir)
    slug = stem or _slug(material)
    models = []
    for _, result in rows:
        name = f"{slug}-{_slug(result.spec)}.glb"
        info = export_gltf(result, out_dir / name, measured=measured)
        models.append({"spec": result.spec, "gltf_model": info["model"], "kind": info["kind"], "file": name})
    still, exposure = _measured_still(slug, renders, out_dir)
    still_html = (f"<figure><img src=\"{escape(still)}\" alt=\"measured sphere\" width=\"320\" height=\"320\">"
                  "<figcaption>measured: the preview renderer's still (sampled environment light)"
                  "</figcaption></figure>" if still else
                  "<p class=\"note\">No still of the measured sphere: "
                  f"{escape(render_note or 'the lit-sphere comparison was not rendered')}.</p>")
    return viewer_section(material, models, out_dir, still_html, stem=slug, exposure=exposure)


def write_viewer_files(out_dir: pathlib.Path) -> None:
    """Write the files every viewer in ``out_dir`` shares (the three.js bundle, the
    environment, viewer.js) where they are missing or stale; ViewerUnavailable without three.js."""
    folder = three_dir()
    bundle = out_dir / BUNDLE_NAME
    if folder is None or not bundle.is_file() or _bundle_version(bundle) != three_version(folder):
        write_three_bundle(out_dir, folder)
    if not (out_dir / ENVIRONMENT_JS).is_file():
        write_environment(out_dir)
    if not (out_dir / VIEWER_JS.name).is_file() or (out_dir / VIEWER_JS.name).read_bytes() != VIEWER_JS.read_bytes():
        _copy(VIEWER_JS, out_dir / VIEWER_JS.name)


def viewer_section(material: str, models: list[dict], out_dir: str | os.PathLike[str], still_html: str,
                   stem: str | None = None, exposure: float = 1.0) -> str:
    """Write ``<stem>-viewer-data.js`` (``stem``: the material's slug by default) into
    ``out_dir`` (beside the page, after ``write_viewer_files``) and return the viewer's HTML section.  ``models``: one
    {"spec", "gltf_model", "kind", "file"} per exported .glb, ``file`` relative to
    the page; ``still_html``: what is shown beside the viewer; ``exposure``: the viewer's
    (brdf_fit.render.viewer_exposure of the measured picture beside it)."""
    from html import escape
    out_dir = pathlib.Path(out_dir)
    models = [{**m, "glb_base64": _b64(out_dir / m["file"])} for m in models]
    data_name = f"{stem or _slug(material)}-viewer-data.js"
    atomic_write_text(out_dir / data_name, "window.BRDF_VIEWER_DATA = " + json.dumps(
        {"material": material, "models": models, "camera": preview_camera(),
         "tone_mapping": "pbr_neutral", "exposure": float(exposure)}) + ";\n")
    buttons = "".join(
        f"<button type=\"button\" data-model=\"{i}\">{escape(m['spec'])}</button> "
        for i, m in enumerate(models))
    links = ", ".join(f"<a href=\"{escape(m['file'])}\">{escape(m['file'])}</a>" for m in models)
    return (
        "<h2>3D viewer</h2>"
        "<div style=\"display:flex;gap:1em;flex-wrap:wrap;align-items:flex-start\">"
        "<figure><canvas id=\"brdf-viewer\" width=\"320\" height=\"320\" "
        "style=\"width:320px;height:320px;border:1px solid #eee;touch-action:none\"></canvas>"
        f"<figcaption><span id=\"brdf-viewer-status\">loading the viewer...</span><br>{buttons}"
        "</figcaption></figure>" + still_html + "</div>"
        "<p class=\"meta\">The exported glTF material of each fit (" + links + ") in three.js "
        "(drag to orbit, wheel to zoom), lit like the preview renders: the generated sky "
        f"(<a href=\"{ENVIRONMENT_HDR}\">{ENVIRONMENT_HDR}</a>) and its sun, the "
        "same camera, the same exposure and tone map as the stills (docs/colour.md). three.js is a "
        "real-time engine: its image-based lighting is prefiltered and "
        "it adds multiple-scattering energy to the specular lobe (docs/web-viewer.md).</p>"
        f"<script src=\"{BUNDLE_NAME}\"></script><script src=\"{ENVIRONMENT_JS}\"></script>"
        f"<script src=\"{escape(data_name)}\"></script><script src=\"{VIEWER_JS.name}\"></script>")


__all__ = ["write_viewer", "write_three_bundle", "bundle_three", "three_dir", "write_environment",
           "preview_camera", "ViewerUnavailable", "THREE_DIR_VARIABLE"]
