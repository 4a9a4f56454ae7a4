// The Khronos glTF Sample Viewer page (compare/web/sample_viewer.py): the job's glTF and environment through
// the viewer's own API (GltfView, GltfState, ResourceLoader of npm @khronosgroup/gltf-viewer): its loader,
// its shaders, its KHR_lights_punctual, its own prefiltering of the HDR panorama (GGX, Lambertian and
// Charlie cube maps and their LUTs, made in WebGL). Read back as linear radiance:
//   * GltfView.renderFrame draws to the context's default framebuffer (bindFramebuffer(null)): here that
//     binding is redirected to a float framebuffer of the same context, so the viewer draws its frame into
//     RGBA32F without a change to its code;
//   * tone mapping NONE, and the viewer's own LINEAR_OUTPUT define (the one its transmission pass uses) on
//     every shader, so its final colour is the linear sum of its lobes, without the pow(1/2.2) of its
//     output transfer;
//   * the camera is the suite's look-at pinhole camera: the viewer's user camera with its transform and its
//     projection (jittered by Halton 2, 3, the first frame at the pixel centres), averaged in float in
//     plain WebGL 2 (common.js).
import { GltfView, ResourceLoader, GltfState } from '@khronosgroup/gltf-viewer';
import { Accumulator, base64, clipRange, floatCanvas, jitter, loadJob, perspective } from './common.js';

let S = null;

// The viewer's IBL prefiltering (its iblSampler) with its defaults is 2.4 billion texture samples: a 256²
// cube, 2048 Lambertian and 1024 GGX samples a texel, two 1024² LUTs of 512 samples; on a GPU a fraction of a
// second, on SwiftShader minutes. The `coarse` option sets smaller values with the same number of roughness
// levels (a 64² cube whose mips stop at 4², 256 and 128 samples, 128² LUTs).
const COARSE_IBL = { textureSize: 64, lowestMipLevel: 2, lambertianSampleCount: 256, ggxSampleCount: 128,
  sheenSamplCount: 32, lutResolution: 128 };

// iblSampler is internal to the bundle (made inside ResourceLoader.loadEnvironment). Its constructor assigns
// these fields one by one, so for the length of the call a setter of the same name on Object.prototype is
// what each assignment meets: it gives the new instance its own field with the value asked for instead.
async function withIblSettings(settings, fn) {
  const keys = Object.keys(settings);
  if (keys.some((k) => k in Object.prototype)) throw new Error('Object.prototype already has an IBL field');
  for (const k of keys) {
    Object.defineProperty(Object.prototype, k, {
      configurable: true,
      set() { Object.defineProperty(this, k, { value: settings[k], writable: true, configurable: true, enumerable: true }); },
    });
  }
  try {
    return await fn();
  } finally {
    for (const k of keys) delete Object.prototype[k];
  }
}

const LIBS = './node_modules/@khronosgroup/gltf-viewer/dist/libs/';

const sub = (a, b) => a.map((x, i) => x - b[i]);
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const unit = (a) => { const n = Math.hypot(...a); return a.map((x) => x / n); };

// The camera's world transform (column-major, gl-matrix's layout): right, up, back and the eye. The viewer's
// user camera is this transform; its view matrix is its inverse.
function cameraTransform(cam) {
  const back = unit(sub(cam.position, cam.target));
  const right = unit(cross(cam.up, back));
  const up = cross(back, right);
  return new Float32Array([...right, 0, ...up, 0, ...back, 0, ...cam.position, 1]);
}

// A float framebuffer of the job's size: RGBA32F colour (blendable where EXT_float_blend is, else RGBA16F:
// the viewer blends its BLEND materials into it) and a depth buffer.
function floatFramebuffer(gl, w, h) {
  const format = gl.getExtension('EXT_float_blend') ? gl.RGBA32F : gl.RGBA16F;
  const tex = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, tex);
  gl.texStorage2D(gl.TEXTURE_2D, 1, format, w, h);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
  gl.bindTexture(gl.TEXTURE_2D, null);
  const depth = gl.createRenderbuffer();
  gl.bindRenderbuffer(gl.RENDERBUFFER, depth);
  gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT24, w, h);
  gl.bindRenderbuffer(gl.RENDERBUFFER, null);
  const fb = gl.createFramebuffer();
  gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
  gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
  gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, depth);
  if (gl.checkFramebufferStatus(gl.FRAMEBUFFER) !== gl.FRAMEBUFFER_COMPLETE) {
    throw new Error('a float framebuffer is not complete: float render targets are not available');
  }
  gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  return { fb, tex, format: format === gl.RGBA32F ? 'RGBA32F' : 'RGBA16F' };
}

