"""The engine of texton noise in the plane: setup, kernel parameters, rasters, points.

g(x) = m + (Σ_j h(x − x_j) − λ ∫h) / √λ with x_j a Poisson process of
intensity λ = MNI / area(supp h) (CGF eq. (1)-(2), §3.3), generated cell by
cell from hashed seeds (CGF §8; kernels/impacts.py) so that any window, at any
position, on any device, shows the same noise.

Rasters: the impacts of the cells under the raster are drawn once (a count
pass, a prefix sum, an emit pass). On the CPU each thread then *splats* every
impact's texton into the band of rows it owns, so no pixel ever tests
impacts that miss it; on CUDA one thread per pixel gathers the impacts of its
neighbouring cells. Points: each point walks its neighbouring cells.

This module is used by the public front ends (synthesis, filtering, plane,
mixing, surface); it validates what it computes from, not user options.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import warp as wp

from ._checks import check_mni, check_positive, check_real
from ._runtime import BANDS_PER_THREAD, init_warp, is_cpu, map_points, split_launch
from .errors import TextonError
from .limits import check_memory, check_work
from .kernels import noise2d as K
from .kernels.impacts import Cells
from .texton import Texton

#: Default cell side as a fraction of the texton support side (CGF §8).
CELL_FACTOR = 0.6
POISSON_MODES = ("exact", "gaussian")
#: Raster strategies: "splat" (each impact adds its texton to the pixels it
#: covers; CPU default) and "gather" (each pixel sums nearby impacts; CUDA default).
METHODS = ("auto", "splat", "gather")
#: Refuse rasters whose cell block would exceed this many cells (a tiny scale
#: makes one pixel cover huge areas of the noise).
MAX_CELLS = 1 << 26
#: Refuse cell grids where one point must visit more cells than this (a tiny
#: period or cell_factor), or where a cell holds more impacts than MAX_CELL_MEAN
#: on average (a huge cell_factor): both would hang or overflow the kernels.
MAX_CELLS_PER_POINT = 4096
MAX_CELL_MEAN = 1.0e5
#: Cell indices are int32 in the kernels: positions must stay below this many cells.
MAX_CELL_INDEX = 1 << 30
#: The block's impacts are indexed by int32 offsets.
MAX_IMPACTS = 1 << 30
#: Largest scale (pixels per texel): the kernels hold pixel positions in float32
#: relative to the block of cells, whose ~2**-24 relative precision reaches a
#: pixel step at about 1e5 pixels per texel.
MAX_SCALE = 1.0e4
#: Host bytes per impact of a raster's block: its position (vec2), and for mixed
#: noise its label and sign.
IMPACT_BYTES = 8
MARKED_IMPACT_BYTES = 16


def support_reach(order: int) -> float:
    """ψ of this order is supported on [−reach, reach]."""
    return 0.5 if order == 0 else (order + 1) / 2.0


@dataclass(frozen=True)
class NoiseSetup:
    """Everything the kernels need that follows from (texton, mni, seed, options)."""

    lam: float
    cell: tuple[float, float]
    period_cells: tuple[int, int]
    lo: tuple[float, float]
    hi: tuple[float, float]
    coeffs: np.ndarray  # (r + 2 PAD, s + 2 PAD, 3) float32
    mni: float = 0.0  # λ · area(supp h)

    @property
    def lam_cell(self) -> float:
        return self.lam * self.cell[0] * self.cell[1]


def noise_setup(texton: Texton, mni: float, period=None, cell_factor: float = CELL_FACTOR) -> NoiseSetup:
    """Intensity, cell grid and support box of the noise of ``texton``."""
    if not isinstance(texton, Texton):
        raise TextonError(f"texton must be a Texton, got {type(texton).__name__}")
    mni = check_mni(mni)
    cell_factor = check_positive(cell_factor, "cell_factor")
    if texton.support_area == 0:
        raise TextonError("texton: every coefficient is zero, so its noise is the constant mean; nothing to synthesize")
    r, s = texton.size
    reach = support_reach(texton.order)
    lo = (-reach, -reach)
    hi = (s - 1 + reach, r - 1 + reach)
    side = cell_factor * max(hi[0] - lo[0], hi[1] - lo[1])
    if not 0.0 < float(np.float32(side)) < math.inf:
        raise TextonError(f"cell_factor {cell_factor:g} makes cells of {side:.3g} texels, which float32 cannot "
                          f"hold; use a cell_factor near the default {CELL_FACTOR}")
    if period is None:
        cell = (side, side)
        period_cells = (0, 0)
    else:
        px, py = check_period(period)
        if max(px, py) / side > MAX_CELL_INDEX:
            # the kernels wrap int32 cell indices modulo the period's cell count: beyond
            # 2**30 cells the count itself would wrap and the period silently change
            raise TextonError(
                f"period ({px:.6g}, {py:.6g}) texels spans {px / side:.4g} x {py / side:.4g} noise cells of "
                f"{side:.3g} texels; "
                f"a period can span at most 2**30 cells, i.e. {MAX_CELL_INDEX * side:.4g} texels for this "
                "texton and cell_factor (the noise is defined within that range anyway); use a smaller period"
            )
        nx = max(1, round(px / side))
        ny = max(1, round(py / side))
        cell = (px / nx, py / ny)
        period_cells = (nx, ny)
    # The kernels hold the cell side in float32: use that same value on the host,
    # so that host-placed blocks and kernel-placed cells coincide far from the origin.
    with np.errstate(over="ignore"):
        cell = tuple(float(np.float32(c)) for c in cell)
    if not all(0.0 < c < math.inf for c in cell):  # a period far below a texel
        raise TextonError(f"period {period!r} makes cells of {cell[0]:.3g} x {cell[1]:.3g} texels, which float32 "
                          "cannot hold; use a period of at least a texel")
    lam = mni / texton.support_area
    per_point = (math.ceil((hi[0] - lo[0]) / cell[0]) + 1) * (math.ceil((hi[1] - lo[1]) / cell[1]) + 1)
    if per_point > MAX_CELLS_PER_POINT:
        raise TextonError(
            f"cells of {cell[0]:.3g} x {cell[1]:.3g} texels are too small for a texton support of "
            f"{hi[0] - lo[0]:g} x {hi[1] - lo[1]:g}: each point would visit {per_point} cells "
            f"(at most {MAX_CELLS_PER_POINT}); use a larger cell_factor or period"
        )
    if lam * cell[0] * cell[1] > MAX_CELL_MEAN:
        raise TextonError(
            f"mni {mni:g} with cell_factor {cell_factor:g} makes cells hold {lam * cell[0] * cell[1]:.3g} impacts "
            f"on average (at most {MAX_CELL_MEAN:g}); use a lower mni or a smaller cell_factor (default {CELL_FACTOR})"
        )
    return NoiseSetup(lam, cell, period_cells, lo, hi, padded_coeffs(texton), mni)


def padded_coeffs(texton: Texton) -> np.ndarray:
    """The coefficients as the kernels read them: (r + 2 PAD, s + 2 PAD, 3) float32,
    a zero margin of PAD texels around, unused channels zero."""
    r, s = texton.size
    coeffs = np.zeros((r + 2 * K.PAD, s + 2 * K.PAD, 3), np.float32)
    coeffs[K.PAD:K.PAD + r, K.PAD:K.PAD + s, : texton.channels] = texton.coeffs
    return coeffs


def check_cell_range(lo: float, hi: float, cell: float, what: str) -> None:
    """Positions whose cell indices would not fit the kernels' int32 are refused."""
    if max(abs(lo), abs(hi)) / cell >= MAX_CELL_INDEX:
        raise TextonError(
            f"{what} reach {max(abs(lo), abs(hi)):.3g} texels from the origin; the noise is defined "
            f"within ±{MAX_CELL_INDEX * cell:.3g} texels (2**30 cells)"
        )


