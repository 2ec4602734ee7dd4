// warp-texton view, WebGL2 mode: the page draws the noise itself with the exported GLSL library
// (TextonNoise, /texton_noise.js, builds the program and uploads the texton). Only the texton comes
// from the server (/api/shader, once per analysis setting); the view and the noise settings are
// uniforms, so panning, zooming and the sliders redraw without a request. A tiling model's payload
// (kind "tiling") is its GLSL port: the seed is its one uniform, the view placed on its lattice
// (and, for a model with a lattice of its example, the anchor's position mod that lattice's modulus).
"use strict";
(function (root) {
  const f = Math.fround;

  // What wp.poisson derives from a cell's mean count before drawing, in float32, as the exporter
  // computes it (shader_glsl.poisson_constants): exp and log rounded once from float64, as the C
  // library's expf and logf (which Warp's CPU kernels call) round; below a mean of 10 (the
  // multiplication of uniforms draws) the PTRS values are unused, 0.
  function poissonConstants(mean) {
    const lam = f(mean), slam = f(Math.sqrt(lam));
    if (!(lam >= 10)) return { enlam: f(Math.exp(-lam)), slam, ptrs: [0, 0, 0, 0], ptrs2: [0, 0] };
    const b = f(f(0.931) + f(f(2.53) * slam));
    const a = f(f(-0.059) + f(f(0.02483) * b));
    const invalpha = f(f(1.1239) + f(f(1.1328) / f(b - f(3.4))));
    const vr = f(f(0.9277) - f(f(3.6224) / f(b - f(2.0))));
    return { enlam: f(Math.exp(-lam)), slam, ptrs: [b, a, f(Math.log(invalpha)), vr], ptrs2: [f(Math.log(lam)), 0] };
  }

  // The uniforms of the noise settings (view_webgl.VIEW_UNIFORMS), or null where the texton's
  // noise refuses the MNI (the tiles then say why). λ = mni / area and a cell's mean count
  // λ · cw · ch in float64, then float32: noise_setup's and params_record's arithmetic.
  function noiseUniforms(payload, mni, seed, filter) {
    // a tiling model: the seed alone, for its one filter (none)
    if (payload.kind === "tiling") return payload.filters[filter] ? { TL_SEED: seed >>> 0 } : null;
    const lam = mni / payload.area;
    const mean = lam * payload.cell[0] * payload.cell[1];
    const flt = payload.filters[filter];
    if (!(mean <= payload.max_mean_count) || !flt) return null;
    const p = poissonConstants(mean);
    return {
      TN_SEED: seed >>> 0, TN_MEAN_COUNT: f(mean), TN_SQRT_MEAN_COUNT: p.slam, TN_EXP_NEG_MEAN: p.enlam,
      TN_PTRS: p.ptrs, TN_PTRS2: p.ptrs2, TN_LAM: f(lam), TN_SQRT_LAM: f(Math.sqrt(f(lam))),
      TN_FILTER_MODE: flt.mode, TN_LOD_BIAS: flt.bias,
    };
  }

  // A width x height raster whose top-left corner is at (left, top) in the page's unrotated view
  // coordinates, at scale pixels per texel, turned by rot degrees (view_query.view_window): its
  // origin split into an integer cell and a float32 remainder (the exporter's placement).
  function placement(payload, v) {
    const th = v.rot * (Math.PI / 180), c = Math.cos(th), s = Math.sin(th);
    const origin = [c * v.left - s * v.top, s * v.left + c * v.top];
    const base = [Math.floor(origin[0] / payload.cell[0]), Math.floor(origin[1] / payload.cell[1])];
    return {
      base, origin: [f(origin[0] - base[0] * payload.cell[0]), f(origin[1] - base[1] * payload.cell[1])],
      step_x: [f(c / v.scale), f(s / v.scale)], step_y: [f(-s / v.scale), f(c / v.scale)],
    };
  }

  // A tiling model's view (payload.kind "tiling"): the raster's centre placed on the model's
  // triangle lattice in float64, as runtimes.glsl.tiling.tiling_anchor places it: the lower-left vertex
  // (a, b) of its lattice cell, frac = p(a, b) - P(a, b) and the centre relative to P(a, b), the
  // vertex rounded to whole texels; then float32, with the steps per pixel (the preview's placement).
  // anchor_mod: P(a, b) mod the example lattice's modulus N per axis (runtimes.glsl.tiling.anchor_mod; N = 1
  // without one), exact: P is a whole number below 2^53 and % of doubles is exact.
  function tilingPlacement(payload, v) {
    const th = v.rot * (Math.PI / 180), c = Math.cos(th), s = Math.sin(th);
    const origin = [c * v.left - s * v.top, s * v.left + c * v.top];
    const sx = [c / v.scale, s / v.scale], sy = [-s / v.scale, c / v.scale];
    const x = [origin[0] + (sx[0] * (v.width / 2) + sy[0] * (v.height / 2)),
               origin[1] + (sx[1] * (v.width / 2) + sy[1] * (v.height / 2))];
    const side = payload.side, r = payload.sqrt3_2;
    const qy = (x[1] / side) / r, qx = x[0] / side - qy * 0.5;
    const a = Math.floor(qx), b = Math.floor(qy);
    const p = [side * (a + b * 0.5), side * b * r];
    const P = [Math.floor(p[0] + 0.5), Math.floor(p[1] + 0.5)];
    const n = payload.modulus || 1;
    const mod = (q) => ((q % n) + n) % n;
    return {
      anchor: [a, b], anchor_mod: [mod(P[0]), mod(P[1])],
      frac: [f(p[0] - P[0]), f(p[1] - P[1])], centre: [f(x[0] - P[0]), f(x[1] - P[1])],
      step_x: [f(sx[0]), f(sx[1])], step_y: [f(sy[0]), f(sy[1])],
    };
  }

  // The renderer of one texton (or tiling model) on canvas (a WebGL2 context made by the caller).
  function create(gl, payload) {
    const specs = {};
    for (const [name, t] of Object.entries(payload.textures)) {
      specs[name] = { width: t.width, height: t.height, data: TextonNoise.floats(t.data) };
    }
    const bind = TextonNoise.textures(gl, specs);
    const prog = TextonNoise.program(gl, payload.library, payload.main);
    const locations = new Map();
    const loc = (name) => {
      if (!locations.has(name)) locations.set(name, gl.getUniformLocation(prog, name));
      return locations.get(name);
    };
    function setTiling(u, v) {
      gl.uniform1ui(loc("TL_SEED"), u.TL_SEED);
      const at = tilingPlacement(payload, v);
      gl.uniform2i(loc("tn_anchor"), at.anchor[0], at.anchor[1]);
      gl.uniform2i(loc("tn_anchor_mod"), at.anchor_mod[0], at.anchor_mod[1]);
      gl.uniform2fv(loc("tn_frac"), at.frac);
      gl.uniform2fv(loc("tn_centre"), at.centre);
      gl.uniform2fv(loc("tn_step_x"), at.step_x);
      gl.uniform2fv(loc("tn_step_y"), at.step_y);
      gl.uniform1i(loc("tn_width"), v.width);
      gl.uniform1i(loc("tn_height"), v.height);
    }
    function set(u, v) {
      bind(prog);
      if (payload.kind === "tiling") { setTiling(u, v); return; }
      gl.uniform1ui(loc("TN_SEED"), u.TN_SEED);
      for (const name of ["TN_MEAN_COUNT", "TN_SQRT_MEAN_COUNT", "TN_EXP_NEG_MEAN", "TN_LAM", "TN_SQRT_LAM",
                          "TN_LOD_BIAS"]) gl.uniform1f(loc(name), u[name]);
      gl.uniform4fv(loc("TN_PTRS"), u.TN_PTRS);
      gl.uniform2fv(loc("TN_PTRS2"), u.TN_PTRS2);
      gl.uniform1i(loc("TN_FILTER_MODE"), u.TN_FILTER_MODE);
      const at = placement(payload, v);
      gl.uniform2i(loc("tn_base"), at.base[0], at.base[1]);
      gl.uniform2fv(loc("tn_origin"), at.origin);
      gl.uniform2fv(loc("tn_step_x"), at.step_x);
      gl.uniform2fv(loc("tn_step_y"), at.step_y);
      gl.uniform1i(loc("tn_height"), v.height);
    }
    return {
      payload,
      // the view v = {width, height, scale, rot, left, top} on the canvas, with the uniforms u
      draw(u, v) {
        set(u, v);
        TextonNoise.draw(gl, prog, v.width, v.height);
      },
      // the same as float32, RGBA per pixel, top row first
      readFloat: (u, v) => TextonNoise.readFloat(gl, prog, v.width, v.height, () => set(u, v)),
      dispose() {
        gl.deleteProgram(prog);
        bind.dispose();
      },
    };
  }

  // The WebGL2 context of canvas and the name of its renderer, or null.
  function context(canvas) {
    const gl = canvas.getContext("webgl2", { antialias: false, alpha: false, depth: false, stencil: false,
                                            preserveDrawingBuffer: true });
    if (!gl) return null;
    const info = gl.getExtension("WEBGL_debug_renderer_info");
    const renderer = String(info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER));
    return { gl, renderer, floatTargets: !!gl.getExtension("EXT_color_buffer_float") };
  }

  // Wait until the GPU has drawn what was asked (a one-pixel read): for timing frames.
  function finish(gl) {
    const px = new Uint8Array(4);
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
  }

  // The page's WebGL2 mode on glCanvas: the texton of one analysis at a time, fetched once from
  // /api/shader?KEY (KEY: the analysis's query), and frames of it. noise = {mni, seed, filter};
  // view as create's draw takes it. onChange() asks the page for a frame; onLost() is called
  // once if the context is lost (a GPU reset, a driver's timeout).
  function mode(glCanvas, onChange, onLost) {
    const ctx = context(glCanvas);
    if (ctx === null) return null;
    let current = null;           // create(...) of the analysis drawn, with its key
    let loading = null;           // the analysis whose texton is being fetched
    const failed = new Map();     // analysis -> why WebGL does not draw it (the tiles do)
    const uniforms = (noise) => noiseUniforms(current.payload, noise.mni, noise.seed, noise.filter);
    // a histogram-preserving texton's tables are those of its MNI: its program is fetched per MNI
    // (the payload says "histogram"); any other's once per analysis
    const wanted = (key, noise) => (current && current.key === key && !current.payload.histogram) ||
                                   (current && current.key === key && current.mni === noise.mni);
    function load(key, mni) {
      const id = `${key}&mni=${mni}`;
      if (loading === id) return;
      loading = id;
      let retry = 0;
      fetch(`/api/shader?${id}`)
        .then(async (r) => {
          if (r.status === 503) { retry = 1000; return null; }  // the server is busy: ask again in a moment
          if (!r.ok) throw new Error((await r.text()).trim() || `HTTP ${r.status}`);
          return r.json();
        })
        .then((payload) => {
          if (payload === null || loading !== id) return;
          const made = create(ctx.gl, payload);
          if (current) current.dispose();
          current = Object.assign(made, { key, mni });
        })
        .catch((e) => { if (loading === id) failed.set(key, e.message); })
        .finally(() => setTimeout(() => { if (loading === id) loading = null; onChange(); }, retry));
    }
    let lost = false;
    glCanvas.addEventListener("webglcontextlost", () => {
      lost = true;
      current = loading = null;
      onLost();
    });
    return {
      renderer: ctx.renderer,
      floatTargets: ctx.floatTargets,
      // whether WebGL draws this analysis and noise (true while its texton loads)
      usable: (key, noise) => !lost && !failed.has(key) && (current === null || current.key !== key ||
                                                          uniforms(noise) !== null),
      // why it does not
      failure: (key) => (lost ? "the WebGL2 context was lost" : failed.get(key) ||
                         (current && current.payload.refused) || "the MNI is too high for this texton's cells"),
      // draw a frame; returns 1 while the texton of key (or its tables for another MNI) loads, else 0
      draw(key, noise, view) {
        const stale = !wanted(key, noise);  // 1 until the program of this analysis (and MNI) is in
        if (stale) {
          load(key, noise.mni);
          if (!current || current.key !== key) return 1;  // another analysis: the last frame stays
        }
        if (glCanvas.width !== view.width || glCanvas.height !== view.height) {
          glCanvas.width = view.width;
          glCanvas.height = view.height;
        }
        current.draw(uniforms(noise), view);  // another MNI's tables meanwhile: redrawn once in
        glCanvas.hidden = false;
        return stale ? 1 : 0;
      },
      readFloat: (noise, view) => current.readFloat(uniforms(noise), view),
      noiseUniforms: (noise) => uniforms(noise),
      // ms per frame of n new views (a one-texel pan each), each drawn and finished
      frames(n, noise, view) {
        const u = uniforms(noise);
        current.draw(u, view);
        finish(ctx.gl);
        const t0 = performance.now();
        for (let k = 0; k < n; k++) {
          current.draw(u, Object.assign(view, { left: view.left + 1 / view.scale }));
          finish(ctx.gl);
        }
        return (performance.now() - t0) / n;
      },
    };
  }

  root.ViewerGL = { poissonConstants, noiseUniforms, placement, tilingPlacement, create, context, finish, mode };
})(typeof window !== "undefined" ? window : globalThis);
