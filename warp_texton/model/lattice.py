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
* detection (model/lattice_detection.py, ``detect_lattices``) — candidate lattices from the
  autocorrelation's peaks, each with its **strength**: the fraction of the example's variance in the
  lattice's frequencies above the spectrum around them (what the lattice-periodic mean holds beyond
  chance).
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

__all__ = ["Seams", "seam_ratios", "SEAM_THRESHOLD", "Lattice", "lattice_mean", "lattice_frequencies", "reduced_basis",
           "MIN_VECTOR", "MAX_MODULUS", "lattice_of"]

#: Above this ratio of wrap-seam energy to inside energy an axis is not seamless (measured on game
#: textures and crops of them, docs/tiling.md).
SEAM_THRESHOLD = 2.5
#: Shortest lattice vector, texels: shorter repeats are grain (JPEG blocks, weaves), not layout.
MIN_VECTOR = 6.0
#: The largest modulus N (integer dual vectors over N keep the evaluators' products within 32 bits).
MAX_MODULUS = 1 << 16


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


def reduced_basis(b: np.ndarray) -> np.ndarray:
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
        them (``lattice_detection.detect_lattices``); None for a lattice given by hand.

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
        b = reduced_basis(n * np.linalg.inv(k))  # columns: the primal basis (B K^T = N I)
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
