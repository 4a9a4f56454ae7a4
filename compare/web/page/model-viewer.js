// The page side of compare/web/model_viewer.py: the suite's job shown by a <model-viewer> element, set up
// through its public attributes as a user would (src, environment-image, skybox-image, camera-orbit,
// camera-target, field-of-view, tone-mapping, exposure), then read back:
//   * as the element shows it (options.linear false): its canvas, 8-bit sRGB after its own tone mapper,
//     returned as floats in [0, 1] with output 'display' (the suite measures it with LDR metrics only);
//   * tone mapping off (options.linear): the element's own three.js scene and camera drawn by its own
//     WebGLRenderer into a float render target, jittered frames averaged in float, linear radiance.
// Python drives it through Playwright with the three functions every engine page defines (host.py).
import * as THREE from 'three';
import '@google/model-viewer';
import { base64 } from './common.js';
import { FrameMean } from './three-mean.js';

let S = null;

// The element keeps its scene and renderer behind symbols (model-viewer-base.ts: $scene, $renderer); the
// float readback needs both, so they are found by their descriptions.
function internal(el, description) {
  let o = el;
  while (o) {
    const sym = Object.getOwnPropertySymbols(o).find((s) => s.description === description);
    if (sym) return el[sym];
    o = Object.getPrototypeOf(o);
  }
  throw new Error(`<model-viewer> has no internal '${description}' (a model-viewer release this page does not know)`);
}

const sub = (a, b) => a.map((x, i) => x - b[i]);
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const unit = (a) => { const n = Math.hypot(...a); return a.map((x) => x / n); };

// The suite's look-at camera as model-viewer's orbit about the target: radius, theta (about +Y from +Z),
// phi (from +Y); SmoothControls.moveCamera places the camera at target + r (sin φ sin θ, cos φ, sin φ cos θ)
// with +Y as its up. A camera whose up is not in the plane of +Y and its view (a rolled camera) has no orbit.
function orbit(cam) {
  const d = sub(cam.position, cam.target);
  const r = Math.hypot(...d);
  const o = unit(d);
  const phi = Math.acos(Math.max(-1, Math.min(1, o[1])));
  const theta = Math.atan2(o[0], o[2]);
  const f = o.map((x) => -x);
  const upTrue = unit(sub(cam.up, f.map((x) => x * dot(cam.up, f))));
  const upOrbit = [-Math.cos(phi) * Math.sin(theta), Math.sin(phi), -Math.cos(phi) * Math.cos(theta)];
  if (!(dot(upTrue, upOrbit) > 1 - 1e-9)) {
    throw new Error('the camera is rolled (its up is not in the plane of +Y and its view): <model-viewer>\'s '
      + 'orbit camera keeps +Y up');
  }
  return { r, theta, phi };
}

function waitFor(test, what, ms = 600000) {
  const t0 = performance.now();
  return new Promise((resolve, reject) => {
    const poll = () => {
      if (test()) resolve();
      else if (performance.now() - t0 > ms) reject(new Error(`timed out waiting for ${what}`));
      else setTimeout(poll, 10);
    };
    poll();
  });
}

// One frame of the element through its own renderer (Renderer.render, what its animation loop calls),
// then a one-pixel readback that waits for the GPU.
function drawElement() {
  S.scene.queueRender();
  S.mv.render(performance.now());
  const gl = S.three.getContext();
  gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
}

