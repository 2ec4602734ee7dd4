"""The methods the runner times texton noise against, each a callable of no
arguments that returns the finished (H, W, C) float32 raster on the host.

* ``FFTSample`` — the spectral method: white noise → rfft2 → α̂√b̂ → irfft2
  (from ``bench_synthesis.py``), NumPy/SciPy on all cores, host only.
* ``DSNSample`` — the discrete spot noise of EUSIPCO Algorithm 1
  (``warp_texton.dsn``), NumPy, host only.
* ``PerlinRaster`` — Warp's built-in Perlin noise ``wp.pnoise``, one call per
  pixel and channel: the cost floor of a procedural noise on the same device.
* ``NaivePerPixel`` — ``warp_texton.evaluate`` at every pixel centre: each
  pixel draws its neighbouring cells' impacts itself, nothing is shared.

The Perlin kernel is benchmark code, not package code, so it lives here.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import warp as wp

from warp_texton import dsn, evaluate, synthesize

from .bench_synthesis import FFTSample

__all__ = ["FFTSample", "DSNSample", "PerlinRaster", "NaivePerPixel", "TextonNoise", "cpu_threads"]

#: Perlin lattice cells per pixel: one feature every 16 pixels, about a 64² texton's grain.
PERLIN_FEATURE = 16.0
#: Perlin period in lattice cells: longer than any raster here, so nothing repeats.
PERLIN_PERIOD = 4096


@wp.kernel
def pnoise_raster(seed: int, inv_feature: float, period: int, row0: int, out: wp.array3d(dtype=float)):
    i, j = wp.tid()
    row = row0 + i
    x = wp.vec2((float(j) + 0.5) * inv_feature, (float(row) + 0.5) * inv_feature)
    for c in range(out.shape[2]):
        # one independent noise field per channel
        out[row, j, c] = wp.pnoise(wp.rand_init(seed, c), x, period, period)


def cpu_threads() -> int:
    """Threads a CPU raster is split over: one per CPU, as the package does."""
    return max(1, os.cpu_count() or 1)


def row_bands(h: int, threads: int) -> list[tuple[int, int]]:
    """Two bands of rows per thread, like ``warp_texton.synthesis``."""
    edges = np.linspace(0, h, min(h, 2 * threads) + 1).astype(int)
    return [(r0, r1) for r0, r1 in zip(edges[:-1], edges[1:]) if r1 > r0]


class TextonNoise:
    """``warp_texton.synthesize`` on one device."""

    def __init__(self, texton, shape, mni, device):
        self.args = (texton, shape)
        self.kwargs = {"mni": mni, "seed": 1, "device": device}

    def __call__(self):
        return synthesize(*self.args, **self.kwargs)


class DSNSample:
    """``warp_texton.dsn``: the discrete spot noise, on the host."""

    def __init__(self, texton, shape, mni):
        self.texton, self.shape, self.mni = texton, shape, mni

    def __call__(self):
        return dsn(self.texton, self.shape, mni=self.mni, seed=1)


class PerlinRaster:
    """``wp.pnoise`` at every pixel, one field per channel; CPU rows split over threads."""

    def __init__(self, shape, channels, device):
        self.shape, self.channels, self.device = tuple(shape), channels, device
        self.cpu = wp.get_device(device).is_cpu
        self.threads = cpu_threads() if self.cpu else 1

    def __call__(self):
        h, w = self.shape
        args = (1, 1.0 / PERLIN_FEATURE, PERLIN_PERIOD)
        with wp.ScopedDevice(self.device):
            if not self.cpu:
                out = wp.empty((h, w, self.channels), dtype=float)
                wp.launch(pnoise_raster, dim=(h, w), inputs=[*args, 0, out])
                return out.numpy()
            host = np.zeros((h, w, self.channels), np.float32)
            out = wp.array(host, dtype=float, copy=False)

            def run(band):
                r0, r1 = band
                wp.launch(pnoise_raster, dim=(r1 - r0, w), inputs=[*args, r0, out])

            # one CPU launch runs on one thread; Warp releases the GIL during it
            with ThreadPoolExecutor(self.threads) as pool:
                list(pool.map(run, row_bands(h, self.threads)))
            return host


class NaivePerPixel:
    """``warp_texton.evaluate`` at every pixel centre (j + ½, i + ½)."""

    def __init__(self, texton, shape, mni, device):
        h, w = shape
        jj, ii = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
        self.points = np.stack([jj.ravel(), ii.ravel()], axis=1)
        self.texton, self.shape, self.mni, self.device = texton, tuple(shape), mni, device

    def __call__(self):
        values = evaluate(self.texton, self.points, mni=self.mni, seed=1, device=self.device)
        return values.reshape(*self.shape, -1)
