"""Batches of rasters: many small rasters of texton noise, each with its own texton,
seed, scale, rotation and offset, computed together (synthetic data).

:func:`synthesize_batch` draws each item's parameters (:class:`BatchParams`),
prices the whole batch once, then puts its plain items into one
count/emit/splat pass (CPU) or one gather launch (CUDA) per group of about
``canvas.STRIP_WORK`` pixels; filtered items go through the filters one by one.
Item k equals :func:`warp_texton.synthesize` with ``Batch.params.item(k)``.
Batches of tiling models (:class:`~warp_texton.model.tiling.TilingModel`) run item by item
through ``synthesize`` (one launch each: a tiling item has no impacts to share).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..model.noise_tables import at_mni
from ..core.checks import check_int, check_positive, check_seed, check_shape
from ..core.runtime import progress_bar, resolve_device
from .canvas import Canvas, check_output, group_size, lanes_for, result_bytes
from ..core.errors import TextonError
from .filtering import (COST_HINT_NAMES, FILTER_BYTES_PER_PIXEL, FilterOptions, RasterPixels, filter_pixels,
                        needs_filtering, pixel_shares)
from ..core.limits import check_memory, check_work, work_budget
from .engine import CELL_FACTOR, NoiseSetup, noise_setup, params_record, params_struct
from .raster import (RasterWindow, TextonStack, check_method, check_raster_cost, raster_cost, raster_geometry,
                     raster_reach, rasters, resolve_method, window_block)
from .synthesis import check_tiling_reach, filtered_work, synthesize
from ..model.texton import Texton
from ..model.tiling import TilingModel

#: Host memory per batch item besides its pixels: its drawn parameters (NumPy) and its
#: window (a small Python object with its geometry): 1.2 KiB measured (tracemalloc, 20 000 items
#: of 1x1 pixels), rounded up.
BATCH_ITEM_BYTES = 2048
#: Work per batch item besides its pixels, in operations: drawing its window, its parameters'
#: record and its block is Python code of about 90 us an item (100 000 items of 1x1 pixels in
#: 9.0 s on the two-core CPU of docs/limits.md), which the raster path's 7e8 operations / s
#: would spend on 6.5e4 operations; rounded up, so a million items are refused by the default budget.
BATCH_ITEM_OPS = 1.0e5
#: Work of one pixel of a tiling model, in operations: 512² pixels in about 11 ms on the two-core
#: CPU of docs/limits.md (docs/tiling.md), 42 ns a pixel, which the raster path's 7e8 operations / s
#: spends on 30; rounded up.
TILING_PIXEL_OPS = 32.0


@dataclass(frozen=True)
class BatchParams:
    """The parameters each item of a batch was made with (arrays of length ``count``).

    ``item(k)`` gives item k's keyword arguments for :func:`synthesize`;
    with ``textons[texton[k]]`` and the batch's other options, that call makes
    item k again, bit for bit.

    Attributes
    ----------
    texton : int64 array (count,)
        Index of each item's texton in the batch's textons.
    seed : int64 array (count,)
        Each item's noise seed, in [0, 2**32).
    scale : float64 array (count,)
        Pixels per texel.
    rotation : float64 array (count,)
        Degrees.
    offset : float64 array (count, 2)
        (x, y) of each raster's top-left corner, in texels.
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
    """What :func:`synthesize_batch` returns: ``images, params = synthesize_batch(...)``.

    Attributes
    ----------
    images : float32 array (count, height, width, C)
        NumPy, or a ``wp.array`` for ``output="warp"``.
    params : BatchParams
        What each item was made with.
    """

    images: object  # (count, H, W, C) float32: NumPy or wp.array
    params: BatchParams


def _check_textons(textons) -> list:
    if isinstance(textons, (Texton, TilingModel)):
        return [textons]
    try:
        textons = list(textons)
    except TypeError:
        raise TextonError(f"textons must be a Texton, a TilingModel or a list of them, got "
                          f"{type(textons).__name__}") from None
    if not textons:
        raise TextonError("textons is empty; give at least one Texton or TilingModel")
    for k, t in enumerate(textons):
        if not isinstance(t, (Texton, TilingModel)):
            raise TextonError(f"textons[{k}] must be a Texton or a TilingModel, got {type(t).__name__}")
        if type(t) is not type(textons[0]):
            raise TextonError(f"textons[{k}] is a {type(t).__name__} but textons[0] a {type(textons[0]).__name__}; "
                              "a batch's models must all be textons or all tiling models (make separate batches)",
                              param="textons")
        if t.channels != textons[0].channels:
            raise TextonError(
                f"textons[{k}] has {t.channels} channel(s) but textons[0] has {textons[0].channels}; a batch's "
                "textons must have the same channel count (make separate batches, or give grey textons three "
                "equal channels)"
            )
    return textons


