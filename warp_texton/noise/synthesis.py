"""Texton noise on rasters, batches of rasters and points: the public front ends.

Each function validates its arguments, checks the budgets of the whole call
once, then dispatches to the engine (:mod:`warp_texton.noise.raster` for plain
rasters, :mod:`warp_texton.noise.engine` for points) or to the filters in
:mod:`warp_texton.noise.filtering`.

Large rasters are computed in strips of rows of bounded work, each a window
of the same raster with its own block of impacts (windows are bit-identical
to the same pixels of a larger raster), so that memory for impacts stays
small, a progress bar can count strips, and Ctrl-C waits for one strip at
most. Batches put many small rasters into one count/emit/splat pass (CPU) or
one gather launch (CUDA).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..core.checks import check_seed
from ..core.runtime import progress_bar, resolve_device
from .canvas import Canvas, check_output, lanes_for, result_bytes, strips
from ..core.errors import TextonError
from .filtering import (COST_HINT_NAMES, COST_SAMPLES, FILTER_BYTES_PER_PIXEL, FilterOptions, RasterPixels,
                        check_jacobian, filter_pixels, filter_work, needs_filtering, pixel_cost, pixel_shares)
from .engine import (CELL_FACTOR, POINT_BYTES, NoiseSetup, check_cell_range, check_points_cost, noise_params,
                     noise_setup, params_record, params_struct, point_values)
from .noise_options import NoiseOptions, check_period
from .raster import (MAX_PIXEL_INDEX, RasterWindow, TextonStack, check_method, check_pixel_offset,  # noqa: F401 (0.2 names)
                     check_points, check_raster_cost, raster_cost, raster_placement, raster_reach, rasters,
                     resolve_method, window_block)
from ..model.noise_tables import at_mni
from ..model.texton import Texton
from ..model.tiling import TilingModel
from .tiling import MAX_TILING_REACH, tiling_at, tiling_pixels
from .tiling_filtering import tiling_filter_work, tiling_filtered_raster, tiling_options, tiling_supersampled
from .tiling import refuse_texton_options as _refuse_texton_options
from ..core.limits import check_memory, check_work

if TYPE_CHECKING:
    import warp as wp

def synthesize(
    texton: Texton | TilingModel,
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
    noise: NoiseOptions | None = None,
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
        docs/limits.md); a longer one is refused. A tiling model takes any
        period up to 2³⁰ texels; its triangle lattice shrinks slightly to fit
        (docs/tiling.md, "Periodic tiles").
    device : str, optional
        "cpu", "cuda", "cuda:N"; default CUDA when available, else CPU.
    poisson : {"exact", "gaussian"}
        Cell counts exactly Poisson, or the rounded Gaussian approximation of
        the authors' viewer.
    cell_factor : float
        Side of the random cells relative to the side of the texton's support
        (> 0; CGF §8 uses ~0.6). A different value gives a different, equally
        valid, noise.
    noise : NoiseOptions, optional
        ``mni``, ``seed``, ``period``, ``poisson`` and ``cell_factor`` as one
        value (:class:`~warp_texton.NoiseOptions`), in place of those keywords,
        which must then keep their defaults.
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
        (:func:`warp_texton.noise.filtering.kept_levels`) fade to the texton's mean;
        supersamples beyond the noise's cell range count as the mean. A tiling
        model takes the same filters, through a MIP pyramid of its example
        (docs/tiling.md, "Filtering"; ``fade_energy`` does not apply).
    pixel_offset : (row, column) of integers
        Within ±2³⁰. Make the result the window of pixels ``pixel_offset`` +
        (i, j) of the raster that ``offset``, ``scale`` and ``rotation``
        place: windows of one raster are then bit for bit the same pixels as
        one call for the whole (:mod:`warp_texton.noise.dask_arrays` computes chunks this
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
    the memory budget of :mod:`warp_texton.core.limits`. The first call in a
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
    if isinstance(texton, TilingModel):
        return _synthesize_tiling(texton, shape, seed=seed, scale=scale, rotation=rotation, offset=offset,
                                  period=period, device=device, pixel_offset=pixel_offset, output=output,
                                  jacobian=jacobian, filter=filter,
                                  texton_only=dict(mni=(mni, 30.0),
                                                   poisson=(poisson, "exact"), cell_factor=(cell_factor, CELL_FACTOR),
                                                   method=(method, "auto"), noise=(noise, None)))
    (h, w), first, origin, step = raster_placement(shape, scale, rotation, offset, pixel_offset)
    noise = NoiseOptions.given(noise, mni=mni, seed=seed, period=period, poisson=poisson, cell_factor=cell_factor)
    texton = at_mni(texton, noise.mni)  # the histogram tables of this MNI's noise
    seed = noise.seed
    check_method(method)
    output = check_output(output)
    setup = noise_setup(texton, noise.mni, noise.period, noise.cell_factor)
    options = FilterOptions.of(filter)
    J = step if jacobian is None else check_jacobian(jacobian, (h, w))
    device = resolve_device(device)
    raster_reach(origin, step, (h, w), setup, first)  # far positions are refused before any allocation
    filtered = needs_filtering(J, options)
    rec = params_record(texton, setup, seed, noise.poisson)
    whole = RasterWindow(rec, setup, 0, texton.order, origin, step, (first[0], first[1]), float(scale))
    # a grey texton's raster reads and writes one float a texel
    lanes = lanes_for([texton])
    stack = TextonStack.of([setup.coeffs], lanes)
    parts = strips(h, w, pixel_cost(options, filtered))
    strip = (parts[0][1] - parts[0][0], w)
    # one check for the call: the output and one strip at a time in memory, every strip's work
    if filtered:
        work = filtered_work(texton, setup, J, options, h * w)
        strip_bytes = strip[0] * w * FILTER_BYTES_PER_PIXEL
        what = f"a {w}x{h} raster with filter {options.kind!r} at MNI {setup.mni:.6g}"
        hint = options.spec.cost_hint
        blocks = None
    else:
        method = resolve_method(method, device)
        blocks = [window_block(whole, (h, w))]
        strip_bytes, work, what = raster_cost([whole], (h, w), stack, blocks=blocks, splat=method == "splat")
        hint = "use a smaller raster or a lower mni"
        if len(parts) > 1:  # one strip's blocks at a time, each strip placing its own
            strip_bytes = raster_cost([whole], strip, stack, splat=method == "splat")[0]
            blocks = None
    check_raster_cost(result_bytes(1, h, w, texton.channels, device, output, lanes) + strip_bytes, work, what,
                      "use a smaller shape, or warp_texton.noise.dask_arrays.synthesize_dask (or the CLI's .zarr output) "
                      "for rasters larger than memory", hint, mentions=("shape", *COST_HINT_NAMES))
    p = params_struct(rec) if filtered else rec
    canvas = Canvas((h, w), device, lanes)
    rows = canvas.rows(w)
    bar = progress_bar(progress and len(parts) > 1, h, "synthesize", "row")
    try:
        for r0, r1 in parts:
            at = (first[0] + r0, first[1])
            if filtered:
                fp = J if J.ndim == 2 else J[r0:r1]
                pixels = RasterPixels((r1 - r0, w), origin, step, fp, first=at)
                filter_pixels(p, texton, setup, pixels, options, device, seed, out=canvas.pixels(r0 * w, r1 * w))
                if texton.histogram is not None:
                    canvas.keep_shares(r0 * w, r1 * w, pixel_shares(texton, pixels, options))
            else:
                win = RasterWindow(p, setup, 0, texton.order, origin, step, at, float(scale))
                rasters([win], stack, (r1 - r0, w), device, method, rows[r0:r1], blocks=blocks)
            bar.update(r1 - r0)
    finally:
        bar.close()
    return canvas.result(texton.channels, output, textons=[texton])


def evaluate(
    texton: Texton | TilingModel,
    points,
    *,
    mni: float = 30.0,
    seed: int = 0,
    period=None,
    device=None,
    poisson: str = "exact",
    cell_factor: float = CELL_FACTOR,
    noise: NoiseOptions | None = None,
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
    mni : float
        As in :func:`synthesize`.
    seed : int
        As in :func:`synthesize`; the same values give the same noise, so
        ``synthesize(t, ...)[i, j]`` equals ``evaluate`` at that pixel's
        position to float32 rounding.
    device : str, optional
        As in :func:`synthesize`.
    period : (Px, Py), optional
        As in :func:`synthesize`.
    poisson : {"exact", "gaussian"}
        As in :func:`synthesize`.
    cell_factor : float
        As in :func:`synthesize`.
    noise : NoiseOptions, optional
        As in :func:`synthesize`: the five options above as one value.
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
        infinite values or reaches beyond ±2³⁰ cells from the origin, for more
        points than the memory budget holds (priced before they are read), and for
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
    pts = check_points(points, POINT_BYTES, "evaluating")
    if isinstance(texton, TilingModel):
        _refuse_texton_options(dict(mni=(mni, 30.0), poisson=(poisson, "exact"),
                                    cell_factor=(cell_factor, CELL_FACTOR), noise=(noise, None)))
        seed = check_seed(seed)
        output = check_output(output)
        check_tiling_reach(pts)
        per = check_tiling_period(period)
        return _tiling_output(tiling_at(texton, np.ascontiguousarray(pts), seed, device, per), output, device)
    noise = NoiseOptions.given(noise, mni=mni, seed=seed, period=period, poisson=poisson, cell_factor=cell_factor)
    texton = at_mni(texton, noise.mni)  # the histogram tables of this MNI's noise
    output = check_output(output)
    setup = noise_setup(texton, noise.mni, noise.period, noise.cell_factor)
    if pts.size:
        check_cell_range(pts[:, 0].min() - setup.hi[0], pts[:, 0].max() - setup.lo[0], setup.cell[0], "points")
        check_cell_range(pts[:, 1].min() - setup.hi[1], pts[:, 1].max() - setup.lo[1], setup.cell[1], "points")
    check_points_cost(setup, pts.shape[0], f"{pts.shape[0]} points")
    device = resolve_device(device)
    p = noise_params(texton, setup, noise.seed, noise.poisson)
    n = pts.shape[0]
    canvas = Canvas((n,), device, lanes_for([texton]))
    if n:
        point_values(p, setup.coeffs, np.ascontiguousarray(pts), device, canvas.pixels(0, n))
    return canvas.result(texton.channels, output, textons=[texton])


def filtered_work(texton: Texton, setup: NoiseSetup, J: np.ndarray, options: FilterOptions, count: int) -> float:
    """Operations of filtering ``count`` pixels whose footprints are ``J`` (any shape
    ending in (2, 2)), judged from up to COST_SAMPLES of them spread evenly."""
    J = J.reshape(-1, 2, 2)
    sample = J[np.linspace(0, len(J) - 1, min(len(J), COST_SAMPLES)).astype(np.int64)]
    return count * filter_work(texton, setup, sample, options)


# ---------------------------------------------------------------- tiling models

#: Tiling models place points with float64 lattice indices in int32: positions stay within ±2³⁰ texels.
# (defined with the tiling drivers, which the ground plane shares)


def check_tiling_reach(pts: np.ndarray) -> None:
    if pts.size and np.abs(pts).max() > MAX_TILING_REACH:
        raise TextonError(f"points reach {np.abs(pts).max():.3g} texels from the origin; a tiling model is "
                          f"defined within ±{MAX_TILING_REACH:.3g} texels", param="points")


def _tiling_output(values, output: str, device):
    """NumPy values as ``output`` asks; a device array that is already the output as it is."""
    if output == "numpy" or not isinstance(values, np.ndarray):
        return values
    import warp as wp

    return wp.array(values, dtype=float, device=resolve_device(device))


def check_tiling_period(period) -> tuple[float, float] | None:
    """None, or the period (Px, Py) of a tiling model's noise: positive, at most ±2³⁰ texels."""
    if period is None:
        return None
    px, py = check_period(period)
    if max(px, py) > MAX_TILING_REACH:
        raise TextonError(f"period ({px:g}, {py:g}): a tiling model's period is at most {MAX_TILING_REACH:.3g} "
                          "texels", param="period")
    return px, py


