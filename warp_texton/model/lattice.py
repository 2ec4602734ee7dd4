"""The structure of an example: whether it tiles (its seams), the lattice of a near-regular texture, and
the lattice-periodic mean that a tiling model keeps aligned.

* :func:`seam_ratios` — per axis, the energy of the pair of lines that meet across the wrap (last and
  first column, last and first row) over that of the inside pairs *at the same phase* of the axis's
  period (pairs one period apart, where the example repeats along the axis; all inside pairs where it
  does not). A seamless example's wrap is one more inside pair: about 1, even where the artist cut it
  along a mortar line; a crop's joins two unrelated lines, 3 to 500 on photographs (docs/tiling.md,
  "Seamless examples").
* :class:`Lattice` — the translations that map a regular texture onto itself, as integer dual vectors
  k over a modulus N: the texture's phase at x is k · x / N (mod 1). Two vectors (tiles, stack and
  running bond, plates) or one (courses of one height, stones of any length: translations along the
  courses are free). Integers make the snap of a patch to the lattice exact in every evaluator
  (``kernels/tiling_draw.py``); N is the least common multiple of a seamless example's sides (the
  lattice is commensurate with the example's period, as a seamless regular texture is) or 2¹⁶.
* :func:`detect_lattices` — candidate lattices from the autocorrelation's peaks (refined over every
  peak of the lattice), each with its **strength**: the fraction of the example's variance in the
  lattice's frequencies above the spectrum around them (what the lattice-periodic mean holds beyond
  chance). Stochastic textures have none above :data:`MIN_STRENGTH`.
* :func:`lattice_mean` — the mean of the example over the lattice's translations, at every texel:
  exactly the example's Fourier coefficients at the lattice's frequencies for a seamless example, the
  mean over texels of the same phase otherwise.

NumPy/SciPy only. References: Y. Liu, R. T. Collins, Y. Tsin, "A computational model for periodic
pattern perception based on frieze and wallpaper groups", IEEE PAMI 26(3), 2004 (lattices from
autocorrelation peaks); L. Moisan, "Periodic plus smooth image decomposition", JMIV 39, 2011.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from ..core.errors import TextonError

# SciPy (its FFT and ndimage) and the periodic component are imported where they are used: a model file
# that holds a lattice is read, and rendered, without them (tests/cli/test_startup.py)

__all__ = ["Seams", "seam_ratios", "SEAM_THRESHOLD", "Lattice", "detect_lattices", "lattice_mean", "MIN_STRENGTH",
           "MIN_VECTOR", "MAX_MODULUS", "lattice_of"]

#: Above this ratio of wrap-seam energy to inside energy an axis is not seamless (measured on game
#: textures and crops of them, docs/tiling.md).
SEAM_THRESHOLD = 2.5
#: Shortest lattice vector, texels: shorter repeats are grain (JPEG blocks, weaves), not layout.
MIN_VECTOR = 6.0
#: The largest modulus N (integer dual vectors over N keep the evaluators' products within 32 bits).
MAX_MODULUS = 1 << 16
#: Lattices weaker than this (fraction of variance their mean holds beyond chance) are not reported.
MIN_STRENGTH = 0.03
#: ... and weaker than this many standard errors of their own estimate.
MIN_SIGNIFICANCE = 5.0
#: Of the candidates of a rank, those whose least autocorrelation at their vectors (:func:`_support`) is at
#: least SUPPORT of the best one's, and whose strength is at least STRENGTH_KEPT of the strongest's, the
#: one of the smallest cell is the texture's (its sublattices explain as much with larger cells).
SUPPORT = 0.5
STRENGTH_KEPT = 0.85
#: A 2-D lattice is reported beside the 1-D one only where it holds this much more of the variance (a
#: second vector along courses of stones of random length explains nothing more, and misregisters them).
MIN_SECOND_AXIS = 0.03
#: A lattice frequency counts in a lattice's strength where its power is this many times its background.
PEAK_CONTRAST = 3.0
#: Autocorrelation peaks that seed the candidates: value, dip towards the origin, how many.
PEAK_VALUE = 0.05
PEAK_DIP = 0.1
PEAKS = 10
#: A lattice vector must repeat at least this many times across a seamless example, one more across
#: another (its frequencies then lie three bins or more apart, four where a frequency between bins
#: takes 3 × 3 of them, and the background around each is the spectrum's, not the lattice's).
MIN_REPEATS = 3.0


def _lines_period(e: np.ndarray) -> float | None:
    """The period (in lines, sub-line) of a profile of line-pair energies, or None where it does not repeat."""
    n = len(e)
    x = e - e.mean()
    ac = np.real(np.fft.ifft(np.abs(np.fft.fft(x)) ** 2))
    if ac[0] <= 0:
        return None
    ac = ac / ac[0]
    best, at = 0.3, None
    for p in range(4, n // 2):
        if ac[p] > ac[p - 1] and ac[p] >= ac[p + 1] and ac[p] > best:
            best, at = ac[p], p
    if at is None:
        return None
    a, b, c = ac[at - 1], ac[at], ac[at + 1]
    den = a - 2 * b + c
    return float(at + (0.5 * (a - c) / den if den < 0 else 0.0))


@dataclass(frozen=True)
class Seams:
    """:func:`seam_ratios` of an example: per axis the ratio and the period it compared at (None: the axis
    does not repeat)."""

    ratio_x: float
    ratio_y: float
    period_x: float | None
    period_y: float | None

    @property
    def wrap(self) -> tuple[bool, bool]:
        """(x, y): whether each axis is seamless (ratio at most :data:`SEAM_THRESHOLD`)."""
        return self.ratio_x <= SEAM_THRESHOLD, self.ratio_y <= SEAM_THRESHOLD


def seam_ratios(u) -> Seams:
    """How much the wrap of an example (H, W, C) stands out on each axis (module docstring).

    The energy of a pair of neighbouring lines is the mean squared difference over the line and the
    channels. The wrap pair (line n − 1 and line 0) is compared with the median of the inside pairs one,
    two, ... periods away from it (each the largest in ±2 lines, as a sub-line period rounds), the period
    being that of the profile of pair energies (its autocorrelation's highest peak above 0.3; the window
    widens by 1 % of the distance, as the period's error adds up), or with the
    median of all inside pairs where the profile does not repeat.
    """
    a = np.asarray(u, np.float64)
    a = a[:, :, None] if a.ndim == 2 else a
    out: list[tuple[float, float | None]] = []
    for axis in (1, 0):
        m = np.moveaxis(a, axis, 0)
        n = m.shape[0]
        e = ((np.roll(m, -1, axis=0) - m) ** 2).reshape(n, -1).mean(axis=1)  # pair j: lines j, j + 1
        inside = e[:n - 1]
        period = _lines_period(inside) if n >= 16 else None
        ref = float(np.median(inside))
        if period is not None:
            ks = np.arange(1, int((n - 2) // period) + 1)
            js = np.round(n - 1 - ks * period).astype(int)
            # ±2 lines, and 1 % of the distance more: a sub-line period's error grows with it
            reach = 2 + np.round(0.01 * ks * period).astype(int)
            near = [inside[max(0, j - r):j + r + 1].max() for j, r in zip(js, reach) if 0 <= j < n - 1]
            if near:
                ref = float(np.median(near))
        out.append((float(e[n - 1] / max(ref, 1e-30)) if e[n - 1] > 0 else 0.0, period))
    return Seams(out[0][0], out[1][0], out[0][1], out[1][1])


# ---------------------------------------------------------------- lattices


def _reduced(b: np.ndarray) -> np.ndarray:
    """Lagrange–Gauss reduction of a basis (2, 2) (columns), shortest vector first."""
    b1, b2 = b[:, 0].astype(np.float64), b[:, 1].astype(np.float64)
    for _ in range(64):
        if b1 @ b1 > b2 @ b2:
            b1, b2 = b2, b1
        m = round(float(b1 @ b2) / float(b1 @ b1))
        if m == 0:
            break
        b2 = b2 - m * b1
    if b1 @ b1 > b2 @ b2:
        b1, b2 = b2, b1
    return np.stack([b1, b2], axis=1)


def _reduced_int(k: np.ndarray) -> np.ndarray:
    """Lagrange–Gauss reduction of an integer basis (2, 2) (columns), exactly."""
    k1, k2 = [int(v) for v in k[:, 0]], [int(v) for v in k[:, 1]]
    dot = lambda p, q: p[0] * q[0] + p[1] * q[1]  # noqa: E731
    for _ in range(64):
        if dot(k1, k1) > dot(k2, k2):
            k1, k2 = k2, k1
        n1 = dot(k1, k1)
        m = (2 * dot(k1, k2) + n1) // (2 * n1)  # the nearest integer to k1·k2 / k1·k1
        if m == 0:
            break
        k2 = [k2[0] - m * k1[0], k2[1] - m * k1[1]]
    if dot(k1, k1) > dot(k2, k2):
        k1, k2 = k2, k1
    return np.array([k1, k2], np.int64).T


def _canonical(k) -> tuple[int, int]:
    """A dual vector up to sign: first nonzero component positive."""
    ky, kx = int(k[0]), int(k[1])
    return (ky, kx) if (ky > 0 or (ky == 0 and kx > 0)) else (-ky, -kx)


@dataclass(frozen=True)
class Lattice:
    """The translations of a regular texture, as integer dual vectors over a modulus (module docstring).

    Attributes
    ----------
    modulus : int
        N, 2 to 2¹⁶: the texture's phase at x = (y, x) is k · x / N (mod 1) for each dual vector k.
    dual : tuple of one or two (ky, kx) integer pairs
        Two: a 2-D lattice (vectors: the basis whose dual they are); one: courses, the lattice's vectors
        every v with k · v ∈ N ℤ (translations along the courses are free). Reduced and signed canonically,
        so that equal lattices compare equal.
    strength : float or None
        The fraction of the example's variance in the lattice's frequencies above the spectrum around
        them (:func:`detect_lattices`); None for a lattice given by hand.

    Raises
    ------
    TextonError
        For a modulus or vectors out of range: vectors shorter than :data:`MIN_VECTOR` texels (the
        evaluators' 32-bit products need |k| ≤ N / 6), two dual vectors that are parallel.
    """

    modulus: int
    dual: tuple[tuple[int, ...], ...]  # (ky, kx) pairs
    strength: float | None = None

    def __post_init__(self):
        n = self.modulus
        if isinstance(n, bool) or not isinstance(n, numbers.Integral) or not 2 <= int(n) <= MAX_MODULUS:
            raise TextonError(f"lattice modulus must be an integer from 2 to {MAX_MODULUS}, got {n!r:.40}",
                              param="lattice")
        try:
            k = np.array(self.dual, dtype=np.int64).reshape(-1, 2)
            ok = np.array_equal(k, np.array(self.dual, dtype=np.float64).reshape(-1, 2))
        except (TypeError, ValueError, OverflowError):
            ok = False
        if not ok or k.shape[0] not in (1, 2):
            raise TextonError(f"lattice dual must be one or two pairs of integers, got {self.dual!r:.80}",
                              param="lattice")
        if k.shape[0] == 2:
            if k[0, 0] * k[1, 1] - k[0, 1] * k[1, 0] == 0:
                raise TextonError("lattice: the two vectors are parallel (give one vector for courses)",
                                  param="lattice")
            k = _reduced_int(k.T).T
        rows = tuple(sorted(_canonical(r) for r in k)) if k.shape[0] == 2 else (_canonical(k[0]),)
        limit = int(n) // int(math.ceil(MIN_VECTOR))
        if any(abs(v) > limit for r in rows for v in r) or any(r == (0, 0) for r in rows):
            raise TextonError(f"lattice: vectors must be at least {MIN_VECTOR:g} texels long "
                              f"(got {self._describe(rows, int(n))})", param="lattice")
        if self.strength is not None and not (isinstance(self.strength, numbers.Real)
                                              and math.isfinite(float(self.strength))):
            raise TextonError(f"lattice strength must be a finite number or None, got {self.strength!r:.40}",
                              param="lattice")
        object.__setattr__(self, "modulus", int(n))
        object.__setattr__(self, "dual", rows)
        if self.strength is not None:
            object.__setattr__(self, "strength", float(self.strength))

    @staticmethod
    def _describe(rows, n) -> str:
        try:
            return ", ".join(f"({v[0]:.3g}, {v[1]:.3g})" for v in Lattice._vectors_of(rows, n))
        except (ZeroDivisionError, np.linalg.LinAlgError):
            return "zero"

    @staticmethod
    def _vectors_of(rows, n) -> list[tuple[float, float]]:
        k = np.array(rows, np.float64)
        if k.shape[0] == 1:
            kk = k[0]
            v = n * kk / float(kk @ kk)
            return [(float(v[0]), float(v[1]))]
        b = _reduced(n * np.linalg.inv(k))  # columns: the primal basis (B K^T = N I)
        return [(float(b[0, j]), float(b[1, j])) for j in range(2)]

    @property
    def rank(self) -> int:
        """2 for a 2-D lattice, 1 for courses."""
        return len(self.dual)

    @property
    def vectors(self) -> tuple[tuple[float, float], ...]:
        """The lattice's vectors (dy, dx) in texels: a reduced basis (2-D), or the course vector, the shortest
        translation across the courses (1-D)."""
        return tuple(self._vectors_of(self.dual, self.modulus))

    @property
    def dual_matrix(self) -> np.ndarray:
        """(rank, 2) int64: the dual vectors (ky, kx) as rows."""
        return np.array(self.dual, np.int64)

    def frequencies(self) -> np.ndarray:
        """(rank, 2) float64: the dual vectors in cycles per texel (fy, fx)."""
        return self.dual_matrix / float(self.modulus)

    def half_extent(self) -> tuple[int, int]:
        """(ey, ex): the most a snap moves a texel on each axis (half the cell's extent, rounded up, plus the
        rounding of the move to whole texels)."""
        v = np.array(self.vectors, np.float64)
        if self.rank == 1:
            e = 0.5 * np.abs(v[0])
        else:
            e = 0.5 * np.abs(v).sum(axis=0)
        return int(math.ceil(e[0])) + 1, int(math.ceil(e[1])) + 1

    def commensurate(self, shape) -> bool:
        """Whether the example's period (H, W) lies on the lattice: every frequency is a whole number of
        cycles over the example (a seamless regular texture is so)."""
        h, w = shape[:2]
        k = self.dual_matrix
        return bool(np.all((k[:, 0] * h) % self.modulus == 0) and np.all((k[:, 1] * w) % self.modulus == 0))

    def to_json(self) -> dict:
        """The lattice as JSON values (the model files' ``tiling_lattice``)."""
        out: dict = {"modulus": self.modulus, "dual": [list(r) for r in self.dual]}
        if self.strength is not None:
            out["strength"] = self.strength
        return out

    @classmethod
    def from_json(cls, value) -> Lattice:
        if not isinstance(value, dict) or set(value) - {"modulus", "dual", "strength"}:
            raise TextonError(f"lattice must be an object with modulus, dual (and strength), got {value!r:.80}",
                              param="lattice")
        return cls(value.get("modulus"), value.get("dual"), value.get("strength"))  # type: ignore[arg-type]

    @classmethod
    def from_vectors(cls, vectors, shape, wrap=(False, False), strength: float | None = None) -> Lattice:
        """The lattice of one or two vectors (dy, dx) in texels, for an example of ``shape``.

        Where the example wraps on both axes and N = lcm(H, W) ≤ 2¹⁶, the lattice is made commensurate with
        it (each frequency rounded to whole cycles over the example: the vectors move by at most a fraction
        of a texel on a seamless example whose lattice they are); else N = 2¹⁶ (vectors within L²/2¹⁶
        texels of those given)."""
        try:
            v = np.array(vectors, dtype=np.float64).reshape(-1, 2)
        except (TypeError, ValueError):
            raise TextonError(f"lattice must be one or two vectors (dy, dx), got {vectors!r:.80}",
                              param="lattice") from None
        if v.shape[0] not in (1, 2) or not np.all(np.isfinite(v)) or np.size(vectors) != v.size:
            raise TextonError(f"lattice must be one or two vectors (dy, dx) of finite numbers, got {vectors!r:.80}",
                              param="lattice")
        lengths = np.hypot(v[:, 0], v[:, 1])
        if np.any(lengths < MIN_VECTOR):
            raise TextonError(f"lattice: vectors must be at least {MIN_VECTOR:g} texels long, got "
                              f"{', '.join(f'{x:.3g}' for x in lengths)}", param="lattice")
        if v.shape[0] == 2 and abs(v[0, 0] * v[1, 1] - v[0, 1] * v[1, 0]) < 1e-6 * lengths.prod():
            raise TextonError("lattice: the two vectors are parallel (give one vector for courses)",
                              param="lattice")
        h, w = shape[:2]
        # rows f_j: cycles per texel, f_j · v_i = δ_ij (F V^T = I)
        f = v / (lengths ** 2)[:, None] if v.shape[0] == 1 else np.linalg.inv(v.T)
        both = bool(wrap[0]) and bool(wrap[1])
        lcm = h * w // math.gcd(h, w)
        if both and lcm <= MAX_MODULUS:
            k = np.round(f * np.array([h, w], np.float64)).astype(np.int64)  # whole cycles over the example
            k = k * np.array([lcm // h, lcm // w], np.int64)
            n = lcm
        else:
            n = MAX_MODULUS
            k = np.round(f * n).astype(np.int64)
        return cls(n, tuple(tuple(int(x) for x in r) for r in k), strength)


# ---------------------------------------------------------------- detection


def _luminance(u) -> np.ndarray:
    a = np.asarray(u, np.float64)
    g = a.mean(axis=2) if a.ndim == 3 else a
    return g - g.mean()


def _prepared(u, exact: bool) -> np.ndarray:
    """The example's luminance, mean removed; its periodic component unless it wraps on both axes."""
    from .gaussian import periodic_component
    g = _luminance(u)
    if not exact:
        g = np.asarray(periodic_component(g[:, :, None]), np.float64)[:, :, 0]
        g = g - g.mean()
    return g


def autocorrelation(g: np.ndarray) -> np.ndarray:
    """The circular autocorrelation of g (mean removed), 1 at lag 0, lag 0 at the centre (H // 2, W // 2)."""
    from scipy import fft as sfft
    f = sfft.rfft2(g)
    a = sfft.irfft2(np.abs(f) ** 2, s=g.shape)
    return sfft.fftshift(a / max(float(a[0, 0]), 1e-30))


def _subpixel(a: np.ndarray, y: int, x: int) -> np.ndarray:
    off = np.zeros(2)
    h, w = a.shape
    if 0 < y < h - 1 and 0 < x < w - 1:
        for k, (m, p) in enumerate(((a[y - 1, x], a[y + 1, x]), (a[y, x - 1], a[y, x + 1]))):
            c = m - 2 * a[y, x] + p
            if c < 0:
                off[k] = float(np.clip(0.5 * (m - p) / c, -0.5, 0.5))
    return off


def autocorrelation_peaks(a: np.ndarray, limit: float) -> list[tuple[float, np.ndarray]]:
    """(value, lag (dy, dx)) of the autocorrelation's peaks in one half plane, nearest first: local maxima
    (5 × 5) at least :data:`MIN_VECTOR` and at most ``limit`` texels from the origin, of value at least
    :data:`PEAK_VALUE`, dipping by :data:`PEAK_DIP` on the way to the origin (not the central lobe's
    slope), the nearest :data:`PEAKS` of those at least half as high as the highest; sub-texel by a parabola
    on each axis."""
    from scipy.ndimage import map_coordinates, maximum_filter
    h, w = a.shape
    c = np.array([h // 2, w // 2], np.float64)
    ys, xs = np.nonzero(a == maximum_filter(a, size=5, mode="wrap"))
    out = []
    t = np.linspace(0.1, 0.9, 17)
    for y, x in zip(ys, xs):
        d = np.array([y, x], np.float64) - c
        r = float(np.hypot(*d))
        if r < MIN_VECTOR or r > limit or a[y, x] < PEAK_VALUE or d[0] < 0 or (d[0] == 0 and d[1] < 0):
            continue
        d = d + _subpixel(a, int(y), int(x))
        seg = c[None, :] + t[:, None] * d[None, :]
        if a[y, x] - map_coordinates(a, [seg[:, 0], seg[:, 1]], order=1, mode="wrap").min() < PEAK_DIP:
            continue
        out.append((float(a[y, x]), d))
    if not out:
        return out
    # the nearest of the strong peaks: a lattice's basis is short, and a regular texture's far peaks are as
    # high as its near ones
    top = max(p[0] for p in out)
    strong = sorted((p for p in out if p[0] >= 0.5 * top), key=lambda p: float(np.hypot(*p[1])))
    return strong[:PEAKS]


def _refined(a: np.ndarray, basis: np.ndarray, reach: int = 4) -> np.ndarray:
    """The basis (2, 2) refined by least squares over the autocorrelation's peaks near its lattice points
    within ``reach`` cells: a far peak measures the vectors as finely as its distance allows."""
    h, w = a.shape
    c = np.array([h // 2, w // 2], np.float64)
    limit = min(h, w) / 2 - 3
    rows, seen, weights = [], [], []
    for k1 in range(-reach, reach + 1):
        for k2 in range(-reach, reach + 1):
            d = basis @ np.array([k1, k2], np.float64)
            if (k1 == 0 and k2 == 0) or np.hypot(*d) > limit:
                continue
            iy, ix = (int(round(v)) for v in c + d)
            win = a[iy - 2:iy + 3, ix - 2:ix + 3]
            my, mx = np.unravel_index(int(np.argmax(win)), win.shape)
            y, x = iy - 2 + my, ix - 2 + mx
            if a[y, x] <= 0:
                continue
            rows.append((k1, k2))
            seen.append(np.array([y, x], np.float64) + _subpixel(a, y, x) - c)
            weights.append(math.sqrt(float(a[y, x])))
    if len(rows) < 3:
        return basis
    wts = np.array(weights)[:, None]
    sol, *_ = np.linalg.lstsq(np.array(rows, np.float64) * wts, np.array(seen) * wts, rcond=None)
    refined = sol.T
    return refined if abs(np.linalg.det(refined)) > 0.5 * abs(np.linalg.det(basis)) else basis


def lattice_frequencies(lattice: Lattice, shape) -> np.ndarray:
    """(n, 2): the lattice's frequencies (fy, fx) in cycles per texel within the band (|f| ≤ ½ on each axis),
    one of each ± pair, 0 left out."""
    f = lattice.frequencies()
    if lattice.rank == 1:
        m = int(0.5 / max(float(np.abs(f[0]).max()), 1e-12))
        return np.arange(1, m + 1)[:, None] * f[0][None, :]
    reach = int(np.ceil(np.abs(np.linalg.inv(f.T)).sum(axis=1).max() * 0.5)) + 1
    reach = min(reach, 256)
    k1, k2 = np.meshgrid(np.arange(-reach, reach + 1), np.arange(-reach, reach + 1), indexing="ij")
    pts = k1.ravel()[:, None] * f[0] + k2.ravel()[:, None] * f[1]
    keep = np.all(np.abs(pts) <= 0.5, axis=1) & (np.abs(pts).sum(axis=1) > 0)
    half = (pts[:, 0] > 1e-12) | ((np.abs(pts[:, 0]) <= 1e-12) & (pts[:, 1] > 0))
    return pts[keep & half]


def lattice_power(g: np.ndarray, exact: bool) -> np.ndarray:
    """The power spectrum the strengths are read from: g's own where the example wraps on both axes (its
    lattice frequencies fall on bins), else g under a Hann window: a frequency between bins leaks into
    the bins a few away from it as 1/d³ instead of 1/d², so that a lattice's sublattices, whose frequencies
    lie between the texture's, find no power there."""
    from scipy import fft as sfft
    if not exact:
        wy, wx = np.hanning(g.shape[0] + 2)[1:-1], np.hanning(g.shape[1] + 2)[1:-1]
        g = (g - g.mean()) * wy[:, None] * wx[None, :]
    power = np.abs(sfft.fft2(g)) ** 2
    power[0, 0] = 0.0
    return power


def _strength(power: np.ndarray, lattice: Lattice, exact: bool) -> tuple[float, float]:
    """(strength, its standard error): the power at the lattice's frequencies above the local background
    (median of a ring around each, over ln 2: the mean of an exponential periodogram), over the total;
    a frequency between bins (an example that does not wrap) takes the 3 × 3 bins around it."""
    h, w = power.shape
    total = float(power.sum())
    pts = lattice_frequencies(lattice, (h, w))
    if total <= 0 or not len(pts):
        return 0.0, 0.0
    r = 0 if exact else 1
    ring = r + 3
    oy, ox = np.meshgrid(np.arange(-ring, ring + 1), np.arange(-ring, ring + 1), indexing="ij")
    inner = (np.abs(oy) <= r) & (np.abs(ox) <= r)
    outer = (np.abs(oy) > r + 1) | (np.abs(ox) > r + 1)
    n_inner = int(inner.sum())
    cy = np.round(pts[:, 0] * h).astype(np.int64)
    cx = np.round(pts[:, 1] * w).astype(np.int64)
    around = power[(cy[:, None] + oy.ravel()[None, :]) % h, (cx[:, None] + ox.ravel()[None, :]) % w]
    bg = np.median(around[:, outer.ravel()], axis=1) / math.log(2.0)
    win = around[:, inner.ravel()].sum(axis=1)
    # only frequencies that stand out of their background count: a lattice's sublattices add frequencies
    # between the texture's, where the texture's peaks leak a little into many windows
    held = win > PEAK_CONTRAST * bg * n_inner
    excess = float((win - bg * n_inner)[held].sum())
    var = float((bg * bg).sum() * n_inner)
    return 2.0 * excess / total, 2.0 * math.sqrt(var) / total


def detect_lattices(u, wrap=(False, False)) -> list[Lattice]:  # noqa: C901 (the candidates, then the best)
    """Candidate lattices of an example (H, W, C): at most one 2-D and one 1-D lattice, each of strength at
    least :data:`MIN_STRENGTH` and :data:`MIN_SIGNIFICANCE` standard errors, strongest first; [] for a
    stochastic texture.

    Candidates: pairs of the autocorrelation's peaks (:func:`autocorrelation_peaks`; the example's own for a
    seamless example, its periodic component's otherwise), reduced, refined over the peaks of their
    lattice, and made integer (:meth:`Lattice.from_vectors`, commensurate with a seamless example); the
    1-D lattices of their dual vectors and small combinations of them, and of single peaks. Each vector
    between :data:`MIN_VECTOR` and half the example, at least six cells (2-D) or three courses (1-D) in it.
    The best of each rank by strength less three standard errors; a larger cell or longer course only
    where it holds 0.02 more (a lattice and its sublattices explain the same variance: the coarsest that
    does is the texture's).
    """
    wrap = (bool(wrap[0]), bool(wrap[1]))
    a = np.asarray(u, np.float64)
    h, w = a.shape[:2]
    if min(h, w) < 4 * MIN_VECTOR:
        return []
    both = wrap[0] and wrap[1]
    g = _prepared(a, both)
    power = lattice_power(g, both)
    ac = autocorrelation(g)
    peaks = [d for _, d in autocorrelation_peaks(ac, min(h, w) / 2)]
    limit = min(h, w) / 2
    seen: dict[tuple, Lattice] = {}

    def add(lattice: Lattice | None):
        if lattice is None or lattice.dual in seen:
            return
        if both and not lattice.commensurate((h, w)):
            return
        v = np.array(lattice.vectors)
        lengths = np.hypot(v[:, 0], v[:, 1])
        if lengths.min() < MIN_VECTOR or lengths.max() > limit:
            return
        if np.any(_repeats(v, (h, w)) < (MIN_REPEATS if both else MIN_REPEATS + 1)):
            return
        seen[lattice.dual] = lattice

    def make(vectors) -> Lattice | None:
        try:
            return Lattice.from_vectors(vectors, (h, w), wrap)
        except TextonError:
            return None

    def add_courses(lattice: Lattice | None):
        # a course vector and its fractions (a peak four courses away is a course lattice too)
        if lattice is None:
            return
        add(lattice)
        k = lattice.dual_matrix[0]
        for m in (2, 3, 4):
            if np.abs(k * m).max() <= lattice.modulus // int(math.ceil(MIN_VECTOR)):
                add(Lattice(lattice.modulus, (tuple(int(x) for x in k * m),)))

    for i in range(len(peaks)):
        add_courses(make([peaks[i]]))
        for j in range(i + 1, len(peaks)):
            b = np.stack([peaks[i], peaks[j]], axis=1)
            if abs(np.linalg.det(b)) < 0.2 * np.linalg.norm(peaks[i]) * np.linalg.norm(peaks[j]):
                continue
            b = _reduced(b)
            if not both:
                b = _reduced(_refined(ac, b))
            two = make([b[:, 0], b[:, 1]])
            if two is None:
                continue
            add(two)
            k = two.dual_matrix
            for m1, m2 in ((1, 0), (0, 1), (1, 1), (1, -1), (2, 1), (1, 2), (2, -1), (1, -2)):
                kk = m1 * k[0] + m2 * k[1]
                if kk.any() and np.abs(kk).max() <= two.modulus // int(math.ceil(MIN_VECTOR)):
                    add_courses(Lattice(two.modulus, (tuple(int(x) for x in kk),)))
    rows = []
    for lattice in seen.values():
        s, se = _strength(power, lattice, both)
        if s < MIN_STRENGTH or se > s / MIN_SIGNIFICANCE:
            continue
        v = np.array(lattice.vectors)
        size = abs(float(np.linalg.det(v))) if lattice.rank == 2 else float(np.hypot(*v[0]))
        rows.append((lattice.rank, s, size, _support(ac, v), lattice))
    found = []
    for rank in (2, 1):
        cand = [r for r in rows if r[0] == rank]
        if not cand:
            continue
        top = max(r[3] for r in cand)
        cand = [r for r in cand if r[3] >= SUPPORT * top and r[3] > 0]
        if not cand:
            continue
        strongest = max(r[1] for r in cand)
        _, s, _, _, lattice = min((r for r in cand if r[1] >= STRENGTH_KEPT * strongest),
                                  key=lambda r: (r[2], -r[1]))
        if rank == 1 and not both:
            lattice, s = _refined_course(power, lattice, s)
        found.append((s, Lattice(lattice.modulus, lattice.dual, round(s, 4))))
    if len(found) == 2 and found[0][0] < found[1][0] + MIN_SECOND_AXIS:
        found = found[1:]  # courses: a second vector adds nothing to them
    return [lat for _, lat in sorted(found, key=lambda t: -t[0])]


def _refined_course(power: np.ndarray, lattice: Lattice, strength: float) -> tuple[Lattice, float]:
    """A course lattice of an example that does not wrap, its dual vector moved by fractions of a frequency
    bin to where its strength is highest (an autocorrelation peak of courses lies anywhere along its
    ridge, and the vector through it leans): a pattern search, down to 1/16 of a bin."""
    h, w = power.shape
    n = lattice.modulus
    k = lattice.dual_matrix[0].astype(np.int64)
    step = max(1, int(round(n / (4.0 * max(h, w)))))
    best = (strength, k)
    while step >= max(1, n // (16 * max(h, w))):
        moved = False
        for dy in (-step, 0, step):
            for dx in (-step, 0, step):
                kk = best[1] + np.array([dy, dx])
                try:
                    cand = Lattice(n, (tuple(int(x) for x in kk),))
                except TextonError:
                    continue
                st, _ = _strength(power, cand, False)
                if st > best[0] + 1e-6:
                    best, moved = (st, kk), True
        if not moved:
            step //= 2
            if step == 0:
                break
    return Lattice(n, (tuple(int(x) for x in best[1]),)), best[0]


def _support(ac: np.ndarray, vectors: np.ndarray) -> float:
    """The autocorrelation (centred, :func:`autocorrelation`) at a lattice's vectors, the least of them
    (bilinear): every vector of the texture's lattice is a peak of it; a lattice that is not the
    texture's has a vector where the texture does not repeat."""
    from scipy.ndimage import map_coordinates
    c = np.array([ac.shape[0] // 2, ac.shape[1] // 2], np.float64)
    at = c[None, :] + np.asarray(vectors, np.float64)
    return float(map_coordinates(ac, [at[:, 0], at[:, 1]], order=1, mode="wrap").min())


def _repeats(vectors: np.ndarray, shape) -> np.ndarray:
    """How many times each lattice vector (dy, dx) fits across the example along its own direction (the
    example's width along a unit vector e is |e_y| H + |e_x| W)."""
    h, w = shape[:2]
    v = np.asarray(vectors, np.float64)
    lengths = np.maximum(np.hypot(v[:, 0], v[:, 1]), 1e-12)
    return (np.abs(v[:, 0]) * h + np.abs(v[:, 1]) * w) / lengths ** 2


def lattice_of(value, shape, wrap) -> Lattice | None:
    """A user's ``lattice`` argument as a :class:`Lattice` (None, a Lattice, or one or two vectors (dy, dx))."""
    if value is None or isinstance(value, Lattice):
        return value
    return Lattice.from_vectors(value, shape, wrap)


# ---------------------------------------------------------------- the lattice-periodic mean


def lattice_mean(u, lattice: Lattice, wrap=(False, False)) -> np.ndarray:
    """The mean of the example (H, W, C) over the lattice's translations at every texel, float32 (H, W, C).

    A seamless example (both axes) with a commensurate lattice: exactly its Fourier coefficients at the
    lattice's frequencies (and 0) kept, the others zeroed: the mean over the lattice's translations on the
    torus the example tiles. Otherwise: texels binned by phase (k · x / N mod 1; bins of about a texel,
    bilinear splat), each bin's mean read back bilinearly at each texel's phase.
    """
    from scipy import fft as sfft
    a = np.asarray(u, np.float64)
    a = a[:, :, None] if a.ndim == 2 else a
    h, w, c = a.shape
    if wrap[0] and wrap[1] and lattice.commensurate((h, w)):
        mask = np.zeros((h, w), bool)
        mask[0, 0] = True
        for fy, fx in lattice_frequencies(lattice, (h, w)):
            iy, ix = int(round(fy * h)) % h, int(round(fx * w)) % w
            mask[iy, ix] = mask[-iy % h, -ix % w] = True
        f = sfft.fft2(a, axes=(0, 1))
        return np.real(sfft.ifft2(f * mask[:, :, None], axes=(0, 1))).astype(np.float32)
    # phases at texel indices: an integer lattice's texels then fall on bin centres, each in one bin
    yy, xx = np.meshgrid(np.arange(h, dtype=np.float64), np.arange(w, dtype=np.float64), indexing="ij")
    phase = (np.stack([yy.ravel(), xx.ravel()], axis=1) @ lattice.frequencies().T) % 1.0  # (HW, rank)
    if lattice.rank == 2:  # the phase's axes are the dual vectors', whose cells span the primal basis
        bins = [max(4, int(round(float(np.hypot(*v))))) for v in _primal_of_dual(lattice)]
    else:
        bins = [max(4, int(round(float(np.hypot(*lattice.vectors[0])))))]
    flat = a.reshape(-1, c)
    corners = []
    for axis, n in enumerate(bins):
        p = phase[:, axis] * n
        i0 = np.floor(p).astype(np.int64) % n
        t = p - np.floor(p)
        corners.append(((i0, 1.0 - t), ((i0 + 1) % n, t)))
    shape_bins = tuple(bins)
    acc = np.zeros(shape_bins + (c,))
    weight = np.zeros(shape_bins)
    combos = [(p,) for p in corners[0]] if lattice.rank == 1 else [(p, q) for p in corners[0] for q in corners[1]]
    for combo in combos:
        index = tuple(ix for ix, _ in combo)
        wt = np.prod([t for _, t in combo], axis=0)
        np.add.at(acc, index, flat * wt[:, None])
        np.add.at(weight, index, wt)
    means = acc / np.maximum(weight, 1e-12)[..., None]
    out = np.zeros_like(flat)
    for combo in combos:
        index = tuple(ix for ix, _ in combo)
        out += means[index] * np.prod([t for _, t in combo], axis=0)[:, None]
    return out.reshape(h, w, c).astype(np.float32)


def _primal_of_dual(lattice: Lattice) -> list[np.ndarray]:
    """The primal vectors paired with each dual vector (B K^T = N I), columns of B in dual order."""
    b = lattice.modulus * np.linalg.inv(lattice.dual_matrix.astype(np.float64))
    return [b[:, 0], b[:, 1]]
