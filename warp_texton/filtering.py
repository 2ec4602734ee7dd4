"""Anti-aliased texton noise (CGF §5) and a perspective ground-plane renderer.

Averaging texton noise over a pixel's footprint F gives the noise of the
filtered texton h ∗ 1_F/|F| with the same impacts, so filtering the noise is
filtering the texton. ``"mip"`` and ``"anisotropic"`` look the filtered texton
up in a MIP pyramid of block means (see kernels/filter2d.py);
``"supersample"`` averages n × n jittered evaluations per pixel, the
reference they are measured against.

A footprint is the 2 × 2 Jacobian J of the texel position with respect to the
pixel position: its columns are the texel-space steps of one pixel to the
right and one pixel down, so the pixel covers x + J [-½, ½]².
"""

from __future__ import annotations

import math

import numpy as np

from ._checks import check_int, check_positive, check_seed, check_shape
from .errors import TextonError
from .texton import Texton

FILTERS = ("none", "mip", "anisotropic", "supersample")
#: Most lookups along a footprint's major axis ("anisotropic"); past this
#: anisotropy the level rises instead, as GPU anisotropic filtering does.
MAX_ANISO = 8
#: Added to log2 of a lookup's width to pick its level, per filter. A level-ℓ
#: lookup blurs like a box of width √3 · 2^ℓ (block mean, then the bilinear
#: tent), so −log2 √3 ≈ −0.79 would match the pixel box's second moment. The
#: defaults are the optima measured on the plane benchmark with two textures
#: (docs/benchmarks.md): "mip" sits lower because its single lookup takes the
#: major axis as its width and so over-blurs along the minor one.
LOD_BIAS = {"mip": -1.3, "anisotropic": -0.6}
#: The pyramid ends at the first level whose noise keeps less than this
#: fraction of the texton noise's variance (∫h_ℓ² / ∫h²); past that level the
#: filtered noise fades to its mean. The coarse levels of a textured texton
#: carry little variance but cost the most (the widest supports, the most
#: lookups). On the plane benchmark, 0.1 instead of keeping every level costs
#: 0.002 in error for about a fifth of the time; 0.25 saves more but flattens
#: a band of the far field that still has visible grain (docs/model.md §13).
#: Smooth textures keep all their levels.
FADE_ENERGY = 0.1
#: Default samples per pixel side for ``filter="supersample"``.
SUPERSAMPLE = 20
#: Bounds on ``supersample`` and ``max_aniso`` (a pixel's work grows with them).
MAX_SUPERSAMPLE = 64
MAX_MAX_ANISO = 64
#: Footprint entries are clamped to ±this many texels: far past the coarsest
#: MIP level, where the filtered noise is its mean, and safe in float32.
MAX_FOOTPRINT = 1.0e12
#: Sub-pixel evaluations per batch when supersampling (bounds host memory).
_BATCH = 1 << 22


