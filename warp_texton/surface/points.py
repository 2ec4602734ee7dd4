"""Surface texton noise at points of a surface (CGF §6).

At a surface point y with unit normal n and tangent frame (u1, u2), the noise
projects the impacts of a 3-D Poisson process of intensity λ that lie within
r/2 of the tangent plane, weighted by (1 − 2|⟨y − x, n⟩|/r)⁺:

    f(y) = Σ_i (1 − 2|⟨y − x_i, n⟩|/r)⁺ h(⟨y − x_i, u1⟩, ⟨y − x_i, u2⟩)
    g(y) = m + (f − λ (r/2) ∫h) / √(λ r/3)          (CGF Prop. 3)

so g has the texton's mean and variance on any surface. r is the larger side
of the texton's support and MNI = λ r · area(supp h) (λ r³ for a square
support). Frames follow one rule (see :func:`warp_texton.tangent_frames`,
warp_texton/surface/frames.py) unless given.

Points are evaluated in blocks (warp_texton/surface/blocks.py): sorted by the block of
cubes they lie in, each block's cubes draw their impacts once and every point
of the block gathers them, in the order a lone point would walk them
(``method="points"``, the reference), so both give the same values. Cube
indices come from float64 positions, so the noise is as exact far from the
origin as near it. Meshes and vertex colours are in mesh.py, renders in
render.py.

Kernels driven here: ``warp_texton.kernels.impacts``, ``warp_texton.kernels.surface_points``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import warp as wp

from ..core.checks import check_positive
from ..core.runtime import resolve_device, split_launch
from .blocks import BLOCK_CUBES, BYTES_PER_POINT, CLUSTER_MIN, CLUSTER_POINTS, BlockedPoints, gather_blocks, \
    sort_into_blocks
from ..noise.colours import to_colours
from ..core.errors import TextonError
from .frames import UP, as_points, check_lengths, frame_rule, unit_rows
from ..kernels import surface_points
from ..kernels.impacts import Cells3
from ..core.limits import check_memory, check_work
from ..noise.engine import MAX_CELL_INDEX, MAX_CELL_MEAN, WALK_COST, noise_setup
from ..noise.noise_options import NoiseOptions, check_poisson
from ..model.texton import Texton
from ..model.tiling import TilingModel
from .tiling import TILING_POINT_OPS, TilingSetup, check_tiling_reach, tiling_params, tiling_setup, \
    tiling_surface_noise, tiling_values

#: Default cell side relative to the slab thickness r.
CELL_FACTOR = 0.6
#: Refuse cube grids where one point must visit more cubes than this (a tiny cell_factor).
MAX_CUBES_PER_POINT = 8192
#: Evaluation paths: "blocks" (points share their cubes' impacts), "points"
#: (each point draws the impacts of its cubes itself: the reference) and "auto"
#: (the walk below AUTO_MIN_POINTS points, where sorting and the extra launches
#: cost more than they save — measured: 642 points, walk 14 ms, blocks 20 ms;
#: 10 000 sparse points, blocks 1.4× faster — else the points are sorted into blocks
#: and the blocks gather them when a block holds AUTO_MIN_DENSITY points or more on
#: average, the walk takes them otherwise). All give the same values.
METHODS = ("auto", "blocks", "points")
AUTO_MIN_POINTS = 4096
#: Points per block from which blocks beat the walk (measured on 200k points on spheres,
#: RGB textons of 32² and 64², MNI 60, 2 cores: blocks/walk time 0.13 at 25,000 points per
#: block, 0.66-0.73 at 31-68, 1.1 at 31 (64²), 1.6 at 12, 2.4 at 3.4-8.5, 5.4 at 1.2;
#: docs/benchmarks.md, "Surface noise").
AUTO_MIN_DENSITY = 24.0
#: Room for float32 rounding in :func:`walk_reach` (relative).
REACH_ROUNDING = 1.0 + 1e-5
#: Operations (the unit of limits.check_work) of the block path, fitted to its measured
#: times on dense and sparse point sets (docs/limits.md, "Surface noise by path"): per
#: cube drawn (its count, its impacts' slots and the host's index arrays) and per impact
#: drawn; per impact of a listed cluster's cubes scanned (the cubes of one walk); per
#: point and impact of its cluster's list (about λ r times the support box); and for a
#: point of a cluster too small for a list, which walks its block's drawn impacts, per
#: cube of its walk tested and per impact read.
BLOCK_CUBE_OPS = 340.0
BLOCK_IMPACT_OPS = 3.7
LIST_OPS = 7.0
GATHER_OPS = 1.5
BLOCK_WALK_CUBE_OPS = 62.0
BLOCK_WALK_OPS = 2.0


def _prepare_points(pts: np.ndarray, normals: np.ndarray, texel: float) -> tuple[np.ndarray, np.ndarray]:
    """(pts / texel, float32 unit normals) from finite (N, 3) float64 arrays, in a CPU
    kernel: the values of ``pts / texel`` and ``unit_rows(normals)`` in one pass."""
    n = len(pts)
    pos = np.empty((n, 3))
    unit = np.empty((n, 3), np.float32)
    length = np.empty(n)
    inputs: list[wp.array] = [wp.array(np.ascontiguousarray(pts), dtype=wp.vec3d, device="cpu", copy=False),
              wp.array(np.ascontiguousarray(normals), dtype=wp.vec3d, device="cpu", copy=False)]
    outputs: list[wp.array] = [wp.array(a, dtype=t, device="cpu", copy=False)
               for a, t in ((pos, wp.vec3d), (unit, wp.vec3), (length, wp.float64))]
    split_launch("cpu", surface_points, n, lambda a, b: wp.launch(
        surface_points.prepare_points, dim=b - a, device="cpu",
        inputs=[*(x[a:b] for x in inputs), wp.float64(texel), *(y[a:b] for y in outputs)]))
    check_lengths(length, "normals")
    return pos, unit


@dataclass(frozen=True)
class SurfaceSetup:
    r: float
    lam: float
    cell: float
    coeffs: np.ndarray
    lo: tuple[float, float]  # texton support box, texton coordinates
    hi: tuple[float, float]
    texton: Texton | None = None  # whose histogram transform maps the values (evaluate_points)


def surface_setup(texton: Texton | TilingModel, mni: float, cell_factor: float = CELL_FACTOR) -> SurfaceSetup:
    if isinstance(texton, TilingModel):  # a tiling model: triplanar projection (surface/tiling.py)
        return tiling_setup(texton, mni)  # type: ignore[return-value]
    base = noise_setup(texton, mni)
    r = max(base.hi[0] - base.lo[0], base.hi[1] - base.lo[1])
    lam = check_positive(mni, "mni") / (r * texton.support_area)
    cell = float(np.float32(check_positive(cell_factor, "cell_factor") * r))
    per_point = (math.ceil(r * math.sqrt(3.0) / cell) + 1) ** 3
    if per_point > MAX_CUBES_PER_POINT:
        raise TextonError(f"cell_factor {cell_factor:g} is too small: each point would visit {per_point} cells "
                          f"(at most {MAX_CUBES_PER_POINT})")
    if lam * cell ** 3 > MAX_CELL_MEAN:
        raise TextonError(f"cell_factor {cell_factor:g} is too large: cells would hold {lam * cell ** 3:.3g} impacts")
    return SurfaceSetup(r, lam, cell, base.coeffs, base.lo, base.hi, texton)


def walk_cubes(setup: SurfaceSetup) -> int:
    """The cubes a point's walk may visit."""
    return (math.ceil(setup.r * math.sqrt(3.0) / setup.cell) + 1) ** 3


