// The Babylon.js page (compare/web/babylon.py): the job's glTF through Babylon's own glTF loader (its
// materials, KHR_lights_punctual as Babylon's lights), each area light as a RectAreaLight (linearly
// transformed cosines, no shadows) with a visible emitter face, the environment EXR through
// EXRCubeTexture and Babylon's own prefiltering, no tone mapping or gamma; jittered frames rendered
// into a float render target and averaged in float (common.js).
import { Engine } from '@babylonjs/core/Engines/engine.js';
import { Constants } from '@babylonjs/core/Engines/constants.js';
import { Scene } from '@babylonjs/core/scene.js';
import { Vector3, Matrix, Quaternion } from '@babylonjs/core/Maths/math.vector.js';
import { Color3, Color4 } from '@babylonjs/core/Maths/math.color.js';
import { FreeCamera } from '@babylonjs/core/Cameras/freeCamera.js';
import { TransformNode } from '@babylonjs/core/Meshes/transformNode.js';
import { Mesh } from '@babylonjs/core/Meshes/mesh.js';
import { VertexData } from '@babylonjs/core/Meshes/mesh.vertexData.js';
import { RectAreaLight } from '@babylonjs/core/Lights/rectAreaLight.js';
import { SpotLight } from '@babylonjs/core/Lights/spotLight.js';
import { ShadowGenerator } from '@babylonjs/core/Lights/Shadows/shadowGenerator.js';
import '@babylonjs/core/Lights/Shadows/shadowGeneratorSceneComponent.js';
import { RenderTargetTexture } from '@babylonjs/core/Materials/Textures/renderTargetTexture.js';
import { RawTexture } from '@babylonjs/core/Materials/Textures/rawTexture.js';
import { EXRCubeTexture } from '@babylonjs/core/Materials/Textures/exrCubeTexture.js';
import { ExrLoaderGlobalConfiguration } from '@babylonjs/core/Materials/Textures/Loaders/EXR/exrLoader.configuration.js';
import { PBRMaterial } from '@babylonjs/core/Materials/PBR/pbrMaterial.js';
import '@babylonjs/core/Helpers/sceneHelpers.js';
import '@babylonjs/core/Loading/loadingScreen.js';
import { AppendSceneAsync } from '@babylonjs/core/Loading/sceneLoader.js';
import '@babylonjs/loaders/glTF/glTFFileLoader.js';
import '@babylonjs/loaders/glTF/2.0/index.js';
import { RectAreaLightTexturesLib } from 'three/addons/lights/RectAreaLightTexturesLib.js';
import { Accumulator, base64, clipRange, floatCanvas, jitter, loadJob, peak, perspective } from './common.js';

let S = null;

// The LTC tables Babylon fetches from its CDN (areaLightsLTC.bin) are Heitz et al.'s fit, the one
// three.js ships: the page takes three.js' copy, so nothing is fetched from outside, and both engines
// read it the same way (uv = (roughness, sqrt(1 - N.V)), M^-1 from (t.x, t.y, t.z, t.w)).
function installLtc(scene) {
  RectAreaLightTexturesLib.init();
  const engine = scene.getEngine();
  const make = (data) => {
    const t = RawTexture.CreateRGBATexture(data, 64, 64, engine, false, false, Constants.TEXTURE_BILINEAR_SAMPLINGMODE,
      Constants.TEXTURETYPE_HALF_FLOAT);
    t.wrapU = t.wrapV = Constants.TEXTURE_CLAMP_ADDRESSMODE;
    return t;
  };
  scene._ltcTextures = { LTC1: make(RectAreaLightTexturesLib.LTC_HALF_1.image.data),
    LTC2: make(RectAreaLightTexturesLib.LTC_HALF_2.image.data) };
}

// A frame whose axes are x, y, z (world vectors), at p.
function node(scene, name, p, x, y, z) {
  const t = new TransformNode(name, scene);
  const m = Matrix.FromValues(...x, 0, ...y, 0, ...z, 0, 0, 0, 0, 1);
  t.rotationQuaternion = Quaternion.FromRotationMatrix(m);
  t.position = new Vector3(...p);
  return t;
}

