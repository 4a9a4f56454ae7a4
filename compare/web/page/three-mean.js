// The running mean of jittered three.js frames in float, for the pages that draw with three.js (the three.js
// page, <model-viewer>'s linear variant; each page's import map names its own three.js release): frame k is
// drawn at jitter(k)'s sub-pixel offset into a float target and mixed into the mean with weight 1/(k+1).

import * as THREE from 'three';
import { FullScreenQuad } from 'three/addons/postprocessing/Pass.js';
import { jitter } from './common.js';

function floatTarget(w, h, samples = 0) {
  return new THREE.WebGLRenderTarget(w, h, {
    type: THREE.FloatType, format: THREE.RGBAFormat, colorSpace: THREE.LinearSRGBColorSpace,
    minFilter: THREE.NearestFilter, magFilter: THREE.NearestFilter, depthBuffer: true, samples,
  });
}

export class FrameMean {
  // w×h float targets: the frame's (multisampled with `samples` > 0) and the mean's two, read and written in turn
  constructor(w, h, samples = 0) {
    this.w = w;
    this.h = h;
    this.frame = floatTarget(w, h, samples);
    this.acc = [floatTarget(w, h), floatTarget(w, h)];
    this.blend = new FullScreenQuad(new THREE.ShaderMaterial({
      uniforms: { prev: { value: null }, frame: { value: null }, weight: { value: 1 } },
      vertexShader: 'varying vec2 vUv; void main() { vUv = uv; gl_Position = vec4(position.xy, 0.0, 1.0); }',
      fragmentShader: 'uniform sampler2D prev, frame; uniform float weight; varying vec2 vUv;'
        + 'void main() { gl_FragColor = mix(texture2D(prev, vUv), texture2D(frame, vUv), weight); }',
      depthTest: false, depthWrite: false, toneMapped: false,
    }));
  }

  // Frame k (0 first) of `scene` seen by `camera`, its view offset set to the frame's jitter, folded into the
  // mean; returns the target that now holds the mean.
  step(renderer, scene, camera, k) {
    const { w, h } = this;
    const [jx, jy] = jitter(k);
    camera.setViewOffset(w, h, jx, jy, w, h);
    renderer.setRenderTarget(this.frame);
    renderer.render(scene, camera);
    const [prev, next] = this.acc;
    this.blend.material.uniforms.prev.value = prev.texture;
    this.blend.material.uniforms.frame.value = this.frame.texture;
    this.blend.material.uniforms.weight.value = 1 / (k + 1);
    renderer.setRenderTarget(next);
    this.blend.render(renderer);
    this.acc = [next, prev];
    return next;
  }

  // the mean of the frames so far
  get target() {
    return this.acc[0];
  }
}