def surface_visits(setup: SurfaceSetup) -> float:
    """Operations (the unit of limits.check_work) of one point's walk (``method="points"``):
    the impacts of the cubes its walk may visit, times WALK_COST, as a point of the plane
    counts them (noise.walk_cost). Measured on a two-core CPU: 7e8 to 1e9 of them a second
    (docs/limits.md)."""
    return WALK_COST * walk_cubes(setup) * setup.lam * setup.cell ** 3


def _listed(setup: SurfaceSetup) -> float:
    # impacts of a cluster's list, about: λ r times the texton's support box
    return setup.lam * setup.r * (setup.hi[0] - setup.lo[0]) * (setup.hi[1] - setup.lo[1])


def _gather_visits(setup: SurfaceSetup, per_cluster: float) -> float:
    # a point of a cluster of ``per_cluster`` points: its walk of the block's impacts (a
    # cluster too small for a list), or its share of the list and its gather
    mu = setup.lam * setup.cell ** 3
    if per_cluster < CLUSTER_MIN:
        return walk_cubes(setup) * (BLOCK_WALK_CUBE_OPS + BLOCK_WALK_OPS * mu)
    return walk_cubes(setup) * mu * LIST_OPS / per_cluster + _listed(setup) * GATHER_OPS


def _cube_ops(setup: SurfaceSetup) -> float:
    return BLOCK_CUBE_OPS + BLOCK_IMPACT_OPS * setup.lam * setup.cell ** 3


