// Texton noise in WebGL2: builds programs from the exported GLSL (texton_noise.glsl), uploads the
// texton's textures and draws or reads back the noise. A plain script (no module system, no
// network): it defines the global TextonNoise, for pages that inline it (the HTML preview of
// `warp-texton shader --html`) or load it with a <script> tag (the viewer).
(function (root) {
  "use strict";

  // A triangle that covers the viewport, from gl_VertexID alone (no vertex buffers).
  const VERTEX = "#version 300 es\n" +
    "void main() {\n" +
    "  vec2 p = vec2(float((gl_VertexID & 1) << 2) - 1.0, float((gl_VertexID & 2) << 1) - 1.0);\n" +
    "  gl_Position = vec4(p, 0.0, 1.0);\n" +
    "}\n";

  // Evaluation at given points: point p reads texels (3 (p % 256) + t, p / 256), t = 0, 1, 2, of
  // tn_points and writes pixel (p % 256, p / 256). Layout per kind:
  //   0 plane, 2 impacts: (cell.x, cell.y, rel.x, rel.y)
  //   1 filtered:         (cell.x, cell.y, rel.x, rel.y), (dx.x, dx.y, dy.x, dy.y)
  //   3 surface:          (cube.x, cube.y, cube.z, -), (rel.x, rel.y, rel.z, -), (n.x, n.y, n.z, -)
  const POINTS_MAIN = `
uniform highp sampler2D tn_points;
uniform int tn_kind;
out vec4 tn_out;
void main() {
  ivec2 px = ivec2(gl_FragCoord.xy);
  vec4 a = texelFetch(tn_points, ivec2(3 * px.x, px.y), 0);
  vec4 b = texelFetch(tn_points, ivec2(3 * px.x + 1, px.y), 0);
  vec4 c = texelFetch(tn_points, ivec2(3 * px.x + 2, px.y), 0);
  vec3 v;
  if (tn_kind == 0) v = texton_noise_at(ivec2(a.xy), a.zw);
  else if (tn_kind == 1) v = texton_noise_filtered_at(ivec2(a.xy), a.zw, b.xy, b.zw);
  else if (tn_kind == 2) v = texton_impacts_at(ivec2(a.xy), a.zw);
  else v = texton_surface_noise_at(ivec3(a.xyz), b.xyz, c.xyz);
  tn_out = vec4(v, 1.0);
}
`;
  const KINDS = { plane: 0, filtered: 1, impacts: 2, surface: 3 };
  const ROW = 256;

  function shader(gl, type, source) {
    const s = gl.createShader(type);
    gl.shaderSource(s, source);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) {
      throw new Error("texton noise: shader compilation failed: " + gl.getShaderInfoLog(s));
    }
    return s;
  }

  // A program whose fragment shader is the exported library followed by `main` (a GLSL main()).
  function program(gl, library, main) {
    const p = gl.createProgram();
    gl.attachShader(p, shader(gl, gl.VERTEX_SHADER, VERTEX));
    gl.attachShader(p, shader(gl, gl.FRAGMENT_SHADER, library + "\n" + main));
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) {
      throw new Error("texton noise: program link failed: " + gl.getProgramInfoLog(p));
    }
    return p;
  }

  // Float32Array of a base64 string (little-endian float32, as the exporter writes them).
  function floats(base64) {
    const bin = atob(base64);
    const bytes = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
    return new Float32Array(bytes.buffer);
  }

  // An RGBA32F texture read with texelFetch: no filtering, no mipmaps. The texture bound to the
  // active unit stays bound.
  function floatTexture(gl, width, height, data) {
    const bound = gl.getParameter(gl.TEXTURE_BINDING_2D);
    const t = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, t);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, width, height, 0, gl.RGBA, gl.FLOAT, data);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    gl.bindTexture(gl.TEXTURE_2D, bound);
    return t;
  }

  // The texton's textures ({name: {width, height, data: Float32Array}}, as texton_noise.json
  // lists them) on units 0, 1, ...; returns a function that binds them to a program (and whose
  // dispose() deletes them).
  function textures(gl, specs) {
    const made = Object.keys(specs).map((name) => [name, floatTexture(gl, specs[name].width, specs[name].height,
                                                                       specs[name].data)]);
    function bind(prog) {
      gl.useProgram(prog);
      made.forEach(([name, tex], unit) => {
        gl.activeTexture(gl.TEXTURE0 + unit);
        gl.bindTexture(gl.TEXTURE_2D, tex);
        gl.uniform1i(gl.getUniformLocation(prog, name), unit);
      });
      return made.length;
    }
    bind.dispose = () => made.forEach(([, tex]) => gl.deleteTexture(tex));
    return bind;
  }

  // Draw prog over a width x height viewport of the bound framebuffer.
  function draw(gl, prog, width, height) {
    gl.useProgram(prog);
    gl.viewport(0, 0, width, height);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
  }

  // Render with prog into a width x height RGBA32F target (EXT_color_buffer_float) and return its
  // pixels as a Float32Array of width * height * 4, top row first.
  function readFloat(gl, prog, width, height, before) {
    if (!gl.getExtension("EXT_color_buffer_float")) {
      throw new Error("texton noise: float render targets (EXT_color_buffer_float) are not available");
    }
    const tex = floatTexture(gl, width, height, null);
    const fb = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
    gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
    if (before) before();
    draw(gl, prog, width, height);
    const out = new Float32Array(width * height * 4);
    gl.readPixels(0, 0, width, height, gl.RGBA, gl.FLOAT, out);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.deleteFramebuffer(fb);
    gl.deleteTexture(tex);
    const flipped = new Float32Array(out.length);
    const row = width * 4;
    for (let i = 0; i < height; i++) flipped.set(out.subarray((height - 1 - i) * row, (height - i) * row), i * row);
    return flipped;
  }

  // The noise at points: kind "plane", "filtered", "impacts" or "surface"; inputs a Float32Array
  // of 12 floats per point (three RGBA texels, POINTS_MAIN's layout). Returns 4 floats per point.
  function evaluatePoints(gl, library, bindTextures, kind, inputs) {
    const n = inputs.length / 12;
    const rows = Math.max(1, Math.ceil(n / ROW));
    const padded = new Float32Array(ROW * rows * 12);
    padded.set(inputs);
    const prog = program(gl, library, POINTS_MAIN);
    const unit = bindTextures(prog);
    const pts = floatTexture(gl, 3 * ROW, rows, padded);
    gl.activeTexture(gl.TEXTURE0 + unit);
    gl.bindTexture(gl.TEXTURE_2D, pts);
    gl.uniform1i(gl.getUniformLocation(prog, "tn_points"), unit);
    gl.uniform1i(gl.getUniformLocation(prog, "tn_kind"), KINDS[kind]);
    const px = readFloat(gl, prog, ROW, rows);
    gl.deleteTexture(pts);
    gl.deleteProgram(prog);
    // readFloat flips rows to top-first; point p is in GL row p / ROW, counted from the bottom
    const out = new Float32Array(n * 4);
    for (let p = 0; p < n; p++) {
      const src = ((rows - 1 - Math.floor(p / ROW)) * ROW + (p % ROW)) * 4;
      out.set(px.subarray(src, src + 4), p * 4);
    }
    return out;
  }

  root.TextonNoise = { VERTEX, POINTS_MAIN, program, floats, floatTexture, textures, draw, readFloat,
                       evaluatePoints };
})(typeof window !== "undefined" ? window : globalThis);
