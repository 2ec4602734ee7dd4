"""What the GLSL port of either model kind shares: its files, float literals, textures as page data, and
the WebGL2 preview page, whose one boot script draws a texton's or a tiling model's window.

A GLSL export is a library (the model's ``*.glsl``), the JavaScript that builds programs
and uploads textures (``shaders/texton_noise.js``, shared by every page that loads it,
the viewer's included), the textures as raw little-endian float32 RGBA (``NAME.f32``,
rows top first), their description (``texton_noise.json``) and a preview page
(``preview.html``): :func:`export_files` writes them alike for both kinds.

The preview page (:func:`preview_page`) is self-contained: the library, its ``main()``,
the textures (base64) and the window's placement (uniforms) are inlined as JSON, and
:data:`PREVIEW_BOOT` draws the window and offers ``window.textonNoise.readFloat()`` (and,
for texton noise, ``readImpacts()`` and ``evaluatePoints()``).
"""

from __future__ import annotations

import base64
import json

import numpy as np

from ..._version import __version__
from ..shared import template

#: The largest texture side WebGL2 guarantees (MAX_TEXTURE_SIZE ≥ 2048); larger textures are refused.
MAX_TEXTURE_SIZE = 2048
#: The largest preview canvas side (the float render target is a texture too).
MAX_PREVIEW_SIDE = 2048
#: The files of a GLSL export besides the library and its textures: the JavaScript, the description, the page.
JS_FILE = "texton_noise.js"
META_FILE = "texton_noise.json"
PREVIEW_FILE = "preview.html"


def glsl_float(v) -> str:
    """A float32 as a GLSL literal that reads back to the same float32."""
    return f"{float(np.float32(v)):.9e}"


def texture_data(textures: dict) -> dict:
    """The textures as ``TextonNoise.textures`` takes them in a page: name -> {width, height,
    data: base64 of little-endian float32 RGBA, top row first} (``TextonNoise.floats`` decodes it)."""
    return {name: {"width": a.shape[1], "height": a.shape[0],
                   "data": base64.b64encode(np.ascontiguousarray(a, "<f4").tobytes()).decode()}
            for name, a in textures.items()}


def export_files(library_file: str, source: str, textures: dict, settings: dict, page: str) -> dict[str, bytes]:
    """The files of a GLSL export, name -> content: the library, the JavaScript, each texture
    (NAME.f32), their description (texton_noise.json, marked as the package's) and the page."""
    files = {library_file: source.encode(), JS_FILE: template(JS_FILE).encode()}
    described = {}
    for name, a in textures.items():
        files[f"{name}.f32"] = np.ascontiguousarray(a, "<f4").tobytes()
        described[name] = {"file": f"{name}.f32", "width": a.shape[1], "height": a.shape[0], "format": "RGBA32F"}
    meta = {"warp_texton": __version__, "language": "glsl", "library": library_file, "script": JS_FILE,
            "textures": described, "settings": settings}
    files[META_FILE] = (json.dumps(meta, indent=2) + "\n").encode()
    files[PREVIEW_FILE] = page.encode()
    return files


#: The preview page's script: draws the window (``data.main`` over the library, the placement's
#: uniforms set before every draw) and offers the window's values to the page's reader.
PREVIEW_BOOT = """
(function () {
  "use strict";
  const data = JSON.parse(document.getElementById("texton-noise-data").textContent);
  const canvas = document.getElementById("noise");
  const gl = canvas.getContext("webgl2", {antialias: false, preserveDrawingBuffer: true});
  const status = document.getElementById("status");
  if (!gl) { status.textContent = "This page needs WebGL2."; return; }
  const specs = {};
  for (const [name, t] of Object.entries(data.textures)) {
    specs[name] = {width: t.width, height: t.height, data: TextonNoise.floats(t.data)};
  }
  const bind = TextonNoise.textures(gl, specs);
  const prog = TextonNoise.program(gl, data.library, data.main);
  const w = data.width, h = data.height;
  // the window's placement (data.uniforms: name -> [the gl.uniform* suffix, its values]) and, where
  // main() has one, its output tn_output (0: the values; 1: the impacts per pixel)
  function uniforms(output) {
    bind(prog);
    for (const [name, [kind, values]] of Object.entries(data.uniforms)) {
      gl["uniform" + kind](gl.getUniformLocation(prog, name), ...values);
    }
    gl.uniform1i(gl.getUniformLocation(prog, "tn_output"), output);
  }
  uniforms(0);
  TextonNoise.draw(gl, prog, w, h);
  status.textContent = data.caption;
  const page = {
    width: w, height: h, channels: data.channels,
    // the window's values as float32, RGBA per pixel, top row first
    readFloat: () => Array.from(TextonNoise.readFloat(gl, prog, w, h, () => uniforms(0))),
  };
  if (data.impacts) {
    // per pixel: (impacts in the texton's support, Σ of their offsets d = x − q)
    page.readImpacts = () => Array.from(TextonNoise.readFloat(gl, prog, w, h, () => uniforms(1)));
    // the noise at points, TextonNoise.evaluatePoints's layout
    page.evaluatePoints = (kind, inputs) => Array.from(TextonNoise.evaluatePoints(gl, data.library, bind, kind,
                                                                                  new Float32Array(inputs)));
  }
  window.textonNoise = page;
})();
"""


def preview_page(title: str, caption: str, shape, library: str, main: str, textures: dict, channels: int,
                 uniforms: dict, impacts: bool = False) -> str:
    """A self-contained page: a w × h canvas ``#noise`` that :data:`PREVIEW_BOOT` draws ``main``
    on (after ``library``), with ``textures`` (name -> float32 RGBA array) and the placement's
    ``uniforms`` (name -> [the ``gl.uniform*`` suffix, values]); ``impacts``: the page also
    reads texton noise's impacts and evaluates it at points."""
    h, w = shape
    data = {"library": library, "main": main, "width": w, "height": h, "channels": channels,
            "uniforms": uniforms, "impacts": impacts, "caption": caption, "textures": texture_data(textures)}
    blob = json.dumps(data).replace("</", "<\\/")  # no "</script>" inside the script element
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>{title}</title>
<style>body {{ background: #222; color: #ddd; font: 14px sans-serif; margin: 16px; }}
canvas {{ display: block; image-rendering: pixelated; }}</style>
</head>
<body>
<canvas id="noise" width="{w}" height="{h}"></canvas>
<p id="status">drawing...</p>
<script type="application/json" id="texton-noise-data">{blob}</script>
<script>{template(JS_FILE)}</script>
<script>{PREVIEW_BOOT}</script>
</body>
</html>
"""
