// The PlayCanvas page (compare/web/playcanvas.py): the job's glTF through PlayCanvas' own container
// loader (StandardMaterial, KHR_lights_punctual as PlayCanvas' lights), each area light as a light of
// rectangular shape (LIGHTSHAPE_RECT: linearly transformed cosines), the environment EXR through
// PlayCanvas' own prefiltering (EnvLighting into an env atlas), no tone mapping or gamma; jittered
// frames rendered into an RGBA32F render target and averaged in float in plain WebGL 2 (common.js),
// which also reads them back (PlayCanvas has no synchronous float readback).
import * as pc from 'playcanvas';
import { RectAreaLightTexturesLib } from 'three/addons/lights/RectAreaLightTexturesLib.js';
import { EXRLoader } from 'three/addons/loaders/EXRLoader.js';
import { Accumulator, base64, clipRange, floatCanvas, jitter, loadJob, peak, perspective } from './common.js';

let S = null;

// PlayCanvas' light colours are gamma-encoded and linearised with pow 2.2 (Color.linear): the encoded
// colour and intensity whose linear product is rgb, exactly (an intensity of at least 1 multiplies after
// linearising)
function setLinear(light, rgb) {
  const [unit, k] = peak(rgb);
  const [c, i] = k >= 1 ? [unit, k] : [rgb, 1];
  light.color = new pc.Color(...c.map((v) => Math.pow(v, 1 / 2.2)));
  light.intensity = i;
}

// PlayCanvas' shaders scale a light's diffuse term by 16 (the inverse-square falloff 16 / (d^2 + 1) of
// a punctual light, and 16 x the LTC form factor of an area light) and draw Lambert without 1/pi: the
// suite's radiance L of an area light is a colour L / 16, a punctual intensity I a colour I / (16 pi)
const AREA_SCALE = 1 / 16;
const PUNCTUAL_SCALE = 1 / (16 * Math.PI);

function loadContainer(app, url) {
  return new Promise((resolve, reject) => {
    app.assets.loadFromUrl(url, 'container', (err, asset) => (err ? reject(new Error(`glTF: ${err}`)) : resolve(asset)));
  });
}

