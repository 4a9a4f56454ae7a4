// What the Babylon.js and PlayCanvas pages share (compare/web/host.py drives them): the job, a WebGL 2
// canvas with float render targets, the jitter sequence, the projection it offsets, and an accumulator
// that averages each frame's float target into RGBA32F in plain WebGL 2 and reads it back as float32.

// Frame k's sub-pixel offset (pixels, x right, y down): the pixel centre first, then Halton (2, 3),
// as the three.js page and the progressive rasterizer do.
export function jitter(k) {
  const halton = (i, b) => {
    let f = 1, r = 0;
    for (; i > 0; i = Math.floor(i / b)) { f /= b; r += f * (i % b); }
    return r;
  };
  return k === 0 ? [0, 0] : [halton(k, 2) - 0.5, halton(k, 3) - 0.5];
}

export async function loadJob(jobUrl) {
  const job = await (await fetch(jobUrl)).json();
  return { job, base: jobUrl.substring(0, jobUrl.lastIndexOf('/') + 1) };
}

// A canvas of the job's size with a WebGL 2 context that renders to float targets, or one error naming
// what is missing.
export function floatCanvas(w, h, attributes = {}) {
  const canvas = document.createElement('canvas');
  canvas.width = w;
  canvas.height = h;
  document.body.appendChild(canvas);
  const gl = canvas.getContext('webgl2', { antialias: false, alpha: false, depth: true, stencil: true,
    preserveDrawingBuffer: false, ...attributes });
  if (!gl) throw new Error('no WebGL 2 context');
  if (!gl.getExtension('EXT_color_buffer_float')) {
    throw new Error('no EXT_color_buffer_float: float render targets are not available');
  }
  const info = gl.getExtension('WEBGL_debug_renderer_info');
  const renderer = info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER);
  return { canvas, gl, renderer };
}

// A right-handed perspective projection (OpenGL clip space, column-major: the memory layout of both
// Babylon's Matrix and PlayCanvas' Mat4), shifted by (jx, jy) pixels so that pixel centres sample
// there.
export function perspective(fovDeg, w, h, near, far, jx = 0, jy = 0) {
  const f = 1 / Math.tan((fovDeg * Math.PI) / 360);
  const a = w / h;
  const m = new Float32Array(16);
  m[0] = f / a;
  m[5] = f;
  m[10] = (far + near) / (near - far);
  m[11] = -1;
  m[14] = (2 * far * near) / (near - far);
  // clip x += dx * w_clip with w_clip = -z: the image moves by -jx so the centre samples at +jx
  m[8] = (2 * jx) / w;
  m[9] = (-2 * jy) / h;
  return m;
}

// The near and far planes for a camera at eye over a scene of the given bounds (min, max).
export function clipRange(eye, min, max) {
  const size = Math.hypot(max[0] - min[0], max[1] - min[1], max[2] - min[2]) || 10;
  const d = Math.hypot(...[0, 1, 2].map((i) => Math.max(min[i] - eye[i], 0, eye[i] - max[i])));
  const far = Math.max(d + size, 1e-3) * 2;
  return [far * 1e-5, far];
}

const VS = `#version 300 es
void main() { vec2 p = vec2(float((gl_VertexID & 1) << 2) - 1.0, float((gl_VertexID & 2) << 1) - 1.0);
  gl_Position = vec4(p, 0.0, 1.0); }`;
const FS = `#version 300 es
precision highp float; uniform sampler2D prev, frame; uniform float weight; out vec4 color;
void main() { ivec2 p = ivec2(gl_FragCoord.xy);
  color = mix(texelFetch(prev, p, 0), texelFetch(frame, p, 0), weight); }`;