def check_period(period) -> tuple[float, float]:
    """A pair (Px, Py) of positive numbers."""
    px, py = _pair(period, "period", "(Px, Py) of positive numbers")
    return check_positive(px, "period[0]"), check_positive(py, "period[1]")


def _pair(value, name: str, what: str):
    if isinstance(value, (str, bytes)):
        raise TextonError(f"{name} must be a pair {what}, got {value!r:.60}")
    try:
        a, b = value
    except Exception:  # not iterable, wrong length
        raise TextonError(f"{name} must be a pair {what}, got {value!r:.60}") from None
    return a, b


def check_pair(value, name: str) -> tuple[float, float]:
    """A pair (x, y) of finite numbers."""
    x, y = _pair(value, name, "(x, y) of numbers")
    return check_real(x, f"{name}[0]"), check_real(y, f"{name}[1]")


#: Operations (the unit of limits.check_work) per impact a point's cell walk
#: visits: a walk draws each visited cell's impacts again for every point, where
#: a raster draws them once and splats; measured at about 15 raster lookups per
#: walk visit on the CPU (benchmarks/bench_limits.py).
WALK_COST = 16.0


def walk_cost(setup: NoiseSetup, width, height):
    """Operations of a cell walk over a box of ``width`` × ``height`` texels (arrays
    broadcast): the impacts of the cells it covers, times WALK_COST."""
    cw, ch = setup.cell
    cells = (np.ceil(np.asarray(width) / cw) + 1) * (np.ceil(np.asarray(height) / ch) + 1)
    return WALK_COST * cells * setup.lam_cell


