/* compare report: the interactive HDR viewer (swipe comparison + exposure slider), and sortable tables.
 *
 * Data: each scene's data/<id>.js registers window.COMPARE_HDR[id] with linear
 * RGB images as little-endian float16, base64 (see compare/report/html.py).
 * They come in through <script src> because a page opened from file:// may not
 * fetch files and a canvas showing an <img> from disk cannot be read back.
 *
 * Tone mapping mirrors compare.image.tonemap.to_ldr(image, exposure, operator="aces"):
 * clamp negatives, Stephen Hill's ACES fit (RRT+ODT, same matrices and curve as
 * compare.image.tonemap.aces), clamp to [0, 1], sRGB transfer, 8-bit rounding.
 * Keep the two in step: tests/test_browser.py compares them pixel by pixel.
 */
"use strict";

(function () {
  // compare.image.tonemap._ACES_IN / _ACES_OUT, row-major.
  const ACES_IN = [0.59719, 0.35458, 0.04823, 0.07600, 0.90834, 0.01566, 0.02840, 0.13383, 0.83777];
  const ACES_OUT = [1.60475, -0.53108, -0.07367, -0.10208, 1.10813, -0.00605, -0.00327, -0.07276, 1.07602];
  const F32_MAX = 3.4028234663852886e38;

  function clamp01(x) { return x < 0 ? 0 : (x > 1 ? 1 : x); }

  function srgbEncode(x) {
    return x <= 0.0031308 ? 12.92 * x : 1.055 * Math.pow(x, 1 / 2.4) - 0.055;
  }

  function rrtOdt(v) {
    return (v * (v + 0.0245786) - 0.000090537) / (v * (0.983729 * v + 0.4329510) + 0.238081);
  }

  /** Linear RGB × exposure → 8-bit sRGB [r, g, b], as compare.image.tonemap.write_png does. */
  function tonemap(r, g, b, exposure) {
    // _prep: clamp to [0, float32 max] after the exposure multiply.
    r = Math.min(Math.max(r * exposure, 0), F32_MAX);
    g = Math.min(Math.max(g * exposure, 0), F32_MAX);
    b = Math.min(Math.max(b * exposure, 0), F32_MAX);
    const x = rrtOdt(ACES_IN[0] * r + ACES_IN[1] * g + ACES_IN[2] * b);
    const y = rrtOdt(ACES_IN[3] * r + ACES_IN[4] * g + ACES_IN[5] * b);
    const z = rrtOdt(ACES_IN[6] * r + ACES_IN[7] * g + ACES_IN[8] * b);
    const R = clamp01(ACES_OUT[0] * x + ACES_OUT[1] * y + ACES_OUT[2] * z);
    const G = clamp01(ACES_OUT[3] * x + ACES_OUT[4] * y + ACES_OUT[5] * z);
    const B = clamp01(ACES_OUT[6] * x + ACES_OUT[7] * y + ACES_OUT[8] * z);
    return [
      Math.round(clamp01(srgbEncode(R)) * 255),
      Math.round(clamp01(srgbEncode(G)) * 255),
      Math.round(clamp01(srgbEncode(B)) * 255),
    ];
  }

  // All 65536 half-float values, decoded once (faster than decoding per pixel).
  let HALF = null;
  function halfTable() {
    if (HALF) return HALF;
    HALF = new Float32Array(65536);
    for (let h = 0; h < 65536; h++) {
      const s = (h & 0x8000) ? -1 : 1, e = (h >> 10) & 0x1f, f = h & 0x3ff;
      if (e === 0) HALF[h] = s * f * Math.pow(2, -24);
      else if (e === 31) HALF[h] = f ? NaN : s * Infinity;
      else HALF[h] = s * (1 + f / 1024) * Math.pow(2, e - 15);
    }
    return HALF;
  }

  /** base64 little-endian float16 → Float32Array. */
  function decodeF16(b64) {
    const bin = atob(b64);
    const n = bin.length >> 1;
    const out = new Float32Array(n);
    const table = halfTable();
    for (let i = 0; i < n; i++) {
      out[i] = table[bin.charCodeAt(2 * i) | (bin.charCodeAt(2 * i + 1) << 8)];
    }
    return out;
  }

  /** Tone-map a decoded linear image into RGBA bytes. */
  function toneMapImage(hdr, width, height, exposure) {
    const out = new Uint8ClampedArray(width * height * 4);
    for (let p = 0, q = 0; p < width * height * 3; p += 3, q += 4) {
      const c = tonemap(hdr[p], hdr[p + 1], hdr[p + 2], exposure);
      out[q] = c[0]; out[q + 1] = c[1]; out[q + 2] = c[2]; out[q + 3] = 255;
    }
    return out;
  }

  class Viewer {
    constructor(root, data) {
      this.root = root;
      this.data = data;
      this.width = data.width;
      this.height = data.height;
      this.canvas = root.querySelector("canvas.view");
      this.canvas.width = this.width;
      this.canvas.height = this.height;
      this.ctx = this.canvas.getContext("2d");
      this.divider = root.querySelector(".divider");
      this.pickA = root.querySelector(".pick-a");
      this.pickB = root.querySelector(".pick-b");
      this.swipe = root.querySelector(".swipe");
      this.ev = root.querySelector(".ev");
      this.evOut = root.querySelector(".ev-value");
      this.hdr = {};     // key -> Float32Array (decoded lazily)
      this.ldr = {};     // key -> {exposure, rgba}
      for (const img of data.images) this.hdr[img.key] = img;
      const stage = root.querySelector(".stage");
      // Small images are shown magnified (pixelated), large ones at their size.
      const scale = Math.max(1, Math.floor(640 / this.width));
      this.canvas.style.width = Math.min(this.width * scale, 1300) + "px";
      const redraw = () => this.draw();
      this.swipe.addEventListener("input", redraw);
      this.ev.addEventListener("input", redraw);
      this.pickA.addEventListener("change", redraw);
      this.pickB.addEventListener("change", redraw);
      let dragging = false;
      const fromPointer = (ev) => {
        const rect = this.canvas.getBoundingClientRect();
        const f = (ev.clientX - rect.left) / Math.max(1, rect.width);
        this.swipe.value = String(Math.round(clamp01(f) * 1000));
        this.draw();
      };
      stage.addEventListener("pointerdown", (ev) => { dragging = true; stage.setPointerCapture(ev.pointerId); fromPointer(ev); });
      stage.addEventListener("pointermove", (ev) => { if (dragging) fromPointer(ev); });
      stage.addEventListener("pointerup", () => { dragging = false; });
      stage.addEventListener("pointercancel", () => { dragging = false; });
      this.draw();
    }

    exposure() {
      return this.data.exposure * Math.pow(2, parseFloat(this.ev.value));
    }

    image(key) {
      const exposure = this.exposure();
      const cached = this.ldr[key];
      if (cached && cached.exposure === exposure) return cached.rgba;
      const entry = this.hdr[key];
      if (!entry) throw new Error("no HDR image " + key);
      if (!entry.pixels) entry.pixels = decodeF16(entry.data);
      if (entry.pixels.length !== this.width * this.height * 3) {
        throw new Error("HDR image " + key + " has " + entry.pixels.length + " values, expected " + this.width * this.height * 3);
      }
      const rgba = toneMapImage(entry.pixels, this.width, this.height, exposure);
      this.ldr[key] = { exposure, rgba };
      return rgba;
    }

    /** Compose: columns left of the swipe position from image A, the rest from image B. */
    draw() {
      const a = this.image(this.pickA.value), b = this.image(this.pickB.value);
      const w = this.width, h = this.height;
      const split = Math.round(parseInt(this.swipe.value, 10) / 1000 * w);
      const out = this.ctx.createImageData(w, h);
      for (let y = 0; y < h; y++) {
        const row = y * w * 4;
        out.data.set(a.subarray(row, row + split * 4), row);
        out.data.set(b.subarray(row + split * 4, row + w * 4), row + split * 4);
      }
      this.ctx.putImageData(out, 0, 0);
      this.divider.style.left = (split / w * 100) + "%";
      const ev = parseFloat(this.ev.value);
      this.evOut.textContent = "EV " + (ev >= 0 ? "+" : "") + ev.toFixed(1) + " (×" + this.exposure().toPrecision(3) + ")";
    }
  }

  /** Sortable tables (the scenario table): a header button sorts the body's rows by a number its column's
   * cells carry (data-<key> of the cell in column data-col, or of the row itself without data-col);
   * pressed again, the other way. Rows without the number go last; ties keep the file's order. */
  function startSortable(table) {
    const body = table.tBodies[0];
    const buttons = Array.from(table.querySelectorAll("thead button.sort"));
    for (const button of buttons) {
      button.addEventListener("click", () => {
        const key = button.dataset.key;
        const col = button.dataset.col === undefined ? null : parseInt(button.dataset.col, 10);
        const dir = button.dataset.dir === "ascending" ? "descending" : "ascending";
        for (const b of buttons) { delete b.dataset.dir; b.setAttribute("aria-pressed", "false"); }
        for (const th of table.tHead.rows[0].cells) th.removeAttribute("aria-sort");
        button.dataset.dir = dir;
        button.setAttribute("aria-pressed", "true");
        button.closest("th").setAttribute("aria-sort", dir);
        const value = (tr) => {
          const holder = col === null ? tr : tr.cells[col];
          const v = holder ? parseFloat(holder.dataset[key]) : NaN;
          return Number.isFinite(v) ? v : null;
        };
        const sign = dir === "ascending" ? 1 : -1;
        const rows = Array.from(body.rows);
        rows.sort((a, b) => {
          const x = value(a), y = value(b);
          if (x === null || y === null) {
            if (x !== y) return x === null ? 1 : -1;
          } else if (x !== y) {
            return sign * (x - y);
          }
          return parseInt(a.dataset.order, 10) - parseInt(b.dataset.order, 10);
        });
        for (const tr of rows) body.appendChild(tr);
      });
    }
  }

  const viewers = {};
  function start() {
    for (const table of document.querySelectorAll("table.sortable")) startSortable(table);
    const all = window.COMPARE_HDR || {};
    for (const root of document.querySelectorAll(".viewer")) {
      const id = root.dataset.scene;
      const status = root.querySelector(".status");
      try {
        if (!all[id]) throw new Error("data/" + id + ".js did not load");
        viewers[id] = new Viewer(root, all[id]);
        status.textContent = "";
        status.hidden = true;
      } catch (err) {
        status.textContent = "Interactive view unavailable: " + err.message;
        status.classList.add("error");
        console.error(err);  // to the console too, where the browser test looks for errors
      }
    }
    document.body.dataset.viewersReady = String(Object.keys(viewers).length);
  }

  window.COMPARE = { tonemap, decodeF16, toneMapImage, viewers };
  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
})();
