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

import functools
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
#: Bytes per impact of a raster's block: its offset in its cell (vec2) and its cell
#: (int32); mixed noise adds its label (int32) and sign (float32).
IMPACT_BYTES = 12
MARKED_IMPACT_BYTES = 20


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
    area = texton.support_area  # a mask computation: once
    if area == 0:
        raise TextonError("texton: every coefficient is zero, so its noise is the constant mean; nothing to synthesize",
                          param="texton")
    r, s = texton.size
    reach = support_reach(texton.order)
    lo = (-reach, -reach)
    hi = (s - 1 + reach, r - 1 + reach)
    side = cell_factor * max(hi[0] - lo[0], hi[1] - lo[1])
    if not 0.0 < float(np.float32(side)) < math.inf:
        raise TextonError(f"cell_factor {cell_factor:g} makes cells of {side:.3g} texels, which float32 cannot "
                          f"hold; use a cell_factor near the default {CELL_FACTOR}", param="cell_factor")
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
                f"periods span at most 2**30 cells, i.e. {MAX_CELL_INDEX * side:.4g} texels for this "
                "texton and cell_factor (the noise is defined within that range anyway); use a smaller period",
                param="period", mentions=("period",),
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
                          "cannot hold; use a period of at least a texel", param="period")
    lam = mni / area
    per_point = (math.ceil((hi[0] - lo[0]) / cell[0]) + 1) * (math.ceil((hi[1] - lo[1]) / cell[1]) + 1)
    if per_point > MAX_CELLS_PER_POINT:
        raise TextonError(
            f"cells of {cell[0]:.3g} x {cell[1]:.3g} texels are too small for a texton support of "
            f"{hi[0] - lo[0]:g} x {hi[1] - lo[1]:g}: each point would visit {per_point} cells "
            f"(at most {MAX_CELLS_PER_POINT}); use a larger cell_factor or period", mentions=("cell_factor", "period")
        )
    if lam * cell[0] * cell[1] > MAX_CELL_MEAN:
        raise TextonError(
            f"mni {mni:g} with cell_factor {cell_factor:g} makes cells hold {lam * cell[0] * cell[1]:.3g} impacts "
            f"on average (at most {MAX_CELL_MEAN:g}); use a lower mni or a smaller cell_factor (default {CELL_FACTOR})",
            param="mni", mentions=("mni", "cell_factor")
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
        raise TextonError(f"{name} must be a pair {what}, got {value!r:.60}", param=name)
    try:
        a, b = value
    except Exception:  # not iterable, wrong length
        raise TextonError(f"{name} must be a pair {what}, got {value!r:.60}", param=name) from None
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
               "use fewer points or a lower mni", mentions=("mni",))


def raster_cost(windows, blocks, shape, stack, marked: bool = False, splat: bool = True):
    """(bytes, operations, description) of rasters (one window or a batch).

    Memory: counts and offsets per cell, the blocks' impacts (with labels and
    signs when ``marked``), each (H, W, 3) float32 raster and its copy to C
    channels, the coefficient stack. Work: the impacts drawn plus, for every
    pixel, the impacts whose support covers it (MNI on average) at
    :func:`lookup_cost` operations each.
    """
    h, w = shape
    ncells = impacts = work = 0.0
    for win, (_, _, ncx, ncy) in zip(windows, blocks):
        s = win.setup
        expected = s.lam * ncx * ncy * s.cell[0] * s.cell[1]
        impacts += expected + 10 * math.sqrt(expected)
        ncells += ncx * ncy
        on_grid = splat and win.order == 1 and np.array_equal(win.step, np.eye(2))
        work += float(h) * w * s.mni * lookup_cost(win.order, on_grid)
    per_impact = MARKED_IMPACT_BYTES if marked else IMPACT_BYTES
    nbytes = 8.0 * ncells + per_impact * impacts + 2 * 12.0 * h * w * len(windows) + stack.coeffs.nbytes
    mni = max(win.setup.mni for win in windows)
    what = (f"a {w}x{h} raster at MNI {mni:.6g}" if len(windows) == 1
            else f"{len(windows)} rasters of {w}x{h} at MNI up to {mni:.6g}")
    return nbytes, impacts + work, what


def check_raster_cost(windows, blocks, shape, stack, marked: bool = False, splat: bool = True) -> None:
    """Refuse rasters whose impact blocks and output, or work, exceed the budgets."""
    nbytes, work, what = raster_cost(windows, blocks, shape, stack, marked, splat)
    check_memory(nbytes, what, "use a smaller raster, a larger scale or a lower mni", mentions=("scale", "mni"))
    check_work(work, what, "use a smaller raster or a lower mni", mentions=("mni",))


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