def _finite_pair(value, name: str) -> tuple[float, float]:
    try:
        if any(isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real) for v in value):
            raise TypeError  # strings such as "1" would pass float()
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        raise TextonError(f"{name} must be a number, a (lo, hi) range or an array of one value per item, "
                          f"got {value!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise TextonError(f"{name} range must be finite numbers, got ({lo}, {hi})")
    if lo > hi:
        raise TextonError(f"{name} range must have lo <= hi, got ({lo}, {hi})")
    return lo, hi


def _numeric_array(value: np.ndarray, name: str) -> None:
    """Refuse arrays of strings, objects, booleans or complex numbers: NumPy would
    convert some of them (``np.array(["1.0"])``) silently."""
    if value.dtype.kind not in "iuf":
        raise TextonError(f"{name}: an array must hold real numbers (int or float dtype), got dtype {value.dtype}")


def _per_item(value, name: str, count: int, rng, *, log: bool = False, positive: bool = False) -> np.ndarray:
    """A number (every item), a (lo, hi) tuple or list (drawn uniformly, log-uniformly
    for ``log``), or a NumPy array of one value per item."""
    if isinstance(value, np.ndarray):
        _numeric_array(value, name)
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
        _numeric_array(value, "offset")
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
        entropy: int | list[int] = [int(s) for s in seeds]
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
    *,
    mni: float = 30.0,
    seed=0,
    scale=1.0,
    rotation=0.0,
    offset=(0.0, 0.0),
    period=None,
    device=None,
    texton_index=None,
    poisson: str = "exact",
    cell_factor: float = CELL_FACTOR,
    method: str = "auto",
    filter="none",
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
    textons : Texton, TilingModel or a list of them
        Textons of one channel count; their sizes and orders may differ. Or
        tiling models (``analyze(..., method="tiling")``) of one channel count:
        each item is then ``synthesize(model, shape, **params.item(k))``
        (the texton-noise options ``mni``, ``period``, ``poisson``,
        ``cell_factor``, ``method`` and ``filter`` go to :func:`synthesize`,
        which refuses what a tiling model does not support).
    count : int
        Number of rasters, >= 1 (their memory must fit the budget of
        :mod:`warp_texton.core.limits`).
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
    period : (Px, Py), optional
        As in :func:`synthesize`, for every item.
    filter : str or FilterOptions
        As in :func:`synthesize`, for every item.
    device : str, optional
        As in :func:`synthesize`, for every item.
    poisson : {"exact", "gaussian"}
        As in :func:`synthesize`, for every item.
    cell_factor : float
        As in :func:`synthesize`, for every item.
    method : {"auto", "splat", "gather"}
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
        ``(images, params)``: float32 (count, height, width, C) (NumPy, or a
        ``wp.array`` for ``output="warp"``) and the :class:`BatchParams` of
        the items (arrays ``texton``, ``seed``, ``scale``, ``rotation``,
        ``offset``).

    Raises
    ------
    TextonError
        For an empty or non-:class:`Texton` ``textons``, textons of different
        channel counts, ``count`` < 1 or a batch over the memory budget
        (checked before allocating), ranges with lo > hi or NaN/infinite
        bounds, arrays of the wrong shape, and whatever :func:`synthesize`
        refuses.

    Notes
    -----
    Speed against single calls: docs/scale.md, "batches".

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton, synthesize, synthesize_batch
    >>> rng = np.random.default_rng(0)
    >>> textons = [Texton(0.05 * rng.standard_normal((s, s, 3)), [0.5, 0.4, 0.3], order)
    ...            for s, order in ((16, 1), (24, 3))]
    >>> images, params = synthesize_batch(textons, 32, (64, 64), seed=7, scale=(0.5, 2.0), rotation=(0, 360),
    ...                                   offset=((-1e4, 1e4), (-1e4, 1e4)), device="cpu")
    >>> images.shape, params.texton[:4], params.item(0)["seed"]
    ((32, 64, 64, 3), array([0, 1, 0, 0]), 2926574226)
    >>> k = 5
    >>> again = synthesize(textons[params.texton[k]], (64, 64), **params.item(k), device="cpu")
    >>> bool(np.array_equal(again, images[k]))
    True

    Explicit per-item values, and the result left on the device (here the
    CPU) as a ``wp.array``:

    >>> w, _ = synthesize_batch(textons[0], 3, (32, 32), seed=np.array([1, 2, 3]),
    ...                         rotation=np.array([0.0, 45.0, 90.0]), device="cpu", output="warp")
    >>> type(w).__name__, w.shape, np.from_dlpack(w).shape
    ('array', (3, 32, 32, 3), (3, 32, 32, 3))
    """
    textons = _check_textons(textons)
    count = check_int(count, "count", minimum=1)
    h, w = check_shape(shape)
    output = check_output(output)
    if isinstance(textons[0], TilingModel):
        return _tiling_batch(textons, count, (h, w), seed, scale, rotation, offset, device, texton_index, output,
                             progress, dict(mni=mni, period=period, poisson=poisson, cell_factor=cell_factor,
                                            method=method, filter=filter))
    mni = check_positive(mni, "mni")
    options = FilterOptions.of(filter)
    check_method(method)
    channels = textons[0].channels
    device = resolve_device(device)
    lanes = lanes_for(textons)  # grey textons: one float a texel and a pixel through the kernels
    items_bytes = result_bytes(count, h, w, channels, device, output, lanes) + count * BATCH_ITEM_BYTES
    # before anything of size count is made (its parameters, its windows): what grows with count alone
    check_memory(items_bytes, f"a batch of {count} {w}x{h} rasters with {channels} channel(s)",
                 "use a smaller count or shape, or make the batch in parts")
    # a lower bound of check_batch_cost's work (every pixel looks up at least MNI impacts on average),
    # checked before the per-item setup, which is itself the cost of a batch of many tiny items; only
    # a refusal reaches check_work here, so work_log keeps one estimate per call, the full one
    bound = count * (BATCH_ITEM_OPS + h * w * mni)
    if not bound <= work_budget():
        check_work(bound, f"a batch of {count} {w}x{h} rasters at MNI {mni:.6g}",
                   "use a smaller count or shape, or a lower mni, or make the batch in parts", param="count",
                   mentions=("shape", "mni"))
    params = draw_batch_params(len(textons), count, seed, scale, rotation, offset, texton_index)
    setups = [noise_setup(t, mni, period, cell_factor) for t in textons]
    textons = [at_mni(t, mni) for t in textons]  # the histogram tables of this MNI's noise
    stack = TextonStack.of([s.coeffs for s in setups], lanes)
    windows, filtered = {}, []
    for k in range(count):
        i = int(params.texton[k])
        kw = params.item(k)
        origin, step = raster_geometry((h, w), kw["scale"], kw["rotation"], kw["offset"])
        rec = params_record(textons[i], setups[i], kw["seed"], poisson)
        win = RasterWindow(rec, setups[i], i, textons[i].order, origin, step, (0, 0), kw["scale"])
        if needs_filtering(step, options):
            raster_reach(origin, step, (h, w), setups[i])  # far positions are refused before any allocation
            filtered.append((k, win))
        else:
            windows[k] = (win, window_block(win, (h, w)))  # refuses them too (raster_reach)
    # plain items in groups of consecutive items, so each group writes one block of rows
    per_group = group_size(h, w)
    groups = [(g0, min(k1, g0 + per_group)) for k0, k1 in _runs(list(windows)) for g0 in range(k0, k1, per_group)]
    method = resolve_method(method, device) if windows else method
    check_batch_cost(textons, setups, h, w, windows, groups, filtered, stack, options, method, items_bytes)
    canvas = Canvas((count, h, w), device, lanes)
    rows = canvas.rows(w)
    bar = progress_bar(progress, count, "synthesize_batch", "image")
    try:
        for g0, g1 in groups:
            group = [windows[k] for k in range(g0, g1)]
            rasters([win for win, _ in group], stack, (h, w), device, method, rows[g0 * h: g1 * h],
                    blocks=[block for _, block in group])
            bar.update(g1 - g0)
        for k, win in filtered:
            t = textons[win.texton]
            pixels = RasterPixels((h, w), win.origin, win.step, win.step)
            filter_pixels(params_struct(win.p), t, win.setup, pixels, options, device, params.item(k)["seed"],
                          out=canvas.pixels(k * h * w, (k + 1) * h * w))
            if t.histogram is not None:
                canvas.keep_shares(k * h * w, (k + 1) * h * w, pixel_shares(t, pixels, options))
            bar.update(1)
    finally:
        bar.close()
    return Batch(canvas.result(channels, output, textons=[textons[int(i)] for i in params.texton]), params)


def check_batch_cost(textons: list[Texton], setups: list[NoiseSetup], h: int, w: int, windows: dict, groups: list,
                     filtered: list, stack: TextonStack, options: FilterOptions, method: str,
                     items_bytes: float) -> None:
    """The budget check of a batch: its output and items (``items_bytes``) with the
    largest group's blocks or one filtered item's pixels in memory; the work of
    every group and every filtered item, and every item's setup (BATCH_ITEM_OPS)."""
    work, nbytes = (len(windows) + len(filtered)) * BATCH_ITEM_OPS, 0.0
    for g0, g1 in groups:
        group = [windows[k] for k in range(g0, g1)]
        group_bytes, group_work, _ = raster_cost([win for win, _ in group], (h, w), stack,
                                                 blocks=[block for _, block in group], splat=method == "splat")
        work += group_work
        nbytes = max(nbytes, group_bytes)
    if filtered:
        nbytes = max(nbytes, h * w * FILTER_BYTES_PER_PIXEL)
        for i, (t, setup) in enumerate(zip(textons, setups)):
            steps = np.array([win.step for _, win in filtered if win.texton == i]).reshape(-1, 2, 2)
            if steps.shape[0]:
                work += filtered_work(t, setup, steps, options, len(steps) * h * w)
    mni = max(s.mni for s in setups)
    what = f"a batch of {len(windows) + len(filtered)} {w}x{h} rasters at MNI {mni:.6g}"
    if filtered:
        what += f" ({len(filtered)} with filter {options.kind!r})"
    check_raster_cost(items_bytes + nbytes, work, what, "use a smaller count or shape, or make the batch in parts",
                      options.spec.cost_hint if filtered else "use a smaller count or shape, or a lower mni",
                      mentions=("count", "shape", *COST_HINT_NAMES))


def _runs(items: list[int]) -> list[tuple[int, int]]:
    """Maximal runs [k0, k1) of consecutive integers in the sorted list ``items``."""
    runs: list[list[int]] = []
    for k in items:
        if runs and runs[-1][1] == k:
            runs[-1][1] = k + 1
        else:
            runs.append([k, k + 1])
    return [(a, b) for a, b in runs]


def _tiling_batch(models: list[TilingModel], count: int, shape: tuple[int, int], seed, scale, rotation, offset,
                  device, texton_index, output: str, progress: bool, options: dict) -> Batch:
    """:func:`synthesize_batch` of tiling models: item k is ``synthesize(models[params.texton[k]], shape,
    **params.item(k), **options)``, computed item by item (bit for bit that call)."""
    h, w = shape
    channels = models[0].channels
    # what synthesize refuses for every item (texton-noise options), before anything is made
    synthesize(models[0], (1, 1), device="cpu", **options)
    device = resolve_device(device)
    items_bytes = result_bytes(count, h, w, channels, device, output) + count * BATCH_ITEM_BYTES
    what = f"a batch of {count} {w}x{h} rasters of a tiling model"
    check_memory(items_bytes, what, "use a smaller count or shape, or make the batch in parts")
    check_work(count * (BATCH_ITEM_OPS + h * w * TILING_PIXEL_OPS), what,
               "use a smaller count or shape, or make the batch in parts", param="count", mentions=("shape",))
    params = draw_batch_params(len(models), count, seed, scale, rotation, offset, texton_index)
    corners = np.array([[0, 0], [w, 0], [0, h], [w, h]], np.float64).T
    for k in range(count):  # far positions are refused before any item is computed
        kw = params.item(k)
        origin, step = raster_geometry((h, w), kw["scale"], kw["rotation"], kw["offset"])
        check_tiling_reach((origin[:, None] + step @ corners).T)
    images = np.empty((count, h, w, channels), np.float32)
    bar = progress_bar(progress, count, "synthesize_batch", "image")
    try:
        for k in range(count):
            images[k] = synthesize(models[int(params.texton[k])], (h, w), **params.item(k), device=device,
                                   **options)
            bar.update(1)
    finally:
        bar.close()
    if output == "warp":
        import warp as wp

        return Batch(wp.array(images, dtype=float, device=device), params)
    return Batch(images, params)
