"""Texton noise as GLSL: the exported shader library, its textures and its HTML preview.

The GLSL source (``shaders/texton_noise.glsl``, package data) is one template:
this module writes its constants block from the host code the Warp kernels
take their parameters from (``noise.noise_setup`` and ``noise.params_record``
for the plane, ``surface.surface_setup`` and ``surface.surface_params`` for
surfaces, ``filtering.pyramid_stack`` for the filters, ``colours`` for a
histogram transform), so the shader's constants are the kernels' float32 values. Floats are written with nine
significant digits, which a GLSL compiler reads back to the same float32.

The texton travels as RGBA32F textures read with ``texelFetch`` (exact values,
no filtering by the GPU): ``texton_coeffs``, the coefficients with the
kernels' zero margin, and ``texton_pyramid``, the MIP levels stacked in rows as
the kernels' ``Pyramid`` holds them. A GL mip chain is not used: GL halves odd
sides down, the package's pyramid pads them up (block means of zero-padded
2 × 2 blocks), and its levels carry the same zero margin as level 0.

Beside the plane noise the library has its exact gradient, ``texton_noise_grad(_at)``
(``kernels/noise_gradient.py``'s ``texton_slope`` over the same impacts); :func:`gradient_window`
is what a page draws a window's derivatives with (:data:`GRADIENT_MAIN`).

A texton with a histogram transform adds ``texton_colours`` (its inverse-CDF
tables, one row per variance share) and ``texton_shares`` (its footprint
shares), which the library's ``texton_noise*`` functions use to return the
example's colours (:func:`colour_textures`).

The JavaScript that builds programs and uploads the textures
(``shaders/texton_noise.js``) and the preview page are the GLSL port's, shared
with tiling models (:mod:`warp_texton.runtimes.glsl.page`). Derivations and the
measured agreement: docs/renderers.md.

Kernels driven here: ``warp_texton.kernels.noise_raster``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...model.noise_tables import at_mni
from ...core.checks import check_shape
from ..._version import __version__
from ...core.errors import TextonError
from ...noise.filter_options import FilterOptions
from ...noise.filtering import pyramid_stack
from ...noise.colours import ANGLES, LOG_EXTENTS, noise_moments, share_table
from ...model.histogram import GAUSS_RANGE, SHARE_STEPS
from ...kernels.noise_raster import PAD
from ...noise.engine import CELL_FACTOR, noise_setup, params_record
from ...noise.noise_options import NoiseOptions
from ...noise.raster import raster_geometry, raster_reach
from ...surface.frames import UP
from ...surface.points import surface_params, surface_setup
from ...model.texton import Texton
from ..shared import template
from .page import (JS_FILE, MAX_PREVIEW_SIDE, MAX_TEXTURE_SIZE, META_FILE, PREVIEW_FILE, export_files, glsl_float,
                   preview_page, texture_data)

#: The orders the GLSL reproduces (all of the package's).
ORDERS = (0, 1, 3, 5)
#: The filters its filtered variant offers; "supersample" (hundreds of walks a pixel) is left out.
FILTERS = ("none", "mip", "anisotropic")
#: The library of an export (beside the page's files: the JavaScript, the description, the preview).
GLSL_FILE = "texton_noise.glsl"
#: Every file a texton's GLSL export may write (the textures of a histogram transform included).
FILES = frozenset({GLSL_FILE, JS_FILE, META_FILE, PREVIEW_FILE, "texton_coeffs.f32", "texton_pyramid.f32",
                   "texton_colours.f32", "texton_shares.f32"})
#: TN_FILTER_MODE of each filter.
FILTER_MODES = {"none": 0, "mip": 1, "anisotropic": 2}
_f = glsl_float


def _vec(values) -> str:
    vals = [_f(v) for v in values]
    return f"vec{len(vals)}({', '.join(vals)})"


def _f32(fn, x) -> float:
    # exp and log rounded once from float64, as the C library's expf and logf round (the
    # functions Warp's CPU kernels call); NumPy's float32 exp and log may be 1 ulp away
    with np.errstate(all="ignore"):
        return float(np.float32(fn(np.float64(x))))


def poisson_constants(mean: float) -> tuple[float, float, tuple[float, ...], tuple[float, ...]]:
    """(e^−mean, √mean, (b, a, log(1/α), v_r), (log mean, 0)): what ``wp.poisson`` computes from its
    mean before drawing, in float32 with the operations of Warp's rand.h, for a cell's mean count;
    below a mean of 10, where ``wp.poisson`` multiplies uniforms, the PTRS values are 0."""
    f = np.float32
    lam = f(mean)
    with np.errstate(all="ignore"):
        slam = np.sqrt(lam)
        b = f(0.931) + f(2.53) * slam
        a = f(-0.059) + f(0.02483) * b
        invalpha = f(1.1239) + f(1.1328) / (b - f(3.4))
        vr = f(0.9277) - f(3.6224) / (b - f(2.0))
    if not lam >= 10.0:  # the multiplication of uniforms draws: the PTRS constants are unused (and may be NaN)
        return _f32(np.exp, -lam), float(slam), (0.0, 0.0, 0.0, 0.0), (0.0, 0.0)
    ptrs = (float(b), float(a), _f32(np.log, invalpha), float(vr))
    return _f32(np.exp, -lam), float(slam), ptrs, (_f32(np.log, lam), 0.0)


@dataclass(frozen=True)
class GlslNoise:
    """The exported library of one noise: its source and its textures."""

    source: str
    textures: dict  # name -> float32 array (H, W, 4)
    settings: dict  # what the constants were made from, for texton_noise.json
    cell: tuple[float, float]  # the plane's cell size, texels (float32 values)
    channels: int


def _rgba(a: np.ndarray) -> np.ndarray:
    out = np.zeros(a.shape[:2] + (4,), np.float32)
    out[..., :3] = a
    return out


def check_texture_sizes(textures: dict, limit: int = MAX_TEXTURE_SIZE, target: str = "glsl") -> None:
    """Refuse textures with a side over ``limit`` texels."""
    for name, a in textures.items():
        h, w = a.shape[:2]
        if max(h, w) > limit:
            raise TextonError(
                f"the texton is too large for {target}: its {name} texture would be {w} x {h} texels, and WebGL2 "
                f"guarantees {limit} per side (the MIP levels stack to about twice the texton's height plus "
                f"{2 * PAD} texels a level); use a texton of at most about {limit // 2 - 8 * PAD} texels a side",
                param="texton")


def colour_textures(texton: Texton) -> dict:
    """The histogram transform's textures (none without one): ``texton_colours``, row s
    the inverse-CDF tables prefiltered for the share s / (S − 1), channels in RGB;
    ``texton_shares``, the footprint shares (row: major extent; column: minor extent ·
    ANGLES + angle) in R."""
    if texton.histogram is None:
        return {}
    tables = np.transpose(texton.histogram.prefiltered, (0, 2, 1))  # (S, K, C)
    shares = share_table(texton)
    e = shares.shape[0]
    return {"texton_colours": _rgba(tables), "texton_shares": _rgba(shares.reshape(e, -1)[..., None])}


def colour_constants(texton: Texton) -> list:
    """The histogram transform's constants (kernels/noise_colours.py ``ColourMap``); pass-through
    values without one."""
    tr = texton.histogram
    c = texton.channels
    matrix, centre = np.eye(3), np.zeros(3)
    if tr is not None:
        matrix[:c, :c] = tr.matrix
        centre[:c] = tr.centre
    std = np.ones(3)
    std[:c] = noise_moments(texton)[1]
    return [
        ("const bool", "TN_HISTOGRAM", "true" if tr is not None else "false"),
        ("const vec3", "TN_NOISE_STD", _vec(std)),
        ("const mat3", "TN_COLOUR_MATRIX", f"mat3({', '.join(_f(v) for v in matrix.ravel(order='F'))})"),
        ("const vec3", "TN_COLOUR_CENTRE", _vec(centre)),
        ("const float", "TN_GAUSS_RANGE", _f(GAUSS_RANGE)),
        ("const int", "TN_LUT_SIZE", str(tr.lut.shape[1] if tr is not None else 2)),
        ("const int", "TN_SHARE_STEPS", str(SHARE_STEPS)),
        ("const int", "TN_EXTENTS", str(len(LOG_EXTENTS))),
        ("const int", "TN_ANGLES", str(ANGLES)),
        ("const float", "TN_LOG_FIRST", _f(LOG_EXTENTS[0])),
        ("const float", "TN_LOG_STEP", _f(LOG_EXTENTS[1] - LOG_EXTENTS[0])),
    ]


def glsl_noise(texton: Texton, *, mni: float = 30.0, seed: int = 0, period=None, cell_factor: float = CELL_FACTOR,
               poisson: str = "exact", filter="anisotropic", surface_mni: float | None = None, up=UP,
               side=None, noise: NoiseOptions | None = None) -> GlslNoise:
    """The GLSL library of a noise, with its constants from the kernels' host code (see the module).

    ``noise`` (a :class:`~warp_texton.NoiseOptions`) may stand for ``mni``, ``seed``,
    ``period``, ``poisson`` and ``cell_factor``."""
    if not isinstance(texton, Texton):
        raise TextonError(f"texton must be a Texton, got {type(texton).__name__}", param="texton")
    if texton.order not in ORDERS:
        raise TextonError(f"order {texton.order} is not available in glsl; accepted: {', '.join(map(str, ORDERS))}",
                          param="texton")
    options = FilterOptions.of(filter)
    if options.kind not in FILTERS:
        raise TextonError(f"filter {options.kind!r} is not available in glsl; accepted: {', '.join(FILTERS)}",
                          param="filter")
    noise = NoiseOptions.given(noise, mni=mni, seed=seed, period=period, poisson=poisson, cell_factor=cell_factor)
    mni, seed, period, poisson, cell_factor = noise.mni, noise.seed, noise.period, noise.poisson, noise.cell_factor
    setup = noise_setup(texton, mni, period, cell_factor)
    texton = at_mni(texton, mni)  # the histogram tables of this MNI's noise
    rec = params_record(texton, setup, seed, poisson)
    pyr = pyramid_stack(texton, options.fade_energy)
    textures = {"texton_coeffs": _rgba(setup.coeffs), "texton_pyramid": _rgba(pyr.coeffs[:int(pyr.rows[:pyr.levels].sum())])}
    textures.update(colour_textures(texton))
    check_texture_sizes(textures)
    s3 = surface_setup(texton, mni if surface_mni is None else surface_mni, cell_factor)
    sp = surface_params(texton, s3, seed, poisson, up, side)
    cells = rec["cells"]
    consts = [
        *_plane_constants(texton, seed, setup, rec),
        *_filter_constants(options, pyr),
        *_surface_constants(sp),
        *colour_constants(texton),
    ]
    block = "\n".join(f"{t} {name} = {value};" for t, name, value in consts)
    header = (f"// Generated by warp-texton {__version__}: texton {texton.size[1]} x {texton.size[0]}, order "
              f"{texton.order}, {texton.channels} channel(s); mni {setup.mni:g}, seed {seed}, poisson {poisson}, "
              f"cell_factor {cell_factor:g}, period {None if period is None else tuple(period)}, "
              f"filter {options.kind}")
    source = template(GLSL_FILE).replace("//@CONSTANTS@", header + "\n" + block)
    settings = {"mni": setup.mni, "surface_mni": float(mni if surface_mni is None else surface_mni), "seed": seed,
                "period": None if period is None else [float(v) for v in period], "cell_factor": float(cell_factor),
                "poisson": poisson, "filter": options.kind, "order": texton.order, "channels": texton.channels,
                "cell": [float(v) for v in cells["size"]], "cube": float(np.float32(sp.cells.size))}
    return GlslNoise(source, textures, settings, (float(cells["size"][0]), float(cells["size"][1])), texton.channels)


def _plane_constants(texton: Texton, seed: int, setup, rec: np.ndarray) -> list:
    """The plane noise's constants: the kernels' ``NoiseParams`` record (kernels/noise_raster.py)
    and the Poisson sampler's constants of its mean count."""
    cells = rec["cells"]
    mean2, sqrt2, ptrs2, log2_ = poisson_constants(float(cells["mean_count"]))
    lam = np.float32(rec["lam"])
    return [
        ("const int", "TN_PAD", str(PAD)),
        ("const int", "TN_CHANNELS", str(texton.channels)),
        ("const int", "TN_ORDER", str(texton.order)),
        ("const uint", "TN_SEED", f"{seed}u"),
        ("const bool", "TN_EXACT_POISSON", "true" if int(cells["exact_poisson"]) else "false"),
        ("const float", "TN_CELL_W", _f(cells["size"][0])),
        ("const float", "TN_CELL_H", _f(cells["size"][1])),
        ("const int", "TN_PERIOD_X", str(int(cells["period"][0]))),
        ("const int", "TN_PERIOD_Y", str(int(cells["period"][1]))),
        ("const float", "TN_MEAN_COUNT", _f(cells["mean_count"])),
        ("const float", "TN_SQRT_MEAN_COUNT", _f(sqrt2)),
        ("const float", "TN_EXP_NEG_MEAN", _f(mean2)),
        ("const vec4", "TN_PTRS", _vec(ptrs2)),
        ("const vec2", "TN_PTRS2", _vec(log2_)),
        ("const vec2", "TN_LO", _vec(rec["lo"])),
        ("const vec2", "TN_HI", _vec(rec["hi"])),
        ("const float", "TN_LAM", _f(lam)),
        ("const float", "TN_SQRT_LAM", _f(np.sqrt(lam))),
        ("const vec3", "TN_MEAN", _vec(rec["mean"])),
        ("const vec3", "TN_INTEGRAL", _vec(rec["integral"])),
        ("const int", "TN_COEFF_ROWS", str(setup.coeffs.shape[0])),
        ("const int", "TN_COEFF_COLS", str(setup.coeffs.shape[1])),
    ]