def params_record(texton: Texton, setup: NoiseSetup, seed: int, poisson: str = "exact") -> np.ndarray:
    """:func:`noise_params` as a record of its NumPy dtype (the same values), made
    without Warp's struct objects, which cost more than a small raster to build."""
    if poisson not in POISSON_MODES:
        raise TextonError(f"poisson must be one of {', '.join(POISSON_MODES)}, got {poisson!r}")
    rec = np.zeros((), dtype=record_dtype(K.NoiseParams))
    c = rec["cells"]
    c["size"] = setup.cell
    c["period"] = setup.period_cells
    c["mean_count"] = setup.lam_cell
    c["seed"] = seed
    c["exact_poisson"] = 1 if poisson == "exact" else 0
    rec["order"] = texton.order
    rec["lo"] = setup.lo
    rec["hi"] = setup.hi
    rec["lam"] = setup.lam
    rec["mean"][: texton.channels] = texton.mean
    rec["integral"][: texton.channels] = texton.integral
    return rec


def params_mean(p: K.NoiseParams) -> np.ndarray:
    """The noise mean held by ``p``, as three float32 values."""
    return np.array([p.mean[0], p.mean[1], p.mean[2]], np.float32)


def raster_geometry(shape, scale, rotation, offset):
    """Pixel (i, j) ↦ x = offset + R(rotation) ((j + ½)/scale, (i + ½)/scale):
    returns (origin (2,), step (2, 2)) in float64, columns the steps along j and i."""
    scale = check_positive(scale, "scale")
    if scale > MAX_SCALE:
        raise TextonError(f"scale must be at most {MAX_SCALE:g} pixels per texel (float32 positions cannot "
                          f"resolve finer pixels), got {scale:g}", param="scale")
    rotation = check_real(rotation, "rotation")
    ox, oy = check_pair(offset, "offset")
    th = math.radians(rotation)
    rot = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    with np.errstate(over="ignore"):
        step = rot / scale  # columns: noise step per pixel along x (j) and along y (i)
    h, w = shape
    if not np.isfinite(step).all() or not np.isfinite(step * max(h, w)).all():
        raise TextonError(f"scale {scale!r} is too small: pixel positions overflow", param="scale")
    return np.array([ox, oy]), step


def raster_reach(origin, step, shape, setup: NoiseSetup, first=(0, 0)):
    """(x0, x1, y0, y1): the texel box whose cells the raster reads (its corners'
    box grown by the support), refused where cell indices would not fit int32.

    ``first`` = (row, column): the raster is the window of that many pixels
    down and right of ``origin`` in the raster that ``origin`` and ``step`` place.
    """
    h, w = shape
    r0, c0 = first
    corners = origin[:, None] + step @ np.array([[c0, c0 + w, c0, c0 + w], [r0, r0, r0 + h, r0 + h]],
                                                dtype=np.float64)
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


@dataclass(frozen=True)
class RasterWindow:
    """One raster of a batch: the noise of ``p`` at pixels ``first`` + (i, j) of the
    raster that ``origin`` and ``step`` place (see :func:`raster_geometry`), with
    texton ``texton`` of the batch's :class:`TextonStack`."""

    p: object  # kernels.noise2d.NoiseParams, or its record (params_record)
    setup: NoiseSetup
    texton: int
    order: int
    origin: np.ndarray
    step: np.ndarray
    first: tuple = (0, 0)
    scale: float = 1.0  # for messages only


@dataclass(frozen=True)
class TextonStack:
    """Padded textons stacked along the rows (one common width): entry k holds
    ``count[k]`` textons of ``rows[k]`` rows each from row ``row0[k]``, ``cols[k]`` wide."""

    coeffs: np.ndarray  # (total rows, width, 3) float32
    row0: tuple
    rows: tuple
    cols: tuple

    @classmethod
    def of(cls, entries) -> "TextonStack":
        """Stack padded coefficient arrays (rows, cols, 3), or (R, rows, cols, 3) for
        the R textons of mixed noise (one entry)."""
        entries = [np.asarray(e, np.float32) for e in entries]
        entries = [e[None] if e.ndim == 3 else e for e in entries]
        width = max(e.shape[2] for e in entries)
        total = sum(e.shape[0] * e.shape[1] for e in entries)
        coeffs = np.zeros((total, width, 3), np.float32)
        row0, at = [], 0
        for e in entries:
            n, r, c = e.shape[:3]
            coeffs[at:at + n * r, :c] = e.reshape(n * r, c, 3)
            row0.append(at)
            at += n * r
        return cls(coeffs, tuple(row0), tuple(e.shape[1] for e in entries), tuple(e.shape[2] for e in entries))


