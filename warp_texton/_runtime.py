"""Warp start-up, devices, and the CPU thread split that every launch uses.

One CPU launch runs on one thread, and Warp releases the GIL during it, so
CPU work is cut into contiguous parts (row bands of a raster, chunks of
points) launched from a pool of threads. On CUDA one launch covers it all.
"""

from __future__ import annotations

import os
import sys
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import warp as wp

from .errors import TextonError

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
        raise TextonError(f"device: {device!r} asked for, but no CUDA device is available; available: {names}")
    try:
        return str(wp.get_device(device))
    except Exception:
        names = ", ".join(str(d) for d in wp.get_devices())
        raise TextonError(f"device: unknown device {device!r}; available: {names}") from None


def is_cpu(device) -> bool:
    return wp.get_device(device).is_cpu


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
    loaded first, so that threads never compile it concurrently.
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
    with ThreadPoolExecutor(threads) as pool:
        list(pool.map(lambda part: launch(*part), parts))


def map_points(device, module, n: int, values) -> np.ndarray:
    """An (n, 3) float32 array of ``values(start, stop) -> (stop - start, 3)``,
    computed in parts as :func:`split_launch` cuts them."""
    out = np.zeros((n, 3), np.float32)

    def launch(start, stop):
        out[start:stop] = values(start, stop)

    split_launch(device, module, n, launch)
    return out
