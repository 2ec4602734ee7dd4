"""Texton noise on rasters and at points: the host side of kernels/noise2d.py.

g(x) = m + (Σ_j h(x − x_j) − λ ∫h) / √λ with x_j a Poisson process of
intensity λ = MNI / area(supp h) (CGF eq. (1)-(2), §3.3), generated cell by
cell from hashed seeds (CGF §8) so that any window, at any position, on any
device, shows the same noise.

Rasters: the impacts of the cells under the raster are drawn once (a count
pass, a prefix sum, an emit pass). On the CPU each thread then *splats* every
impact's texton into the band of rows it owns, so no pixel ever tests
impacts that miss it; on CUDA one thread per pixel gathers the impacts of its
neighbouring cells. Points: each point draws the impacts of its neighbouring
cells itself.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from ._checks import check_positive, check_seed, check_shape
from .errors import TextonError
from .filtering import (FADE_ENERGY, MAX_ANISO, SUPERSAMPLE, check_fade_energy, check_filter,
                        check_filter_options, check_jacobian, filtered_raster, needs_filtering, point_values)
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


def _warp():
    """Warp, initialised without its greeting or the native "no CUDA driver" note."""
    import warp as wp

    if not getattr(_warp, "done", False):
        wp.config.log_level = wp.LOG_WARNING
        # The driver note is printed by native code: silence file descriptor 2 meanwhile.
        saved = os.dup(2)
        try:
            with open(os.devnull, "wb") as null:
                os.dup2(null.fileno(), 2)
                wp.init()
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        _warp.done = True
    return wp


def resolve_device(device=None) -> str:
    """"cuda" when available for ``None``, else "cpu"; names are checked."""
    wp = _warp()
    if device is None:
        return "cuda:0" if wp.is_cuda_available() else "cpu"
    if str(device).startswith("cuda") and not wp.is_cuda_available():
        names = ", ".join(str(d) for d in wp.get_devices())
        raise TextonError(f"device: {device!r} asked for, but no CUDA device is available; available: {names}")
    try:
        return str(wp.get_device(device))
    except Exception:
        names = ", ".join(str(d) for d in wp.get_devices())
        raise TextonError(f"device: unknown device {device!r}; available: {names}") from None


@dataclass(frozen=True)
class NoiseSetup:
    """Everything the kernels need that follows from (texton, mni, seed, options)."""

    lam: float
    cell: tuple[float, float]
    period_cells: tuple[int, int]
    lo: tuple[float, float]
    hi: tuple[float, float]
    coeffs: np.ndarray  # (r + 2 PAD, s + 2 PAD, 3) float32

    @property
    def lam_cell(self) -> float:
        return self.lam * self.cell[0] * self.cell[1]


def noise_setup(texton: Texton, mni: float, period=None, cell_factor: float = CELL_FACTOR) -> NoiseSetup:
    """Intensity, cell grid and support box of the noise of ``texton``."""
    _warp()  # configure Warp before the kernel module imports it
    if not isinstance(texton, Texton):
        raise TextonError(f"texton must be a Texton, got {type(texton).__name__}")
    mni = check_positive(mni, "mni")
    cell_factor = check_positive(cell_factor, "cell_factor")
    if texton.support_area == 0:
        raise TextonError("texton: every coefficient is zero, so its noise is the constant mean; nothing to synthesize")
    r, s = texton.size
    k = texton.order
    reach = 0.5 if k == 0 else (k + 1) / 2.0  # ψ is supported on [-reach, reach]
    lo = (-reach, -reach)
    hi = (s - 1 + reach, r - 1 + reach)
    side = cell_factor * max(hi[0] - lo[0], hi[1] - lo[1])
    if period is None:
        cell = (side, side)
        period_cells = (0, 0)
    else:
        px, py = _check_period(period)
        nx = max(1, round(px / side))
        ny = max(1, round(py / side))
        cell = (px / nx, py / ny)
        period_cells = (nx, ny)
    # The kernels hold the cell side in float32: use that same value on the host,
    # so that host-placed blocks and kernel-placed cells coincide far from the origin.
    cell = tuple(float(np.float32(c)) for c in cell)
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
            f"cell_factor {cell_factor:g} makes cells hold {lam * cell[0] * cell[1]:.3g} impacts on average "
            f"(at most {MAX_CELL_MEAN:g}); use a smaller cell_factor (default {CELL_FACTOR})"
        )
    return NoiseSetup(lam, cell, period_cells, lo, hi, padded_coeffs(texton))


def padded_coeffs(texton: Texton) -> np.ndarray:
    """The coefficients as the kernels read them: (r + 2 PAD, s + 2 PAD, 3) float32,
    a zero margin of PAD texels around, unused channels zero."""
    from .kernels.noise2d import PAD

    r, s = texton.size
    coeffs = np.zeros((r + 2 * PAD, s + 2 * PAD, 3), np.float32)
    coeffs[PAD:PAD + r, PAD:PAD + s, : texton.channels] = texton.coeffs
    return coeffs


def _check_cell_range(lo: float, hi: float, cell: float, what: str) -> None:
    """Positions whose cell indices would not fit the kernels' int32 are refused."""
    if max(abs(lo), abs(hi)) / cell >= MAX_CELL_INDEX:
        raise TextonError(
            f"{what} reach {max(abs(lo), abs(hi)):.3g} texels from the origin; the noise is defined "
            f"within ±{MAX_CELL_INDEX * cell:.3g} texels (2**30 cells)"
        )


