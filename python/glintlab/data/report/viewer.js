"use strict";
/* glintlab's image viewer (glintlab/report/viewer.py writes the page; docs/guide/scenes.md#the-image-viewer).
   The renders are float16 radiance, deflated and base64-encoded in <script type="text/plain"> elements of
   this page; the camera path is a lossless animated WebP of log-encoded radiance, decoded frame by frame
   with WebCodecs' ImageDecoder. Exposure and tone curve are applied
   here, to both. glintlab.studies.scene_frames has the same tone curves in numpy (the browser test
   compares this canvas with them). No network, no library. */
(function () {
  const M = JSON.parse(document.getElementById("gv-manifest").textContent);
  const root = document.getElementById("gv");
  const dpr = () => window.devicePixelRatio || 1;

  // ---- numbers: float16, the tone curves, sRGB, false colour
  const HALF = new Float32Array(65536);
  for (let h = 0; h < 65536; h++) {
    const s = h & 0x8000 ? -1 : 1, e = (h >> 10) & 31, f = h & 1023;
    HALF[h] = e === 0 ? s * f * 2 ** -24 : e === 31 ? (f ? NaN : s * Infinity) : s * (1 + f / 1024) * 2 ** (e - 15);
  }
  const TONES = {
    aces: (x) => Math.min(1, Math.max(0, (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14))),
    reinhard: (x) => x / (1 + x),
    clamp: (x) => Math.min(x, 1),
  };
  const srgb = (y) => (y <= 0.0031308 ? 12.92 * y : 1.055 * Math.pow(y, 1 / 2.4) - 0.055);
  const toByte = (x, tone) => Math.round(255 * srgb(TONES[tone](x > 0 ? x : 0)));
  const clamp01 = (v) => Math.min(1, Math.max(0, v));
  // c in [0, 1]: black, red, yellow, white where the method is brighter; black, blue, cyan, white where darker.
  function falseColour(c, brighter) {
    const a = Math.round(255 * Math.min(1, 3 * c)), b = Math.round(255 * clamp01(3 * c - 1));
    const d = Math.round(255 * clamp01(3 * c - 2));
    return brighter ? [a, b, d] : [d, b, a];
  }

  // ---- the stored data
  const cache = new Map();
  function bytesOf(id) {
    const s = atob(document.getElementById(id).textContent.trim());
    const a = new Uint8Array(s.length);
    for (let i = 0; i < s.length; i++) a[i] = s.charCodeAt(i);
    return a;
  }
  function inflated(id) {  // a promise of the inflated bytes of one stored blob
    if (!cache.has(id)) {
      const stream = new Blob([bytesOf(id)]).stream().pipeThrough(new DecompressionStream("deflate"));
      cache.set(id, new Response(stream).arrayBuffer());
    }
    return cache.get(id);
  }
  const halves = (id) => inflated(id).then((b) => new Uint16Array(b));  // float16 codes of one image

  // ---- state
  const MODES = [["image", "image"], ["diff-own", "difference vs own truth"], ["diff-facets", "difference vs facet truth"],
                 ["rel-own", "relative error vs own truth"], ["rel-facets", "relative error vs facet truth"]];
  const RANGES = [0.1, 0.25, 0.5, 1, 2, 4, 8, 16];
  const S = {scene: 0, col: 0, mode: "image", tone: M.tones[0], exposure: 0, flip: null, range: 4,
             zoom: null, ox: 0, oy: 0, frame: 0, playing: null, pops: true, rendered: 0, fzoom: 1, fcenter: [0.5, 0.5]};
  const scene = () => M.scenes[S.scene];
  const column = () => scene().columns[S.col];

  // ---- the page
  function el(tag, attrs, ...kids) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) {
      if (k.startsWith("on")) e.addEventListener(k.slice(2), v); else e.setAttribute(k, v);
    }
    for (const k of kids) e.append(k);
    return e;
  }
  const sceneRow = el("div", {class: "gv-row", id: "gv-scenes"}, el("span", {class: "gv-name"}, "scene"));
  const methodRow = el("div", {class: "gv-row", id: "gv-methods"}, el("span", {class: "gv-name"}, "method"));
  const modeSel = el("select", {id: "gv-mode", onchange: () => { S.mode = modeSel.value; draw(); }},
                     ...MODES.map(([v, t]) => el("option", {value: v}, t)));
  const toneSel = el("select", {id: "gv-tone", onchange: () => { S.tone = toneSel.value; draw(); drawFlicker(); }},
                     ...M.tones.map((t) => el("option", {value: t}, t)));
  const expRange = el("input", {id: "gv-exposure", type: "range", min: -24, max: 24, step: 0.25,
                                oninput: () => setExposure(+expRange.value)});
  const expOut = el("output", {id: "gv-exposure-value"});
  const rangeSel = el("select", {id: "gv-range", onchange: () => { S.range = +rangeSel.value; draw(); }},
                      ...RANGES.map((r) => el("option", {value: r}, `±${r} × smooth`)));
  const controls = el("div", {class: "gv-row"},
    el("label", {}, "show ", modeSel), el("label", {}, " tone ", toneSel),
    el("label", {}, " exposure "), el("button", {id: "gv-exp-down", onclick: () => setExposure(S.exposure - 0.5)}, "−"),
    expRange, el("button", {id: "gv-exp-up", onclick: () => setExposure(S.exposure + 0.5)}, "+"), expOut,
    el("button", {id: "gv-exp-reset", onclick: () => setExposure(scene().exposure)}, "default"),
    el("label", {}, " rel. error range ", rangeSel),
    el("button", {id: "gv-fit", onclick: () => { S.zoom = null; present(); }}, "fit"),
    el("button", {id: "gv-one", onclick: () => zoomTo(1) }, "1:1"),
    el("button", {id: "gv-flip", onmousedown: () => flip("own"), onmouseup: () => flip(null),
                  onmouseleave: () => flip(null)}, "hold: truth"));
  const canvas = el("canvas", {class: "gv-canvas", id: "gv-canvas", tabindex: 0});
  const legend = el("div", {class: "gv-legend", id: "gv-legend"});
  const info = el("div", {class: "gv-info", id: "gv-info"}, "move the pointer over the image for pixel values");
  const keys = el("div", {class: "gv-keys"});
  keys.innerHTML = "<kbd>1</kbd>–<kbd>9</kbd>, <kbd>←</kbd> <kbd>→</kbd> method · <kbd>↑</kbd> <kbd>↓</kbd> scene · " +
    "hold <kbd>space</kbd>: own truth, hold <kbd>f</kbd>: facet truth · <kbd>+</kbd> <kbd>−</kbd> exposure ½ stop, " +
    "<kbd>e</kbd> default · <kbd>t</kbd> tone curve · <kbd>d</kbd> show (image, differences) · wheel: zoom, drag: pan, " +
    "<kbd>r</kbd> fit, <kbd>o</kbd> 1:1 · <kbd>p</kbd> play the path, <kbd>,</kbd> <kbd>.</kbd> step";
  const flickCanvas = el("canvas", {class: "gv-canvas", id: "gv-flicker"});
  const fallback = el("img", {id: "gv-animation", alt: "the camera path (log-encoded radiance)", style: "display:none;max-width:100%"});
  const frameRange = el("input", {id: "gv-frame", type: "range", min: 0, max: 1, step: 1,
                                  oninput: () => showFrame(+frameRange.value)});
  const playBtn = el("button", {id: "gv-play", onclick: () => play(!S.playing)}, "play");
  const popsBox = el("input", {id: "gv-pops", type: "checkbox", checked: "", onchange: () => { S.pops = popsBox.checked; drawFlicker(); }});
  const fzoomSel = el("select", {id: "gv-fzoom", onchange: () => { S.fzoom = +fzoomSel.value; drawFlicker(); }},
                      ...[1, 2, 4, 8].map((z) => el("option", {value: z}, `${z}×`)));
  const flickInfo = el("div", {class: "gv-info", id: "gv-flicker-info"});
  root.append(sceneRow, methodRow, controls, canvas, legend, info, keys,
              el("h2", {class: "gv-h"}, "Flicker along the camera path"),
              el("div", {class: "gv-note"}, "The method (left) beside its own truth (and the facet truth where that is " +
                 "another) along the camera path (sub-pixel pans, then steps towards the surface), at the exposure and " +
                 "tone curve above. Red: the pixels where the method's glint appears or vanishes between the previous " +
                 "frame and this one with no change in its truth there (the pops the flicker table counts). Zoom " +
                 "crops around the point last clicked in the image above."),
              el("div", {class: "gv-row"}, el("button", {id: "gv-prev", onclick: () => showFrame(S.frame - 1)}, "‹"),
                 playBtn, el("button", {id: "gv-next", onclick: () => showFrame(S.frame + 1)}, "›"), frameRange,
                 el("label", {}, popsBox, " mark pops"), el("label", {}, " zoom ", fzoomSel)),
              flickCanvas, flickInfo, fallback);

  function tabs() {
    sceneRow.replaceChildren(sceneRow.firstChild, ...M.scenes.map((s, i) =>
      el("button", {class: "gv-tab" + (i === S.scene ? " on" : ""), "data-scene": s.name, onclick: () => setScene(i)},
         `${s.name}`, el("small", {}, `${s.width} × ${s.height}`))));
    const st = scene().stats || {};
    methodRow.replaceChildren(methodRow.firstChild, ...scene().columns.map((c, i) => {
      const s = st[c.method];
      const sub = c.truth_kind === "self" ? "the truth" : c.method === scene().smooth ? "no glints" :
        s ? `σ×${s.std_ratio.toFixed(2)} · pops ${(1000 * s.own_pop_rate).toFixed(1)}‰` : c.returns;
      return el("button", {class: "gv-tab" + (i === S.col ? " on" : ""), "data-method": c.method,
                           title: `${c.method}; own truth: ${c.truth_kind}`, onclick: () => setColumn(i)},
                `${i < 9 ? i + 1 + " " : ""}${c.label}`, el("small", {}, sub));
    }));
  }

  // ---- what is shown
  function labelOf(key) {
    const sc = scene();
    if (key === sc.facets) return "facet truth";
    if (key === sc.smooth) return "smooth D(h)";
    const c = sc.columns.find((c) => c.method === key);
    return c ? c.label : key;
  }
  function shown() {  // [key shown, key compared with or null, how]
    const c = column(), sc = scene();
    if (S.flip) return [S.flip === "facets" ? sc.facets : c.own, null, "image"];
    if (S.mode === "image") return [c.method, null, "image"];
    return [c.method, S.mode.endsWith("own") ? c.own : sc.facets, S.mode.slice(0, 3)];
  }
  let work = document.createElement("canvas"), arrays = {};
  async function draw() {
    const sc = scene(), [key, ref, how] = shown(), ticket = ++draw.ticket;
    const ids = [key, ref, sc.smooth].filter((k) => k);
    const got = await Promise.all(ids.map((k) => halves(sc.images[k])));
    if (ticket !== draw.ticket) return;
    arrays = Object.fromEntries(ids.map((k, i) => [k, got[i]]));
    const W = sc.width, H = sc.height, img = new ImageData(W, H), px = img.data;
    const gain = 2 ** (S.exposure - sc.scale_log2), a = arrays[key];
    if (how === "image") {
      const lut = new Uint8Array(65536);
      for (let h = 0; h < 65536; h++) lut[h] = toByte(HALF[h] * gain, S.tone);
      for (let i = 0, j = 0; i < a.length; i++, j += 4) { const v = lut[a[i]]; px[j] = px[j + 1] = px[j + 2] = v; px[j + 3] = 255; }
    } else {
      const b = arrays[ref], s = arrays[sc.smooth];
      for (let i = 0, j = 0; i < a.length; i++, j += 4) {
        const d = HALF[a[i]] - HALF[b[i]];
        let rgb;
        if (how === "dif") rgb = falseColour(srgb(TONES[S.tone](Math.abs(d) * gain)), d > 0);
        else { const sm = HALF[s[i]]; rgb = sm > 0 ? falseColour(Math.min(1, Math.abs(d / sm) / S.range), d > 0) : [48, 48, 48]; }
        px[j] = rgb[0]; px[j + 1] = rgb[1]; px[j + 2] = rgb[2]; px[j + 3] = 255;
      }
    }
    work.width = W; work.height = H;
    work.getContext("2d").putImageData(img, 0, 0);
    legend.textContent = how === "image" ? `${labelOf(key)}${S.flip ? " (held)" : ""}: radiance × 2^${S.exposure.toFixed(2)}, ${S.tone}, sRGB` :
      `${labelOf(key)} − ${labelOf(ref)}: red → yellow where the method is brighter, blue → cyan where darker; ` +
      (how === "dif" ? `brightness: |difference| × 2^${S.exposure.toFixed(2)} through the ${S.tone} curve` :
       `saturating at |difference| = ${S.range} × the smooth render; grey: no smooth value`);
    S.rendered++;
    present();
  }
  draw.ticket = 0;

  // ---- zoom and pan: image pixel (x, y) covers canvas pixels [ox + x s, ox + (x + 1) s)
  const LADDER = [1 / 8, 1 / 6, 1 / 4, 1 / 3, 1 / 2, 2 / 3, 1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64];
  function sizeCanvas(c, w, h) {
    const cw = c.clientWidth || 800, ch = Math.round(Math.min(cw * h / w, 0.8 * window.innerHeight));
    c.style.height = ch + "px";
    c.width = Math.round(cw * dpr()); c.height = Math.round(ch * dpr());
  }
  function fitScale() {
    const sc = scene(), f = Math.min(canvas.width / sc.width, canvas.height / sc.height);
    return f >= 1 ? Math.floor(f) : f;
  }
  function zoomTo(s, cx, cy) {
    const sc = scene(), old = S.zoom || fitScale();
    if (S.zoom === null) center(old);
    cx = cx === undefined ? canvas.width / 2 : cx; cy = cy === undefined ? canvas.height / 2 : cy;
    S.ox = Math.round(cx - (cx - S.ox) * s / old); S.oy = Math.round(cy - (cy - S.oy) * s / old);
    S.zoom = s;
    present();
  }
  function center(s) {
    const sc = scene();
    S.ox = Math.round((canvas.width - sc.width * s) / 2); S.oy = Math.round((canvas.height - sc.height * s) / 2);
  }
  function present() {
    if (!work.width) return;
    const sc = scene(), s = S.zoom || fitScale();
    if (S.zoom === null) center(s);
    const g = canvas.getContext("2d");
    g.imageSmoothingEnabled = false;
    g.fillStyle = "#111"; g.fillRect(0, 0, canvas.width, canvas.height);
    g.drawImage(work, S.ox, S.oy, sc.width * s, sc.height * s);
    canvas.dataset.view = [s, S.ox, S.oy].join(",");
    canvas.dataset.state = JSON.stringify({scene: sc.name, method: column().method, shown: shown()[0], mode: S.mode,
                                           tone: S.tone, exposure: S.exposure, rendered: S.rendered});
  }
  canvas.addEventListener("wheel", (e) => {
    e.preventDefault();
    const s = S.zoom || fitScale(), up = e.deltaY < 0;
    const next = up ? LADDER.find((z) => z > s * 1.001) : [...LADDER].reverse().find((z) => z < s / 1.001);
    if (next) zoomTo(next, e.offsetX * dpr(), e.offsetY * dpr());
  }, {passive: false});
  let drag = null;
  let moved = false;
  canvas.addEventListener("mousedown", (e) => { drag = [e.clientX, e.clientY]; moved = false; canvas.focus(); });
  canvas.addEventListener("click", (e) => {  // a click (not a drag) centres the flicker view's zoom there
    if (moved) return;
    const sc = scene(), s = S.zoom || fitScale();
    const x = (e.offsetX * dpr() - S.ox) / s / sc.width, y = (e.offsetY * dpr() - S.oy) / s / sc.height;
    if (x >= 0 && x <= 1 && y >= 0 && y <= 1) { S.fcenter = [x, y]; drawFlicker(); }
  });
  window.addEventListener("mouseup", () => { drag = null; });
  canvas.addEventListener("mousemove", (e) => {
    if (drag) {
      if (S.zoom === null) S.zoom = fitScale();
      S.ox += Math.round((e.clientX - drag[0]) * dpr()); S.oy += Math.round((e.clientY - drag[1]) * dpr());
      moved = moved || e.clientX !== drag[0] || e.clientY !== drag[1];
      drag = [e.clientX, e.clientY]; present();
    }
    readout(e.offsetX * dpr(), e.offsetY * dpr());
  });
  canvas.addEventListener("dblclick", () => { if (S.zoom === null) zoomTo(1); else { S.zoom = null; present(); } });
  function readout(cx, cy) {
    const sc = scene(), s = S.zoom || fitScale(), x = Math.floor((cx - S.ox) / s), y = Math.floor((cy - S.oy) / s);
    if (x < 0 || y < 0 || x >= sc.width || y >= sc.height) { info.textContent = ""; return; }
    const i = y * sc.width + x, c = column(), unit = 2 ** -sc.scale_log2;
    const want = [c.method, c.own, sc.facets, sc.smooth].filter((k, j, all) => all.indexOf(k) === j);
    Promise.all(want.map((k) => halves(sc.images[k]))).then((arr) => {
      const v = Object.fromEntries(want.map((k, j) => [k, HALF[arr[j][i]] * unit]));
      const fmt = (z) => z.toPrecision(4), m = v[c.method], sm = v[sc.smooth];
      const rel = (t) => (sm > 0 ? ` (${((m - t) / sm >= 0 ? "+" : "") + ((m - t) / sm).toFixed(3)} × smooth)` : "");
      let text = `pixel (${x}, ${y}) radiance: ${c.label} ${fmt(m)}`;
      if (c.own !== c.method && c.own !== sc.facets) text += ` · own truth ${fmt(v[c.own])}, method − own truth ${fmt(m - v[c.own])}${rel(v[c.own])}`;
      text += ` · facet truth ${fmt(v[sc.facets])}, method − facet truth ${fmt(m - v[sc.facets])}${rel(v[sc.facets])}`;
      info.textContent = text + ` · smooth ${fmt(sm)}`;
    });
  }

  // ---- controls
  function setExposure(e) {
    S.exposure = Math.round(e * 100) / 100;
    expRange.value = S.exposure; expOut.textContent = `${S.exposure.toFixed(2)} stops`;
    draw(); drawFlicker();
  }
  function setColumn(i) {
    if (i < 0 || i >= scene().columns.length) return;
    S.col = i; tabs(); draw(); drawFlicker();
  }
  function setScene(i) {
    if (i < 0 || i >= M.scenes.length) return;
    S.scene = i; S.col = Math.min(S.col, scene().columns.length - 1); S.zoom = null;
    sizeCanvas(canvas, scene().width, scene().height);
    tabs(); loadVideo(); setExposure(scene().exposure);
  }
  function flip(which) {
    if (S.flip === which) return;
    S.flip = which; draw();
  }
  function cycle(list, value, step) { return list[(list.indexOf(value) + step + list.length) % list.length]; }
  document.addEventListener("keydown", (e) => {
    if (e.target.tagName === "SELECT" || e.target.tagName === "INPUT" || e.ctrlKey || e.metaKey || e.altKey) return;
    const k = e.key;
    if (k === " " || k === "f") { flip(k === " " ? "own" : "facets"); e.preventDefault(); return; }
    if (e.repeat) return;
    if (/^[1-9]$/.test(k)) setColumn(+k - 1);
    else if (k === "ArrowRight") setColumn(S.col + 1);
    else if (k === "ArrowLeft") setColumn(S.col - 1);
    else if (k === "ArrowDown") setScene(S.scene + 1);
    else if (k === "ArrowUp") setScene(S.scene - 1);
    else if (k === "+" || k === "=") setExposure(S.exposure + 0.5);
    else if (k === "-" || k === "_") setExposure(S.exposure - 0.5);
    else if (k === "e") setExposure(scene().exposure);
    else if (k === "t") { S.tone = toneSel.value = cycle(M.tones, S.tone, 1); draw(); drawFlicker(); }
    else if (k === "d") { S.mode = modeSel.value = cycle(MODES.map((m) => m[0]), S.mode, 1); draw(); }
    else if (k === "r") { S.zoom = null; present(); }
    else if (k === "o") zoomTo(1);
    else if (k === "p") play(!S.playing);
    else if (k === ",") showFrame(S.frame - 1);
    else if (k === ".") showFrame(S.frame + 1);
    else return;
    e.preventDefault();
  });
  document.addEventListener("keyup", (e) => {
    if (e.key === " " || e.key === "f") { flip(null); e.preventDefault(); }  // no click of a focused button
  });
  window.addEventListener("blur", () => flip(null));

  // ---- the camera path: one animated WebP per scene (a mosaic of tiles), each frame decoded by ImageDecoder
  // into `mosaic`, its tiles mapped through the exposure and tone curve
  const tile = document.createElement("canvas"), mosaic = document.createElement("canvas");
  const mctx = mosaic.getContext("2d", {willReadFrequently: true});
  let decoder = null, popBits = null, shownFrame = -1;
  function loadVideo() {
    const v = scene().video;
    S.frame = 0; play(false); popBits = null; shownFrame = -1;
    if (decoder) decoder.close();
    decoder = null;
    if (!v) { flickInfo.textContent = ""; return; }
    frameRange.max = v.frames - 1; frameRange.value = 0;
    const name = scene().name, bytes = bytesOf(v.id);
    inflated(v.pops_id).then((b) => { if (scene().name === name) { popBits = new Uint8Array(b); drawFlicker(); } });
    if (!window.ImageDecoder) {  // the animation plays as it is stored (log-encoded), without exposure or pops
      fallback.src = URL.createObjectURL(new Blob([bytes], {type: "image/webp"}));
      fallback.style.display = "block"; flickCanvas.style.display = "none";
      flickInfo.textContent = "This browser has no ImageDecoder (WebCodecs): the path plays as stored, log-encoded.";
      return;
    }
    decoder = new ImageDecoder({data: bytes, type: "image/webp"});
    showFrame(0);
  }
  async function showFrame(k) {
    const v = scene().video;
    if (!v || !decoder) return;
    S.frame = (k + v.frames) % v.frames; frameRange.value = S.frame;
    const want = S.frame, dec = decoder, r = await dec.decode({frameIndex: want});
    if (dec === decoder && want === S.frame) {
      mosaic.width = r.image.displayWidth; mosaic.height = r.image.displayHeight;
      mctx.drawImage(r.image, 0, 0);
      shownFrame = want;
      drawFlicker();
    }
    r.image.close();
  }
  function play(on) {
    if (S.playing) clearInterval(S.playing);
    S.playing = null; playBtn.textContent = "play";
    const v = scene().video;
    if (on && v && decoder) { S.playing = setInterval(() => showFrame(S.frame + 1), 1000 / v.fps); playBtn.textContent = "pause"; }
  }
  function popRow(v, method, pair) {  // the pixel -> popped? test of row (method, pair) of the bit mask
    const row = (v.pop_order.indexOf(method) * (v.frames - 1) + pair) * v.pop_row_bytes;
    return (i) => (popBits[row + (i >> 3)] >> (7 - (i & 7))) & 1;
  }
  function drawFlicker() {
    const sc = scene(), v = sc.video, c = column();
    if (!v || shownFrame < 0) return;
    // The smooth render has no tile (no glints to flicker): its column shows the facet truth alone.
    const keys = [c.method, c.own, sc.facets].filter((k, j, all) => all.indexOf(k) === j && k in v.at);
    // The crop of each tile shown (all of it, or 1 / zoom of it around the chosen centre), at s canvas pixels per pixel.
    const cw0 = Math.max(1, Math.round(v.width / S.fzoom)), ch0 = Math.max(1, Math.round(v.height / S.fzoom));
    const cx0 = Math.min(v.width - cw0, Math.max(0, Math.round(S.fcenter[0] * v.width - cw0 / 2)));
    const cy0 = Math.min(v.height - ch0, Math.max(0, Math.round(S.fcenter[1] * v.height - ch0 / 2)));
    const head = Math.round(18 * dpr()), gap = Math.round(6 * dpr());
    const avail = Math.round((flickCanvas.clientWidth || 800) * dpr());
    const s = Math.max(1, Math.min(Math.floor((avail - gap * (keys.length - 1)) / (cw0 * keys.length)),
                                   Math.floor(0.7 * window.innerHeight * dpr() / ch0)));
    const width = keys.length * cw0 * s + (keys.length - 1) * gap, ch = head + ch0 * s;
    if (flickCanvas.width !== avail || flickCanvas.height !== ch) {
      flickCanvas.width = avail; flickCanvas.height = ch; flickCanvas.style.height = ch / dpr() + "px";
    }
    const g = flickCanvas.getContext("2d"), x0 = Math.max(0, Math.round((avail - width) / 2));
    g.fillStyle = "#fafafa"; g.fillRect(0, 0, avail, ch);
    const lut = new Uint8Array(256), gain = 2 ** (S.exposure - sc.scale_log2);
    for (let code = 0; code < 256; code++) lut[code] = code ? toByte(2 ** (v.lo + (code - 1) * (v.hi - v.lo) / 254) * gain, S.tone) : 0;
    tile.width = cw0; tile.height = ch0;
    const tg = tile.getContext("2d");
    g.imageSmoothingEnabled = false;
    g.font = `${Math.round(12 * dpr())}px sans-serif`; g.textBaseline = "top";
    const frame = shownFrame, pair = frame - 1, count = frame > 0 ? v.pop_counts[c.method][pair] : 0;
    keys.forEach((key, n) => {
      const [sx, sy] = v.at[key];
      const img = mctx.getImageData(sx + cx0, sy + cy0, cw0, ch0), px = img.data;
      for (let j = 0; j < px.length; j += 4) { const b = lut[px[j]]; px[j] = px[j + 1] = px[j + 2] = b; px[j + 3] = 255; }
      tg.putImageData(img, 0, 0);
      const x = x0 + n * (cw0 * s + gap);
      g.drawImage(tile, 0, 0, cw0, ch0, x, head, cw0 * s, ch0 * s);
      let title = key === c.method ? c.label : key === sc.facets ? "facet truth" : `own truth (${c.truth_kind})`;
      if (key === c.method && frame > 0) {
        title += ` · pops ${frame}→${frame + 1}: ${(1000 * count / v.valid).toFixed(1)}‰`;
        if (S.pops && popBits && count) {
          const popped = popRow(v, c.method, pair);
          g.fillStyle = "rgba(255, 32, 32, 0.6)";
          for (let y = 0; y < ch0; y++) for (let q = 0; q < cw0; q++) {
            if (popped((y + cy0) * v.width + q + cx0)) g.fillRect(x + q * s, head + y * s, s, s);
          }
        }
      }
      g.fillStyle = "#222";
      g.fillText(title, x, 2 * dpr());
    });
    flickCanvas.dataset.view = [s, x0, head, gap, frame, cx0, cy0, cw0, ch0].join(",");
    const kind = frame <= Math.floor(v.frames / 2) ? "pan" : "zoom";  // validation.scene_images.camera_path
    flickInfo.textContent = `frame ${frame + 1} / ${v.frames} (${frame === 0 ? "start" : kind}), ${v.width} × ${v.height}` +
      (frame > 0 ? ` · pops between frames ${frame} and ${frame + 1}: ${count} pixels, ` +
       `${(1000 * count / v.valid).toFixed(2)} per 1000 valid pixels` : "") +
      ` · over the path: ${(1000 * v.pop_rate[c.method]).toFixed(2)} per 1000 pixel-frames (the table's pops against ` +
      `${c.truth_kind === "facets" || c.truth_kind === "self" ? "the facets" : "its own truth"})`;
    flickCanvas.dataset.rendered = (+(flickCanvas.dataset.rendered || 0) + 1).toString();
  }

  // ---- start
  modeSel.value = S.mode; toneSel.value = S.tone; rangeSel.value = S.range;
  window.addEventListener("resize", () => { sizeCanvas(canvas, scene().width, scene().height); present(); drawFlicker(); });
  setScene(0);
})();