def _filter_constants(options: FilterOptions, pyr) -> list:
    """The filters' constants (kernels/noise_filter.py): the mode, its settings and the MIP pyramid's levels."""
    L = pyr.levels
    return [
        ("const int", "TN_FILTER_MODE", str(FILTER_MODES[options.kind])),
        ("const int", "TN_MAX_ANISO", str(options.max_aniso)),
        ("const float", "TN_LOD_BIAS", _f(options.bias if options.spec.footprint else 0.0)),
        ("const int", "TN_LEVELS", str(L)),
        ("const int", "TN_PYRAMID_COLS", str(pyr.coeffs.shape[1])),
        (f"const int[{L}]", "TN_LEVEL_ROW0", f"int[{L}]({', '.join(str(int(v)) for v in pyr.row0[:L])})"),
        (f"const int[{L}]", "TN_LEVEL_ROWS", f"int[{L}]({', '.join(str(int(v)) for v in pyr.rows[:L])})"),
        (f"const float[{L}]", "TN_LEVEL_STEP", f"float[{L}]({', '.join(_f(v) for v in pyr.step[:L])})"),
        (f"const float[{L}]", "TN_LEVEL_ORIGIN", f"float[{L}]({', '.join(_f(v) for v in pyr.origin[:L])})"),
        (f"const vec2[{L}]", "TN_LEVEL_LO", f"vec2[{L}]({', '.join(_vec(v) for v in pyr.lo[:L])})"),
        (f"const vec2[{L}]", "TN_LEVEL_HI", f"vec2[{L}]({', '.join(_vec(v) for v in pyr.hi[:L])})"),
    ]


