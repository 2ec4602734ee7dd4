"""Anti-aliased texton noise (CGF §5): the texton's MIP pyramid, footprints, the filters.

Averaging texton noise over a pixel's footprint noise_filter gives the noise of the
filtered texton h ∗ 1_F/|noise_filter| with the same impacts, so filtering the noise is
filtering the texton. ``"mip"`` and ``"anisotropic"`` look the filtered texton
up in a MIP pyramid of block means (see kernels/noise_filter.py);
``"supersample"`` averages n × n jittered evaluations per pixel, the
reference they are measured against. The options of a filter,
:class:`~warp_texton.FilterOptions`, and the registry of kinds,
:data:`FILTERS`, are defined in :mod:`warp_texton.noise.filter_options` and are part
of this module's interface too.

A footprint is the 2 × 2 Jacobian J of the texel position with respect to the
pixel position: its columns are the texel-space steps of one pixel to the
right and one pixel down, so the pixel covers x + J [-½, ½]².

Pixels come as a :class:`PixelSet` (a raster's here, a plane view's in
:mod:`warp_texton.noise.ground_plane`), and :func:`filter_pixels` is the one dispatcher
from a :class:`FilterOptions` to the kernels.

Kernels driven here: ``warp_texton.kernels.noise_filter``, ``warp_texton.kernels.noise_raster``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np
import warp as wp

from ..core.checks import as_real_array
from ..core.runtime import map_points, split_launch
from ..core.errors import TextonError
# the options and the registry of kinds are part of this module's interface too
from .filter_options import (FADE_ENERGY, FILTERS, LOD_BIAS, MAX_ANISO, MAX_LOD_BIAS, MAX_MAX_ANISO,  # noqa: F401
                             MAX_SUPERSAMPLE, SUPERSAMPLE, FilterKind, FilterOptions)
from ..kernels import noise_filter
from ..kernels.noise_raster import PAD
from ..core.limits import check_memory, check_work
from .colours import footprint_shares, shares_of
from .engine import NoiseSetup, cell_limit, params_mean, point_values, support_reach, visits_per_point, walk_cost
from ..model.texton import Texton, lag0_covariance

MAX_FOOTPRINT = 1.0e12
"""Footprint entries are clamped to ±this many texels: far past the coarsest
MIP level, where the filtered noise is its mean, and safe in float32."""
SUPERSAMPLE_BATCH = 1 << 22
"""Sub-pixel evaluations per batch when supersampling (bounds host memory)."""
COST_SAMPLES = 4096
"""Footprints sampled (evenly over the pixels) to estimate a filter's work."""
FILTER_BYTES_PER_PIXEL = 160
"""Host bytes per filtered pixel: keys, centres and footprints (float64), the
float32 copies sent to the kernels, the (N, 3) result and its reshaped copy."""


COST_HINT_NAMES = ("supersample", "max_aniso", "fade_energy", "mni")
"""The arguments the filters' cost hints name."""

POINT_COST = 8
"""What one filtered pixel costs, in raster pixels (a walk over its cells per
lookup): it sizes the strips of filtered rasters and plane views."""


