"""The viewer's WebGL2 mode: what the page needs to draw the noise itself.

The page (``static/viewer_webgl.js``) draws the view with the exported GLSL
library (the registry's WebGL2 language, :mod:`warp_texton.runtimes.glsl`: the
same source, constants and textures as ``export_shader``), so pan, zoom, rotation
and the noise settings redraw without a request. Only the texton travels: one request per analysis
setting (:func:`shader_payload`).

The exported library holds every setting as a constant; here the ones the
page's controls change are turned into uniforms (:data:`VIEW_UNIFORMS`): the
seed, the values that follow from the MNI (the cell's mean impact count, the
Poisson sampler's constants, λ and √λ) and the filter's mode and level bias.
The page computes them from the MNI as the exporter does in float32
(``runtimes.glsl.texton.poisson_constants``; the viewer's WebGL test compares both),
from the cell size and the texton's support area given here.

A tiling model (``analyze(..., method="tiling")``) is drawn with the same port's
library of it (:mod:`warp_texton.runtimes.glsl.tiling`, the export's library and
textures, a histogram-preserving model's tables included) by
:func:`tiling_payload`: its one view uniform is the seed (``TL_SEED``); the
page places the view's centre on the model's triangle lattice in float64 (as
``tiling_anchor`` does, with the vertex draw's √3/2; for a model with a lattice,
the anchor's position mod its modulus, as ``anchor_mod`` does) and draws the
unfiltered blend, so the filter "none" alone is drawn (the tiles draw the others).
A wrapped or lattice model's library and textures (the lattice-periodic mean) are
the export's too.
"""

from __future__ import annotations

import re

import numpy as np

from ..kernels.tiling_draw import SQRT3_2
from ..noise.filter_options import FilterOptions
from ..noise.engine import CELL_FACTOR, MAX_CELL_MEAN
from ..noise.noise_options import NoiseOptions
from ..runtimes.languages import WEBGL, language
from ..runtimes.shared import check_tiling_model, model_note
from ..model.noise_tables import at_mni
from ..model.texton import Texton
from ..runtimes.glsl.texton import colour_textures
from ..model.tiling import TilingModel

#: The library's constants the page sets as uniforms, with their GLSL types.
VIEW_UNIFORMS = {"TN_SEED": "uint", "TN_MEAN_COUNT": "float", "TN_SQRT_MEAN_COUNT": "float",
                 "TN_EXP_NEG_MEAN": "float", "TN_PTRS": "vec4", "TN_PTRS2": "vec2", "TN_LAM": "float",
                 "TN_SQRT_LAM": "float", "TN_FILTER_MODE": "int", "TN_LOD_BIAS": "float"}

#: The page's main(): pixel (i, j) of the view (top row first) is the noise at
#: tn_base · cell + tn_origin + tn_step_x (j + ½) + tn_step_y (i + ½), as a
#: ``synthesize`` raster places it, filtered for the footprint of the steps.
VIEW_MAIN = """
uniform ivec2 tn_base;
uniform vec2 tn_origin;
uniform vec2 tn_step_x;
uniform vec2 tn_step_y;
uniform int tn_height;
out vec4 tn_colour;
void main() {
  int j = int(gl_FragCoord.x);
  int i = tn_height - 1 - int(gl_FragCoord.y);
  vec2 rel = tn_origin + tn_step_x * (float(j) + 0.5) + tn_step_y * (float(i) + 0.5);
  vec3 v = texton_noise_filtered_at(tn_base, rel, tn_step_x, tn_step_y);
  if (TN_CHANNELS == 1) v = vec3(v.r);
  tn_colour = vec4(v, 1.0);
}
"""


def with_uniforms(source: str, names=VIEW_UNIFORMS) -> str:
    """``source`` with the constants ``names`` declared as uniforms instead."""
    for name, kind in names.items():
        source, n = re.subn(rf"^const {kind} {name} = [^;\n]*;$", f"uniform {kind} {name};", source, flags=re.M)
        if n != 1:
            raise ValueError(f"the GLSL library declares {name} {n} times as a const {kind}")
    return source


def shader_payload(texton: Texton, *, filters, cell_factor: float = CELL_FACTOR, mni: float | None = None) -> dict:
    """The page's WebGL2 program for ``texton``: the library with :data:`VIEW_UNIFORMS`,
    its main, the textures (base64 float32) and what the uniforms are computed from.

    ``filters`` are the names the page offers, each with its mode and level bias.
    The unperiodic plane and exact Poisson counts, as the viewer's tiles. ``mni``: the view's,
    whose histogram tables the colour texture holds (``noise_tables.at_mni``; None: the fitted
    ones); the page asks again when its MNI changes.
    """
    glsl = language(WEBGL).port()
    # the MNI only sets constants that become uniforms: one that every texton's cells accept
    g = glsl.library(texton, filter="anisotropic", noise=NoiseOptions(mni=1.0, cell_factor=cell_factor))
    if texton.histogram is not None:  # the tables of the view's MNI, not of the placeholder 1
        g.textures.update(colour_textures(texton if mni is None else at_mni(texton, mni)))
    cw, ch = g.cell
    options = {name: FilterOptions.of(name) for name in filters}
    return {
        "library": with_uniforms(g.source),
        "main": VIEW_MAIN,
        "textures": glsl.texture_data(g.textures),
        "channels": g.channels,
        # λ = mni / area (float64), a cell's mean count λ · cw · ch: noise_setup's arithmetic
        "area": float(texton.support_area),
        "cell": [cw, ch],
        "max_mean_count": MAX_CELL_MEAN,  # more is refused (noise_setup): the page shows tiles, which say why
        "filters": {name: {"mode": glsl.FILTER_MODES[o.kind],
                           "bias": float(np.float32(o.bias if o.spec.footprint else 0.0))}
                    for name, o in options.items()},
        "texton": f"{texton.size[1]}×{texton.size[0]}, order {texton.order}",
        "histogram": texton.histogram is not None,  # its tables depend on the MNI: asked for again per MNI
    }


#: The uniforms of a tiling model's library in the viewer: the seed.
TILING_UNIFORMS = {"TL_SEED": "uint"}


def tiling_payload(model: TilingModel) -> dict:
    """The page's WebGL2 program for a tiling model: its GLSL library (the export's, the
    seed a uniform), the preview's main, the textures (the example and guide, a
    histogram-preserving model's tables, a lattice model's lattice-periodic mean), and what the page places
    the view with: the lattice side (float32, as the kernels hold it), √3/2 (the vertex draw's) and the
    example lattice's modulus (1 without one). Its one filter is "none"."""
    model = check_tiling_model(model)
    glsl = language(WEBGL).port()
    lib = glsl.library(model)
    h, w, c = model.example.shape
    return {
        "kind": "tiling",
        "library": with_uniforms(lib.source, TILING_UNIFORMS),
        "main": lib.main,
        "textures": glsl.texture_data(lib.textures),
        "channels": lib.channels,
        "side": float(np.float32(model.side)),
        "sqrt3_2": float(SQRT3_2),
        "modulus": 1 if model.lattice is None else int(model.lattice.modulus),
        "filters": {"none": {"mode": 0, "bias": 0.0}},
        "refused": "the WebGL2 mode draws a tiling model unfiltered (filter none)",
        "texton": f"tiling model of a {w}×{h} example, side {model.side:g}"
                  + (", histogram preserved" if model.histogram is not None else "") + model_note(model),
    }
