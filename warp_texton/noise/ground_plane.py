"""An infinite ground plane covered with texton noise, seen in perspective (CGF Fig. 3).

Each pixel's ray meets the plane at a texel position; the noise there is
filtered for the pixel's footprint (:mod:`warp_texton.noise.filtering`), which grows
towards the horizon.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..model.noise_tables import at_mni
from ..core.checks import check_positive, check_real, check_seed, check_shape
from ..core.runtime import progress_bar, resolve_device
from .canvas import Canvas, check_output, fill_pixels, lanes_for, result_bytes, strips
from .colours import to_colours
from ..core.errors import TextonError
from .filtering import (COST_SAMPLES, MAX_FOOTPRINT, FilterOptions, PixelSet, check_filter_cost, filter_pixels, pixel_cost,
                        pixel_shares)
from ..core.limits import check_memory
from .engine import cell_limit, noise_params, noise_setup, params_mean
from ..model.texton import Texton
from ..model.tiling import TilingModel

if TYPE_CHECKING:
    import warp as wp


class PlaneCamera:
    """The camera of :func:`~warp_texton.render_plane`: a pinhole ``height`` above the plane z = 0.

    It looks towards +Y, its view direction ``tilt`` degrees from straight
    down, with a vertical field of view ``fov``. It takes the arguments of
    :func:`~warp_texton.render_plane` of the same names, with the same checks.

    Parameters
    ----------
    shape : (height, width)
        The image size in pixels; see :func:`~warp_texton.render_plane` for
        this and the other arguments.
    height : float
        Above the plane, world units.
    tilt : float
        Degrees from straight down, in [0, 90).
    fov : float
        Vertical, degrees.
    texel_size : float
        World units per texel.

    Attributes
    ----------
    shape : (int, int)
        ``(H, W)``, as checked.
    height : float
    tilt : float
    fov : float
    texel_size : float
    focal : float
        The focal length in pixels, ``(H/2) / tan(fov/2)``.

    Raises
    ------
    TextonError
        For a bad ``shape``; a ``height`` or ``texel_size`` that is not a
        finite number > 0; a ``tilt`` outside [0, 90) or a ``fov`` outside
        (0, 180), or either not a number.

    Notes
    -----
    Image points are ``(i, j)`` = (row, column) with pixel corners at
    integers, so the centre of pixel (i, j) is ``(i + 0.5, j + 0.5)``; both
    methods broadcast over arrays of i and j.

    Pixel (i, j) of an H × W image looks along d + u r − v up with
    u = (j + ½ − W/2)/f, v = (i + ½ − H/2)/f, f = ``focal``, so rows go
    from the far side (top) to the near side (bottom). A ray that meets the
    plane does so at distance s = height / (cos t + v sin t); the texel
    position is (X, −Y) / texel_size so that the texture keeps its orientation
    when seen from above. Derivation of the footprints: docs/model.md §13,
    "The ground plane of render_plane".

    References
    ----------
    CGF Fig. 3 (a textured ground plane in perspective, filtered per pixel).

    Examples
    --------
    >>> camera = PlaneCamera((1024, 1024), height=1.0, tilt=70.0, fov=40.0, texel_size=0.0011)
    >>> round(camera.focal, 1)
    1406.7
    >>> camera.texels(255.5, 511.5).round(2).tolist()  # 5.9 world units ahead (+Y), texel y = -Y / texel_size
    [-1.89, -5337.37]
    >>> camera.footprints(255.5, 511.5).round(2).tolist()
    [[3.79, 0.01], [0.0, 22.18]]
    >>> sky = PlaneCamera((64, 64), height=1.0, tilt=80.0, fov=40.0, texel_size=0.01)
    >>> sky.texels(0.5, 0.5).tolist(), sky.texels(63.5, 31.5).round(2).tolist()  # above and below the horizon
    ([nan, nan], [-1.08, -175.24])
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
        """The texel positions that image points see on the plane.

        Parameters
        ----------
        i : float or array
            Rows of the image points, pixel corners at integers (the centre
            of pixel (i, j) is (i + 0.5, j + 0.5)).
        j : float or array
            Their columns, broadcast with ``i``.

        Returns
        -------
        float64 array (..., 2)
            The texel position ``(x, y)`` each point sees; NaN where its ray
            misses the plane (at or above the horizon).
        """
        t = math.radians(self.tilt)
        u, v = self._uv(np.asarray(i, np.float64), np.asarray(j, np.float64))
        den = math.cos(t) + v * math.sin(t)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.where(den > 0, self.height / den, np.nan)
        x = s * u / self.texel_size
        y = -s * (math.sin(t) - v * math.cos(t)) / self.texel_size
        return np.stack([x, y], -1)

    def footprints(self, i, j) -> np.ndarray:
        """The footprints of image points: Jacobians of the texel position with respect to (column, row).

        Parameters
        ----------
        i : float or array
            Rows of the image points, as in :meth:`texels`.
        j : float or array
            Their columns, broadcast with ``i``.

        Returns
        -------
        float64 array (..., 2, 2)
            The footprint ``jacobian`` that :func:`~warp_texton.synthesize`
            takes, at each point: its columns are the texel-space steps of one
            pixel to the right and one pixel down. NaN entries where the ray
            misses the plane. Derived in docs/model.md §13, "The ground plane
            of render_plane".
        """
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
    texton: Texton | TilingModel,
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

    The plane z = 0 covered with texton noise, seen by a pinhole camera
    ``height`` above it that looks towards +Y, its view direction ``tilt``
    degrees from straight down (:class:`~warp_texton.noise.ground_plane.PlaneCamera`). The
    top of the image is the far side; with the defaults the view reaches 20°
    short of the horizon. Every pixel is filtered for its own footprint, which
    grows and stretches with the distance.

    Parameters
    ----------
    texton : Texton or TilingModel
        A tiling model (``analyze(..., method="tiling")``) is filtered through
        a MIP pyramid of its example (docs/tiling.md, "Filtering"); ``mni``
        does not apply to it.
    shape : (height, width)
        Image size in pixels, at most 2**28 pixels.
    height : float
        Camera height above the plane, world units, > 0.
    tilt : float
        Degrees between the view direction and straight down, in [0, 90): 0
        looks straight down, and the horizon enters the view once
        ``tilt + fov/2`` reaches 90.
    fov : float
        Vertical field of view in degrees, in (0, 180).
    texel_size : float
        World units per texel, > 0: smaller values give a finer texture.
    mni : float
        Mean number of impacts per point, as in :func:`~warp_texton.synthesize`.
    seed : int
        The impacts' seed, as in :func:`~warp_texton.synthesize`.
    device : str, optional
        Warp device, as in :func:`~warp_texton.synthesize`.
    filter : str or FilterOptions
        Per-pixel filtering of the texton for the pixel's footprint (CGF §5):
        "none", "mip", "anisotropic" (the default) or "supersample" (the n × n
        supersampled reference, 20 × 20 by default), or a
        :class:`~warp_texton.FilterOptions` that sets ``max_aniso``,
        ``supersample``, ``fade_energy`` or ``lod_bias``, as in
        :func:`~warp_texton.synthesize`. The footprints come from the camera,
        and with "supersample" each sub-pixel is projected onto the plane
        exactly.
    output : {"numpy", "warp"}
        A NumPy array, or a ``wp.array`` on ``device`` that is never copied to
        the host (see :func:`~warp_texton.synthesize`).
    progress : bool
        Show a progress bar over the rows of a large view (computed in strips
        of bounded work) once it has run for two seconds.

    Returns
    -------
    float32 array (height, width, C), NumPy or ``wp.array``
        Pixels that see no plane (at or above the horizon) or whose centre
        lies more than 2**29 noise cells from the origin hold the texton's
        mean. With the same texton, ``mni`` and ``seed`` every filter shows
        the same impacts, so the images differ only by their blur.

    Raises
    ------
    TextonError
        For a bad ``shape``; a ``height`` or ``texel_size`` that is not a
        finite number > 0; a ``tilt`` outside [0, 90) or a ``fov`` outside
        (0, 180), or either not a number; an unknown ``filter`` (and the
        errors of :class:`~warp_texton.FilterOptions`); a bad ``output``; a
        view over the memory or work budget; and the ``texton``, ``mni``,
        ``seed`` and ``device`` errors of :func:`~warp_texton.synthesize`.

    References
    ----------
    CGF §5 (filtering), Fig. 3 (the ground plane). Derivations: docs/model.md §13.

    Examples
    --------
    >>> from warp_texton import analyze, read_image
    >>> from warp_texton.demo import demo_texture_path
    >>> texton = analyze(read_image(demo_texture_path()), size=64, seed=0)
    >>> plane = render_plane(texton, (64, 64), seed=1, device="cpu")  # anisotropic, at most 8 lookups
    >>> raw = render_plane(texton, (64, 64), seed=1, filter="none", device="cpu")  # the far half aliases
    >>> plane.shape, plane.dtype
    ((64, 64, 1), dtype('float32'))
    >>> round(float(raw[:8].std()), 3), round(float(plane[:8].std()), 3)
    (0.154, 0.0)

    The top rows are past the last MIP level kept for this texton
    (:func:`~warp_texton.noise.filtering.kept_levels`), where the filtered noise is
    its mean. With the horizon in view (tilt 80 + half of fov 40 = 100
    degrees), the sky holds the mean too:

    >>> sky = render_plane(texton, (32, 64), tilt=80.0, filter="mip", seed=1, device="cpu")
    >>> bool(sky[0, 0, 0] == texton.mean[0])
    True

    The reference of a small view, 4 × 4 jittered samples per pixel, and a
    finer texture:

    >>> from warp_texton import FilterOptions
    >>> ref = render_plane(texton, (16, 16), filter=FilterOptions("supersample", supersample=4),
    ...                    seed=1, device="cpu")
    >>> fine = render_plane(texton, (64, 64), tilt=60.0, texel_size=0.01, seed=1, device="cpu")
    """
    camera = PlaneCamera(shape, height, tilt, fov, texel_size)
    h, w = camera.shape
    output = check_output(output)
    options = FilterOptions.of(filter)
    if isinstance(texton, TilingModel):
        values = _tiling_plane(texton, camera, None, options, mni, seed, device).reshape(h, w, -1)
        return _tiling_result(values, output, device)
    setup = noise_setup(texton, mni)  # a bad texton or mni is refused before anything is allocated
    texton = at_mni(texton, setup.mni)  # the histogram tables of this MNI's noise
    check_seed(seed)
    device = resolve_device(device)
    check_plane_cost(texton, setup, camera, None, options)
    lanes = lanes_for([texton])  # a grey texton's view: one float a pixel through the kernels
    check_memory(result_bytes(1, h, w, texton.channels, device, output, lanes) + h * w * 16,
                 f"a {w}x{h} plane view", "use a smaller shape", mentions=("shape",))
    p = noise_params(texton, setup, seed)
    canvas = Canvas((h, w), device, lanes)
    parts = strips(h, w, pixel_cost(options, True))
    bar = progress_bar(progress and len(parts) > 1, h, "render-plane", "row")
    try:
        for r0, r1 in parts:
            shares = _fill_plane_pixels(p, texton, setup, camera, np.arange(r0 * w, r1 * w), options, device, seed,
                                        progress and len(parts) == 1, canvas.pixels(r0 * w, r1 * w))
            if shares is not None:
                canvas.keep_shares(r0 * w, r1 * w, shares)
            bar.update(r1 - r0)
    finally:
        bar.close()
    return canvas.result(texton.channels, output, textons=[texton])


def plane_pixels(texton: Texton | TilingModel, camera: PlaneCamera, pixels, *, mni: float = 30.0, seed: int = 0, device=None,
                 filter="anisotropic", progress: bool = False, out=None) -> np.ndarray | None:
    """Some pixels of :func:`~warp_texton.render_plane`'s image, without rendering the rest.

    Parameters
    ----------
    texton : Texton
    camera : PlaneCamera
        The view, made with the ``shape``, ``height``, ``tilt``, ``fov`` and
        ``texel_size`` that :func:`~warp_texton.render_plane` would take.
    pixels : int array (N,) or None
        Flat pixel indices ``i * W + j``, not checked (keep them in
        [0, H·W)); ``None``: every pixel, in order.
    mni : float
        As in :func:`~warp_texton.render_plane`.
    seed : int
        As in :func:`~warp_texton.render_plane`.
    device : str, optional
        As in :func:`~warp_texton.render_plane`.
    filter : str or FilterOptions
        As in :func:`~warp_texton.render_plane` (default "anisotropic").
    progress : bool
        Show the supersampling's progress bar.
    out : warp.array of vec3 (N,), optional
        An array on ``device`` into which all three channels of the values are
        written (unused channels of a grey texton are 0), instead of returning
        them: :func:`~warp_texton.render_plane` fills its output in strips this
        way, without a copy through the host.

    Returns
    -------
    float32 array (N, C) or None
        The values of the pixels, equal to the same pixels of
        :func:`~warp_texton.render_plane` with the same arguments; ``None``
        when ``out`` is given.

    Raises
    ------
    TextonError
        For an unknown ``filter``, a view over the memory or work budget, and
        the ``texton``, ``mni``, ``seed`` and ``device`` errors of
        :func:`~warp_texton.synthesize`.

    Notes
    -----
    The benchmark computes its supersampled reference on a subset of pixels
    this way, and measures other settings with
    ``FilterOptions(..., lod_bias=...)`` and ``fade_energy``.

    Examples
    --------
    >>> from warp_texton import analyze, read_image
    >>> from warp_texton.demo import demo_texture_path
    >>> texton = analyze(read_image(demo_texture_path()), size=64, seed=0)
    >>> from warp_texton import render_plane
    >>> camera = PlaneCamera((64, 64), height=1.0, tilt=70.0, fov=40.0, texel_size=0.01)
    >>> img = render_plane(texton, (64, 64), texel_size=0.01, seed=1, device="cpu")
    >>> some = plane_pixels(texton, camera, [0, 1000, 64 * 64 - 1], seed=1, device="cpu")
    >>> some.shape, bool(np.array_equal(some, img.reshape(-1, 1)[[0, 1000, 64 * 64 - 1]]))
    ((3, 1), True)
    >>> import warp as wp
    >>> out = wp.zeros(3, dtype=wp.vec3, device="cpu")
    >>> plane_pixels(texton, camera, [0, 1000, 64 * 64 - 1], seed=1, device="cpu", out=out) is None
    True
    >>> bool(np.array_equal(out.numpy()[:, :1], some))
    True
    """
    options = FilterOptions.of(filter)
    if isinstance(texton, TilingModel):
        values = _tiling_plane(texton, camera, pixels, options, mni, seed, device)
        if out is None:
            return values
        full = np.zeros((values.shape[0], 3), np.float32)
        full[:, :values.shape[1]] = values
        out.assign(full)
        return None
    seed = check_seed(seed)
    setup = noise_setup(texton, mni)
    texton = at_mni(texton, setup.mni)  # the histogram tables of this MNI's noise
    device = resolve_device(device)
    p = noise_params(texton, setup, seed)
    h, w = camera.shape
    keys = None if pixels is None else np.asarray(pixels, np.int64)
    count = h * w if keys is None else keys.size
    check_plane_cost(texton, setup, camera, keys, options)  # the budgets, before the per-pixel arrays
    keys = np.arange(count) if keys is None else keys
    values = np.empty((keys.size, 3), np.float32) if out is None else out
    shares = _fill_plane_pixels(p, texton, setup, camera, keys, options, device, seed, progress, values)
    if shares is not None:  # the pixels' colours, as render_plane hands them over
        host = values if isinstance(values, np.ndarray) else values.numpy()
        to_colours(host, texton, shares)
        if not isinstance(values, np.ndarray):
            values.assign(host)
    return None if out is not None else values[:, : texton.channels]


def _fill_plane_pixels(p, texton: Texton, setup, camera: PlaneCamera, keys: np.ndarray, options: FilterOptions,
                       device, seed: int, progress: bool, out) -> np.ndarray | None:
    """Write the values of the flat pixel indices ``keys`` of ``camera``'s view into ``out``
    (an (N, 3) float32 NumPy array or wp.array of vec3), every argument checked and the
    budgets priced by the caller: render_plane once for the whole view, plane_pixels per call.

    Returns the shares of the variance the pixels kept (0 where they see the mean)
    for a texton with a histogram transform, else None."""
    ii, jj = np.divmod(keys, camera.shape[1])
    centre = camera.texels(ii + 0.5, jj + 0.5)
    # positions whose cells the kernels could not index see the mean
    limit = cell_limit(setup)
    hit = np.isfinite(centre).all(axis=1) & (np.abs(centre) < limit).all(axis=1)
    idx = np.flatnonzero(hit)
    preserve = texton.histogram is not None
    seen = PlanePixels(camera, keys[idx], np.ascontiguousarray(centre[idx]), options.spec.footprint or preserve)
    if isinstance(out, np.ndarray):
        out[:] = params_mean(p)
        out[idx] = filter_pixels(p, texton, setup, seen, options, device, seed, progress)
    else:
        fill_pixels(out, idx, params_mean(p), device,
                    lambda target: filter_pixels(p, texton, setup, seen, options, device, seed, progress, target))
    if not preserve:
        return None
    shares = np.zeros(keys.size)
    shares[idx] = pixel_shares(texton, seen, options)
    return shares


def check_plane_cost(texton: Texton, setup, camera: PlaneCamera, keys, options: FilterOptions) -> None:
    """Refuse the pixels ``keys`` (None: every pixel) of ``camera`` when filtering them
    would exceed the budgets, judged from the footprints of up to COST_SAMPLES
    pixels spread over them (above the horizon a pixel costs nothing)."""
    h, w = camera.shape
    count = h * w if keys is None else keys.size
    picks = np.linspace(0, count - 1, min(count, COST_SAMPLES)).astype(np.int64) if count else np.zeros(0, np.int64)
    pi, pj = np.divmod(picks if keys is None else keys[picks], w)
    sample = camera.footprints(pi + 0.5, pj + 0.5)
    check_filter_cost(texton, setup, count, sample, options, f"a {w}x{h} plane view")


# ---------------------------------------------------------------- tiling models


def _tiling_plane(model: TilingModel, camera: PlaneCamera, keys, options: FilterOptions, mni, seed, device) -> np.ndarray:
    """(N, C) values of the flat pixels ``keys`` (None: all) of ``camera``'s view of a tiling model, filtered
    as ``options`` say: the footprint kinds through the same kernel function as ``synthesize``'s filtered
    rasters (``tiling_filtered``), "supersample" with each sub-pixel projected exactly. Pixels that see no
    plane, or whose centre lies beyond ±2³⁰ texels, hold the example's mean."""
    from .tiling import MAX_TILING_REACH, refuse_texton_options, tiling_at
    from .tiling_filtering import tiling_filter_work, tiling_filtered_at, tiling_options, tiling_supersampled
    from ..core.limits import check_work

    refuse_texton_options(dict(mni=(mni, 30.0)))
    seed = check_seed(seed)
    options = tiling_options(options)
    device = resolve_device(device)
    h, w = camera.shape
    keys = np.arange(h * w, dtype=np.int64) if keys is None else np.asarray(keys, np.int64)
    what = f"a {w}x{h} plane view of a tiling model"
    check_memory(float(keys.size) * 160, what, "use a smaller shape", mentions=("shape",))
    check_work(tiling_filter_work(options, keys.size), f"{what} with filter {options.kind!r}", options.spec.cost_hint,
               mentions=("shape", "supersample", "max_aniso"))
    ii, jj = np.divmod(keys, w)
    centre = camera.texels(ii + 0.5, jj + 0.5)
    with np.errstate(invalid="ignore"):
        hit = np.isfinite(centre).all(axis=1) & (np.abs(centre) < MAX_TILING_REACH).all(axis=1)
    idx = np.flatnonzero(hit)
    values = np.empty((keys.size, model.channels), np.float32)
    values[:] = model.mean3[:model.channels]
    seen = PlanePixels(camera, keys[idx], np.ascontiguousarray(centre[idx]), options.spec.footprint)
    if not idx.size:
        return values
    if options.spec.supersamples:
        values[idx] = tiling_supersampled(model, seen, options.supersample, seed, device, reach=MAX_TILING_REACH)
    elif options.spec.footprint:
        J = np.clip(np.nan_to_num(seen.footprints(0, seen.count), nan=0.0), -MAX_FOOTPRINT, MAX_FOOTPRINT)
        values[idx] = tiling_filtered_at(model, seen.centres(0, seen.count), J, options, seed, device)
    else:
        values[idx] = tiling_at(model, seen.centres(0, seen.count), seed, device)
    return values


def _tiling_result(values: np.ndarray, output: str, device):
    if output == "numpy":
        return values
    import warp as wp

    return wp.array(values, dtype=float, device=resolve_device(device))
