// warp-texton view: an infinite canvas of texton noise, cut into tiles the server computes, or
// drawn by the page itself with WebGL2 (viewer_webgl.js) where the browser offers it.
//
// View coordinates u are texels before the rotation; the noise shown at u is the
// noise at R(rotation) u. At tile level z (2**z pixels per texel) tile (x, y) holds
// the global pixels [xT, xT + T) x [yT, yT + T) of that level, so tiles of one
// level are windows of a single raster. The canvas shows level z scaled by
// f = (device pixels per texel) / 2**z, which is 1 at whole zoom levels: then a
// canvas pixel is exactly one tile pixel.
"use strict";
(() => {
  const $ = (id) => document.getElementById(id);
  const canvas = $("canvas");
  const ctx = canvas.getContext("2d", { alpha: false });
  const TILE = 256;
  const MAX_BITMAPS = 600;
  const glCanvas = $("canvas-gl");
  // ?render=webgl|tiles forces a mode; auto (the default): WebGL2 where the browser has it on a
  // GPU. A software rasterizer draws the per-pixel shader far slower than the server's kernels,
  // which draw each impact once per tile (docs/viewer.md has the measured frame times).
  const RENDER = new URLSearchParams(location.search).get("render") || "auto";
  const SOFTWARE = /SwiftShader|llvmpipe|softpipe|software|Basic Render/i;

  const state = {
    info: null,
    mode: "noise",
    render: "tiles",  // "webgl": the page draws the noise mode itself; "tiles": the server does
    seed: 0, mni: 30, rot: 0, filter: "anisotropic",
    size: 64, order: 1, cc: true,
    zoom: 0,          // log2 of CSS pixels per texel
    left: 0, top: 0,  // view coordinates (texels) of the canvas's top-left corner
    plane: { tilt: 70, height: 1, fov: 40, texel: 0.002, res: 0.5 },
    mix: { b: null, steps: 9, start: 0, end: 512 },
  };

  // ------------------------------------------------------------ geometry
  const dpr = () => window.devicePixelRatio || 1;
  const scale = () => 2 ** state.zoom * dpr();  // device pixels per texel
  const zoomBounds = () => {
    const b = state.info.bounds;
    if (state.mode === "mix") return [b.mix_zoom[0], b.mix_zoom[1] + b.enlarge];
    return [b.zoom_min[state.filter], b.zoom_max + b.enlarge];
  };
  const levelBounds = () => {
    const b = state.info.bounds;
    if (state.mode === "mix") return b.mix_zoom;
    return [b.zoom_min[state.filter], b.zoom_max];
  };
  function level() {
    const [lo, hi] = levelBounds();
    return Math.min(hi, Math.max(lo, Math.round(Math.log2(scale()))));
  }
  // At whole zoom levels keep the corner on the pixel grid, so canvas pixels are tile pixels.
  function snap() {
    const s = scale();
    if (Number.isInteger(Math.log2(s))) {
      state.left = Math.round(state.left * s) / s;
      state.top = Math.round(state.top * s) / s;
    }
  }
  function centre() {
    const s = scale();
    return [state.left + canvas.width / (2 * s), state.top + canvas.height / (2 * s)];
  }
  function setCentre(cx, cy) {
    const s = scale();
    state.left = cx - canvas.width / (2 * s);
    state.top = cy - canvas.height / (2 * s);
    snap();
  }
  const rotate = (deg, [x, y]) => {
    const t = (deg * Math.PI) / 180, c = Math.cos(t), s = Math.sin(t);
    return [c * x - s * y, s * x + c * y];
  };
  function setZoom(z, ax = canvas.width / 2, ay = canvas.height / 2) {
    const [lo, hi] = zoomBounds();
    z = Math.min(hi, Math.max(lo, z));
    if (Math.abs(z - Math.round(z)) < 0.02) z = Math.round(z);
    const s0 = scale(), ux = state.left + ax / s0, uy = state.top + ay / s0;
    state.zoom = z;
    const s1 = scale();
    state.left = ux - ax / s1;
    state.top = uy - ay / s1;
    snap();
    changed();
  }
  // Turn the noise about the point at the centre of the view, which stays put.
  function setRotation(deg) {
    const world = rotate(state.rot, centre());
    state.rot = deg;
    const [cx, cy] = rotate(-deg, world);
    setCentre(cx, cy);
  }

  // ------------------------------------------------------------- queries
  function analysisParams() {
    return state.info.kind === "image" ? { size: state.size, order: state.order, cc: state.cc ? 1 : 0 } : {};
  }
  function query(params) {
    return Object.entries(params).map(([k, v]) => `${k}=${encodeURIComponent(v)}`).join("&");
  }
  function settings() {
    const p = { src: state.info.src, ...analysisParams(), seed: state.seed, mni: state.mni };
    if (state.mode === "mix") {
      Object.assign(p, { mode: "mix", b: state.mix.b, steps: state.mix.steps, ra: state.mix.start, rb: state.mix.end });
    } else if (state.mode === "noise") {
      Object.assign(p, { rot: state.rot, filter: state.filter });
    } else {
      p.filter = state.filter;
    }
    return p;
  }
  const tileURL = (base, z, x, y) => `/tile?${base}&z=${z}&x=${x}&y=${y}`;

  // ------------------------------------------------------------- bitmaps
  const bitmaps = new Map();   // url -> ImageBitmap, in least-recently-used order
  const inflight = new Map();  // url -> AbortController
  const failed = new Map();    // url -> message
  let lastTileMs = null;

  function cached(url) {
    const b = bitmaps.get(url);
    if (b) { bitmaps.delete(url); bitmaps.set(url, b); }
    return b;
  }
  function keep(url, bitmap) {
    bitmaps.set(url, bitmap);
    while (bitmaps.size > MAX_BITMAPS) {
      const [old, b] = bitmaps.entries().next().value;
      bitmaps.delete(old);
      b.close();
    }
  }
  function load(url, onDone) {
    const ac = new AbortController();
    inflight.set(url, ac);
    fetch(url, { signal: ac.signal })
      .then(async (r) => {
        if (r.status === 503) {  // the server is busy: ask again in a moment
          await new Promise((resolve) => setTimeout(resolve, 1000));
          throw Object.assign(new Error("busy"), { name: "AbortError" });
        }
        if (!r.ok) throw new Error((await r.text()).trim() || `HTTP ${r.status}`);
        const timing = /dur=([\d.]+)/.exec(r.headers.get("Server-Timing") || "");
        if (timing) lastTileMs = parseFloat(timing[1]);
        return createImageBitmap(await r.blob(), { colorSpaceConversion: "none", premultiplyAlpha: "none" });
      })
      .then((bitmap) => keep(url, bitmap))
      .catch((e) => { if (e.name !== "AbortError") { failed.set(url, e.message); showError(e.message); } })
      .finally(() => { if (inflight.get(url) === ac) inflight.delete(url); onDone(); });
  }
  // Requests the view no longer needs are dropped (the browser cancels them, and the
  // server skips a computation whose client has gone).
  function dropStale(needed) {
    for (const [url, ac] of inflight) if (!needed.has(url)) { ac.abort(); inflight.delete(url); }
  }

  // ------------------------------------------------------------- drawing
  let pending = 0, frameRequested = false, previousBase = null, planeURL = null;
  const idleWaiters = [];

  // ------------------------------------------------------------- WebGL2
  let gl = null;  // ViewerGL.mode of the overlay canvas, where the browser has WebGL2
  const analysisKey = () => query({ src: state.info.src, ...analysisParams() });
  const glNoise = () => ({ mni: state.mni, seed: state.seed, filter: state.filter });
  const glView = () => ({ width: canvas.width, height: canvas.height, scale: scale(), rot: state.rot,
                          left: state.left, top: state.top });
  // WebGL draws the noise mode; the ground plane, mixing and what the shader refuses are tiles
  const usingGL = () => state.render === "webgl" && gl !== null && state.mode === "noise" &&
                        gl.usable(analysisKey(), glNoise());
  function initGL() {
    const select = $("render");
    const lost = () => {
      state.render = select.value = "tiles";
      select.querySelector("option[value=webgl]").disabled = true;
      $("render-note").textContent = "The WebGL2 context was lost: the server draws tiles.";
      changed();
    };
    // a model the server has no WebGL2 program for (info.supports.webgl false): the tiles draw
    const served = !(state.info.supports && state.info.supports.webgl === false);
    if (RENDER !== "tiles" && served) {
      try { gl = ViewerGL.mode(glCanvas, requestFrame, lost); } catch (e) { gl = null; }
    }
    select.querySelector("option[value=webgl]").disabled = gl === null;
    const software = gl !== null && SOFTWARE.test(gl.renderer);
    state.render = gl !== null && (RENDER === "webgl" || (RENDER === "auto" && !software)) ? "webgl" : "tiles";
    select.value = state.render;
    $("render-note").textContent = gl ? `WebGL2: ${gl.renderer}` + (software ? " (software: slower than tiles)" : "") :
      !served ? "No WebGL2 program for this model: the server draws tiles." :
      RENDER === "tiles" ? "" : "WebGL2 is not available here: the server draws tiles.";
  }
  function drawGL() {
    message(null);
    dropStale(new Set());
    pending = gl.draw(analysisKey(), glNoise(), glView());  // 1 while the texton loads: the last frame stays
  }

  function changed() { requestFrame(); }
  function requestFrame() {
    if (!frameRequested) { frameRequested = true; requestAnimationFrame(draw); }
  }
  function draw() {
    frameRequested = false;
    if (!state.info) return;
    if (usingGL()) {
      drawGL();
    } else {
      glCanvas.hidden = true;
      ctx.fillStyle = "#202225";
      ctx.fillRect(0, 0, canvas.width, canvas.height);
      if (state.mode === "plane") drawPlane(); else drawTiles();
    }
    hud();
    if (pending === 0) while (idleWaiters.length) idleWaiters.shift()();
  }

  function drawTiles() {
    if (state.mode === "mix" && !state.mix.b) {
      pending = 0;
      message("Mixing needs a second input B: upload an image in the side panel.");
      dropStale(new Set());
      return;
    }
    message(null);
    const s = scale(), z = level(), st = 2 ** z, f = s / st;
    const base = query(settings());
    const x0 = Math.floor((state.left * st) / TILE), y0 = Math.floor((state.top * st) / TILE);
    const x1 = Math.ceil(((state.left + canvas.width / s) * st) / TILE) - 1;
    const y1 = Math.ceil(((state.top + canvas.height / s) * st) / TILE) - 1;
    const [cx, cy] = centre();
    const tiles = [];
    for (let y = y0; y <= y1; y++) {
      for (let x = x0; x <= x1; x++) {
        const d = ((x + 0.5) * TILE / st - cx) ** 2 + ((y + 0.5) * TILE / st - cy) ** 2;
        tiles.push({ x, y, d });
      }
    }
    tiles.sort((a, b) => a.d - b.d);  // the centre first
    const needed = new Set();
    let missing = 0;
    const edge = (v, origin) => Math.round((v - origin) * s);
    for (const t of tiles) {
      const url = tileURL(base, z, t.x, t.y);
      const rect = [edge((t.x * TILE) / st, state.left), edge((t.y * TILE) / st, state.top),
                    edge(((t.x + 1) * TILE) / st, state.left), edge(((t.y + 1) * TILE) / st, state.top)];
      const bitmap = cached(url);
      if (bitmap) { blit(bitmap, 0, 0, TILE, rect, f); continue; }
      if (failed.has(url)) continue;
      missing++;
      needed.add(url);
      drawFallback(t, z, rect, f);
      if (!inflight.has(url)) load(url, requestFrame);
    }
    dropStale(needed);
    pending = missing;
    if (missing === 0) previousBase = base;
  }

  function blit(bitmap, sx, sy, sw, rect, f) {
    ctx.imageSmoothingEnabled = f !== 1 || sw !== TILE;
    ctx.drawImage(bitmap, sx, sy, sw, sw, rect[0], rect[1], rect[2] - rect[0], rect[3] - rect[1]);
  }
  // While a tile loads: the same tile with the previous settings, else a coarser level.
  function drawFallback(t, z, rect, f) {
    if (previousBase) {
      const b = cached(tileURL(previousBase, z, t.x, t.y));
      if (b) { blit(b, 0, 0, TILE, rect, f); return; }
    }
    const base = query(settings());
    for (let k = 1; k <= 4; k++) {
      const px = Math.floor(t.x / 2 ** k), py = Math.floor(t.y / 2 ** k);
      const b = cached(tileURL(base, z - k, px, py)) || (previousBase && cached(tileURL(previousBase, z - k, px, py)));
      if (b) {
        const part = TILE / 2 ** k;
        blit(b, (t.x - px * 2 ** k) * part, (t.y - py * 2 ** k) * part, part, rect, 2);
        return;
      }
    }
  }

  function planeSize() {
    const bound = state.info.bounds.plane_pixels;
    let res = state.plane.res;
    while (Math.round(canvas.width * res) * Math.round(canvas.height * res) > bound) res *= 0.9;
    return [Math.max(1, Math.round(canvas.width * res)), Math.max(1, Math.round(canvas.height * res))];
  }
  function planeParams() {
    const [w, h] = planeSize();
    const p = state.plane;
    return { ...settings(), w, h, tilt: p.tilt, height: p.height, fov: p.fov, texel: p.texel };
  }
  function drawPlane() {
    message(null);
    const url = `/plane?${query(planeParams())}`;
    const bitmap = cached(url);
    const needed = new Set();
    if (bitmap) {
      ctx.imageSmoothingEnabled = true;
      ctx.drawImage(bitmap, 0, 0, canvas.width, canvas.height);
      planeURL = url;
      pending = 0;
    } else {
      const old = planeURL && cached(planeURL);
      if (old) { ctx.imageSmoothingEnabled = true; ctx.drawImage(old, 0, 0, canvas.width, canvas.height); }
      if (!failed.has(url)) {
        needed.add(url);
        if (!inflight.has(url)) load(url, requestFrame);
        pending = 1;
      } else pending = 0;
    }
    dropStale(needed);
  }

  function hud() {
    let text;
    if (state.mode === "plane") {
      const [w, h] = planeSize();
      text = `plane ${w}×${h}` + (pending ? " · rendering…" : "");
    } else {
      const [cx, cy] = rotate(state.mode === "mix" ? 0 : state.rot, centre());
      const s = scale() / dpr();
      const glNow = usingGL();
      text = `${s >= 1 ? s.toFixed(2) + " px/texel" : (1 / s).toFixed(2) + " texels/px"} · ` +
             (glNow ? "WebGL2" : `level ${level()}`) + ` · centre (${cx.toFixed(1)}, ${cy.toFixed(1)})` +
             (pending ? (glNow ? " · loading the texton…" : ` · ${pending} tiles to load`) : "");
      if (!glNow && state.render === "webgl" && state.mode === "noise" && gl) text += ` · tiles: ${gl.failure(analysisKey())}`;
    }
    if (lastTileMs !== null && !(state.mode === "noise" && usingGL())) text += ` · last ${lastTileMs.toFixed(0)} ms`;
    $("hud").textContent = text;
  }
  function message(text) {
    const m = $("message");
    m.hidden = !text;
    if (text) m.textContent = text;
  }
  function showError(text) {
    const s = $("status");
    s.textContent = text;
    s.classList.add("error");
  }
  function clearError() {
    const s = $("status");
    s.textContent = "";
    s.classList.remove("error");
  }

  // -------------------------------------------------------------- panel
  let panelAbort = null, panelKey = null;
  function refreshPanel() {
    const params = { src: state.info.src, ...analysisParams(), seed: state.seed };
    const key = query(params);
    if (key === panelKey) return;
    panelKey = key;
    if (panelAbort) panelAbort.abort();
    panelAbort = new AbortController();
    $("model-error").textContent = "analysing…";
    fetch(`/api/panel?${key}`, { signal: panelAbort.signal })
      .then(async (r) => {
        if (!r.ok) throw new Error((await r.text()).trim());
        return r.json();
      })
      .then((p) => {
        $("model-error").textContent = p.model_error == null ? `n/a (${p.kind === "tiling" ? "tiling model" : "texton file"})` : p.model_error.toFixed(3);
        $("texton-info").textContent = (p.summary ? `${p.summary}, ` : `${p.texton_size[0]}×${p.texton_size[1]} texton, order ${p.order}, ` +
          `${p.channels === 1 ? "grey" : "RGB"}, `) + `mean ${p.mean.map((v) => v.toFixed(3)).join(", ")}` +
          (p.structure != null ? `, structure score ${p.structure.toFixed(2)}` : "");
        for (const name of ["input", "gaussian", "texton", "spectrum_input", "spectrum_texton", "spectrum_noise"]) {
          const img = $(`img-${name}`);
          if (p[name]) img.src = p[name];
        }
      })
      .catch((e) => {
        if (e.name === "AbortError") return;
        panelKey = null;
        $("model-error").textContent = "—";
        showError(e.message);
      });
  }

  // ------------------------------------------------------------- export
  function exportParams() {
    const kind = $("export-kind").value;
    const w = parseInt($("export-w").value, 10), h = parseInt($("export-h").value, 10);
    const p = { src: state.info.src, ...analysisParams(), seed: state.seed, mni: state.mni, format: $("export-format").value };
    if (state.mode === "plane") {
      const pl = state.plane;
      return { ...p, mode: "plane", filter: state.filter, w, h, tilt: pl.tilt, height: pl.height, fov: pl.fov, texel: pl.texel };
    }
    // the view's region: exactly the canvas at its own size, else the same centre and width
    const s = scale();
    let es = s, left = state.left, top = state.top;
    if (w !== canvas.width || h !== canvas.height) {
      const [cx, cy] = centre();
      es = (s * w) / canvas.width;
      left = cx - w / (2 * es);
      top = cy - h / (2 * es);
    }
    if (state.mode === "mix") {
      return { ...p, mode: "mix", b: state.mix.b, steps: state.mix.steps, ra: state.mix.start, rb: state.mix.end,
               w, h, scale: es, left, top };
    }
    if (kind === "tile") return { ...p, rot: state.rot, filter: state.filter, kind, w, h, scale: s };
    return { ...p, rot: state.rot, filter: state.filter, kind, w, h, scale: es, left, top };
  }
  async function doExport() {
    clearError();
    const q = query(exportParams());
    const r = await fetch(`/api/plan?${q}`);
    if (!r.ok) { showError((await r.text()).trim()); return; }
    const plan = await r.json();
    $("export-file").textContent = `${plan.file} (${plan.width}×${plan.height})`;
    $("export-cli").textContent = plan.cli.join("\n");
    $("export-python").textContent = plan.python;
    $("export-plan").hidden = false;
    const a = document.createElement("a");
    a.href = `/export?${q}`;
    a.download = plan.file;
    document.body.appendChild(a);
    a.click();
    a.remove();
  }

  // ------------------------------------------------------------- inputs
  function fitRamp() {
    const s = scale();
    state.mix.start = Math.round(state.left + (0.25 * canvas.width) / s);
    state.mix.end = Math.round(state.left + (0.75 * canvas.width) / s);
    if (state.mix.end <= state.mix.start) state.mix.end = state.mix.start + 1;
    $("ramp-a").value = state.mix.start;
    $("ramp-b").value = state.mix.end;
  }
  function setMode(mode) {
    if (mode === "mix" && state.rot !== 0) setRotation(0);
    if (mode === "mix" && state.mode !== "mix" && !rampSet) { fitRamp(); rampSet = true; }
    state.mode = mode;
    $("plane-section").hidden = mode !== "plane";
    $("mix-section").hidden = mode !== "mix";
    $("rot-row").hidden = mode !== "noise";
    $("filter-row").hidden = mode === "mix";
    $("zoom-row").hidden = mode === "plane";
    const kind = $("export-kind");
    kind.querySelector("option[value=tile]").disabled = mode !== "noise";
    if (mode !== "noise") kind.value = "view";
    setZoom(state.zoom);
    clearError();
    changed();
  }
  let rampSet = false;

  function bind(id, onInput, event = "input") {
    $(id).addEventListener(event, (e) => { clearError(); onInput(e.target); changed(); });
  }
  function outputs() {
    $("mni-out").textContent = state.mni;
    $("rot-out").textContent = `${state.rot}°`;
    $("tilt-out").textContent = `${state.plane.tilt}°`;
    $("height-out").textContent = state.plane.height.toPrecision(3);
    $("fov-out").textContent = `${state.plane.fov}°`;
    $("texel-out").textContent = state.plane.texel.toPrecision(2);
    $("steps-out").textContent = state.mix.steps;
  }
  function addSecond(id, name) {
    const sel = $("mix-b");
    if (![...sel.options].some((o) => o.value === id)) sel.add(new Option(name, id));
    sel.value = id;
    state.mix.b = id;
  }

  function setupControls() {
    const info = state.info, d = info.defaults;
    Object.assign(state, { seed: d.seed, mni: d.mni, filter: d.filter, size: d.size, order: d.order, cc: d.cc });
    $("input-name").textContent = `${info.name} (${info.kind}${info.input_size ? `, ${info.input_size[0]}×${info.input_size[1]}` : ""})` +
      (info.device ? ` · ${info.device}` : "");
    $("seed").value = state.seed;
    $("mni").min = Math.max(1, Math.ceil(info.bounds.mni[0]));
    $("mni").value = state.mni;
    for (const f of info.bounds.filters) {  // the server's registry of filters: names and what each does
      const option = new Option(f, f);
      option.title = info.filter_notes[f];
      $("filter").add(option);
    }
    $("filter").value = state.filter;
    const sizes = $("size");
    const largest = info.input_size ? Math.floor((Math.min(...info.input_size) + 1) / 2) : info.bounds.texton_size[1];
    // half the input at most (docs/limits.md), and always the size in use, however large
    for (const v of [8, 16, 24, 32, 48, 64, 96, 128, largest, state.size].filter((v, i, a) => a.indexOf(v) === i).sort((a, b) => a - b)) {
      if (v === state.size || (v >= info.bounds.texton_size[0] && v <= Math.min(largest, info.bounds.texton_size[1]))) {
        sizes.add(new Option(`${v}×${v}`, v));
      }
    }
    sizes.value = state.size;
    $("order").value = state.order;
    $("cc").checked = state.cc;
    if (info.kind !== "image") {
      for (const id of ["size", "order", "cc"]) $(id).disabled = true;
      $("analysis-note").textContent = `The input is a ${info.kind === "tiling" ? "tiling model" : "texton"} file: nothing to analyse.`;
      for (const id of ["fig-input", "fig-gaussian", "fig-spectrum-input"]) $(id).hidden = true;
    }
    if (info.kind === "tiling") {  // tiling and blending: no MNI; the modes the server supports for it
      $("mni").disabled = true;
      const supports = info.supports || {};
      for (const [mode, ok] of [["plane", supports.plane], ["mix", supports.mix]]) {
        document.querySelector(`input[name=mode][value=${mode}]`).disabled = !ok;
      }
    }
    if (info.mix_b) addSecond(info.mix_b.id, info.mix_b.name);
    outputs();

    bind("render", (t) => { state.render = t.value; }, "change");
    document.querySelectorAll("input[name=mode]").forEach((r) => r.addEventListener("change", (e) => setMode(e.target.value)));
    bind("seed", (t) => {
      const v = Number(t.value);
      if (Number.isInteger(v) && v >= 0 && v < 2 ** 32) state.seed = v;
      refreshPanel();
    });
    $("seed-next").addEventListener("click", () => { state.seed = (state.seed + 1) % 2 ** 32; $("seed").value = state.seed; refreshPanel(); changed(); });
    bind("mni", (t) => { state.mni = Number(t.value); outputs(); });
    bind("rot", (t) => { setRotation(Number(t.value)); outputs(); });
    bind("filter", (t) => { state.filter = t.value; setZoom(state.zoom); }, "change");
    bind("size", (t) => { state.size = Number(t.value); refreshPanel(); }, "change");
    bind("order", (t) => { state.order = Number(t.value); refreshPanel(); }, "change");
    bind("cc", (t) => { state.cc = t.checked; refreshPanel(); }, "change");
    bind("tilt", (t) => { state.plane.tilt = Number(t.value); outputs(); });
    bind("height", (t) => { state.plane.height = Number((10 ** Number(t.value)).toPrecision(3)); outputs(); });
    bind("fov", (t) => { state.plane.fov = Number(t.value); outputs(); });
    bind("texel", (t) => { state.plane.texel = Number((10 ** Number(t.value)).toPrecision(2)); outputs(); });
    bind("plane-res", (t) => { state.plane.res = Number(t.value); }, "change");
    bind("steps", (t) => { state.mix.steps = Number(t.value); outputs(); });
    bind("mix-b", (t) => { state.mix.b = t.value || null; }, "change");
    bind("ramp-a", (t) => { if (t.value !== "" && Number(t.value) < state.mix.end) state.mix.start = Number(t.value); }, "change");
    bind("ramp-b", (t) => { if (t.value !== "" && Number(t.value) > state.mix.start) state.mix.end = Number(t.value); }, "change");
    $("ramp-fit").addEventListener("click", () => { fitRamp(); changed(); });
    $("mix-file").addEventListener("change", async (e) => {
      const file = e.target.files[0];
      if (!file) return;
      clearError();
      const r = await fetch("/api/upload", { method: "POST", body: file,
        headers: { "X-Requested-With": "warp-texton", "X-Filename": encodeURIComponent(file.name).slice(0, 200) } });
      if (!r.ok) { showError((await r.text()).trim()); return; }
      const b = await r.json();
      addSecond(b.id, `${b.name} (${b.width}×${b.height})`);
      changed();
    });
    $("zoom-in").addEventListener("click", () => setZoom(Math.round(state.zoom) + 1));
    $("zoom-out").addEventListener("click", () => setZoom(Math.round(state.zoom) - 1));
    $("zoom-one").addEventListener("click", () => setZoom(0));
    $("home").addEventListener("click", () => { setCentre(...rotate(-state.rot, [0, 0])); changed(); });
    $("export").addEventListener("click", () => doExport().catch((e) => showError(e.message)));
    document.querySelectorAll("button.copy").forEach((b) => b.addEventListener("click", () => {
      const text = $(b.dataset.copy).textContent;
      if (navigator.clipboard) navigator.clipboard.writeText(text).catch(() => {});
    }));
  }

  // ------------------------------------------------------- pointer/wheel
  const pointers = new Map();
  let pinch = null;
  canvas.addEventListener("pointerdown", (e) => {
    canvas.setPointerCapture(e.pointerId);
    pointers.set(e.pointerId, [e.clientX, e.clientY]);
    canvas.classList.add("dragging");
    if (pointers.size === 2) {
      const [a, b] = [...pointers.values()];
      pinch = { d: Math.hypot(a[0] - b[0], a[1] - b[1]), zoom: state.zoom };
    }
  });
  canvas.addEventListener("pointermove", (e) => {
    const last = pointers.get(e.pointerId);
    if (!last || state.mode === "plane") return;
    if (pointers.size === 2 && pinch) {
      pointers.set(e.pointerId, [e.clientX, e.clientY]);
      const [a, b] = [...pointers.values()];
      const r = canvas.getBoundingClientRect();
      setZoom(pinch.zoom + Math.log2(Math.hypot(a[0] - b[0], a[1] - b[1]) / pinch.d),
              ((a[0] + b[0]) / 2 - r.left) * dpr(), ((a[1] + b[1]) / 2 - r.top) * dpr());
      return;
    }
    const s = scale();
    state.left -= ((e.clientX - last[0]) * dpr()) / s;
    state.top -= ((e.clientY - last[1]) * dpr()) / s;
    pointers.set(e.pointerId, [e.clientX, e.clientY]);
    snap();
    changed();
  });
  const release = (e) => {
    pointers.delete(e.pointerId);
    if (pointers.size < 2) pinch = null;
    if (!pointers.size) canvas.classList.remove("dragging");
  };
  canvas.addEventListener("pointerup", release);
  canvas.addEventListener("pointercancel", release);
  canvas.addEventListener("wheel", (e) => {
    e.preventDefault();
    const r = canvas.getBoundingClientRect();
    const unit = e.deltaMode === 1 ? 16 : e.deltaMode === 2 ? 400 : 1;
    if (state.mode === "plane") {
      state.plane.height = Math.min(100, Math.max(0.01, state.plane.height * 2 ** ((e.deltaY * unit) / 500)));
      $("height").value = Math.log10(state.plane.height);
      outputs();
      changed();
      return;
    }
    setZoom(state.zoom - (e.deltaY * unit) / 400, (e.clientX - r.left) * dpr(), (e.clientY - r.top) * dpr());
  }, { passive: false });
  canvas.addEventListener("keydown", (e) => {
    const step = 64 / scale();
    const keys = {
      "+": () => setZoom(Math.round(state.zoom) + 1), "=": () => setZoom(Math.round(state.zoom) + 1),
      "-": () => setZoom(Math.round(state.zoom) - 1), "0": () => setZoom(0),
      ArrowLeft: () => { state.left -= step; }, ArrowRight: () => { state.left += step; },
      ArrowUp: () => { state.top -= step; }, ArrowDown: () => { state.top += step; },
      h: () => setCentre(...rotate(-state.rot, [0, 0])),
    };
    if (keys[e.key]) { e.preventDefault(); keys[e.key](); snap(); changed(); }
  });

  function resize() {
    const [cx, cy] = state.info ? centre() : [0, 0];
    canvas.width = Math.max(1, Math.round(canvas.clientWidth * dpr()));
    canvas.height = Math.max(1, Math.round(canvas.clientHeight * dpr()));
    $("export-w").value = canvas.width;
    $("export-h").value = canvas.height;
    if (state.info) setCentre(cx, cy);
    changed();
  }
  window.addEventListener("resize", resize);

  // --------------------------------------------------------------- start
  // For tests and scripts: the view, the number of tiles still loading, a promise of idleness.
  window.viewer = {
    state,
    pending: () => (state.info ? pending : 1),
    panelPending: () => panelKey === null || $("model-error").textContent === "analysing…",
    view: () => ({ zoom: state.zoom, scale: scale(), level: level(), left: state.left, top: state.top,
                   rot: state.rot, width: canvas.width, height: canvas.height, tile: TILE }),
    idle: () => new Promise((resolve) => { idleWaiters.push(resolve); requestFrame(); }),
    setView: (v) => { Object.assign(state, v); snap(); changed(); },
    // the WebGL2 mode: what draws now, the float32 pixels of the view (RGBA, top row first),
    // the uniforms of noise settings, and the time of n frames (ms each, drawn and finished)
    render: () => ({ requested: RENDER, render: state.render, drawing: state.info && usingGL() ? "webgl" : "tiles",
                     renderer: gl && gl.renderer, floatTargets: gl !== null && gl.floatTargets }),
    setRender: (mode) => { state.render = mode; $("render").value = mode; changed(); },
    readFloat: () => Array.from(gl.readFloat(glNoise(), glView())),
    noiseUniforms: (mni, seed, filter) => gl.noiseUniforms({ mni, seed, filter }),
    glFrames: (n) => gl.frames(n, glNoise(), glView()),
  };

  fetch("/api/info")
    .then((r) => r.json())
    .then((info) => {
      state.info = info;
      initGL();
      setupControls();
      resize();
      setCentre(canvas.width / (2 * scale()), canvas.height / (2 * scale()));  // the origin at the top-left
      refreshPanel();
      changed();
    })
    .catch((e) => showError(`cannot reach the server: ${e.message}`));
})();
