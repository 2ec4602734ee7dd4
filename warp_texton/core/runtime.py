"""Warp start-up, devices, and the CPU thread split that every launch uses.

One CPU launch runs on one thread, and Warp releases the GIL during it, so
CPU work is cut into contiguous parts (row bands of a raster, chunks of
points) launched from a pool of threads. On CUDA one launch covers it all.

Kernels driven here: ``warp_texton.kernels.native_simd`` (which form of the native loops was built).
"""

from __future__ import annotations

import os
import sys
import threading
from concurrent.futures import ThreadPoolExecutor, wait

import numpy as np
import warp as wp

from .errors import TextonError
from .limits import checkpoint

#: Row bands per CPU thread for raster launches: rows cost about the same, so
#: a few bands per thread balance the pool.
BANDS_PER_THREAD = 2
#: Parts per CPU thread for points and rendered rows, whose cost varies more.
CHUNKS_PER_THREAD = 4

_start_lock = threading.Lock()
_started = False


def init_warp():
    """Initialise Warp once, quietly, and return the ``warp`` module.

    Warp's greeting is turned off by its log level; the "no CUDA driver" note
    comes from native code, so file descriptor 2 points at /dev/null while
    ``wp.init()`` runs. A lock makes start-up safe when many threads make
    their first call at once: fd 2 is saved and restored exactly once.
    """
    global _started
    if _started:
        return wp
    with _start_lock:
        if not _started:
            wp.config.log_level = wp.LOG_WARNING
            _quiet_init()
            _started = True
    return wp


def _quiet_init() -> None:
    try:
        saved = os.dup(2)
    except OSError:  # no stderr to protect
        wp.init()
        return
    try:
        sys.stderr.flush()
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 2)
            wp.init()
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def resolve_device(device=None) -> str:
    """The Warp device name for ``device``: CUDA when available for ``None``,
    else "cpu"; other names are checked against the devices present."""
    init_warp()
    if device is None:
        return "cuda:0" if wp.is_cuda_available() else "cpu"
    if str(device).startswith("cuda") and not wp.is_cuda_available():
        names = ", ".join(str(d) for d in wp.get_devices())
        raise TextonError(f"device: {device!r} asked for, but no CUDA device is available; available: {names}", param="device")
    try:
        return str(wp.get_device(device))
    except Exception:
        names = ", ".join(str(d) for d in wp.get_devices())
        raise TextonError(f"device: unknown device {device!r}; available: {names}", param="device") from None


def is_cpu(device) -> bool:
    return wp.get_device(device).is_cpu


def vector_form(device, enabled: bool = True) -> str:
    """The form of the native CPU loops (kernels/native_simd.py) that runs on ``device``: "avx512",
    "avx2" or "neon" where their vector form was compiled for that instruction set, "scalar"
    otherwise (other CPUs, CUDA, or ``enabled`` False): all forms give the same values."""
    from ..kernels import native_simd

    init_warp()
    device = resolve_device(device)
    if not is_cpu(device) or not enabled:
        return "scalar"
    flag = wp.zeros(1, dtype=wp.int32, device=device)
    wp.launch(native_simd.vector_form_probe, dim=1, inputs=[flag], device=device)
    return native_simd.VECTOR_FORMS[int(flag.numpy()[0])]


def cpu_threads() -> int:
    """Threads for CPU launches: the cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def split_launch(device, module, n: int, launch, per_thread: int = CHUNKS_PER_THREAD) -> None:
    """Call ``launch(start, stop)`` over [0, n).

    On the CPU, [0, n) is cut into about ``per_thread`` contiguous parts per
    thread, launched from a thread pool; parts must write disjoint outputs.
    On CUDA, one call covers [0, n). ``module`` (the kernels' module) is
    loaded first, so that threads never compile it concurrently. An exception
    (or Ctrl-C) drops the parts not yet started and waits for the running ones.
    """
    if n <= 0:
        return
    if not is_cpu(device):
        launch(0, n)
        return
    wp.load_module(module, device=device, block_dim=1)  # the variant CPU launches use
    threads = cpu_threads()
    cuts = np.linspace(0, n, min(n, per_thread * threads) + 1).astype(int).tolist()
    parts = [(a, b) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]
    if threading.current_thread().name.startswith(POOL_NAME):
        for a, b in parts:  # called from a launch: the pool's threads are busy with its parts
            launch(a, b)
        return
    pool = launch_pool()
    futures = [pool.submit(launch, a, b) for a, b in parts]
    try:
        for future in futures:
            future.result()
    except BaseException:
        # an error, or Ctrl-C in this thread: the parts not started are dropped,
        # only the running launches (one part each) are waited for
        for future in futures:
            future.cancel()
        wait(futures)
        raise


#: Name prefix of the launch pool's threads.
POOL_NAME = "warp-texton-launch"
_pool: ThreadPoolExecutor | None = None
_pool_lock = threading.Lock()


def launch_pool() -> ThreadPoolExecutor:
    """The process's pool of ``cpu_threads()`` threads for CPU launches, made on
    first use and kept: starting threads at every call costs more than a small
    raster (and much more on a loaded machine)."""
    global _pool
    with _pool_lock:
        if _pool is None:
            _pool = ThreadPoolExecutor(cpu_threads(), thread_name_prefix=POOL_NAME)
        return _pool


def _forget_pool() -> None:
    # a forked child inherits the pool object but not its threads
    global _pool, _pool_lock
    _pool = None
    _pool_lock = threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pool)


def map_points(device, module, n: int, values) -> np.ndarray:
    """An (n, 3) float32 array of ``values(start, stop) -> (stop - start, 3)``,
    computed in parts as :func:`split_launch` cuts them."""
    out = np.zeros((n, 3), np.float32)

    def launch(start, stop):
        out[start:stop] = values(start, stop)

    split_launch(device, module, n, launch)
    return out


class _NoBar:
    """Stands for a progress bar when none is shown."""

    total = 0

    def update(self, n=1):
        checkpoint()

    def close(self):
        pass


def progress_bar(enabled: bool, total: int, desc: str, unit: str):
    """A tqdm bar over ``total`` units when ``enabled`` (shown once the work has
    run for PROGRESS_DELAY seconds, so that short calls print nothing), else a
    stand-in with the same ``update``/``close``."""
    if not enabled:
        return _NoBar()
    from tqdm.auto import tqdm

    from .progress import PROGRESS_DELAY

    class _Bar(tqdm):
        # every strip is a point where an abandoned computation stops
        def update(self, n=1):
            checkpoint()
            return super().update(n)

    return _Bar(total=total, desc=desc, unit=unit, leave=False, delay=PROGRESS_DELAY)
