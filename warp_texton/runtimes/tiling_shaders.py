"""Tiling models as GLSL and OSL: the ports of ``kernels/noise_tiling.py`` ``tiling_value``.

A :class:`~warp_texton.model.tiling.TilingModel` exports as

* GLSL (``shaders/tiling_noise.glsl``, its constants block written here):
  ``tiling_noise(x)`` and ``tiling_noise_at(anchor, frac, rel)``, the example
  (and its guide, in alpha) as one RGBA32F texture ``tiling_example`` read
  with ``texelFetch``, and an HTML preview page (WebGL2) drawing the window
  ``synthesize`` gives;
* OSL (``shaders/tiling_noise.osl``): ``tiling_plane``, the model on object
  coordinates or UVs, with the example embedded as a constant array.

Both reproduce docs/tiling.md's specification: the vertex hash and Warp's PCG
draws in 32-bit integer arithmetic (equal bits), the float steps in float32.
Neither has float64 (the kernels' grid): GLSL takes positions relative to an
anchor vertex of the lattice whose whole-texel position the host computes in
float64 (:func:`tiling_anchor`), OSL takes the shading point in float32 from
the origin. docs/tiling.md gives the limits and the measured agreement.
No filtered variant is exported (the shaders are the unfiltered ``tiling_value``).

Kernels driven here: ``warp_texton.kernels.noise_tiling``.
"""

from __future__ import annotations

import json
import math
from importlib import resources
from string import Template

import numpy as np

from .._version import __version__
from ..core.checks import check_positive, check_seed, check_shape
from ..core.errors import TextonError
from ..kernels import tiling_draw
from ..model.tiling import TilingModel
from ..model.histogram import GAUSS_RANGE
from ..noise.colours import noise_moments
from ..noise.noise_options import NoiseOptions
from ..noise.raster import raster_geometry
from ..noise.synthesis import MAX_TILING_REACH
from .osl import colour_map_code
from .glsl import JS_FILE, MAX_PREVIEW_SIDE, MAX_TEXTURE_SIZE, META_FILE, PREVIEW_FILE, page_html, texture_data

#: The files of a GLSL export of a tiling model (beside texton_noise.js, texton_noise.json, preview.html).
GLSL_FILE = "tiling_noise.glsl"
EXAMPLE_TEXTURE = "tiling_example"
#: A histogram-preserving model's tables (tiling_colours.f32).
COLOUR_TEXTURE = "tiling_colours"
#: The OSL export's shader and its description.
OSL_FILE = "tiling_plane.osl"
#: √3/2 as the kernels hold it (float64): the host places the GLSL port's anchor with it.
SQRT3_2 = float(tiling_draw.SQRT3_2)
#: Floats of example an OSL shader embeds at most (texels × channels, plus the guide's when
#: the model has a guide weight): a 512 × 512 RGB example (docs/tiling.md gives compile times).
MAX_OSL_FLOATS = 512 * 512 * 3


def _source(name: str) -> str:
    return resources.files("warp_texton.runtimes").joinpath("shaders").joinpath(name).read_text(encoding="utf-8")


def _f(v) -> str:
    """A float32 as a GLSL literal that reads back to the same float32."""
    return f"{float(np.float32(v)):.9e}"


def check_model(model) -> TilingModel:
    if not isinstance(model, TilingModel):
        raise TextonError(f"model must be a TilingModel, got {type(model).__name__}", param="texton")
    return model


def refuse_texton_options(noise: NoiseOptions | None, **options) -> int:
    """The seed of a tiling model's export; one error naming the texton-noise options given
    (``noise``'s mni, period, poisson, cell_factor other than their defaults, and any of
    ``options`` that is not None)."""
    default = NoiseOptions()
    given = []
    seed = 0
    if noise is not None:
        given = [name for name in ("mni", "period", "poisson", "cell_factor")
                 if getattr(noise, name) != getattr(default, name)]
        seed = noise.seed
    given += [name for name, value in options.items() if value is not None]
    if given:
        raise TextonError(f"{', '.join(given)} do not apply to the shader export of a tiling model (method "
                          "'tiling'): its shaders are the unfiltered plane tiling (docs/tiling.md)", param=given[0])
    return seed