def visits_per_point(setup: NoiseSetup) -> float:
    """Operations of one point's cell walk over the texton's support box."""
    return float(walk_cost(setup, setup.hi[0] - setup.lo[0], setup.hi[1] - setup.lo[1]))


def lookup_cost(order: int, on_grid: bool) -> float:
    """Operations per texton lookup of a raster splat or gather: 1 on the vectorised
    path (bilinear, unrotated, scale 1), else max(8, 2 (order + 1)²) for the taps
    of the general path (measured on the CPU, 512² RGB rasters of a 64² texton at
    MNI 30: about 7, 6, 32-70 and 95-115 times the vectorised path for orders 0,
    1, 3 and 5)."""
    return 1.0 if on_grid else max(8.0, 2.0 * (order + 1) ** 2)


def check_points_cost(setup: NoiseSetup, count: int, what: str, evaluations: float = 1.0,
                      bytes_per_point: float = 64.0) -> None:
    """Refuse ``count`` point evaluations (``evaluations`` walks each) beyond the budgets."""
    check_memory(count * bytes_per_point, what, "use fewer points")
    check_work(count * evaluations * visits_per_point(setup), f"{what} at MNI {setup.mni:.6g}",
               "use fewer points or a lower mni")


def check_raster_cost(setup: NoiseSetup, shape, ncells: int, stacked: int = 1, marked: bool = False,
                      lookup: float = 1.0) -> None:
    """Refuse a raster whose impact block, output or work exceed the budgets.

    Memory: counts and offsets per cell, the block's impacts (with labels and
    signs when ``marked``), the (H, W, 3) float32 raster and its copy to C
    channels, the coefficient stack. Work: the impacts drawn plus, for every
    pixel, the impacts whose support covers it (MNI on average) at ``lookup``
    operations each (:func:`lookup_cost`).
    """
    h, w = shape
    expected = setup.lam * ncells * setup.cell[0] * setup.cell[1]
    impacts = expected + 10 * math.sqrt(expected)
    per_impact = MARKED_IMPACT_BYTES if marked else IMPACT_BYTES
    nbytes = 8.0 * ncells + per_impact * impacts + 2 * 12.0 * h * w + stacked * setup.coeffs.nbytes
    what = f"a {w}x{h} raster at MNI {setup.mni:.6g}"
    check_memory(nbytes, what, "use a smaller raster, a larger scale or a lower mni")
    check_work(impacts + float(h) * w * setup.mni * lookup, what, "use a smaller raster or a lower mni")


def cell_limit(setup: NoiseSetup) -> float:
    """Texel coordinates beyond ±this are left to the mean: their cells (and those
    of the supports around them) would not fit the kernels' int32 cell indices."""
    return 0.5 * MAX_CELL_INDEX * min(setup.cell)


def noise_params(texton: Texton, setup: NoiseSetup, seed: int, poisson: str = "exact") -> K.NoiseParams:
    """The kernels' ``NoiseParams`` for ``texton`` with this setup and seed."""
    if poisson not in POISSON_MODES:
        raise TextonError(f"poisson must be one of {', '.join(POISSON_MODES)}, got {poisson!r}")
    init_warp()
    cells = Cells()
    cells.size = wp.vec2(*setup.cell)
    cells.period = wp.vec2i(*setup.period_cells)
    cells.mean_count = setup.lam_cell
    cells.seed = wp.uint32(seed)
    cells.exact_poisson = 1 if poisson == "exact" else 0
    p = K.NoiseParams()
    p.cells = cells
    p.order = texton.order
    p.lo = wp.vec2(*setup.lo)
    p.hi = wp.vec2(*setup.hi)
    p.lam = setup.lam
    mean = np.zeros(3)
    mean[: texton.channels] = texton.mean
    integral = np.zeros(3)
    integral[: texton.channels] = texton.integral
    p.mean = wp.vec3(*mean)
    p.integral = wp.vec3(*integral)
    return p


