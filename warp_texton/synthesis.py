"""Texton noise on rasters, batches of rasters and points: the public front ends.

Each function validates its arguments, then dispatches to the engine in
:mod:`warp_texton.noise` (plain rasters and points) or to the filters in
:mod:`warp_texton.filtering`.

Large rasters are computed in strips of rows of bounded work, each a window
of the same raster with its own block of impacts (windows are bit-identical
to the same pixels of a larger raster), so that memory for impacts stays
small, a progress bar can count strips, and Ctrl-C waits for one strip at
most. Batches put many small rasters into one count/emit/splat pass (CPU) or
one gather launch (CUDA).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ._checks import as_real_array, check_int, check_positive, check_seed, check_shape
from ._runtime import progress_bar, resolve_device
from .errors import TextonError
from .filtering import (COST_SAMPLES, FilterOptions, RasterPixels, check_filter_cost, check_jacobian,
                        filter_pixels, needs_filtering, pixel_cost)
from .limits import check_memory, check_work
from .noise import (CELL_FACTOR, IMPACT_BYTES, METHODS, STRIP_WORK, Canvas, RasterWindow, TextonStack, check_cell_range,
                    check_output, check_points_cost, noise_params, noise_setup, params_record, point_values,
                    raster_cost, raster_geometry, raster_impacts, raster_reach, rasters, result_bytes, strips,
                    window_block)
from .texton import Texton

#: Pixel windows are placed with int32 indices in the kernels.
MAX_PIXEL_INDEX = 1 << 30
#: Host memory per batch item besides its pixels: its drawn parameters (NumPy) and its
#: window (a small Python object with its geometry): 1.2 KiB measured (tracemalloc, 20 000 items
#: of 1x1 pixels), rounded up.
BATCH_ITEM_BYTES = 2048


def check_pixel_offset(pixel_offset) -> tuple[int, int]:
    """A pair (row, column) of integers within ±2**30."""
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
    filter="none",
    pixel_offset=(0, 0),
    output: str = "numpy",
    progress: bool = False,
):
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
    filter : str or FilterOptions
        Anti-aliasing for the footprint (CGF §5): "none", "mip",
        "anisotropic" or "supersample" with default settings, or a
        :class:`~warp_texton.FilterOptions` (``max_aniso``, ``supersample``,
        ``fade_energy``). Where every footprint needs a single lookup of the
        unfiltered texton, "mip" and "anisotropic" are exactly "none".
        Footprints past the last kept MIP level fade to the texton mean;
        supersamples beyond the noise's cell range count as the mean.
    pixel_offset : (row, column) of integers
        Make the result the window of pixels ``pixel_offset`` + (i, j) of the
        raster that ``offset``, ``scale`` and ``rotation`` place: windows of
        one raster are then bit for bit the same pixels as one call for the
        whole (:mod:`warp_texton.dask` computes chunks this way).
    output : {"numpy", "warp"}
        A NumPy array on the host, or a ``wp.array`` on ``device`` that is
        never copied to the host (hand it to PyTorch or JAX through DLPack:
        ``torch.from_dlpack(a)``). Supersampled values are averaged on the
        host and uploaded.
    progress : bool
        Show a progress bar over the strips of a large raster (once it has run
        for two seconds).

    Returns
    -------
    float32 array (height, width, C): NumPy, or a ``wp.array`` for ``output="warp"``

    References
    ----------
    CGF eq. (1)-(2), §3.3, §4, §5, §8.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import FilterOptions, Texton, synthesize
    >>> t = Texton(np.random.default_rng(0).standard_normal((8, 8, 1)) / 8, [0.5])
    >>> synthesize(t, (32, 48), device="cpu").shape
    (32, 48, 1)
    >>> far = synthesize(t, (16, 16), scale=0.1, filter=FilterOptions("anisotropic", max_aniso=4), device="cpu")
    >>> whole = synthesize(t, (32, 48), scale=0.7, rotation=20, device="cpu")
    >>> part = synthesize(t, (8, 8), scale=0.7, rotation=20, pixel_offset=(20, 30), device="cpu")
    >>> bool((part == whole[20:28, 30:38]).all())
    True
    """
    h, w = check_shape(shape)
    seed = check_seed(seed)
    if not isinstance(method, str) or method not in METHODS:
        raise TextonError(f"method must be one of {', '.join(METHODS)}, got {method!r:.60}")
    first = check_pixel_offset(pixel_offset)
    output = check_output(output)
    setup = noise_setup(texton, mni, period, cell_factor)
    origin, step = raster_geometry((h, w), scale, rotation, offset)
    options = FilterOptions.of(filter)
    J = step if jacobian is None else check_jacobian(jacobian, (h, w))
    device = resolve_device(device)
    raster_reach(origin, step, (h, w), setup, first)  # far positions are refused before any allocation
    filtered = needs_filtering(J, options)
    # the filters take Warp's struct; plain rasters its record, quicker to make
    p = (noise_params if filtered else params_record)(texton, setup, seed, poisson)
    whole = RasterWindow(p, setup, 0, texton.order, origin, step, (first[0], first[1]), float(scale))
    if filtered:  # the work of every pixel's lookups, judged from footprints spread over the raster
        sample = J.reshape(-1, 2, 2)
        sample = sample[np.linspace(0, len(sample) - 1, min(len(sample), COST_SAMPLES)).astype(np.int64)]
        check_filter_cost(texton, setup, h * w, sample, options, f"a {w}x{h} raster")
    else:  # the whole raster's work; its memory is that of one strip at a time (checked in rasters)
        _, work, what = raster_cost([whole], [window_block(whole, (h, w))], (h, w), TextonStack.of([setup.coeffs]),
                                    splat=method != "gather")
        check_work(work, what, "use a smaller raster or a lower mni", mentions=("mni",))
    parts = strips(h, w, pixel_cost(options, filtered))
    r0, r1 = parts[0]
    work = (r1 - r0) * w * 40 if filtered else raster_impacts([whole], (r1 - r0, w)) * IMPACT_BYTES
    check_memory(result_bytes(1, h, w, texton.channels, device, output) + work,
                 f"a {h}x{w} raster with {texton.channels} channel(s)",
                 "use a smaller shape, or warp_texton.dask.synthesize_dask (or the CLI's .zarr output) "
                 "for rasters larger than memory")
    canvas = Canvas((h, w), device)
    stack = TextonStack.of([setup.coeffs])
    rows = canvas.rows(w)
    bar = progress_bar(progress and len(parts) > 1, h, "synthesize", "row")
    try:
        for r0, r1 in parts:
            at = (first[0] + r0, first[1])
            if filtered:
                fp = J if J.ndim == 2 else J[r0:r1]
                pixels = RasterPixels((r1 - r0, w), origin, step, fp, first=at)
                filter_pixels(p, texton, setup, pixels, options, device, seed, out=canvas.pixels(r0 * w, r1 * w))
            else:
                win = RasterWindow(p, setup, 0, texton.order, origin, step, at, float(scale))
                rasters([win], stack, (r1 - r0, w), device, method, rows[r0:r1])
            bar.update(r1 - r0)
    finally:
        bar.close()
    return canvas.result(texton.channels, output)


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
    output: str = "numpy",
):
    """Texton noise at arbitrary points.

    Parameters
    ----------
    texton : Texton
    points : array (N, 2)
        Positions (x, y) in texel units, x to the right, y down.
    mni, seed, device, period, poisson, cell_factor
        As in :func:`synthesize`; the same values give the same noise, so
        ``synthesize(t, ...)[i, j]`` equals ``evaluate`` at that pixel's position.
    output : {"numpy", "warp"}
        A NumPy array, or a ``wp.array`` on ``device`` (see :func:`synthesize`).

    Returns
    -------
    float32 array (N, C): NumPy, or a ``wp.array`` for ``output="warp"``

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton, evaluate
    >>> t = Texton(np.ones((4, 4, 1)) / 4, [0.5])
    >>> evaluate(t, [[0.5, 0.5], [1e6, -3.25]], device="cpu").shape
    (2, 1)
    """
    pts = as_real_array(points, "points", "an array of shape (N, 2) of numbers")
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise TextonError(f"points must have shape (N, 2), got {pts.shape}")
    if not np.isfinite(pts).all():
        raise TextonError(f"points contain {int((~np.isfinite(pts)).sum())} NaN or infinite values")
    seed = check_seed(seed)
    output = check_output(output)
    setup = noise_setup(texton, mni, period, cell_factor)
    if pts.size:
        check_cell_range(pts[:, 0].min() - setup.hi[0], pts[:, 0].max() - setup.lo[0], setup.cell[0], "points")
        check_cell_range(pts[:, 1].min() - setup.hi[1], pts[:, 1].max() - setup.lo[1], setup.cell[1], "points")
    check_points_cost(setup, pts.shape[0], f"{pts.shape[0]} points")
    device = resolve_device(device)
    p = noise_params(texton, setup, seed, poisson)
    n = pts.shape[0]
    canvas = Canvas((n,), device)
    if n:
        point_values(p, setup.coeffs, np.ascontiguousarray(pts), device, canvas.pixels(0, n))
    return canvas.result(texton.channels, output)


