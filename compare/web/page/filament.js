// The Filament page (compare/web/filament.py): the job's glTF through Filament's own glTF loader (gltfio, its
// ubershader materials, KHR_lights_punctual as Filament lights), lit by an IndirectLight the suite made
// (ibl.json and ibl.bin: a prefiltered reflections cube with its mips and nine irradiance SH coefficients, the
// inputs of IndirectLight.Builder that Filament's cmgen tool would otherwise make), the same cube as the
// skybox. Exposure 1 (aperture 1, shutter 1.2 s, ISO 100), IBL and sky intensity 1, post-processing off
// (no tone mapping, no output transfer, no dithering or anti-aliasing): the view renders linear radiance
// into a float RenderTarget; jittered frames (a custom projection per frame) are averaged in float in plain
// WebGL 2 (common.js), which also reads them back (Filament's JavaScript bindings have no readPixels).
import { Accumulator, base64, clipRange, jitter, loadJob, peak, perspective } from './common.js';

let S = null;

// filament.js is a classic script (an Emscripten module under the global Filament) that finds filament.wasm
// beside itself
function loadScript(src) {
  return new Promise((resolve, reject) => {
    const s = document.createElement('script');
    s.src = src;
    s.onload = resolve;
    s.onerror = () => reject(new Error(`could not load ${src}`));
    document.head.appendChild(s);
  });
}

// Filament makes its GL objects itself and does not hand them out: the float colour texture of the view's
// render target is recognised when Filament allocates it (texStorage2D of RGBA32F at the job's size, the
// only one) and read by the accumulator in the same context.
function watchFloatTextures(gl, w, h) {
  const found = [];
  const storage = gl.texStorage2D.bind(gl);
  gl.texStorage2D = (target, levels, format, width, height) => {
    storage(target, levels, format, width, height);
    if (target === gl.TEXTURE_2D && format === gl.RGBA32F && width === w && height === h) {
      found.push(gl.getParameter(gl.TEXTURE_BINDING_2D));
    }
  };
  return found;
}

function cubeTexture(F, engine, levels, size, data) {
  const tex = F.Texture.Builder().width(size).height(size).levels(levels.length)
    .sampler(F.Texture$Sampler.SAMPLER_CUBEMAP).format(F.Texture$InternalFormat.RGB16F).build(engine);
  levels.forEach(([offset, count], level) => {
    const pixels = new Float32Array(data, offset, count);
    tex.setImageCube(engine, level, F.PixelBuffer(pixels, F.PixelDataFormat.RGB, F.PixelDataType.FLOAT));
  });
  return tex;
}

// Texture usage flags are bits (TextureUsage in filament.d.ts); the bindings give them as numbers or as
// enum values with a .value
function usage(F, name) {
  const u = F.Texture$Usage[name];
  return typeof u === 'object' ? u.value : u;
}

function loadAsset(asset, base) {
  return new Promise((resolve) => asset.loadResources(resolve, null, base, 1));
}