def params_mean(p: K.NoiseParams) -> np.ndarray:
    """The noise mean held by ``p``, as three float32 values."""
    return np.array([p.mean[0], p.mean[1], p.mean[2]], np.float32)


def raster_geometry(shape, scale, rotation, offset):
    """Pixel (i, j) ↦ x = offset + R(rotation) ((j + ½)/scale, (i + ½)/scale):
    returns (origin (2,), step (2, 2)) in float64, columns the steps along j and i."""
    scale = check_positive(scale, "scale")
    if scale > MAX_SCALE:
        raise TextonError(f"scale must be at most {MAX_SCALE:g} pixels per texel (float32 positions cannot "
                          f"resolve finer pixels), got {scale:g}")
    rotation = check_real(rotation, "rotation")
    ox, oy = check_pair(offset, "offset")
    th = math.radians(rotation)
    rot = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    with np.errstate(over="ignore"):
        step = rot / scale  # columns: noise step per pixel along x (j) and along y (i)
    h, w = shape
    if not np.isfinite(step).all() or not np.isfinite(step * max(h, w)).all():
        raise TextonError(f"scale {scale!r} is too small: pixel positions overflow")
    return np.array([ox, oy]), step


def raster_reach(origin, step, shape, setup: NoiseSetup):
    """(x0, x1, y0, y1): the texel box whose cells the raster reads (its corners'
    box grown by the support), refused where cell indices would not fit int32."""
    h, w = shape
    corners = origin[:, None] + step @ np.array([[0, w, 0, w], [0, 0, h, h]], dtype=np.float64)
    x0, x1 = corners[0].min() - setup.hi[0], corners[0].max() - setup.lo[0]
    y0, y1 = corners[1].min() - setup.hi[1], corners[1].max() - setup.lo[1]
    check_cell_range(x0, x1, setup.cell[0], "the raster's positions")
    check_cell_range(y0, y1, setup.cell[1], "the raster's positions")
    return x0, x1, y0, y1


@dataclass(frozen=True)
class Regions:
    """How mixed noise picks each impact's texton (see kernels.noise2d.label_impacts)."""

    count: int  # number of stacked textons
    rho: np.ndarray | None  # (H, W) float32 ρ map, or None for vertical strips


def draw_block(p, cell0, ncx: int, ncy: int):
    """Impacts of the ncx × ncy cells from cell0, grouped by cell, with offsets
    (on the current device)."""
    n_cells = ncx * ncy
    counts = wp.zeros(n_cells + 1, dtype=wp.int32)
    wp.launch(K.count_impacts, dim=n_cells, inputs=[p, wp.vec2i(*cell0), ncx, counts])
    offsets = wp.zeros(n_cells + 1, dtype=wp.int32)
    wp.utils.array_scan(counts, offsets, inclusive=False)
    total = int(offsets[n_cells: n_cells + 1].numpy()[0])
    impacts = wp.zeros(max(total, 1), dtype=wp.vec2)
    if total:
        wp.launch(K.emit_impacts, dim=n_cells, inputs=[p, wp.vec2i(*cell0), ncx, offsets, impacts])
    return impacts[:total] if total else impacts[:0], offsets


