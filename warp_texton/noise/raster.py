"""Rasters of plane noise: windows of one global raster, their impact blocks, splat or gather.

A raster is placed in the noise by an origin and a step per pixel
(:func:`raster_geometry`); a :class:`RasterWindow` is any rectangle of it, so a
large raster computed in strips or chunks is bit for bit the same as one call.
:func:`rasters` computes many windows in one pass: the impacts of the cells
under each window are drawn once (a count pass, a prefix sum, an emit pass);
on the CPU each thread then *splats* every impact's texton into the band of
rows it owns, so no pixel ever tests impacts that miss it; on CUDA one thread
per pixel gathers the impacts of its neighbouring cells.

The budgets are the front ends' to check, once per call, with
:func:`raster_cost`; this module refuses only what the kernels cannot index
(int32 cells and impacts).

Kernels driven here: ``warp_texton.kernels.noise_raster``.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np
import warp as wp

from ..core.checks import as_real_array, check_positive, check_real, check_shape
from ..core.runtime import BANDS_PER_THREAD, is_cpu, split_launch
from .canvas import LANES, VEC3_BYTES, Canvas, strips
from ..core.errors import TextonError
from ..kernels import noise_raster
from ..core.limits import check_memory, check_work, checkpoint
from .engine import NoiseSetup, check_cell_range, check_pair, lookup_cost, record_dtype

#: Raster strategies: "splat" (each impact adds its texton to the pixels it
#: covers; CPU default) and "gather" (each pixel sums nearby impacts; CUDA default).
METHODS = ("auto", "splat", "gather")
#: Refuse rasters whose cell block would exceed this many cells (a tiny scale
#: makes one pixel cover huge areas of the noise).
MAX_CELLS = 1 << 26
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
#: Bytes per cell of a block: its impact count and its offset (int32 each, with
#: the prefix sum's copy).
CELL_BYTES = 8
#: Standard deviations of the Poisson count added to a block's expected impacts:
#: a bound that a block's real count exceeds with negligible probability.
IMPACT_SIGMAS = 10

#: Pixel windows are placed with int32 indices in the kernels.
MAX_PIXEL_INDEX = 1 << 30


def check_pixel_offset(pixel_offset) -> tuple[int, int]:
    """A pair (row, column) of integers within ±2**30: where a window starts in the global raster."""
    try:
        r, c = pixel_offset
    except (TypeError, ValueError):
        raise TextonError(f"pixel_offset must be a pair (row, column) of integers, got {pixel_offset!r}") from None
    out = []
    for v, name in ((r, "pixel_offset[0] (row)"), (c, "pixel_offset[1] (column)")):
        if isinstance(v, bool) or not isinstance(v, numbers.Integral):
            raise TextonError(f"{name} must be an integer, got {v!r}")
        if abs(int(v)) > MAX_PIXEL_INDEX:
            raise TextonError(f"{name} must be within ±2**30, got {v}")
        out.append(int(v))
    return out[0], out[1]


def raster_placement(shape, scale, rotation, offset, pixel_offset=(0, 0)):
    """((H, W), first, origin, step): a raster's checked shape and pixel offset and the geometry
    (:func:`raster_geometry`) that places its pixels, for every front end that takes a raster."""
    h, w = check_shape(shape)
    first = check_pixel_offset(pixel_offset)
    origin, step = raster_geometry((h, w), scale, rotation, offset)
    return (h, w), first, origin, step


def check_points(points, bytes_per_point: float, what: str) -> np.ndarray:
    """Positions (N, 2) (x, y) in texel units, checked: shape, memory (``bytes_per_point`` each, priced before
    any pass over them: a broadcast array of 10**9 points is 16 bytes, its copy 16 GB) and finite values."""
    pts = as_real_array(points, "points", "an array of shape (N, 2) of numbers")
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise TextonError(f"points must have shape (N, 2), got {pts.shape}", param="points")
    check_memory(pts.shape[0] * bytes_per_point, f"{what} {pts.shape[0]} points", "use fewer points", param="points")
    if not np.isfinite(pts).all():
        raise TextonError(f"points contain {int((~np.isfinite(pts)).sum())} NaN or infinite values", param="points")
    return pts


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
    """How mixed noise picks each impact's texton (see kernels.noise_raster.label_impacts)."""

    count: int  # number of stacked textons
    rho: np.ndarray | None  # (H, W) float32 ρ map, or None for vertical strips
    first: tuple[int, int] = (0, 0)  # the global (row, column) of the map's pixel (0, 0) and of the strips' left edge


