"""Tiling and blending on rasters and points: the drivers of the tiling kernels.

The model and its files live in :mod:`warp_texton.model.tiling`, its measures in :mod:`warp_texton.model.structure` (NumPy only);
this module packs a :class:`~warp_texton.model.tiling.TilingModel` into the kernels' struct and
launches them (docs/tiling.md).

Filtered tilings (mip, anisotropic, supersample) are :mod:`warp_texton.noise.tiling_filtering`'s.

Kernels driven here: ``warp_texton.kernels.noise_tiling`` (its vertex draw: ``warp_texton.kernels.tiling_draw``).
"""

from __future__ import annotations

import math
import numbers
import weakref

import numpy as np

from ..core.runtime import CHUNKS_PER_THREAD, init_warp, is_cpu, resolve_device, split_launch, vector_form
from ..kernels import noise_tiling, tiling_draw
from ..core.errors import TextonError
from ..model.tiling import TilingModel
from .colours import to_colours

#: Tiling models place points with float64 lattice indices in int32: positions stay within ±2³⁰ texels.
MAX_TILING_REACH = float(1 << 30)


def texton_options_given(options: dict) -> list[str]:
    """The names of ``options`` (name=(value, default)) given other values than their defaults: what a
    tiling model refuses (a bool is never a number's default, a default of None takes only None)."""
    def same(value, default):
        if value is default:
            return True
        if isinstance(value, bool) or isinstance(default, bool) or default is None:
            return False
        return isinstance(value, (str, numbers.Real)) and type(value) is not bool and value == default

    return [name for name, (value, default) in options.items() if not same(value, default)]


def refuse_texton_options(options: dict) -> None:
    """One error naming the texton-noise options given to a tiling model in the plane."""
    given = texton_options_given(options)
    if given:
        raise TextonError(f"{', '.join(given)} do not apply to a tiling model (method 'tiling'); "
                          "they are texton-noise options", param=given[0])


#: The device arrays of each model, per device (models are immutable).
_ARRAYS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def tiling_struct(model: TilingModel, seed: int, device: str):
    """The kernels' ``Tiling`` struct of a model and a seed, its arrays on ``device``."""
    wp = init_warp()
    per_device = _ARRAYS.setdefault(model, {})
    if device not in per_device:
        ex = model.example

        def lanes(img):  # (vec3 array, float array or None): the three-lane and the grey one-lane forms
            rgb = img if img.shape[2] == 3 else np.concatenate([img, np.zeros(img.shape[:2] + (2,), np.float32)],
                                                               axis=2)
            grey = wp.array(np.ascontiguousarray(img[..., 0]), dtype=float, device=device) \
                if img.shape[2] == 1 else None
            return wp.array(np.ascontiguousarray(rgb), dtype=wp.vec3, device=device), grey

        guide = model.guide if model.guide_weight != 0.0 else np.zeros((1, 1), np.float32)
        means = model.mean_image if model.lattice is not None else np.zeros((1, 1, ex.shape[2]), np.float32)
        per_device[device] = (*lanes(ex), wp.array(guide, dtype=float, device=device), *lanes(means))
    rgb, _, guide, mean_rgb, _ = per_device[device]
    t = noise_tiling.Tiling()
    t.example, t.guide, t.mean_image = rgb, guide, mean_rgb
    t.side = float(model.side)
    t.margin = int(model.margin)
    (lx, nx), (ly, ny) = model.centre_box
    t.lo, t.count = wp.vec2i(lx, ly), wp.vec2i(nx, ny)
    t.wrap = wp.vec2i(int(model.wrap[0]), int(model.wrap[1]))
    t.rank, t.modulus = 0, 1
    t.k1 = t.k2 = wp.vec2i(0, 0)
    if model.lattice is not None:
        k = model.lattice.dual_matrix
        t.rank, t.modulus = model.lattice.rank, model.lattice.modulus
        t.k1 = wp.vec2i(int(k[0, 1]), int(k[0, 0]))  # (ky, kx) rows → (x, y)
        if model.lattice.rank == 2:
            t.k2 = wp.vec2i(int(k[1, 1]), int(k[1, 0]))
    t.squarings = int(model.sharpness).bit_length() - 1
    t.guide_weight = float(model.guide_weight)
    t.variance_preserving = int(model.blend == "variance")
    t.mean = wp.vec3(*model.mean3.tolist())
    t.seed = wp.uint32(seed & 0xFFFFFFFF)
    return t


