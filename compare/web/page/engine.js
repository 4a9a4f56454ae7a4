// The page side of compare/web/renderer.py: builds the suite's job (job.json, scene.gltf,
// environment.exr) as a three.js scene and renders it with three.js (rasterized, jittered
// frames accumulated in float) or three-gpu-pathtracer (one path-traced sample per step).
// Output is linear radiance read back from float render targets: no tone mapping, no 8-bit
// images anywhere in the measurement path. Python drives it through Playwright:
//   await window.compareSetup({job, engine, options})  -> {setup_ms, renderer, ...}
//   await window.compareStep(n)                        -> cumulative ms of the first n steps
//   window.compareImage()                              -> base64 of the float32 RGBA pixels (bottom row first)
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { EXRLoader } from 'three/addons/loaders/EXRLoader.js';
import { RectAreaLightUniformsLib } from 'three/addons/lights/RectAreaLightUniformsLib.js';
import { FrameMean } from './three-mean.js';

let S = null;

function linear(rgb) {
  // THREE.Color holds linear floats; the peak goes into the light's intensity
  const k = Math.max(rgb[0], rgb[1], rgb[2], 1e-30);
  return [new THREE.Color().setRGB(rgb[0] / k, rgb[1] / k, rgb[2] / k, THREE.LinearSRGBColorSpace), k];
}

function basis(x, y, z) {
  const m = new THREE.Matrix4().makeBasis(new THREE.Vector3(...x), new THREE.Vector3(...y), new THREE.Vector3(...z));
  return new THREE.Quaternion().setFromRotationMatrix(m);
}