def _check_period(period) -> tuple[float, float]:
    try:
        px, py = period
    except (TypeError, ValueError):
        raise TextonError(f"period must be a pair (Px, Py) of positive numbers, got {period!r}") from None
    return check_positive(px, "period[0]"), check_positive(py, "period[1]")


def _params(wp, texton: Texton, setup: NoiseSetup, seed: int, poisson: str):
    from .kernels.impacts import Cells
    from .kernels.noise2d import NoiseParams

    if poisson not in POISSON_MODES:
        raise TextonError(f"poisson must be one of {', '.join(POISSON_MODES)}, got {poisson!r}")
    cells = Cells()
    cells.size = wp.vec2(*setup.cell)
    cells.period = wp.vec2i(*setup.period_cells)
    cells.mean_count = setup.lam_cell
    cells.seed = wp.uint32(seed)
    cells.exact_poisson = 1 if poisson == "exact" else 0
    p = NoiseParams()
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


def _threads() -> int:
    return max(1, os.cpu_count() or 1)


def _raster_geometry(shape, scale, rotation, offset):
    """Pixel (i, j) ↦ x = offset + R(rotation) ((j + ½)/scale, (i + ½)/scale)."""
    scale = check_positive(scale, "scale")
    try:
        rotation = float(rotation)
        ox, oy = (float(v) for v in offset)
    except (TypeError, ValueError):
        raise TextonError(f"rotation must be a number and offset a pair (x, y), got {rotation!r}, {offset!r}") from None
    if not (math.isfinite(rotation) and math.isfinite(ox) and math.isfinite(oy)):
        raise TextonError("rotation and offset must be finite")
    th = math.radians(rotation)
    rot = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    with np.errstate(over="ignore"):
        step = rot / scale  # columns: noise step per pixel along x (j) and along y (i)
    h, w = shape
    if not np.isfinite(step).all() or not np.isfinite(step * max(h, w)).all():
        raise TextonError(f"scale {scale!r} is too small: pixel positions overflow")
    return np.array([ox, oy]), step