def _synthesize_tiling(model: TilingModel, shape, *, seed, scale, rotation, offset, period, device, pixel_offset,
                       output, jacobian, filter, texton_only):
    """``synthesize`` for a :class:`TilingModel`: any window, offset, scale, rotation, period and filter."""
    _refuse_texton_options(texton_only)
    period = check_tiling_period(period)
    options = tiling_options(FilterOptions.of(filter))
    (h, w), first, origin, step = raster_placement(shape, scale, rotation, offset, pixel_offset)
    seed = check_seed(seed)
    output = check_output(output)
    corners = origin[:, None] + step @ np.array([[first[1], first[1] + w, first[1], first[1] + w],
                                                 [first[0], first[0], first[0] + h, first[0] + h]], np.float64)
    check_tiling_reach(corners.T)
    device = resolve_device(device)
    J = step if jacobian is None else check_jacobian(jacobian, (h, w))
    if not needs_filtering(J, options):
        return _tiling_output(tiling_pixels(model, (h, w), origin, step, first, seed, device, period, output), output,
                              device)
    what = f"a {w}x{h} raster of a tiling model with filter {options.kind!r}"
    check_memory(float(h * w) * FILTER_BYTES_PER_PIXEL, what, "use a smaller shape", mentions=("shape",))
    check_work(tiling_filter_work(options, h * w), what, options.spec.cost_hint, mentions=("shape", *COST_HINT_NAMES))
    if options.spec.supersamples:
        pixels = RasterPixels((h, w), origin, step, J, first=first)
        values = tiling_supersampled(model, pixels, options.supersample, seed, device, period).reshape(h, w, -1)
    else:
        values = tiling_filtered_raster(model, (h, w), origin, step, first, J, options, seed, device, period)
    return _tiling_output(values, output, device)