# ---------------------------------------------------------------- the grid (float64, on the host)


def tiling_anchor(model: TilingModel, x) -> tuple[tuple[int, int], np.ndarray, np.ndarray]:
    """((a, b), frac, rel) of a point x (noise units, float64) for ``tiling_noise_at``: the
    lower-left vertex (a, b) of x's lattice cell (the kernels' ``triangle_of``), frac =
    p(a, b) − P(a, b) and rel = x − P(a, b), P(a, b) = ⌊p(a, b) + ½⌋ the vertex rounded to
    whole texels (``vertex_position``), all in float64 as the kernels compute them."""
    x = np.asarray(x, np.float64)
    s = float(np.float32(model.side))
    sy = (x[1] / s) / SQRT3_2
    sx = x[0] / s - sy * 0.5
    a, b = int(math.floor(sx)), int(math.floor(sy))
    p = np.array([s * (a + b * 0.5), s * b * SQRT3_2])
    P = np.floor(p + 0.5)
    return (a, b), p - P, x - P


# ---------------------------------------------------------------- GLSL


def example_texture(model: TilingModel) -> np.ndarray:
    """(H, W, 4) float32: the example in RGB (grey in R), the guide in A (zeros without a guide weight)."""
    ex = model.example
    out = np.zeros(ex.shape[:2] + (4,), np.float32)
    out[..., :ex.shape[2]] = ex
    if model.guide_weight != 0.0:
        out[..., 3] = model.guide
    return out


def colour_texture(model: TilingModel) -> np.ndarray | None:
    """(1, K, 4) float32: a histogram-preserving model's inverse-CDF tables (the unfiltered row
    of ``prefiltered``, which ``colour_value`` reads), channel c in component c; None without tables."""
    tr = model.histogram
    if tr is None:
        return None
    tables = np.asarray(tr.prefiltered[-1], np.float32)  # (C, K)
    out = np.zeros((1, tables.shape[1], 4), np.float32)
    out[0, :, :tables.shape[0]] = tables.T
    return out


def colour_constants(model: TilingModel) -> list:
    """The histogram tables' constants (kernels/noise_colours.py ``ColourMap``, as
    :func:`~warp_texton.noise.colours.make_colour_map` fills it); pass-through values without tables."""
    tr = model.histogram
    c = model.channels
    matrix, centre, mean, std = np.eye(3), np.zeros(3), np.zeros(3), np.ones(3)
    if tr is not None:
        matrix[:c, :c] = tr.matrix
        centre[:c] = tr.centre
        m, sd = noise_moments(model)
        mean[:c], std[:c] = m, sd
    vec = lambda v: f"vec3({', '.join(_f(x) for x in v)})"  # noqa: E731
    return [
        ("const bool", "TL_HISTOGRAM", "true" if tr is not None else "false"),
        ("const vec3", "TL_NOISE_MEAN", vec(mean)),
        ("const vec3", "TL_NOISE_STD", vec(std)),
        ("const mat3", "TL_COLOUR_MATRIX", f"mat3({', '.join(_f(v) for v in matrix.ravel(order='F'))})"),
        ("const vec3", "TL_COLOUR_CENTRE", vec(centre)),
        ("const float", "TL_GAUSS_RANGE", _f(GAUSS_RANGE)),
        ("const int", "TL_LUT_SIZE", str(tr.lut.shape[1] if tr is not None else 2)),
    ]


def textures(model: TilingModel) -> dict[str, np.ndarray]:
    """The GLSL textures of a tiling model: the example (and guide), and a histogram-preserving
    model's tables."""
    out = {EXAMPLE_TEXTURE: example_texture(model)}
    colours = colour_texture(model)
    if colours is not None:
        out[COLOUR_TEXTURE] = colours
    return out


