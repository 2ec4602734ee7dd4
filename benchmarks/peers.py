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
* ``FastNoiseLiteFrame`` — FastNoiseLite's OpenSimplex2 noise through its
  Python binding (``pyfastnoiselite``, a benchmark-only dependency),
  ``gen_from_coords`` over a frame's pixel grid, one thread: the procedural
  noise users of noise libraries compare with first. Host only.
* ``TilingBlending`` — tiling and blending with the histogram-preserving
  operator (Heitz & Neyret, HPG 2018; Deliot & Heitz, GPU Zen 2, 2019), NumPy,
  host only: the quality peer of ``bench_quality.py`` (docs/quality.md).

The Perlin kernel is benchmark code, not package code, so it lives here.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import warp as wp
from warp_texton import dsn, evaluate, synthesize
from warp_texton.model.histogram import HistogramTransform

from .bench_synthesis import FFTSample

__all__ = ["FFTSample", "DSNSample", "PerlinRaster", "NaivePerPixel", "TextonNoise", "FastNoiseLiteFrame",
           "fastnoiselite_missing", "TilingBlending",
           "variance_preserving_blend", "triangle_grid", "cpu_threads"]

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
    """Two bands of rows per thread, like ``warp_texton.noise.synthesis``."""
    edges = np.linspace(0, h, min(h, 2 * threads) + 1).astype(int)
    return [(r0, r1) for r0, r1 in zip(edges[:-1], edges[1:]) if r1 > r0]


class TextonNoise:
    """``warp_texton.synthesize`` on one device."""

    def __init__(self, texton, shape, mni, device):
        self.args = (texton, shape)
        self.kwargs = {"mni": mni, "seed": 1, "device": device}

    def __call__(self):
        return synthesize(*self.args, **self.kwargs)


def fastnoiselite_missing() -> str | None:
    """Why the FastNoiseLite peer cannot run here, or None."""
    import importlib.util

    if importlib.util.find_spec("pyfastnoiselite") is None:
        return "pyfastnoiselite is not installed (pip install 'warp-texton[bench]')"
    return None


class FastNoiseLiteFrame:
    """FastNoiseLite's OpenSimplex2 at every pixel of an (H, W) frame, as its Python
    users call it: one ``gen_from_coords`` over the pixel grid's (2, H·W) float32
    coordinates (made once, outside the timing: the most favourable reading for
    FastNoiseLite), one thread (the binding has no threads), default frequency
    0.01, one channel."""

    def __init__(self, shape, seed: int = 1):
        from pyfastnoiselite.pyfastnoiselite import FastNoiseLite, NoiseType

        self.shape = tuple(shape)
        self.noise = FastNoiseLite(seed)
        self.noise.noise_type = NoiseType.NoiseType_OpenSimplex2
        h, w = self.shape
        ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
        self.coords = np.ascontiguousarray(np.stack([xs.ravel(), ys.ravel()]))

    def __call__(self):
        return np.asarray(self.noise.gen_from_coords(self.coords), np.float32).reshape(self.shape + (1,))


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


# ---------------------------------------------------------------- tiling and blending
#
# Written by hand from the papers' description (no maintained Python library does it:
# the published versions are shaders inside engines): Heitz & Neyret, "High-Performance
# By-Example Noise using a Histogram-Preserving Blending Operator", HPG 2018, and Deliot &
# Heitz, "Procedural Stochastic Textures by Tiling and Blending", GPU Zen 2, 2019.

_SQRT3 = np.sqrt(3.0)


def variance_preserving_blend(values: np.ndarray, weights: np.ndarray, mean: float = 0.0) -> np.ndarray:
    """HPG 2018 eq. (4): (Σ wᵢ Gᵢ − μ) / √(Σ wᵢ²) + μ, for weights that sum to 1.

    ``values`` (K, ..., C) are the K patches, ``weights`` (K, ...) their weights.
    """
    w = weights[..., None]
    return ((w * values).sum(axis=0) - mean) / np.sqrt((w * w).sum(axis=0)) + mean


def triangle_grid(points: np.ndarray, side: float) -> tuple[np.ndarray, np.ndarray]:
    """The triangle of each point on a grid of equilateral triangles of ``side`` pixels.

    Returns the lattice coordinates (a, b) of its three vertices, (3, ..., 2)
    integers, vertex (a, b) at ``side`` · (a + b/2, b √3/2), and their barycentric
    weights (3, ...). Points are (..., 2) as (x, y).
    """
    q = np.asarray(points, np.float64) / side
    s = np.stack([q[..., 0] - q[..., 1] / _SQRT3, 2.0 * q[..., 1] / _SQRT3], -1)  # skewed: vertices on Z²
    base = np.floor(s)
    f = s - base
    upper = f[..., 0] + f[..., 1] > 1.0  # the triangle (1,0)-(0,1)-(1,1) of the cell
    one = np.ones_like(f[..., 0])
    corner = np.where(upper[..., None], base + 1.0, base)
    vx = np.stack([corner, base + np.stack([one, 0 * one], -1), base + np.stack([0 * one, one], -1)])
    w0 = np.where(upper, f[..., 0] + f[..., 1] - 1.0, 1.0 - f[..., 0] - f[..., 1])
    w1 = np.where(upper, 1.0 - f[..., 1], f[..., 0])
    w2 = np.where(upper, 1.0 - f[..., 0], f[..., 1])
    return vx.astype(np.int64), np.stack([w0, w1, w2])