# ------------------------------------------------------------------ batches
@dataclass(frozen=True)
class BatchParams:
    """The parameters each item of a batch was made with (arrays of length ``count``).

    ``item(k)`` gives item k's keyword arguments for :func:`synthesize`;
    with ``textons[texton[k]]`` and the batch's other options, that call makes
    item k again, bit for bit.
    """

    texton: np.ndarray  # int64: index into the batch's textons
    seed: np.ndarray  # int64 in [0, 2**32)
    scale: np.ndarray  # float64
    rotation: np.ndarray  # float64, degrees
    offset: np.ndarray  # float64 (count, 2)

    def __len__(self) -> int:
        return int(self.seed.shape[0])

    def item(self, k: int) -> dict:
        """``seed``, ``scale``, ``rotation`` and ``offset`` of item k, as Python numbers."""
        return {"seed": int(self.seed[k]), "scale": float(self.scale[k]), "rotation": float(self.rotation[k]),
                "offset": (float(self.offset[k, 0]), float(self.offset[k, 1]))}


class Batch(NamedTuple):
    """What :func:`synthesize_batch` returns: ``images, params = synthesize_batch(...)``."""

    images: object  # (count, H, W, C) float32: NumPy or wp.array
    params: BatchParams


def _check_textons(textons) -> list[Texton]:
    if isinstance(textons, Texton):
        return [textons]
    try:
        textons = list(textons)
    except TypeError:
        raise TextonError(f"textons must be a Texton or a list of Textons, got {type(textons).__name__}") from None
    if not textons:
        raise TextonError("textons is empty; give at least one Texton")
    for k, t in enumerate(textons):
        if not isinstance(t, Texton):
            raise TextonError(f"textons[{k}] must be a Texton, got {type(t).__name__}")
        if t.channels != textons[0].channels:
            raise TextonError(
                f"textons[{k}] has {t.channels} channel(s) but textons[0] has {textons[0].channels}; a batch's "
                "textons must have the same channel count (make separate batches, or give grey textons three "
                "equal channels)"
            )
    return textons