def glsl_source(model: TilingModel, seed: int) -> str:
    """The GLSL library of a tiling model and seed (``shaders/tiling_noise.glsl``, constants filled)."""
    h, w, c = model.example.shape
    if max(h, w) > MAX_TEXTURE_SIZE:
        raise TextonError(f"the example ({w} x {h} texels) is too large for glsl: WebGL2 guarantees "
                          f"{MAX_TEXTURE_SIZE} texels a side; analyze a smaller example", param="texton")
    consts = [
        ("const uint", "TL_SEED", f"{seed}u"),
        ("const int", "TL_CHANNELS", str(c)),
        ("const int", "TL_ROWS", str(h)),
        ("const int", "TL_COLS", str(w)),
        ("const int", "TL_MARGIN", str(model.margin)),
        ("const float", "TL_SIDE", _f(model.side)),
        ("const int", "TL_SQUARINGS", str(int(model.sharpness).bit_length() - 1)),
        ("const float", "TL_GUIDE_WEIGHT", _f(model.guide_weight)),
        ("const bool", "TL_VARIANCE_PRESERVING", "true" if model.blend == "variance" else "false"),
        ("const vec3", "TL_MEAN", f"vec3({', '.join(_f(v) for v in model.mean3)})"),
        *colour_constants(model),
    ]
    header = (f"// Generated by warp-texton {__version__}: tiling model, example {w} x {h}, {c} channel(s), side "
              f"{model.side:g}, sharpness {model.sharpness}, guide weight {model.guide_weight:g}, blend "
              f"{model.blend}, seed {seed}")
    block = "\n".join(f"{t} {name} = {value};" for t, name, value in consts)
    return (_source(GLSL_FILE).replace("//@CONSTANTS@", header + "\n" + block)
            .replace("//@TILING_DRAW@", tiling_draw.draw_code("glsl")))


def _settings(model: TilingModel, seed: int) -> dict:
    h, w, c = model.example.shape
    return {"method": "tiling", "seed": seed, "side": float(model.side), "sharpness": int(model.sharpness),
            "guide_weight": float(model.guide_weight), "blend": model.blend, "channels": c,
            "example": [w, h], "margin": model.margin}


def tiling_glsl_files(model: TilingModel, seed: int = 0) -> dict[str, bytes]:
    """The files of a GLSL export of a tiling model, name -> content: the library
    (tiling_noise.glsl), the JavaScript (texton_noise.js), the example texture as raw
    little-endian float32 RGBA (tiling_example.f32, rows top first), their description
    (texton_noise.json) and a preview page of a 512 × 512 window at scale 1 (preview.html)."""
    model = check_model(model)
    seed = check_seed(seed)
    source = glsl_source(model, seed)
    tex = textures(model)
    files = {GLSL_FILE: source.encode(), JS_FILE: _source(JS_FILE).encode()}
    described = {}
    for name, a in tex.items():
        files[f"{name}.f32"] = np.ascontiguousarray(a, "<f4").tobytes()
        described[name] = {"file": f"{name}.f32", "width": a.shape[1], "height": a.shape[0], "format": "RGBA32F"}
    meta = {"warp_texton": __version__, "language": "glsl", "library": GLSL_FILE, "script": JS_FILE,
            "textures": described, "settings": _settings(model, seed)}
    files[META_FILE] = (json.dumps(meta, indent=2) + "\n").encode()
    files[PREVIEW_FILE] = _preview(model, seed, source, tex, (512, 512), 1.0, 0.0, (0.0, 0.0)).encode()
    return files


#: The preview's (and the viewer's WebGL2 mode's) main(): pixel (i, j) of a w × h window (top row
#: first) at tn_centre + tn_step_x (j + ½ − w/2) + tn_step_y (i + ½ − h/2) from P(tn_anchor).
PREVIEW_MAIN = """
uniform ivec2 tn_anchor;
uniform vec2 tn_frac;
uniform vec2 tn_centre;
uniform vec2 tn_step_x;
uniform vec2 tn_step_y;
uniform int tn_width;
uniform int tn_height;
out vec4 tn_colour;
void main() {
  int j = int(gl_FragCoord.x);
  int i = tn_height - 1 - int(gl_FragCoord.y);
  // the pixel's centre relative to the window's centre (exact halves), then to P(anchor)
  float dj = float(j) + 0.5 - 0.5 * float(tn_width);
  float di = float(i) + 0.5 - 0.5 * float(tn_height);
  vec3 v = tiling_noise_at(tn_anchor, tn_frac, tn_centre + tn_step_x * dj + tn_step_y * di);
  if (TL_CHANNELS == 1) v = vec3(v.r);
  tn_colour = vec4(v, 1.0);
}
"""