def synthesize(
    texton: Texton,
    shape=(512, 512),
    mni: float = 30.0,
    seed: int = 0,
    scale: float = 1.0,
    rotation: float = 0.0,
    offset=(0.0, 0.0),
    period=None,
    device=None,
    *,
    poisson: str = "exact",
    cell_factor: float = CELL_FACTOR,
    method: str = "auto",
    jacobian=None,
    filter: str = "none",
    supersample: int = SUPERSAMPLE,
    max_aniso: int = MAX_ANISO,
    fade_energy: float = FADE_ENERGY,
) -> np.ndarray:
    """Texton noise on an H × W raster.

    Pixel (i, j) is the noise at x = offset + R(rotation) · ((j + ½)/scale, (i + ½)/scale)
    in texel units, so ``scale`` is pixels per texel and ``rotation`` (degrees)
    turns the noise. Any window of the infinite noise can be made, and windows
    whose offsets differ by their width join without a seam.

    Parameters
    ----------
    texton : Texton
    shape : (height, width)
    mni : float
        Mean number of impacts per point; λ = mni / texton.support_area.
    seed : int
        In [0, 2**32).
    scale, rotation, offset
        The raster's placement in the noise (see above).
    period : (Px, Py), optional
        Make the noise exactly periodic with these periods (texel units):
        ``synthesize(t, (H, W), period=(W, H))`` is a seamless tile.
    device : str, optional
        "cpu", "cuda", "cuda:N"; default CUDA when available, else CPU.
    poisson : {"exact", "gaussian"}
        Cell counts exactly Poisson, or the rounded Gaussian approximation of
        the authors' viewer.
    cell_factor : float
        Cell side relative to the texton support side (CGF §8 uses ~0.6).
    method : {"auto", "splat", "gather"}
        How the raster is computed; both give the same noise. "auto" splats
        on the CPU (threads own row bands) and gathers on CUDA (a thread per
        pixel).
    jacobian : array (2, 2) or (height, width, 2, 2), optional
        Each pixel's footprint in texel space: columns are the texel-space
        steps of one pixel to the right and one pixel down. Default: the
        raster's own steps, R(rotation) / scale. Only the filters read it.
    filter : {"none", "mip", "anisotropic", "supersample"}
        Anti-aliasing for the footprint (CGF §5): "mip" looks the texton up
        in a MIP pyramid at the footprint's major length, "anisotropic" also
        averages up to ``max_aniso`` lookups along its major axis, "supersample" averages
        ``supersample``² jittered evaluations over the footprint (the
        reference). Where every footprint needs a single lookup of the
        unfiltered texton (up to about 2.5 texels for "mip", 1.5 for round
        footprints with "anisotropic"), "mip" and "anisotropic" are exactly
        "none". Footprints past the last kept MIP level fade to the texton
        mean; supersamples beyond the noise's cell range count as the mean.
    supersample : int
        Samples per pixel side for ``filter="supersample"``.
    max_aniso : int
        Most lookups along a footprint's major axis for "anisotropic"; past
        that anisotropy the level rises instead.
    fade_energy : float
        The MIP pyramid ends at the first level whose noise keeps less than
        this fraction of the variance; larger footprints fade to the mean
        (0 keeps every level).

    Returns
    -------
    float32 array (height, width, C)

    References
    ----------
    CGF eq. (1)-(2), §3.3, §4, §5, §8.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton, synthesize
    >>> t = Texton(np.random.default_rng(0).standard_normal((8, 8, 1)) / 8, [0.5])
    >>> synthesize(t, (32, 48), device="cpu").shape
    (32, 48, 1)
    """
    h, w = check_shape(shape)
    seed = check_seed(seed)
    setup = noise_setup(texton, mni, period, cell_factor)
    origin, step = _raster_geometry((h, w), scale, rotation, offset)
    filter = check_filter(filter)
    J = None if jacobian is None else check_jacobian(jacobian, (h, w))
    supersample, max_aniso = check_filter_options(supersample, max_aniso)
    fade_energy = check_fade_energy(fade_energy)
    device = resolve_device(device)
    wp = _warp()
    p = _params(wp, texton, setup, seed, poisson)
    if needs_filtering(step if J is None else J, filter, max_aniso):
        _raster_reach(origin, step, (h, w), setup)
        out = filtered_raster(wp, p, texton, setup, (h, w), origin, step, J, device, filter, supersample, seed,
                              max_aniso, fade_energy)
        return np.ascontiguousarray(out[:, :, : texton.channels])
    out = _raster(wp, p, setup, setup.coeffs, texton.order, (h, w), origin, step, device, method, scale)
    return np.ascontiguousarray(out[:, :, : texton.channels])