async function buildScene(engine, job, base, options) {
  const scene = new Scene(engine);
  scene.useRightHandedSystem = true; // glTF's and the suite's frame: the loader adds no mirroring root
  scene.clearColor = new Color4(0, 0, 0, 1);
  scene.ambientColor = new Color3(0, 0, 0);
  // linear radiance out: image processing "by a post-process" that is never attached, so the materials
  // skip tone mapping and gamma, and no clamp at 30
  const ip = scene.imageProcessingConfiguration;
  ip.applyByPostProcess = true;
  ip.toneMappingEnabled = false;
  ip.skipFinalColorClamp = true;
  ip.exposure = 1;
  ip.contrast = 1;
  await AppendSceneAsync(base + 'scene.gltf', scene, { pluginExtension: '.gltf' });
  installLtc(scene);
  for (const c of [...scene.cameras]) c.dispose(); // the job's camera is made below
  const meshes = scene.meshes.filter((m) => m.getTotalVertices() > 0);
  // KHR_lights_punctual (job schema 2): Babylon's lights in glTF's units (cd, lux at 683 lm/W); back to
  // the suite's W/sr and W/m^2; range ignored as everywhere in the suite
  const punctual = scene.lights.filter((l) => !(l instanceof RectAreaLight));
  for (const l of punctual) {
    l.intensity /= job.lumens_per_watt;
    l.range = Number.MAX_VALUE;
  }
  const shadowCasters = [];
  for (const l of job.scene.lights) {
    const [color, k] = peak(l.radiance);
    const neg = (v) => v.map((c) => -c);
    if (options.shadows) {
      // a shadow-mapped stand-in, as threejs:shadows: a spot light at the centre, on-axis intensity the
      // rectangle's L.A (W/sr), its cone the lit hemisphere up to 80 degrees (RectAreaLight casts none)
      const spot = new SpotLight(l.name, new Vector3(...l.center), new Vector3(...l.normal), Math.PI * 160 / 180, 1, scene);
      spot.diffuse = spot.specular = new Color3(...color);
      spot.intensity = k * l.size[0] * l.size[1];
      spot.falloffType = 2; // glTF's: the physical inverse square, no range
      spot.range = Number.MAX_VALUE;
      shadowCasters.push(spot);
    } else {
      // RectAreaLight: width along local x, height along local y, lit side along local -z
      const light = new RectAreaLight(l.name, Vector3.Zero(), l.size[0], l.size[1], scene);
      light.parent = node(scene, `${l.name} frame`, l.center, l.tangent, neg(l.bitangent), neg(l.normal));
      light.diffuse = light.specular = new Color3(...color);
      light.intensity = k;
    }
    // the camera sees the emitter: a one-sided quad of its radiance facing the lit side
    const face = new Mesh(`${l.name} face`, scene);
    const vd = new VertexData();
    vd.positions = l.corners.flat();
    vd.indices = [0, 2, 1, 0, 3, 2]; // Babylon's front faces wind clockwise
    vd.normals = [...l.normal, ...l.normal, ...l.normal, ...l.normal];
    vd.applyToMesh(face);
    const m = new PBRMaterial(`${l.name} emitter`, scene);
    m.unlit = true;
    m.albedoColor = new Color3(0, 0, 0);
    m.emissiveColor = new Color3(color[0] * k, color[1] * k, color[2] * k);
    m.backFaceCulling = true;
    face.material = m;
    face.metadata = { isLightFace: true };
  }
  if (options.shadows || punctual.length) {
    for (const l of [...shadowCasters, ...punctual]) {
      const g = new ShadowGenerator(1024, l);
      g.usePoissonSampling = true; // PCF's comparison sampler meets a float texture on its unit once an environment is bound
      g.bias = 1e-4;
      for (const m of meshes) g.addShadowCaster(m);
    }
    for (const m of meshes) m.receiveShadows = true;
  }
  const env = job.scene.environment;
  if (env) {
    // Babylon's EXR reader loads fflate from unpkg: the same version, served from web/node_modules
    ExrLoaderGlobalConfiguration.FFLATEUrl = new URL('./node_modules/fflate/umd/index.js', location.href).href;
    const tex = await new Promise((resolve, reject) => {
      const t = new EXRCubeTexture(base + 'environment.exr', scene, 256, false, true, false, true,
        () => resolve(t), (m, e) => reject(new Error(`the environment did not load: ${m || e}`)));
    });
    // Babylon's cube, made from the map in a right-handed scene, sees the suite's +X where it puts -X, and
    // its rotationY turns the other way: half a turn less the suite's angle lines them up (the axes test
    // of tests/test_web.py checks it against Mitsuba)
    tex.rotationY = Math.PI - (env.rotation_deg * Math.PI) / 180;
    scene.environmentTexture = tex;
    scene.environmentIntensity = env.intensity;
    if (env.background !== false) { // background false: no skybox, the clear colour (black) behind the scene
      S.skybox = scene.createDefaultSkybox(tex, true, 1, 0, false);
      S.skybox.material.reflectionTexture.rotationY = tex.rotationY;
    }
  }
  return scene;
}