def window_block(win: RasterWindow, shape):
    """(cx0, cy0, ncx, ncy): the cells whose impacts can reach the window."""
    h, w = shape
    cw, ch = win.setup.cell
    x0, x1, y0, y1 = raster_reach(win.origin, win.step, shape, win.setup, win.first)
    cx0, cy0 = math.floor(x0 / cw), math.floor(y0 / ch)
    ncx, ncy = math.floor(x1 / cw) - cx0 + 1, math.floor(y1 / ch) - cy0 + 1
    if ncx * ncy > MAX_CELLS:
        raise TextonError(
            f"scale {win.scale} makes this {h}x{w} raster cover {ncx * ncy} noise cells "
            f"(at most {MAX_CELLS}); use a larger scale or a smaller raster", param="scale", mentions=("scale",)
        )
    return cx0, cy0, ncx, ncy


def raster_impacts(windows, shape, blocks=None) -> float:
    """The expected number of impacts the windows' blocks hold, plus ten standard
    deviations; refused above MAX_IMPACTS (the kernels index impacts with int32)."""
    blocks = [window_block(win, shape) for win in windows] if blocks is None else blocks
    expected = 0.0
    for win, (_, _, ncx, ncy) in zip(windows, blocks):
        expected += win.setup.lam * ncx * ncy * win.setup.cell[0] * win.setup.cell[1]
    bound = expected + 10 * math.sqrt(expected)
    if bound > MAX_IMPACTS:
        raise TextonError(
            f"this raster needs about {expected:.3g} impacts (at most {MAX_IMPACTS}); "
            "use a lower mni, a larger scale or a smaller raster", mentions=("mni", "scale")
        )
    return bound


@functools.cache
def record_dtype(struct) -> np.dtype:
    """The NumPy dtype of a Warp struct's records (Warp builds it anew at every call)."""
    return np.dtype(struct.numpy_dtype())


def struct_array(table: np.ndarray, struct, device):
    """(a ``wp.array`` of ``struct`` holding the records of ``table``, the array that
    owns its memory): the bytes go over as they are, which skips Warp's
    per-call parsing of the struct's NumPy dtype. Keep the owner alive while
    the array is used."""
    raw = np.ascontiguousarray(table).view(np.uint8)
    owner = wp.array(raw, dtype=wp.uint8, device=device, copy=not is_cpu(device))
    return wp.array(ptr=owner.ptr, dtype=struct, shape=(table.shape[0],), device=device), owner


def put_params(rec, p) -> None:
    """Copy the NoiseParams ``p`` into the structured record ``rec`` of its NumPy dtype."""
    c = p.cells
    rec["cells"]["size"] = (c.size[0], c.size[1])
    rec["cells"]["period"] = (c.period[0], c.period[1])
    rec["cells"]["mean_count"] = c.mean_count
    rec["cells"]["seed"] = c.seed
    rec["cells"]["exact_poisson"] = c.exact_poisson
    for name in ("order", "lam"):
        rec[name] = getattr(p, name)
    for name in ("lo", "hi", "mean", "integral"):
        rec[name] = tuple(getattr(p, name))


def window_table(windows, blocks, stack: TextonStack, shape):
    """The kernels' Window records (NumPy structured) and each window's cell count."""
    h, w = shape
    table = np.zeros(len(windows), dtype=record_dtype(K.Window))
    ncells = np.zeros(len(windows), np.int64)
    first_cell = 0
    for b, (win, (cx0, cy0, ncx, ncy)) in enumerate(zip(windows, blocks)):
        t = table[b]
        if isinstance(win.p, np.ndarray):
            t["p"] = win.p
        else:
            put_params(t["p"], win.p)
        t["origin"] = win.origin
        t["step_x"] = win.step[:, 0]
        t["step_y"] = win.step[:, 1]
        t["inv"] = np.linalg.inv(win.step)
        t["fstep_x"] = win.step[:, 0]
        t["fstep_y"] = win.step[:, 1]
        t["first"] = win.first
        t["out_row"] = b * h
        t["width"] = w
        t["cell0"] = (cx0, cy0)
        t["ncx"] = ncx
        t["ncy"] = ncy
        t["first_cell"] = first_cell
        t["texton_row"] = stack.row0[win.texton]
        t["texton_rows"] = stack.rows[win.texton]
        t["texton_cols"] = stack.cols[win.texton]
        t["grid"] = int(win.order == 1 and np.array_equal(win.step, np.eye(2)))
        ncells[b] = ncx * ncy
        first_cell += ncx * ncy
    return table, ncells