#: Listed clusters whose normals' spread prices the block path's gathers (an even sample).
SPREAD_SAMPLE = 4096


def block_visits(setup: SurfaceSetup, blocked: BlockedPoints) -> float:
    """Operations of the block path for points sorted into blocks: the cubes each block
    draws, each listed cluster's scan of its cubes and its points' gathers, and the walks
    of the points of clusters too small for a list (BLOCK_CUBE_OPS ... BLOCK_WALK_OPS).
    A cluster's list grows with the spread ν of its normals (its slab and support ranges
    widen by R ν, R = (r/2)√3: kernels/surface_points.py, list_cluster), up to all the impacts
    of its cubes: points on a surface have ν near 0, a cloud of random normals near 1.4."""
    n = len(blocked.order)
    cubes = float(np.prod(blocked.hi - blocked.lo + 1, axis=1, dtype=np.float64).sum())
    sizes = np.diff(np.r_[blocked.clusters, n])
    listed = sizes >= CLUSTER_MIN
    n_listed = float(sizes[listed].sum())
    scanned = walk_cubes(setup) * setup.lam * setup.cell ** 3
    gathers = 0.0
    if n_listed and blocked.nrm is not None:
        # the spread of the normals of an even sample of the listed clusters (all of them up
        # to SPREAD_SAMPLE): the price is an estimate, and the whole set's spreads cost a
        # tenth of the gather on a million points
        first, size = blocked.clusters[listed], sizes[listed]
        step = max(1, -(-len(first) // SPREAD_SAMPLE))
        first, size = first[::step], size[::step]
        rows = np.arange(int(size.max()))
        inside = rows[None, :] < size[:, None]
        nrm = blocked.nrm[np.where(inside, first[:, None] + rows[None, :], first[:, None])].astype(np.float64)
        mean = (nrm * inside[..., None]).sum(axis=1) / size[:, None]
        nu = np.where(inside, np.linalg.norm(nrm - mean[:, None, :], axis=2), 0.0).max(axis=1)
        growth = (1.0 + math.sqrt(3.0) * nu) ** 3
        per_point = float(np.sum(size * np.minimum(_listed(setup) * growth, scanned))) / float(size.sum())
        gathers = n_listed * per_point * GATHER_OPS
    return (cubes * _cube_ops(setup) + float(np.count_nonzero(listed)) * scanned * LIST_OPS + gathers
            + (n - n_listed) * _gather_visits(setup, 0.0))


def density_visits(setup: SurfaceSetup, density: float) -> float:
    """Operations per point of points spread over a surface at ``density`` points per
    texel² (a render's hits, a bake's samples), on the path ``method="auto"`` takes: the
    walk where a block would hold fewer than AUTO_MIN_DENSITY points, else a block's
    cubes around a flat patch shared by its points, plus a cluster's share. The estimate
    of :func:`block_visits` before the points exist."""
    if isinstance(setup, TilingSetup):
        return TILING_POINT_OPS
    block_side = BLOCK_CUBES * setup.cell
    per_block = density * block_side * block_side
    if not per_block >= AUTO_MIN_DENSITY:
        return surface_visits(setup)
    e = 2.0 * walk_reach(setup.r) / setup.cell + 1.0  # cubes a block reaches past its points, per axis
    cubes = (BLOCK_CUBES + e) ** 2 * (1.0 + e)
    per_cluster = min(float(CLUSTER_POINTS), density * (setup.cell / 2.0) ** 2)
    return min(surface_visits(setup), cubes * _cube_ops(setup) / per_block + _gather_visits(setup, per_cluster))


def floor_visits(setup: SurfaceSetup) -> float:
    """The fewest operations a point can cost on any path (a full cluster's share of the
    densest block path): ``points × floor_visits`` over the budget is refused before
    anything is sorted or cast."""
    if isinstance(setup, TilingSetup):
        return TILING_POINT_OPS
    return _gather_visits(setup, float(CLUSTER_POINTS))


def check_floor(setup: SurfaceSetup, points: float, what: str, hint: str, *, param: str | None = None,
                mentions: tuple[str, ...] = ()) -> None:
    """Refuse ``points`` evaluations that would pass the work budget on any path, before
    any work (an early check: the call's estimate by path comes later)."""
    check_work(points * floor_visits(setup), what, hint, param=param, mentions=mentions, early=True)


def check_surface_work(setup: SurfaceSetup, points: float, density: float, what: str, hint: str, *,
                       param: str | None = None, mentions: tuple[str, ...] = (), early: bool = False,
                       other: float = 0.0) -> None:
    """Refuse ``points`` evaluations of the surface noise at ``density`` points per texel²
    of a surface (:func:`density_visits`), with ``other`` operations of the caller's own,
    beyond the work budget."""
    check_work(other + points * density_visits(setup, density), what, hint, param=param, mentions=mentions,
               early=early)


@dataclass(frozen=True)
class PointsPlan:
    """How :func:`evaluate_points` will evaluate a set of points: ``method``
    ("blocks" or "points"), its estimated ``operations`` and, for blocks, the
    points sorted into them."""

    method: str
    operations: float
    blocked: BlockedPoints | None = None


def plan_points(setup: SurfaceSetup, pos: np.ndarray, nrm: np.ndarray, method: str = "auto") -> PointsPlan:
    """The path and the price of evaluating the surface noise at checked texel positions
    ``pos`` with unit normals ``nrm``: the walk (``surface_visits`` a point) below
    AUTO_MIN_POINTS points, for ``method="points"`` and for sparse sets; else the points
    are sorted into blocks (their memory priced first) and priced by :func:`block_visits`."""
    n = len(pos)
    if isinstance(setup, TilingSetup):
        return PointsPlan("tiling", n * TILING_POINT_OPS)
    walk = n * surface_visits(setup)
    if n == 0 or method == "points" or (method == "auto" and n < AUTO_MIN_POINTS):
        return PointsPlan("points", walk)
    check_memory(n * float(BYTES_PER_POINT), f"sorting {n} points into blocks", "evaluate fewer points at once")
    blocked = sort_into_blocks(pos, nrm, setup.cell, walk_reach(setup.r))
    # by density: a sparse set's blocks draw many cubes for few points each
    if method == "auto" and n / len(blocked.starts) < AUTO_MIN_DENSITY:
        return PointsPlan("points", walk)
    return PointsPlan("blocks", block_visits(setup, blocked), blocked)


def surface_params(texton: Texton | TilingModel, setup: SurfaceSetup, seed: int, poisson: str, up, side_dir) -> surface_points.SurfaceParams:
    """The kernels' ``SurfaceParams`` (CGF Prop. 3 normalisation, the frame rule's directions)."""
    if isinstance(texton, TilingModel):  # the triplanar planes' seeds and blend instead
        return tiling_params(texton, seed, up, side_dir)
    check_poisson(poisson)
    cells = Cells3()
    cells.size = setup.cell
    cells.mean_count = setup.lam * setup.cell ** 3
    cells.seed = wp.uint32(seed)
    cells.exact_poisson = 1 if poisson == "exact" else 0
    p = surface_points.SurfaceParams()
    p.cells = cells
    p.order = texton.order
    p.half = setup.r / 2.0
    p.centre = wp.vec2((setup.lo[0] + setup.hi[0]) / 2.0, (setup.lo[1] + setup.hi[1]) / 2.0)
    p.lo = wp.vec2(*setup.lo)
    p.hi = wp.vec2(*setup.hi)
    c = texton.channels
    integral = np.zeros(3)
    integral[:c] = texton.integral
    mean = np.zeros(3)
    mean[:c] = texton.mean
    p.shift = wp.vec3(*(setup.lam * setup.r / 2.0 * integral))
    p.inv_scale = 1.0 / math.sqrt(setup.lam * setup.r / 3.0)
    p.mean = wp.vec3(*mean)
    a, b = frame_rule(up, side_dir)
    p.up = wp.vec3(*a)
    p.side = wp.vec3(*b)
    return p


def check_reach(pos: np.ndarray, setup: SurfaceSetup, what: str) -> None:
    """Refuse positions (texel units, float64) whose cubes would not fit the
    kernels' int32 cube indices, or that overflowed (a tiny texel_size)."""
    if isinstance(setup, TilingSetup):
        return check_tiling_reach(pos, what)
    with np.errstate(over="ignore", invalid="ignore"):
        far = float(np.abs(pos).max()) if pos.size else 0.0
    limit = (MAX_CELL_INDEX - 2) * setup.cell - setup.r
    if not far < limit:
        where = f"{far:.3g} texels" if math.isfinite(far) else "beyond floating point range"
        raise TextonError(
            f"{what} lie too far from the origin for this texel_size: {where}, where the surface noise is "
            f"defined within ±{limit:.3g} texels (2**30 cubes); use a larger texel_size or move them nearer "
            "the origin"
        )


def texel_positions(points: np.ndarray, texel: float, setup: SurfaceSetup, what: str) -> np.ndarray:
    """World positions divided by the texel size, in float64, checked by :func:`check_reach`."""
    with np.errstate(over="ignore", invalid="ignore"):
        pos = np.asarray(points, dtype=np.float64) / texel
    check_reach(pos, setup, what)
    return pos


def walk_reach(r: float) -> float:
    """How far a point's walk reaches per axis, in texels, for a slab of thickness r:
    the walk's box, frame_extent (kernels/surface_points.py), is at most (r/2)√3 per axis (a
    row of an orthogonal matrix has unit length); with room for float32 rounding, every
    cube a point's walk visits lies in its block."""
    return r / 2.0 * math.sqrt(3.0) * REACH_ROUNDING


def check_method(method: str) -> str:
    if method not in METHODS:
        raise TextonError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    return method


SURFACE_NOISE = NoiseOptions(mni=60.0, cell_factor=CELL_FACTOR)
"""The surface functions' default noise options: MNI 60 (CGF Fig. 4), the other fields the plane's."""


def surface_options(noise: NoiseOptions | None, **keywords) -> NoiseOptions:
    """The :class:`~warp_texton.NoiseOptions` of a surface call: ``noise``, or its
    keywords over :data:`SURFACE_NOISE`; a period is refused (surface noise has none)."""
    noise = NoiseOptions.given(noise, defaults=SURFACE_NOISE, **keywords)
    if noise.period is not None:
        raise TextonError(f"period {noise.period} of noise: surface noise has no period; use period=None",
                          param="period")
    return noise


def surface_noise(
    texton: Texton | TilingModel,
    points,
    normals,
    texel_size: float,
    *,
    mni: float = 60.0,
    seed: int = 0,
    tangents=None,
    device=None,
    up=UP,
    side=None,
    poisson: str = "exact",
    cell_factor: float = CELL_FACTOR,
    noise: NoiseOptions | None = None,
    method: str = "auto",
) -> np.ndarray:
    """Surface texton noise at points of a surface (CGF §6, Prop. 3).

    Positions are in world units; ``texel_size`` (world units per texel) sets
    the scale of the texture on the surface. A point's value depends only on
    its position (in texels), its normal and frame, the texton and the
    options, not on the other points.

    Parameters
    ----------
    texton : Texton or TilingModel
        A tiling model (``analyze(..., method="tiling")``) is projected
        triplanarly (docs/tiling.md, "Surfaces"); it refuses ``mni``,
        ``tangents``, ``poisson``, ``cell_factor``, ``noise`` and ``method``.
    points : array (N, 3)
        Surface points, world units.
    normals : array (N, 3)
        Normals at the points; normalised here, so any non-zero length.
    texel_size : float
        World units per texel, > 0: the texture's scale on the surface
        (smaller values give a finer texture).
    mni : float
        Mean number of impacts per point, > 0; λ = ``mni / (r ·
        texton.support_area)``, r the larger side of the texton's support.
        Surfaces need more than the plane (the slab weighting): 60 by
        default (CGF Fig. 4).
    seed : int
        In [0, 2**32); the surface noise of a seed is independent of the
        plane noise of the same seed.
    tangents : array (N, 3), optional
        The direction of the texton's x axis at each point, projected onto
        the tangent plane and normalised. By default the frame rule of
        :func:`tangent_frames`.
    device : str, optional
        As in :func:`warp_texton.synthesize`.
    up : str or (x, y, z)
        The frame rule's up direction (:func:`tangent_frames`): a vector or
        an axis name, "x", "y" or "z"; default z.
    side : (x, y, z), optional
        The frame rule's second direction; default the world's right for
        the up axis (x, or y when up is x).
    poisson : {"exact", "gaussian"}
        As in :func:`warp_texton.synthesize`.
    cell_factor : float
        As in :func:`warp_texton.synthesize`, relative to r (the cube side is
        ``cell_factor · r``).
    noise : NoiseOptions, optional
        ``mni``, ``seed``, ``poisson`` and ``cell_factor`` as one value
        (:class:`~warp_texton.NoiseOptions`), in place of those keywords, which
        must then keep their defaults; its ``period`` must be None (surface
        noise has none).
    method : {"auto", "blocks", "points"}
        ``"blocks"``: points sorted into blocks share the impacts of their
        cubes; ``"points"``: each point draws its cubes' impacts itself (the
        reference: the same values, slower on many points); ``"auto"``
        (default): the walk below 4096 points (``AUTO_MIN_POINTS``), where
        sorting and the extra launches cost more than they save; above, the
        points are sorted into blocks and the blocks gather them where a block
        holds 24 points or more on average (``AUTO_MIN_DENSITY``), the walk
        takes sparser sets (200k points a few cubes apart: 5× faster).

    Returns
    -------
    float32 array (N, C)
        The noise at each point, with the texton's mean and lag-0 covariance
        in expectation. An empty ``(0, 3)`` input gives an empty ``(0, C)``
        result.

    Raises
    ------
    TextonError
        For a ``texton`` that is not a :class:`~warp_texton.Texton`;
        ``points``, ``normals`` or ``tangents`` that are not numeric (N, 3)
        arrays of the same shape or hold NaN or infinite values; a zero
        normal, or a tangent that is zero or parallel to its normal; a
        ``texel_size`` or ``mni`` that is not a finite number > 0; a bad
        ``seed``, ``device``, ``poisson`` or ``method``; a zero ``up`` or
        ``side``; points whose cubes lie more than 2**30 cubes from the
        origin ("points lie too far from the origin for this texel_size: …
        texels, where the surface noise is defined within ±… texels (2**30
        cubes)", which a tiny ``texel_size`` also gives); a ``cell_factor``
        that would visit more than 8192 cells per point
        (``MAX_CUBES_PER_POINT``) or hold more than 10**5 impacts per cell;
        a block whose impacts would pass the memory budget; points over the
        work budget, priced by the path they take (the walk, or the blocks
        they are sorted into; docs/limits.md, "Surface noise by path"):
        "surface noise at … points at MNI … needs about … operations, over
        the work budget …".

    Notes
    -----
    A 3-D Poisson process whose impacts near the tangent plane are projected
    onto it, with the normalisation of CGF Prop. 3, so the noise has the
    texton's mean and covariance on any surface (the formulas are in the
    module's docstring). Points are evaluated in blocks that share the
    impacts of their cubes (the same values, bit for bit on the CPU, as each
    point walking its own cubes: ``method="points"``), and cubes are found
    from float64 positions, so meshes far from the origin get the same noise
    quality as near it. The model, the frame rule and the renderer are
    derived in docs/model.md §12; meshes are ``trimesh.Trimesh`` objects
    (:func:`texture_mesh`, :func:`render_mesh`, :func:`bake_mesh`).

    References
    ----------
    CGF §6, Proposition 3 (the slab weight and the normalisation); CGF
    Fig. 4 (the MNI surfaces need).

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton, surface_noise
    >>> t = Texton(np.random.default_rng(0).standard_normal((8, 8, 1)) / 8, [0.5])
    >>> p = np.random.default_rng(1).normal(size=(5, 3))
    >>> surface_noise(t, p, p, texel_size=0.01, device="cpu").shape
    (5, 1)
    >>> bool(np.array_equal(surface_noise(t, p, p, 0.01, device="cpu"),
    ...                     surface_noise(t, p, p, 0.01, device="cpu", method="points")))
    True

    The noise of a texton analysed from the demo texture at the vertices of a
    sphere, 100 texels per world unit:

    >>> import trimesh
    >>> from warp_texton import read_image, analyze, tangent_frames
    >>> from warp_texton.demo import demo_texture_path
    >>> texton = analyze(read_image(demo_texture_path()), size=32, iterations=30)
    >>> sphere = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    >>> values = surface_noise(texton, sphere.vertices, sphere.vertex_normals, 0.01, device="cpu")
    >>> values.shape, values.dtype
    ((642, 1), dtype('float32'))

    Given tangents, here the rule's u2, turn the texture by 90 degrees on the
    surface:

    >>> u1, u2 = tangent_frames(sphere.vertex_normals)
    >>> turned = surface_noise(texton, sphere.vertices, sphere.vertex_normals, 0.01,
    ...                        tangents=u2, device="cpu")
    >>> bool(np.array_equal(turned, values))
    False

    The mean and variance are the texton's: many independent points (far
    apart, random normals):

    >>> rng = np.random.default_rng(0)
    >>> far = surface_noise(texton, rng.uniform(-1e4, 1e4, (5000, 3)), rng.normal(size=(5000, 3)),
    ...                     1.0, device="cpu")
    >>> round(float(far.mean()), 3), round(float(texton.mean[0]), 3)
    (0.464, 0.466)
    >>> round(float(far.var()), 4), round(float(texton.covariance()[0, 0]), 4)
    (0.0244, 0.0243)
    """
    if isinstance(texton, TilingModel):  # triplanar tiling (surface/tiling.py)
        return tiling_surface_noise(texton, points, normals, texel_size, seed=seed, device=device, up=up, side=side,
                                    options=dict(mni=(mni, 60.0), tangents=(tangents, None), poisson=(poisson, "exact"),
                                                 cell_factor=(cell_factor, CELL_FACTOR), noise=(noise, None),
                                                 method=(method, "auto")))
    if not isinstance(texton, Texton):
        raise TextonError(f"texton must be a Texton, got {type(texton).__name__}")
    pts = as_points(points, "points")
    raw = as_points(normals, "normals")
    if raw.shape != pts.shape:
        raise TextonError(f"normals has shape {raw.shape}; it must match points {pts.shape}")
    texel = check_positive(texel_size, "texel_size")
    noise = surface_options(noise, mni=mni, seed=seed, poisson=poisson, cell_factor=cell_factor)
    check_method(method)
    setup = surface_setup(texton, noise.mni, noise.cell_factor)
    what, hint = f"surface noise at {len(pts)} points at MNI {noise.mni:.6g}", "use fewer points or a lower mni"
    check_floor(setup, len(pts), what, hint, param="mni", mentions=("points", "mni"))
    device = resolve_device(device)  # starts Warp quietly, before the first launch
    if tangents is None:
        # positions in texels and float32 unit normals in one CPU pass (the values of
        # texel_positions and unit_rows), then their checks
        pos, nrm = _prepare_points(pts, raw, texel)
        check_reach(pos, setup, "points")
        tan = None
    else:
        nrm = unit_rows(raw, "normals")
        tan = as_points(tangents, "tangents")
        if tan.shape != pts.shape:
            raise TextonError(f"tangents has shape {tan.shape}; it must match points {pts.shape}")
        raw_t = np.linalg.norm(tan, axis=1)
        tan = tan - nrm * np.sum(tan * nrm, axis=1)[:, None]
        flat = np.flatnonzero(np.linalg.norm(tan, axis=1) <= 1e-9 * np.maximum(raw_t, 1e-300))
        if flat.size:
            what = "has zero length" if raw_t[flat[0]] == 0 else "is parallel to its normal"
            raise TextonError(f"tangents[{flat[0]}] {what} ({flat.size} such rows); a tangent must have a "
                              "component in the tangent plane")
        tan = tan / np.linalg.norm(tan, axis=1)[:, None]
        pos = texel_positions(pts, texel, setup, "points")
    p = surface_params(texton, setup, noise.seed, noise.poisson, up, side)
    # priced by the path taken, once the points are sorted into blocks
    plan = plan_points(setup, pos, nrm, method)
    check_work(plan.operations, what, hint, param="mni", mentions=("points", "mni"))
    out = evaluate_points(p, setup, pos, nrm, tan, device, plan=plan)
    return np.ascontiguousarray(out[:, : texton.channels])


def evaluate_points(p: surface_points.SurfaceParams, setup: SurfaceSetup, pos: np.ndarray, nrm: np.ndarray, tan, device,
                    method: str = "auto", *, plan: PointsPlan | None = None) -> np.ndarray:
    """(N, 3) float32 surface noise, (N, 1) for a one-channel texton, at checked float64 texel positions with unit
    normals (and unit tangents, or None for the frame rule), by ``plan`` (the caller's
    :func:`plan_points`, priced) or else by ``method``, mapped through the texton's
    histogram transform when it has one: every surface output (points, meshes, bakes,
    renders) gets its values here."""
    if isinstance(setup, TilingSetup):  # a tiling model: the triplanar projection
        return tiling_values(p, pos, nrm, device)
    values = _surface_values(p, setup, pos, nrm, tan, device, method, plan)
    to_colours(values, setup.texton)
    return values


def surface_lanes(setup: SurfaceSetup) -> int:
    """Floats the kernels carry a texel and a value: 1 for a one-channel (grey) texton, else 3."""
    return 1 if setup.texton is not None and setup.texton.channels == 1 else 3


def surface_coeffs(setup: SurfaceSetup) -> wp.array:
    """The padded coefficients as the kernels read them, on the current device: float
    for a one-channel texton (one float a texel), vec3 otherwise."""
    if surface_lanes(setup) == 1:
        return wp.array(np.ascontiguousarray(setup.coeffs[..., 0]), dtype=wp.float32)
    return wp.array(setup.coeffs, dtype=wp.vec3)


def _surface_values(p: surface_points.SurfaceParams, setup: SurfaceSetup, pos: np.ndarray, nrm: np.ndarray, tan, device,
                    method: str, plan: PointsPlan | None) -> np.ndarray:
    n = pos.shape[0]
    lanes = surface_lanes(setup)
    if n == 0:
        return np.zeros((0, lanes), np.float32)
    if plan is None:
        plan = plan_points(setup, pos, nrm, method)
    method, blocked = plan.method, plan.blocked
    with wp.ScopedDevice(device):
        coeffs = surface_coeffs(setup)
        if method == "points":
            dummy = wp.zeros(1, dtype=wp.vec3)

            def values(start, stop):
                res = wp.zeros(stop - start, dtype=coeffs.dtype)
                tarr = wp.array(tan[start:stop], dtype=wp.vec3) if tan is not None else dummy
                wp.launch(surface_points.evaluate_surface, dim=stop - start,
                          inputs=[p, coeffs, wp.array(pos[start:stop], dtype=wp.vec3d),
                                  wp.array(nrm[start:stop], dtype=wp.vec3), tarr, int(tan is not None), res])
                out[start:stop] = res.numpy().reshape(stop - start, lanes)

            out = np.zeros((n, lanes), np.float32)
            split_launch(device, surface_points, n, values)
            return out
        return gather_blocks(p, coeffs, pos, nrm, tan, device, reach=walk_reach(setup.r),
                             mean_count=setup.lam * setup.cell ** 3, sorted_points=blocked)