# ------------------------------------------------------------------ pyramid
def texton_pyramid(texton: Texton) -> list[np.ndarray]:
    """The MIP levels of a texton's coefficients: level ℓ + 1 holds the means of
    2 × 2 blocks of level ℓ (odd sides padded with zeros), down to one
    coefficient. h_ℓ(y) = Σ_k α_ℓ(k) ψ((y − (2^ℓ − 1)/2) / 2^ℓ − k) then has the
    integral of h at every level.
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
    """∫h_ℓ² / ∫h² for every MIP level (summed over channels): the variance the
    noise of level ℓ keeps. ∫h_ℓ² = 4^ℓ Σ_τ b(τ) Σ_x α_ℓ(x) α_ℓ(x + τ)."""
    from .texton import lag0_covariance

    levels = texton_pyramid(texton) if levels is None else levels
    e = np.array([4.0 ** ell * np.trace(np.atleast_2d(lag0_covariance(a.astype(np.float64), texton.order)))
                  for ell, a in enumerate(levels)])
    return e / e[0] if e[0] > 0 else np.ones_like(e)


def kept_levels(texton: Texton, levels=None, fade_energy: float = FADE_ENERGY) -> int:
    """How many MIP levels the filters use: up to and including the first level
    whose energy is below ``fade_energy`` (all of them if none is)."""
    e = level_energies(texton, levels)
    below = np.flatnonzero(e < fade_energy)
    return int(below[0]) + 1 if below.size else len(e)


def _pyramid_struct(wp, texton: Texton, fade_energy: float = FADE_ENERGY):
    from .kernels.filter2d import Pyramid
    from .kernels.noise2d import PAD

    levels = texton_pyramid(texton)
    k = texton.order
    reach = 0.5 if k == 0 else (k + 1) / 2.0
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
    pyr = Pyramid()
    pyr.coeffs = wp.array(stack, dtype=wp.vec3)
    pyr.row0 = wp.array(row0, dtype=wp.int32)
    pyr.rows = wp.array(np.array(rows, np.int32), dtype=wp.int32)
    pyr.step = wp.array(np.array(step, np.float32), dtype=float)
    pyr.origin = wp.array(np.array(origin, np.float32), dtype=float)
    pyr.lo = wp.array(np.array(lo, np.float32), dtype=wp.vec2)
    pyr.hi = wp.array(np.array(hi, np.float32), dtype=wp.vec2)
    pyr.levels = kept_levels(texton, levels, fade_energy)
    pyr.order = k
    return pyr


# --------------------------------------------------------------- footprints
def check_filter(filter: str) -> str:
    if not isinstance(filter, str) or filter not in FILTERS:
        raise TextonError(f"filter must be one of {', '.join(FILTERS)}, got {filter!r}")
    return filter


def check_filter_options(supersample, max_aniso) -> tuple[int, int]:
    """``supersample`` in [1, MAX_SUPERSAMPLE] and ``max_aniso`` in [1, MAX_MAX_ANISO]."""
    n = check_int(supersample, "supersample", minimum=1)
    a = check_int(max_aniso, "max_aniso", minimum=1)
    if n > MAX_SUPERSAMPLE:
        raise TextonError(f"supersample must be at most {MAX_SUPERSAMPLE} (samples per pixel side), got {n}")
    if a > MAX_MAX_ANISO:
        raise TextonError(f"max_aniso must be at most {MAX_MAX_ANISO}, got {a}")
    return n, a


def check_fade_energy(fade_energy) -> float:
    """A number in [0, 1]."""
    if isinstance(fade_energy, bool):
        raise TextonError(f"fade_energy must be a number in [0, 1], got {fade_energy!r}")
    try:
        e = float(fade_energy)
    except (TypeError, ValueError):
        raise TextonError(f"fade_energy must be a number in [0, 1], got {fade_energy!r}") from None
    if not 0.0 <= e <= 1.0:
        raise TextonError(f"fade_energy must be in [0, 1] (0 keeps every MIP level), got {fade_energy!r}")
    return e


def check_jacobian(jacobian, shape) -> np.ndarray:
    """A constant (2, 2) or per-pixel (H, W, 2, 2) footprint, as float64.

    Entries must be finite. Zero and degenerate footprints are accepted (no
    filtering along the missing direction); entries beyond ±MAX_FOOTPRINT are
    clamped there, where the filtered noise is its mean.
    """
    try:
        J = np.asarray(jacobian, dtype=np.float64)
    except (TypeError, ValueError):
        raise TextonError("jacobian must be an array of shape (2, 2) or (H, W, 2, 2) of numbers") from None
    h, w = shape
    if J.shape not in ((2, 2), (h, w, 2, 2)):
        raise TextonError(f"jacobian must have shape (2, 2) or ({h}, {w}, 2, 2) for this raster, got {J.shape}")
    if not np.isfinite(J).all():
        raise TextonError(f"jacobian contains {int((~np.isfinite(J)).sum())} NaN or infinite values; "
                          "footprints must be finite (use 0 for no filtering)")
    return np.clip(J, -MAX_FOOTPRINT, MAX_FOOTPRINT)


def footprint_levels(J: np.ndarray, filter: str, max_aniso: int = MAX_ANISO, lod_bias: float | None = None):
    """Lookups per pixel and MIP level (before clamping at 0) that ``filter``
    picks for footprints ``J`` (..., 2, 2); the kernels make the same choice."""
    m = np.einsum("...ij,...kj->...ik", J, J)
    half = 0.5 * (m[..., 0, 0] + m[..., 1, 1])
    disc = np.sqrt(0.25 * (m[..., 0, 0] - m[..., 1, 1]) ** 2 + m[..., 0, 1] ** 2)
    major = np.sqrt(half + disc)
    minor = np.sqrt(np.maximum(half - disc, 0.0))
    n = np.ones(np.shape(major), int)
    width = major
    if filter == "anisotropic":
        with np.errstate(divide="ignore", invalid="ignore"):
            n = np.where(major > minor * max_aniso, max_aniso, np.ceil(major / minor - 1e-4))
        n = np.maximum(np.nan_to_num(n, nan=1.0), 1).astype(int)
        width = np.maximum(minor, major / n)
    with np.errstate(divide="ignore"):
        lod = np.log2(width) + (LOD_BIAS[filter] if lod_bias is None else lod_bias)
    return n, lod


def needs_filtering(J: np.ndarray, filter: str, max_aniso: int = MAX_ANISO) -> bool:
    """Whether ``filter`` differs from the plain noise for some footprint of J:
    with one lookup at level 0 everywhere, "mip" and "anisotropic" are "none"."""
    if filter == "supersample":
        return True
    if filter == "none":
        return False
    n, lod = footprint_levels(J, filter, max_aniso)
    return bool(np.any(n > 1) or np.any(lod > 0))


# --------------------------------------------------------------- evaluation
def filtered_points(wp, p, texton: Texton, setup, positions, device, filter: str, *,
                    max_aniso: int = MAX_ANISO, lod_bias: float | None = None,
                    fade_energy: float = FADE_ENERGY) -> np.ndarray:
    """(N, 3) filtered noise at N points; ``positions(idx) -> (pts (n, 2) f64, J (n or 1, 2, 2))``."""
    from .kernels import filter2d as F
    from .synthesis import map_points

    f = F.Filter()
    f.mode = 1 if filter == "mip" else 2
    f.max_aniso = int(max_aniso)
    f.lod_bias = float(LOD_BIAS[filter] if lod_bias is None else lod_bias)
    n = positions.count
    with wp.ScopedDevice(device):
        pyr = _pyramid_struct(wp, texton, fade_energy)

        def launch(idx):
            pts, J = positions(idx)
            res = wp.zeros(idx.size, dtype=wp.vec3)
            wp.launch(F.filtered_points, dim=idx.size, inputs=[
                p, pyr, f, wp.array(pts, dtype=wp.vec2d),
                wp.array(J.astype(np.float32), dtype=wp.mat22), int(J.shape[0] > 1), res])
            return res.numpy()

        return map_points(wp, F, device, n, launch)


def point_values(wp, p, coeffs: np.ndarray, pts: np.ndarray, device) -> np.ndarray:
    """(N, 3) unfiltered noise at float64 points, split over threads on the CPU."""
    from .kernels import noise2d as K
    from .synthesis import map_points

    with wp.ScopedDevice(device):
        c = wp.array(coeffs, dtype=wp.vec3)

        def launch(idx):
            res = wp.zeros(idx.size, dtype=wp.vec3)
            wp.launch(K.evaluate_points, dim=idx.size, inputs=[p, c, wp.array(pts[idx], dtype=wp.vec2d), res])
            return res.numpy()

        return map_points(wp, K, device, pts.shape[0], launch)


def subpixel_jitter(seed: int, pixels: np.ndarray, n: int) -> np.ndarray:
    """(len(pixels), n², 2) stratified sub-pixel offsets in [0, 1)²: cell (a, b) of
    an n × n grid, jittered by a hash of (seed, pixel, sample), so that a pixel's
    samples do not depend on which other pixels are computed with it."""
    cells = (np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="xy"), -1).reshape(-1, 2)).astype(np.float64)
    key = (np.asarray(pixels, np.uint64)[:, None, None] * np.uint64(n * n * 2)
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


def supersampled(wp, p, coeffs, subpixels, pixels: np.ndarray, n: int, seed: int, device, limit: float,
                 progress: bool = False) -> np.ndarray:
    """(len(pixels), 3) averages of n × n stratified jittered evaluations per pixel.

    ``subpixels(sel, offsets) -> (len(sel), n², 2)`` gives the texel positions
    of the sub-pixel offsets (len(sel), n², 2) in [0, 1)² of ``pixels[sel]``;
    NaN marks sub-pixels that see no noise. Those, and sub-pixels beyond
    ±``limit`` texels (whose cells the kernels cannot index), count as the mean.
    """
    pixels = np.asarray(pixels)
    out = np.zeros((pixels.size, 3), np.float32)
    per = max(1, _BATCH // (n * n))
    chunks = range(0, pixels.size, per)
    if progress:
        from tqdm.auto import tqdm

        chunks = tqdm(chunks, desc="supersample", unit="batch", leave=False)
    for start in chunks:
        sel = np.arange(start, min(start + per, pixels.size))
        with np.errstate(invalid="ignore"):
            pts = subpixels(sel, subpixel_jitter(seed, pixels[sel], n)).reshape(-1, 2)
            good = (np.abs(pts) < limit).all(axis=1)  # False for NaN too
        vals = np.empty((pts.shape[0], 3), np.float32)
        vals[~good] = p_mean(p)
        vals[good] = point_values(wp, p, coeffs, np.ascontiguousarray(pts[good]), device)
        out[sel] = vals.reshape(sel.size, n * n, 3).mean(axis=1)
    return out


def cell_limit(setup) -> float:
    """Texel coordinates beyond ±this are left to the mean: their cells (and those
    of the supports around them) would not fit the kernels' int32 cell indices."""
    from .synthesis import MAX_CELL_INDEX

    return 0.5 * MAX_CELL_INDEX * min(setup.cell)


