"""Rasters larger than memory: texton noise as a lazy Dask array, and Zarr stores
written chunk by chunk on local threads, local processes or a Dask cluster.

The hashed-cell process makes every window of the noise computable on its
own, and :func:`~warp_texton.synthesize` computes a window from the global
indices of its pixels (``pixel_offset``), so each chunk here is bit for bit
the same pixels as one call for the whole raster would give. A chunk task
holds one chunk and its block of impacts, so memory is bounded by the chunks
in flight (about one per worker), however large the raster.

Needs the ``dask`` extra: ``pip install "warp-texton[dask]"`` (Dask,
``dask.distributed`` and Zarr 3).
"""

from __future__ import annotations

import functools
import json
import math
import numbers
import os
import time
from pathlib import Path
from typing import TYPE_CHECKING, cast

import numpy as np

from ..core.checks import check_int
from ..core.runtime import progress_bar, resolve_device
from .._version import __version__
from .canvas import result_bytes
from ..core.errors import TextonError
from ..files.folders import atomic_folder
from ..files.folders import check_replaceable as replaceable
from .filtering import FilterOptions, needs_filtering
from ..files.images import convert_pixels, report_clipped
from ..core.limits import check_memory, check_work
from .engine import CELL_FACTOR, noise_setup
from .noise_options import NoiseOptions
from .raster import raster_geometry, raster_reach
from .synthesis import check_tiling_reach, synthesize
from ..model.texton import Texton
from ..model.tiling import TilingModel

if TYPE_CHECKING:
    from concurrent.futures import Executor

    import dask.array

#: Host memory per chunk of a store while it is planned and written: its entry in the chunk list
#: and its Dask task (key, delayed call, graph entry); measured 1.5 KiB a chunk (tracemalloc, a
#: 4096² raster in chunks of 16), rounded up.
CHUNK_TASK_BYTES = 2048
#: Work per chunk besides its pixels, in operations: a task's setup, its synthesize call and its
#: write into the store take about 6 ms (1024 chunks of 16² written in 6.3 s, one worker, on the
#: two-core CPU of docs/limits.md), which the raster path's 7.4e8 operations / s spends on 4.5e6.
CHUNK_TASK_OPS = 5.0e6
#: Default chunk side, pixels: 4096² RGB float32 is 192 MiB while it is computed.
CHUNK = 4096
#: Pixel types of a Zarr store; float16 keeps the noise unclipped at half the
#: size of float32 (docs/scale.md).
ZARR_DTYPES = ("float16", "float32", "uint16", "uint8")
ZARR_DTYPE = "float16"
#: Each side of a raster is at most this many pixels (int32 pixel indices).
MAX_SIDE = 1 << 30
SCHEDULERS = ("threads", "processes")


def _need_dask():
    try:
        import dask  # noqa: F401
        import dask.array  # noqa: F401
    except ImportError:
        raise TextonError('warp_texton.noise.dask_arrays needs Dask: pip install "warp-texton[dask]"') from None


def check_big_shape(shape) -> tuple[int, int]:
    """(height, width) of positive integers of at most 2**30 each (no pixel-count cap:
    the raster is never held whole)."""
    try:
        h, w = shape
    except (TypeError, ValueError):
        raise TextonError(f"shape must be a pair (height, width), got {shape!r}") from None
    h = check_int(h, "shape[0] (height)", minimum=1)
    w = check_int(w, "shape[1] (width)", minimum=1)
    if max(h, w) > MAX_SIDE:
        raise TextonError(f"shape ({h}, {w}): each side must be at most 2**30 pixels")
    return h, w


def check_chunks(chunks, shape, name: str = "chunks") -> tuple[int, int]:
    """(rows, columns) of a chunk: an int for square chunks or a pair, positive and
    within the raster."""
    if isinstance(chunks, numbers.Integral) and not isinstance(chunks, bool):
        chunks = (chunks, chunks)
    try:
        ch, cw = chunks
    except (TypeError, ValueError):
        raise TextonError(f"{name} must be a positive integer or a pair (rows, columns), got {chunks!r}") from None
    ch = check_int(ch, f"{name} (rows)", minimum=1)
    cw = check_int(cw, f"{name} (columns)", minimum=1)
    h, w = shape
    if ch > h or cw > w:
        raise TextonError(f"{name} {cw}x{ch} exceed the {w}x{h} raster; use chunks of at most the raster's size")
    return ch, cw