def _raster_reach(origin, step, shape, setup: NoiseSetup):
    """(x0, x1, y0, y1): the texel box whose cells the raster reads (its corners'
    box grown by the support), refused where cell indices would not fit int32."""
    h, w = shape
    corners = origin[:, None] + step @ np.array([[0, w, 0, w], [0, 0, h, h]], dtype=np.float64)
    x0, x1 = corners[0].min() - setup.hi[0], corners[0].max() - setup.lo[0]
    y0, y1 = corners[1].min() - setup.hi[1], corners[1].max() - setup.lo[1]
    _check_cell_range(x0, x1, setup.cell[0], "the raster's positions")
    _check_cell_range(y0, y1, setup.cell[1], "the raster's positions")
    return x0, x1, y0, y1


@dataclass(frozen=True)
class _Regions:
    """How mixed noise picks each impact's texton (see kernels.noise2d.label_impacts)."""

    count: int  # number of stacked textons
    rho: np.ndarray | None  # (H, W) float32 ρ map, or None for vertical strips


def _raster(wp, p, setup: NoiseSetup, coeffs: np.ndarray, order: int, shape, origin, step, device,
            method: str, scale, regions: _Regions | None = None) -> np.ndarray:
    """Evaluate the noise of ``p`` on a raster: (H, W, 3) float32 of normalised values.

    ``coeffs`` holds one padded texton, or ``regions.count`` of them stacked
    along the rows for mixed noise (then values are Σ ε h / √λ, without mean).
    """
    from .kernels import noise2d as K

    h, w = shape
    if method not in METHODS:
        raise TextonError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    on_cpu = wp.get_device(device).is_cpu
    if method == "auto":
        method = "splat" if on_cpu else "gather"
    if method == "splat" and not on_cpu:
        raise TextonError('method "splat" runs on the CPU only (its launches must not overlap); use "gather"')
    cw, ch = setup.cell
    # Noise-space bounding box of the raster, grown by the support: the block of cells to draw.
    x0, x1, y0, y1 = _raster_reach(origin, step, (h, w), setup)
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
    with wp.ScopedDevice(device):
        impacts, offsets = _draw_block(wp, K, p, (cx0, cy0), ncx, ncy)
        n = impacts.shape[0]
        raster = K.Raster()
        # positions relative to the block corner, computed in float64 before rounding
        base = origin - np.array([cx0 * cw, cy0 * ch])
        raster.base = wp.vec2(*base)
        raster.step_x = wp.vec2(*step[:, 0])
        raster.step_y = wp.vec2(*step[:, 1])
        raster.width = w
        raster.height = h
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
                wp.launch(K.label_impacts, dim=n, inputs=[impacts, raster, inv, int(regions.rho is None),
                                                          regions.count, wp.array(rho, dtype=float), marks.labels])
        bands = np.linspace(0, h, min(h, 2 * _threads()) + 1).astype(int)
        bands = [(r0, r1) for r0, r1 in zip(bands[:-1], bands[1:]) if r1 > r0]
        if on_cpu:
            # calloc'd pages are zeroed lazily, by the threads that first touch them
            host = np.zeros((h, w, 3), np.float32)
            out = wp.array(host, dtype=wp.vec3, copy=False)
            result = host
        else:
            out = wp.empty((h, w), dtype=wp.vec3)
        if method == "splat":
            on_grid = order == 1 and np.array_equal(step, np.eye(2))

            def run(band):
                r0, r1 = band
                if n and on_grid:
                    wp.launch(K.splat_impacts_grid, dim=n,
                              inputs=[raster.base, stack, impacts, marks, w, r0, r1, out])
                elif n:
                    wp.launch(K.splat_impacts, dim=n, inputs=[p, raster, inv, stack, impacts, marks, r0, r1, out])
                wp.launch(K.normalize_raster, dim=(r1 - r0, w), inputs=[p, r0, out])
        else:

            def run(band):
                r0, r1 = band
                wp.launch(K.gather_raster, dim=(r1 - r0, w),
                          inputs=[p, raster, stack, impacts, offsets, marks, ncx, ncy, r0, out])

        if on_cpu:
            # one CPU launch runs on one thread; Warp releases the GIL during it
            wp.load_module(K, device=device)
            with ThreadPoolExecutor(_threads()) as pool:
                list(pool.map(run, bands))
        else:
            run((0, h))
            result = out.numpy()
    return result


