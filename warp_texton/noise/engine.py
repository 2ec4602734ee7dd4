"""The engine of texton noise in the plane: setup, kernel parameters, cost, points.

g(x) = m + (Σ_j h(x − x_j) − λ ∫h) / √λ with x_j a Poisson process of
intensity λ = MNI / area(supp h) (CGF eq. (1)-(2), §3.3), generated cell by
cell from hashed seeds (CGF §8; kernels/impacts.py) so that any window, at any
position, on any device, shows the same noise.

:func:`noise_setup` computes what follows from (texton, mni, period,
cell_factor); :func:`params_record` is the one builder of the kernels'
``NoiseParams`` (a NumPy record; :func:`params_struct` makes Warp's struct of
it for the kernels that take one); the cost model prices a point's cell walk
and a raster's texton lookups for the budgets of :mod:`warp_texton.core.limits`;
:func:`point_values` evaluates points, each walking its neighbouring cells.
Rasters are :mod:`warp_texton.noise.raster`'s.

This module is used by the public front ends (synthesis, filtering, plane,
mixing, surface); it validates what it computes from, not user options.

Kernels driven here: ``warp_texton.kernels.noise_raster``.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import warp as wp

from ..core.checks import check_mni, check_positive, check_real
from ..core.runtime import init_warp, map_points, split_launch
from ..core.errors import TextonError
from ..core.limits import check_memory, check_work
from .noise_options import CELL_FACTOR, check_period, check_poisson, unpack_pair
from ..kernels import noise_raster
from ..model.texton import Texton

#: Refuse cell grids where one point must visit more cells than this (a tiny
#: period or cell_factor), or where a cell holds more impacts than MAX_CELL_MEAN
#: on average (a huge cell_factor): both would hang or overflow the kernels.
MAX_CELLS_PER_POINT = 4096
MAX_CELL_MEAN = 1.0e5
#: Cell indices are int32 in the kernels: positions must stay below this many cells.
MAX_CELL_INDEX = 1 << 30


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
        cell = (float(np.float32(cell[0])), float(np.float32(cell[1])))
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
    coeffs = np.zeros((r + 2 * noise_raster.PAD, s + 2 * noise_raster.PAD, 3), np.float32)
    coeffs[noise_raster.PAD:noise_raster.PAD + r, noise_raster.PAD:noise_raster.PAD + s, : texton.channels] = texton.coeffs
    return coeffs


def check_cell_range(lo: float, hi: float, cell: float, what: str) -> None:
    """Positions whose cell indices would not fit the kernels' int32 are refused."""
    if max(abs(lo), abs(hi)) / cell >= MAX_CELL_INDEX:
        raise TextonError(
            f"{what} reach {max(abs(lo), abs(hi)):.3g} texels from the origin; the noise is defined "
            f"within ±{MAX_CELL_INDEX * cell:.3g} texels (2**30 cells)"
        )


def check_pair(value, name: str) -> tuple[float, float]:
    """A pair (x, y) of finite numbers."""
    x, y = unpack_pair(value, name, "(x, y) of numbers")
    return check_real(x, f"{name}[0]"), check_real(y, f"{name}[1]")


#: Operations (the unit of limits.check_work) per impact a point's cell walk
#: visits: a walk draws each visited cell's impacts again for every point, where
#: a raster draws them once and splats; measured at about 15 raster lookups per
#: walk visit on the CPU (benchmarks/bench_limits.py).
WALK_COST = 16.0
#: Bytes per evaluated point: its float64 position and the copy the kernels
#: read (16 each), its vec3 float32 value and the value handed over (12 each),
#: rounded up.
POINT_BYTES = 64.0


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


def check_points_cost(setup: NoiseSetup, count: int, what: str) -> None:
    """The budget check of a call that evaluates ``count`` points, one walk each."""
    check_memory(count * POINT_BYTES, what, "use fewer points")
    check_work(count * visits_per_point(setup), f"{what} at MNI {setup.mni:.6g}", "use fewer points or a lower mni",
               mentions=("mni",))


def cell_limit(setup: NoiseSetup) -> float:
    """Texel coordinates beyond ±this are left to the mean: their cells (and those
    of the supports around them) would not fit the kernels' int32 cell indices."""
    return 0.5 * MAX_CELL_INDEX * min(setup.cell)


@functools.cache
def record_dtype(struct) -> np.dtype:
    """The NumPy dtype of a Warp struct's records (Warp builds it anew at every call)."""
    return np.dtype(struct.numpy_dtype())


def params_record(texton: Texton, setup: NoiseSetup, seed: int, poisson: str = "exact") -> np.ndarray:
    """The kernels' ``NoiseParams`` for ``texton`` with this setup and seed, as a record
    of its NumPy dtype: the one place its fields are written. Rasters carry it as
    it is (in their Window records); it is cheaper to make than Warp's struct
    object, which :func:`params_struct` makes of it for the kernels that take one."""
    check_poisson(poisson)
    rec = np.zeros((), dtype=record_dtype(noise_raster.NoiseParams))
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


def params_struct(rec: np.ndarray) -> noise_raster.NoiseParams:
    """Warp's ``NoiseParams`` struct holding the record ``rec`` byte for byte."""
    init_warp()
    return noise_raster.NoiseParams.from_ptr(np.ascontiguousarray(rec).ctypes.data)


def noise_params(texton: Texton, setup: NoiseSetup, seed: int, poisson: str = "exact") -> noise_raster.NoiseParams:
    """The kernels' ``NoiseParams`` struct for ``texton`` with this setup and seed
    (:func:`params_record`, as Warp's struct)."""
    return params_struct(params_record(texton, setup, seed, poisson))


def params_mean(p: noise_raster.NoiseParams) -> np.ndarray:
    """The noise mean held by ``p``, as three float32 values."""
    return np.array([p.mean[0], p.mean[1], p.mean[2]], np.float32)


def point_values(p, coeffs: np.ndarray, pts: np.ndarray, device, out=None) -> np.ndarray | None:
    """(N, 3) unfiltered noise at float64 points (N, 2), split over threads on the CPU.

    With ``out`` (an (N,) array on ``device``) the values are written there and
    nothing is returned; a float ``out`` takes one channel (a grey texton's: its
    kernels then read one float a texel), a vec3 one three.
    """
    with wp.ScopedDevice(device):
        if out is not None:
            one = out.dtype == wp.float32
            c: wp.array = (wp.array(np.ascontiguousarray(coeffs[..., 0]), dtype=wp.float32) if one
                           else wp.array(coeffs, dtype=wp.vec3))

            def launch(start, stop):
                wp.launch(noise_raster.evaluate_points, dim=stop - start,
                          inputs=[p, c, wp.array(pts[start:stop], dtype=wp.vec2d), out[start:stop]])

            split_launch(device, noise_raster, pts.shape[0], launch)
            return None
        c = wp.array(coeffs, dtype=wp.vec3)

        def values(start, stop):
            res = wp.zeros(stop - start, dtype=wp.vec3)
            wp.launch(noise_raster.evaluate_points, dim=stop - start, inputs=[p, c, wp.array(pts[start:stop], dtype=wp.vec2d), res])
            return res.numpy()

        return map_points(device, noise_raster, pts.shape[0], values)