async function buildScene(app, job, base, options) {
  const scene = app.scene;
  scene.ambientLight = new pc.Color(0, 0, 0);
  scene.clusteredLightingEnabled = false; // forward lights: each light's own shadow map and shape
  // the LTC tables PlayCanvas' examples load (area-light-luts.bin) are Heitz et al.'s fit, the one
  // three.js ships: the page takes three.js' copy, read the same way (uv = (roughness, sqrt(1 - N.V)))
  RectAreaLightTexturesLib.init();
  app.setAreaLightLuts(RectAreaLightTexturesLib.LTC_FLOAT_1.image.data, RectAreaLightTexturesLib.LTC_FLOAT_2.image.data);
  const asset = await loadContainer(app, base + 'scene.gltf');
  const root = asset.resource.instantiateRenderEntity();
  app.root.addChild(root);
  const renders = root.findComponents('render');
  // a light's range bounds its falloff window (1 - (d / range)^4)^2 and its shadow camera's depth: four
  // times the scene's diagonal keeps the window within 1e-4 of 1 and the depth precise
  const box = new pc.BoundingBox();
  renders.forEach((r, i) => r.meshInstances.forEach((mi, j) => (i || j ? box.add(mi.aabb) : box.copy(mi.aabb))));
  const range = 8 * Math.max(box.halfExtents.length(), 1e-3);
  // KHR_lights_punctual (job schema 2): the loader's lights, whose intensities it clamps to [0, 2]; set
  // from the job's W/sr and W/m^2; range ignored as everywhere in the suite
  const byName = new Map((job.scene.punctual || []).map((p) => [p.name, p]));
  const punctual = root.findComponents('light');
  for (const l of punctual) {
    const p = byName.get(l.entity.name);
    if (!p) continue;
    l.enabled = true;
    l.range = range;
    l.falloffMode = pc.LIGHTFALLOFF_INVERSESQUARED;
    setLinear(l, p.intensity.map((v) => v * (p.kind === 'directional' ? 1 / Math.PI : PUNCTUAL_SCALE)));
    if (p.kind === 'spot') {
      l.innerConeAngle = p.inner_cone_deg;
      l.outerConeAngle = p.outer_cone_deg;
    }
    l.castShadows = true;
    l.shadowResolution = 1024;
    l.shadowBias = 0.05;
    l.normalOffsetBias = 0.05;
  }
  for (const l of job.scene.lights) {
    // a spot light of rectangular shape: its local x and z scale the rectangle, it shines along local -y
    // (the cone a hemisphere, so only the shape bounds it); in the shadows variant a spot shadow map from
    // the light's centre, whose camera needs a cone under 90 degrees: 80, as threejs:shadows
    const e = new pc.Entity(l.name);
    const m = new pc.Mat4();
    const neg = (v) => v.map((c) => -c);
    const [x, y, z] = [l.tangent, neg(l.normal), l.bitangent];
    m.set([...x, 0, ...y, 0, ...z, 0, 0, 0, 0, 1]);
    e.setPosition(...l.center);
    e.setRotation(new pc.Quat().setFromMat4(m));
    e.setLocalScale(l.size[0], 1, l.size[1]);
    e.addComponent('light', {
      type: 'spot', shape: pc.LIGHTSHAPE_RECT, innerConeAngle: options.shadows ? 79.9 : 89.9,
      outerConeAngle: options.shadows ? 80 : 90, range,
      falloffMode: pc.LIGHTFALLOFF_INVERSESQUARED, castShadows: !!options.shadows, shadowResolution: 1024,
      shadowBias: 0.05, normalOffsetBias: 0.05,
    });
    setLinear(e.light, l.radiance.map((v) => v * AREA_SCALE));
    app.root.addChild(e);
    // the camera sees the emitter: a one-sided quad of its radiance facing the lit side
    const mat = new pc.StandardMaterial();
    mat.useLighting = false;
    mat.diffuse = new pc.Color(0, 0, 0);
    mat.emissive = new pc.Color(1, 1, 1);
    mat.emissiveIntensity = 1;
    mat.cull = pc.CULLFACE_BACK;
    const [unit, k] = peak(l.radiance);
    mat.emissive = new pc.Color(...unit.map((v) => Math.pow(v, 1 / 2.2))); // linearised with pow 2.2
    mat.emissiveIntensity = k;
    mat.update();
    const mesh = new pc.Mesh(app.graphicsDevice);
    mesh.setPositions(l.corners.flat());
    mesh.setNormals([...l.normal, ...l.normal, ...l.normal, ...l.normal]);
    mesh.setIndices([0, 1, 2, 0, 2, 3]);
    mesh.update();
    const face = new pc.Entity(`${l.name} face`);
    face.addComponent('render', { meshInstances: [new pc.MeshInstance(mesh, mat)], castShadows: false });
    app.root.addChild(face);
  }
  for (const r of renders) {
    r.castShadows = true;
    r.receiveShadows = true;
  }
  const env = job.scene.environment;
  if (env) {
    // PlayCanvas reads no EXR: three.js' EXRLoader decodes the file (a plain decoder, nothing of three's
    // renderer); the pixels go into a float texture that PlayCanvas reprojects and prefilters itself
    const buf = await (await fetch(base + 'environment.exr')).arrayBuffer();
    const exr = new EXRLoader().setDataType(1015 /* THREE.FloatType */).parse(buf);
    const src = new pc.Texture(app.graphicsDevice, {
      name: 'environment', width: exr.width, height: exr.height, format: pc.PIXELFORMAT_RGBA32F,
      projection: pc.TEXTUREPROJECTION_EQUIRECT, mipmaps: false, addressU: pc.ADDRESS_REPEAT,
      addressV: pc.ADDRESS_CLAMP_TO_EDGE, minFilter: pc.FILTER_LINEAR, magFilter: pc.FILTER_LINEAR,
      levels: [flipRows(exr.data, exr.width, exr.height)],
    });
    const lighting = pc.EnvLighting.generateLightingSource(src);
    // the atlas in half floats rather than PlayCanvas' default RGBP 8-bit encoding, which clips bright
    // environments
    const atlas = new pc.Texture(app.graphicsDevice, {
      name: 'envAtlas', width: 512, height: 512, format: pc.PIXELFORMAT_RGBA16F,
      projection: pc.TEXTUREPROJECTION_EQUIRECT, addressU: pc.ADDRESS_CLAMP_TO_EDGE,
      addressV: pc.ADDRESS_CLAMP_TO_EDGE, mipmaps: false,
    });
    pc.EnvLighting.generateAtlas(lighting, { target: atlas });
    const sky = new pc.Texture(app.graphicsDevice, {
      name: 'skybox', cubemap: true, width: 512, height: 512, format: pc.PIXELFORMAT_RGBA16F,
      addressU: pc.ADDRESS_CLAMP_TO_EDGE, addressV: pc.ADDRESS_CLAMP_TO_EDGE, mipmaps: false,
    });
    pc.reprojectTexture(src, sky, { numSamples: 1 });
    scene.envAtlas = atlas;
    scene.skybox = sky;
    scene.skyboxMip = 0;
    scene.skyboxIntensity = env.intensity;
    // the suite turns the lookup by rotation_deg (a direction d reads the map at R^-1 d); PlayCanvas' angle
    // turns the other way (the axes test of tests/test_web.py checks it against Mitsuba)
    scene.skyboxRotation = new pc.Quat().setFromEulerAngles(0, -env.rotation_deg, 0);
    // background false: no sky drawn (the camera's clear colour, black, behind the scene); skyboxIntensity and
    // skyboxRotation still scale and turn the environment light
    if (env.background === false) scene.layers.getLayerById(pc.LAYERID_SKYBOX).enabled = false;
    lighting.destroy();
  }
}