def raster(p, setup: NoiseSetup, coeffs: np.ndarray, order: int, shape, origin, step, device,
           method: str, scale, regions: Regions | None = None) -> np.ndarray:
    """Evaluate the noise of ``p`` on a raster: (H, W, 3) float32 of normalised values.

    ``coeffs`` holds one padded texton, or ``regions.count`` of them stacked
    along the rows for mixed noise (then values are Σ ε h / √λ, without mean).
    """
    h, w = shape
    if method not in METHODS:
        raise TextonError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    on_cpu = is_cpu(device)
    if method == "auto":
        method = "splat" if on_cpu else "gather"
    if method == "splat" and not on_cpu:
        raise TextonError('method "splat" runs on the CPU only (its launches must not overlap); use "gather"')
    cw, ch = setup.cell
    # Noise-space bounding box of the raster, grown by the support: the block of cells to draw.
    x0, x1, y0, y1 = raster_reach(origin, step, (h, w), setup)
    cx0, cy0 = math.floor(x0 / cw), math.floor(y0 / ch)
    ncx, ncy = math.floor(x1 / cw) - cx0 + 1, math.floor(y1 / ch) - cy0 + 1
    if ncx * ncy > MAX_CELLS:
        raise TextonError(
            f"scale {scale} makes this {h}x{w} raster cover {ncx * ncy} noise cells "
            f"(at most {MAX_CELLS}); use a larger scale or a smaller raster"
        )
    expected = setup.lam * ncx * ncy * cw * ch
    if expected + 10 * math.sqrt(expected) > MAX_IMPACTS:
        raise TextonError(
            f"this raster needs about {expected:.3g} impacts (at most {MAX_IMPACTS}); "
            "use a lower mni, a larger scale or a smaller raster"
        )
    grid_path = method == "splat" and order == 1 and np.array_equal(step, np.eye(2))
    check_raster_cost(setup, (h, w), ncx * ncy, coeffs.size // setup.coeffs.size, regions is not None,
                      lookup_cost(order, grid_path))
    with wp.ScopedDevice(device):
        impacts, offsets = draw_block(p, (cx0, cy0), ncx, ncy)
        n = impacts.shape[0]
        r = K.Raster()
        # positions relative to the block corner, computed in float64 before rounding
        base = origin - np.array([cx0 * cw, cy0 * ch])
        r.base = wp.vec2(*base)
        r.step_x = wp.vec2(*step[:, 0])
        r.step_y = wp.vec2(*step[:, 1])
        r.width = w
        r.height = h
        inv = wp.mat22(*np.linalg.inv(step).ravel())
        stack = wp.array(coeffs.reshape(-1, coeffs.shape[-2], 3), dtype=wp.vec3)
        marks = K.Marks()
        marks.rows = coeffs.shape[-3]
        if regions is None:
            marks.marked = 0
            marks.labels = wp.zeros(1, dtype=wp.int32)
            marks.signs = wp.zeros(1, dtype=float)
        else:
            marks.marked = 1
            marks.labels = wp.zeros(max(n, 1), dtype=wp.int32)
            marks.signs = wp.zeros(max(n, 1), dtype=float)
            rho = regions.rho if regions.rho is not None else np.zeros((1, 1), np.float32)
            if n:
                wp.launch(K.emit_signs, dim=ncx * ncy, inputs=[p, wp.vec2i(cx0, cy0), ncx, offsets, marks.signs])
                centre = wp.vec2(0.5 * (setup.lo[0] + setup.hi[0]), 0.5 * (setup.lo[1] + setup.hi[1]))
                wp.launch(K.label_impacts, dim=n, inputs=[impacts, r, inv, centre, int(regions.rho is None),
                                                          regions.count, wp.array(rho, dtype=float), marks.labels])
        if on_cpu:
            # calloc'd pages are zeroed lazily, by the threads that first touch them
            host = np.zeros((h, w, 3), np.float32)
            out = wp.array(host, dtype=wp.vec3, copy=False)
        else:
            out = wp.empty((h, w), dtype=wp.vec3)
        if method == "splat":
            on_grid = order == 1 and np.array_equal(step, np.eye(2))

            def band(r0, r1):
                if n and on_grid:
                    wp.launch(K.splat_impacts_grid, dim=n, inputs=[r.base, stack, impacts, marks, w, r0, r1, out])
                elif n:
                    wp.launch(K.splat_impacts, dim=n, inputs=[p, r, inv, stack, impacts, marks, r0, r1, out])
                wp.launch(K.normalize_raster, dim=(r1 - r0, w), inputs=[p, r0, out])
        else:

            def band(r0, r1):
                wp.launch(K.gather_raster, dim=(r1 - r0, w),
                          inputs=[p, r, stack, impacts, offsets, marks, ncx, ncy, r0, out])

        split_launch(device, K, h, band, BANDS_PER_THREAD)
        return host if on_cpu else out.numpy()


def point_values(p, coeffs: np.ndarray, pts: np.ndarray, device) -> np.ndarray:
    """(N, 3) unfiltered noise at float64 points (N, 2), split over threads on the CPU."""
    with wp.ScopedDevice(device):
        c = wp.array(coeffs, dtype=wp.vec3)

        def values(start, stop):
            res = wp.zeros(stop - start, dtype=wp.vec3)
            wp.launch(K.evaluate_points, dim=stop - start, inputs=[p, c, wp.array(pts[start:stop], dtype=wp.vec2d), res])
            return res.numpy()

        return map_points(device, K, pts.shape[0], values)