async function buildScene(renderer, job, base, options) {
  const scene = new THREE.Scene();
  const gltf = await new GLTFLoader().loadAsync(base + 'scene.gltf');
  scene.add(gltf.scene);
  // KHR_lights_punctual (job schema 2): three's own lights, made by the loader in glTF's units (cd, lux at
  // 683 lm/W); back to the suite's W/sr and W/m², range ignored as everywhere in the suite; hard shadow maps
  // (a cube for a point light, a perspective map for a spot, an orthographic one fitted to the scene for
  // the sun)
  const bounds = new THREE.Box3().setFromObject(gltf.scene);
  const diag = bounds.getSize(new THREE.Vector3()).length() || 1;
  const centre = bounds.getCenter(new THREE.Vector3());
  const lights = [];
  gltf.scene.traverse((o) => { if (o.isLight) lights.push(o); });
  for (const o of lights) {
    o.intensity /= job.lumens_per_watt;
    if (o.distance !== undefined) o.distance = 0;
    o.castShadow = true;
    o.shadow.mapSize.set(1024, 1024);
    o.shadow.bias = -1e-4;
    o.shadow.camera.near = diag * 1e-3;
    o.shadow.camera.far = diag * 4;
    if (o.isDirectionalLight) {
      // its shadow camera sits at the light's position: back along its direction from the scene's centre
      const from = o.getWorldPosition(new THREE.Vector3());
      const travel = o.target.getWorldPosition(new THREE.Vector3()).sub(from).normalize();
      scene.attach(o);
      o.position.copy(centre).addScaledVector(travel, -diag);
      o.target = new THREE.Object3D();
      o.target.position.copy(centre);
      scene.add(o.target);
      const c = o.shadow.camera;
      c.left = c.bottom = -diag / 2;
      c.right = c.top = diag / 2;
    }
    o.shadow.camera.updateProjectionMatrix();
  }
  const punctual = (job.scene.punctual || []).length > 0;
  RectAreaLightUniformsLib.init();
  for (const l of job.scene.lights) {
    const [color, k] = linear(l.radiance);
    if (options.shadows) {
      // a shadow-mapped stand-in: a spot light at the centre, its on-axis intensity the
      // rectangle's L·A (W/sr), its cone the lit hemisphere, instead of the unshadowed LTC light
      // (the cone stops at 80 degrees: a shadow camera of 180 degrees has no projection)
      const spot = new THREE.SpotLight(color, k * l.size[0] * l.size[1], 0, THREE.MathUtils.degToRad(80), 1, 2);
      spot.position.set(...l.center);
      spot.target.position.set(l.center[0] + l.normal[0], l.center[1] + l.normal[1], l.center[2] + l.normal[2]);
      spot.castShadow = true;
      spot.shadow.mapSize.set(1024, 1024);
      spot.shadow.bias = -1e-4;
      const diag = new THREE.Box3().setFromObject(gltf.scene).getSize(new THREE.Vector3()).length() || 1;
      spot.shadow.camera.near = diag * 1e-3; // three's default 0.5 m would clip a room-sized scene
      spot.shadow.camera.far = diag * 2;
      scene.add(spot, spot.target);
    } else {
      // RectAreaLight: width along local x, height along local y, shining along local -z (one-sided)
      const neg = (v) => v.map((c) => -c);
      const light = new THREE.RectAreaLight(color, k, l.size[0], l.size[1]);
      light.position.set(...l.center);
      light.quaternion.copy(basis(l.tangent, neg(l.bitangent), neg(l.normal)));
      scene.add(light);
    }
    // the camera sees the emitter: a plane of its radiance facing the lit side
    const face = new THREE.Mesh(new THREE.PlaneGeometry(l.size[0], l.size[1]),
      new THREE.MeshBasicMaterial({ color: color.clone().multiplyScalar(k), side: THREE.FrontSide, toneMapped: false }));
    face.position.set(...l.center);
    face.quaternion.copy(basis(l.tangent, l.bitangent, l.normal));
    face.userData.isLightFace = true;
    scene.add(face);
  }
  const env = job.scene.environment;
  if (env) {
    const tex = await new EXRLoader().setDataType(THREE.FloatType).loadAsync(base + 'environment.exr');
    tex.mapping = THREE.EquirectangularReflectionMapping;
    tex.colorSpace = THREE.LinearSRGBColorSpace;
    // three's equirect u is Mitsuba's u + 1/4; three applies the inverse of environmentRotation
    const y = THREE.MathUtils.degToRad(env.rotation_deg) - Math.PI / 2;
    // background false: the map lights the scene but camera rays that hit nothing see black (the path
    // tracer draws a colour background for its camera rays, the environment for the others)
    scene.background = env.background === false ? new THREE.Color(0, 0, 0) : tex;
    scene.backgroundIntensity = env.intensity;
    scene.backgroundRotation.set(0, y, 0);
    scene.environmentIntensity = env.intensity;
    scene.environmentRotation.set(0, y, 0);
    if (options.engine === 'threejs') {
      const pmrem = new THREE.PMREMGenerator(renderer);
      scene.environment = pmrem.fromEquirectangular(tex).texture;
      pmrem.dispose();
    } else {
      scene.environment = tex;
    }
  } else {
    scene.background = new THREE.Color(0, 0, 0);
  }
  if (options.shadows || punctual) {
    renderer.shadowMap.enabled = true;
    renderer.shadowMap.type = THREE.PCFSoftShadowMap;
    scene.traverse((o) => {
      if (o.isMesh && !o.userData.isLightFace) {
        o.castShadow = true;
        o.receiveShadow = true;
        // a double-sided material's shadow from the faces turned away from the light, as three does for a
        // single-sided one (its default for DoubleSide, both sides, shadows every lit surface on itself)
        for (const m of Array.isArray(o.material) ? o.material : [o.material]) {
          if (m.side === THREE.DoubleSide) m.shadowSide = THREE.BackSide;
        }
      }
    });
  }
  return scene;
}

function makeCamera(job, scene) {
  const c = job.camera;
  const box = new THREE.Box3().setFromObject(scene);
  const eye = new THREE.Vector3(...c.position);
  const far = Math.max(box.isEmpty() ? 10 : box.distanceToPoint(eye) + box.getSize(new THREE.Vector3()).length(), 1e-3) * 2;
  const camera = new THREE.PerspectiveCamera(c.fov_deg, c.width / c.height, far * 1e-5, far);
  camera.up.set(...c.up);
  camera.position.copy(eye);
  camera.lookAt(...c.target);
  camera.updateMatrixWorld();
  return camera;
}

function sync(renderer, target) {
  // a one-pixel readback waits for the GPU: what a frame cost, not what was queued
  const px = new Float32Array(4);
  renderer.readRenderTargetPixels(target, 0, 0, 1, 1, px);
}