def _finite_pair(value, name: str) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        raise TextonError(f"{name} must be a number, a (lo, hi) range or an array of one value per item, "
                          f"got {value!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise TextonError(f"{name} range must be finite numbers, got ({lo}, {hi})")
    if lo > hi:
        raise TextonError(f"{name} range must have lo <= hi, got ({lo}, {hi})")
    return lo, hi


def _per_item(value, name: str, count: int, rng, *, log: bool = False, positive: bool = False) -> np.ndarray:
    """A number (every item), a (lo, hi) tuple or list (drawn uniformly, log-uniformly
    for ``log``), or a NumPy array of one value per item."""
    if isinstance(value, np.ndarray):
        a = np.asarray(value, np.float64).reshape(-1) if value.ndim <= 1 else None
        if a is None or a.shape[0] != count:
            raise TextonError(f"{name}: an array gives one value per item: shape ({count},), got {value.shape}")
        if not np.isfinite(a).all():
            raise TextonError(f"{name} contains NaN or infinite values")
        if positive and not (a > 0).all():
            raise TextonError(f"{name} values must be > 0, got {a[~(a > 0)][0]}")
        return a
    if isinstance(value, (tuple, list)):
        lo, hi = _finite_pair(value, name)
        if positive and lo <= 0:
            raise TextonError(f"{name} range must be > 0, got ({lo}, {hi})")
        if log:
            return np.exp(rng.uniform(math.log(lo), math.log(hi), count))
        return rng.uniform(lo, hi, count)
    v = check_positive(value, name) if positive else None
    if v is None:
        if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
            raise TextonError(f"{name} must be a finite number, a (lo, hi) range or an array, got {value!r}")
        v = float(value)
    return np.full(count, v)


def _offsets(value, count: int, rng) -> np.ndarray:
    """(count, 2): a pair (x, y) for every item, ((x_lo, x_hi), (y_lo, y_hi)) ranges,
    or a NumPy array (count, 2)."""
    if isinstance(value, np.ndarray):
        a = np.asarray(value, np.float64)
        if a.shape != (count, 2):
            raise TextonError(f"offset: an array gives one (x, y) per item: shape ({count}, 2), got {a.shape}")
        if not np.isfinite(a).all():
            raise TextonError("offset contains NaN or infinite values")
        return a
    try:
        x, y = value
    except (TypeError, ValueError):
        raise TextonError(f"offset must be a pair (x, y), a pair of ranges ((x_lo, x_hi), (y_lo, y_hi)) or an "
                          f"array ({count}, 2), got {value!r}") from None
    return np.stack([_per_item(x, "offset x", count, rng), _per_item(y, "offset y", count, rng)], axis=1)


def draw_batch_params(n_textons: int, count: int, seed, scale, rotation, offset, texton_index=None) -> BatchParams:
    """Each item's texton, seed, scale, rotation and offset (see :func:`synthesize_batch`).

    Every parameter has its own random stream, spawned from ``seed`` in a fixed
    order (texton, seed, scale, rotation, offset), so that fixing one parameter
    leaves the draws of the others unchanged.
    """
    explicit_seeds = isinstance(seed, np.ndarray)
    if explicit_seeds:
        seeds = np.asarray(seed)
        if seeds.shape != (count,) or not np.issubdtype(seeds.dtype, np.integer):
            raise TextonError(f"seed: an array gives one integer seed per item: shape ({count},), "
                              f"got {seeds.dtype} {seeds.shape}")
        if seeds.size and (seeds.min() < 0 or seeds.max() >= 2**32):
            raise TextonError("seed values must be integers in [0, 2**32)")
        entropy = [int(s) for s in seeds]
    else:
        entropy = check_seed(seed)
    streams = [np.random.default_rng(s) for s in np.random.SeedSequence(entropy).spawn(5)]
    if texton_index is None:
        index = streams[0].integers(0, n_textons, count)
    else:
        index = np.asarray(texton_index)
        if index.shape != (count,) or not np.issubdtype(index.dtype, np.integer):
            raise TextonError(f"texton_index must be an integer array of shape ({count},), got {index.dtype} {index.shape}")
        if index.size and (index.min() < 0 or index.max() >= n_textons):
            raise TextonError(f"texton_index values must be in [0, {n_textons}) (one per texton given)")
    seeds = (np.asarray(seed, np.int64) if explicit_seeds
             else streams[1].integers(0, 2**32, count, dtype=np.int64))
    return BatchParams(
        texton=np.asarray(index, np.int64),
        seed=seeds.astype(np.int64),
        scale=_per_item(scale, "scale", count, streams[2], log=True, positive=True),
        rotation=_per_item(rotation, "rotation", count, streams[3]),
        offset=_offsets(offset, count, streams[4]),
    )


def synthesize_batch(
    textons,
    count: int,
    shape=(256, 256),
    seed=0,
    mni: float = 30.0,
    scale=1.0,
    rotation=0.0,
    offset=(0.0, 0.0),
    period=None,
    filter="none",
    device=None,
    *,
    texton_index=None,
    poisson: str = "exact",
    cell_factor: float = CELL_FACTOR,
    method: str = "auto",
    output: str = "numpy",
    progress: bool = False,
) -> Batch:
    """``count`` rasters of texton noise, each with its own texton, seed, scale,
    rotation and offset, computed together.

    Item k is ``synthesize(textons[params.texton[k]], shape, mni, **params.item(k),
    period=period, filter=filter, ...)`` bit for bit, but all plain items run in
    one count/emit/splat pass (CPU: row bands split over threads) or one gather
    launch (CUDA), in groups of about STRIP_WORK pixels; items whose footprint
    needs filtering run one by one through the filters.

    Parameters
    ----------
    textons : Texton or list of Texton
        Textons of one channel count; their sizes and orders may differ.
    count : int
        Number of rasters, >= 1 (their memory must fit the budget of
        :mod:`warp_texton.limits`).
    shape : (height, width)
        The size of every raster.
    seed : int or int array (count,)
        An int seeds the draws of every item's parameters (each parameter from
        its own stream, so fixing one leaves the others' draws unchanged); an
        array gives each item's noise seed (the other draws are then seeded by
        the array).
    mni : float
        As in :func:`synthesize`, for every item.
    scale : number, (lo, hi) or array (count,)
        One scale for all, drawn log-uniformly in [lo, hi], or one per item.
    rotation : number, (lo, hi) or array (count,)
        Degrees: one for all, drawn uniformly in [lo, hi], or one per item.
    offset : (x, y), ((x_lo, x_hi), (y_lo, y_hi)) or array (count, 2)
        One offset for all, each coordinate drawn uniformly, or one per item.
        Ranges are tuples or lists; per-item values are NumPy arrays.
    period, filter, device, poisson, cell_factor, method
        As in :func:`synthesize`, for every item.
    texton_index : int array (count,), optional
        Which texton each item uses; default drawn uniformly.
    output : {"numpy", "warp"}
        A NumPy array, or a ``wp.array`` on ``device`` (see :func:`synthesize`).
    progress : bool
        Show a progress bar over the items (once the batch has run for two seconds).

    Returns
    -------
    Batch
        ``(images, params)``: float32 (count, height, width, C) and the
        :class:`BatchParams` of the items.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton, synthesize, synthesize_batch
    >>> rng = np.random.default_rng(0)
    >>> ts = [Texton(rng.standard_normal((8, 8, 3)) / 8, [0.5] * 3, order) for order in (1, 3)]
    >>> images, params = synthesize_batch(ts, 16, (32, 32), seed=1, scale=(0.5, 2.0), rotation=(0, 360),
    ...                                   device="cpu")
    >>> images.shape
    (16, 32, 32, 3)
    >>> again = synthesize(ts[params.texton[5]], (32, 32), **params.item(5), device="cpu")
    >>> bool((again == images[5]).all())
    True
    """
    textons = _check_textons(textons)
    count = check_int(count, "count", minimum=1)
    h, w = check_shape(shape)
    output = check_output(output)
    mni = check_positive(mni, "mni")
    options = FilterOptions.of(filter)
    channels = textons[0].channels
    device = resolve_device(device)
    # before anything of size count is made: the output, a group's impacts, and each
    # item's parameters and window
    check_memory(result_bytes(count, h, w, channels, device, output)
                 + min(count, max(1, STRIP_WORK // (h * w))) * h * w * 4  # a group's impacts, about
                 + count * BATCH_ITEM_BYTES,
                 f"a batch of {count} {h}x{w} rasters with {channels} channel(s)",
                 "use a smaller count or shape, or make the batch in parts")
    params = draw_batch_params(len(textons), count, seed, scale, rotation, offset, texton_index)
    setups = [noise_setup(t, mni, period, cell_factor) for t in textons]
    stack = TextonStack.of([s.coeffs for s in setups])
    windows, filtered = [], []
    for k in range(count):
        i = int(params.texton[k])
        kw = params.item(k)
        origin, step = raster_geometry((h, w), kw["scale"], kw["rotation"], kw["offset"])
        raster_reach(origin, step, (h, w), setups[i])
        if needs_filtering(step, options):
            p = noise_params(textons[i], setups[i], kw["seed"], poisson)
            filtered.append((k, RasterWindow(p, setups[i], i, textons[i].order, origin, step, (0, 0), kw["scale"])))
        else:
            p = params_record(textons[i], setups[i], kw["seed"], poisson)
            windows.append((k, RasterWindow(p, setups[i], i, textons[i].order, origin, step, (0, 0), kw["scale"])))
    canvas = Canvas((count, h, w), device)
    rows = canvas.rows(w)
    per_group = max(1, STRIP_WORK // (h * w))
    bar = progress_bar(progress, count, "synthesize_batch", "image")
    try:
        # plain items: consecutive runs of items, so each group writes one block of rows
        runs = _runs([k for k, _ in windows])
        by_item = dict(windows)
        for k0, k1 in runs:
            for g0 in range(k0, k1, per_group):
                g1 = min(k1, g0 + per_group)
                group = [by_item[k] for k in range(g0, g1)]
                rasters(group, stack, (h, w), device, method, rows[g0 * h: g1 * h])
                bar.update(g1 - g0)
        for k, win in filtered:
            t = textons[win.texton]
            pixels = RasterPixels((h, w), win.origin, win.step, win.step)
            filter_pixels(win.p, t, win.setup, pixels, options, device, params.item(k)["seed"],
                          out=canvas.pixels(k * h * w, (k + 1) * h * w))
            bar.update(1)
    finally:
        bar.close()
    return Batch(canvas.result(channels, output), params)


def _runs(items: list[int]) -> list[tuple[int, int]]:
    """Maximal runs [k0, k1) of consecutive integers in the sorted list ``items``."""
    runs = []
    for k in items:
        if runs and runs[-1][1] == k:
            runs[-1][1] = k + 1
        else:
            runs.append([k, k + 1])
    return [(a, b) for a, b in runs]