def _surface_constants(sp) -> list:
    """The surface noise's constants (kernels/surface_points.py ``SurfaceParams``) and the Poisson
    sampler's constants of its mean count per cube."""
    mean3 = float(np.float32(sp.cells.mean_count))
    e3, sqrt3, ptrs3, log3 = poisson_constants(mean3)
    return [
        ("const float", "TN_CUBE", _f(sp.cells.size)),
        ("const float", "TN_MEAN_COUNT3", _f(mean3)),
        ("const float", "TN_SQRT_MEAN_COUNT3", _f(sqrt3)),
        ("const float", "TN_EXP_NEG_MEAN3", _f(e3)),
        ("const vec4", "TN_PTRS3", _vec(ptrs3)),
        ("const vec2", "TN_PTRS3B", _vec(log3)),
        ("const float", "TN_SLAB_HALF", _f(sp.half)),
        ("const vec2", "TN_SLAB_CENTRE", _vec(sp.centre)),
        ("const vec3", "TN_SURFACE_SHIFT", _vec(sp.shift)),
        ("const float", "TN_SURFACE_INV_SCALE", _f(sp.inv_scale)),
        ("const vec3", "TN_FRAME_UP", _vec(sp.up)),
        ("const vec3", "TN_FRAME_SIDE", _vec(sp.side)),
    ]