def _hash(a: np.ndarray, b: np.ndarray, seed: int, salt: int) -> np.ndarray:
    """A 64-bit avalanche hash (splitmix64's finaliser) of integer lattice coordinates."""
    with np.errstate(over="ignore"):
        z = (a.astype(np.uint64) * np.uint64(0x9E3779B97F4A7C15) + b.astype(np.uint64) * np.uint64(0xC2B2AE3D27D4EB4F)
             + np.uint64((seed * 0x165667B1 + salt) & 0xFFFFFFFFFFFFFFFF))
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        return z ^ (z >> np.uint64(31))


class TilingBlending:
    """Tiling and blending with the histogram-preserving operator, on the host (NumPy).

    Each output pixel lies in a triangle of an equilateral grid; each vertex of the
    grid shows the example translated by a random offset (a hash of the vertex and
    the seed); the three patches are blended with the pixel's barycentric weights by
    the variance-preserving operator in the example's Gaussianised space, then mapped
    back (the package's :class:`warp_texton.model.histogram.HistogramTransform`, which
    histogram-preserving texton noise uses too). Nearest-pixel lookups: a pixel whose weight
    is 1 for one vertex is that patch's pixel.

    ``side`` is the triangles' side in pixels; a vertex's patch is seen up to
    ``side`` away from it. By default a quarter of the example's smaller side, and
    the patches' centres are drawn at least ``side`` from the border of a
    non-periodic example, so that none crosses it; half of it for a ``periodic``
    (seamless) example, which is read wrapped.

    References
    ----------
    E. Heitz, F. Neyret, "High-Performance By-Example Noise using a
    Histogram-Preserving Blending Operator", Proc. ACM CGIT (HPG) 1(2), 2018.
    T. Deliot, E. Heitz, "Procedural Stochastic Textures by Tiling and Blending",
    GPU Zen 2, 2019.
    """

    def __init__(self, u: np.ndarray, *, side: float | None = None, periodic: bool = False):
        u = np.asarray(u, np.float64)
        u = u[:, :, None] if u.ndim == 2 else u
        self.transform = HistogramTransform.fit(u)
        #: the example in the Gaussian space, (H, W, C)
        self.gaussian = self.transform.to_gaussian(u)
        self.height, self.width = self.gaussian.shape[:2]
        small = min(self.height, self.width)
        self.side = float(side if side is not None else small / (2 if periodic else 4))
        # a patch reaches `side` around its centre: non-periodic examples keep it inside
        self.periodic = periodic or small <= 2 * self.side + 2

    def offsets(self, vertices: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
        """(row, column) translations from output to example of each vertex's patch.

        The vertex's random centre in the example (a hash of the vertex and the seed)
        minus the vertex's position in the output.
        """
        a, b = vertices[..., 0], vertices[..., 1]
        margin = 0.0 if self.periodic else self.side + 1.0
        centres = []
        for salt, extent in ((1, self.height), (2, self.width)):
            unit = (_hash(a, b, seed, salt) >> np.uint64(11)).astype(np.float64) / 2.0 ** 53
            centres.append(margin + unit * (extent - 2.0 * margin))
        return centres[0] - self.side * b * _SQRT3 / 2.0, centres[1] - self.side * (a + b / 2.0)

    def __call__(self, shape, *, seed: int = 0) -> np.ndarray:
        h, w = shape
        yy, xx = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
        vertices, weights = triangle_grid(np.stack([xx + 0.5, yy + 0.5], -1), self.side)
        dy, dx = self.offsets(vertices, seed)
        # nearest pixel: each patch is the example translated by a whole number of pixels
        rows, cols = np.floor(yy + 0.5 + dy).astype(np.int64), np.floor(xx + 0.5 + dx).astype(np.int64)
        if self.periodic:
            rows, cols = rows % self.height, cols % self.width
        patches = self.gaussian[rows, cols]  # (3, h, w, C)
        g = variance_preserving_blend(patches, weights)
        return self.transform.to_colours(g.reshape(-1, g.shape[-1])).reshape(g.shape).astype(np.float32)