window.compareSetup = async ({ job: jobUrl, engine: name, options }) => {
  const t0 = performance.now();
  const { job, base } = await loadJob(jobUrl);
  const { width: w, height: h } = job.camera;
  const { gl, renderer } = floatCanvas(w, h);
  const engine = new Engine(gl, false, { preserveDrawingBuffer: false, stencil: true, doNotHandleContextLost: true });
  if (engine.webGLVersion < 2) throw new Error('no WebGL 2 context');
  S = { job, engine, w, h, options: options || {}, steps: 0, ms: 0 };
  const scene = await buildScene(engine, job, base, S.options);
  const c = job.camera;
  const camera = new FreeCamera('camera', new Vector3(...c.position), scene);
  camera.upVector = new Vector3(...c.up);
  camera.setTarget(new Vector3(...c.target));
  const bounds = scene.getWorldExtends((m) => m.getTotalVertices() > 0 && m !== S.skybox);
  const [near, far] = clipRange(c.position, bounds.min.asArray(), bounds.max.asArray());
  if (S.skybox) S.skybox.scaling = new Vector3(far, far, far);
  scene.activeCamera = camera;
  const frame = new RenderTargetTexture('frame', { width: w, height: h }, scene, {
    type: Constants.TEXTURETYPE_FLOAT, samplingMode: Constants.TEXTURE_NEAREST_SAMPLINGMODE,
    generateMipMaps: false, generateDepthBuffer: true, generateStencilBuffer: true,
  });
  camera.outputRenderTarget = frame;
  Object.assign(S, { scene, camera, frame, near, far, fov: c.fov_deg });
  S.acc = new Accumulator(gl, w, h);
  await scene.whenReadyAsync();
  // shader compilation and uploads belong to set-up: one frame drawn and thrown away
  const w0 = performance.now();
  draw(0);
  S.acc.add(S.frameTexture);
  S.acc = new Accumulator(gl, w, h);
  S.warm = performance.now() - w0;
  return { setup_ms: performance.now() - t0, warm: S.warm, gl_renderer: renderer, version: Engine.Version,
    width: w, height: h };
};

function draw(k) {
  const [jx, jy] = jitter(k);
  S.camera.freezeProjectionMatrix(Matrix.FromArray(perspective(S.fov, S.w, S.h, S.near, S.far, jx, jy)));
  S.scene.render();
  S.frameTexture = S.frame.getInternalTexture()._hardwareTexture.underlyingResource;
}

window.compareStep = async (n) => {
  while (S.steps < n) {
    const t0 = performance.now();
    draw(S.steps);
    S.acc.add(S.frameTexture);
    S.ms += performance.now() - t0;
    S.steps += 1;
  }
  return { ms: S.ms, steps: S.steps };
};

window.compareImage = () => base64(S.acc.read());

window.compareReady = true;