def pixel_cost(options: FilterOptions, filtered: bool = True) -> int:
    """What one pixel costs with ``options``, in raster pixels."""
    if not filtered:
        return 1
    if options.spec.supersamples:
        return POINT_COST * options.supersample ** 2
    if options.spec.axis_lookups:
        return POINT_COST * max(1, options.max_aniso // 2)
    return POINT_COST


# ------------------------------------------------------------------ pyramid
def texton_pyramid(texton: Texton) -> list[np.ndarray]:
    """The MIP levels of a texton's coefficients, from the coefficients down to a single one.

    Parameters
    ----------
    texton : Texton

    Returns
    -------
    list of float32 arrays (r_ℓ, s_ℓ, C)
        Level 0 is ``texton.coeffs``; level ℓ + 1 holds the means of the
        2 × 2 blocks of level ℓ, an odd side padded with zeros; the last level
        is (1, 1, C).

    Notes
    -----
    The texton of level ℓ,

        h_ℓ(y) = Σ_k α_ℓ(k) ψ((y − (2^ℓ − 1)/2) / 2^ℓ − k),

    has the integral of the texton h at every level: ``4**ℓ * levels[ℓ].sum()``
    is ``texton.integral``. The filters use the first
    :func:`kept_levels` of them. Derivation: docs/model.md §13.

    References
    ----------
    CGF §5 (the filtered texton, looked up in a MIP pyramid).

    Examples
    --------
    A 6 × 6 texton of integral 1 has levels of sides 6, 3, 2 (3 padded to 4)
    and 1, each of integral 1:

    >>> import numpy as np
    >>> from warp_texton import Texton
    >>> texton = Texton(np.arange(1, 37).reshape(6, 6, 1) / 666, [0.5])
    >>> levels = texton_pyramid(texton)
    >>> [lv.shape[0] for lv in levels], texton.integral
    ([6, 3, 2, 1], array([1.]))
    >>> [round(float(lv.sum()) * 4**ell, 4) for ell, lv in enumerate(levels)]
    [1.0, 1.0, 1.0, 1.0]
    """
    levels = [np.asarray(texton.coeffs, np.float64)]
    while max(levels[-1].shape[:2]) > 1:
        a = levels[-1]
        r, s = a.shape[:2]
        padded = np.zeros((r + r % 2, s + s % 2, a.shape[2]))
        padded[:r, :s] = a
        levels.append(padded.reshape(padded.shape[0] // 2, 2, padded.shape[1] // 2, 2, -1).mean(axis=(1, 3)))
    return [lv.astype(np.float32) for lv in levels]


def level_energies(texton: Texton, levels=None) -> np.ndarray:
    """The share of the noise's variance that the noise of each MIP level keeps.

    Parameters
    ----------
    texton : Texton
    levels : list of arrays, optional
        A pyramid already computed by :func:`texton_pyramid` for ``texton``
        (default: computed here).

    Returns
    -------
    float64 array (L,)
        ∫h_ℓ h_ℓᵀ / ∫h hᵀ for every level ℓ (traces: summed over channels):
        1 at level 0, decreasing; all ones for a texton of zero energy.

    Notes
    -----
    ∫h_ℓ² = 4^ℓ Σ_τ b(τ) Σ_x α_ℓ(x) α_ℓ(x + τ), where b is the autocorrelation
    of the texton's B-spline ψ and α_ℓ the coefficients of level ℓ
    (docs/model.md §13, "Choosing the level").

    Examples
    --------
    >>> from warp_texton import analyze, read_image
    >>> from warp_texton.demo import demo_texture_path
    >>> texton = analyze(read_image(demo_texture_path()), size=64, seed=0)
    >>> level_energies(texton).round(2)
    array([1.  , 0.64, 0.38, 0.19, 0.08, 0.02, 0.01])
    """
    levels = texton_pyramid(texton) if levels is None else levels
    e = np.array([4.0 ** ell * np.trace(np.atleast_2d(lag0_covariance(a.astype(np.float64), texton.order)))
                  for ell, a in enumerate(levels)])
    return e / e[0] if e[0] > 0 else np.ones_like(e)


def kept_levels(texton: Texton, levels=None, fade_energy: float = FADE_ENERGY) -> int:
    """How many MIP levels the filters use.

    Parameters
    ----------
    texton : Texton
    levels : list of float32 arrays, optional
        The texton's :func:`texton_pyramid`, when it is at hand; default:
        computed here.
    fade_energy : float
        The share of the variance (:func:`level_energies`) below which the
        pyramid ends; default :data:`~warp_texton.noise.filtering.FADE_ENERGY`, as
        in :class:`~warp_texton.FilterOptions`. 0 keeps every level.

    Returns
    -------
    int
        The levels up to and including the first whose share is below
        ``fade_energy``; all of them if none is. Past the last one the
        filtered noise fades to its mean (docs/model.md §13, "Choosing the
        level").

    Examples
    --------
    The texton of the demo texture keeps 5 of its 7 levels:

    >>> from warp_texton import analyze, read_image
    >>> from warp_texton.demo import demo_texture_path
    >>> levels = texton_pyramid(texton := analyze(read_image(demo_texture_path()), size=64, seed=0))
    >>> kept_levels(texton, levels)  # shares 1, 0.64, 0.38, 0.19, 0.08: levels 0 to 4, then the mean
    5
    >>> kept_levels(texton, levels, fade_energy=0.0)
    7
    """
    e = level_energies(texton, levels)
    below = np.flatnonzero(e < fade_energy)
    return int(below[0]) + 1 if below.size else len(e)


@dataclass(frozen=True)
class PyramidStack:
    """The MIP levels of a texton as the filters read them: the padded levels stacked in
    rows of one array, and where each level lies and what it covers (kernels/noise_filter.py,
    ``Pyramid``; the GLSL export reads the same values)."""

    coeffs: np.ndarray  # (Σ rows, s + 2 PAD, 3) float32
    row0: np.ndarray  # int32 (L,): first row of each level
    rows: np.ndarray  # int32 (L,)
    step: np.ndarray  # float32 (L,): texel side 2^ℓ
    origin: np.ndarray  # float32 (L,): position of coefficient (0, 0)
    lo: np.ndarray  # float32 (L, 2): h_ℓ vanishes outside [lo, hi] relative to the impact
    hi: np.ndarray
    levels: int  # the kept levels (kept_levels)
    order: int


def pyramid_stack(texton: Texton, fade_energy: float = FADE_ENERGY) -> PyramidStack:
    """The texton's MIP levels stacked as the filters read them (:class:`PyramidStack`)."""
    levels = texton_pyramid(texton)
    reach = support_reach(texton.order)
    width = levels[0].shape[1] + 2 * PAD
    rows = [lv.shape[0] + 2 * PAD for lv in levels]
    row0 = np.concatenate([[0], np.cumsum(rows)[:-1]]).astype(np.int32)
    stack = np.zeros((sum(rows), width, 3), np.float32)
    lo, hi, step, origin = [], [], [], []
    for ell, (lv, r0) in enumerate(zip(levels, row0)):
        r, s = lv.shape[:2]
        stack[r0 + PAD:r0 + PAD + r, PAD:PAD + s, : texton.channels] = lv
        sz = float(2 ** ell)
        o = (sz - 1.0) / 2.0
        step.append(sz)
        origin.append(o)
        lo.append((o - sz * reach, o - sz * reach))
        hi.append((o + sz * (s - 1 + reach), o + sz * (r - 1 + reach)))
    return PyramidStack(stack, row0, np.array(rows, np.int32), np.array(step, np.float32),
                        np.array(origin, np.float32), np.array(lo, np.float32), np.array(hi, np.float32),
                        kept_levels(texton, levels, fade_energy), texton.order)


def pyramid_struct(texton: Texton, fade_energy: float = FADE_ENERGY, lanes: int = 3) -> noise_filter.Pyramid | noise_filter.Pyramid1:
    """The kernels' ``Pyramid`` of ``texton`` (arrays on the current device); with
    ``lanes`` 1 (a grey texton), a ``Pyramid1`` of float coefficients."""
    st = pyramid_stack(texton, fade_energy)
    pyr: noise_filter.Pyramid | noise_filter.Pyramid1
    if lanes == 1:
        pyr = noise_filter.Pyramid1()
        pyr.coeffs = wp.array(np.ascontiguousarray(st.coeffs[..., 0]), dtype=wp.float32)
    else:
        pyr = noise_filter.Pyramid()
        pyr.coeffs = wp.array(st.coeffs, dtype=wp.vec3)
    pyr.row0 = wp.array(st.row0, dtype=wp.int32)
    pyr.rows = wp.array(st.rows, dtype=wp.int32)
    pyr.step = wp.array(st.step, dtype=float)
    pyr.origin = wp.array(st.origin, dtype=float)
    pyr.lo = wp.array(st.lo, dtype=wp.vec2)
    pyr.hi = wp.array(st.hi, dtype=wp.vec2)
    pyr.levels = st.levels
    pyr.order = st.order
    return pyr


# --------------------------------------------------------------- footprints
def check_jacobian(jacobian, shape) -> np.ndarray:
    """A constant (2, 2) or per-pixel (H, W, 2, 2) footprint, as float64.

    Entries must be finite. Zero and degenerate footprints are accepted (no
    filtering along the missing direction); entries beyond ±MAX_FOOTPRINT are
    clamped there, where the filtered noise is its mean.
    """
    J = as_real_array(jacobian, "jacobian", "an array of shape (2, 2) or (H, W, 2, 2) of numbers")
    h, w = shape
    if J.shape not in ((2, 2), (h, w, 2, 2)):
        raise TextonError(f"jacobian must have shape (2, 2) or ({h}, {w}, 2, 2) for this raster, got {J.shape}",
                          param="jacobian")
    if not np.isfinite(J).all():
        raise TextonError(f"jacobian contains {int((~np.isfinite(J)).sum())} NaN or infinite values; "
                          "footprints must be finite (use 0 for no filtering)", param="jacobian")
    return np.clip(J, -MAX_FOOTPRINT, MAX_FOOTPRINT)


def footprint_levels(J: np.ndarray, options: FilterOptions):
    """The lookups per pixel and the MIP level that a filter chooses for footprints.

    The kernels make the same choice; this is its host copy, for measuring
    and explaining it.

    Parameters
    ----------
    J : array (..., 2, 2)
        Footprints: the Jacobians of the texel position with respect to the
        pixel position (column, row), as :meth:`warp_texton.noise.ground_plane.PlaneCamera.footprints`
        gives them and ``synthesize(..., jacobian=...)`` takes them.
    options : FilterOptions
        Of kind ``"mip"`` or ``"anisotropic"``.

    Returns
    -------
    n : int array
        Lookups per pixel, of J's leading shape (1 for ``"mip"``).
    lod : float array
        The MIP level, of J's leading shape, before the clamp at 0 and the
        fade past the last kept level (:func:`kept_levels`).

    Notes
    -----
    With major and minor the singular values of J and ``bias`` =
    ``options.bias`` (``options.lod_bias``, or ``LOD_BIAS[kind]`` when it is
    ``None``): for ``"anisotropic"``,

        n = min(⌈major / minor⌉, max_aniso),   lod = log2 max(minor, major / n) + bias;

    for ``"mip"``, n = 1 and lod = log2 major + bias (docs/model.md §13,
    "Anisotropic lookups").

    References
    ----------
    CGF §5.

    Examples
    --------
    The footprint of the plane benchmark's camera at a pixel a quarter of the
    way down, in the middle column:

    >>> from warp_texton import FilterOptions
    >>> from warp_texton.noise.ground_plane import PlaneCamera
    >>> camera = PlaneCamera((1024, 1024), height=1.0, tilt=70.0, fov=40.0, texel_size=0.0011)
    >>> J = camera.footprints(255.5, 511.5)
    >>> J.round(2).tolist()
    [[3.79, 0.01], [0.0, 22.18]]
    >>> n, lod = footprint_levels(J, FilterOptions("anisotropic"))
    >>> int(n), round(float(lod), 2)  # six lookups between levels 1 and 2
    (6, 1.32)
    >>> n, lod = footprint_levels(J, FilterOptions("mip"))
    >>> int(n), round(float(lod), 2)
    (1, 3.17)
    """
    m = np.einsum("...ij,...kj->...ik", J, J)
    half = 0.5 * (m[..., 0, 0] + m[..., 1, 1])
    disc = np.sqrt(0.25 * (m[..., 0, 0] - m[..., 1, 1]) ** 2 + m[..., 0, 1] ** 2)
    major = np.sqrt(half + disc)
    minor = np.sqrt(np.maximum(half - disc, 0.0))
    n = np.ones(np.shape(major), int)
    width = major
    if options.spec.axis_lookups:
        with np.errstate(divide="ignore", invalid="ignore"):
            n = np.where(major > minor * options.max_aniso, options.max_aniso, np.ceil(major / minor - 1e-4))
        n = np.maximum(np.nan_to_num(n, nan=1.0), 1).astype(int)
        width = np.maximum(minor, major / n)
    with np.errstate(divide="ignore"):
        lod = np.log2(width) + options.bias
    return n, lod


def needs_filtering(J: np.ndarray, options: FilterOptions) -> bool:
    """Whether ``options`` differ from the plain noise for some footprint of J:
    with one lookup at level 0 everywhere, "mip" and "anisotropic" are "none"."""
    if options.spec.supersamples:
        return True
    if not options.spec.footprint:
        return False
    n, lod = footprint_levels(J, options)
    return bool(np.any(n > 1) or np.any(lod > 0))


# ------------------------------------------------------------------- pixels
class PixelSet(ABC):
    """Pixels to filter: ``count`` of them, each with a flat index ``keys[k]``
    (which seeds its supersampling jitter), a texel-space centre and footprint."""

    count: int
    keys: np.ndarray

    @abstractmethod
    def centres(self, start: int, stop: int) -> np.ndarray:
        """float64 (n, 2) texel-space centres of pixels start…stop."""

    @abstractmethod
    def footprints(self, start: int, stop: int) -> np.ndarray:
        """(n or 1, 2, 2) footprints of pixels start…stop."""

    @abstractmethod
    def subpixels(self, sel: np.ndarray, offsets: np.ndarray) -> np.ndarray:
        """(len(sel), n², 2) texel positions of the offsets (len(sel), n², 2) in
        [0, 1)² of pixels ``sel``, NaN where a sub-pixel sees no noise."""


class RasterPixels(PixelSet):
    """The pixels of a raster: (i, j) at origin + step ((j + ½), (i + ½)),
    footprints ``J`` (constant (2, 2) or per pixel (H, W, 2, 2)).

    ``first`` = (row, column) makes it the window of the pixels ``first`` + (i, j)
    of the raster that ``origin`` and ``step`` place: centres and keys (which
    seed the supersampling jitter) are those of the global pixels, so windows
    are exactly the same pixels as one large raster.
    """

    def __init__(self, shape, origin, step, J, first=(0, 0)):
        h, w = shape
        self.width = w
        self.count = h * w
        self.first = (int(first[0]), int(first[1]))
        i, j = np.divmod(np.arange(h * w, dtype=np.int64), w)
        # the global (row, column), packed: independent of the window's width
        self.keys = ((i + self.first[0]) << 32) + (j + self.first[1])
        self.origin, self.step = origin, step
        self.flat = J.reshape(-1, 2, 2)

    def _centres(self, idx):
        i, j = np.divmod(idx, self.width)
        i = i + self.first[0]
        j = j + self.first[1]
        return self.origin + np.stack([j + 0.5, i + 0.5], -1) @ self.step.T

    def centres(self, start, stop) -> np.ndarray:
        return self._centres(np.arange(start, stop))

    def footprints(self, start, stop) -> np.ndarray:
        return self.flat if self.flat.shape[0] == 1 else self.flat[start:stop]

    def subpixels(self, sel, offsets) -> np.ndarray:
        base = self._centres(sel)[:, None, :]
        rel = offsets - 0.5  # (len(sel), n², 2) in pixel units
        if self.flat.shape[0] == 1:
            return base + rel @ self.flat[0].T
        return base + np.einsum("pab,psb->psa", self.flat[sel], rel)


# --------------------------------------------------------------- evaluation
def filter_work(texton: Texton, setup: NoiseSetup, J: np.ndarray, options: FilterOptions) -> float:
    """Mean operations per pixel of ``options`` for sampled footprints ``J`` (n, 2, 2);
    NaN footprints stand for pixels that see no noise (a plane's sky) and cost nothing.

    "none" walks the texton's support box once, "supersample" n² times. A
    "mip"/"anisotropic" pixel walks the box of its coarser level (level ℓ holds
    ⌈s / 2^ℓ⌉ coefficients 2^ℓ texels apart: about the texton's side plus 2^ℓ
    times the ψ support; the finer level's when it needs one level only) grown
    by the spread of its lookups, and evaluates its lookups at each impact
    there (the walk of kernels/noise_filter.py: filtered_points); pixels past the
    kept levels are the mean.
    """
    J = np.asarray(J, np.float64).reshape(-1, 2, 2)
    seen = np.isfinite(J).all(axis=(1, 2))
    share = float(seen.mean()) if J.shape[0] else 1.0
    walk = visits_per_point(setup)
    if options.spec.supersamples:
        return walk * options.supersample ** 2 * share
    if not options.spec.footprint:
        return walk * share
    J = J[seen]
    if not J.shape[0]:
        return 0.0
    n, lod = footprint_levels(J, options)
    m = np.einsum("...ij,...kj->...ik", J, J)
    major = np.sqrt(0.5 * (m[..., 0, 0] + m[..., 1, 1])
                    + np.sqrt(0.25 * (m[..., 0, 0] - m[..., 1, 1]) ** 2 + m[..., 0, 1] ** 2))
    levels = texton_pyramid(texton)
    kept = kept_levels(texton, levels, options.fade_energy)
    width = 2.0 * support_reach(texton.order)
    level_sides = np.array([[2.0 ** ell * (lv.shape[1] - 1 + width), 2.0 ** ell * (lv.shape[0] - 1 + width)]
                            for ell, lv in enumerate(levels)])  # the box of h_ℓ, as pyramid_struct sets it
    with np.errstate(invalid="ignore", over="ignore"):
        lod = np.nan_to_num(np.maximum(lod, 0.0), nan=float(kept), posinf=float(kept))
        past = lod >= kept
        lod = np.where(past, 0.0, lod)
        l0 = np.floor(lod)
        level = np.where(lod > l0, np.minimum(l0 + 1, kept - 1), l0)
        spread = np.minimum(major, MAX_FOOTPRINT) * (1.0 - 1.0 / n)  # the lookups' extent along the axis
        side_x = level_sides[level.astype(int), 0] + spread
        side_y = level_sides[level.astype(int), 1] + spread
        lookups = n * setup.lam * side_x * side_y  # at most n per impact in the box
        cost = np.where(past, 0.0, walk_cost(setup, side_x, side_y) + lookups)
    return float(np.mean(cost)) * share


def check_filter_cost(texton: Texton, setup: NoiseSetup, count: int, J: np.ndarray, options: FilterOptions,
                      what: str) -> None:
    """Refuse filtering ``count`` pixels (sampled footprints ``J``) beyond the budgets."""
    check_memory(float(count) * FILTER_BYTES_PER_PIXEL, what, "use a smaller image")
    work = float(count) * filter_work(texton, setup, J, options)
    check_work(work, f"{what} with filter {options.kind!r} at MNI {setup.mni:.6g}", options.spec.cost_hint,
               mentions=COST_HINT_NAMES)


def filter_pixels(p, texton: Texton, setup: NoiseSetup, pixels: PixelSet, options: FilterOptions, device,
                  seed: int, progress: bool = False, out=None) -> np.ndarray | None:
    """(pixels.count, 3) values of the noise of ``p`` at ``pixels``, filtered as ``options`` say
    (the front ends check the cost first: :func:`check_filter_cost`).

    With ``out`` (a (pixels.count,) vec3 array on ``device``, or a float one for a
    grey texton: one lane) the values are written there and nothing is returned.
    """
    if options.spec.supersamples:
        values = supersampled(p, setup.coeffs, pixels, options.supersample, seed, device, cell_limit(setup), progress)
        if out is None:
            return values
        out.assign(np.ascontiguousarray(values[:, 0]) if out.dtype == wp.float32 else values)  # one upload
        return None
    if not options.spec.footprint:
        return point_values(p, setup.coeffs, pixels.centres(0, pixels.count), device, out)
    return filtered_points(p, texton, pixels, options, device, out)


def pixel_shares(texton: Texton, pixels: PixelSet, options: FilterOptions) -> np.ndarray:
    """(pixels.count,) shares of the noise's variance that the pixels keep filtered as
    ``options`` say (:func:`~warp_texton.noise.colours.footprint_shares`), for the texton's
    histogram transform. Within the last kept MIP level the filters fade the noise to
    its mean, and past it they return the mean: the shares fade with them."""
    J = pixels.footprints(0, pixels.count)
    if options.spec.footprint:  # the device API's filtered_share
        shares = shares_of(texton, J, filter_struct(options), kept_levels(texton, fade_energy=options.fade_energy))
    else:
        shares = footprint_shares(texton, J, options)
    return np.broadcast_to(shares, (pixels.count,))


def filter_struct(options: FilterOptions) -> noise_filter.Filter:
    """The kernels' ``Filter`` of a footprint kind ("mip" or "anisotropic")."""
    f = noise_filter.Filter()
    f.mode = noise_filter.ANISOTROPIC if options.spec.axis_lookups else noise_filter.MIP
    f.max_aniso = options.max_aniso
    f.lod_bias = options.bias
    return f


def filtered_points(p, texton: Texton, pixels: PixelSet, options: FilterOptions, device, out=None) -> np.ndarray | None:
    """(N, 3) "mip" or "anisotropic" values at the pixels' centres and footprints
    (written into ``out`` when given: a vec3 array, or a float one for a grey
    texton's one lane)."""
    f = filter_struct(options)
    with wp.ScopedDevice(device):
        pyr = pyramid_struct(texton, options.fade_energy, 1 if out is not None and out.dtype == wp.float32 else 3)

        def launch(start, stop, res):
            pts, J = pixels.centres(start, stop), pixels.footprints(start, stop)
            wp.launch(noise_filter.filtered_points, dim=stop - start, inputs=[
                p, pyr, f, wp.array(pts, dtype=wp.vec2d),
                wp.array(J.astype(np.float32), dtype=wp.mat22), int(J.shape[0] > 1), res])

        if out is not None:
            split_launch(device, noise_filter, pixels.count, lambda start, stop: launch(start, stop, out[start:stop]))
            return None

        def values(start, stop):
            res = wp.zeros(stop - start, dtype=wp.vec3)
            launch(start, stop, res)
            return res.numpy()

        return map_points(device, noise_filter, pixels.count, values)


def subpixel_jitter(seed: int, keys: np.ndarray, n: int) -> np.ndarray:
    """(len(keys), n², 2) stratified sub-pixel offsets in [0, 1)²: cell (a, b) of
    an n × n grid, jittered by a hash of (seed, pixel key, sample), so that a
    pixel's samples do not depend on which other pixels are computed with it."""
    cells = (np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="xy"), -1).reshape(-1, 2)).astype(np.float64)
    key = (np.asarray(keys).astype(np.uint64)[:, None, None] * np.uint64(n * n * 2)
           + np.arange(n * n, dtype=np.uint64)[None, :, None] * np.uint64(2)
           + np.arange(2, dtype=np.uint64)[None, None, :])
    u = _splitmix64(key ^ _splitmix64(np.uint64(seed) + np.uint64(0x5EED)))
    return (cells[None] + (u >> np.uint64(11)).astype(np.float64) * 2.0 ** -53) / n


def _splitmix64(x):
    """The SplitMix64 finaliser, elementwise on uint64 (wrapping arithmetic)."""
    with np.errstate(over="ignore"):
        x = np.asarray(x, np.uint64) + np.uint64(0x9E3779B97F4A7C15)
        x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        return x ^ (x >> np.uint64(31))


def jittered_means(pixels, n: int, seed: int, limit: float, mean, values_at, progress: bool = False) -> np.ndarray:
    """(pixels.count, C) means of n × n stratified jittered evaluations per pixel (``values_at(points)``:
    (N, C) values at (N, 2) positions); sub-pixels that see no noise (NaN positions) and those beyond
    ±``limit`` texels (whose cells the kernels cannot index) count as ``mean`` (C,)."""
    channels = len(mean)
    out = np.zeros((pixels.count, channels), np.float32)
    per = max(1, SUPERSAMPLE_BATCH // (n * n))
    chunks = range(0, pixels.count, per)
    if progress:
        from ..core.progress import bar

        chunks = bar(chunks, desc="supersample", unit="batch")
    for start in chunks:
        sel = np.arange(start, min(start + per, pixels.count))
        with np.errstate(invalid="ignore"):
            pts = pixels.subpixels(sel, subpixel_jitter(seed, pixels.keys[sel], n)).reshape(-1, 2)
            good = (np.abs(pts) < limit).all(axis=1)  # False for NaN too
        vals = np.empty((pts.shape[0], channels), np.float32)
        vals[~good] = mean
        vals[good] = values_at(np.ascontiguousarray(pts[good]))
        out[sel] = vals.reshape(sel.size, n * n, channels).mean(axis=1)
    return out


def supersampled(p, coeffs, pixels: PixelSet, n: int, seed: int, device, limit: float,
                 progress: bool = False) -> np.ndarray:
    """(pixels.count, 3) averages of n × n stratified jittered evaluations per pixel.

    Sub-pixels that see no noise (NaN positions) and those beyond ±``limit``
    texels (whose cells the kernels cannot index) count as the mean.
    """
    return jittered_means(pixels, n, seed, limit, params_mean(p), lambda pts: point_values(p, coeffs, pts, device),
                          progress)
