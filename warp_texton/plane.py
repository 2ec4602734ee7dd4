"""An infinite ground plane covered with texton noise, seen in perspective (CGF Fig. 3).

Each pixel's ray meets the plane at a texel position; the noise there is
filtered for the pixel's footprint (:mod:`warp_texton.filtering`), which grows
towards the horizon.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ._checks import check_positive, check_real, check_seed, check_shape
from ._runtime import progress_bar, resolve_device
from .canvas import Canvas, check_output, fill_pixels, result_bytes, strips
from .errors import TextonError
from .filtering import COST_SAMPLES, FilterOptions, PixelSet, check_filter_cost, filter_pixels, pixel_cost
from .limits import check_memory
from .noise import cell_limit, noise_params, noise_setup, params_mean
from .texton import Texton

if TYPE_CHECKING:
    import warp as wp


class PlaneCamera:
    """A pinhole camera ``height`` above the plane z = 0, looking down at ``tilt``
    degrees from the vertical towards +Y, vertical field of view ``fov``.

    Pixel (i, j) of an H × W image looks along d + u r − v up with
    u = (j + ½ − W/2)/f, v = (i + ½ − H/2)/f, f = (H/2)/tan(fov/2), so rows go
    from the far side (top) to the near side (bottom). A ray that meets the
    plane does so at distance s = height / (cos t + v sin t); the texel
    position is (X, −Y) / texel_size so that the texture keeps its orientation
    when seen from above.
    """

    def __init__(self, shape, height, tilt, fov, texel_size):
        self.shape = check_shape(shape)
        self.height = check_positive(height, "height (the camera's height above the plane)")
        self.texel_size = check_positive(texel_size, "texel_size")
        tilt, fov = check_real(tilt, "tilt"), check_real(fov, "fov")
        if not (0.0 <= tilt < 90.0):
            raise TextonError(f"tilt must be in [0, 90) degrees (0 looks straight down), got {tilt!r}", param="tilt")
        if not (0.0 < fov < 180.0):
            raise TextonError(f"fov must be in (0, 180) degrees, got {fov!r}", param="fov")
        self.tilt, self.fov = tilt, fov
        h, _ = self.shape
        self.focal = (h / 2.0) / math.tan(math.radians(fov) / 2.0)

    def _uv(self, i, j):
        h, w = self.shape
        return (j - w / 2.0) / self.focal, (i - h / 2.0) / self.focal

    def texels(self, i, j) -> np.ndarray:
        """Texel positions (…, 2) of image points (row i, column j) (pixel corners
        at integers); NaN where the ray misses the plane."""
        t = math.radians(self.tilt)
        u, v = self._uv(np.asarray(i, np.float64), np.asarray(j, np.float64))
        den = math.cos(t) + v * math.sin(t)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.where(den > 0, self.height / den, np.nan)
        x = s * u / self.texel_size
        y = -s * (math.sin(t) - v * math.cos(t)) / self.texel_size
        return np.stack([x, y], -1)

    def footprints(self, i, j) -> np.ndarray:
        """Jacobians (…, 2, 2) of the texel position w.r.t. (column, row) at image points."""
        t = math.radians(self.tilt)
        u, v = self._uv(np.asarray(i, np.float64), np.asarray(j, np.float64))
        den = math.cos(t) + v * math.sin(t)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.where(den > 0, self.height / den, np.nan)
        k = 1.0 / (self.focal * self.texel_size)
        J = np.zeros(np.shape(s) + (2, 2))
        J[..., 0, 0] = k * s
        J[..., 0, 1] = -k * u * s * s * math.sin(t) / self.height
        J[..., 1, 1] = k * s * s / self.height
        return J


class PlanePixels(PixelSet):
    """The pixels of a plane view (flat indices ``keys``) whose centres see the noise."""

    def __init__(self, camera: PlaneCamera, keys, centre, wants_footprints: bool):
        self.camera = camera
        self.keys = np.asarray(keys, np.int64)
        self.count = self.keys.size
        self.ii, self.jj = np.divmod(self.keys, camera.shape[1])
        self.centre = centre
        self.J = camera.footprints(self.ii + 0.5, self.jj + 0.5) if wants_footprints else None

    def centres(self, start, stop) -> np.ndarray:
        return self.centre[start:stop]

    def footprints(self, start, stop) -> np.ndarray:
        assert self.J is not None, "made with wants_footprints"
        return self.J[start:stop]

    def subpixels(self, sel, offsets) -> np.ndarray:
        return self.camera.texels(self.ii[sel, None] + offsets[..., 1], self.jj[sel, None] + offsets[..., 0])


def render_plane(
    texton: Texton,
    shape=(512, 512),
    *,
    height: float = 1.0,
    tilt: float = 70.0,
    fov: float = 40.0,
    texel_size: float = 0.002,
    mni: float = 30.0,
    seed: int = 0,
    device=None,
    filter="anisotropic",
    output: str = "numpy",
    progress: bool = False,
) -> np.ndarray | wp.array:
    """An infinite ground plane textured with texton noise, seen in perspective (CGF Fig. 3).

    Parameters
    ----------
    texton : Texton
    shape : (height, width)
        Image size in pixels.
    height : float
        Camera height above the plane, world units.
    tilt : float
        Degrees between the view direction and straight down: 0 looks straight
        down, towards 90 the view reaches the horizon. In [0, 90).
    fov : float
        Vertical field of view, degrees. The top of the image is the far side.
    texel_size : float
        World units per texel.
    mni, seed
        As in :func:`warp_texton.synthesize`.
    filter : str or FilterOptions
        Per-pixel filtering of the texton for the pixel's footprint (CGF §5):
        "none", "mip", "anisotropic" (default), or "supersample" (the n × n
        supersampled reference, 20 × 20 by default); a
        :class:`~warp_texton.FilterOptions` sets ``max_aniso``,
        ``supersample`` or ``fade_energy``.
    device : str, optional
    progress : bool
        Show a progress bar over the rows of a large view (once it has run for
        two seconds).
    output : {"numpy", "warp"}
        A NumPy array, or a ``wp.array`` on ``device`` that is never copied to
        the host (see :func:`warp_texton.synthesize`).

    Returns
    -------
    float32 array (height, width, C), NumPy or ``wp.array``; pixels that see no
    plane (above the horizon, or beyond ±2**29 noise cells) hold the texton mean.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton, render_plane
    >>> t = Texton(np.random.default_rng(0).standard_normal((8, 8, 1)) / 8, [0.5])
    >>> render_plane(t, (24, 32), tilt=80, filter="mip", device="cpu").shape
    (24, 32, 1)
    """
    camera = PlaneCamera(shape, height, tilt, fov, texel_size)
    h, w = camera.shape
    output = check_output(output)
    options = FilterOptions.of(filter)
    setup = noise_setup(texton, mni)  # a bad texton or mni is refused before anything is allocated
    check_seed(seed)
    device = resolve_device(device)
    check_plane_cost(texton, setup, camera, None, options)
    check_memory(result_bytes(1, h, w, texton.channels, device, output) + h * w * 16,
                 f"a {h}x{w} plane view", "use a smaller shape", mentions=("shape",))
    canvas = Canvas((h, w), device)
    parts = strips(h, w, pixel_cost(options, True))
    bar = progress_bar(progress and len(parts) > 1, h, "render-plane", "row")
    try:
        for r0, r1 in parts:
            plane_pixels(texton, camera, np.arange(r0 * w, r1 * w), mni=mni, seed=seed, filter=options, device=device,
                         progress=progress and len(parts) == 1, out=canvas.pixels(r0 * w, r1 * w))
            bar.update(r1 - r0)
    finally:
        bar.close()
    return canvas.result(texton.channels, output)


def plane_pixels(texton: Texton, camera: PlaneCamera, pixels, *, mni: float = 30.0, seed: int = 0, device=None,
                 filter="anisotropic", progress: bool = False, out=None) -> np.ndarray | None:
    """(N, C) values of the flat pixel indices ``pixels`` of :func:`render_plane`'s image
    (benchmarks compare filters on a subset of pixels this way); None: every pixel.
    With ``out`` (an (N,) vec3 array on the device) all three channels are written
    there instead."""
    options = FilterOptions.of(filter)
    seed = check_seed(seed)
    setup = noise_setup(texton, mni)
    device = resolve_device(device)
    p = noise_params(texton, setup, seed)
    h, w = camera.shape
    keys = None if pixels is None else np.asarray(pixels, np.int64)
    count = h * w if keys is None else keys.size
    check_plane_cost(texton, setup, camera, keys, options)  # the budgets, before the per-pixel arrays
    keys = np.arange(count) if keys is None else keys
    ii, jj = np.divmod(keys, w)
    centre = camera.texels(ii + 0.5, jj + 0.5)
    # positions whose cells the kernels could not index see the mean
    limit = cell_limit(setup)
    hit = np.isfinite(centre).all(axis=1) & (np.abs(centre) < limit).all(axis=1)
    idx = np.flatnonzero(hit)
    seen = PlanePixels(camera, keys[idx], np.ascontiguousarray(centre[idx]), options.spec.footprint)
    if out is not None:
        fill_pixels(out, idx, params_mean(p), device,
                    lambda target: filter_pixels(p, texton, setup, seen, options, device, seed, progress, target))
        return None
    out = np.empty((ii.size, 3), np.float32)
    out[:] = params_mean(p)
    out[idx] = filter_pixels(p, texton, setup, seen, options, device, seed, progress)
    return out[:, : texton.channels]


def check_plane_cost(texton: Texton, setup, camera: PlaneCamera, keys, options: FilterOptions) -> None:
    """Refuse the pixels ``keys`` (None: every pixel) of ``view`` when filtering them
    would exceed the budgets, judged from the footprints of up to COST_SAMPLES
    pixels spread over them (above the horizon a pixel costs nothing)."""
    h, w = camera.shape
    count = h * w if keys is None else keys.size
    picks = np.linspace(0, count - 1, min(count, COST_SAMPLES)).astype(np.int64) if count else np.zeros(0, np.int64)
    pi, pj = np.divmod(picks if keys is None else keys[picks], w)
    sample = camera.footprints(pi + 0.5, pj + 0.5)
    check_filter_cost(texton, setup, count, sample, options, f"a {w}x{h} plane view")
