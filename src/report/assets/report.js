// vitrum's report viewer: works offline from file://, no external script, font or request.
//
// The page (index.html) carries the sections' structure and, in #vitrum-data, the numbers each
// viewer needs; every image arrives as a data script (data/S-NAME.js) that calls
// vitrumReport.image(key, base64) with its linear RGB as little-endian half floats. The viewer
// tone-maps those values itself, exactly as vitrum's PNG previews do: v·2^EV clamped to [0, 1],
// then the sRGB curve (or v^(1/γ)), rounded to 8 bits, NaN pixels magenta. Error maps show the
// per-pixel relative squared error, mean over channels of (x − r)² / (r² + 0.01), in viridis on
// the log scale of the section's decades. The section's --regions are outlined on the image (with
// their names) while "region outlines" is on. Texts reach the page only through textContent.
"use strict";

(function () {
  const received = new Map();
  const report = {
    /** True once every viewer has drawn. */
    ready: false,
    /** One viewer per section, in page order. */
    viewers: [],
    /** Called by each data script: keeps the image's base64 text until the viewers start. */
    image(key, base64) {
      received.set(key, base64);
    },
  };
  window.vitrumReport = report;

  // Every half float's value, indexed by its 16 bits.
  const HALF = new Float32Array(65536);
  for (let h = 0; h < 65536; h++) {
    const sign = h & 0x8000 ? -1 : 1;
    const exponent = (h >> 10) & 0x1f;
    const mantissa = h & 0x3ff;
    if (exponent === 0) HALF[h] = sign * mantissa * 2 ** -24;
    else if (exponent === 31) HALF[h] = mantissa ? NaN : sign * Infinity;
    else HALF[h] = sign * (1 + mantissa / 1024) * 2 ** (exponent - 15);
  }

  /** The image `key` of `pixels` pixels as RGB floats. */
  function decode(key, pixels) {
    const base64 = received.get(key);
    if (base64 === undefined) throw new Error(`report: no data for ${key} (data/${key}.js did not load)`);
    const bytes = atob(base64);
    if (bytes.length !== pixels * 6) {
      throw new Error(`report: data/${key}.js holds ${bytes.length} bytes, expected ${pixels * 6}`);
    }
    const out = new Float32Array(pixels * 3);
    for (let i = 0, j = 0; i < out.length; i++, j += 2) {
      out[i] = HALF[bytes.charCodeAt(j) | (bytes.charCodeAt(j + 1) << 8)];
    }
    return out;
  }

  /** The sRGB OETF on [0, 1]. */
  function srgb(x) {
    return x <= 0.0031308 ? 12.92 * x : 1.055 * Math.pow(x, 1 / 2.4) - 0.055;
  }

  /** A tone-mapping function from a linear value to an 8-bit code. */
  function toneCurve(exposure, gamma, useSrgb) {
    const scale = 2 ** exposure;
    const inverse = 1 / gamma;
    return (v) => {
      let c = v * scale;
      c = c < 0 ? 0 : c > 1 ? 1 : c;
      return Math.round((useSrgb ? srgb(c) : Math.pow(c, inverse)) * 255);
    };
  }

  /** The relative squared error of pixel i of `test` against `reference`; NaN if either is not finite. */
  function relativeError(test, reference, i) {
    let sum = 0;
    for (let c = 0; c < 3; c++) {
      const x = test[3 * i + c];
      const r = reference[3 * i + c];
      if (!Number.isFinite(x) || !Number.isFinite(r)) return NaN;
      sum += ((x - r) * (x - r)) / (r * r + 0.01);
    }
    return sum / 3;
  }

  /** Viridis at t in [0, 1], interpolated in the page's table. */
  function viridis(table, t) {
    t = Number.isNaN(t) ? 0 : Math.min(1, Math.max(0, t));
    const x = t * (table.length - 1);
    const i = Math.min(Math.floor(x), table.length - 2);
    const f = x - i;
    return [0, 1, 2].map((c) => Math.round(table[i][c] + (table[i + 1][c] - table[i][c]) * f));
  }

  /** A new element with a class and text (text only through textContent). */
  function element(tag, className, text) {
    const e = document.createElement(tag);
    if (className) e.className = className;
    if (text !== undefined) e.textContent = text;
    return e;
  }

  /** "1.234e-3"-style numbers for the readout. */
  function formatValue(v) {
    if (Number.isNaN(v)) return "NaN";
    if (!Number.isFinite(v)) return v > 0 ? "+inf" : "-inf";
    if (v === 0) return "0";
    const a = Math.abs(v);
    return a >= 0.01 && a < 1000 ? v.toPrecision(4) : v.toExponential(3);
  }

  /** One scene's viewer: tabs, A/B flip and split, error maps, exposure, zoom and pan. */
  class Viewer {
    constructor(root, meta, data) {
      this.root = root;
      this.meta = meta;
      this.data = data;
      this.width = meta.width;
      this.height = meta.height;
      this.pixels = meta.width * meta.height;
      this.images = meta.layers.map((l) => decode(l.key, this.pixels));
      this.canvas = root.querySelector("canvas.view");
      this.readout = root.querySelector(".readout");
      this.legend = root.querySelector(".legend");
      this.controls = {
        b: root.querySelector("select.b-layer"),
        split: root.querySelector("input.split"),
        error: root.querySelector("input.error"),
        exposure: root.querySelector("input.exposure"),
        exposureValue: root.querySelector("output.exposure-value"),
        gamma: root.querySelector("input.gamma"),
        gammaValue: root.querySelector("output.gamma-value"),
        srgb: root.querySelector("input.srgb"),
        splitPosition: root.querySelector("input.split-position"),
        regions: root.querySelector("input.regions"),
      };
      this.tabs = Array.from(root.querySelectorAll("button.tab"));
      // Layer 0 is the reference, 1… the methods.
      this.a = meta.layers.length > 1 ? 1 : 0;
      this.b = 0;
      this.flip = false;
      this.split = false;
      this.splitAt = 0.5;
      this.error = false;
      this.exposure = meta.exposure;
      this.gamma = 2.2;
      this.srgb = true;
      this.outlines = meta.regions.length > 0;
      this.zoom = 1;
      this.ox = 0;
      this.oy = 0;
      this.toned = new Map();
      this.errorMaps = new Map();
      this.mouse = null;
      this.wheel = 0;
      this.moved = false;
      this.bind();
      this.layout();
      this.fit();
    }

    /** The state, for tests and for the readout. */
    state() {
      return {
        a: this.a,
        b: this.b,
        shown: this.shown(),
        flip: this.flip,
        split: this.split,
        splitAt: this.splitAt,
        error: this.error,
        exposure: this.exposure,
        gamma: this.gamma,
        srgb: this.srgb,
        outlines: this.outlines,
        zoom: this.zoom,
        ox: this.ox,
        oy: this.oy,
        dpr: this.dpr,
      };
    }

    /** The layer drawn on the left (or everywhere without a split). */
    shown() {
      return this.flip ? this.b : this.a;
    }

    /** Where the centre of image pixel (x, y) is: canvas backing pixels and page CSS pixels. */
    pixelCentre(x, y) {
      const cx = this.ox + (x + 0.5) * this.zoom;
      const cy = this.oy + (y + 0.5) * this.zoom;
      const box = this.canvas.getBoundingClientRect();
      return { canvasX: cx, canvasY: cy, pageX: box.left + cx / this.dpr, pageY: box.top + cy / this.dpr };
    }

    bind() {
      const c = this.controls;
      this.tabs.forEach((tab) => tab.addEventListener("click", () => this.setA(Number(tab.dataset.layer))));
      c.b.addEventListener("change", () => this.set({ b: Number(c.b.value) }));
      c.split.addEventListener("change", () => this.set({ split: c.split.checked }));
      c.error.addEventListener("change", () => this.set({ error: c.error.checked }));
      c.exposure.addEventListener("input", () => this.set({ exposure: Number(c.exposure.value) }));
      c.gamma.addEventListener("input", () => this.set({ gamma: Number(c.gamma.value) }));
      c.srgb.addEventListener("change", () => this.set({ srgb: c.srgb.checked }));
      c.splitPosition.addEventListener("input", () => this.set({ splitAt: Number(c.splitPosition.value) }));
      if (c.regions) c.regions.addEventListener("change", () => this.set({ outlines: c.regions.checked }));
      const canvas = this.canvas;
      canvas.addEventListener("wheel", (e) => {
        if (e.deltaY === 0) return; // a horizontal scroll: not a zoom
        e.preventDefault();
        // Wheel notches and trackpad pixels add up to one power of two per WHEEL_STEP pixels.
        const scale = e.deltaMode === 1 ? 40 : e.deltaMode === 2 ? 800 : 1;
        this.wheel = (Math.sign(this.wheel) === Math.sign(e.deltaY) ? this.wheel : 0) + e.deltaY * scale;
        if (Math.abs(this.wheel) < WHEEL_STEP) return;
        const p = this.canvasPoint(e);
        this.zoomAt(p.x, p.y, this.wheel < 0 ? 2 : 0.5);
        this.wheel = 0;
      }, { passive: false });
      canvas.addEventListener("mousedown", (e) => {
        this.drag = { x: e.clientX, y: e.clientY, ox: this.ox, oy: this.oy };
        e.preventDefault();
      });
      window.addEventListener("mouseup", () => (this.drag = null));
      canvas.addEventListener("mousemove", (e) => {
        if (this.drag && e.buttons & 1) {
          this.ox = this.drag.ox + Math.round((e.clientX - this.drag.x) * this.dpr);
          this.oy = this.drag.oy + Math.round((e.clientY - this.drag.y) * this.dpr);
          this.moved = true;
          this.draw();
        }
        this.mouse = this.canvasPoint(e);
        this.showReadout();
      });
      canvas.addEventListener("mouseleave", () => {
        this.mouse = null;
        this.showReadout();
      });
      this.root.addEventListener("mouseenter", () => (active = this));
      this.root.addEventListener("mousedown", () => (active = this));
    }

    /** The mouse position of `e` in canvas backing pixels. */
    canvasPoint(e) {
      const box = this.canvas.getBoundingClientRect();
      return { x: (e.clientX - box.left) * this.dpr, y: (e.clientY - box.top) * this.dpr };
    }

    /** Sizes the canvas to the page: the viewer's width, the image's aspect, at most 80% of the window's height. */
    layout() {
      this.dpr = window.devicePixelRatio || 1;
      const cssWidth = Math.max(200, Math.floor(this.canvas.parentElement.clientWidth));
      const cssHeight = Math.max(150, Math.min(Math.round((cssWidth * this.height) / this.width), Math.floor(window.innerHeight * 0.8)));
      this.canvas.style.width = `${cssWidth}px`;
      this.canvas.style.height = `${cssHeight}px`;
      this.canvas.width = Math.round(cssWidth * this.dpr);
      this.canvas.height = Math.round(cssHeight * this.dpr);
    }

    /** The largest power-of-two zoom at which the whole image fits, centred on whole pixels. */
    fit() {
      let zoom = 1;
      const fits = (z) => this.width * z <= this.canvas.width && this.height * z <= this.canvas.height;
      while (fits(zoom * 2) && zoom < 256) zoom *= 2;
      while (!fits(zoom) && zoom > 1 / 64) zoom /= 2;
      this.zoom = zoom;
      this.ox = Math.round((this.canvas.width - this.width * zoom) / 2);
      this.oy = Math.round((this.canvas.height - this.height * zoom) / 2);
      this.moved = false;
      this.draw();
      this.showReadout();
    }

    /** One image pixel per canvas pixel, the image's top-left corner at the canvas's. */
    actualSize() {
      this.zoom = 1;
      this.ox = 0;
      this.oy = 0;
      this.moved = true;
      this.draw();
      this.showReadout();
    }

    /** Zooms by `factor` keeping the image point under (x, y) in place. */
    zoomAt(x, y, factor) {
      const zoom = Math.min(256, Math.max(1 / 64, this.zoom * factor));
      const f = zoom / this.zoom;
      this.ox = Math.round(x - (x - this.ox) * f);
      this.oy = Math.round(y - (y - this.oy) * f);
      this.zoom = zoom;
      this.moved = true;
      this.draw();
      this.showReadout();
    }

    /** After a resize: refits an untouched view, else keeps zoom and the point at the canvas's centre. */
    resize() {
      const [w, h] = [this.canvas.width, this.canvas.height];
      this.layout();
      if (!this.moved) {
        this.fit();
        return;
      }
      this.ox += Math.round((this.canvas.width - w) / 2);
      this.oy += Math.round((this.canvas.height - h) / 2);
      this.draw();
    }

    setA(layer) {
      if (layer >= 0 && layer < this.images.length) this.set({ a: layer });
    }

    /** Changes the state, keeps the controls in step, redraws. */
    set(changes) {
      Object.assign(this, changes);
      // Exact: the scene's (or --exposure's) value, moved by the keys' and the slider's steps.
      this.exposure = Math.min(16, Math.max(-16, this.exposure));
      this.gamma = Math.min(3, Math.max(1, Math.round(this.gamma * 100) / 100));
      const c = this.controls;
      c.b.value = String(this.b);
      c.split.checked = this.split;
      c.error.checked = this.error;
      c.exposure.value = String(this.exposure);
      c.exposureValue.textContent = (this.exposure >= 0 ? "+" : "") + this.exposure.toFixed(2);
      c.gamma.value = String(this.gamma);
      c.gamma.disabled = this.srgb;
      c.gammaValue.textContent = this.gamma.toFixed(2);
      c.srgb.checked = this.srgb;
      c.splitPosition.hidden = !this.split;
      c.splitPosition.value = String(this.splitAt);
      if (c.regions) c.regions.checked = this.outlines;
      this.tabs.forEach((tab) => tab.setAttribute("aria-selected", String(Number(tab.dataset.layer) === this.a)));
      this.draw();
      this.showReadout();
    }

    /** Layer k tone-mapped at the current exposure and curve, as a canvas of the image's size. */
    tonedLayer(k) {
      const id = `${k}|${this.exposure}|${this.gamma}|${this.srgb}`;
      let canvas = this.toned.get(id);
      if (canvas) return canvas;
      if (this.toned.size > 2 * this.images.length) this.toned.clear();
      const tone = toneCurve(this.exposure, this.gamma, this.srgb);
      const values = this.images[k];
      canvas = this.blank();
      const context = canvas.getContext("2d");
      const out = context.createImageData(this.width, this.height);
      for (let i = 0; i < this.pixels; i++) {
        const r = values[3 * i], g = values[3 * i + 1], b = values[3 * i + 2];
        const nan = Number.isNaN(r) || Number.isNaN(g) || Number.isNaN(b);
        out.data[4 * i] = nan ? this.data.nan[0] : tone(r);
        out.data[4 * i + 1] = nan ? this.data.nan[1] : tone(g);
        out.data[4 * i + 2] = nan ? this.data.nan[2] : tone(b);
        out.data[4 * i + 3] = 255;
      }
      context.putImageData(out, 0, 0);
      this.toned.set(id, canvas);
      return canvas;
    }

    /** Layer k's error map against the reference (the section's log scale), with its count above the scale. */
    errorLayer(k) {
      let map = this.errorMaps.get(k);
      if (map) return map;
      const [lo, hi] = this.meta.decades;
      const canvas = this.blank();
      const context = canvas.getContext("2d");
      const out = context.createImageData(this.width, this.height);
      let above = 0;
      let nonFinite = 0;
      for (let i = 0; i < this.pixels; i++) {
        const v = relativeError(this.images[k], this.images[0], i);
        let colour;
        if (!Number.isFinite(v)) {
          colour = this.data.nan;
          nonFinite++;
        } else if (v > 0 && Math.log10(v) - 1e-6 > hi) {
          colour = this.data.above;
          above++;
        } else if (v <= 0) {
          colour = viridis(this.data.viridis, 0);
        } else {
          colour = viridis(this.data.viridis, (Math.log10(v) - lo) / (hi - lo));
        }
        out.data.set([colour[0], colour[1], colour[2], 255], 4 * i);
      }
      context.putImageData(out, 0, 0);
      map = { canvas, above, nonFinite };
      this.errorMaps.set(k, map);
      return map;
    }

    /** An offscreen canvas of the image's size. */
    blank() {
      const canvas = document.createElement("canvas");
      canvas.width = this.width;
      canvas.height = this.height;
      return canvas;
    }

    /** What layer k looks like now: its error map (methods, in error mode) or its tone-mapped image. */
    picture(k) {
      return this.error && k !== 0 ? this.errorLayer(k).canvas : this.tonedLayer(k);
    }

    draw() {
      const context = this.canvas.getContext("2d");
      context.imageSmoothingEnabled = false;
      context.fillStyle = "#202020";
      context.fillRect(0, 0, this.canvas.width, this.canvas.height);
      const w = this.width * this.zoom, h = this.height * this.zoom;
      context.drawImage(this.picture(this.shown()), this.ox, this.oy, w, h);
      if (this.split && !this.flip) {
        const x = Math.round(this.splitAt * this.canvas.width);
        context.save();
        context.beginPath();
        context.rect(x, 0, this.canvas.width - x, this.canvas.height);
        context.clip();
        context.drawImage(this.picture(this.b), this.ox, this.oy, w, h);
        context.restore();
        context.fillStyle = "#ffffff";
        context.fillRect(x, 0, 1, this.canvas.height);
      }
      if (this.outlines) this.drawRegions(context);
      this.drawLegend();
    }

    /** Each region's outline, just outside its pixels (which stay visible), and its name above it (below at the top edge). */
    drawRegions(context) {
      const line = Math.max(1, Math.round(this.dpr));
      const text = Math.round(12 * this.dpr);
      context.save();
      context.strokeStyle = REGION_COLOUR;
      context.fillStyle = REGION_COLOUR;
      context.lineWidth = line;
      context.font = `${text}px system-ui, sans-serif`;
      context.textBaseline = "bottom";
      for (const r of this.meta.regions) {
        const x = this.ox + r.x * this.zoom, y = this.oy + r.y * this.zoom;
        const w = r.width * this.zoom, h = r.height * this.zoom;
        context.strokeRect(x - line / 2, y - line / 2, w + line, h + line);
        const above = y - line - 2;
        context.fillText(r.name, x, above >= text ? above : y + h + line + 2 + text);
      }
      context.restore();
    }

    /** The error map's colour bar and counts, shown in error mode. */
    drawLegend() {
      this.legend.hidden = !this.error;
      if (!this.error) return;
      const [lo, hi] = this.meta.decades;
      this.legend.replaceChildren();
      const bar = document.createElement("canvas");
      bar.width = 256;
      bar.height = 12;
      const context = bar.getContext("2d");
      for (let x = 0; x < 256; x++) {
        const c = viridis(this.data.viridis, x / 255);
        context.fillStyle = `rgb(${c[0]},${c[1]},${c[2]})`;
        context.fillRect(x, 0, 1, 12);
      }
      const shown = this.shown();
      this.legend.append(element("span", "", `relative squared error ≤ 1e${lo} `), bar, element("span", "", ` 1e${hi}`));
      if (shown !== 0) {
        const map = this.errorLayer(shown);
        this.legend.append(element("span", "above", ` · red: > 1e${hi} (${map.above} px) · magenta: not finite (${map.nonFinite} px)`));
      } else {
        this.legend.append(element("span", "", " · the reference is shown as an image"));
      }
    }

    /** The values under the mouse: the shown layer's and the reference's linear RGB, and the relative error. */
    showReadout() {
      const m = this.mouse;
      const x = m ? Math.floor((m.x - this.ox) / this.zoom) : -1;
      const y = m ? Math.floor((m.y - this.oy) / this.zoom) : -1;
      const inside = x >= 0 && y >= 0 && x < this.width && y < this.height;
      this.readout.dataset.x = inside ? String(x) : "";
      this.readout.dataset.y = inside ? String(y) : "";
      if (!inside) {
        this.readout.textContent = "move the mouse over the image to read its values";
        return;
      }
      const i = y * this.width + x;
      const rgb = (k) => [0, 1, 2].map((c) => formatValue(this.images[k][3 * i + c])).join(", ");
      const shown = this.split && !this.flip && m.x >= this.splitAt * this.canvas.width ? this.b : this.shown();
      const label = this.meta.layers[shown].label;
      const error = relativeError(this.images[shown], this.images[0], i);
      this.readout.textContent =
        `pixel (${x}, ${y}) · ${label}: (${rgb(shown)}) · reference: (${rgb(0)}) · relative squared error ${formatValue(error)}`;
    }
  }

  /** Makes a results table sortable by clicking its headers (by each cell's exact value). */
  function sortable(table) {
    const headers = Array.from(table.querySelectorAll("th"));
    headers.forEach((th, column) => {
      th.addEventListener("click", () => {
        const ascending = th.getAttribute("aria-sort") !== "ascending";
        headers.forEach((h) => h.removeAttribute("aria-sort"));
        th.setAttribute("aria-sort", ascending ? "ascending" : "descending");
        const body = table.tBodies[0];
        const rows = Array.from(body.rows);
        const value = (row) => row.cells[column].dataset.value;
        const numeric = rows.every((r) => value(r) === "" || !Number.isNaN(Number(value(r))));
        rows.sort((p, q) => {
          const a = value(p), b = value(q);
          if (a === "" || b === "") return (a === "") - (b === "");
          const order = numeric ? Number(a) - Number(b) : a.localeCompare(b);
          return ascending ? order : -order;
        });
        rows.forEach((r) => body.appendChild(r));
      });
    });
  }

  /** The colour of the regions' outlines and names. */
  const REGION_COLOUR = "#ffd400";

  /** Wheel travel (in pixels) per power-of-two zoom step: one notch of a mouse wheel is about 100. */
  const WHEEL_STEP = 50;

  const SVG = "http://www.w3.org/2000/svg";
  const COLOURS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"];

  /** An SVG element with attributes. */
  function svg(tag, attributes, text) {
    const e = document.createElementNS(SVG, tag);
    for (const [k, v] of Object.entries(attributes)) e.setAttribute(k, String(v));
    if (text !== undefined) e.textContent = text;
    return e;
  }

  /**
   * A log-log plot of relMSE against the point's coordinate `axis` (0 spp, 1 seconds); each point
   * [spp, seconds, relMSE, low, high] with a 95% interval (low, high; null without) gets an error
   * bar, a lower bound at or below zero reaching the bottom of the axis.
   */
  function plot(series, axis, label) {
    const W = 460, H = 320, left = 64, right = 12, top = 28, bottom = 44;
    const points = series.flatMap((s) => s.points.filter((p) => p[axis] > 0 && p[2] > 0));
    const highs = points.filter((p) => p[4] > 0 && Number.isFinite(p[4])).map((p) => p[4]);
    const root = svg("svg", { width: W, height: H, viewBox: `0 0 ${W} ${H}`, class: "plot" });
    root.append(svg("text", { x: W / 2, y: 18, "text-anchor": "middle", class: "title" }, `relMSE against ${label}`));
    if (points.length === 0) return root;
    const range = (values) => {
      let lo = Math.floor(Math.log10(Math.min(...values)));
      let hi = Math.ceil(Math.log10(Math.max(...values)));
      if (hi === lo) hi = lo + 1;
      return [lo, hi];
    };
    const [xlo, xhi] = range(points.map((p) => p[axis]));
    const [ylo, yhi] = range(points.map((p) => p[2]).concat(highs));
    const px = (v) => left + ((Math.log10(v) - xlo) / (xhi - xlo)) * (W - left - right);
    const py = (v) => H - bottom - ((Math.log10(v) - ylo) / (yhi - ylo)) * (H - top - bottom);
    root.append(svg("rect", { x: left, y: top, width: W - left - right, height: H - top - bottom, class: "frame" }));
    for (let k = xlo; k <= xhi; k++) {
      const x = px(10 ** k);
      root.append(svg("line", { x1: x, x2: x, y1: top, y2: H - bottom, class: "grid" }));
      root.append(svg("text", { x, y: H - bottom + 16, "text-anchor": "middle" }, `1e${k}`));
    }
    for (let k = ylo; k <= yhi; k++) {
      const y = py(10 ** k);
      root.append(svg("line", { x1: left, x2: W - right, y1: y, y2: y, class: "grid" }));
      root.append(svg("text", { x: left - 6, y: y + 4, "text-anchor": "end" }, `1e${k}`));
    }
    root.append(svg("text", { x: (left + W - right) / 2, y: H - 8, "text-anchor": "middle" }, label));
    series.forEach((s, n) => {
      const colour = COLOURS[n % COLOURS.length];
      const mine = s.points.filter((p) => p[axis] > 0 && p[2] > 0);
      root.append(svg("polyline", { points: mine.map((p) => `${px(p[axis])},${py(p[2])}`).join(" "), stroke: colour, class: "series" }));
      mine.forEach((p) => root.append(svg("circle", { cx: px(p[axis]), cy: py(p[2]), r: 2.5, fill: colour })));
      mine.filter((p) => p[4] > 0 && Number.isFinite(p[4])).forEach((p) => {
        const x = px(p[axis]);
        const [y1, y2] = [py(Math.max(p[3] || 0, 10 ** ylo)), py(p[4])];
        root.append(svg("line", { x1: x, x2: x, y1, y2, stroke: colour, class: "error-bar" }));
        [y1, y2].forEach((y) => root.append(svg("line", { x1: x - 3, x2: x + 3, y1: y, y2: y, stroke: colour, class: "error-bar" })));
      });
    });
    return root;
  }

  /** The section's convergence plots and their legend. */
  function convergence(container, series) {
    container.append(element("h3", "", "Convergence"));
    const plots = element("div", "plots");
    plots.append(plot(series, 0, "samples per pixel"), plot(series, 1, "seconds"));
    const legend = element("ul", "plot-legend");
    series.forEach((s, n) => {
      const item = element("li", "", s.legend || s.method);
      item.style.setProperty("--colour", COLOURS[n % COLOURS.length]);
      legend.append(item);
    });
    container.append(plots, legend);
  }

  let active = null;
  /** The viewer showing B while b is held, whichever viewer the mouse is over at release. */
  let flipped = null;

  /** Ends a flip. */
  function unflip() {
    if (flipped) flipped.set({ flip: false });
    flipped = null;
  }

  /** The number keys, b (held), s, e, + and -, [ and ], g, f and o act on the active viewer. */
  function onKey(e, down) {
    const viewer = active || report.viewers[0];
    const key = e.key;
    if (!down) {
      if (key === "b" || key === "B") unflip();
      return;
    }
    if (!viewer || e.ctrlKey || e.metaKey || e.altKey) return;
    if (e.target instanceof HTMLSelectElement) return;
    const layers = viewer.images.length - 1;
    let handled = true;
    if (/^[0-9]$/.test(key)) {
      const k = key === "0" ? 10 : Number(key);
      if (k <= layers) viewer.setA(k);
    } else if (key === "r") viewer.setA(0);
    else if (key === "b" || key === "B") {
      if (!e.repeat && flipped !== viewer) {
        unflip();
        flipped = viewer;
        viewer.set({ flip: true });
      }
    } else if (key === "s") viewer.set({ split: !viewer.split });
    else if (key === "e") viewer.set({ error: !viewer.error });
    else if (key === "+" || key === "=") viewer.set({ exposure: viewer.exposure + 0.5 });
    else if (key === "-" || key === "_") viewer.set({ exposure: viewer.exposure - 0.5 });
    else if (key === "]") viewer.set({ srgb: false, gamma: viewer.gamma + 0.1 });
    else if (key === "[") viewer.set({ srgb: false, gamma: viewer.gamma - 0.1 });
    else if (key === "g") viewer.set({ srgb: !viewer.srgb });
    else if (key === "f") viewer.fit();
    else if (key === "o") viewer.actualSize();
    else handled = false;
    if (handled) e.preventDefault();
  }

  function start() {
    const data = JSON.parse(document.getElementById("vitrum-data").textContent);
    data.sections.forEach((meta, i) => {
      const root = document.querySelector(`section[data-section="${i}"]`);
      const viewer = new Viewer(root, meta, data);
      viewer.set({});
      report.viewers.push(viewer);
      root.querySelectorAll("table.results").forEach(sortable);
      const container = root.querySelector(".convergence");
      if (container && meta.convergence.length > 0) convergence(container, meta.convergence);
    });
    received.clear();
    document.addEventListener("keydown", (e) => onKey(e, true));
    document.addEventListener("keyup", (e) => onKey(e, false));
    window.addEventListener("resize", () => report.viewers.forEach((v) => v.resize()));
    // A flip lasts while b is held: losing the focus releases it.
    window.addEventListener("blur", unflip);
    report.ready = true;
  }

  document.addEventListener("DOMContentLoaded", start);
})();