window.compareSetup = async ({ job: jobUrl, options }) => {
  const t0 = performance.now();
  const { job, base } = await loadJob(jobUrl);
  const { width: w, height: h } = job.camera;
  const { gl, renderer } = floatCanvas(w, h);
  const target = floatFramebuffer(gl, w, h);
  // the viewer's "default framebuffer" is the float one: every bindFramebuffer(null) it makes (its frame,
  // its clears) lands there; the page's own reads and the accumulator bind their framebuffers explicitly
  const bind = gl.bindFramebuffer.bind(gl);
  gl.bindFramebuffer = (t, fb) => bind(t, fb === null ? target.fb : fb);

  const view = new GltfView(gl);
  const state = view.createState();
  // the loader without the KTX and Draco decoders (createResourceLoader would look for their globals): the
  // job's glTF has PNG/JPEG images and plain buffers
  const loader = new ResourceLoader(view, LIBS);
  state.gltf = await loader.loadGltf(base + 'scene.gltf');
  state.sceneIndex = state.gltf.scene ?? 0;
  // environment.hdr: the job's map with its rotation and intensity baked in, laid out for the viewer's
  // panorama lookup (u = atan2(z, x) / 2π + ½), black where the scene has none (the viewer binds an
  // environment for every draw; black prefilters to black at any setting, so the coarse one). Its sheen
  // albedo table (lut_sheen_E.png, not in the npm package) is the suite's (compare/brdf/sheen.py)
  const env = job.scene.environment;
  const load = () => loader.loadEnvironment(base + 'environment.hdr', { lut_sheen_E_file: base + 'lut_sheen_E.png' });
  state.environment = await ((options && options.coarse) || !env ? withIblSettings(COARSE_IBL, load) : load());
  if (!state.environment) throw new Error('the viewer could not read environment.hdr');
  const p = state.renderingParameters;
  p.toneMap = GltfState.ToneMaps.NONE;
  p.exposure = 1.0;
  p.clearColor = [0, 0, 0, 1]; // a float target keeps the viewer's 0..255 grey as it is
  p.environmentRotation = 0; // the map is already turned (its default, 90°, would turn it again)
  p.blurEnvironmentMap = false; // the background as the other renderers show it: the sharp map
  p.renderEnvironmentMap = !!env && env.background !== false; // false: the clear colour (black) behind
  p.useIBL = !!env;
  p.usePunctual = true;
  p.useDirectionalLightsWithDisabledIBL = false;
  // KHR_lights_punctual in glTF's units (cd, lux) back to the suite's W/sr and W/m²; range ignored as
  // everywhere in the suite (the viewer's windowed falloff only where range > 0)
  for (const light of state.gltf.lights || []) {
    light.intensity /= job.lumens_per_watt;
    light.range = -1;
  }
  // LINEAR_OUTPUT: the viewer's own define for a pass whose output is linear radiance (its transmission
  // pass); added to every shader it selects, the final colour skips toneMap() (exposure and pow 1/2.2)
  const r = view.renderer;
  const fragDefines = r.pushFragParameterDefines.bind(r);
  r.pushFragParameterDefines = (defines, st) => {
    fragDefines(defines, st);
    if (!defines.includes('LINEAR_OUTPUT 1')) defines.push('LINEAR_OUTPUT 1');
  };
  // the scene's world bounds for the clip planes, as the viewer finds them (UserCamera.resetView); then the
  // suite's camera replaces the one it fitted
  const cam = state.userCamera;
  state.gltf.scenes[state.sceneIndex].applyTransformHierarchy(state.gltf);
  cam.resetView(state.gltf, state.sceneIndex);
  cam.transform = cameraTransform(job.camera);
  const { min, max } = cam.sceneExtents;
  const [near, far] = clipRange(job.camera.position, Array.from(min), Array.from(max));
  Object.assign(cam.perspective, { yfov: (job.camera.fov_deg * Math.PI) / 180, znear: near, zfar: far });
  S = { job, gl, view, state, target, w, h, k: 0, steps: 0, ms: 0 };
  cam.getProjectionMatrix = () => {
    const [jx, jy] = jitter(S.k);
    return perspective(job.camera.fov_deg, w, h, near, far, jx, jy);
  };
  // shader compilation and uploads belong to set-up: one frame drawn and thrown away
  const w0 = performance.now();
  S.acc = new Accumulator(gl, w, h);
  draw(0);
  S.acc.add(target.tex);
  S.acc = new Accumulator(gl, w, h);
  S.warm = performance.now() - w0;
  const version = (await (await fetch('./node_modules/@khronosgroup/gltf-viewer/package.json')).json()).version;
  return { setup_ms: performance.now() - t0, warm: S.warm, gl_renderer: renderer, version, width: w, height: h,
    target: target.format };
};

function draw(k) {
  S.k = k;
  S.view.renderFrame(S.state, S.w, S.h);
}

window.compareStep = async (n) => {
  while (S.steps < n) {
    const t0 = performance.now();
    draw(S.steps);
    S.acc.add(S.target.tex);
    S.ms += performance.now() - t0;
    S.steps += 1;
  }
  return { ms: S.ms, steps: S.steps };
};

window.compareImage = () => base64(S.acc.read());

window.compareReady = true;