_PREVIEW_BOOT = """
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
  const w = data.width, h = data.height, at = data.placement;
  function uniforms() {
    bind(prog);
    gl.uniform2i(gl.getUniformLocation(prog, "tn_anchor"), at.anchor[0], at.anchor[1]);
    gl.uniform2f(gl.getUniformLocation(prog, "tn_frac"), at.frac[0], at.frac[1]);
    gl.uniform2f(gl.getUniformLocation(prog, "tn_centre"), at.centre[0], at.centre[1]);
    gl.uniform2f(gl.getUniformLocation(prog, "tn_step_x"), at.step_x[0], at.step_x[1]);
    gl.uniform2f(gl.getUniformLocation(prog, "tn_step_y"), at.step_y[0], at.step_y[1]);
    gl.uniform1i(gl.getUniformLocation(prog, "tn_width"), w);
    gl.uniform1i(gl.getUniformLocation(prog, "tn_height"), h);
  }
  uniforms();
  TextonNoise.draw(gl, prog, w, h);
  status.textContent = data.caption;
  window.textonNoise = {
    width: w, height: h, channels: data.channels,
    // the window's values as float32, RGBA per pixel, top row first
    readFloat: () => Array.from(TextonNoise.readFloat(gl, prog, w, h, uniforms)),
  };
})();
"""


def _placement(model: TilingModel, shape, scale, rotation, offset, anchored: bool = True) -> dict:
    """The window's centre as (anchor, frac, rel) of :func:`tiling_anchor` (float64, then
    float32) and its steps per pixel (float32); not ``anchored``: the anchor (0, 0), so that
    the page computes ``tiling_noise(x)`` with x in float32 from the origin."""
    h, w = shape
    origin, step = raster_geometry(shape, scale, rotation, offset)
    corners = origin[:, None] + step @ np.array([[0, w, 0, w], [0, 0, h, h]], np.float64)
    reach = float(np.abs(corners).max())
    if not reach <= MAX_TILING_REACH:
        raise TextonError(f"the window reaches {reach:.3g} texels from the origin; a tiling model is defined "
                          f"within ±{MAX_TILING_REACH:.3g} texels", param="offset")
    centre = origin + step @ np.array([w / 2, h / 2])
    (a, b), frac, rel = tiling_anchor(model, centre) if anchored else ((0, 0), np.zeros(2), centre)
    f32 = lambda v: [float(np.float32(x)) for x in v]  # noqa: E731
    return {"anchor": [a, b], "frac": f32(frac), "centre": f32(rel), "step_x": f32(step[:, 0]),
            "step_y": f32(step[:, 1])}


def _preview(model, seed, source, tex, shape, scale, rotation, offset, anchored: bool = True) -> str:
    h, w = shape
    caption = (f"tiling model, {w} x {h} pixels: example {model.example.shape[1]} x {model.example.shape[0]}, "
               f"side {model.side:g}, sharpness {model.sharpness}, seed {seed}")
    data = {"library": source, "main": PREVIEW_MAIN, "width": w, "height": h, "channels": model.channels,
            "placement": _placement(model, shape, scale, rotation, offset, anchored), "caption": caption,
            "textures": texture_data(tex)}
    return page_html(f"warp-texton: tiling model ({w} x {h})", w, h, data, _PREVIEW_BOOT)


def tiling_preview_html(model: TilingModel, shape=(512, 512), *, seed: int = 0, scale: float = 1.0,
                        rotation: float = 0.0, offset=(0.0, 0.0), anchored: bool = True) -> str:
    """One self-contained HTML page that draws, with WebGL2 on a canvas ``#noise``, the
    window ``synthesize(model, shape, seed=seed, scale=..., rotation=..., offset=...)`` gives.

    ``anchored=False`` draws it with ``tiling_noise(x)``, x in float32 from the origin (as a
    shader without an anchor, and the OSL port, compute it), to measure what float32 keeps."""
    model = check_model(model)
    h, w = check_shape(shape)
    if max(h, w) > MAX_PREVIEW_SIDE:
        raise TextonError(f"a preview is at most {MAX_PREVIEW_SIDE} pixels a side (the largest render target "
                          f"WebGL2 guarantees), got {w} x {h}", param="shape")
    seed = check_seed(seed)
    source = glsl_source(model, seed)
    return _preview(model, seed, source, textures(model), (h, w), scale, rotation, offset, anchored)


