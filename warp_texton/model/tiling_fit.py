"""Fitting a tiling model to an example: its seams, its lattice and its side, chosen by measurement.

:func:`fit_tiling` (``analyze(u, method="tiling")``) reads what the example is before it makes the
model (docs/tiling.md, "Seamless examples", "Lattices"):

1. **seams** (:func:`~warp_texton.model.lattice_detection.seam_ratios`): an axis whose wrap seam is no stronger
   than the example's inside is read wrapped (``periodic="auto"``), so that a seamless example's
   centres lie anywhere and its patches may be as large as the example;
2. **lattices** (:func:`~warp_texton.model.lattice_detection.detect_lattices`): the candidate 2-D and 1-D
   lattices of a near-regular example (``lattice="auto"``), or the one a user gives;
3. **the choice**: every candidate (no lattice or each lattice found, times a few sides) makes a
   model whose output is *probed* — a raster made by :func:`probe`, the model's own draw evaluated in
   NumPy at scale 1 with its centres drawn from NumPy's generator (a statistical twin of the kernels'
   output: the same blend of the same patches, another stream) — and the candidate whose probe has
   the lowest patch distance to the example (:func:`~warp_texton.model.structure.patch_distance`) is
   kept. ``model.metadata["fit"]`` records the seams, the lattices, every candidate's distance.

The probe is NumPy because the model layer runs no kernels (docs/architecture.md); it reads texels
at whole-texel offsets only (scale 1, pixel centres), so it needs no interpolation.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..core.checks import as_image
from ..core.errors import TextonError
from .histogram import HistogramTransform, check_histogram, gauss_grid
from .lattice import Lattice, lattice_of, seam_ratios
from .lattice_detection import detect_lattices
from .structure import PROBE_LIMIT, check_tiling_analysis, patch_distance, scorable, structure_parts
from .tiling import CUTOFF_FRACTION, MIN_SIDE, SHARPNESS, TILING_KIND, TilingModel, centre_box

__all__ = ["fit_tiling", "LATTICE_AUTO", "example_wrap", "probe", "probe_distance", "gaussianised", "PROBE_SIDE", "SIDE_FRACTIONS",
           "CROP_SIDE_FRACTIONS", "snap_centres"]

#: The probe raster's side (texels; at most twice the example's): the outputs' usual size, where a side
#: of half the example shows a few triangles (priced as structure.PROBE_LIMIT).
PROBE_SIDE = PROBE_LIMIT
#: Candidate sides, as fractions of the example's smaller side: wrapped on both axes, and otherwise.
SIDE_FRACTIONS = (1 / 4, 1 / 3, 1 / 2)
CROP_SIDE_FRACTIONS = (1 / 4, 1 / 6)
#: Seeds of the probes (each candidate is probed with the same ones), and the patch distance's samples
#: and directions for them (a quarter and a half of the default: the candidates' differences, measured
#: with the same patches of the example, are what matters).
PROBE_SEEDS = (11, 12)
PROBE_SAMPLES = 4096
PROBE_DIRECTIONS = 32
#: A seamless example holds whole cells of its lattice: a lattice at least this strong that repeats a
#: fraction of a cell more than this across an axis makes the axis a crop's (:func:`fit_tiling`).
MIN_CELL_STRENGTH = 0.1
CELL_FRACTION = 0.2
CELL_STRENGTH = 0.8
CLEAR_SEAM = 1.0
#: ``lattice``'s default: detect the lattice (a marker, so that None can mean "no lattice").
LATTICE_AUTO = "auto"
#: A lattice is kept over a weaker one (or none) whose probe is at most this much closer to the example:
#: the stronger structure is the texture's (docs/tiling.md, "Lattices").
LATTICE_PREFERENCE = 1.1
SQRT3_2 = math.sqrt(3.0) / 2.0


def snap_centres(c: np.ndarray, p: np.ndarray, lattice: Lattice) -> np.ndarray:
    """``kernels/tiling_draw.py``'s ``lattice_snap`` in NumPy: centres c (n, 2) int (x, y) of vertices at
    the rounded positions p (n, 2) (x, y), snapped to the lattice (integer arithmetic, the same values)."""
    n = lattice.modulus
    k = lattice.dual_matrix[:, ::-1].astype(np.int64)  # (x, y) order
    pm = np.mod(np.asarray(p, np.int64), n)
    d = np.mod(np.asarray(c, np.int64) - pm, n)
    r = np.mod(d @ k.T, n)
    r = np.where(2 * r >= n, r - n, r)

    def round_div(a, b):
        m = (2 * np.abs(a) + b) // (2 * b)
        return np.where(a < 0, -m, m)

    if lattice.rank == 1:
        kk = int(k[0] @ k[0])
        delta = np.stack([round_div(k[0, 0] * r[:, 0], kk), round_div(k[0, 1] * r[:, 0], kk)], axis=1)
    else:
        det = int(k[0, 0] * k[1, 1] - k[0, 1] * k[1, 0])
        sg = -1 if det < 0 else 1
        nx = sg * (k[1, 1] * r[:, 0] - k[0, 1] * r[:, 1])
        ny = sg * (k[0, 0] * r[:, 1] - k[1, 0] * r[:, 0])
        delta = np.stack([round_div(nx, sg * det), round_div(ny, sg * det)], axis=1)
    return np.asarray(c, np.int64) - delta


def probe(model: TilingModel, shape=(PROBE_SIDE, PROBE_SIDE), seed: int = 0) -> np.ndarray:
    """A raster (H, W, C) float32 of the model at scale 1 evaluated in NumPy: the kernels' triangle grid,
    weights, cutoff, blend and lattice snap, with centres drawn from ``numpy.random.default_rng(seed)``
    (the module docstring). Without histogram tables (the blend itself, as ``model.example`` holds it)."""
    h, w = shape
    ex = model.example.astype(np.float64)
    mean_img = model.mean_image
    yy, xx = np.meshgrid(np.arange(h) + 0.5, np.arange(w) + 0.5, indexing="ij")
    sy = yy / (model.side * SQRT3_2)
    sx = xx / model.side - 0.5 * sy
    a, b = np.floor(sx).astype(np.int64), np.floor(sy).astype(np.int64)
    u, v = sx - a, sy - b
    upper = u + v > 1.0
    verts = [(np.where(upper, a + 1, a), np.where(upper, b + 1, b)), (a + 1, b), (a, b + 1)]
    wts = np.stack([np.where(upper, u + v - 1.0, 1.0 - u - v), np.where(upper, 1.0 - v, u),
                    np.where(upper, 1.0 - u, v)])
    k = np.where(wts > 0, np.maximum(wts, 0.0) ** model.sharpness, 0.0)
    k = np.where(k < k.max(axis=0) * CUTOFF_FRACTION, 0.0, k)
    k = k / k.sum(axis=0)
    # the vertices' centres: one draw per distinct vertex of the window
    keys = np.concatenate([(va * 1_000_003 + vb).ravel() for va, vb in verts])
    uniq, inverse = np.unique(keys, return_inverse=True)
    rng = np.random.default_rng(seed)
    (lx, nx), (ly, ny) = model.centre_box
    cen = np.stack([lx + rng.integers(0, nx, uniq.size), ly + rng.integers(0, ny, uniq.size)], axis=1)
    inverse = inverse.reshape(3, h, w)
    acc = np.zeros((h, w, ex.shape[2]))
    macc = np.zeros_like(acc)
    mean = ex.mean(axis=(0, 1))
    for i, (va, vb) in enumerate(verts):
        px = np.floor(model.side * (va + 0.5 * vb) + 0.5).astype(np.int64)
        py = np.floor(model.side * SQRT3_2 * vb + 0.5).astype(np.int64)
        c = cen[inverse[i]]
        if model.lattice is not None:
            c = snap_centres(c.reshape(-1, 2), np.stack([px.ravel(), py.ravel()], 1),
                             model.lattice).reshape(h, w, 2)
        qx = c[..., 0] + np.floor(xx).astype(np.int64) - px
        qy = c[..., 1] + np.floor(yy).astype(np.int64) - py
        qx = np.mod(qx, ex.shape[1]) if model.wrap[0] else np.clip(qx, 0, ex.shape[1] - 1)
        qy = np.mod(qy, ex.shape[0]) if model.wrap[1] else np.clip(qy, 0, ex.shape[0] - 1)
        e = ex[qy, qx]
        m = mean if mean_img is None else mean_img[qy, qx].astype(np.float64)
        acc += (e - m) * k[i][..., None]
        macc += m * k[i][..., None]
    if model.blend == "variance":
        acc /= np.sqrt((k ** 2).sum(axis=0))[..., None]
    return (macc + acc).astype(np.float32)


def probe_distance(model: TilingModel, reference: np.ndarray | None = None, seed: int = 0) -> float:
    """The mean patch distance of the model's probes (:data:`PROBE_SEEDS`) to ``reference`` (default: the
    example the model blends)."""
    ref = model.example if reference is None else reference
    side = min(PROBE_SIDE, 2 * max(ref.shape[:2]))
    return float(np.mean([patch_distance(probe(model, (side, side), s), ref, seed=seed, samples=PROBE_SAMPLES,
                                         directions=PROBE_DIRECTIONS) for s in PROBE_SEEDS]))


def _sides(shape, wrap, lattice: Lattice | None) -> list[float]:
    """The candidate sides for an example of ``shape`` read with ``wrap`` (and a lattice's half extent)."""
    small = min(shape[:2])
    fractions = SIDE_FRACTIONS if (wrap[0] and wrap[1]) else CROP_SIDE_FRACTIONS
    out: list[float] = []
    for f in fractions:
        s = max(2.0, float(math.floor(small * f)))
        ok = False
        while s >= 2.0:
            try:
                centre_box(shape, s, wrap, lattice)
                ok = True
                break
            except TextonError:
                s -= 1.0
        if ok and s not in out:
            out.append(s)
    return out


def _chosen(candidates: list) -> tuple:
    """The candidate (distance, side, lattice) kept: per lattice its closest side; then the strongest
    lattice whose distance is within :data:`LATTICE_PREFERENCE` of the closest of all."""
    measured = [c for c in candidates if c[0] is not None]
    if not measured:
        return candidates[0]
    per: dict = {}
    for c in measured:
        key = None if c[2] is None else c[2].dual
        if key not in per or c[0] < per[key][0]:
            per[key] = c
    closest = min(c[0] for c in per.values())
    fit = [c for c in per.values() if c[0] <= closest * LATTICE_PREFERENCE]
    return max(fit, key=lambda c: (-1.0 if c[2] is None else (c[2].strength or 0.0) * c[2].rank, -c[0]))


def _whole_cells(a: np.ndarray, wrap: tuple[bool, bool], seams) -> tuple[bool, bool]:
    """``wrap`` less the axes across which the example's lattice does not repeat a whole number of times.

    A seamless regular texture holds whole cells: its lattice, detected as a seamless example's (each
    frequency on whole cycles over the example), is as strong as detected as a crop's (sub-texel, free).
    Where the free lattice is stronger by more than :data:`CELL_STRENGTH` and repeats a fraction of a
    cell (more than :data:`CELL_FRACTION`) across an axis, the example is a crop whose seam hides in a
    flat part of its cells: that axis is not read wrapped. Only axes whose seam is no better than their
    inside (ratio above :data:`CLEAR_SEAM`) are checked: below it the join is seamless beyond doubt."""
    if not any(w and r > CLEAR_SEAM for w, r in zip(wrap, (seams.ratio_x, seams.ratio_y))):
        return wrap
    free = [lat for lat in detect_lattices(a, (False, False)) if (lat.strength or 0.0) >= MIN_CELL_STRENGTH]
    if not free:
        return wrap
    if wrap[0] and wrap[1]:
        whole = detect_lattices(a, wrap)
        if whole and max(lat.strength or 0.0 for lat in whole) >= CELL_STRENGTH * (free[0].strength or 0.0):
            return wrap
    k = free[0].dual_matrix.astype(np.float64) / free[0].modulus  # cycles per texel (fy, fx)
    out = list(wrap)
    for axis, size in ((0, a.shape[1]), (1, a.shape[0])):
        cycles = k[:, 1 - axis] * size
        ratio = seams.ratio_x if axis == 0 else seams.ratio_y
        if out[axis] and ratio > CLEAR_SEAM and np.any(np.abs(cycles - np.round(cycles)) > CELL_FRACTION):
            out[axis] = False
    return out[0], out[1]


def example_wrap(a: np.ndarray, periodic="auto"):
    """((x, y) wrap, :class:`~warp_texton.model.lattice_detection.Seams`): how :func:`fit_tiling` reads an example
    (H, W, C) for ``periodic`` ("auto": where its seams are seamless and it holds whole cells of its
    lattice; True or False: both axes)."""
    seams = seam_ratios(a)
    wrap = _wrap_of(periodic, seams)
    if periodic == "auto" and any(wrap):
        wrap = _whole_cells(a, wrap, seams)
    return wrap, seams


def _wrap_of(periodic, seams) -> tuple[bool, bool]:
    if periodic == "auto":
        return seams.wrap
    if isinstance(periodic, (bool, np.bool_)):
        return bool(periodic), bool(periodic)
    raise TextonError(f"periodic must be 'auto', True or False for method 'tiling', got {periodic!r:.60}",
                      param="periodic")


def fit_tiling(u, *, side: float | None = None, sharpness: int = SHARPNESS, guide_weight: float = 0.0,
               blend: str = "variance", score: bool = True, seed: int = 0, source: str | None = None,
               histogram: str = "gaussian", periodic: Any = "auto", lattice: Any = "auto") -> TilingModel:
    """The :class:`~warp_texton.model.tiling.TilingModel` of an example image (``analyze(u, method="tiling")``).

    ``periodic``: ``"auto"`` reads each axis wrapped where the example is seamless across it (its seam
    ratio, :func:`~warp_texton.model.lattice_detection.seam_ratios`); True or False on both axes. ``lattice``:
    ``"auto"`` tries the lattices :func:`~warp_texton.model.lattice_detection.detect_lattices` finds, None none,
    or one or two vectors (dy, dx) in texels (or a :class:`~warp_texton.model.lattice.Lattice`).
    ``side``: the triangles' side, or None to choose it with the lattice by the probes (module
    docstring). ``histogram="preserve"``: the model blends the example Gaussianised per channel and
    maps the blend back through its tables, so that the blend zones keep the example's marginals
    (Heitz & Neyret 2018, §1.4)."""
    histogram = check_histogram(histogram)
    a = as_image(u, "u")
    small = min(a.shape[:2])
    check_tiling_analysis(a.shape, score=score, histogram=histogram)  # before any of its work
    if small < MIN_SIDE:
        raise TextonError(f"the example must be at least {MIN_SIDE} pixels on each side for method 'tiling', "
                          f"got {a.shape[1]}x{a.shape[0]}", param="u")
    wrap, seams = example_wrap(a, periodic)
    if isinstance(lattice, str):
        if lattice != "auto":
            raise TextonError(f"lattice must be 'auto', None, one or two vectors (dy, dx), got {lattice!r:.60}",
                              param="lattice")
        found = detect_lattices(a, wrap)
        lattices: list[Lattice | None] = [None, *found]
    else:
        found = []
        lattices = [lattice_of(lattice, a.shape, wrap)]
    metadata: dict[str, Any] = {"method": TILING_KIND}
    if source is not None:
        metadata["source"] = source
    if score and scorable(a.shape):
        d_gauss, floor = structure_parts(a, seed)
        metadata["structure"] = d_gauss / max(floor, 1e-12)
        metadata["texton_distance"] = d_gauss
    if histogram == "gaussian":
        example, transform = a, None
    else:
        example, transform = gaussianised(a)
        metadata["histogram"] = histogram
        if score and scorable(a.shape):  # method="auto" compares in the space the model blends in
            metadata["texton_distance_blended"] = structure_parts(example.astype(np.float64), seed)[0]
    def measured(lat, s):
        try:
            m = TilingModel(example, s, sharpness, guide_weight, {}, blend, transform, wrap, lat)
        except TextonError:
            return None
        return (probe_distance(m, seed=seed) if probing else None), s, lat

    # the lattice at the middle side, then the side with that lattice (or the side given)
    probing = scorable(a.shape) and (len(lattices) > 1 or side is None)
    sides = {id(lat): ([float(side)] if side is not None else _sides(a.shape, wrap, lat)) for lat in lattices}
    candidates = [c for lat in lattices if sides[id(lat)]
                  for c in [measured(lat, sides[id(lat)][len(sides[id(lat)]) // 2])] if c is not None]
    if not candidates:  # the side given holds no candidate: the plain model's error
        TilingModel(example, float(side or 2.0), sharpness, guide_weight, {}, blend, transform, wrap, None)
    best = _chosen(candidates)
    for s in sides[id(best[2])]:
        if s != best[1] and probing:
            c = measured(best[2], s)
            if c is not None:
                candidates.append(c)
                best = c if c[0] < best[0] else best
    metadata["fit"] = {
        "seams": [round(seams.ratio_x, 4), round(seams.ratio_y, 4)],
        "wrap": [int(wrap[0]), int(wrap[1])],
        "lattices": [{"vectors": [list(v) for v in lat.vectors], "strength": lat.strength} for lat in found],
        "candidates": [{"side": s, "lattice": None if lat is None else [list(v) for v in lat.vectors],
                        "patch": None if d is None else round(d, 6)} for d, s, lat in candidates],
    }
    if best[0] is not None:
        metadata["tiling_distance"] = best[0]
    return TilingModel(example, best[1], sharpness, guide_weight, metadata, blend, transform, wrap, best[2])


def gaussianised(u: np.ndarray) -> tuple[np.ndarray, HistogramTransform]:
    """(example, transform) of a histogram-preserving tiling model of the image u (H, W, C).

    The example is u Gaussianised per channel (RGB channels for colour, as
    ``analyze``'s texton tables; grey's one channel): ranks to standard
    Gaussian quantiles (:meth:`HistogramTransform.to_gaussian`), float32. The
    outputs standardise the blend by the example's own mean and standard
    deviation (:func:`warp_texton.noise.colours.noise_moments`), so each table
    is fitted on those standardised values s: ``lut[c, k]`` is channel c of
    u where s crosses the grid value g_k (linear between the example's
    distinct values), the quantile of u at the probability of g_k. A texel
    alone (most of the plane at a high sharpness) then maps back to its own
    colour to within the table's resolution (10⁻⁴ on 8-bit photographs,
    where the tables of :meth:`HistogramTransform.fit`, read at shifted
    values, were a level off).
    """
    fit = HistogramTransform.fit(u, axes="rgb" if u.shape[2] > 1 else "pca")
    example = fit.to_gaussian(u).astype(np.float32)
    flat = example.reshape(-1, u.shape[2]).astype(np.float64)
    mean = example.mean(axis=(0, 1), dtype=np.float64)
    std = np.sqrt(np.maximum(((flat - mean) ** 2).mean(axis=0), 1e-30))
    s = (flat - mean) / std
    z = fit.decorrelate(u).reshape(-1, u.shape[2])
    grid = gauss_grid(fit.lut.shape[1])
    lut = np.empty_like(fit.lut)
    for c in range(u.shape[2]):
        values, first = np.unique(s[:, c], return_index=True)
        lut[c] = np.interp(grid, values, z[first, c])
    return example, HistogramTransform(fit.matrix, fit.centre, np.maximum.accumulate(lut, axis=1))