function flipRows(data, w, h) {
  // three's EXRLoader gives rows bottom-up (flipY for WebGL); a PlayCanvas texture's row 0 is the top
  const out = new Float32Array(data.length);
  const row = w * 4;
  for (let y = 0; y < h; y++) out.set(data.subarray(y * row, (y + 1) * row), (h - 1 - y) * row);
  return out;
}

window.compareSetup = async ({ job: jobUrl, engine: name, options }) => {
  const t0 = performance.now();
  const { job, base } = await loadJob(jobUrl);
  const { width: w, height: h } = job.camera;
  const { canvas, gl, renderer } = floatCanvas(w, h);
  const device = new pc.WebglGraphicsDevice(canvas, { gl, antialias: false, alpha: false });
  const app = new pc.AppBase(canvas);
  const opts = new pc.AppOptions();
  opts.graphicsDevice = device;
  opts.componentSystems = [pc.RenderComponentSystem, pc.CameraComponentSystem, pc.LightComponentSystem];
  opts.resourceHandlers = [pc.TextureHandler, pc.ContainerHandler];
  app.init(opts);
  app.autoRender = false;
  app.setCanvasFillMode(pc.FILLMODE_NONE, w, h);
  app.setCanvasResolution(pc.RESOLUTION_FIXED, w, h);
  S = { job, app, w, h, options: options || {}, steps: 0, ms: 0 };
  await buildScene(app, job, base, S.options);
  const c = job.camera;
  const frame = new pc.RenderTarget({
    colorBuffer: new pc.Texture(device, { name: 'frame', width: w, height: h, format: pc.PIXELFORMAT_RGBA32F,
      mipmaps: false, minFilter: pc.FILTER_NEAREST, magFilter: pc.FILTER_NEAREST }),
    depth: true,
  });
  const aabb = new pc.BoundingBox();
  let first = true;
  for (const r of app.root.findComponents('render')) {
    for (const mi of r.meshInstances) {
      if (first) aabb.copy(mi.aabb); else aabb.add(mi.aabb);
      first = false;
    }
  }
  const [near, far] = clipRange(c.position, aabb.getMin().toArray(), aabb.getMax().toArray());
  const cam = new pc.Entity('camera');
  cam.addComponent('camera', {
    clearColor: new pc.Color(0, 0, 0, 1), nearClip: near, farClip: far, fov: c.fov_deg,
    toneMapping: pc.TONEMAP_NONE, gammaCorrection: pc.GAMMA_NONE, renderTarget: frame,
  });
  cam.setPosition(...c.position);
  cam.lookAt(new pc.Vec3(...c.target), new pc.Vec3(...c.up));
  app.root.addChild(cam);
  // transmission refracts the opaque scene behind it: PlayCanvas grabs it only when a camera asks
  cam.camera.requestSceneColorMap(true);
  Object.assign(S, { cam, frame, near, far, fov: c.fov_deg, k: 0 });
  cam.camera.calculateProjection = (mat) => {
    const [jx, jy] = jitter(S.k);
    mat.set(Array.from(perspective(S.fov, S.w, S.h, S.near, S.far, jx, jy)));
  };
  app.start();
  S.acc = new Accumulator(gl, w, h);
  // shader compilation and uploads belong to set-up: one frame drawn and thrown away
  const w0 = performance.now();
  draw(0);
  S.acc.add(S.frame.colorBuffer.impl._glTexture);
  S.acc = new Accumulator(gl, w, h);
  S.warm = performance.now() - w0;
  return { setup_ms: performance.now() - t0, warm: S.warm, gl_renderer: renderer, version: pc.version,
    width: w, height: h };
};

function draw(k) {
  S.k = k;
  S.app.render();
}

window.compareStep = async (n) => {
  while (S.steps < n) {
    const t0 = performance.now();
    draw(S.steps);
    S.acc.add(S.frame.colorBuffer.impl._glTexture);
    S.ms += performance.now() - t0;
    S.steps += 1;
  }
  return { ms: S.ms, steps: S.steps };
};

window.compareImage = () => base64(S.acc.read());

window.compareReady = true;