def glsl_files(texton: Texton, **options) -> dict[str, bytes]:
    """The files of a GLSL export, name -> content: the library (texton_noise.glsl), the
    JavaScript (texton_noise.js), each texture as raw little-endian float32 RGBA
    (NAME.f32, rows top first), their description (texton_noise.json) and a preview page
    of a 512 × 512 window at scale 1 (preview.html). ``options``: those of :func:`glsl_noise`."""
    g = glsl_noise(texton, **options)
    page = _page(g, (512, 512), _placement(g, (512, 512), 1.0, 0.0, (0.0, 0.0)))
    return export_files(GLSL_FILE, g.source, g.textures, g.settings, page)


def _placement(g: GlslNoise, shape, scale, rotation, offset) -> dict:
    """The page's uniforms: pixel (i, j) at tn_base · cell + tn_origin + tn_step_x (j + ½) + tn_step_y (i + ½),
    the window's origin split into an integer cell index and a float32 remainder (computed in float64)."""
    origin, step = raster_geometry(shape, scale, rotation, offset)
    cell = np.array(g.cell)
    base = np.floor(origin / cell)
    rel = origin - base * cell
    f32 = lambda v: [float(np.float32(x)) for x in v]  # noqa: E731
    return {"tn_base": ["2i", [int(v) for v in base]], "tn_origin": ["2f", f32(rel)],
            "tn_step_x": ["2f", f32(step[:, 0])], "tn_step_y": ["2f", f32(step[:, 1])],
            "tn_height": ["1i", [int(shape[0])]]}