def tiling_colours(model: TilingModel, values: np.ndarray) -> None:
    """Map a tiling model's blended values (..., lanes ≥ C) float32, in place, through its histogram
    tables (a histogram-preserving model), exactly as texton noise maps its noise
    (:func:`~warp_texton.noise.colours.to_colours`); nothing for a model without tables.
    Every unfiltered output of a tiling model passes its values through here once, after the blend."""
    if model.histogram is not None:
        flat = values.reshape(-1, values.shape[-1])
        to_colours(flat, model)
        if not np.shares_memory(flat, values):  # a copy (a strided view): write it back
            values[...] = flat.reshape(values.shape)


def refuse_filtered_tables(model: TilingModel) -> None:
    """A histogram-preserving tiling model has no prefiltered tables yet: "mip" and "anisotropic"
    footprints are refused for it (one error); "supersample" maps each sample and is exact."""
    if model.histogram is not None:
        raise TextonError("filters 'mip' and 'anisotropic' do not apply to a histogram-preserving tiling model "
                          "(its tables are not prefiltered); use filter='supersample', or a model analysed "
                          "without histogram='preserve'", param="filter")


def skip_below(model: TilingModel) -> float:
    """The barycentric weight below which ``tiling_runs`` drops a vertex without raising it to the
    sharpness: 0.3 · CUTOFF^(1/sharpness), where w^sharpness is below CUTOFF × the largest weight's
    (≥ (1/3)^sharpness) with a 10 % margin, so the reference drops it too; 0 with a guide."""
    if model.guide_weight != 0.0:
        return 0.0
    return float(np.float32(0.3 * float(tiling_draw.CUTOFF) ** (1.0 / model.sharpness)))


def period_lattice(model: TilingModel, period) -> tuple[int, int]:
    """(cols, rows): the vertices per period of a periodic tiling's lattice, for ``period`` = (Px, Py).

    cols = ⌈Px / side⌉ and rows = 2 ⌈Py / (side √3)⌉ (even, so that a row period shifts the skewed
    lattice by whole vertices): the triangles shrink to fit a whole number per period, by at most one
    part in cols across and in rows/2 down, so that every point stays within ``side`` of its vertices
    (docs/tiling.md, "Periodic tiles")."""
    px, py = period
    cols = max(1, math.ceil(px / model.side))
    rows = 2 * max(1, math.ceil(py / (model.side * math.sqrt(3.0))))
    return cols, rows


def lattice_struct(model: TilingModel, period):
    """The kernels' ``Lattice``: the plain one for ``period`` None, else the periodic one of (Px, Py)."""
    wp = init_warp()
    lat = noise_tiling.Lattice()
    lat.periodic = 0
    lat.cols, lat.rows = 1, 2
    lat.dx = lat.dy = lat.px = lat.py = wp.float64(1.0)
    if period is not None:
        cols, rows = period_lattice(model, period)
        lat.periodic = 1
        lat.cols, lat.rows = cols, rows
        lat.px, lat.py = wp.float64(period[0]), wp.float64(period[1])
        lat.dx, lat.dy = wp.float64(period[0] / cols), wp.float64(period[1] / rows)
    return lat


def _lanes(model: TilingModel, device):
    """(example array, lattice-periodic mean array, mean, texel type) of the kernels' one-lane (grey) or
    three-lane path."""
    wp = init_warp()
    rgb, grey, _, mean_rgb, mean_grey = _ARRAYS[model][device]
    if grey is not None:
        return grey, mean_grey, float(model.mean3[0]), float
    return rgb, mean_rgb, wp.vec3(*model.mean3.tolist()), wp.vec3


#: Pixels per thread of ``tiling_runs`` (one vertex cache per run).
RUN_CPU = 64
RUN_CUDA = 4
#: Whether CPU rasters run the native run loop's vector form (kernels/noise_tiling_native.py) where it was
#: built; False: its plain C++ form. Both give ``tiling_runs``' values bit for bit.
SIMD = True
#: Parts per CPU thread of a native raster (a launch costs about 0.1 ms of Python, the loop about 6-11 ns a pixel).
PARTS_NATIVE = 1


def simd_loops(device="cpu") -> str:
    """The form of the tiling raster's CPU run loop (kernels/noise_tiling_native.py) that runs:
    "avx512", "avx2" or "neon" where its vector form was compiled for that instruction set,
    "scalar" otherwise (other CPUs, CUDA, or :data:`SIMD` off): all give the same values."""
    return vector_form(device, SIMD)