def rasters(windows, stack: TextonStack, shape, device, method: str, out,
            regions: Regions | None = None) -> None:
    """Evaluate the noise of every window into ``out``, a (len(windows) · H, W) vec3
    array on ``device`` (zeroed for the splat): window b fills rows b·H….

    All windows share one count/emit pass and one splat (CPU, split into row
    bands over threads) or gather launch. ``regions`` (one window only) makes
    mixed noise: values are then Σ ε h / √λ, without the mean.
    """
    h, w = shape
    if method not in METHODS:
        raise TextonError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    on_cpu = is_cpu(device)
    if method == "auto":
        method = "splat" if on_cpu else "gather"
    if method == "splat" and not on_cpu:
        raise TextonError('method "splat" runs on the CPU only (its launches must not overlap); use "gather"')
    blocks = [window_block(win, shape) for win in windows]
    raster_impacts(windows, shape, blocks)
    check_raster_cost(windows, blocks, shape, stack, regions is not None, method == "splat")
    table, ncells = window_table(windows, blocks, stack, shape)
    n_cells = int(ncells.sum())
    first_cells = np.concatenate([[0], np.cumsum(ncells)])
    with wp.ScopedDevice(device):
        wins, owner = struct_array(table, K.Window, device)
        cell_window = wp.array(np.repeat(np.arange(len(windows), dtype=np.int32), ncells), dtype=wp.int32)
        counts = wp.zeros(n_cells + 1, dtype=wp.int32)
        wp.launch(K.count_impacts, dim=n_cells, inputs=[wins, cell_window, counts])
        offsets = wp.zeros(n_cells + 1, dtype=wp.int32)
        wp.utils.array_scan(counts, offsets, inclusive=False)
        if on_cpu:
            starts = offsets.numpy()[first_cells]  # a view: no copy on the CPU
        else:
            starts = offsets[n_cells: n_cells + 1].numpy()
        n = int(starts[-1])
        impacts = wp.empty(max(n, 1), dtype=wp.vec2)
        impact_cell = wp.empty(max(n, 1), dtype=wp.int32)
        if n:
            wp.launch(K.emit_impacts, dim=n_cells, inputs=[wins, cell_window, offsets, impacts, impact_cell])
        coeffs = wp.array(stack.coeffs, dtype=wp.vec3)
        marks = K.Marks()
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
                wp.launch(K.emit_signs, dim=n_cells, inputs=[wins, cell_window, offsets, marks.signs])
                # CGF §7 labels x_j for a kernel centred on x_j: the centre of the support box
                setup = windows[0].setup
                centre = wp.vec2(0.5 * (setup.lo[0] + setup.hi[0]), 0.5 * (setup.lo[1] + setup.hi[1]))
                wp.launch(K.label_impacts, dim=n, inputs=[wins, cell_window, impacts, impact_cell, centre,
                                                          int(regions.rho is None), regions.count,
                                                          wp.array(rho, dtype=float), marks.labels])
        if method == "splat":

            def band(r0, r1):
                k0, k1 = int(starts[r0 // h]), int(starts[(r1 - 1) // h + 1])
                if k1 > k0:
                    wp.launch(K.splat_impacts, dim=k1 - k0,
                              inputs=[wins, cell_window, coeffs, impacts, impact_cell, marks, k0, h, r0, r1, out])
                wp.launch(K.normalize_rows, dim=r1 - r0, inputs=[wins, h, r0, out])
        else:

            def band(r0, r1):
                wp.launch(K.gather_raster, dim=(r1 - r0, w),
                          inputs=[wins, coeffs, impacts, offsets, marks, h, r0, out])

        split_launch(device, K, len(windows) * h, band, BANDS_PER_THREAD)


class Canvas:
    """Float32 output memory ``shape`` + (3,) that the kernels write through vec3
    views: NumPy on the CPU (zero pages, touched first by the threads that fill
    them), a ``wp.array`` on a CUDA device.

    ``result(channels, output)`` hands it over as NumPy (``output="numpy"``; a
    copy from a GPU) or as a ``wp.array`` on the device (``output="warp"``).
    """

    def __init__(self, shape, device):
        self.shape = tuple(int(s) for s in shape)
        self.device = device
        if is_cpu(device):
            self.host = np.zeros(self.shape + (3,), np.float32)
            self.data = wp.array(self.host, dtype=wp.float32, device=device, copy=False)
        else:
            self.host = None
            self.data = wp.zeros(self.shape + (3,), dtype=wp.float32, device=device)
        self.size = int(np.prod(self.shape))

    def pixels(self, start: int, stop: int):
        """Values start…stop (row-major order) as a 1-D vec3 view."""
        return wp.array(ptr=self.data.ptr + start * 12, dtype=wp.vec3, shape=(stop - start,), device=self.device)

    def rows(self, width: int):
        """All values as a (size / width, width) vec3 view."""
        return wp.array(ptr=self.data.ptr, dtype=wp.vec3, shape=(self.size // width, width), device=self.device)

    def result(self, channels: int, output: str):
        if output == "warp":
            return self.data if channels == 3 else \
                self.data[(slice(None),) * len(self.shape) + (slice(0, channels),)].contiguous()
        a = self.host if self.host is not None else self.data.numpy()
        return a if channels == 3 else np.ascontiguousarray(a[..., :channels])


def fill_pixels(out, index: np.ndarray, mean, device, compute) -> None:
    """``out`` (an (N,) vec3 array) holds ``mean`` except at ``index``, where
    ``compute(target)`` writes its values (into ``out`` itself when every pixel
    is computed, else through a scatter on the device)."""
    n = out.shape[0]
    with wp.ScopedDevice(device):
        if index.size == n:
            compute(out)
            return
        out.fill_(wp.vec3(*(float(v) for v in mean)))
        if index.size:
            values = wp.empty(index.size, dtype=wp.vec3)
            compute(values)
            wp.launch(K.scatter_values, dim=index.size, inputs=[values, wp.array(index.astype(np.int64), dtype=wp.int64), out])


#: Work of one strip of a large raster (or one group of a batch), in raster
#: pixels: a few tenths of a second on two cores, so that a progress bar moves
#: and Ctrl-C stops within one strip.
STRIP_WORK = 1 << 22


def strips(h: int, w: int, cost: int = 1):
    """Row ranges (r0, r1) cutting an H × W raster into strips of about STRIP_WORK,
    for pixels that each cost ``cost`` raster pixels."""
    rows = max(1, STRIP_WORK // max(1, w * cost))
    return [(r0, min(h, r0 + rows)) for r0 in range(0, h, rows)]


def result_bytes(count: int, h: int, w: int, channels: int, device, output: str) -> int:
    """Bytes of a float32 (count, H, W, 3) canvas plus what handing it over copies."""
    n = count * h * w
    extra = 0
    if channels != 3:
        extra = n * channels * 4  # the channels taken out of the canvas
    elif output == "numpy" and not is_cpu(device):
        extra = n * 3 * 4  # the copy to the host
    return n * 12 + extra


OUTPUTS = ("numpy", "warp")


def check_output(output) -> str:
    """``"numpy"`` or ``"warp"``."""
    if not isinstance(output, str) or output not in OUTPUTS:
        raise TextonError(f"output must be one of {', '.join(OUTPUTS)}, got {output!r}")
    return output


def raster(p, setup: NoiseSetup, coeffs: np.ndarray, order: int, shape, origin, step, device,
           method: str, scale, regions: Regions | None = None) -> np.ndarray:
    """Evaluate the noise of ``p`` on a raster: (H, W, 3) float32 of normalised values.

    ``coeffs`` holds one padded texton, or ``regions.count`` of them stacked
    (R, rows, cols, 3) for mixed noise (then values are Σ ε h / √λ, without mean).
    """
    canvas = Canvas(shape, device)
    win = RasterWindow(p, setup, 0, order, origin, step, (0, 0), scale)
    rasters([win], TextonStack.of([coeffs]), shape, device, method, canvas.rows(shape[1]), regions)
    return canvas.result(3, "numpy")


def point_values(p, coeffs: np.ndarray, pts: np.ndarray, device, out=None) -> np.ndarray | None:
    """(N, 3) unfiltered noise at float64 points (N, 2), split over threads on the CPU.

    With ``out`` (an (N,) vec3 array on ``device``) the values are written there
    and nothing is returned.
    """
    with wp.ScopedDevice(device):
        c = wp.array(coeffs, dtype=wp.vec3)
        if out is not None:
            def launch(start, stop):
                wp.launch(K.evaluate_points, dim=stop - start,
                          inputs=[p, c, wp.array(pts[start:stop], dtype=wp.vec2d), out[start:stop]])

            split_launch(device, K, pts.shape[0], launch)
            return None

        def values(start, stop):
            res = wp.zeros(stop - start, dtype=wp.vec3)
            wp.launch(K.evaluate_points, dim=stop - start, inputs=[p, c, wp.array(pts[start:stop], dtype=wp.vec2d), res])
            return res.numpy()

        return map_points(device, K, pts.shape[0], values)
