"""Finding the lattice of a near-regular example (model/lattice.py holds what a lattice is).

:func:`detect_lattices` seeds candidate lattices from the autocorrelation's peaks of the example's
luminance (its periodic component unless it wraps on both axes), refines each over every peak of the
lattice, and keeps those whose **strength** (the fraction of the example's variance in the lattice's
frequencies above the spectrum around them) is above :data:`MIN_STRENGTH` and significant; of a rank,
the one of the smallest cell among the strongest, best supported candidates is the texture's
(docs/tiling.md, "Lattices").
"""

from __future__ import annotations

import math

import numpy as np

from ..core.errors import TextonError
from .lattice import MIN_VECTOR, Lattice, lattice_frequencies, reduced_basis

# SciPy (its FFT and ndimage) and the periodic component are imported where they are used

__all__ = ["detect_lattices", "autocorrelation", "autocorrelation_peaks", "lattice_power", "MIN_STRENGTH",
           "MIN_SIGNIFICANCE"]

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
            b = reduced_basis(b)
            if not both:
                b = reduced_basis(_refined(ac, b))
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