def p_mean(p) -> np.ndarray:
    return np.array([p.mean[0], p.mean[1], p.mean[2]], np.float32)


class _Positions:
    """Pixel positions and footprints of a raster, made per batch of pixel indices."""

    def __init__(self, count, fn):
        self.count = count
        self._fn = fn

    def __call__(self, idx):
        return self._fn(idx)


def filtered_raster(wp, p, texton: Texton, setup, shape, origin, step, J, device, filter: str,
                    supersample: int, seed: int, max_aniso: int = MAX_ANISO,
                    fade_energy: float = FADE_ENERGY) -> np.ndarray:
    """(H, W, 3) raster of ``synthesis.synthesize`` with a filter other than "none"."""
    h, w = shape

    def centres(idx):
        i, j = np.divmod(idx, w)
        return origin + np.stack([j + 0.5, i + 0.5], -1) @ step.T

    if filter == "supersample":
        steps = step if J is None else J

        def subpixels(idx, offsets):
            Jp = steps if steps.ndim == 2 else steps.reshape(-1, 2, 2)[idx]
            base = centres(idx)[:, None, :]
            rel = offsets - 0.5  # (len(idx), n², 2) in pixel units
            if Jp.ndim == 2:
                return base + rel @ Jp.T
            return base + np.einsum("pab,psb->psa", Jp, rel)

        vals = supersampled(wp, p, setup.coeffs, subpixels, np.arange(h * w), supersample, seed, device,
                            cell_limit(setup))
        return vals.reshape(h, w, 3)
    foot = (step if J is None else J)
    flat = foot.reshape(-1, 2, 2)

    def positions(idx):
        return centres(idx), (flat if flat.shape[0] == 1 else flat[idx])

    vals = filtered_points(wp, p, texton, setup, _Positions(h * w, positions), device, filter,
                           max_aniso=max_aniso, fade_energy=fade_energy)
    return vals.reshape(h, w, 3)