class _Plan:
    """A validated request: the texton, the raster, its chunks and synthesize's options."""

    noise: NoiseOptions | None  # None for a tiling model

    def __init__(self, texton, shape, chunks, mni, seed, scale, rotation, offset, period, device, poisson,
                 cell_factor, method, filter, noise=None):
        if not isinstance(texton, (Texton, TilingModel)):
            raise TextonError(f"texton must be a Texton or a TilingModel, got {type(texton).__name__}")
        self.texton = texton
        self.shape = check_big_shape(shape)
        self.chunks = check_chunks(chunks, self.shape)
        if isinstance(texton, TilingModel):
            self._tiling(mni, seed, scale, rotation, offset, period, device, poisson, cell_factor, method, filter,
                         noise)
            return
        self.noise = NoiseOptions.given(noise, mni=mni, seed=seed, period=period, poisson=poisson,
                                        cell_factor=cell_factor)
        self.options = dict(noise=self.noise, scale=scale, rotation=rotation, offset=offset, device=device,
                            method=method, filter=FilterOptions.of(filter))
        # everything synthesize would refuse is refused here, once, before any chunk runs
        setup = noise_setup(texton, self.noise.mni, self.noise.period, self.noise.cell_factor)
        origin, step = raster_geometry(self.shape, scale, rotation, offset)
        raster_reach(origin, step, self.shape, setup)
        synthesize(texton, (1, 1), **{**self.options, "device": "cpu"}, pixel_offset=(0, 0))
        self.filtered = needs_filtering(step, self.options["filter"])
        if device is not None:
            resolve_device(device)

    def _tiling(self, mni, seed, scale, rotation, offset, period, device, poisson, cell_factor, method, filter,
                noise) -> None:
        """A tiling model's plan: its chunks are ``synthesize`` windows with the options as given (the
        texton-noise ones at their defaults, which ``synthesize`` checks: it refuses the others)."""
        self.noise = None
        self.options = dict(mni=mni, seed=seed, scale=scale, rotation=rotation, offset=offset, period=period,
                            device=device, poisson=poisson, cell_factor=cell_factor, method=method, filter=filter,
                            noise=noise)
        synthesize(self.texton, (1, 1), **{**self.options, "device": "cpu"}, pixel_offset=(0, 0))
        h, w = self.shape
        origin, step = raster_geometry(self.shape, scale, rotation, offset)
        check_tiling_reach((origin[:, None] + step @ np.array([[0, w, 0, w], [0, 0, h, h]], np.float64)).T)
        self.filtered = False
        if device is not None:
            resolve_device(device)

    def chunk_bytes(self, stored_itemsize: int = 0) -> int:
        ch, cw = self.chunks
        c = self.texton.channels
        return result_bytes(1, ch, cw, c, "cpu", "numpy") + ch * cw * c * stored_itemsize

    def grid(self):
        """(row0, row1, col0, col1) of every chunk, row-major."""
        h, w = self.shape
        ch, cw = self.chunks
        return [(r, min(h, r + ch), c, min(w, c + cw)) for r in range(0, h, ch) for c in range(0, w, cw)]