#: The preview's main(): tn_output 0 draws the noise, 1 the impacts per pixel (count, Σ d).
PREVIEW_MAIN = """
uniform ivec2 tn_base;
uniform vec2 tn_origin;
uniform vec2 tn_step_x;
uniform vec2 tn_step_y;
uniform int tn_height;
uniform int tn_output;  // 0: the noise, 1: (impact count, Σ d) per pixel
out vec4 tn_colour;
void main() {
  int j = int(gl_FragCoord.x);
  int i = tn_height - 1 - int(gl_FragCoord.y);
  vec2 rel = tn_origin + tn_step_x * (float(j) + 0.5) + tn_step_y * (float(i) + 0.5);
  vec3 v = tn_output == 1 ? texton_impacts_at(tn_base, rel) : texton_noise_at(tn_base, rel);
  if (TN_CHANNELS == 1 && tn_output == 0) v = vec3(v.r);
  tn_colour = vec4(v, 1.0);
}
"""


def _page(g: GlslNoise, shape, uniforms: dict) -> str:
    h, w = shape
    s = g.settings
    caption = (f"texton noise, {w} x {h} pixels: mni {s['mni']:g}, seed {s['seed']}, order {s['order']}"
               + (f", period {s['period'][0]:g} x {s['period'][1]:g}" if s["period"] else ""))
    return preview_page(f"warp-texton: texton noise ({w} x {h})", caption, shape, g.source, PREVIEW_MAIN,
                        g.textures, g.channels, uniforms, impacts=True)


