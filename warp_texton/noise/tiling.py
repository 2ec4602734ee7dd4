"""Tiling and blending on rasters and points: the drivers of the tiling kernels.

The model, its files and its measures live in :mod:`warp_texton.model.tiling` (NumPy only);
this module packs a :class:`~warp_texton.model.tiling.TilingModel` into the kernels' struct and
launches them (docs/tiling.md).

Kernels driven here: ``warp_texton.kernels.noise_tiling``.
"""

from __future__ import annotations

import math
import weakref

import numpy as np

from ..core.runtime import init_warp, is_cpu, resolve_device, split_launch
from ..kernels import noise_tiling
from ..model.tiling import TilingModel

#: The device arrays of each model, per device (models are immutable).
_ARRAYS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def tiling_struct(model: TilingModel, seed: int, device: str):
    """The kernels' ``Tiling`` struct of a model and a seed, its arrays on ``device``."""
    wp = init_warp()
    per_device = _ARRAYS.setdefault(model, {})
    if device not in per_device:
        ex = model.example
        rgb = ex if ex.shape[2] == 3 else np.concatenate([ex, np.zeros(ex.shape[:2] + (2,), np.float32)], axis=2)
        guide = model.guide if model.guide_weight != 0.0 else np.zeros((1, 1), np.float32)
        grey = wp.array(np.ascontiguousarray(ex[..., 0]), dtype=float, device=device) if ex.shape[2] == 1 else None
        per_device[device] = (wp.array(np.ascontiguousarray(rgb), dtype=wp.vec3, device=device),
                              wp.array(guide, dtype=float, device=device), grey)
    t = noise_tiling.Tiling()
    t.example, t.guide = per_device[device][:2]
    t.side = float(model.side)
    t.margin = int(model.margin)
    t.squarings = int(model.sharpness).bit_length() - 1
    t.guide_weight = float(model.guide_weight)
    t.variance_preserving = int(model.blend == "variance")
    t.mean = wp.vec3(*model.mean3.tolist())
    t.seed = wp.uint32(seed & 0xFFFFFFFF)
    return t


def skip_below(model: TilingModel) -> float:
    """The barycentric weight below which ``tiling_runs`` drops a vertex without raising it to the
    sharpness: 0.3 · CUTOFF^(1/sharpness), where w^sharpness is below CUTOFF × the largest weight's
    (≥ (1/3)^sharpness) with a 10 % margin, so the reference drops it too; 0 with a guide."""
    if model.guide_weight != 0.0:
        return 0.0
    return float(np.float32(0.3 * float(noise_tiling.CUTOFF) ** (1.0 / model.sharpness)))


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


def _lanes(model: TilingModel, t, device):
    """(example array, mean, texel type) of the kernels' one-lane (grey) or three-lane path."""
    wp = init_warp()
    grey = _ARRAYS[model][device][2]
    if grey is not None:
        return grey, float(model.mean3[0]), float
    return t.example, t.mean, wp.vec3


#: Pixels per thread of ``tiling_runs`` (one vertex cache per run).
RUN_CPU = 64
RUN_CUDA = 4


def tiling_pixels(model: TilingModel, shape, origin, step, first, seed: int, device, period=None) -> np.ndarray:
    """The (H, W, C) float32 raster whose pixel (i, j) is the model at
    origin + step · (first[1] + j + ½, first[0] + i + ½) (``raster_geometry``'s layout),
    periodic with ``period`` = (Px, Py) when given."""
    wp = init_warp()
    device = resolve_device(device)
    h, w = shape
    t = tiling_struct(model, seed, device)
    lat = lattice_struct(model, period)
    example, mean, dtype = _lanes(model, t, device)
    lanes = 1 if dtype is float else 3
    host = np.empty((h, w, lanes), np.float32) if is_cpu(device) else None
    out = wp.array(host[..., 0] if lanes == 1 else host, dtype=dtype, copy=False) if host is not None \
        else wp.empty((h, w), dtype=dtype, device=device)
    o = wp.vec2d(float(origin[0]), float(origin[1]))
    sx = wp.vec2d(float(step[0, 0]), float(step[1, 0]))
    sy = wp.vec2d(float(step[0, 1]), float(step[1, 1]))
    run = RUN_CPU if is_cpu(device) else RUN_CUDA
    skip = skip_below(model)

    def launch(r0, r1):
        if r1 > r0:
            at = wp.vec2i(int(first[0]) + r0, int(first[1]))
            wp.launch(noise_tiling.tiling_runs, dim=(r1 - r0, -(-w // run)),
                      inputs=[t, lat, example, mean, skip, o, sx, sy, at, run, out[r0:r1]], device=device)

    split_launch(device, noise_tiling, h, launch)
    if host is not None:
        return host
    values = out.numpy()
    return values[..., None] if lanes == 1 else values


def tiling_at(model: TilingModel, points: np.ndarray, seed: int, device, period=None) -> np.ndarray:
    """The (N, C) float32 values of the model at points (N, 2) (x, y), float64; periodic with
    ``period`` = (Px, Py) when given."""
    wp = init_warp()
    device = resolve_device(device)
    n = points.shape[0]
    t = tiling_struct(model, seed, device)
    pts = wp.array(np.ascontiguousarray(points, np.float64), dtype=wp.vec2d, device=device)
    out = wp.empty(n, dtype=wp.vec3, device=device)
    lat = lattice_struct(model, period)

    def launch(k0, k1):
        if period is None:  # the reference, tiling_value
            wp.launch(noise_tiling.tiling_points, dim=k1 - k0, inputs=[t, pts[k0:k1], out[k0:k1]], device=device)
        else:
            wp.launch(noise_tiling.lattice_points, dim=k1 - k0,
                      inputs=[t, lat, t.example, t.mean, skip_below(model), pts[k0:k1], out[k0:k1]], device=device)

    split_launch(device, noise_tiling, n, launch)
    return np.ascontiguousarray(out.numpy()[:, :model.channels]) if n else np.zeros((0, model.channels), np.float32)