def _chunk(plan: _Plan, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
    # plan.options hold no output: NumPy, the default
    return cast(np.ndarray, synthesize(plan.texton, (r1 - r0, c1 - c0), pixel_offset=(r0, c0), **plan.options))


def _block(plan: _Plan, block_info=None) -> np.ndarray:
    (r0, r1), (c0, c1), _ = block_info[None]["array-location"]
    return _chunk(plan, r0, r1, c0, c1)


def synthesize_dask(
    texton: Texton | TilingModel,
    shape,
    *,
    chunks=CHUNK,
    mni: float = 30.0,
    seed: int = 0,
    scale: float = 1.0,
    rotation: float = 0.0,
    offset=(0.0, 0.0),
    period=None,
    device=None,
    poisson: str = "exact",
    cell_factor: float = CELL_FACTOR,
    noise: NoiseOptions | None = None,
    method: str = "auto",
    filter="none",
) -> dask.array.Array:
    """Texton noise on an H × W raster as a lazy ``dask.array`` of (H, W, C) float32.

    Chunk (r, c) is ``synthesize(texton, chunk shape, ..., pixel_offset=(r0, c0))``:
    bit for bit the pixels that one ``synthesize`` call for the whole raster
    would give (which memory may not allow). Nothing is computed until the
    array is; any Dask scheduler computes it, each task one chunk.

    Parameters
    ----------
    texton : Texton or TilingModel
        A texton, or a tiling model (``analyze(..., method="tiling")``): its
        chunks are ``synthesize`` windows too, bit for bit; the texton-noise
        options go to :func:`~warp_texton.synthesize` as given, which refuses
        those a tiling model does not support.
    shape : (height, width)
        Each side at most 2**30 pixels; no limit on the pixel count.
    chunks : int or (rows, columns)
        Chunk size, positive and at most the raster's; default 4096.
    mni : float
        Mean number of impacts per point, as in :func:`warp_texton.synthesize`.
    seed : int
        The noise's seed, as in :func:`warp_texton.synthesize`.
    scale : float
        Pixels per texel, as in :func:`warp_texton.synthesize`.
    rotation : float
        Degrees, counter-clockwise on screen, as in :func:`warp_texton.synthesize`.
    offset : (x, y)
        Noise position of the raster's top-left corner, texels, as in
        :func:`warp_texton.synthesize`.
    period : (Px, Py), optional
        Periods of a periodic noise, texels (``None``: it never repeats), as in
        :func:`warp_texton.synthesize`.
    device : str, optional
        Warp device, as in :func:`warp_texton.synthesize`.
    poisson : {"exact", "gaussian"}
        How the cells' impact counts are drawn, as in :func:`warp_texton.synthesize`.
    cell_factor : float
        Side of the random cells relative to the texton's support, as in
        :func:`warp_texton.synthesize`.
    noise : NoiseOptions, optional
        ``mni``, ``seed``, ``period``, ``poisson`` and ``cell_factor`` as one
        value, as in :func:`warp_texton.synthesize`.
    method : {"auto", "splat", "gather"}
        How the raster is computed, as in :func:`warp_texton.synthesize`.
    filter : str or FilterOptions
        The anti-aliasing filter, as in :func:`warp_texton.synthesize`, with a
        constant footprint (no per-pixel ``jacobian``).

    Returns
    -------
    dask.array.Array of float32, shape (height, width, C), chunks (rows, columns, C)

    Raises
    ------
    TextonError
        Everything :func:`warp_texton.synthesize` would refuse, when the array
        is made (not when a chunk runs); a side above 2**30; ``chunks`` that
        are not positive or larger than the raster; a chunk over the memory
        budget; and a missing ``dask`` extra.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton, synthesize
    >>> from warp_texton.noise.dask_arrays import synthesize_dask
    >>> t = Texton(0.015 * np.random.default_rng(1).standard_normal((16, 16, 3)), [0.5, 0.45, 0.4])
    >>> lazy = synthesize_dask(t, (1000, 1500), chunks=256, rotation=20, device="cpu")
    >>> lazy.shape, lazy.chunks[0][:2], lazy.dtype
    ((1000, 1500, 3), (256, 256), dtype('float32'))

    Only the chunks that meet a window are computed:

    >>> window = lazy[300:420, 700:900].compute()
    >>> bool(np.array_equal(window, synthesize(t, (120, 200), rotation=20, pixel_offset=(300, 700), device="cpu")))
    True
    """
    _need_dask()
    import dask.array as da

    plan = _Plan(texton, shape, chunks, mni, seed, scale, rotation, offset, period, device, poisson,
                 cell_factor, method, filter, noise)
    check_memory(plan.chunk_bytes(), f"a {plan.chunks[1]}x{plan.chunks[0]} chunk", "use smaller chunks")
    h, w = plan.shape
    ch, cw = plan.chunks
    rows = (ch,) * (h // ch) + ((h % ch,) if h % ch else ())
    cols = (cw,) * (w // cw) + ((w % cw,) if w % cw else ())
    c = texton.channels
    return da.map_blocks(functools.partial(_block, plan), chunks=(rows, cols, (c,)), dtype=np.float32,
                         meta=np.empty((0, 0, 0), np.float32), name=f"texton-noise-{_token(plan)}")


def _token(plan: _Plan) -> str:
    from dask.base import tokenize

    t = plan.texton
    colours = () if t.histogram is None else (t.histogram.matrix, t.histogram.centre, t.histogram.lut)
    if isinstance(t, TilingModel):
        model = (t.example, t.side, t.sharpness, t.guide_weight, t.blend)
        return tokenize("tiling", *model, *colours, plan.shape, plan.chunks, repr(sorted(plan.options.items())))
    return tokenize(t.coeffs, t.mean, t.order, *colours, plan.shape, plan.chunks, repr(sorted(plan.options.items())))


# --------------------------------------------------------------------- Zarr
def _store_chunk(plan: _Plan, store: str, dtype: str, r0: int, r1: int, c0: int, c1: int) -> int:
    """Compute one chunk, write it into the store, return its clipped pixel count."""
    import zarr

    data, clipped = convert_pixels(_chunk(plan, r0, r1, c0, c1), dtype, in_place=True)
    if not (Path(store) / "zarr.json").exists():
        return 0  # the write was abandoned (Ctrl-C) and its folder removed: write nothing
    zarr.open_array(store, mode="r+")[r0:r1, c0:c1, :] = data
    return clipped


def _is_our_store(path: Path) -> bool:
    meta = path / "zarr.json"
    return (meta.is_file() and meta.stat().st_size < (1 << 20)
            and "warp_texton" in json.loads(meta.read_text(encoding="utf-8")).get("attributes", {}))


def check_replaceable(path: Path, overwrite: bool) -> None:
    """An existing ``path`` may be replaced only with ``overwrite`` and only if it is a Zarr
    store this package wrote (a folder whose zarr.json carries the ``warp_texton`` attributes):
    --overwrite must not delete a folder of anything else."""
    replaceable(path, overwrite, _is_our_store, "a Zarr store")


def check_store_cost(plan: _Plan) -> None:
    """Price a whole store before its chunk list is made: the chunks' tasks in memory, and
    their overhead as work. Each chunk's own noise is priced when it is computed (a
    ``synthesize`` of one chunk): a store is made chunk by chunk, with a progress bar and
    Ctrl-C, so a store larger than one raster the budget allows is what it is for."""
    h, w = plan.shape
    ch, cw = plan.chunks
    n = math.ceil(h / ch) * math.ceil(w / cw)
    what = f"a {w}x{h} store cut into {n} blocks of {cw}x{ch}"
    check_memory(n * CHUNK_TASK_BYTES, what, "use larger chunks or a smaller raster", param="chunks",
                 mentions=("chunks", "shape"))
    check_work(n * CHUNK_TASK_OPS, what, "use larger chunks or a smaller raster", param="chunks",
               mentions=("chunks", "shape"))


def check_scheduler(scheduler) -> tuple[str, str | None]:
    """("threads" | "processes" | "distributed", address or None)."""
    if not isinstance(scheduler, str) or not scheduler:
        raise TextonError(f"scheduler must be threads, processes or a scheduler address, got {scheduler!r}")
    if scheduler in SCHEDULERS:
        return scheduler, None
    if "://" in scheduler or ":" in scheduler:
        return "distributed", scheduler
    raise TextonError(f"scheduler must be threads, processes or a scheduler address (host:port, tcp://host:port), "
                      f"got {scheduler!r}")


def write_zarr(
    path,
    texton: Texton | TilingModel,
    shape,
    *,
    chunks=CHUNK,
    dtype: str = ZARR_DTYPE,
    scheduler: str = "threads",
    workers: int | None = None,
    overwrite: bool = False,
    progress: bool = False,
    **options,
) -> dict:
    """Write texton noise on an H × W raster into a Zarr store, chunk by chunk.

    Each chunk is computed (:func:`synthesize_dask`'s chunks), converted to
    ``dtype`` and written by one task; at most about ``workers`` chunks are in
    memory at once. The store is made in a temporary folder beside ``path``
    and renamed into place when complete: a failed or interrupted write leaves
    nothing (with a remote cluster, chunks already running finish and find
    their folder gone).

    Parameters
    ----------
    path : str or Path
        The store (a folder, conventionally ``*.zarr``); must not exist unless ``overwrite``.
    texton : Texton or TilingModel
        As in :func:`synthesize_dask`.
    shape : (height, width)
        As in :func:`synthesize_dask`.
    chunks : int or (rows, columns)
        As in :func:`synthesize_dask`; the store's chunks are the same (all
        channels in one chunk).
    dtype : {"float16", "float32", "uint16", "uint8"}
        Stored pixel type (default float16: unclipped, half of float32).
        Integer types hold [0, 1] scaled to their range, clipped outside; the
        clipped pixels are counted and reported once.
    scheduler : str
        "threads" (default), "processes" (local worker processes), or the
        address of a ``dask.distributed`` scheduler ("tcp://host:8786"),
        whose workers must see ``path``.
    workers : int, optional
        Local threads or processes (default: the usable cores).
    overwrite : bool
        Replace an existing store (only once the new one is complete).
    progress : bool
        A progress bar over the chunks.
    **options
        mni, seed, scale, rotation, offset, period, device, poisson,
        cell_factor, noise, method, filter: as in :func:`warp_texton.synthesize`.

    Returns
    -------
    dict
        ``path``, ``shape``, ``chunks``, ``dtype``, ``clipped`` (pixels),
        ``seconds``.

    Raises
    ------
    TextonError
        For an existing store without ``overwrite``, an unknown ``dtype``,
        ``scheduler`` or option, a bad ``workers``, the errors of
        :func:`synthesize_dask`, the chunks in flight over the memory budget,
        and a missing ``dask`` extra.

    Notes
    -----
    The store's attributes record the texton, the noise options and the
    pixel convention (``attrs["warp_texton"]``). Figures for a 65536 × 65536
    store: docs/scale.md.

    Examples
    --------
    >>> import numpy as np
    >>> import zarr
    >>> from warp_texton import Texton
    >>> from warp_texton.noise.dask_arrays import write_zarr
    >>> t = Texton(0.015 * np.random.default_rng(1).standard_normal((16, 16, 3)), [0.5, 0.45, 0.4])
    >>> store = "noise.zarr"
    >>> import warnings
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")       # 1.5 % of the pixels clipped to [0, 1]
    ...     report = write_zarr(store, t, (512, 768), chunks=256, dtype="uint8", rotation=20, device="cpu")
    >>> zarr.open_array(store).shape, report["clipped"]
    ((512, 768, 3), 6022)
    """
    _need_dask()
    import zarr

    path = Path(path)
    if dtype not in ZARR_DTYPES:
        raise TextonError(f"dtype must be one of {', '.join(ZARR_DTYPES)} for a Zarr store, got {dtype!r}")
    kind, address = check_scheduler(scheduler)
    if workers is not None:
        workers = check_int(workers, "workers", minimum=1)
    unknown = set(options) - {"mni", "seed", "scale", "rotation", "offset", "period", "device", "poisson",
                              "cell_factor", "noise", "method", "filter"}
    if unknown:
        raise TextonError(f"unknown options: {', '.join(sorted(unknown))}")
    defaults = dict(mni=30.0, seed=0, scale=1.0, rotation=0.0, offset=(0.0, 0.0), period=None, device=None,
                    poisson="exact", cell_factor=CELL_FACTOR, method="auto", filter="none", noise=None)
    plan = _Plan(texton, shape, chunks, **{**defaults, **options})
    check_replaceable(path, overwrite)
    check_store_cost(plan)
    n_workers = workers or os.cpu_count() or 1
    in_flight = n_workers if kind != "distributed" else 1
    check_memory(in_flight * plan.chunk_bytes(np.dtype(dtype).itemsize),
                 f"{in_flight} chunk(s) of {plan.chunks[1]}x{plan.chunks[0]} in memory at once",
                 "use smaller chunks or fewer workers")
    h, w = plan.shape
    c = texton.channels
    t0 = time.perf_counter()
    grid = plan.grid()
    with atomic_folder(path, lambda p: check_replaceable(p, overwrite)) as tmp:
        zarr.create_array(store=str(tmp), shape=(h, w, c), chunks=(*plan.chunks, c), dtype=dtype, fill_value=0,
                          dimension_names=("y", "x", "channel"), attributes=_attributes(plan, dtype))
        task = functools.partial(_store_chunk, plan, str(tmp), dtype)
        bar = progress_bar(progress, len(grid), "zarr", "chunk")
        try:
            if address is not None:  # kind "distributed"
                clipped = _run_distributed(address, task, grid, bar)
            else:
                clipped = _run_local(kind, n_workers, task, grid, bar)
        finally:
            bar.close()
    report_clipped(path, clipped, h * w, dtype)
    return {"path": str(path), "shape": (h, w, c), "chunks": plan.chunks, "dtype": dtype, "clipped": clipped,
            "seconds": time.perf_counter() - t0}


def _attributes(plan: _Plan, dtype: str) -> dict:
    o = plan.options
    n = plan.noise
    t = plan.texton
    if isinstance(t, TilingModel) or n is None:
        return _tiling_attributes(plan, dtype)
    noise = dict(mni=n.mni, seed=n.seed, scale=o["scale"], rotation=o["rotation"], offset=list(o["offset"]),
                 period=None if n.period is None else list(n.period), poisson=n.poisson, cell_factor=n.cell_factor,
                 filter=o["filter"].kind)
    values = "noise values" if dtype.startswith("float") else f"[0, 1] scaled to 0..{np.iinfo(dtype).max}, clipped"
    return {"warp_texton": {"version": __version__, "noise": json.loads(json.dumps(noise, default=float)),
                            "texton": {"size": list(t.size), "order": t.order, "channels": t.channels,
                                       "mean": [float(v) for v in t.mean]},
                            "pixel": "(i, j) at offset + R(rotation) ((j + 1/2) / scale, (i + 1/2) / scale)",
                            "values": values}}


def _run_local(kind: str, workers: int, task, grid, bar) -> int:
    """The chunks on Dask's local scheduler, with a pool we own: on Ctrl-C the
    scheduler stops submitting, and the chunks already running finish before
    the temporary store is removed."""
    import dask
    from dask.callbacks import Callback

    if kind == "threads":
        from concurrent.futures import ThreadPoolExecutor

        pool: Executor = ThreadPoolExecutor(workers)
    else:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"))
    tasks = [dask.delayed(task, pure=True)(*g, dask_key_name=f"chunk-{i}") for i, g in enumerate(grid)]

    def done(key, result, dsk, state, worker_id):
        bar.update(1)

    try:
        with Callback(posttask=done):
            counts = dask.compute(*tasks, scheduler=kind, pool=pool, num_workers=workers)
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    return int(sum(counts))


def _run_distributed(address: str, task, grid, bar) -> int:
    """The chunks on a ``dask.distributed`` cluster: one future per chunk, counted as they finish."""
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise TextonError('a scheduler address needs dask.distributed: pip install "warp-texton[dask]"') from None
    try:
        client = Client(address, timeout=30, set_as_default=False)
    except (OSError, TimeoutError) as exc:
        raise TextonError(f"scheduler {address}: cannot connect ({exc})") from None
    futures = []
    try:
        futures = [client.submit(task, *g, key=f"texton-chunk-{os.getpid()}-{time.time_ns()}-{i}", pure=False)
                   for i, g in enumerate(grid)]
        total = 0
        for future in as_completed(futures, loop=client.loop):
            total += future.result()
            bar.update(1)
        return total
    except BaseException:
        client.cancel(futures)
        raise
    finally:
        client.close()


def _tiling_attributes(plan: _Plan, dtype: str) -> dict:
    """The store's attributes for a tiling model: the model's parameters and the options as given."""
    o = plan.options
    t = plan.texton
    assert isinstance(t, TilingModel), "a plan without noise options is a tiling model's"
    h, w, c = t.example.shape
    filt = o["filter"] if isinstance(o["filter"], str) else getattr(o["filter"], "kind", str(o["filter"]))
    noise = dict(seed=o["seed"], scale=o["scale"], rotation=o["rotation"], offset=list(o["offset"]),
                 period=None if o["period"] is None else list(o["period"]), filter=filt)
    values = "noise values" if dtype.startswith("float") else f"[0, 1] scaled to 0..{np.iinfo(dtype).max}, clipped"
    model = {"kind": t.kind, "example": [w, h], "channels": c, "side": t.side, "sharpness": t.sharpness,
             "guide_weight": t.guide_weight, "blend": t.blend,
             "histogram": "preserve" if t.histogram is not None else "gaussian",
             "mean": [float(v) for v in t.mean]}
    return {"warp_texton": {"version": __version__, "noise": json.loads(json.dumps(noise, default=float)),
                            "texton": model,
                            "pixel": "(i, j) at offset + R(rotation) ((j + 1/2) / scale, (i + 1/2) / scale)",
                            "values": values}}
