"""Synthetic regular textures with known lattices: tiles, bricks and courses, seamless or cropped.

Ground truth for lattice detection and for the structure benchmarks (``bench_seamless.py``): each
case of :data:`CASES` draws an RGB image whose lattice vectors are known exactly.

* ``square`` — square tiles, stack bond, 32 texels (vectors (32, 0), (0, 32));
* ``running`` — running-bond bricks 32 × 64, each course shifted by half a brick (vectors (32, 32),
  (32, −32): the reduced basis of (0, 64) and (32, 32));
* ``hexagonal`` — near-hexagonal cells (the Voronoi cells of (0, 32) and (28, 16): integer vectors
  within 1 % of a hexagonal lattice, so that the seamless version tiles);
* ``rotated`` — square tiles turned by 18.4° (vectors (8, 24), (−24, 8));
* ``courses`` — a 1-D lattice: courses 24 texels high of stones of random length (18 to 78 texels)
  whose joints do not line up from course to course (vector (24, 0) only: no translation along the
  courses maps the texture onto itself).

Each with mortar lines (2 texels wide, anti-aliased), per-tile colour variation (``variation``,
the standard deviation of a tile's colour about the base colour), a smooth weathering field
(``weathering``, multiplicative) and white noise (``noise``). ``seamless=True`` returns a texture
whose period is the image (every lattice vector's multiple that spans it is integer, colours and
noise periodic); ``seamless=False`` returns a crop: a window of a seamless texture twice as large,
narrower than it by a fraction of a cell (0.37 of the shortest vector) and shifted, so its wrap cuts
through tiles.

Imported by the tests as ``from benchmarks.synthetic_lattices import lattice_texture`` (NumPy and
SciPy only, nothing from the package).

    >>> u, truth = lattice_texture("running", seed=1)
    >>> u.shape, truth.rank, truth.vectors
    ((256, 256, 3), 2, ((32.0, 32.0), (32.0, -32.0)))
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["CASES", "Truth", "lattice_texture", "same_lattice"]


@dataclass(frozen=True)
class Truth:
    """The known lattice of a synthetic texture: ``vectors`` (dy, dx) in texels, a reduced basis (two) or
    the course vector (one); ``rank`` 2 or 1; ``seamless`` whether the image tiles."""

    kind: str
    vectors: tuple[tuple[float, float], ...]
    seamless: bool

    @property
    def rank(self) -> int:
        return len(self.vectors)


@dataclass(frozen=True)
class _Case:
    vectors: tuple  # the lattice's basis (dy, dx), or the course vector
    shape: tuple  # the seamless image: a period of the lattice on both axes
    layout: str  # "voronoi", "bond" or "courses"


CASES = {
    "square": _Case(((32, 0), (0, 32)), (256, 256), "voronoi"),
    "running": _Case(((32, 32), (32, -32)), (256, 256), "bond"),
    "hexagonal": _Case(((0, 32), (28, 16)), (224, 224), "voronoi"),
    "rotated": _Case(((8, 24), (-24, 8)), (240, 240), "voronoi"),
    "courses": _Case(((24, 0),), (240, 240), "courses"),
}
#: Mortar: colour (RGB) and half width in texels.
MORTAR = np.array([0.78, 0.76, 0.72])
MORTAR_HALF = 1.0
BASE = np.array([0.55, 0.30, 0.22])
#: Course stones: mean length and the range of lengths (fractions of the mean).
STONE = 48.0
STONE_RANGE = (0.375, 1.625)


def _hash01(*keys: np.ndarray, seed: int, salt: int) -> np.ndarray:
    """Uniforms in [0, 1) from integer arrays (splitmix64's finaliser)."""
    with np.errstate(over="ignore"):
        z = np.uint64((seed * 0x9E3779B97F4A7C15 + salt * 0xD1B54A32D192ED03) & 0xFFFFFFFFFFFFFFFF)
        for k, m in zip(keys, (0xBF58476D1CE4E5B9, 0x94D049BB133111EB, 0xC2B2AE3D27D4EB4F)):
            z = z ^ (np.asarray(k).astype(np.int64).astype(np.uint64) * np.uint64(m))
            z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
            z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
            z = z ^ (z >> np.uint64(31))
    return (z >> np.uint64(11)).astype(np.float64) / 2.0 ** 53


def _periodic_field(shape, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """Periodic smooth Gaussian noise (H, W) of unit standard deviation: white noise low-passed in Fourier."""
    h, w = shape
    f = np.fft.fft2(rng.normal(size=(h, w)))
    fy, fx = np.meshgrid(np.fft.fftfreq(h), np.fft.fftfreq(w), indexing="ij")
    g = np.real(np.fft.ifft2(f * np.exp(-2.0 * (np.pi * sigma) ** 2 * (fy ** 2 + fx ** 2))))
    return g / max(float(g.std()), 1e-12)


def _reduce(cells: np.ndarray, period: np.ndarray) -> np.ndarray:
    """Integer cell coordinates (..., 2) reduced modulo the sublattice of the image's period (columns of
    ``period``, integer, in cell coordinates): the same tile across the wrap gets the same colour."""
    inv = np.linalg.inv(period)
    t = np.floor(cells @ inv.T + 1e-9)
    return np.rint(cells - t @ period.T).astype(np.int64)


def _voronoi(yy, xx, basis: np.ndarray, period: np.ndarray, seed: int):
    """(tile id (..., 2), distance to the cell's border) of the Voronoi cells of the lattice ``basis``."""
    p = np.stack([yy, xx], -1)
    c = p @ np.linalg.inv(basis).T
    base = np.floor(c)
    best = np.full(yy.shape, np.inf)
    second = np.full(yy.shape, np.inf)
    ids = np.zeros(yy.shape + (2,), np.int64)
    pts = []
    for dy in (-1, 0, 1, 2):
        for dx in (-1, 0, 1, 2):
            cell = base + np.array([dy, dx], np.float64)
            centre = cell @ basis.T
            pts.append((cell, centre))
    for cell, centre in pts:
        d = np.linalg.norm(p - centre, axis=-1)
        closer = d < best
        second = np.where(closer, best, np.minimum(second, d))
        ids = np.where(closer[..., None], cell.astype(np.int64), ids)
        best = np.where(closer, d, best)
    # distance to the bisector with the second-nearest centre (exact for a Voronoi edge)
    # is (d2² − d1²) / (2 |c2 − c1|); |c2 − c1| ≈ the shortest vector where they are neighbours
    short = float(np.min(np.hypot(basis[0], basis[1])))
    border = (second ** 2 - best ** 2) / (2.0 * short)
    return _reduce(ids, period), border


def _bond(yy, xx, height: float, width: float, period_rows: int, period_cols: int):
    """Running bond: course r shifted by r · width / 2; (tile id, distance to the brick's border)."""
    r = np.floor(yy / height)
    x = xx - r * width / 2.0
    col = np.floor(x / width)
    fy, fx = yy - r * height, x - col * width
    border = np.minimum(np.minimum(fy, height - fy), np.minimum(fx, width - fx))
    # reduce (r, col) modulo the image's period: rows mod period_rows, columns (in the course's frame)
    rr = r.astype(np.int64)
    q = rr // period_rows  # wrapping q periods of rows shifts the columns by q · period_rows / 2 bricks
    cc = col.astype(np.int64) + q * (period_rows // 2)
    return np.stack([rr - q * period_rows, cc % period_cols], -1), border


def _courses(yy, xx, height: float, period: tuple, seed: int, wrap_width: float):
    """Courses of stones of random lengths, joints wrapping at ``wrap_width``; (tile id, border distance)."""
    rows_in_period = int(round(period[0] / height))
    r = np.floor(yy / height).astype(np.int64)
    fy = yy - r * height
    rm = r % rows_in_period
    border = np.minimum(fy, height - fy)
    ids = np.zeros(yy.shape + (2,), np.int64)
    dist = np.full(yy.shape, np.inf)
    for row in np.unique(rm):
        joints = _course_joints(int(row), wrap_width, seed)
        sel = rm == row
        x = np.mod(xx[sel], wrap_width)
        k = np.searchsorted(joints, x, side="right") - 1  # stone k spans joints[k]..joints[k+1]
        left = x - joints[k]
        right = joints[k + 1] - x
        ids[sel] = np.stack([np.full(k.shape, row), k % (len(joints) - 1)], -1)
        dist[sel] = np.minimum(left, right)
    return ids, np.minimum(border, dist)


def _course_joints(row: int, width: float, seed: int) -> np.ndarray:
    """Stone joints of one course, periodic with period ``width``: random lengths rescaled to fill a period,
    a random phase; two periods' joints, from at most 0 to past ``width``, so every x in [0, width) lies
    between two of them."""
    rng = np.random.default_rng([seed, 7919, row])
    lengths: list[float] = []
    while sum(lengths) < width:
        lengths.append(STONE * rng.uniform(*STONE_RANGE))
    one = np.concatenate([[0.0], np.cumsum(np.array(lengths) * width / sum(lengths))])  # 0 .. width
    phase = rng.uniform(0.0, width)
    return np.concatenate([one[:-1] + phase - width, one + phase])


def _render(case: _Case, periods: int, seed: int, noise: float, variation: float, weathering: float) -> np.ndarray:
    """``periods`` × ``periods`` periods of the seamless texture of a case (its period: ``case.shape``), RGB
    float32 in [0, 1]: the tiles' colours repeat with the period, the weathering and the noise span the
    whole canvas (periodic over it)."""
    ph, pw = case.shape
    h, w = periods * ph, periods * pw
    rng = np.random.default_rng([seed, 104729, periods])
    yy, xx = np.meshgrid(np.arange(h) + 0.5, np.arange(w) + 0.5, indexing="ij")
    if case.layout == "voronoi":
        basis = np.array(case.vectors, np.float64).T  # columns
        period = np.linalg.solve(basis, np.array([[ph, 0], [0, pw]], np.float64))  # cell coordinates of the period
        if not np.allclose(period, np.rint(period), atol=1e-6):
            raise ValueError(f"{case.shape} is not a period of the lattice {case.vectors}")
        ids, border = _voronoi(yy, xx, basis, np.rint(period), seed)
    elif case.layout == "bond":
        height = float(case.vectors[0][0])
        width = 2.0 * float(case.vectors[0][1])
        if ph % int(2 * height) or pw % int(width):
            raise ValueError(f"{case.shape} is not a period of running bond {height}x{width}")
        ids, border = _bond(yy, xx, height, width, int(round(ph / height)), int(round(pw / width)))
    else:
        height = float(case.vectors[0][0])
        if ph % int(height):
            raise ValueError(f"{case.shape} is not a period of courses {height} high")
        ids, border = _courses(yy, xx, height, (ph, pw), seed, float(pw))
    # per-tile colour: brightness and a little hue, hashed on the tile id reduced modulo the period
    u = [_hash01(ids[..., 0], ids[..., 1], seed=seed, salt=s) for s in (1, 2, 3)]
    gain = 1.0 + variation * np.sqrt(12.0) * (u[0] - 0.5)
    tint = np.stack([1.0 + 0.5 * variation * np.sqrt(12.0) * (u[k] - 0.5) for k in (1, 2, 2)], -1)
    tile = BASE * gain[..., None] * tint
    # mortar, anti-aliased over one texel
    m = np.clip(MORTAR_HALF + 0.5 - border, 0.0, 1.0)[..., None]
    img = (1.0 - m) * tile + m * MORTAR
    if weathering:
        img = img * (1.0 + weathering * _periodic_field((h, w), 12.0, rng))[..., None]
    if noise:
        img = img + noise * rng.normal(size=img.shape)
    return np.clip(img, 0.0, 1.0).astype(np.float32)


def _reduced_basis(vectors) -> tuple[tuple[float, float], ...]:
    v = [np.array(x, np.float64) for x in vectors]
    if len(v) == 1:
        return (tuple(float(a) for a in v[0]),)
    b1, b2 = v
    for _ in range(64):
        if b1 @ b1 > b2 @ b2:
            b1, b2 = b2, b1
        m = round(float(b1 @ b2) / float(b1 @ b1))
        if m == 0:
            break
        b2 = b2 - m * b1
    return tuple(tuple(float(a) for a in b) for b in (b1, b2))


def lattice_texture(kind: str, *, seamless: bool = True, seed: int = 0, noise: float = 0.03,
                    variation: float = 0.12, weathering: float = 0.08, periods: int = 1) -> tuple[np.ndarray, Truth]:
    """(image (H, W, 3) float32 in [0, 1], its :class:`Truth`) of a case of :data:`CASES`.

    ``seamless=False``: a crop (module docstring). ``periods``: a seamless canvas of that many periods a
    side (without noise and weathering, exactly the one-period image tiled). The same ``seed`` gives the
    same image."""
    if kind not in CASES:
        raise ValueError(f"kind must be one of {', '.join(CASES)}, got {kind!r}")
    case = CASES[kind]
    h, w = case.shape
    if seamless:
        img = _render(case, periods, seed, noise, variation, weathering)
    else:
        big = _render(case, 2, seed, noise, variation, weathering)
        short = min(float(np.hypot(*v)) for v in case.vectors)
        cut = max(3, int(round(0.37 * short)))
        oy, ox = int(round(0.29 * h)), int(round(0.41 * w))
        img = np.ascontiguousarray(big[oy:oy + h - cut, ox:ox + w - cut])
    return img, Truth(kind, _reduced_basis(case.vectors), seamless)


def same_lattice(found, truth, tol: float = 0.5) -> bool:
    """Whether vectors ``found`` (one or two (dy, dx)) span the same lattice as ``truth`` to within ``tol``
    texels: each found vector is within ``tol`` of an integer combination of the true ones and the cells
    have the same area (two vectors), or the course vectors agree up to sign (one)."""
    f = np.array(found, np.float64).reshape(-1, 2)
    t = np.array(truth, np.float64).reshape(-1, 2)
    if f.shape[0] != t.shape[0]:
        return False
    if t.shape[0] == 1:
        return bool(min(np.hypot(*(f[0] - t[0])), np.hypot(*(f[0] + t[0]))) <= tol)
    coeffs = np.linalg.solve(t.T, f.T)  # found = truth^T · coeffs
    near = np.rint(coeffs)
    err = np.hypot(*(t.T @ near - f.T))
    same_area = abs(abs(np.linalg.det(near)) - 1.0) < 1e-9
    return bool(np.all(err <= tol) and same_area)
