// The report's 3D viewer (brdf-fit fitting/web_viewer.py writes this file next
// to the report, with three-bundle.js, viewer-environment.js and
// <material>-viewer-data.js: all classic scripts, so the page also works when
// opened from disk, where browsers refuse ES modules and fetch()).
//
// Scene: the exported .glb (a UV sphere with the fitted material), the
// preview renderer's camera, its environment (the generated sky as an
// equirectangular map for image-based lighting and the background) and the
// sky's sun as a directional light, tone-mapped as the report's stills are
// (docs/colour.md, "One colour path"): Khronos PBR Neutral (three.js's
// NeutralToneMapping) at the measured still's exposure, the sky behind at
// exposure 1.  Sets window.brdfViewerRendered after the first frame with a
// model, or window.brdfViewerError with the reason it could not draw.
(function () {
  "use strict";

  // Our lat-long maps put azimuth phi = atan2(x, -z) at u = (phi + pi) / 2pi
  // (shaders/environment.py); three.js puts atan2(z, x) there.  Turning its
  // lookups by this angle about +y aligns the two.
  const ENVIRONMENT_ROTATION_Y = Math.PI / 2;

  const canvas = document.getElementById("brdf-viewer");
  const status = document.getElementById("brdf-viewer-status");

  function fail(message) {
    window.brdfViewerError = message;
    if (status) status.textContent = "3D viewer not shown: " + message;
  }

  function bytes(base64) {
    const text = atob(base64);
    const out = new Uint8Array(text.length);
    for (let i = 0; i < text.length; i++) out[i] = text.charCodeAt(i);
    return out.buffer;
  }

  function linearColor(THREE, rgb) {
    return new THREE.Color().setRGB(rgb[0], rgb[1], rgb[2], THREE.LinearSRGBColorSpace);
  }

  function start() {
    const lib = window.BRDF_THREE, env = window.BRDF_VIEWER_ENVIRONMENT, data = window.BRDF_VIEWER_DATA;
    if (!canvas) return;
    if (!lib || !env || !data) {
      fail("its scripts (three-bundle.js, viewer-environment.js, the viewer data) did not load");
      return;
    }
    const THREE = lib.THREE;
    const renderer = new THREE.WebGLRenderer({ canvas: canvas, antialias: true });
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    renderer.setSize(canvas.clientWidth, canvas.clientHeight, false);
    // NeutralToneMapping is shaders/image.py's "pbr_neutral" after the same exposure factor.
    const exposure = data.exposure || 1.0;
    renderer.toneMapping = THREE.NeutralToneMapping;
    renderer.toneMappingExposure = exposure;
    renderer.outputColorSpace = THREE.SRGBColorSpace;

    const scene = new THREE.Scene();
    const hdr = new lib.HDRLoader().setDataType(THREE.FloatType).parse(bytes(env.hdr_base64));
    const map = new THREE.DataTexture(hdr.data, hdr.width, hdr.height, THREE.RGBAFormat, hdr.type);
    map.colorSpace = THREE.LinearSRGBColorSpace;
    map.minFilter = map.magFilter = THREE.LinearFilter;
    map.generateMipmaps = false;
    map.flipY = true;
    map.mapping = THREE.EquirectangularReflectionMapping;
    map.needsUpdate = true;
    scene.environment = map;
    scene.background = map;
    scene.backgroundIntensity = 1.0 / exposure;
    scene.environmentRotation.y = ENVIRONMENT_ROTATION_Y;
    scene.backgroundRotation.y = ENVIRONMENT_ROTATION_Y;
    for (const sun of env.directional_lights) {
      const light = new THREE.DirectionalLight(linearColor(THREE, sun.irradiance), 1.0);
      light.position.set(sun.direction[0], sun.direction[1], sun.direction[2]);
      scene.add(light);
    }

    const cam = data.camera;
    const camera = new THREE.PerspectiveCamera(cam.fov_deg, canvas.clientWidth / canvas.clientHeight, 0.1, 100);
    camera.position.set(cam.position[0], cam.position[1], cam.position[2]);
    const controls = new lib.OrbitControls(camera, canvas);
    controls.target.set(cam.target[0], cam.target[1], cam.target[2]);
    controls.update();

    let current = null;
    const render = () => renderer.render(scene, camera);
    controls.addEventListener("change", render);

    function show(index) {
      const model = data.models[index];
      new lib.GLTFLoader().parse(bytes(model.glb_base64), "", function (gltf) {
        if (current) scene.remove(current);
        current = gltf.scene;
        scene.add(current);
        render();
        if (status) {
          status.textContent = model.spec + " exported as " + model.gltf_model + " (" + model.kind +
            "), three.js r" + lib.version.replace(/^0\./, "").replace(/\.0$/, "");
        }
        window.brdfViewerModel = model.spec;
        window.brdfViewerRendered = true;
      }, function (err) {
        fail("the .glb of " + model.spec + " could not be read (" + err + ")");
      });
    }

    document.querySelectorAll("button[data-model]").forEach(function (button) {
      button.addEventListener("click", function () { show(Number(button.dataset.model)); });
    });
    if (data.models.length) show(0);
  }

  try {
    start();
  } catch (err) {
    fail(String(err && err.message ? err.message : err));
  }
})();