window.compareSetup = async ({ job: jobUrl, engine, options }) => {
  const t0 = performance.now();
  const job = await (await fetch(jobUrl)).json();
  const base = jobUrl.substring(0, jobUrl.lastIndexOf('/') + 1);
  const { width: w, height: h } = job.camera;
  const canvas = document.createElement('canvas');
  canvas.width = w;
  canvas.height = h;
  document.body.appendChild(canvas);
  const gl = canvas.getContext('webgl2', { antialias: false, alpha: false, depth: true });
  if (!gl) throw new Error('no WebGL 2 context');
  if (!gl.getExtension('EXT_color_buffer_float')) throw new Error('no EXT_color_buffer_float: float render targets are not available');
  const info = gl.getExtension('WEBGL_debug_renderer_info');
  const glRenderer = info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER);
  const renderer = new THREE.WebGLRenderer({ canvas, context: gl, antialias: false });
  renderer.setPixelRatio(1);
  renderer.setSize(w, h, false);
  renderer.toneMapping = THREE.NoToneMapping;
  renderer.outputColorSpace = THREE.LinearSRGBColorSpace;
  options = { ...(options || {}), engine };
  const scene = await buildScene(renderer, job, base, options);
  const camera = makeCamera(job, scene);
  S = { job, renderer, scene, camera, w, h, engine, options, steps: 0, ms: 0 };
  if (engine === 'threejs') {
    S.mean = new FrameMean(w, h, options.msaa ? 4 : 0);
    renderer.compile(scene, camera);
    renderer.setRenderTarget(S.mean.frame);
    renderer.render(scene, camera); // shader compilation and uploads belong to set-up
    sync(renderer, S.mean.frame);
  } else {
    const { WebGLPathTracer } = await import('three-gpu-pathtracer');
    const pt = new WebGLPathTracer(renderer);
    pt.tiles.set(1, 1);
    pt.renderToCanvas = false;
    pt.rasterizeScene = false;
    pt.renderDelay = 0;
    pt.minSamples = 0;
    pt.fadeDuration = 0;
    pt.dynamicLowRes = false;
    pt.filterGlossyFactor = 0; // no bias against fireflies: the ground truth has none
    pt.bounces = Math.max(1, job.scene.max_depth - 1);
    scene.traverse((o) => { if (o.userData.isLightFace) o.visible = false; }); // it traces the RectAreaLight itself
    pt.setScene(scene, camera);
    while (pt.isCompiling) await new Promise((r) => setTimeout(r, 20));
    // the first update only starts compiling the path tracing shader (tens of seconds on
    // SwiftShader without KHR_parallel_shader_compile): trace until one sample exists, in set-up,
    // then start the count again
    const w0 = performance.now();
    while (pt.samples < 1) {
      pt.renderSample();
      sync(renderer, pt.target);
      await new Promise((r) => setTimeout(r, 0));
    }
    S.warm = performance.now() - w0;
    pt.reset();
    S.pt = pt;
  }
  return { setup_ms: performance.now() - t0, warm: S.warm, gl_renderer: glRenderer, three: THREE.REVISION, version: THREE.REVISION, width: w, height: h };
};

window.compareStep = async (n) => {
  const { renderer, scene, camera } = S;
  while (S.steps < n) {
    const t0 = performance.now();
    if (S.engine === 'threejs') {
      // frame k: jittered by Halton (2, 3), the first one at the pixel centres
      sync(renderer, S.mean.step(renderer, scene, camera, S.steps));
    } else {
      S.pt.renderSample();
      sync(renderer, S.pt.target);
    }
    S.ms += performance.now() - t0;
    S.steps += 1;
  }
  return { ms: S.ms, steps: S.steps, samples: S.pt ? S.pt.samples : S.steps };
};

window.compareImage = () => {
  const target = S.engine === 'threejs' ? S.mean.target : S.pt.target;
  const px = new Float32Array(S.w * S.h * 4);
  S.renderer.readRenderTargetPixels(target, 0, 0, S.w, S.h, px);
  const bytes = new Uint8Array(px.buffer);
  let s = '';
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
  return btoa(s);
};

window.compareReady = true;