@dataclass(frozen=True)
class RasterWindow:
    """One raster of a batch: the noise of ``p`` at pixels ``first`` + (i, j) of the
    raster that ``origin`` and ``step`` place (see :func:`raster_geometry`), with
    texton ``texton`` of the batch's :class:`TextonStack`."""

    p: np.ndarray  # the kernels' NoiseParams as a record (noise.params_record)
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
    ``count[k]`` textons of ``rows[k]`` rows each from row ``row0[k]``, ``cols[k]`` wide,
    with ``lanes`` channels a texel (1: grey textons, read and splatted as one
    float; 3: the kernels' vec3)."""

    coeffs: np.ndarray  # (total rows, width, lanes) float32
    row0: tuple
    rows: tuple
    cols: tuple
    lanes: int = 3

    @classmethod
    def of(cls, entries, lanes: int = 3) -> "TextonStack":
        """Stack padded coefficient arrays (rows, cols, 3), or (R, rows, cols, 3) for
        the R textons of mixed noise (one entry), keeping their first ``lanes``
        channels (the others must be zero: 1 for grey textons)."""
        if lanes not in LANES:
            raise ValueError(f"lanes must be one of {LANES}, got {lanes!r}")
        entries = [np.asarray(e, np.float32) for e in entries]
        entries = [e[None] if e.ndim == 3 else e for e in entries]
        width = max(e.shape[2] for e in entries)
        total = sum(e.shape[0] * e.shape[1] for e in entries)
        coeffs = np.zeros((total, width, lanes), np.float32)
        row0, at = [], 0
        for e in entries:
            n, r, c = e.shape[:3]
            coeffs[at:at + n * r, :c] = e.reshape(n * r, c, 3)[..., :lanes]
            row0.append(at)
            at += n * r
        return cls(coeffs, tuple(row0), tuple(e.shape[1] for e in entries), tuple(e.shape[2] for e in entries),
                   lanes)

    def device_array(self) -> wp.array:
        """The coefficients as the kernels read them, on the current device: float
        (one lane) or vec3."""
        if self.lanes == 1:
            return wp.array(np.ascontiguousarray(self.coeffs[..., 0]), dtype=wp.float32)
        return wp.array(self.coeffs, dtype=wp.vec3)


def window_block(win: RasterWindow, shape):
    """(cx0, cy0, ncx, ncy): the cells whose impacts can reach the window."""
    h, w = shape
    cw, ch = win.setup.cell
    x0, x1, y0, y1 = raster_reach(win.origin, win.step, shape, win.setup, win.first)
    cx0, cy0 = math.floor(x0 / cw), math.floor(y0 / ch)
    ncx, ncy = math.floor(x1 / cw) - cx0 + 1, math.floor(y1 / ch) - cy0 + 1
    if ncx * ncy > MAX_CELLS:
        raise TextonError(
            f"scale {win.scale} makes this {w}x{h} raster cover {ncx * ncy} noise cells "
            f"(at most {MAX_CELLS}); use a larger scale or a smaller raster", param="scale", mentions=("scale",)
        )
    return cx0, cy0, ncx, ncy


def block_impacts(win: RasterWindow, block) -> float:
    """The expected number of impacts in the block of cells ``block`` of ``win``."""
    _, _, ncx, ncy = block
    return win.setup.lam * ncx * ncy * win.setup.cell[0] * win.setup.cell[1]


def raster_impacts(windows, shape, blocks=None) -> float:
    """The expected number of impacts the windows' blocks hold, plus IMPACT_SIGMAS
    standard deviations; refused above MAX_IMPACTS (the kernels index impacts with int32)."""
    blocks = [window_block(win, shape) for win in windows] if blocks is None else blocks
    expected = sum(block_impacts(win, block) for win, block in zip(windows, blocks))
    bound = expected + IMPACT_SIGMAS * math.sqrt(expected)
    if bound > MAX_IMPACTS:
        raise TextonError(
            f"this raster needs about {expected:.3g} impacts (at most {MAX_IMPACTS}); "
            "use a lower mni, a larger scale or a smaller raster", mentions=("mni", "scale")
        )
    return bound


def raster_cost(windows, shape, stack: TextonStack, *, blocks=None, marked: bool = False, splat: bool = True):
    """(bytes, operations, description) of one pass over ``windows`` (see :func:`rasters`).

    Bytes: the counts and offsets of the blocks' cells, their impacts (with
    labels and signs when ``marked``), each bounded by IMPACT_SIGMAS standard
    deviations, and the texton stack; not the output, which the caller's
    :class:`~warp_texton.noise.canvas.Canvas` holds. Operations: the impacts drawn
    plus, for every pixel, the impacts whose support covers it (MNI on average)
    at :func:`~warp_texton.noise.engine.lookup_cost` operations each.
    """
    h, w = shape
    blocks = [window_block(win, shape) for win in windows] if blocks is None else blocks
    ncells = impacts = work = 0.0
    for win, block in zip(windows, blocks):
        expected = block_impacts(win, block)
        impacts += expected + IMPACT_SIGMAS * math.sqrt(expected)
        ncells += block[2] * block[3]
        on_grid = splat and win.order == 1 and np.array_equal(win.step, np.eye(2))
        work += float(h) * w * win.setup.mni * lookup_cost(win.order, on_grid)
    per_impact = MARKED_IMPACT_BYTES if marked else IMPACT_BYTES
    nbytes = CELL_BYTES * ncells + per_impact * impacts + stack.coeffs.nbytes
    mni = max(win.setup.mni for win in windows)
    what = (f"a {w}x{h} raster at MNI {mni:.6g}" if len(windows) == 1
            else f"{len(windows)} rasters of {w}x{h} at MNI up to {mni:.6g}")
    return nbytes, impacts + work, what


def check_raster_cost(nbytes: float, work: float, what: str,
                      memory_hint: str = "use a smaller raster, a larger scale or a lower mni",
                      work_hint: str = "use a smaller raster or a lower mni",
                      mentions: tuple[str, ...] = ("scale", "mni")) -> None:
    """The budget check of a call that makes rasters, once per call: ``nbytes`` (its
    output and its largest pass's :func:`raster_cost`) and ``work`` (all its passes).
    Work first: at a high MNI both are over, and the work's hint names the mni,
    which brings both down. ``mentions``: the argument names the hints speak of
    (see :class:`TextonError`)."""
    check_work(work, what, work_hint, mentions=mentions)
    check_memory(nbytes, what, memory_hint, mentions=mentions)


def check_method(method) -> str:
    """One of METHODS."""
    if not isinstance(method, str) or method not in METHODS:
        raise TextonError(f"method must be one of {', '.join(METHODS)}, got {method!r:.60}")
    return method


def resolve_method(method: str, device) -> str:
    """"splat" or "gather" for ``method`` on ``device`` ("auto": splat on the CPU,
    gather on CUDA)."""
    check_method(method)
    on_cpu = is_cpu(device)
    if method == "auto":
        return "splat" if on_cpu else "gather"
    if method == "splat" and not on_cpu:
        raise TextonError('method "splat" runs on the CPU only (its launches must not overlap); use "gather"')
    return method


def struct_array(table: np.ndarray, struct, device):
    """(a ``wp.array`` of ``struct`` holding the records of ``table``, the array that
    owns its memory): the bytes go over as they are, which skips Warp's
    per-call parsing of the struct's NumPy dtype. Keep the owner alive while
    the array is used."""
    raw = np.ascontiguousarray(table).view(np.uint8)
    owner: wp.array = wp.array(raw, dtype=wp.uint8, device=device, copy=not is_cpu(device))
    return wp.array(ptr=owner.ptr, dtype=struct, shape=(table.shape[0],), device=device), owner


def window_table(windows, blocks, stack: TextonStack, shape):
    """The kernels' Window records (NumPy structured) and each window's cell count."""
    h, w = shape
    table = np.zeros(len(windows), dtype=record_dtype(noise_raster.Window))
    ncells = np.zeros(len(windows), np.int64)
    first_cell = 0
    for b, (win, (cx0, cy0, ncx, ncy)) in enumerate(zip(windows, blocks)):
        t = table[b]
        t["p"] = win.p
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


def band_impacts(win: RasterWindow, block, i0: int, i1: int, offsets: np.ndarray, first_cell: int,
                 k0: int, k1: int) -> tuple[int, int]:
    """The impacts k0 ≤ k < k1 of ``win`` (cells from ``first_cell`` in the
    blocks' ``offsets``) that can reach its rows i0 ≤ i < i1: those of the cell
    rows whose impacts' supports meet the rows, and one more cell row each side
    (far above rounding), when the raster is unrotated (a pixel row is a row of
    the noise); all of them otherwise. A splat band visits only these: the
    others would add nothing to its rows, so the sums do not change."""
    step = win.step
    if step[0, 1] != 0.0 or step[1, 0] != 0.0 or not step[1, 1] > 0.0:
        return k0, k1
    cx0, cy0, ncx, ncy = block
    ch = win.setup.cell[1]
    r = win.first[0]
    y_lo = win.origin[1] + step[1, 1] * (r + i0 + 0.5) - win.setup.hi[1]
    y_hi = win.origin[1] + step[1, 1] * (r + i1 - 0.5) - win.setup.lo[1]
    a = max(math.floor(y_lo / ch) - 1 - cy0, 0)
    b = min(math.floor(y_hi / ch) + 1 - cy0, ncy - 1)
    if b < a:
        return k0, k0
    return max(k0, int(offsets[first_cell + a * ncx])), min(k1, int(offsets[first_cell + (b + 1) * ncx]))


def rasters(windows, stack: TextonStack, shape, device, method: str, out,
            regions: Regions | None = None, blocks=None) -> None:
    """Evaluate the noise of every window into ``out``, a (len(windows) · H, W) array
    on ``device`` of the stack's lanes (float for one, vec3 for three; zeroed for
    the splat): window b fills rows b·H….

    All windows share one count/emit pass and one splat (CPU, split into row
    bands over threads) or gather launch. ``regions`` (one window only) makes
    mixed noise: values are then Σ ε h / √λ, without the mean. ``blocks``: the
    windows' :func:`window_block`, when the caller has them already.

    The caller checks the budgets (:func:`raster_cost`); this refuses only
    blocks the kernels cannot index.
    """
    h, w = shape
    on_cpu = is_cpu(device)
    method = resolve_method(method, device)
    blocks = [window_block(win, shape) for win in windows] if blocks is None else blocks
    raster_impacts(windows, shape, blocks)
    table, ncells = window_table(windows, blocks, stack, shape)
    n_cells = int(ncells.sum())
    first_cells = np.concatenate([[0], np.cumsum(ncells)])
    with wp.ScopedDevice(device):
        wins, owner = struct_array(table, noise_raster.Window, device)
        cell_window: wp.array = wp.array(np.repeat(np.arange(len(windows), dtype=np.int32), ncells), dtype=wp.int32)
        counts = wp.zeros(n_cells + 1, dtype=wp.int32)
        wp.launch(noise_raster.count_impacts, dim=n_cells, inputs=[wins, cell_window, counts])
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
            wp.launch(noise_raster.emit_impacts, dim=n_cells, inputs=[wins, cell_window, offsets, impacts, impact_cell])
        coeffs = stack.device_array()
        marks = noise_raster.Marks()
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
                wp.launch(noise_raster.emit_signs, dim=n_cells, inputs=[wins, cell_window, offsets, marks.signs])
                # CGF §7 labels x_j for a kernel centred on x_j: the centre of the support box
                setup = windows[0].setup
                centre = wp.vec2(0.5 * (setup.lo[0] + setup.hi[0]), 0.5 * (setup.lo[1] + setup.hi[1]))
                wp.launch(noise_raster.label_impacts, dim=n, inputs=[wins, cell_window, impacts, impact_cell, centre,
                                                          int(regions.rho is None), regions.count,
                                                          wp.array(rho, dtype=float), wp.vec2i(*regions.first),
                                                          marks.labels])
        if method == "splat":
            offs = offsets.numpy()  # a view on the CPU

            def band(r0, r1):
                k0, k1 = int(starts[r0 // h]), int(starts[(r1 - 1) // h + 1])
                if r0 // h == (r1 - 1) // h:
                    b = r0 // h
                    k0, k1 = band_impacts(windows[b], blocks[b], r0 - b * h, r1 - b * h, offs, int(first_cells[b]),
                                          k0, k1)
                if k1 > k0:
                    wp.launch(noise_raster.splat_impacts, dim=k1 - k0,
                              inputs=[wins, cell_window, coeffs, impacts, impact_cell, marks, k0, h, r0, r1, out])
                wp.launch(noise_raster.normalize_rows, dim=r1 - r0, inputs=[wins, h, r0, out])
        else:

            def band(r0, r1):
                wp.launch(noise_raster.gather_raster, dim=(r1 - r0, w),
                          inputs=[wins, coeffs, impacts, offsets, marks, h, r0, out])

        split_launch(device, noise_raster, len(windows) * h, band, BANDS_PER_THREAD)


def raster(p: np.ndarray, setup: NoiseSetup, coeffs: np.ndarray, order: int, shape, origin, step, device,
           method: str, scale, regions: Regions | None = None, lanes: int = 3) -> np.ndarray:
    """Evaluate the noise of ``p`` (a :func:`~warp_texton.noise.engine.params_record`) on a
    raster in one pass, after checking its budgets: (H, W, lanes) float32 of
    normalised values (``lanes`` 1 for grey textons: one float a texel and a pixel
    through the kernels, the values of the first of three lanes).

    ``coeffs`` holds one padded texton, or ``regions.count`` of them stacked
    (R, rows, cols, 3) for mixed noise (then values are Σ ε h / √λ, without mean).
    """
    h, w = shape
    method = resolve_method(method, device)
    win = RasterWindow(p, setup, 0, order, origin, step, (0, 0), scale)
    stack = TextonStack.of([coeffs], lanes)
    blocks = [window_block(win, shape)]
    nbytes, work, what = raster_cost([win], shape, stack, blocks=blocks, marked=regions is not None,
                                     splat=method == "splat")
    # the canvas and the copy the caller makes of its channels
    check_raster_cost(nbytes + 2 * VEC3_BYTES * h * w, work, what)
    canvas = Canvas(shape, device, lanes)
    rows = canvas.rows(w)
    parts = strips(h, w)
    if len(parts) == 1:
        rasters([win], stack, shape, device, method, rows, regions, blocks)
    else:
        for r0, r1 in parts:
            # strips of rows, each placing its own impacts (the values of one pass): a caller
            # that has gone stops the computation between two (limits.cancellable)
            checkpoint()
            strip = RasterWindow(p, setup, 0, order, origin, step, (r0, 0), scale)
            rasters([strip], stack, (r1 - r0, w), device, method, rows[r0:r1], regions)
    return canvas.result(lanes, "numpy", textons=[None])  # mixed values: the caller adds the means