window.compareSetup = async ({ job: jobUrl, options }) => {
  const t0 = performance.now();
  const job = await (await fetch(jobUrl)).json();
  const base = jobUrl.substring(0, jobUrl.lastIndexOf('/') + 1);
  const { width: w, height: h, fov_deg: fov, target } = job.camera;
  const linear = !!(options && options.linear);
  const Element = customElements.get('model-viewer');
  Element.minimumRenderScale = 1; // no dynamic down-scaling when frames are slow (SwiftShader)
  const { r, theta, phi } = orbit(job.camera);
  const el = document.createElement('model-viewer');
  el.style.cssText = `display:block;width:${w}px;height:${h}px`;
  const attributes = {
    // the environment the suite wrote as Radiance HDR (the element reads .hdr, not .exr), turned and scaled
    // as the scene says; shown behind the model (skybox-image, below) unless the scene hides it
    'environment-image': base + 'environment.hdr',
    'camera-orbit': `${theta}rad ${phi}rad ${r}m`,
    // the orbit's own limits would clamp phi to [22.5°, 157.5°] and the radius to the model's size
    'min-camera-orbit': `-Infinity 0rad ${r}m`, 'max-camera-orbit': `Infinity ${Math.PI}rad ${r}m`,
    'camera-target': `${target[0]}m ${target[1]}m ${target[2]}m`,
    'field-of-view': `${fov}deg`, 'min-field-of-view': '0.0001deg', 'max-field-of-view': '179deg',
    'interaction-prompt': 'none', 'shadow-intensity': '0', loading: 'eager', reveal: 'auto',
    'tone-mapping': linear ? 'none' : 'auto', exposure: '1',
  };
  // the scene's background false is model-viewer's own case of no skybox-image (renderSkybox false): nothing
  // behind the model, the element's transparent clear
  const env = job.scene.environment;
  const sky = !!env && env.background !== false;
  if (sky) attributes['skybox-image'] = base + 'environment.hdr';
  for (const [k, v] of Object.entries(attributes)) el.setAttribute(k, v);
  const loaded = new Promise((resolve, reject) => {
    el.addEventListener('load', resolve, { once: true });
    el.addEventListener('error', (e) => reject(new Error(`<model-viewer> could not load the scene: ${
      JSON.stringify((e && e.detail && e.detail.type) || 'error')}`)), { once: true });
  });
  el.setAttribute('src', base + 'scene.gltf');
  document.body.appendChild(el);
  await loaded;
  const scene = internal(el, 'scene');
  const mv = internal(el, 'renderer');
  const three = mv.threeRenderer;
  S = { job, el, scene, mv, three, w, h, linear, steps: 0, ms: 0 };
  await waitFor(() => scene.environment != null && (!sky || scene.background != null),
    'the environment');
  // KHR_lights_punctual: three's lights in glTF's units (cd, lux); back to the suite's W/sr and W/m² as the
  // three.js page does, range ignored as everywhere in the suite
  scene.traverse((o) => {
    if (o.isLight) {
      o.intensity /= job.lumens_per_watt;
      if (o.distance !== undefined) o.distance = 0;
    }
  });
  // the element fits its field of view to the model's aspect (ModelScene.adjustedFoV): measure what it
  // made of the one asked for and ask for the one that gives the suite's
  el.jumpCameraToGoal();
  await el.updateComplete;
  drawElement();
  const k = Math.tan((scene.camera.fov * Math.PI) / 360) / Math.tan((fov * Math.PI) / 360);
  if (Math.abs(k - 1) > 1e-7) {
    el.setAttribute('field-of-view', `${(360 / Math.PI) * Math.atan(Math.tan((fov * Math.PI) / 360) / k)}deg`);
    await el.updateComplete;
    el.jumpCameraToGoal();
    drawElement();
  }
  const cam = scene.camera;
  const at = scene.getTarget();
  const eye = [cam.position.x + at.x, cam.position.y + at.y, cam.position.z + at.z];
  if (Math.abs(cam.fov - fov) > 1e-4 || Math.hypot(...sub(eye, job.camera.position)) > 1e-5 * Math.max(r, 1)) {
    throw new Error(`<model-viewer> placed its camera at ${eye.map((x) => x.toFixed(5))} with a field of view `
      + `of ${cam.fov.toFixed(5)}°, not the scene's camera`);
  }
  if (linear) {
    S.camera = cam.clone();
    S.mean = new FrameMean(w, h);
    three.setRenderTarget(S.mean.frame);
    three.render(scene, S.camera); // shader compilation and uploads belong to set-up
    three.setRenderTarget(null);
  }
  const gl = three.getContext();
  const info = gl.getExtension('WEBGL_debug_renderer_info');
  const glRenderer = info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER);
  // the element's release, as npm installed it (it reports none itself)
  const version = (await (await fetch('./node_modules/@google/model-viewer/package.json')).json()).version;
  return { setup_ms: performance.now() - t0, gl_renderer: glRenderer, three: THREE.REVISION, version,
    output: linear ? 'linear' : 'display', field_of_view_asked: el.getAttribute('field-of-view') };
};

window.compareStep = async (n) => {
  const { three, scene } = S;
  while (S.steps < n) {
    const t0 = performance.now();
    if (S.linear) {
      // frame k: the element's scene and camera, jittered by Halton (2, 3), the first at the pixel centres
      const next = S.mean.step(three, scene, S.camera, S.steps);
      three.readRenderTargetPixels(next, 0, 0, 1, 1, new Float32Array(4));
      three.setRenderTarget(null);
    } else {
      drawElement(); // the element draws the same image every frame: a step is one more frame of it
    }
    S.ms += performance.now() - t0;
    S.steps += 1;
  }
  return { ms: S.ms, steps: S.steps };
};

window.compareImage = () => {
  const { w, h } = S;
  const px = new Float32Array(w * h * 4);
  if (S.linear) {
    S.three.readRenderTargetPixels(S.mean.target, 0, 0, w, h, px);
    return base64(px);
  }
  // what the element shows: its canvas (the top-left w×h of the shared WebGL canvas), 8-bit sRGB
  const canvas = document.createElement('canvas');
  canvas.width = w;
  canvas.height = h;
  const ctx = canvas.getContext('2d');
  ctx.drawImage(S.mv.displayCanvas(S.scene), 0, 0, w, h, 0, 0, w, h);
  const rgba = ctx.getImageData(0, 0, w, h).data;
  for (let y = 0; y < h; y++) { // bottom row first, as the float pages answer
    for (let i = 0; i < w * 4; i++) {
      // as shown over the page's black: where the element is transparent (no skybox) its colour times its
      // alpha (getImageData gives colour not multiplied by alpha); opaque pixels as they are
      const a = rgba[y * w * 4 + i - (i % 4) + 3] / 255;
      px[(h - 1 - y) * w * 4 + i] = (i % 4 === 3 ? 1 : a) * (rgba[y * w * 4 + i] / 255);
    }
  }
  return base64(px);
};

window.compareReady = true;