window.compareSetup = async ({ job: jobUrl }) => {
  const t0 = performance.now();
  const { job, base } = await loadJob(jobUrl);
  const { width: w, height: h } = job.camera;
  await loadScript('./node_modules/filament/filament.js');
  await new Promise((resolve) => Filament.init([], resolve));
  const F = Filament;
  const canvas = document.createElement('canvas');
  canvas.width = w;
  canvas.height = h;
  document.body.appendChild(canvas);
  const engine = F.Engine.create(canvas, { antialias: false, alpha: false });
  const gl = canvas.getContext('webgl2'); // the context Filament made
  if (!gl.getExtension('EXT_color_buffer_float')) {
    throw new Error('no EXT_color_buffer_float: float render targets are not available');
  }
  const found = watchFloatTextures(gl, w, h);
  const info = gl.getExtension('WEBGL_debug_renderer_info');
  const glRenderer = info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER);
  const scene = engine.createScene();
  const swapChain = engine.createSwapChain();
  const renderer = engine.createRenderer();
  renderer.setClearOptions({ clearColor: [0, 0, 0, 1], clear: true });
  const camera = engine.createCamera(F.EntityManager.get().create());
  const view = engine.createView();
  view.setCamera(camera);
  view.setScene(scene);
  view.setViewport([0, 0, w, h]);
  view.setPostProcessingEnabled(false);
  // the glTF through gltfio
  const gltf = new Uint8Array(await (await fetch(base + 'scene.gltf')).arrayBuffer());
  const loader = engine.createAssetLoader();
  const asset = loader.createAsset(gltf);
  if (!asset) throw new Error('Filament could not read the job\'s glTF');
  await loadAsset(asset, new URL(base, location.href).href);
  asset.releaseSourceData();
  scene.addEntities(asset.getEntities());
  // KHR_lights_punctual: gltfio makes point and spot lights of the glTF's candela and directional lights of
  // its lux; the job's W/sr and W/m² are set instead (setIntensity takes lumens, 4π candela, for point and
  // spot lights), with a falloff radius far beyond the scene (range ignored as everywhere in the suite)
  const box = asset.getBoundingBox();
  const lm = engine.getLightManager();
  const byName = new Map((job.scene.punctual || []).map((p) => [p.name, p]));
  const diag = Math.hypot(...[0, 1, 2].map((i) => box.max[i] - box.min[i])) || 10;
  for (const entity of asset.getLightEntities()) {
    const p = byName.get(asset.getName(entity));
    if (!p) continue;
    const inst = lm.getInstance(entity);
    const [color, k] = peak(p.intensity);
    lm.setColor(inst, color);
    lm.setIntensity(inst, p.kind === 'directional' ? k : 4 * Math.PI * k);
    if (p.kind !== 'directional') lm.setFalloff(inst, 8 * diag);
    inst.delete();
  }
  // the suite's IndirectLight and skybox (a black environment where the scene has none)
  const ibl = await (await fetch(base + 'ibl.json')).json();
  const data = await (await fetch(base + 'ibl.bin')).arrayBuffer();
  const cube = cubeTexture(F, engine, ibl.levels, ibl.size, data);
  const light = F.IndirectLight.Builder().reflections(cube).irradianceSh(3, ibl.sh).intensity(1.0).build(engine);
  scene.setIndirectLight(light);
  if (ibl.sky) scene.setSkybox(F.Skybox.Builder().environment(cube).build(engine));
  camera.setExposure(1.0, 1.2, 100.0);
  const c = job.camera;
  camera.lookAt(c.position, c.target, c.up);
  const [near, far] = clipRange(c.position, box.min, box.max);
  // the view's float target: colour RGBA32F (read by the accumulator), depth
  const color = F.Texture.Builder().width(w).height(h).levels(1)
    .usage(usage(F, 'COLOR_ATTACHMENT') | usage(F, 'SAMPLEABLE'))
    .sampler(F.Texture$Sampler.SAMPLER_2D).format(F.Texture$InternalFormat.RGBA32F).build(engine);
  const depth = F.Texture.Builder().width(w).height(h).levels(1).usage(usage(F, 'DEPTH_ATTACHMENT'))
    .sampler(F.Texture$Sampler.SAMPLER_2D).format(F.Texture$InternalFormat.DEPTH24).build(engine);
  const target = F.RenderTarget.Builder().texture(F.RenderTarget$AttachmentPoint.COLOR, color)
    .texture(F.RenderTarget$AttachmentPoint.DEPTH, depth).build(engine);
  view.setRenderTarget(target);
  S = { job, engine, renderer, swapChain, view, camera, w, h, near, far, fov: c.fov_deg, steps: 0, ms: 0, found, gl };
  // shader compilation and uploads belong to set-up: one frame drawn and thrown away
  const w0 = performance.now();
  draw(0);
  if (found.length !== 1) {
    throw new Error(`the view's float colour texture was not recognised (${found.length} RGBA32F ${w}×${h} textures)`);
  }
  S.tex = found[0];
  S.acc = new Accumulator(gl, w, h);
  S.acc.add(S.tex);
  S.acc = new Accumulator(gl, w, h);
  S.warm = performance.now() - w0;
  const version = (await (await fetch('./node_modules/filament/package.json')).json()).version;
  return { setup_ms: performance.now() - t0, warm: S.warm, gl_renderer: glRenderer, version,
    width: w, height: h };
};

function draw(k) {
  const [jx, jy] = jitter(k);
  S.camera.setCustomProjection(Array.from(perspective(S.fov, S.w, S.h, S.near, S.far, jx, jy)), S.near, S.far);
  // a standalone view: drawn into its render target outside beginFrame/endFrame, which could skip a frame
  // to pace a swap chain
  S.renderer.renderStandaloneView(S.view);
  S.engine.execute();
}

window.compareStep = async (n) => {
  while (S.steps < n) {
    const t0 = performance.now();
    draw(S.steps);
    S.acc.add(S.tex);
    S.ms += performance.now() - t0;
    S.steps += 1;
  }
  return { ms: S.ms, steps: S.steps };
};

window.compareImage = () => base64(S.acc.read());

window.compareReady = true;