// The running mean of frames in RGBA32F: A_k = A_(k-1) + (C_k - A_(k-1)) / k, as the three.js page and
// the rasterizer accumulate. It draws in the engine's own context, so it puts back every piece of GL
// state it touches: the engine's state caches stay true.
export class Accumulator {
  constructor(gl, w, h) {
    this.gl = gl;
    this.w = w;
    this.h = h;
    const shader = (type, src) => {
      const s = gl.createShader(type);
      gl.shaderSource(s, src);
      gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
      return s;
    };
    const saved = this.save();
    this.program = gl.createProgram();
    gl.attachShader(this.program, shader(gl.VERTEX_SHADER, VS));
    gl.attachShader(this.program, shader(gl.FRAGMENT_SHADER, FS));
    gl.linkProgram(this.program);
    if (!gl.getProgramParameter(this.program, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(this.program));
    this.vao = gl.createVertexArray();
    this.targets = [0, 1].map(() => {
      const tex = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_2D, tex);
      gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA32F, w, h);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
      const fb = gl.createFramebuffer();
      gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
      gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
      if (gl.checkFramebufferStatus(gl.FRAMEBUFFER) !== gl.FRAMEBUFFER_COMPLETE) {
        throw new Error('an RGBA32F render target is not complete: float render targets are not available');
      }
      return { tex, fb };
    });
    this.restore(saved);
    this.count = 0;
  }

  save() {
    const gl = this.gl;
    const caps = [gl.BLEND, gl.DEPTH_TEST, gl.CULL_FACE, gl.SCISSOR_TEST, gl.STENCIL_TEST, gl.RASTERIZER_DISCARD,
      gl.SAMPLE_ALPHA_TO_COVERAGE, gl.POLYGON_OFFSET_FILL];
    const active = gl.getParameter(gl.ACTIVE_TEXTURE);
    const units = [0, 1].map((i) => {
      gl.activeTexture(gl.TEXTURE0 + i);
      return [gl.getParameter(gl.TEXTURE_BINDING_2D), gl.getParameter(gl.SAMPLER_BINDING)];
    });
    gl.activeTexture(active);
    return {
      caps: caps.map((c) => [c, gl.isEnabled(c)]),
      draw: gl.getParameter(gl.DRAW_FRAMEBUFFER_BINDING), read: gl.getParameter(gl.READ_FRAMEBUFFER_BINDING),
      program: gl.getParameter(gl.CURRENT_PROGRAM), vao: gl.getParameter(gl.VERTEX_ARRAY_BINDING),
      viewport: gl.getParameter(gl.VIEWPORT), mask: gl.getParameter(gl.COLOR_WRITEMASK),
      depthMask: gl.getParameter(gl.DEPTH_WRITEMASK), active, units,
      pack: gl.getParameter(gl.PIXEL_PACK_BUFFER_BINDING), texture2d: null,
    };
  }

  restore(s) {
    const gl = this.gl;
    for (const [c, on] of s.caps) (on ? gl.enable(c) : gl.disable(c));
    gl.bindFramebuffer(gl.DRAW_FRAMEBUFFER, s.draw);
    gl.bindFramebuffer(gl.READ_FRAMEBUFFER, s.read);
    gl.useProgram(s.program);
    gl.bindVertexArray(s.vao);
    gl.viewport(...s.viewport);
    gl.colorMask(...s.mask);
    gl.depthMask(s.depthMask);
    s.units.forEach(([tex, sampler], i) => {
      gl.activeTexture(gl.TEXTURE0 + i);
      gl.bindTexture(gl.TEXTURE_2D, tex);
      gl.bindSampler(i, sampler);
    });
    gl.activeTexture(s.active);
    gl.bindBuffer(gl.PIXEL_PACK_BUFFER, s.pack);
  }

  // Adds the float texture `frame` (the engine's frame, this size) to the mean, then waits for the GPU
  // with a one-pixel readback: what the frame cost, not what was queued.
  add(frame) {
    const gl = this.gl;
    const s = this.save();
    const [prev, next] = this.targets;
    for (const c of [gl.BLEND, gl.DEPTH_TEST, gl.CULL_FACE, gl.SCISSOR_TEST, gl.STENCIL_TEST, gl.RASTERIZER_DISCARD,
      gl.SAMPLE_ALPHA_TO_COVERAGE, gl.POLYGON_OFFSET_FILL]) gl.disable(c);
    gl.bindFramebuffer(gl.FRAMEBUFFER, next.fb);
    gl.viewport(0, 0, this.w, this.h);
    gl.colorMask(true, true, true, true);
    gl.useProgram(this.program);
    gl.bindVertexArray(this.vao);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, prev.tex);
    gl.bindSampler(0, null);
    gl.activeTexture(gl.TEXTURE1);
    gl.bindTexture(gl.TEXTURE_2D, frame);
    gl.bindSampler(1, null);
    gl.uniform1i(gl.getUniformLocation(this.program, 'prev'), 0);
    gl.uniform1i(gl.getUniformLocation(this.program, 'frame'), 1);
    gl.uniform1f(gl.getUniformLocation(this.program, 'weight'), 1 / (this.count + 1));
    gl.drawArrays(gl.TRIANGLES, 0, 3);
    this.targets = [next, prev];
    this.count += 1;
    this.readInto(new Float32Array(4), 1, 1);
    this.restore(s);
  }

  readInto(px, w, h) {
    const gl = this.gl;
    gl.bindBuffer(gl.PIXEL_PACK_BUFFER, null);
    gl.bindFramebuffer(gl.READ_FRAMEBUFFER, this.targets[0].fb);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.FLOAT, px);
    return px;
  }

  // The mean's float32 RGBA pixels, bottom row first.
  read() {
    const s = this.save();
    const px = this.readInto(new Float32Array(this.w * this.h * 4), this.w, this.h);
    this.restore(s);
    return px;
  }
}

export function base64(floats) {
  const bytes = new Uint8Array(floats.buffer, floats.byteOffset, floats.byteLength);
  let s = '';
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
  return btoa(s);
}

// A colour as (unit colour, peak): the peak goes into a light's intensity.
export function peak(rgb) {
  const k = Math.max(rgb[0], rgb[1], rgb[2], 1e-30);
  return [[rgb[0] / k, rgb[1] / k, rgb[2] / k], k];
}
