"""The page benchmarks/engine_three.py draws with: three.js r187 in headless Chromium.

``three_images(folder, names, size, lights)`` serves ``folder`` (the three.js bundle of
brdf_fit.report.web_viewer, folder/NAME.glb) on 127.0.0.1, opens a page in headless Chromium
(tests/headless_chromium.py) and returns three.js's linear renders: each .glb's material, as
GLTFLoader loads it, on a grid mesh whose vertices sit on the pixel centres of a unit sphere seen
orthographically along +z (exact sphere normals; tangents along the azimuth around y), one white
directional light of irradiance 1 at a time, drawn into a FloatType render target and read back
as float32 (readRenderTargetPixels); and the normals three.js shaded with (MeshNormalMaterial).

Beside the material as shipped, variants with some of three.js's differences from the glTF BRDF
patched out of its shader chunks (``CAUSES``; the first four lines are tests/three_patches.py's
NOT_IN_SPEC, which tests/test_cross_render.py patches out too): they say where a difference
between three.js's picture and the spec's comes from.
"""

import base64
import functools
import http.server
import json
import pathlib
import threading

import numpy as np

from three_patches import NOT_IN_SPEC_JS, PATCHER_JS      # tests/ (benchmarks/engine_three.py puts it on the path)

# The variants drawn: {name: the patches, indices into the page's PATCHES}.  "shipped" is the material
# as loaded, the one judged; the others say where a difference from the spec comes from.
CAUSES = {       # one difference between three.js r187's direct lighting and the glTF BRDF each
    "multiscattering": ([0], "Turquin's multiple-scattering compensation x (1 + F0 (1/E_ss - 1))"),
    "geometric_roughness": ([1, 2], "roughness += max |dFdx, dFdy of n| (the coat's too)"),
    "coat_fresnel": ([3], "the coat's Fresnel at v.h, not n.v"),
    "sg_fresnel": ([4, 5], "Epic's spherical-Gaussian Fresnel, not Schlick's (1 - v.h)^5"),
    "diffuse_rgb": ([6], "the diffuse under (1 - F) per channel, not (1 - max(F)) (KHR_materials_specular)"),
}
VARIANTS = {"shipped": [], "spec_terms": [0, 1, 2, 3], "as_spec": list(range(7)),
            **{name: which for name, (which, _) in CAUSES.items()}}