def preview_html(texton: Texton, shape=(512, 512), *, mni: float = 30.0, seed: int = 0, scale: float = 1.0,
                 rotation: float = 0.0, offset=(0.0, 0.0), period=None, poisson: str = "exact",
                 cell_factor: float = CELL_FACTOR, filter="anisotropic", noise: NoiseOptions | None = None) -> str:
    """One self-contained HTML page that draws the window ``synthesize`` gives with the
    same arguments, with WebGL2 on a canvas ``#noise`` (see the module)."""
    h, w = check_shape(shape)
    if max(h, w) > MAX_PREVIEW_SIDE:
        raise TextonError(f"a preview is at most {MAX_PREVIEW_SIDE} pixels a side (the largest render target "
                          f"WebGL2 guarantees), got {w} x {h}", param="shape")
    noise = NoiseOptions.given(noise, mni=mni, seed=seed, period=period, poisson=poisson, cell_factor=cell_factor)
    g = glsl_noise(texton, filter=filter, noise=noise)
    setup = noise_setup(texton, noise.mni, noise.period, noise.cell_factor)
    origin, step = raster_geometry((h, w), scale, rotation, offset)
    raster_reach(origin, step, (h, w), setup)  # what synthesize refuses, refused here
    if not all(math.isfinite(v) for v in origin):
        raise TextonError("offset must be finite", param="offset")
    return _page(g, (h, w), _placement(g, (h, w), scale, rotation, offset))


#: A main() that draws a window's derivatives with the library's gradient (``texton_noise_grad_at``):
#: ``tn_output`` 0 the derivatives per pixel along the columns, 1 along the rows (the texel gradient
#: times the raster's steps, as ``gradient(texton, shape=...)`` gives them), 2 the value beside them.
GRADIENT_MAIN = """
uniform ivec2 tn_base;
uniform vec2 tn_origin;
uniform vec2 tn_step_x;
uniform vec2 tn_step_y;
uniform int tn_height;
uniform int tn_output;  // 0: d/dcolumn, 1: d/drow, 2: the value
out vec4 tn_colour;
void main() {
  int j = int(gl_FragCoord.x);
  int i = tn_height - 1 - int(gl_FragCoord.y);
  vec2 rel = tn_origin + tn_step_x * (float(j) + 0.5) + tn_step_y * (float(i) + 0.5);
  vec3 dx, dy;
  vec3 v = texton_noise_grad_at(tn_base, rel, dx, dy);
  if (tn_output == 0) v = dx * tn_step_x.x + dy * tn_step_x.y;
  else if (tn_output == 1) v = dx * tn_step_y.x + dy * tn_step_y.y;
  tn_colour = vec4(v, 1.0);
}
"""


def gradient_window(texton: Texton, shape, *, scale: float = 1.0, rotation: float = 0.0, offset=(0.0, 0.0),
                    noise: NoiseOptions | None = None) -> dict:
    """What a WebGL2 page needs to draw the derivatives of ``synthesize(texton, shape, ...)``'s window
    with the library's ``texton_noise_grad_at`` (:data:`GRADIENT_MAIN`), as a preview page's data
    holds it: ``library``, ``main``, ``textures`` (``texture_data``), ``uniforms`` (the window's
    placement), ``width``, ``height``, ``channels``. Draw it with ``TextonNoise.program`` and set
    ``tn_output`` (0: ∂/∂column, 1: ∂/∂row, 2: the value)."""
    h, w = check_shape(shape)
    if max(h, w) > MAX_PREVIEW_SIDE:
        raise TextonError(f"a window is at most {MAX_PREVIEW_SIDE} pixels a side (the largest render target "
                          f"WebGL2 guarantees), got {w} x {h}", param="shape")
    noise = NoiseOptions() if noise is None else NoiseOptions.given(noise)
    g = glsl_noise(texton, noise=noise)
    setup = noise_setup(texton, noise.mni, noise.period, noise.cell_factor)
    origin, step = raster_geometry((h, w), scale, rotation, offset)
    raster_reach(origin, step, (h, w), setup)
    return {"library": g.source, "main": GRADIENT_MAIN, "textures": texture_data(g.textures),
            "uniforms": _placement(g, (h, w), scale, rotation, offset), "width": w, "height": h,
            "channels": g.channels}