# -------------------------------------------------------------------- plane
class PlaneView:
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
        try:
            tilt, fov = float(tilt), float(fov)
        except (TypeError, ValueError):
            raise TextonError(f"tilt and fov must be numbers (degrees), got {tilt!r}, {fov!r}") from None
        if not (0.0 <= tilt < 90.0):
            raise TextonError(f"tilt must be in [0, 90) degrees (0 looks straight down), got {tilt!r}")
        if not (0.0 < fov < 180.0):
            raise TextonError(f"fov must be in (0, 180) degrees, got {fov!r}")
        self.tilt, self.fov = tilt, fov
        h, _ = self.shape
        self.focal = (h / 2.0) / math.tan(math.radians(fov) / 2.0)

    def _uv(self, i, j):
        h, w = self.shape
        return (j - w / 2.0) / self.focal, (i - h / 2.0) / self.focal

    def texels(self, i, j):
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

    def footprints(self, i, j):
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


def render_plane(
    texton: Texton,
    shape=(512, 512),
    height: float = 1.0,
    tilt: float = 70.0,
    fov: float = 40.0,
    texel_size: float = 0.002,
    mni: float = 30.0,
    seed: int = 0,
    filter: str = "anisotropic",
    supersample: int = SUPERSAMPLE,
    device=None,
    *,
    max_aniso: int = MAX_ANISO,
    fade_energy: float = FADE_ENERGY,
    progress: bool = False,
) -> np.ndarray:
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
    filter : {"none", "mip", "anisotropic", "supersample"}
        Per-pixel filtering of the texton for the pixel's footprint (CGF §5),
        or the n × n supersampled reference.
    supersample : int
        Samples per pixel side for ``filter="supersample"`` (20: 400 per pixel).
    device : str, optional
    max_aniso : int
        Most lookups along a footprint's major axis for "anisotropic".
    fade_energy : float
        The MIP pyramid ends at the first level whose noise keeps less than
        this fraction of the variance; larger footprints fade to the mean.
        0 keeps every level (slower at a distance, a little more accurate).
    progress : bool
        Show a progress bar while supersampling.

    Returns
    -------
    float32 array (height, width, C); pixels that see no plane (above the
    horizon, or beyond ±2**29 noise cells) hold the texton mean.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton, render_plane
    >>> t = Texton(np.random.default_rng(0).standard_normal((8, 8, 1)) / 8, [0.5])
    >>> render_plane(t, (24, 32), tilt=80, filter="mip", device="cpu").shape
    (24, 32, 1)
    """
    view = PlaneView(shape, height, tilt, fov, texel_size)
    h, w = view.shape
    out = plane_pixels(texton, view, np.arange(h * w), mni, seed, filter, supersample, device,
                       progress=progress, max_aniso=max_aniso, fade_energy=fade_energy)
    return np.ascontiguousarray(out.reshape(h, w, -1))


def plane_pixels(texton: Texton, view: PlaneView, pixels, mni: float = 30.0, seed: int = 0,
                 filter: str = "anisotropic", supersample: int = SUPERSAMPLE, device=None, *,
                 progress: bool = False, max_aniso: int = MAX_ANISO, lod_bias: float | None = None,
                 fade_energy: float = FADE_ENERGY) -> np.ndarray:
    """(N, C) values of the flat pixel indices ``pixels`` of :func:`render_plane`'s image
    (benchmarks compare filters on a subset of pixels this way)."""
    from .synthesis import _params, _warp, noise_setup, resolve_device

    filter = check_filter(filter)
    seed = check_seed(seed)
    n, max_aniso = check_filter_options(supersample, max_aniso)
    fade_energy = check_fade_energy(fade_energy)
    setup = noise_setup(texton, mni)
    device = resolve_device(device)
    wp = _warp()
    p = _params(wp, texton, setup, seed, "exact")
    h, w = view.shape
    ii, jj = np.divmod(np.asarray(pixels, np.int64), w)
    centre = view.texels(ii + 0.5, jj + 0.5)
    # positions whose cells the kernels could not index see the mean
    limit = cell_limit(setup)
    hit = np.isfinite(centre).all(axis=1) & (np.abs(centre) < limit).all(axis=1)
    out = np.empty((ii.size, 3), np.float32)
    out[:] = p_mean(p)
    idx = np.flatnonzero(hit)
    if filter == "none":
        out[idx] = point_values(wp, p, setup.coeffs, np.ascontiguousarray(centre[idx]), device)
    elif filter == "supersample":

        def subpixels(sel, offsets):
            return view.texels(ii[idx[sel], None] + offsets[..., 1], jj[idx[sel], None] + offsets[..., 0])

        pix = np.asarray(pixels, np.int64)[idx]
        out[idx] = supersampled(wp, p, setup.coeffs, subpixels, pix, n, seed, device, limit, progress)
    else:
        J = view.footprints(ii[idx] + 0.5, jj[idx] + 0.5)

        def positions(sel):
            return centre[idx[sel]], J[sel]

        out[idx] = filtered_points(wp, p, texton, setup, _Positions(idx.size, positions), device, filter,
                                   max_aniso=max_aniso, lod_bias=lod_bias, fade_energy=fade_energy)
    return out[:, : texton.channels]