# The page: one grid mesh on the pixel centres (row-major from the bottom, as WebGL reads back), each
# material drawn once per light into a float render target.  NOT_IN_SPEC, patcher: tests/three_patches.py.
PAGE_JS = r"""
"use strict";
const { THREE, GLTFLoader } = window.BRDF_THREE;
const config = window.CONFIG, size = config.size;
""" + NOT_IN_SPEC_JS + PATCHER_JS + r"""
// and Epic's spherical-Gaussian Fresnel (common: F_Schlick), where glTF has Schlick's (1 - v.h)^5
const SCHLICK = [
  ["common", "float fresnel = exp2( ( - 5.55473 * dotVH - 6.98316 ) * dotVH );",
   "float fresnel = pow( 1.0 - dotVH, 5.0 );", "vec3 F_Schlick("],
  ["common", "float fresnel = exp2( ( - 5.55473 * dotVH - 6.98316 ) * dotVH );",
   "float fresnel = pow( 1.0 - dotVH, 5.0 );", "float F_Schlick("],
];
// and the dielectric's diffuse under 1 - max(F) (KHR_materials_specular's fresnel_mix), not 1 - F per channel
const MAX_F = [
  ["lights_physical_pars_fragment", "reflectedLight.directDiffuse += irradiance * diffuseBRDF * ( 1.0 - F );",
   "reflectedLight.directDiffuse += irradiance * diffuseBRDF * ( 1.0 - max( max( F.r, F.g ), F.b ) );",
   "void RE_Direct_Physical("],
];
const PATCHES = [...NOT_IN_SPEC, ...SCHLICK, ...MAX_F];
function sphereGrid() {
  // vertices on the pixel centres, on the unit sphere (z = sqrt(1 - r^2)) with its exact normal and
  // the image error's tangent (along the azimuth around y); outside the disc z = 0
  const pos = [], nor = [], tan = [], uv = [], index = [], c = (k) => (k + 0.5) / size * 2 - 1;
  const side = size + 2;      // one pixel beyond the image on each side: every disc pixel is inside the mesh
  for (let i = -1; i <= size; i++) for (let j = -1; j <= size; j++) {
    const x = c(j), y = c(i), r2 = x * x + y * y, z = Math.sqrt(Math.max(1 - r2, 0));
    const n = r2 < 1 ? [x, y, z] : [x / Math.sqrt(r2), y / Math.sqrt(r2), 0];
    const h = Math.hypot(n[2], n[0]), t = h > 0 ? [n[2] / h, 0, -n[0] / h] : [1, 0, 0];
    pos.push(x, y, z); nor.push(...n); tan.push(...t, 1); uv.push(0.5 * x + 0.5, 0.5 * y + 0.5);
  }
  const inside = (i, j) => c(i) * c(i) + c(j) * c(j) < 1;
  for (let i = -1; i < size; i++) for (let j = -1; j < size; j++) {
    if (!(inside(i, j) || inside(i, j + 1) || inside(i + 1, j) || inside(i + 1, j + 1))) continue;
    const a = (i + 1) * side + j + 1, b = a + 1, d = a + side, e = d + 1;
    index.push(a, b, e, a, e, d);          // counter-clockwise seen from +z
  }
  const g = new THREE.BufferGeometry();
  g.setAttribute("position", new THREE.Float32BufferAttribute(pos, 3));
  g.setAttribute("normal", new THREE.Float32BufferAttribute(nor, 3));
  g.setAttribute("tangent", new THREE.Float32BufferAttribute(tan, 4));
  g.setAttribute("uv", new THREE.Float32BufferAttribute(uv, 2));
  g.setIndex(index);
  return g;
}
function b64(f32) {
  const u8 = new Uint8Array(f32.buffer);
  let s = "";
  for (let i = 0; i < u8.length; i += 0x8000) s += String.fromCharCode.apply(null, u8.subarray(i, i + 0x8000));
  return btoa(s);
}
const renderer = new THREE.WebGLRenderer({ canvas: document.getElementById("c"), antialias: false });
renderer.setPixelRatio(1);
renderer.toneMapping = THREE.NoToneMapping;
const target = new THREE.WebGLRenderTarget(size, size, { type: THREE.FloatType, minFilter: THREE.NearestFilter,
  magFilter: THREE.NearestFilter, depthBuffer: true, samples: 0 });
const camera = new THREE.OrthographicCamera(-1, 1, 1, -1, 0.1, 100);
camera.position.set(0, 0, 10);
camera.lookAt(0, 0, 0);
const scene = new THREE.Scene();
const light = new THREE.DirectionalLight(new THREE.Color(1, 1, 1), 1.0);
scene.add(light, light.target);
const mesh = new THREE.Mesh(sphereGrid());
scene.add(mesh);
function draw() {
  const buf = new Float32Array(size * size * 4);
  renderer.setRenderTarget(target);
  renderer.setClearColor(0x000000, 0);
  renderer.clear();
  renderer.render(scene, camera);
  renderer.readRenderTargetPixels(target, 0, 0, size, size, buf);
  renderer.setRenderTarget(null);
  return b64(buf);
}
window.results = {};
(async () => {
  mesh.material = new THREE.MeshNormalMaterial();
  window.results.normals = draw();
  for (const name of config.materials) {
    const gltf = await new GLTFLoader().loadAsync(name + ".glb");
    let material = null;
    gltf.scene.traverse((o) => { if (o.isMesh && !material) material = o.material; });
    const out = {};
    for (const [variant, which] of Object.entries(config.variants)) {
      const m = which.length ? material.clone() : material;
      if (which.length) {
        m.onBeforeCompile = patcher(which.map((k) => PATCHES[k]));
        m.customProgramCacheKey = () => variant;
      }
      mesh.material = m;
      out[variant] = [];
      for (const d of config.lights) { light.position.fromArray(d); out[variant].push(draw()); }
    }
    window.results[name] = out;
  }
  window.rendered = true;
})().catch((err) => { console.error(String(err)); window.renderError = String(err); });
"""


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


def three_images(folder, names, size, lights, variants=VARIANTS):
    """{name: {variant: (L, size, size, 4) float32}, "normals": (size, size, 4), "version": r}:
    three.js's linear renders of folder/NAME.glb (row 0 at the top), one per light direction."""
    from brdf_fit.report.web_viewer import three_dir, write_three_bundle
    from headless_chromium import HeadlessChromium, find_chromium
    if find_chromium() is None or three_dir() is None:
        raise SystemExit("engine_three needs chromium and node_modules/three (npm ci)")
    folder = pathlib.Path(folder)
    write_three_bundle(folder)
    config = {"size": size, "materials": list(names), "lights": [[float(x) for x in d] for d in lights],
              "variants": variants}
    (folder / "engine_three.html").write_text(
        '<!doctype html><html><head><meta charset="utf-8"><link rel="icon" href="data:,"></head><body>'
        f'<canvas id="c" width="{size}" height="{size}"></canvas><script src="three-bundle.js"></script>'
        f"<script>window.CONFIG = {json.dumps(config)};</script><script>{PAGE_JS}</script></body></html>")
    handler = functools.partial(_QuietHandler, directory=str(folder))
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()

    def decode(text):
        return np.frombuffer(base64.b64decode(text), np.float32).reshape(size, size, 4)[::-1]
    try:
        with HeadlessChromium(folder, size + 64, size + 64, timeout=600) as browser:
            browser.open(f"http://127.0.0.1:{httpd.server_address[1]}/engine_three.html")
            browser.wait_for("window.rendered === true || !!window.renderError")
            error = browser.evaluate("window.renderError || null")
            if error or browser.errors:
                raise RuntimeError(f"three.js: {error}; {browser.errors}")
            out = {"normals": decode(browser.evaluate("window.results.normals")),
                   "version": browser.evaluate("window.BRDF_THREE.THREE.REVISION")}
            for name in names:
                got = browser.evaluate(f"window.results[{json.dumps(name)}]")
                out[name] = {v: np.stack([decode(s) for s in got[v]]) for v in variants}
    finally:
        httpd.shutdown()
        httpd.server_close()
    return out