def map_points(wp, module, device, n: int, launch) -> np.ndarray:
    """Run ``launch(indices) -> (len, 3) array`` over n points, into an (n, 3) array.

    On the CPU the points are split into chunks launched from a thread pool (one
    CPU launch runs on one thread; Warp releases the GIL meanwhile); on CUDA
    there is one launch.
    """
    out = np.zeros((n, 3), np.float32)
    if not n:
        return out
    if not wp.get_device(device).is_cpu:
        out[:] = launch(np.arange(n))
        return out
    wp.load_module(module, device=device)

    def run(idx):
        if idx.size:
            out[idx] = launch(idx)

    with ThreadPoolExecutor(_threads()) as pool:
        list(pool.map(run, np.array_split(np.arange(n), min(n, 4 * _threads()))))
    return out


def _draw_block(wp, K, p, cell0, ncx: int, ncy: int):
    """Impacts of the ncx × ncy cells from cell0, grouped by cell, with offsets."""
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


def evaluate(
    texton: Texton,
    points,
    mni: float = 30.0,
    seed: int = 0,
    device=None,
    *,
    period=None,
    poisson: str = "exact",
    cell_factor: float = CELL_FACTOR,
) -> np.ndarray:
    """Texton noise at arbitrary points.

    Parameters
    ----------
    texton : Texton
    points : array (N, 2)
        Positions (x, y) in texel units, x to the right, y down.
    mni, seed, device, period, poisson, cell_factor
        As in :func:`synthesize`; the same values give the same noise, so
        ``synthesize(t, ...)[i, j]`` equals ``evaluate`` at that pixel's position.

    Returns
    -------
    float32 array (N, C)

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton, evaluate
    >>> t = Texton(np.ones((4, 4, 1)) / 4, [0.5])
    >>> evaluate(t, [[0.5, 0.5], [1e6, -3.25]], device="cpu").shape
    (2, 1)
    """
    try:
        pts = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError):
        raise TextonError("points must be an array of shape (N, 2) of numbers") from None
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise TextonError(f"points must have shape (N, 2), got {pts.shape}")
    if not np.isfinite(pts).all():
        raise TextonError(f"points contain {int((~np.isfinite(pts)).sum())} NaN or infinite values")
    seed = check_seed(seed)
    setup = noise_setup(texton, mni, period, cell_factor)
    if pts.size:
        _check_cell_range(pts[:, 0].min() - setup.hi[0], pts[:, 0].max() - setup.lo[0], setup.cell[0], "points")
        _check_cell_range(pts[:, 1].min() - setup.hi[1], pts[:, 1].max() - setup.lo[1], setup.cell[1], "points")
    device = resolve_device(device)
    wp = _warp()
    p = _params(wp, texton, setup, seed, poisson)
    out = point_values(wp, p, setup.coeffs, pts, device)
    return np.ascontiguousarray(out[:, : texton.channels])