def tiling_pixels(model: TilingModel, shape, origin, step, first, seed: int, device, period=None,
                  output: str = "numpy"):
    """The (H, W, C) float32 raster whose pixel (i, j) is the model at
    origin + step · (first[1] + j + ½, first[0] + i + ½) (``raster_geometry``'s layout),
    periodic with ``period`` = (Px, Py) when given: NumPy, or with ``output="warp"`` on a GPU a
    float32 ``wp.array`` (H, W, C) that never leaves the device."""
    wp = init_warp()
    device = resolve_device(device)
    h, w = shape
    tiling_struct(model, seed, device)  # the model's arrays on the device
    example, mean_img, mean, dtype = _lanes(model, device)
    lanes = 1 if dtype is float else 3
    if is_cpu(device):
        host = np.empty((h, w, lanes), np.float32)
        buf = None
        out = wp.array(host[..., 0] if lanes == 1 else host, dtype=dtype, copy=False, device=device)
    else:
        host = None
        buf = wp.empty((h, w, lanes), dtype=float, device=device)  # the result; the kernels write a view of it
        out = wp.array(ptr=buf.ptr, dtype=dtype, shape=(h, w), device=device)
    o = wp.vec2d(float(origin[0]), float(origin[1]))
    sx = wp.vec2d(float(step[0, 0]), float(step[1, 0]))
    sy = wp.vec2d(float(step[0, 1]), float(step[1, 1]))
    run = RUN_CPU if is_cpu(device) else RUN_CUDA
    skip = skip_below(model)
    native = is_cpu(device) and model.guide_weight == 0.0

    def launch(r0, r1):
        if r1 > r0:
            # each launch packs structs of its own: CPU launches run from several threads at once
            t = tiling_struct(model, seed, device)
            lat = lattice_struct(model, period)
            at = wp.vec2i(int(first[0]) + r0, int(first[1]))
            if native:  # the CPU's native run loop (guide_weight 0)
                wp.launch(noise_tiling.tiling_runs_native, dim=(r1 - r0, -(-w // run)),
                          inputs=[t, lat, example, mean_img, mean, skip, o, sx, sy, at, run, int(SIMD), out[r0:r1]],
                          device=device)
            else:
                wp.launch(noise_tiling.tiling_runs, dim=(r1 - r0, -(-w // run)),
                          inputs=[t, lat, example, mean_img, mean, skip, o, sx, sy, at, run, out[r0:r1]],
                          device=device)

    # the native loop's launches cost more than their rows at small sizes: fewer, longer parts
    split_launch(device, noise_tiling, h, launch, per_thread=PARTS_NATIVE if native else CHUNKS_PER_THREAD)
    if host is not None:
        tiling_colours(model, host)
        return host
    assert buf is not None
    if model.histogram is None:
        return buf if output == "warp" else buf.numpy()
    values = buf.numpy()  # the tables map on the host (to_colours), as texton noise's do
    tiling_colours(model, values)
    return wp.array(values, dtype=float, device=device) if output == "warp" else values


def tiling_at(model: TilingModel, points: np.ndarray, seed: int, device, period=None) -> np.ndarray:
    """The (N, C) float32 values of the model at points (N, 2) (x, y), float64; periodic with
    ``period`` = (Px, Py) when given."""
    wp = init_warp()
    device = resolve_device(device)
    n = points.shape[0]
    pts = wp.array(np.ascontiguousarray(points, np.float64), dtype=wp.vec2d, device=device)
    out = wp.empty(n, dtype=wp.vec3, device=device)

    def launch(k0, k1):
        t = tiling_struct(model, seed, device)  # structs of its own per launch (launched from several threads)
        lat = lattice_struct(model, period)
        if period is None:  # the reference, tiling_value
            wp.launch(noise_tiling.tiling_points, dim=k1 - k0, inputs=[t, pts[k0:k1], out[k0:k1]], device=device)
        else:
            wp.launch(noise_tiling.lattice_points, dim=k1 - k0,
                      inputs=[t, lat, t.example, t.mean_image, t.mean, skip_below(model), pts[k0:k1], out[k0:k1]],
                      device=device)

    split_launch(device, noise_tiling, n, launch)
    if not n:
        return np.zeros((0, model.channels), np.float32)
    values = out.numpy()
    tiling_colours(model, values)
    return np.ascontiguousarray(values[:, :model.channels])
