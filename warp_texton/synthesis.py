"""Texton noise on rasters, batches of rasters and points: the public front ends.

Each function validates its arguments, checks the budgets of the whole call
once, then dispatches to the engine (:mod:`warp_texton.raster` for plain
rasters, :mod:`warp_texton.noise` for points) or to the filters in
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
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from ._checks import as_real_array, check_int, check_positive, check_seed, check_shape
from ._runtime import progress_bar, resolve_device
from .errors import TextonError
from .canvas import Canvas, check_output, group_size, result_bytes, strips
from .filtering import (COST_SAMPLES, FILTER_BYTES_PER_PIXEL, FilterOptions, RasterPixels, check_jacobian,
                        filter_pixels, filter_work, needs_filtering, pixel_cost)
from .limits import check_memory
from .noise import (CELL_FACTOR, NoiseSetup, check_cell_range, check_points_cost, noise_params, noise_setup,
                    params_record, params_struct, point_values)
from .raster import (RasterWindow, TextonStack, check_method, check_raster_cost, raster_cost, raster_geometry,
                     raster_reach, rasters, resolve_method, window_block)
from .texton import Texton

if TYPE_CHECKING:
    import warp as wp

#: Pixel windows are placed with int32 indices in the kernels.
MAX_PIXEL_INDEX = 1 << 30
#: What to make smaller when a filter's work is over the budget, besides the
#: raster and the mni.
FILTER_KNOBS = {"supersample": "supersample", "anisotropic": "max_aniso"}
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
    *,
    mni: float = 30.0,
    seed: int = 0,
    scale: float = 1.0,
    rotation: float = 0.0,
    offset=(0.0, 0.0),
    period=None,
    device=None,
    poisson: str = "exact",
    cell_factor: float = CELL_FACTOR,
    method: str = "auto",
    jacobian=None,
    filter="none",
    pixel_offset=(0, 0),
    output: str = "numpy",
    progress: bool = False,
) -> np.ndarray | wp.array:
    """Texton noise on an H × W raster.

    Pixel (i, j) is the noise at x = offset + R(rotation) · ((j + ½)/scale, (i + ½)/scale)
    in texel units, x to the right and y down, so ``scale`` is pixels per
    texel and ``rotation`` (degrees) turns the noise; with the defaults, pixel
    (i, j) is the noise at (j + ½, i + ½). Any window of the infinite noise
    can be made, and windows whose offsets differ by their width join without
    a seam.

    The noise's value at a position depends only on the texton, ``mni``,
    ``seed``, ``period``, ``poisson`` and ``cell_factor``; the raster's
    ``shape``, ``scale``, ``rotation``, ``offset``, the ``device`` and the
    ``method`` only choose where and how it is sampled. A ``filter`` other
    than "none" averages the same noise over each pixel's footprint, so the
    value of a pixel then also depends on its footprint.

    Parameters
    ----------
    texton : Texton
        From :func:`analyze` or :func:`load_texton`.
    shape : (height, width)
        Positive integers, at most 2²⁸ pixels.
    mni : float
        Mean number of impacts per point, at least 10⁻³; λ = mni /
        texton.support_area. Higher is more Gaussian and slower; about 30 is
        enough.
    seed : int
        In [0, 2**32); the same seed gives the same noise on every device.
    scale : float
        Pixels per texel, in (0, 10⁴]: 2 shows the texture twice as large,
        0.25 a quarter as large (with the default ``filter="none"``, small
        scales alias).
    rotation : float
        Degrees; a positive angle turns the texture counter-clockwise on
        screen.
    offset : (x, y)
        The noise position of the raster's top-left corner, in texels.
        Without rotation, rasters whose offsets differ by (W / scale, 0) are
        neighbouring windows and join without a seam.
    period : (Px, Py), optional
        ``None``: the noise never repeats. A pair makes the noise exactly
        periodic with these periods (texel units):
        ``synthesize(t, (H, W), period=(W, H))`` is a seamless tile at scale
        1; at another scale use (W / scale, H / scale). Note the order:
        ``period`` is (x, y), ``shape`` is (height, width). A period spans at
        most 2³⁰ noise cells (4.2 × 10¹⁰ texels for a 64 × 64 texton,
        docs/limits.md); a longer one is refused.
    device : str, optional
        "cpu", "cuda", "cuda:N"; default CUDA when available, else CPU.
    poisson : {"exact", "gaussian"}
        Cell counts exactly Poisson, or the rounded Gaussian approximation of
        the authors' viewer.
    cell_factor : float
        Side of the random cells relative to the side of the texton's support
        (> 0; CGF §8 uses ~0.6). A different value gives a different, equally
        valid, noise.
    method : {"auto", "splat", "gather"}
        How the raster is computed; both give the same noise. "splat": each
        impact adds its texton to the pixels it covers (CPU only; threads own
        row bands); "gather": each pixel sums the impacts of nearby cells (a
        thread per pixel); "auto" splats on the CPU and gathers on CUDA. Not
        used when a filter applies: filtered pixels are evaluated one by one,
        like :func:`evaluate`'s points.
    jacobian : array (2, 2) or (height, width, 2, 2), optional
        Each pixel's footprint in texel space, for the whole raster or per
        pixel: columns are the texel-space steps of one pixel to the right and
        one pixel down, so the pixel covers x + J [−½, ½]². Default: the
        raster's own steps, R(rotation) / scale. Only the filters read it;
        entries must be finite and are clamped to ±10¹² texels; a zero
        footprint means no filtering.
    filter : str or FilterOptions
        Anti-aliasing for the footprint (CGF §5, docs/model.md §13): "none"
        (one evaluation per pixel), "mip" (one lookup of a MIP pyramid of the
        texton, at the footprint's major length), "anisotropic" (up to
        ``max_aniso`` lookups along the footprint's major axis) or
        "supersample" (the mean of ``supersample``² jittered evaluations: the
        reference, slow), with default settings, or a
        :class:`~warp_texton.FilterOptions` to change them. Where every
        footprint needs a single lookup of the unfiltered texton (at
        ``scale=1``, and down to scale ≈ 0.41 for "mip", 0.66 for
        "anisotropic") both give exactly the output of "none". Footprints past
        the last MIP level the filters keep
        (:func:`warp_texton.filtering.kept_levels`) fade to the texton's mean;
        supersamples beyond the noise's cell range count as the mean.
    pixel_offset : (row, column) of integers
        Within ±2³⁰. Make the result the window of pixels ``pixel_offset`` +
        (i, j) of the raster that ``offset``, ``scale`` and ``rotation``
        place: windows of one raster are then bit for bit the same pixels as
        one call for the whole (:mod:`warp_texton.dask` computes chunks this
        way; docs/scale.md, "windows and chunks").
    output : {"numpy", "warp"}
        A NumPy array on the host, or a ``wp.array`` on ``device`` that is
        never copied to the host; hand it over with DLPack
        (``torch.from_dlpack(a)``, ``jax.dlpack.from_dlpack(a)``,
        ``numpy.from_dlpack(a)`` on the CPU). Supersampled values are averaged
        on the host and uploaded.
    progress : bool
        Show a progress bar over the strips of a large raster, once it has run
        for two seconds (the CLI turns it on unless ``-q``).

    Returns
    -------
    float32 array (height, width, C)
        C the texton's channels: NumPy, or a ``wp.array`` for
        ``output="warp"``. In expectation its mean is ``texton.mean`` and its
        lag-0 colour covariance ``texton.covariance()``; with a filter the
        mean is still ``texton.mean`` and the covariance (about) that of the
        noise averaged over the footprints, lower.

    Raises
    ------
    TextonError
        For a ``texton`` that is not a :class:`Texton`; a ``shape`` that is
        not a pair of positive integers or exceeds 2²⁸ pixels; ``mni``,
        ``scale``, ``cell_factor`` or a period component that is not a finite
        number > 0; a ``seed`` outside [0, 2³²); a non-finite ``rotation`` or
        ``offset``, or an ``offset`` that is not a pair; an unknown
        ``device``, ``poisson``, ``method`` or ``filter``; ``method="splat"``
        on CUDA; a ``jacobian`` that is not numeric, not of shape (2, 2) or
        (height, width, 2, 2), or holds NaN or infinite values; a
        ``supersample`` or ``max_aniso`` that is not an integer in [1, 64]; a
        ``fade_energy`` outside [0, 1]; a ``pixel_offset`` that is not a pair
        of integers within ±2³⁰; an ``output`` other than "numpy" or "warp";
        and parameters the kernels cannot run: positions beyond ±2³⁰ cells
        from the origin, a ``cell_factor`` or period so small that a point
        would visit more than 4096 cells, a ``cell_factor`` so large that a
        cell would hold more than 10⁵ impacts on average, a ``scale`` so small
        that the raster covers more than 2²⁶ cells or needs more than 2³⁰
        impacts; a period longer than 2³⁰ cells; an ``mni`` below 10⁻³ or a
        ``scale`` above 10⁴; and a request over the memory or work budget
        (docs/limits.md).

    Notes
    -----
    Rasters of more than ``canvas.STRIP_WORK`` pixels (4 Mi, less with a
    filter) are computed in strips of rows, each with its own block of
    impacts: the same values, a moving progress bar, and Ctrl-C that stops
    within a strip. The output (plus what handing it over copies) must fit
    the memory budget of :mod:`warp_texton.limits`. The first call in a
    process compiles the kernels for its device, or loads them from Warp's
    kernel cache (``~/.cache/warp/<warp version>`` by default). The model, the
    random cells and the kernels are described in docs/model.md §10.

    References
    ----------
    CGF eq. (1)-(2), §3.3, §4, §5, §8.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import read_image, analyze, synthesize
    >>> from warp_texton.demo import demo_texture_path
    >>> u = read_image(demo_texture_path())
    >>> texton = analyze(u, size=64, seed=0)
    >>> noise = synthesize(texton, shape=(1080, 1920), mni=30, seed=1, device="cpu")
    >>> noise.shape, noise.dtype
    ((1080, 1920, 1), dtype('float32'))
    >>> round(float(u.mean()), 3), round(float(noise.mean()), 3)
    (0.466, 0.466)

    A seamless 256 × 256 tile: the noise is periodic with period 256 texels,
    so one period to the right is the same tile:

    >>> tile = synthesize(texton, shape=(256, 256), period=(256, 256), seed=1, device="cpu")
    >>> next_tile = synthesize(texton, (256, 256), period=(256, 256), seed=1, offset=(256, 0), device="cpu")
    >>> bool(np.allclose(tile, next_tile, atol=1e-4))
    True

    Windows of the same noise join without a seam, and a window given by
    ``pixel_offset`` is bit for bit a part of the whole:

    >>> left = synthesize(texton, (128, 128), seed=1, device="cpu")
    >>> right = synthesize(texton, (128, 128), seed=1, offset=(128, 0), device="cpu")
    >>> both = synthesize(texton, (128, 256), seed=1, device="cpu")
    >>> bool(np.allclose(np.concatenate([left, right], axis=1), both, atol=1e-4))
    True
    >>> whole = synthesize(texton, (64, 96), scale=0.7, rotation=20, device="cpu")
    >>> part = synthesize(texton, (8, 8), scale=0.7, rotation=20, pixel_offset=(20, 30), device="cpu")
    >>> bool((part == whole[20:28, 30:38]).all())
    True

    The two raster methods give the same noise; ``poisson`` and
    ``cell_factor`` change the noise itself:

    >>> a = synthesize(texton, (128, 128), seed=1, device="cpu", method="splat")
    >>> b = synthesize(texton, (128, 128), seed=1, device="cpu", method="gather")
    >>> bool(np.allclose(a, b, atol=1e-5))
    True
    >>> approx = synthesize(texton, (128, 128), seed=1, poisson="gaussian", device="cpu")
    >>> coarse = synthesize(texton, (128, 128), seed=1, cell_factor=1.0, device="cpu")

    Filtering: seen from ten times further, one pixel covers 10 × 10 texels.
    Point-sampled, the noise keeps its full contrast as aliased grain;
    filtered, each pixel is about the mean of its 10 × 10 texels, as in the
    supersampled reference:

    >>> from warp_texton import FilterOptions
    >>> far = synthesize(texton, (64, 64), seed=1, scale=0.1, device="cpu")            # aliased
    >>> far_aa = synthesize(texton, (64, 64), seed=1, scale=0.1, filter="anisotropic", device="cpu")
    >>> ref = synthesize(texton, (64, 64), seed=1, scale=0.1, filter=FilterOptions("supersample", supersample=8),
    ...                  device="cpu")
    >>> [round(float(a.std()), 2) for a in (far, far_aa, ref)]
    [0.16, 0.07, 0.08]

    At scale 1 a pixel is one texel: nothing to filter, "mip" is exactly
    "none". Footprints can also be given per pixel, here 1 × 1 texel at the
    top to 1 × 20 texels at the bottom:

    >>> bool(np.array_equal(synthesize(texton, (64, 64), seed=1, filter="mip", device="cpu"),
    ...                     synthesize(texton, (64, 64), seed=1, device="cpu")))
    True
    >>> J = np.zeros((64, 64, 2, 2))
    >>> J[..., 0, 0] = 1.0
    >>> J[..., 1, 1] = np.linspace(1.0, 20.0, 64)[:, None]
    >>> blurred = synthesize(texton, (64, 64), seed=1, jacobian=J, filter="anisotropic", device="cpu")

    Errors name the argument:

    >>> from warp_texton import Texton, TextonError
    >>> t = Texton(np.full((8, 8, 1), 0.01), mean=[0.5])
    >>> for kwargs in ({"mni": 0}, {"period": (512,)}, {"offset": (1e12, 0)}, {"method": "fast"}, {"filter": "box"}):
    ...     try:
    ...         synthesize(t, (64, 64), device="cpu", **kwargs)
    ...     except TextonError as exc:
    ...         print(exc)
    mni must be a finite number > 0, got 0.0
    period must be a pair (Px, Py) of positive numbers, got (512,)
    the raster's positions reach 1e+12 texels from the origin; the noise is defined within ±5.8e+09 texels (2**30 cells)
    method must be one of auto, splat, gather, got 'fast'
    filter must be one of none, mip, anisotropic, supersample, got 'box'
    """
    h, w = check_shape(shape)
    seed = check_seed(seed)
    check_method(method)
    first = check_pixel_offset(pixel_offset)
    output = check_output(output)
    setup = noise_setup(texton, mni, period, cell_factor)
    origin, step = raster_geometry((h, w), scale, rotation, offset)
    options = FilterOptions.of(filter)
    J = step if jacobian is None else check_jacobian(jacobian, (h, w))
    device = resolve_device(device)
    raster_reach(origin, step, (h, w), setup, first)  # far positions are refused before any allocation
    filtered = needs_filtering(J, options)
    rec = params_record(texton, setup, seed, poisson)
    whole = RasterWindow(rec, setup, 0, texton.order, origin, step, (first[0], first[1]), float(scale))
    stack = TextonStack.of([setup.coeffs])
    parts = strips(h, w, pixel_cost(options, filtered))
    strip = (parts[0][1] - parts[0][0], w)
    # one check for the call: the output and one strip at a time in memory, every strip's work
    if filtered:
        work = filtered_work(texton, setup, J, options, h * w)
        strip_bytes = strip[0] * w * FILTER_BYTES_PER_PIXEL
        what = f"a {w}x{h} raster with filter {options.kind!r} at MNI {setup.mni:.6g}"
        hint = filter_hint(options)
        blocks = None
    else:
        method = resolve_method(method, device)
        blocks = [window_block(whole, (h, w))]
        strip_bytes, work, what = raster_cost([whole], (h, w), stack, blocks=blocks, splat=method == "splat")
        hint = "use a smaller raster or a lower mni"
        if len(parts) > 1:  # one strip's blocks at a time, each strip placing its own
            strip_bytes = raster_cost([whole], strip, stack, splat=method == "splat")[0]
            blocks = None
    check_raster_cost(result_bytes(1, h, w, texton.channels, device, output) + strip_bytes, work, what,
                      "use a smaller shape, or warp_texton.dask.synthesize_dask (or the CLI's .zarr output) "
                      "for rasters larger than memory", hint)
    p = params_struct(rec) if filtered else rec
    canvas = Canvas((h, w), device)
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
                rasters([win], stack, (r1 - r0, w), device, method, rows[r0:r1], blocks=blocks)
            bar.update(r1 - r0)
    finally:
        bar.close()
    return canvas.result(texton.channels, output)


def evaluate(
    texton: Texton,
    points,
    *,
    mni: float = 30.0,
    seed: int = 0,
    period=None,
    device=None,
    poisson: str = "exact",
    cell_factor: float = CELL_FACTOR,
    output: str = "numpy",
) -> np.ndarray | wp.array:
    """Texton noise at arbitrary points.

    Each point draws its neighbouring cells' impacts itself, so for full
    rasters :func:`synthesize` is much faster; use ``evaluate`` for scattered
    positions (texture coordinates, a warped grid, a few probes).

    Parameters
    ----------
    texton : Texton
    points : array (N, 2)
        Positions (x, y) in texel units, x to the right, y down; converted to
        float64.
    mni, seed, device, period, poisson, cell_factor
        As in :func:`synthesize`; the same values give the same noise, so
        ``synthesize(t, ...)[i, j]`` equals ``evaluate`` at that pixel's
        position to float32 rounding.
    output : {"numpy", "warp"}
        A NumPy array, or a ``wp.array`` on ``device`` (see :func:`synthesize`).

    Returns
    -------
    float32 array (N, C)
        NumPy, or a ``wp.array`` for ``output="warp"``. An empty (0, 2) array
        gives an empty (0, C) result.

    Raises
    ------
    TextonError
        When ``points`` is not numeric, not of shape (N, 2), holds NaN or
        infinite values or reaches beyond ±2³⁰ cells from the origin, and for
        the ``texton``, ``mni``, ``seed``, ``device``, ``period``,
        ``poisson``, ``cell_factor`` and ``output`` errors of
        :func:`synthesize`.

    References
    ----------
    CGF eq. (1)-(2), §3.3.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import read_image, analyze, synthesize, evaluate
    >>> from warp_texton.demo import demo_texture_path
    >>> texton = analyze(read_image(demo_texture_path()), size=64, seed=0)
    >>> points = np.array([[0.5, 0.5], [100.25, 37.75], [1.0e6, -2.0e6]])
    >>> evaluate(texton, points, mni=30, seed=1, device="cpu").shape
    (3, 1)

    The same noise as a raster: pixel (i, j) is at (j + 0.5, i + 0.5):

    >>> raster = synthesize(texton, (64, 64), mni=30, seed=1, device="cpu")
    >>> bool(np.allclose(evaluate(texton, [[10.5, 3.5]], seed=1, device="cpu"), raster[3, 10], atol=1e-4))
    True

    Any layout of positions, e.g. a polar grid (rows: angle, columns: radius):

    >>> r, a = np.meshgrid(np.linspace(0, 200, 100), np.linspace(0, 2 * np.pi, 360))
    >>> polar = evaluate(texton, np.stack([r * np.cos(a), r * np.sin(a)], axis=-1).reshape(-1, 2), seed=1,
    ...                  device="cpu")
    >>> polar.reshape(360, 100, 1).shape
    (360, 100, 1)
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
    mni = check_positive(mni, "mni")
    options = FilterOptions.of(filter)
    check_method(method)
    channels = textons[0].channels
    device = resolve_device(device)
    items_bytes = result_bytes(count, h, w, channels, device, output) + count * BATCH_ITEM_BYTES
    # before anything of size count is made (its parameters, its windows): what grows with count alone
    check_memory(items_bytes, f"a batch of {count} {h}x{w} rasters with {channels} channel(s)",
                 "use a smaller count or shape, or make the batch in parts")
    params = draw_batch_params(len(textons), count, seed, scale, rotation, offset, texton_index)
    setups = [noise_setup(t, mni, period, cell_factor) for t in textons]
    stack = TextonStack.of([s.coeffs for s in setups])
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
    canvas = Canvas((count, h, w), device)
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
            bar.update(1)
    finally:
        bar.close()
    return Batch(canvas.result(channels, output), params)


def filtered_work(texton: Texton, setup: NoiseSetup, J: np.ndarray, options: FilterOptions, count: int) -> float:
    """Operations of filtering ``count`` pixels whose footprints are ``J`` (any shape
    ending in (2, 2)), judged from up to COST_SAMPLES of them spread evenly."""
    J = J.reshape(-1, 2, 2)
    sample = J[np.linspace(0, len(J) - 1, min(len(J), COST_SAMPLES)).astype(np.int64)]
    return count * filter_work(texton, setup, sample, options)


def filter_hint(options: FilterOptions) -> str:
    """What to change when filtering with ``options`` is over the work budget."""
    knob = FILTER_KNOBS.get(options.kind)
    return f"use a smaller {knob}, a smaller raster or a lower mni" if knob else "use a smaller raster or a lower mni"


def check_batch_cost(textons: list[Texton], setups: list[NoiseSetup], h: int, w: int, windows: dict, groups: list,
                     filtered: list, stack: TextonStack, options: FilterOptions, method: str,
                     items_bytes: float) -> None:
    """The budget check of a batch: its output and items (``items_bytes``) with the
    largest group's blocks or one filtered item's pixels in memory; the work of
    every group and every filtered item."""
    work, nbytes = 0.0, 0.0
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
    what = f"a batch of {len(windows) + len(filtered)} {h}x{w} rasters at MNI {mni:.6g}"
    if filtered:
        what += f" ({len(filtered)} with filter {options.kind!r})"
    check_raster_cost(items_bytes + nbytes, work, what, "use a smaller count or shape, or make the batch in parts",
                      filter_hint(options) if filtered else "use a smaller count or shape, or a lower mni")


def _runs(items: list[int]) -> list[tuple[int, int]]:
    """Maximal runs [k0, k1) of consecutive integers in the sorted list ``items``."""
    runs = []
    for k in items:
        if runs and runs[-1][1] == k:
            runs[-1][1] = k + 1
        else:
            runs.append([k, k + 1])
    return [(a, b) for a, b in runs]