# ---------------------------------------------------------------- OSL


def _osl_float(v) -> str:
    x = float(np.float32(v))
    s = repr(x)
    return s if ("e" in s or "." in s) else s + ".0"


def _i32(v: int) -> int:
    v &= 0xFFFFFFFF
    return v - (1 << 32) if v >= 1 << 31 else v


def tiling_osl_files(model: TilingModel, seed: int = 0, texel_size: float = 0.01) -> dict[str, bytes]:
    """The OSL export of a tiling model: ``{"tiling_plane.osl": source}``, the shader
    ``tiling_plane`` (the model at a texel-space point made from object coordinates or UVs,
    as ``texton_plane``), the example embedded (at most :data:`MAX_OSL_FLOATS` floats)."""
    model = check_model(model)
    seed = check_seed(seed)
    texel_size = check_positive(texel_size, "texel_size")
    h, w, c = model.example.shape
    guide = model.guide_weight != 0.0
    stride = c + int(guide)
    if h * w * stride > MAX_OSL_FLOATS:
        raise TextonError(f"the example ({w} x {h} texels, {stride} value(s) a texel) is too large for an OSL "
                          f"shader: at most {MAX_OSL_FLOATS} floats (a 512 x 512 RGB example); analyze a smaller "
                          "example", param="texton")
    data = model.example.reshape(h * w, c)
    if guide:
        data = np.concatenate([data, model.guide.reshape(h * w, 1)], axis=1)
    flat = np.ascontiguousarray(data, np.float32).ravel()
    lines = [", ".join(_osl_float(v) for v in flat[k:k + 8]) for k in range(0, flat.size, 8)]
    mean = model.mean3
    values = {
        "SEED": str(_i32(seed)), "TEXEL_SIZE": _osl_float(texel_size), "N": str(flat.size),
        "DATA": ",\n        ".join(lines), "ROWS": str(h), "COLS": str(w), "STRIDE": str(stride),
        "CHANNELS": str(c), "MARGIN": str(model.margin), "SIDE": _osl_float(model.side),
        "SQUARINGS": str(int(model.sharpness).bit_length() - 1),
        "GUIDE_WEIGHT": _osl_float(model.guide_weight), "VARIANCE": "1" if model.blend == "variance" else "0",
        "MEAN": f"color({', '.join(_osl_float(v) for v in mean)})", "TILING_DRAW": tiling_draw.draw_code("osl"),
        "TEXEL": "color(T[k], T[k + 1], T[k + 2])" if c == 3 else "color(T[k], 0.0, 0.0)",
        "GUIDE": f"T[k + {c}]" if guide else "0.0",
        "COLOUR": "g" if c == 3 else "color(g[0], g[0], g[0])",
        "MAP": colour_map_code(model),
    }
    header = (f"// Generated by warp-texton {__version__}: tiling model, example {w} x {h}, {c} channel(s), side "
              f"{model.side:g}, sharpness {model.sharpness}, guide weight {model.guide_weight:g}, blend "
              f"{model.blend}\n")
    return {OSL_FILE: (header + Template(_source("tiling_noise.osl")).substitute(values)).encode()}


def tiling_osl_meta(model: TilingModel, seed: int, texel_size) -> bytes:
    """The description of a tiling model's OSL export, marked as the package's."""
    settings = {**_settings(model, seed), "texel_size": 0.01 if texel_size is None else float(texel_size)}
    meta = {"warp_texton": __version__, "language": "osl", "shaders": [OSL_FILE], "channels": model.channels,
            "settings": settings}
    return (json.dumps(meta, indent=2) + "\n").encode()
