"""Texton noise on rasters and at points: the public front ends.

Each function validates its arguments, then dispatches to the engine in
:mod:`warp_texton.noise` (plain rasters and points) or to the filters in
:mod:`warp_texton.filtering`.
"""

from __future__ import annotations

import numpy as np

from ._checks import as_real_array, check_seed, check_shape
from ._runtime import resolve_device
from .errors import TextonError
from .filtering import (COST_SAMPLES, FilterOptions, RasterPixels, check_filter_cost, check_jacobian,
                        filter_pixels, needs_filtering)
from .noise import (CELL_FACTOR, METHODS, check_cell_range, check_points_cost, noise_params, noise_setup,
                    point_values, raster, raster_geometry, raster_reach)
from .texton import Texton


def synthesize(
    texton: Texton,
    shape=(512, 512),
    mni: float = 30.0,
    seed: int = 0,
    scale: float = 1.0,
    rotation: float = 0.0,
    offset=(0.0, 0.0),
    period=None,
    device=None,
    *,
    poisson: str = "exact",
    cell_factor: float = CELL_FACTOR,
    method: str = "auto",
    jacobian=None,
    filter="none",
) -> np.ndarray:
    """Texton noise on an H × W raster.

    Pixel (i, j) is the noise at x = offset + R(rotation) · ((j + ½)/scale, (i + ½)/scale)
    in texel units, so ``scale`` is pixels per texel and ``rotation`` (degrees)
    turns the noise. Any window of the infinite noise can be made, and windows
    whose offsets differ by their width join without a seam.

    Parameters
    ----------
    texton : Texton
    shape : (height, width)
    mni : float
        Mean number of impacts per point; λ = mni / texton.support_area.
    seed : int
        In [0, 2**32).
    scale, rotation, offset
        The raster's placement in the noise (see above).
    period : (Px, Py), optional
        Make the noise exactly periodic with these periods (texel units):
        ``synthesize(t, (H, W), period=(W, H))`` is a seamless tile.
    device : str, optional
        "cpu", "cuda", "cuda:N"; default CUDA when available, else CPU.
    poisson : {"exact", "gaussian"}
        Cell counts exactly Poisson, or the rounded Gaussian approximation of
        the authors' viewer.
    cell_factor : float
        Cell side relative to the texton support side (CGF §8 uses ~0.6).
    method : {"auto", "splat", "gather"}
        How the raster is computed; both give the same noise. "auto" splats
        on the CPU (threads own row bands) and gathers on CUDA (a thread per
        pixel).
    jacobian : array (2, 2) or (height, width, 2, 2), optional
        Each pixel's footprint in texel space: columns are the texel-space
        steps of one pixel to the right and one pixel down. Default: the
        raster's own steps, R(rotation) / scale. Only the filters read it.
    filter : str or FilterOptions
        Anti-aliasing for the footprint (CGF §5): "none", "mip",
        "anisotropic" or "supersample" with default settings, or a
        :class:`~warp_texton.FilterOptions` (``max_aniso``, ``supersample``,
        ``fade_energy``). Where every footprint needs a single lookup of the
        unfiltered texton, "mip" and "anisotropic" are exactly "none".
        Footprints past the last kept MIP level fade to the texton mean;
        supersamples beyond the noise's cell range count as the mean.

    Returns
    -------
    float32 array (height, width, C)

    References
    ----------
    CGF eq. (1)-(2), §3.3, §4, §5, §8.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import FilterOptions, Texton, synthesize
    >>> t = Texton(np.random.default_rng(0).standard_normal((8, 8, 1)) / 8, [0.5])
    >>> synthesize(t, (32, 48), device="cpu").shape
    (32, 48, 1)
    >>> far = synthesize(t, (16, 16), scale=0.1, filter=FilterOptions("anisotropic", max_aniso=4), device="cpu")
    """
    h, w = check_shape(shape)
    seed = check_seed(seed)
    if not isinstance(method, str) or method not in METHODS:
        raise TextonError(f"method must be one of {', '.join(METHODS)}, got {method!r:.60}")
    setup = noise_setup(texton, mni, period, cell_factor)
    origin, step = raster_geometry((h, w), scale, rotation, offset)
    options = FilterOptions.of(filter)
    J = step if jacobian is None else check_jacobian(jacobian, (h, w))
    device = resolve_device(device)
    p = noise_params(texton, setup, seed, poisson)
    if needs_filtering(J, options):
        raster_reach(origin, step, (h, w), setup)
        sample = J.reshape(-1, 2, 2)
        sample = sample[np.linspace(0, len(sample) - 1, min(len(sample), COST_SAMPLES)).astype(np.int64)]
        check_filter_cost(texton, setup, h * w, sample, options, f"a {w}x{h} raster")
        out = filter_pixels(p, texton, setup, RasterPixels((h, w), origin, step, J), options, device, seed)
        out = out.reshape(h, w, 3)
    else:
        out = raster(p, setup, setup.coeffs, texton.order, (h, w), origin, step, device, method, scale)
    return np.ascontiguousarray(out[:, :, : texton.channels])


def evaluate(
    texton: Texton,
    points,
    mni: float = 30.0,
    seed: int = 0,
    device=None,
    *,
    period=None,
    poisson: str = "exact",
    cell_factor: float = CELL_FACTOR,
) -> np.ndarray:
    """Texton noise at arbitrary points.

    Parameters
    ----------
    texton : Texton
    points : array (N, 2)
        Positions (x, y) in texel units, x to the right, y down.
    mni, seed, device, period, poisson, cell_factor
        As in :func:`synthesize`; the same values give the same noise, so
        ``synthesize(t, ...)[i, j]`` equals ``evaluate`` at that pixel's position.

    Returns
    -------
    float32 array (N, C)

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton, evaluate
    >>> t = Texton(np.ones((4, 4, 1)) / 4, [0.5])
    >>> evaluate(t, [[0.5, 0.5], [1e6, -3.25]], device="cpu").shape
    (2, 1)
    """
    pts = as_real_array(points, "points", "an array of shape (N, 2) of numbers")
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise TextonError(f"points must have shape (N, 2), got {pts.shape}")
    if not np.isfinite(pts).all():
        raise TextonError(f"points contain {int((~np.isfinite(pts)).sum())} NaN or infinite values")
    seed = check_seed(seed)
    setup = noise_setup(texton, mni, period, cell_factor)
    if pts.size:
        check_cell_range(pts[:, 0].min() - setup.hi[0], pts[:, 0].max() - setup.lo[0], setup.cell[0], "points")
        check_cell_range(pts[:, 1].min() - setup.hi[1], pts[:, 1].max() - setup.lo[1], setup.cell[1], "points")
    check_points_cost(setup, pts.shape[0], f"{pts.shape[0]} points")
    device = resolve_device(device)
    p = noise_params(texton, setup, seed, poisson)
    out = point_values(p, setup.coeffs, np.ascontiguousarray(pts), device)
    return np.ascontiguousarray(out[:, : texton.channels])
