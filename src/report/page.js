"use strict";
// The comparison viewer of index.html (src/report/page.rs writes the data it reads).
// Images arrive as base64 IEEE half floats (RGB, little endian) times a per-image power of two;
// what is shown is tone-mapped here exactly as `film::write_png` does (exposure, clamp, sRGB,
// round to nearest), and the error view is `metrics::relative_error_per_pixel` on the log
// viridis scale of `metrics::error_map_colour`, so the page agrees with the PNGs of the run.
(function () {
  const DATA = JSON.parse(document.getElementById("viewer-data").textContent);
  const $ = (id) => document.getElementById(id);

  const HALF = new Float32Array(65536);
  for (let h = 0; h < 65536; h++) {
    const e = (h >> 10) & 31, m = h & 1023;
    let v = e === 0 ? m * Math.pow(2, -24) : e === 31 ? (m ? NaN : Infinity) : (1 + m / 1024) * Math.pow(2, e - 15);
    HALF[h] = h & 0x8000 ? -v : v;
  }

  function pixels(img) {
    if (!img.px) {
      const bin = atob(img.data);
      const bytes = new Uint8Array(bin.length);
      for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
      const half = new Uint16Array(bytes.buffer);
      const px = new Float32Array(half.length);
      for (let i = 0; i < half.length; i++) px[i] = HALF[half[i]] * img.scale;
      img.px = px;
    }
    return img.px;
  }

  function srgb8(linear) {
    const v = Number.isNaN(linear) ? 0 : Math.min(Math.max(linear, 0), 1);
    const enc = v <= 0.0031308 ? 12.92 * v : 1.055 * Math.pow(v, 1 / 2.4) - 0.055;
    return Math.floor(enc * 255 + 0.5);
  }

  function viridis(t) {
    const stops = DATA.viridis;
    const x = Math.min(Math.max(t, 0), 1) * (stops.length - 1);
    const i = Math.min(Math.floor(x), stops.length - 2), f = x - i;
    return [0, 1, 2].map((c) => Math.round(stops[i][c] + f * (stops[i + 1][c] - stops[i][c])));
  }

  function errorColour(e) {
    if (Number.isNaN(e)) return DATA.error_nan_rgb;
    const lo = Math.log10(DATA.error_min), hi = Math.log10(DATA.error_max);
    return viridis((Math.log10(e) - lo) / (hi - lo));
  }

  function relativeError(px, ref, p) {
    let s = 0;
    for (let c = 0; c < 3; c++) {
      const d = px[3 * p + c] - ref[3 * p + c], r = ref[3 * p + c];
      s += (d * d) / (r * r + DATA.rel_mse_epsilon);
    }
    return Math.sqrt(s / 3);
  }

  const state = { scene: 0, budget: 0, image: 0, exposure: DATA.exposure, zoom: 1, cx: 0, cy: 0 };
  const scene = () => DATA.scenes[state.scene];
  const shown = () => {
    const s = scene(), list = s.budgets.length ? s.budgets[state.budget].images : [];
    return state.image < list.length ? list[state.image] : s.reference;
  };
  const imageCount = () => {
    const s = scene();
    return (s.budgets.length ? s.budgets[state.budget].images.length : 0) + 1;
  };

  const views = [$("view-image"), $("view-error")];
  const offscreen = [document.createElement("canvas"), document.createElement("canvas")];

  function paintOffscreen() {
    const s = scene(), img = shown(), px = pixels(img), ref = pixels(s.reference);
    const k = Math.pow(2, state.exposure);
    for (const [which, canvas] of offscreen.entries()) {
      canvas.width = s.width;
      canvas.height = s.height;
      const ctx = canvas.getContext("2d");
      const out = ctx.createImageData(s.width, s.height);
      for (let p = 0; p < s.width * s.height; p++) {
        const rgb = which === 0
          ? [srgb8(px[3 * p] * k), srgb8(px[3 * p + 1] * k), srgb8(px[3 * p + 2] * k)]
          : errorColour(relativeError(px, ref, p));
        out.data.set(rgb, 4 * p);
        out.data[4 * p + 3] = 255;
      }
      ctx.putImageData(out, 0, 0);
    }
  }

  // The view: `zoom` screen pixels per image pixel (relative to fitting the image), centred on
  // image point (cx, cy); both canvases always share it.
  function scaleOf(canvas) {
    const s = scene();
    return Math.min(canvas.width / s.width, canvas.height / s.height) * state.zoom;
  }

  function drawViews() {
    for (const [which, canvas] of views.entries()) {
      const ctx = canvas.getContext("2d");
      ctx.setTransform(1, 0, 0, 1, 0, 0);
      ctx.fillStyle = "#222";
      ctx.fillRect(0, 0, canvas.width, canvas.height);
      const k = scaleOf(canvas);
      ctx.imageSmoothingEnabled = false;
      ctx.setTransform(k, 0, 0, k, canvas.width / 2 - state.cx * k, canvas.height / 2 - state.cy * k);
      ctx.drawImage(offscreen[which], 0, 0);
    }
  }

  function fit() {
    state.zoom = 1;
    state.cx = scene().width / 2;
    state.cy = scene().height / 2;
  }

  // The image pixel under canvas point (x, y) in canvas pixels, or null outside the image.
  function imagePixelAt(x, y, canvas) {
    const k = scaleOf(canvas || views[0]);
    const c = canvas || views[0];
    const ix = Math.floor(state.cx + (x - c.width / 2) / k), iy = Math.floor(state.cy + (y - c.height / 2) / k);
    return ix >= 0 && iy >= 0 && ix < scene().width && iy < scene().height ? [ix, iy] : null;
  }

  // The canvas point at the centre of image pixel (ix, iy).
  function canvasPointOf(ix, iy, canvas) {
    const k = scaleOf(canvas);
    return [canvas.width / 2 + (ix + 0.5 - state.cx) * k, canvas.height / 2 + (iy + 0.5 - state.cy) * k];
  }

  function fmt(v) {
    if (v === null || v === undefined || Number.isNaN(v)) return "–";
    if (Number.isInteger(v) && Math.abs(v) < 1e7) return String(v);
    const a = Math.abs(v);
    return a >= 0.01 && a < 1e4 ? v.toPrecision(4) : v.toExponential(3);
  }

  function showMetrics() {
    const img = shown(), rows = img.metrics.map(([name, value, ci]) => {
      const interval = ci ? ` <span class="ci">[${fmt(ci[0])}, ${fmt(ci[1])}]</span>` : "";
      return `<tr><th>${name}</th><td>${typeof value === "number" ? fmt(value) : value}${interval}</td></tr>`;
    });
    $("metrics").innerHTML = `<caption>${img.label}</caption>` + rows.join("");
  }

  function showLists() {
    const s = scene();
    $("scenes").innerHTML = DATA.scenes
      .map((sc, i) => `<button data-scene="${i}" class="${i === state.scene ? "on" : ""}">${sc.name}</button>`)
      .join("");
    $("budgets").innerHTML = s.budgets
      .map((b, i) => `<button data-budget="${i}" class="${i === state.budget ? "on" : ""}">${b.name}</button>`)
      .join("");
    const list = (s.budgets.length ? s.budgets[state.budget].images : []).concat([s.reference]);
    $("images").innerHTML = list
      .map((im, i) => {
        const key = i === list.length - 1 ? "r" : i < 9 ? String(i + 1) : "";
        return `<button data-image="${i}" class="${i === state.image ? "on" : ""}"><kbd>${key}</kbd> ${im.label}</button>`;
      })
      .join("");
  }

  function update(repaint) {
    if (repaint) paintOffscreen();
    drawViews();
    showLists();
    showMetrics();
    $("exposure").value = state.exposure;
    $("exposure-value").textContent = (state.exposure >= 0 ? "+" : "") + state.exposure.toFixed(1) + " EV";
    const st = $("status").dataset;
    st.scene = scene().name;
    st.image = shown().label;
    st.budget = scene().budgets.length ? scene().budgets[state.budget].name : "";
    st.exposure = String(state.exposure);
    st.zoom = String(state.zoom);
  }

  function select(what, value) {
    if (what === "scene") {
      state.scene = (value + DATA.scenes.length) % DATA.scenes.length;
      state.budget = Math.min(state.budget, Math.max(scene().budgets.length - 1, 0));
      state.image = Math.min(state.image, imageCount() - 1);
      fit();
    } else if (what === "budget") {
      const n = Math.max(scene().budgets.length, 1);
      state.budget = (value + n) % n;
      state.image = Math.min(state.image, imageCount() - 1);
    } else {
      state.image = (value + imageCount()) % imageCount();
    }
    update(true);
  }

  function setExposure(ev) {
    state.exposure = Math.round(Math.min(Math.max(ev, -16), 16) * 2) / 2;
    update(true);
  }

  function zoomAt(factor, x, y, canvas) {
    const k = scaleOf(canvas);
    const ix = state.cx + (x - canvas.width / 2) / k, iy = state.cy + (y - canvas.height / 2) / k;
    state.zoom = Math.min(Math.max(state.zoom * factor, 0.25), 256);
    const k2 = scaleOf(canvas);
    // Keep the image point under the cursor where it is.
    state.cx = ix - (x - canvas.width / 2) / k2;
    state.cy = iy - (y - canvas.height / 2) / k2;
    update(false);
  }

  function canvasPoint(canvas, event) {
    const r = canvas.getBoundingClientRect();
    return [((event.clientX - r.left) * canvas.width) / r.width, ((event.clientY - r.top) * canvas.height) / r.height];
  }

  for (const canvas of views) {
    canvas.addEventListener("wheel", (e) => {
      e.preventDefault();
      const [x, y] = canvasPoint(canvas, e);
      zoomAt(e.deltaY < 0 ? 1.25 : 0.8, x, y, canvas);
    }, { passive: false });
    let drag = null;
    canvas.addEventListener("mousedown", (e) => { drag = canvasPoint(canvas, e); });
    window.addEventListener("mouseup", () => { drag = null; });
    canvas.addEventListener("mousemove", (e) => {
      const [x, y] = canvasPoint(canvas, e);
      if (drag) {
        const k = scaleOf(canvas);
        state.cx -= (x - drag[0]) / k;
        state.cy -= (y - drag[1]) / k;
        drag = [x, y];
        update(false);
      }
      const p = imagePixelAt(x, y, canvas);
      if (!p) { $("pixel").textContent = ""; return; }
      const i = p[1] * scene().width + p[0], px = pixels(shown()), ref = pixels(scene().reference);
      const rgb = (a) => `(${fmt(a[3 * i])}, ${fmt(a[3 * i + 1])}, ${fmt(a[3 * i + 2])})`;
      $("pixel").textContent = `pixel (${p[0]}, ${p[1]}): ${rgb(px)} · reference ${rgb(ref)} · relative error ${fmt(100 * relativeError(px, ref, i))} %`;
    });
  }

  document.addEventListener("click", (e) => {
    const b = e.target.closest("button");
    if (!b) return;
    if (b.dataset.scene !== undefined) select("scene", Number(b.dataset.scene));
    else if (b.dataset.budget !== undefined) select("budget", Number(b.dataset.budget));
    else if (b.dataset.image !== undefined) select("image", Number(b.dataset.image));
    else if (b.id === "fit") { fit(); update(false); }
  });
  $("exposure").addEventListener("input", (e) => setExposure(Number(e.target.value)));

  document.addEventListener("keydown", (e) => {
    if (e.ctrlKey || e.metaKey || e.altKey || e.target.tagName === "INPUT") return;
    const k = e.key;
    if (k >= "1" && k <= "9" && Number(k) <= imageCount() - 1) select("image", Number(k) - 1);
    else if (k === "r") select("image", imageCount() - 1);
    else if (k === "ArrowRight") select("image", state.image + 1);
    else if (k === "ArrowLeft") select("image", state.image - 1);
    else if (k === "ArrowDown") select("scene", state.scene + 1);
    else if (k === "ArrowUp") select("scene", state.scene - 1);
    else if (k === "b") select("budget", state.budget + 1);
    else if (k === "+" || k === "=") setExposure(state.exposure + 0.5);
    else if (k === "-") setExposure(state.exposure - 0.5);
    else if (k === "0") setExposure(DATA.exposure);
    else if (k === "f") { fit(); update(false); }
    else return;
    e.preventDefault();
  });

  // The error scale: the same colours as the views, decades labelled.
  (function colourBar() {
    const bar = $("colour-bar"), ctx = bar.getContext("2d");
    const lo = Math.log10(DATA.error_min), hi = Math.log10(DATA.error_max);
    for (let x = 0; x < bar.width; x++) {
      ctx.fillStyle = `rgb(${errorColour(Math.pow(10, lo + ((hi - lo) * (x + 0.5)) / bar.width)).join(",")})`;
      ctx.fillRect(x, 0, 1, bar.height);
    }
    const labels = [];
    for (let d = Math.ceil(lo); d <= Math.floor(hi); d++) {
      const pct = 100 * Math.pow(10, d);
      labels.push(`<span style="left:${(100 * (d - lo)) / (hi - lo)}%">${pct >= 1 ? pct.toFixed(0) : pct.toString()} %</span>`);
    }
    $("colour-bar-labels").innerHTML = labels.join("");
  })();

  window.viewer = { state, select, setExposure, zoomAt, imagePixelAt, canvasPointOf, shown, views };
  fit();
  update(true);
})();
