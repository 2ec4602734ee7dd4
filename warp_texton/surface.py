"""Surface texton noise on meshes without UVs (CGF §6): points, vertex colours, renders.

At a surface point y with unit normal n and tangent frame (u1, u2), the noise
projects the impacts of a 3-D Poisson process of intensity λ that lie within
r/2 of the tangent plane, weighted by (1 − 2|⟨y − x, n⟩|/r)⁺:

    f(y) = Σ_i (1 − 2|⟨y − x_i, n⟩|/r)⁺ h(⟨y − x_i, u1⟩, ⟨y − x_i, u2⟩)
    g(y) = m + (f − λ (r/2) ∫h) / √(λ r/3)          (CGF Prop. 3)

so g has the texton's mean and variance on any surface. r is the larger side
of the texton's support and MNI = λ r · area(supp h) (λ r³ for a square
support). Frames follow one rule (see :func:`tangent_frames`) unless given.

Points are evaluated in blocks: sorted by the block of cubes they lie in, each
block's cubes draw their impacts once and every point of the block gathers
them, in the order a lone point would walk them (``method="points"``, the
reference), so both give the same values. Cube indices come from float64
positions, so the noise is as exact far from the origin as near it.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
import warp as wp

from ._checks import as_real_array, check_int, check_positive, check_seed, check_shape
from ._runtime import CHUNKS_PER_THREAD, cpu_threads, map_points, resolve_device, split_launch
from .errors import TextonError
from .limits import check_memory
from .kernels import surface as K
from .kernels.impacts import Cells3
from .noise import MAX_CELL_INDEX, MAX_CELL_MEAN, POISSON_MODES, noise_setup
from .texton import Texton

#: Default cell side relative to the slab thickness r.
CELL_FACTOR = 0.6
#: The frame rule's directions: u1 follows `up` projected on the tangent plane,
#: blended towards `side` where the normal is close to `up`.
UP = (0.0, 0.0, 1.0)
SIDE = (1.0, 0.0, 0.0)
MAX_RENDER_PIXELS = 1 << 26
#: Refuse cube grids where one point must visit more cubes than this (a tiny cell_factor).
MAX_CUBES_PER_POINT = 8192
#: Default texture scale on a mesh: this many texels along its bounding-box diagonal.
TEXELS_PER_DIAGONAL = 256
#: Evaluation paths: "blocks" (points share their cubes' impacts), "points"
#: (each point draws the impacts of its cubes itself: the reference) and "auto"
#: (the walk below AUTO_MIN_POINTS points, where sorting and the extra launches
#: cost more than they save — measured: 642 points, walk 14 ms, blocks 20 ms;
#: 10 000 sparse points, blocks 1.4× faster — else blocks). All give the same values.
METHODS = ("auto", "blocks", "points")
AUTO_MIN_POINTS = 4096
#: Points are grouped by blocks of BLOCK_CUBES = 2**BLOCK_SHIFT cubes per side.
BLOCK_SHIFT = 2
BLOCK_CUBES = 1 << BLOCK_SHIFT
#: Cubes drawn per round of the block path (bounds its impact buffer).
CUBES_PER_ROUND = 1 << 20
#: Points of a block that share a cell of side cube / 2**(3 − CLUSTER_LEVEL) (a half
#: cube: measured fastest on dense and sparse meshes, see docs/benchmarks.md) are
#: taken in clusters of at most CLUSTER_POINTS, which list the impacts that may
#: reach them once (in runs of one cube each); clusters of fewer than CLUSTER_MIN
#: points, or whose list would pass CLUSTER_CAP impacts or CLUSTER_RUNS cubes, walk
#: the block's cubes instead. At most
#: CLUSTERS_PER_ROUND lists exist at once.
CLUSTER_POINTS = 16
CLUSTER_MIN = 4
CLUSTER_RUNS = 128
CLUSTER_LEVEL = 2
CLUSTER_CAP = 1024
CLUSTERS_PER_ROUND = 1 << 12
#: Use the vector loops of kernels/surface_native.py where the CPU has AVX2, AVX-512
#: or NEON (the same values as their scalar form; tests switch it off to check that form).
SIMD = True
#: Names ``up`` takes besides a 3-vector: the world axis that points up.
UP_NAMES = ("x", "y", "z")
#: Default view of renders: azimuth and elevation (degrees) of the camera seen from
#: the mesh's centre, in the Z-up frame (azimuth 0 along +X, −90 along −Y: the front).
VIEW = (-55.0, 25.0)
#: Default light direction in the Z-up frame (towards the light).
LIGHT = (0.4, -0.5, 1.0)


def default_texel_size(mesh) -> float:
    """World units per texel when none is given: the bounding-box diagonal /
    TEXELS_PER_DIAGONAL (1 for a mesh of zero extent)."""
    lo, hi = np.asarray(mesh.bounds, dtype=np.float64)
    return float(np.linalg.norm(hi - lo)) / TEXELS_PER_DIAGONAL or 1.0


def _points(a, name: str) -> np.ndarray:
    try:
        arr = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError):
        raise TextonError(f"{name} must be an array of shape (N, 3) of numbers") from None
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise TextonError(f"{name} must have shape (N, 3), got {arr.shape}")
    if not np.isfinite(arr).all():
        raise TextonError(f"{name} contain {int((~np.isfinite(arr)).sum())} NaN or infinite values")
    return arr


def _prepare_points(pts: np.ndarray, normals: np.ndarray, texel: float) -> tuple[np.ndarray, np.ndarray]:
    """(pts / texel, float32 unit normals) from finite (N, 3) float64 arrays, in a CPU
    kernel: the values of ``pts / texel`` and ``_unit_rows(normals)`` in one pass."""
    n = len(pts)
    pos = np.empty((n, 3))
    unit = np.empty((n, 3), np.float32)
    length = np.empty(n)
    inputs = [wp.array(np.ascontiguousarray(pts), dtype=wp.vec3d, device="cpu", copy=False),
              wp.array(np.ascontiguousarray(normals), dtype=wp.vec3d, device="cpu", copy=False)]
    outputs = [wp.array(a, dtype=t, device="cpu", copy=False)
               for a, t in ((pos, wp.vec3d), (unit, wp.vec3), (length, wp.float64))]
    split_launch("cpu", K, n, lambda a, b: wp.launch(
        K.prepare_points, dim=b - a, device="cpu",
        inputs=[*(x[a:b] for x in inputs), wp.float64(texel), *(y[a:b] for y in outputs)]))
    _check_lengths(length, "normals")
    return pos, unit


def _check_lengths(length: np.ndarray, name: str) -> None:
    """Refuse rows of zero length (``name`` is a plural: "normals")."""
    bad = np.flatnonzero(length < 1e-12)
    if bad.size:
        raise TextonError(f"{name}[{bad[0]}] has zero length ({bad.size} such rows); every {name[:-1]} must be non-zero")


def _unit_rows(v: np.ndarray, name: str) -> np.ndarray:
    # np.linalg.norm(v, axis=1), bit for bit (the same sums in the same order), faster
    length = np.sqrt(v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1] + v[:, 2] * v[:, 2])
    _check_lengths(length, name)
    return v / length[:, None]


def _point(v, name: str) -> np.ndarray:
    """A finite 3-vector of numbers."""
    p = as_real_array(v, name, "a point (x, y, z) of numbers").reshape(-1)
    if p.shape != (3,) or not np.isfinite(p).all():
        raise TextonError(f"{name} must be a point (x, y, z) of finite numbers, got {v!r:.60}")
    return p


def _direction(v, name: str) -> np.ndarray:
    """A unit 3-vector from a non-zero triple of finite numbers (strings are not numbers)."""
    try:
        d = as_real_array(v, name, "a non-zero 3-vector").reshape(-1)
    except TextonError:
        raise TextonError(f"{name} must be a non-zero 3-vector of numbers, got {v!r:.60}") from None
    if d.shape != (3,) or not np.isfinite(d).all() or np.linalg.norm(d) < 1e-12:
        raise TextonError(f"{name} must be a non-zero 3-vector, got {v!r:.60}")
    return d / np.linalg.norm(d)


def tangent_frames(normals, up=UP, side=None) -> tuple[np.ndarray, np.ndarray]:
    """The frame rule used when no tangents are given: returns (u1, u2).

    u1 is the direction of v(n) = P_n(up) + ⟨up, n⟩⁴ P_n(side), with P_n the
    projection on the plane orthogonal to n, and u2 = n × u1. v is continuous
    in n and vanishes only at isolated normals (where it does, P_n(side) stands
    in), so frames vary continuously wherever the normals do, except at those
    isolated points — which any rule must have on a closed surface. On a plane
    facing ``up`` the frame is (side, up × side); on walls u1 points ``up``.
    The kernels implement the same rule (kernels/surface.py:tangent_frame).
    """
    n = _unit_rows(_points(normals, "normals"), "normals")
    a, b = frame_rule(up, side)
    ca = n @ a
    v = (a - n * ca[:, None]) + (b - n * (n @ b)[:, None]) * (ca ** 4)[:, None]
    small = np.linalg.norm(v, axis=1) < 1e-6
    if small.any():
        v[small] = b - n[small] * (n[small] @ b)[:, None]
        still = np.linalg.norm(v, axis=1) < 1e-6
        v[still] = np.cross(n[still], a)
    u1 = v / np.linalg.norm(v, axis=1)[:, None]
    return u1, np.cross(n, u1)


def up_vector(up) -> np.ndarray:
    """``up`` as a unit 3-vector: "x", "y", "z" name a world axis; a 3-vector is normalised."""
    if isinstance(up, str):
        name = up.lower()
        if name not in UP_NAMES:
            raise TextonError(f"up must be one of x, y, z or a 3-vector, got {up!r}")
        return np.eye(3)[UP_NAMES.index(name)]
    return _direction(up, "up")


def up_rotation(up) -> np.ndarray:
    """The rotation R (world = R · z-up frame) that takes the Z-up frame of the
    defaults (frame rule, view, light) to a world whose up is ``up``.

    R's columns are (b, a × b, a): a = ``up``, b = the x axis made orthogonal to
    a (the y axis when a is along x). So "z" is the identity and "y" is glTF's
    frame (+Z, the front, is the Z-up frame's −Y; +X stays to the right).

    >>> up_rotation("y").astype(int).tolist()
    [[1, 0, 0], [0, 0, 1], [0, -1, 0]]
    """
    a = up_vector(up)
    b = np.array([1.0, 0.0, 0.0]) - a * a[0]
    if np.linalg.norm(b) < 1e-3:
        b = np.array([0.0, 1.0, 0.0]) - a * a[1]
    b /= np.linalg.norm(b)
    return np.stack([b, np.cross(a, b), a], axis=1)


def frame_rule(up, side=None) -> tuple[np.ndarray, np.ndarray]:
    """(up, side) vectors of the frame rule: ``side`` defaults to the world's
    "right" for this up axis (x, or y when up is along x)."""
    if side is None:
        r = up_rotation(up)
        return r[:, 2].copy(), r[:, 0].copy()
    return up_vector(up), _direction(side, "side")


def view_direction(view, up=UP) -> np.ndarray:
    """Unit vector from a mesh's centre towards the camera for ``view`` =
    (azimuth, elevation) in degrees: azimuth about the up axis from the world's
    right (x), −90 looking at the front; elevation above the horizon."""
    try:
        az, el = as_real_array(view, "view", "a pair (azimuth, elevation) of numbers, in degrees").tolist()
    except (TypeError, ValueError):
        raise TextonError(f"view must be a pair (azimuth, elevation) in degrees, got {view!r:.60}") from None
    if not (math.isfinite(az) and math.isfinite(el)) or abs(el) >= 90.0:
        raise TextonError(f"view elevation must be finite and strictly between -90 and 90 degrees, got {view!r}")
    a, e = math.radians(az), math.radians(el)
    return up_rotation(up) @ np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])


@dataclass(frozen=True)
class SurfaceSetup:
    r: float
    lam: float
    cell: float
    coeffs: np.ndarray
    lo: tuple[float, float]  # texton support box, texton coordinates
    hi: tuple[float, float]


def surface_setup(texton: Texton, mni: float, cell_factor: float = CELL_FACTOR) -> SurfaceSetup:
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
    return SurfaceSetup(r, lam, cell, base.coeffs, base.lo, base.hi)


def surface_params(texton: Texton, setup: SurfaceSetup, seed: int, poisson: str, up, side) -> K.SurfaceParams:
    """The kernels' ``SurfaceParams`` (CGF Prop. 3 normalisation, the frame rule's directions)."""
    if poisson not in POISSON_MODES:
        raise TextonError(f"poisson must be one of {', '.join(POISSON_MODES)}, got {poisson!r}")
    cells = Cells3()
    cells.size = setup.cell
    cells.mean_count = setup.lam * setup.cell ** 3
    cells.seed = wp.uint32(seed)
    cells.exact_poisson = 1 if poisson == "exact" else 0
    p = K.SurfaceParams()
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
    a, b = frame_rule(up, side)
    p.up = wp.vec3(*a)
    p.side = wp.vec3(*b)
    return p


def check_reach(pos: np.ndarray, setup: SurfaceSetup, what: str) -> None:
    """Refuse positions (texel units, float64) whose cubes would not fit the
    kernels' int32 cube indices, or that overflowed (a tiny texel_size)."""
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


def check_method(method: str) -> str:
    if method not in METHODS:
        raise TextonError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    return method


def surface_noise(
    texton: Texton,
    points,
    normals,
    texel_size: float,
    mni: float = 60.0,
    seed: int = 0,
    tangents=None,
    device=None,
    *,
    up=UP,
    side=None,
    poisson: str = "exact",
    cell_factor: float = CELL_FACTOR,
    method: str = "auto",
) -> np.ndarray:
    """Surface texton noise at points of a surface (CGF §6, Prop. 3).

    Parameters
    ----------
    texton : Texton
    points : array (N, 3)
        Surface points in world units.
    normals : array (N, 3)
        Surface normals (need not be unit; zero rows are refused).
    texel_size : float
        World units per texel: the texture's scale on the surface.
    mni : float
        Mean number of impacts per point, λ r · area(supp h); 60 by default
        (the slab weighting needs more impacts than the plane, CGF §6).
    seed : int
    tangents : array (N, 3), optional
        First tangent direction u1 per point (projected on the tangent plane
        and normalised); by default the rule of :func:`tangent_frames`.
    device : str, optional
    up, side : 3-vectors
        Directions of the frame rule.
    poisson, cell_factor
        As in :func:`warp_texton.synthesize`.
    method : str
        ``"blocks"``: points sorted into blocks share the impacts of their
        cubes; ``"points"``: each point draws its cubes' impacts itself (the
        reference: same values, slower on many points); ``"auto"`` (default):
        the walk below 4096 points, blocks above.

    Returns
    -------
    float32 array (N, C)

    References
    ----------
    CGF §6, Proposition 3 (the slab weight and the normalisation).

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
    """
    if not isinstance(texton, Texton):
        raise TextonError(f"texton must be a Texton, got {type(texton).__name__}")
    pts = _points(points, "points")
    raw = _points(normals, "normals")
    if raw.shape != pts.shape:
        raise TextonError(f"normals has shape {raw.shape}; it must match points {pts.shape}")
    texel = check_positive(texel_size, "texel_size")
    seed = check_seed(seed)
    check_method(method)
    setup = surface_setup(texton, mni, cell_factor)
    if tangents is None:
        # positions in texels and float32 unit normals in one CPU pass (the values of
        # texel_positions and _unit_rows), then their checks
        pos, nrm = _prepare_points(pts, raw, texel)
        check_reach(pos, setup, "points")
        tan = None
    else:
        nrm = _unit_rows(raw, "normals")
        tan = _points(tangents, "tangents")
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
    device = resolve_device(device)
    p = surface_params(texton, setup, seed, poisson, up, side)
    out = evaluate_points(p, setup, pos, nrm, tan, device, method)
    return np.ascontiguousarray(out[:, : texton.channels])


def evaluate_points(p: K.SurfaceParams, setup: SurfaceSetup, pos: np.ndarray, nrm: np.ndarray, tan, device,
                    method: str = "auto") -> np.ndarray:
    """(N, 3) float32 surface noise at checked float64 texel positions with unit
    normals (and unit tangents, or None for the frame rule)."""
    n = pos.shape[0]
    if n == 0:
        return np.zeros((0, 3), np.float32)
    if method == "auto":
        method = "points" if n < AUTO_MIN_POINTS else "blocks"
    with wp.ScopedDevice(device):
        coeffs = wp.array(setup.coeffs, dtype=wp.vec3)
        if method == "points":
            dummy = wp.zeros(1, dtype=wp.vec3)

            def values(start, stop):
                res = wp.zeros(stop - start, dtype=wp.vec3)
                tarr = wp.array(tan[start:stop], dtype=wp.vec3) if tan is not None else dummy
                wp.launch(K.evaluate_surface, dim=stop - start,
                          inputs=[p, coeffs, wp.array(pos[start:stop], dtype=wp.vec3d),
                                  wp.array(nrm[start:stop], dtype=wp.vec3), tarr, int(tan is not None), res])
                return res.numpy()

            return map_points(device, K, n, values)
        return gather_blocks(p, setup, coeffs, pos, nrm, tan, device)


#: x ↦ x with two zero bits after each of its 5 bits (Morton codes of 32 steps per axis)
_SPREAD = np.array([sum(((x >> b) & 1) << (3 * b) for b in range(5)) for x in range(8 * BLOCK_CUBES)], np.int64)


def _blocks(pos: np.ndarray, nrm: np.ndarray, setup: SurfaceSetup):
    """Points sorted into blocks of BLOCK_CUBES³ cubes: (order, sorted positions, sorted
    float32 normals, starts, lo, hi, clusters), with lo/hi the first and last cube (per
    axis) that the points of each block can reach and clusters the first point of each
    cluster (sorted order)."""
    c = setup.cell
    scale = 8.0 / c
    shift = 3 + BLOCK_SHIFT
    pos = np.ascontiguousarray(pos, dtype=np.float64)
    points = wp.array(pos, dtype=wp.vec3d, device="cpu", copy=False)
    # the eighth of a cube each point lies in, floor(y · 8 / c) (any rounding will do:
    # a sort key); its block of BLOCK_CUBES = 2**BLOCK_SHIFT cubes of 8 eighths per side,
    # numbered from the blocks of the smallest coordinates (floor and the product are
    # monotone: the smallest eighth is that of the smallest coordinate); within a block
    # the Morton order of the eighths, so that consecutive points are neighbours
    lo_fine = [int(math.floor(float(pos[:, k].min()) * scale)) for k in range(3)]
    hi_fine = [int(math.floor(float(pos[:, k].max()) * scale)) for k in range(3)]
    own_min = [f >> shift for f in lo_fine]
    span = [(hi >> shift) - o + 1 for hi, o in zip(hi_fine, own_min)]
    if float(span[0]) * float(span[1]) * float(span[2]) < 2.0**46:
        # the keys in a CPU kernel (several times faster than NumPy on (N, 3) arrays)
        keys = wp.empty(len(pos), dtype=wp.int64, device="cpu")
        spread = wp.array(_SPREAD, dtype=wp.int64, device="cpu")
        split_launch("cpu", K, len(pos), lambda a, b: wp.launch(
            K.block_keys, dim=b - a, device="cpu",
            inputs=[points[a:b], wp.float64(scale), wp.int64(shift), *(wp.int64(o) for o in own_min),
                    wp.int64(span[0]), wp.int64(span[1]), spread, keys[a:b]]))
        key = keys.numpy()
        order = np.argsort(key, kind="stable")
        key = key[order]
        block = key >> 15
    else:  # blocks spread over more than int64 keys hold
        fine = [np.floor(pos[:, k] * scale).astype(np.int64) for k in range(3)]
        own = [(f >> shift) - o for f, o in zip(fine, own_min)]
        morton = _SPREAD[fine[0] & (8 * BLOCK_CUBES - 1)] | (_SPREAD[fine[1] & (8 * BLOCK_CUBES - 1)] << 1) | \
            (_SPREAD[fine[2] & (8 * BLOCK_CUBES - 1)] << 2)
        order = np.lexsort((morton, own[0], own[1], own[2]))
        o = np.stack(own, axis=1)[order]
        block = np.cumsum(np.r_[0, np.any(o[1:] != o[:-1], axis=1)])
        key = (block << 15) | morton[order]
    new_block = np.r_[True, block[1:] != block[:-1]]
    starts = np.flatnonzero(new_block)
    # frame_extent ≤ (r/2)√3 per axis (a row of an orthogonal matrix has unit length),
    # with room for float32 rounding: every cube a point's walk visits is in its block.
    # floor((min p − R)/c) = min floor((p − R)/c): floor and rounding are monotone.
    reach = setup.r / 2.0 * math.sqrt(3.0) * (1.0 + 1e-5)
    ps = np.empty_like(pos)
    ns = np.empty((len(pos), 3), np.float32)
    wp_order = wp.array(order, dtype=wp.int64, device="cpu", copy=False)
    normals = wp.array(np.ascontiguousarray(nrm, dtype=np.float32), dtype=wp.vec3, device="cpu", copy=False)
    wp_ps = wp.array(ps, dtype=wp.vec3d, device="cpu", copy=False)
    wp_ns = wp.array(ns, dtype=wp.vec3, device="cpu", copy=False)
    split_launch("cpu", K, len(pos), lambda a, b: wp.launch(
        K.take_points, dim=b - a, device="cpu", inputs=[wp_order[a:b], points, normals, wp_ps[a:b], wp_ns[a:b]]))
    lo = np.floor((np.minimum.reduceat(ps, starts, axis=0) - reach) / c).astype(np.int64)
    hi = np.floor((np.maximum.reduceat(ps, starts, axis=0) + reach) / c).astype(np.int64)
    # clusters: runs of points in the same cluster cell, cut every CLUSTER_POINTS
    cell = key >> (3 * CLUSTER_LEVEL)
    first = np.r_[True, cell[1:] != cell[:-1]] | new_block
    run = np.cumsum(first) - 1
    rank = np.arange(len(order)) - np.flatnonzero(first)[run]
    clusters = np.flatnonzero(first | (rank % CLUSTER_POINTS == 0))
    return order, ps, ns, starts, lo, hi, clusters


def gather_blocks(p, setup: SurfaceSetup, coeffs, pos, nrm, tan, device) -> np.ndarray:
    """The block path of :func:`evaluate_points`: sort, draw each block's cubes once, list
    each cluster's impacts, gather (docs/model.md, "Blocks of points")."""
    n = pos.shape[0]
    order, sorted_pos, sorted_nrm, starts, lo, hi, clusters = _blocks(pos, nrm, setup)
    dims = hi - lo + 1
    cubes = np.prod(dims, axis=1)
    mean_count = setup.lam * setup.cell ** 3
    # the peak: the sorted copies of the points and their frames, one round's cubes and
    # impacts (at most CUBES_PER_ROUND cubes, or one block), and the cluster lists
    round_cubes = min(float(cubes.sum()), max(float(CUBES_PER_ROUND), float(cubes.max())))
    # the CPU lists and gathers each cluster in turn (order-1 textons), in a one-slot
    # scratch per launch; otherwise the clusters of a round are listed at once
    on_cpu = wp.get_device(device).is_cpu
    by_cluster = on_cpu and p.order == 1
    slots = CHUNKS_PER_THREAD * cpu_threads() if by_cluster else min(len(clusters), CLUSTERS_PER_ROUND)
    list_bytes = slots * (12.0 * CLUSTER_CAP + 8.0 * CLUSTER_RUNS + 12.0)
    check_memory(round_cubes * (24 + 12 * (mean_count + 10 * math.sqrt(mean_count) + 1)) + list_bytes + n * 160.0,
                 f"surface noise at {n} points", "evaluate fewer points at once")
    ends = np.r_[starts[1:], n]
    sorted_tan = np.take(tan, order, axis=0).astype(np.float32) if tan is not None else None
    # values go straight to the points' own rows (dest = order), in place on the CPU
    out = np.empty((n, 3), np.float32)
    res = wp.array(out, dtype=wp.vec3, copy=False) if on_cpu else wp.empty(n, dtype=wp.vec3)
    lists = None if by_cluster else _ClusterLists(min(len(clusters), CLUSTERS_PER_ROUND))
    b0 = 0
    nb = len(starts)
    cum = np.cumsum(cubes)
    while b0 < nb:
        before = cum[b0 - 1] if b0 else 0
        b1 = max(b0 + 1, int(np.searchsorted(cum, before + CUBES_PER_ROUND, side="right")))
        _gather_round(p, coeffs, sorted_pos, sorted_nrm, sorted_tan, device, starts[b0:b1], ends[b0:b1], clusters,
                      lo[b0:b1], dims[b0:b1], cubes[b0:b1], lists, res, order, by_cluster)
        b0 = b1
    return out if on_cpu else res.numpy()


class _ClusterLists:
    """Room for the impact lists of ``size`` clusters (``K.Clusters`` without ``first``),
    allocated once per call and reused by every round."""

    def __init__(self, size: int):
        cl = K.Clusters()
        cl.cap = CLUSTER_CAP
        cl.cap_runs = CLUSTER_RUNS
        cl.first = wp.empty(1, dtype=wp.int32)  # set per round
        cl.runs = wp.empty(size, dtype=wp.int32)
        cl.run_cube = wp.empty(size * CLUSTER_RUNS, dtype=wp.int32)
        cl.run_end = wp.empty(size * CLUSTER_RUNS, dtype=wp.int32)
        cl.ux = wp.empty(size * CLUSTER_CAP, dtype=wp.float32)
        cl.uy = wp.empty(size * CLUSTER_CAP, dtype=wp.float32)
        cl.uz = wp.empty(size * CLUSTER_CAP, dtype=wp.float32)
        self.clusters = cl


def _gather_round(p, coeffs, pos, nrm, tan, device, starts, ends, clusters, lo, dims, cubes, lists, res, order,
                  by_cluster: bool) -> None:
    nb = len(starts)
    base = np.zeros(nb, np.int64)
    base[1:] = np.cumsum(cubes)[:-1]
    total = int(cubes.sum())
    owner = np.repeat(np.arange(nb), cubes)
    local = np.arange(total, dtype=np.int64) - base[owner]
    d = dims[owner]
    coords = lo[owner] + np.stack([local % d[:, 0], (local // d[:, 0]) % d[:, 1], local // (d[:, 0] * d[:, 1])],
                                  axis=1)
    p0, p1 = int(starts[0]), int(ends[-1])
    block_of = np.repeat(np.arange(nb, dtype=np.int32), ends - starts)
    cube_arr = wp.array(coords.astype(np.int32), dtype=wp.vec3i)
    counts = wp.empty(total + 1, dtype=wp.int32)
    split_launch(device, K, total, lambda a, b: wp.launch(K.count_cubes, dim=b - a,
                                                          inputs=[p, cube_arr[a:b], counts[a:b]]))
    offsets = wp.empty(total + 1, dtype=wp.int32)
    wp.utils.array_scan(counts, offsets, inclusive=False)
    n_impacts = int(offsets[total:total + 1].numpy()[0])
    blocks = K.CubeBlocks()
    blocks.cubes = cube_arr
    blocks.origin = wp.array(lo.astype(np.int32), dtype=wp.vec3i)
    blocks.dims = wp.array(dims.astype(np.int32), dtype=wp.vec3i)
    blocks.base = wp.array(base.astype(np.int32), dtype=wp.int32)
    blocks.offsets = offsets
    blocks.ux, blocks.uy, blocks.uz = (wp.empty(max(n_impacts, 1), dtype=wp.float32) for _ in range(3))
    if n_impacts:
        split_launch(device, K, total, lambda a, b: wp.launch(
            K.emit_cubes, dim=b - a, inputs=[p, cube_arr[a:b], offsets[a:], blocks.ux, blocks.uy, blocks.uz]))
    m = p1 - p0
    on_cpu = wp.get_device(device).is_cpu
    # the CPU reads the sorted copies in place (contiguous rows of float64 / float32)
    pts = wp.array(pos[p0:p1], dtype=wp.vec3d, copy=not on_cpu)
    nrms = wp.array(nrm[p0:p1], dtype=wp.vec3, copy=not on_cpu)
    tans = wp.array(tan[p0:p1], dtype=wp.vec3, copy=not on_cpu) if tan is not None else wp.zeros(1, dtype=wp.vec3)
    owners = wp.array(block_of, dtype=wp.int32)
    frames = K.PointFrames()
    frames.u1, frames.u2 = wp.empty(m, dtype=wp.vec3), wp.empty(m, dtype=wp.vec3)
    frames.lo, frames.hi = wp.empty(m, dtype=wp.vec3i), wp.empty(m, dtype=wp.vec3i)

    def frame(a, b):
        sub = K.PointFrames()
        sub.u1, sub.u2, sub.lo, sub.hi = frames.u1[a:b], frames.u2[a:b], frames.lo[a:b], frames.hi[a:b]
        wp.launch(K.frame_points, dim=b - a, inputs=[p, pts[a:b], nrms[a:b], tans[a:b] if tan is not None else tans,
                                                     int(tan is not None), sub])

    if not by_cluster:  # gather_cluster_lists frames its own points
        split_launch(device, K, m, frame)
    dest = wp.array(order[p0:p1], dtype=wp.int64, copy=not on_cpu)
    # one thread per cluster on the CPU (cluster_sums: SIMD over its points) for
    # order-1 textons; one per point elsewhere (the GPU, and other orders)
    simd = int(bool(SIMD))
    # the round's clusters (a cluster never straddles blocks: block starts are cluster starts)
    mine = clusters[(clusters >= p0) & (clusters < p1)]
    cfirst = np.r_[mine - p0, m].astype(np.int32)
    cluster_of = None if by_cluster else wp.array(np.repeat(np.arange(len(mine), dtype=np.int32), np.diff(cfirst)),
                                                  dtype=wp.int32)
    if by_cluster:
        first = wp.array(cfirst, dtype=wp.int32)

        def gather(a, b):
            wp.launch(K.gather_cluster_lists, dim=b - a, inputs=[p, coeffs, pts, nrms, tans, int(tan is not None),
                                                                 frames, owners, blocks, first,
                                                                 _ClusterLists(1).clusters, a, CLUSTER_MIN, simd, res,
                                                                 dest])

        split_launch(device, K, len(mine), gather)
    else:
        cl = lists.clusters
        for m0 in range(0, len(mine), CLUSTERS_PER_ROUND):
            m1 = min(m0 + CLUSTERS_PER_ROUND, len(mine))
            cl.first = wp.array(cfirst[m0:m1 + 1], dtype=wp.int32)
            split_launch(device, K, m1 - m0, lambda a, b: wp.launch(
                K.list_cluster_impacts, dim=b - a, inputs=[p, pts, nrms, frames, owners, blocks, cl, a, CLUSTER_MIN,
                                                           simd]))
            k0, k1 = int(cfirst[m0]), int(cfirst[m1])
            split_launch(device, K, k1 - k0, lambda a, b, m0=m0, k0=k0: wp.launch(
                K.gather_clustered, dim=b - a, inputs=[p, coeffs, pts, nrms, frames, owners, blocks, cluster_of, cl,
                                                       m0, a + k0, res, dest]))


def simd_loops(device="cpu") -> str:
    """The form of the block path's CPU loops (kernels/surface_native.py) that runs:
    "avx512", "avx2" or "neon" where their vector form was compiled for that
    instruction set, "scalar" otherwise (other CPUs, CUDA, or ``SIMD`` off): all
    give the same values; benchmarks report which ran."""
    device = resolve_device(device)
    if not wp.get_device(device).is_cpu or not SIMD:
        return "scalar"
    with wp.ScopedDevice(device):
        flag = wp.zeros(1, dtype=wp.int32)
        wp.launch(K.simd_probe, dim=1, inputs=[flag])
        return ("scalar", "neon", "avx2", "avx512")[int(flag.numpy()[0])]


def check_mesh(mesh):
    import trimesh

    if not isinstance(mesh, trimesh.Trimesh):
        raise TextonError(f"mesh must be a trimesh.Trimesh, got {type(mesh).__name__}")
    if len(mesh.faces) == 0 or len(mesh.vertices) == 0:
        raise TextonError("mesh is empty: it has no triangles")
    v = np.asarray(mesh.vertices, dtype=np.float64)
    if not np.isfinite(v).all():
        raise TextonError("mesh has NaN or infinite vertex coordinates")
    f = np.asarray(mesh.faces)
    if f.min() < 0 or f.max() >= len(v):
        raise TextonError("mesh faces index vertices that do not exist")
    return mesh


def vertex_normals(mesh, up=UP) -> np.ndarray:
    """Unit vertex normals from trimesh (face normals averaged, weighted by the
    corner angles). Vertices that touch only zero-area faces, or none, have no
    normal: they take ``up``, so that every vertex gets a defined colour."""
    n = np.asarray(mesh.vertex_normals, dtype=np.float64).copy()
    length = np.linalg.norm(n, axis=1)
    bad = ~np.isfinite(length) | (length < 1e-12)
    n[bad] = up_vector(up)
    return n / np.linalg.norm(n, axis=1)[:, None]


def srgb_to_linear(v) -> np.ndarray:
    """The sRGB decoding (IEC 61966-2-1) of values in [0, 1]: what glTF's linear
    ``COLOR_0`` holds for a colour an image stores as ``v``.

    >>> srgb_to_linear([0.0, 0.5, 1.0]).round(4).tolist()
    [0.0, 0.214, 1.0]
    """
    v = np.asarray(v, dtype=np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(v) -> np.ndarray:
    """The sRGB encoding, inverse of :func:`srgb_to_linear`."""
    v = np.clip(np.asarray(v, dtype=np.float64), 0.0, None)
    return np.where(v <= 0.0031308, v * 12.92, 1.055 * v ** (1 / 2.4) - 0.055)


def vertex_spacing(mesh, texel_size: float) -> float:
    """The median edge length of ``mesh`` in texels: how far apart vertex colours are."""
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    if len(f) == 0:
        return 0.0
    return float(np.median(np.linalg.norm(v[f[:, [1, 2, 0]]] - v[f], axis=2))) / texel_size


def texture_mesh(
    mesh,
    texton: Texton,
    texel_size: float,
    mni: float = 60.0,
    seed: int = 0,
    max_edge: float | None = None,
    *,
    device=None,
    up=UP,
    side=None,
    max_faces: int = 5_000_000,
    linear: bool = False,
    name: str = "mesh",
    warn: bool = True,
):
    """A copy of ``mesh`` with per-vertex colours from surface texton noise.

    Vertex colours hold one value per vertex, interpolated across faces: they
    show the texture only where vertices are at most about a texel apart. When
    the median edge is longer than a texel, a warning names the mesh and the
    spacing and suggests a baked texture (:func:`warp_texton.bake_mesh`) or
    ``max_edge``.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    texton : Texton
    texel_size : float
        World units per texel.
    mni, seed
        As in :func:`surface_noise`.
    max_edge : float, optional
        First subdivide the mesh until no edge is longer than ``max_edge``
        texels, so that vertex colours resolve the noise (≈ 1 texel).
    max_faces : int
        Refuse a subdivision that would exceed this many faces.
    up, side
        The frame rule's directions (``up`` may name an axis: "x", "y", "z").
    linear : bool
        Store linear colours (glTF ``COLOR_0`` is linear by definition) instead
        of the noise's own sRGB-coded values (PLY, OBJ).
    name : str
        How the warning names the mesh (a file name in a batch).
    warn : bool
        Warn about vertices further apart than a texel (a batch reports it itself).

    Returns
    -------
    trimesh.Trimesh with ``visual.vertex_colors`` (RGBA, 8 bits).
    """
    import trimesh

    mesh = check_mesh(mesh)
    texel = check_positive(texel_size, "texel_size")
    max_faces = check_int(max_faces, "max_faces", minimum=1)
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    if not isinstance(texton, Texton):
        raise TextonError(f"texton must be a Texton, got {type(texton).__name__}")
    texel_positions(vertices, texel, surface_setup(texton, mni), "the mesh's vertices")
    if max_edge is not None:
        edge = check_positive(max_edge, "max_edge") * texel
        lengths = np.linalg.norm(vertices[faces[:, [1, 2, 0]]] - vertices[faces], axis=2)
        # trimesh halves edges: a face whose longest edge is L splits 4^k ways, 2^k ≥ L / edge
        halvings = np.ceil(np.log2(np.maximum(lengths.max(axis=1) / edge, 1.0)))
        factor = 4.0 ** halvings  # an upper bound on the faces each face becomes
        total = float(factor.sum())
        if not total <= max_faces:  # inf for an edge far below the mesh's
            count = f"about {total:.0f}" if math.isfinite(total) else "more than can be counted:"
            raise TextonError(
                f"max_edge {max_edge:g} texels would make {count} faces (at most {max_faces}); "
                "use a larger max_edge or texel_size"
            )
        vertices, faces = trimesh.remesh.subdivide_to_size(vertices, faces, max_edge=edge, max_iter=64)
    out = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    spacing = vertex_spacing(out, texel)
    if warn and spacing > 1.0:
        warnings.warn(f"{name}: vertices are {spacing:.3g} texels apart (median edge), so vertex colours blur the "
                      "texture; bake a texture (--bake RES) or subdivide (--max-edge 1)", stacklevel=2)
    colours = surface_noise(texton, vertices, vertex_normals(out, up), texel, mni, seed, device=device, up=up,
                            side=side)
    if colours.shape[1] == 1:
        colours = np.repeat(colours, 3, axis=1)
    colours = np.clip(colours, 0.0, 1.0)
    if linear:
        colours = srgb_to_linear(colours)
    rgba = np.empty((len(vertices), 4), np.uint8)
    rgba[:, :3] = np.round(colours * 255.0)
    rgba[:, 3] = 255
    out.visual.vertex_colors = rgba
    return out


@dataclass(frozen=True)
class Camera:
    """A pinhole camera: ``position`` looks at ``target``; ``fov`` is vertical, degrees.

    Checked when made: finite positions apart from each other, a non-zero ``up``
    not along the view, and a ``fov`` in (0, 180).
    """

    position: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float] = UP
    fov: float = 35.0

    def __post_init__(self):
        fov = check_positive(self.fov, "camera.fov")
        if fov >= 180.0:
            raise TextonError(f"camera.fov must be below 180 degrees, got {fov}")
        eye, target = (_point(v, name) for v, name in ((self.position, "camera.position"),
                                                         (self.target, "camera.target")))
        forward = _direction(target - eye, "camera.target - camera.position")
        up = _direction(self.up, "camera.up")
        if np.linalg.norm(np.cross(forward, up)) < 1e-9:
            raise TextonError("camera.up is parallel to the view direction")
        object.__setattr__(self, "position", tuple(float(v) for v in eye))
        object.__setattr__(self, "target", tuple(float(v) for v in target))
        object.__setattr__(self, "up", tuple(float(v) for v in np.asarray(self.up, np.float64).reshape(3)))
        object.__setattr__(self, "fov", fov)

    @classmethod
    def framing(cls, mesh, direction=None, fov: float = 35.0, up=UP, zoom: float = 1.0, *,
                view=VIEW) -> "Camera":
        """A camera looking at the mesh's bounding-box centre, far enough for its
        bounding sphere to fit the view (``zoom`` > 1 moves closer). It sits along
        ``direction`` from the centre, or at ``view`` = (azimuth, elevation) in
        degrees for this ``up`` axis (see :func:`view_direction`)."""
        lo, hi = np.asarray(mesh.bounds, dtype=np.float64)
        centre = (lo + hi) / 2.0
        radius = max(np.linalg.norm(hi - lo) / 2.0, 1e-9)
        d = view_direction(view, up) if direction is None else _direction(direction, "direction")
        fov = check_positive(fov, "fov")
        if fov >= 180.0:
            raise TextonError(f"fov must be below 180 degrees, got {fov}")
        dist = radius / math.sin(math.radians(fov) / 2.0) * 1.05 / check_positive(zoom, "zoom")
        return cls(tuple(centre + d * dist), tuple(centre), tuple(up_vector(up)), fov)


def check_background(background) -> np.ndarray:
    try:
        bg = np.asarray(background, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise TextonError(f"background must be an RGB triple, got {background!r}") from None
    if not np.isfinite(bg).all():
        raise TextonError(f"background must be finite, got {background!r}")
    return bg


@dataclass(frozen=True)
class RayHits:
    """What each pixel's ray hits (see :func:`cast_rays`).

    face : int32 (H, W), −1 where the ray misses; bary : float64 (H, W, 3), the
    hit's barycentric weights of the face's three corners; normal : float32
    (H, W, 3), the shading normal; shade : float32 (H, W), 0.3 + 0.7 |⟨n, light⟩|.
    """

    face: np.ndarray
    bary: np.ndarray
    normal: np.ndarray
    shade: np.ndarray
    vertices: np.ndarray
    faces: np.ndarray

    @property
    def hit(self) -> np.ndarray:
        return self.face >= 0

    def points(self) -> np.ndarray:
        """(N, 3) float64 world positions of the hits (row-major order of the hit pixels),
        from the face's vertices and the weights: as exact far from the origin as near it."""
        tri = self.faces[self.face[self.hit]]
        b = self.bary[self.hit]
        v = self.vertices
        return b[:, 0:1] * v[tri[:, 0]] + b[:, 1:2] * v[tri[:, 1]] + b[:, 2:3] * v[tri[:, 2]]


def screen_box(rel: np.ndarray, forward, right, cam_up, tan_half_fov: float, aspect: float, h: int, w: int):
    """(r0, r1, c0, c1): the pixels whose rays may hit a mesh with vertices at ``rel``
    from the eye, from the vertices' projections (a triangle in front of the eye
    projects inside the triangle of its projected corners), with a margin of two
    pixels; none when every vertex lies behind the eye's plane (a ray goes forward),
    the whole image when some do."""
    z = rel @ forward
    if rel.shape[0] == 0 or z.max() < 0.0:
        return 0, 0, 0, 0
    if not z.min() > 1e-9 * (float(np.abs(z).max()) + 1e-300):
        return 0, h, 0, w
    sx = (rel @ right) / z / (tan_half_fov * aspect)
    sy = (rel @ cam_up) / z / tan_half_fov
    # pixel centre j sits at sx = 2 (j + 0.5) / w − 1; row i at sy = 1 − 2 (i + 0.5) / h
    cols = (sx + 1.0) * (w / 2.0) - 0.5
    rows = (1.0 - sy) * (h / 2.0) - 0.5
    c0 = int(np.clip(np.floor(cols.min()) - 2, 0, w))
    c1 = int(np.clip(np.ceil(cols.max()) + 3, 0, w))
    r0 = int(np.clip(np.floor(rows.min()) - 2, 0, h))
    r1 = int(np.clip(np.ceil(rows.max()) + 3, 0, h))
    return r0, r1, c0, c1


def cast_rays(mesh, shape, camera: Camera | None = None, *, up=UP, view=None, fov=None, light=None,
              device=None) -> RayHits:
    """Cast one ray per pixel at ``mesh`` (the camera, view, fov, up and light of
    :func:`render_mesh`): the face hit, its barycentric weights, the shading normal
    (interpolated vertex normals, the face normal across creases over 30°) and the
    diffuse shade. The BVH holds the vertices in float32 around the centre of their
    bounding box, so meshes far from the origin are hit as precisely as near ones.
    Only the pixels of the mesh's screen box (:func:`screen_box`) cast rays.

    Returns
    -------
    RayHits
    """
    h, w = check_shape(shape, max_pixels=MAX_RENDER_PIXELS)
    box, (face_b, bary_b, nrm_b, shade_b), vertices, faces = _cast_box(mesh, (h, w), camera, up, view, fov, light,
                                                                       device)
    r0, r1, c0, c1 = box
    face = np.full((h, w), -1, np.int32)
    nrm = np.zeros((h, w, 3), np.float32)
    shade = np.zeros((h, w), np.float32)
    face[r0:r1, c0:c1] = face_b
    nrm[r0:r1, c0:c1] = nrm_b
    shade[r0:r1, c0:c1] = shade_b
    # the third weight 1 − u − v (misses keep (0, 0, 1))
    weights = np.zeros((h, w, 3))
    weights[..., 2] = 1.0
    b = bary_b.astype(np.float64)
    weights[r0:r1, c0:c1, :2] = b
    weights[r0:r1, c0:c1, 2] = 1.0 - b[..., 0] - b[..., 1]
    return RayHits(face, weights, nrm, shade, vertices, faces)


def _cast_box(mesh, shape, camera, up, view, fov, light, device):
    """The ray cast of :func:`cast_rays` over the mesh's screen box only: (box, (face,
    bary (u, v), normal, shade) of the box's pixels, float64 vertices, int64 faces)."""
    mesh = check_mesh(mesh)
    h, w = shape
    rot = up_rotation(up)
    if camera is None:
        cam = Camera.framing(mesh, fov=35.0 if fov is None else fov, up=up, view=VIEW if view is None else view)
    elif view is not None or fov is not None:
        raise TextonError("give either camera or view/fov, not both")
    else:
        cam = camera
    if not isinstance(cam, Camera):
        raise TextonError(f"camera must be a warp_texton.Camera, got {type(cam).__name__}")
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    origin = (lo + hi) / 2.0  # the ray cast runs in float32 around this point
    eye = np.asarray(cam.position, dtype=np.float64)
    # a Camera is checked when made: the view and up directions are non-zero and apart
    forward = _direction(np.asarray(cam.target, dtype=np.float64) - eye, "camera.target - camera.position")
    right = np.cross(forward, _direction(cam.up, "camera.up"))
    right /= np.linalg.norm(right)
    cam_up = np.cross(right, forward)
    light_dir = rot @ _direction(LIGHT, "light") if light is None else _direction(light, "light")
    check_memory(h * w * 60.0, f"a {w}x{h} render", "render fewer pixels")
    device = resolve_device(device)
    c = K.Camera()
    c.origin = wp.vec3(*(eye - origin))
    c.right = wp.vec3(*right)
    c.up = wp.vec3(*cam_up)
    c.forward = wp.vec3(*forward)
    c.tan_half_fov = math.tan(math.radians(cam.fov) / 2.0)
    c.aspect = w / h
    c.light = wp.vec3(*light_dir)
    faces_np = np.asarray(mesh.faces, dtype=np.int64)
    r0, r1, c0, c1 = screen_box(vertices - eye, forward, right, cam_up, c.tan_half_fov, c.aspect, h, w)
    rh, rw = max(r1 - r0, 0), max(c1 - c0, 0)
    if rh == 0 or rw == 0:
        return (r0, r0, c0, c0), (np.full((0, 0), -1, np.int32), np.zeros((0, 0, 2), np.float32),
                                  np.zeros((0, 0, 3), np.float32), np.zeros((0, 0), np.float32)), vertices, faces_np
    with wp.ScopedDevice(device):
        points = wp.array(vertices - origin, dtype=wp.vec3)
        indices = wp.array(faces_np.astype(np.int32).reshape(-1), dtype=wp.int32)
        wmesh = wp.Mesh(points=points, indices=indices)
        normals = wp.array(vertex_normals(mesh, up), dtype=wp.vec3)
        outs = [wp.empty((rh, rw), dtype=t) for t in (wp.int32, wp.vec2, wp.vec3, wp.float32)]

        def band(a, b):
            wp.launch(K.cast_rays, dim=(b - a, rw), inputs=[wmesh.id, normals, indices, c, h, w, r0 + a, c0,
                                                            *(o[a:b] for o in outs)])

        split_launch(device, K, rh, band)
        return (r0, r1, c0, c1), tuple(o.numpy() for o in outs), vertices, faces_np


def render_mesh(
    mesh,
    texton: Texton,
    shape=(512, 512),
    texel_size: float | None = None,
    camera: Camera | None = None,
    mni: float = 60.0,
    seed: int = 0,
    device=None,
    *,
    background=(0.92, 0.92, 0.92),
    light=None,
    up=UP,
    side=None,
    view=None,
    fov=None,
    method: str = "auto",
) -> np.ndarray:
    """Ray-cast ``mesh`` with surface texton noise and simple diffuse shading.

    Each pixel's ray hits the mesh (``wp.Mesh`` BVH, ``wp.mesh_query_ray``, in
    world units around the mesh's centre); the hit is placed in float64 from
    the face's vertices and its barycentric weights, and the noise is evaluated
    there with the interpolated vertex normal (the face normal across creases
    sharper than 30°) and the frame rule, for all hits at once (in blocks, as
    :func:`surface_noise`), then shaded by 0.3 + 0.7 |⟨n, light⟩|. Missed
    pixels get ``background``.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    texton : Texton
    shape : (height, width)
    texel_size : float, optional
        World units per texel; default: the bounding-box diagonal / 256.
    camera : Camera, optional
        Default: :meth:`Camera.framing` of the mesh at ``view`` and ``fov``.
    mni, seed, device
        As in :func:`surface_noise`.
    up : "x", "y", "z" or 3-vector
        The world's up axis: the frame rule's ``up``, the default camera's up,
        and the frame of ``view`` and of the default light.
    side : 3-vector, optional
        The frame rule's ``side`` (default: the world's right for ``up``).
    view : (azimuth, elevation), optional
        Degrees; default (−55, 25): from the front left, above (:func:`view_direction`).
    fov : float, optional
        Vertical field of view of the default camera, degrees (default 35).
    light : 3-vector, optional
        Towards the light; default (0.4, −0.5, 1) in the Z-up frame, turned with ``up``.
    method : "blocks" or "points"
        As in :func:`surface_noise` (the same image).

    Returns
    -------
    float32 array (height, width, 3) in [0, 1]

    References
    ----------
    CGF §6 (surface noise), Fig. 8 (textured meshes without UVs).
    """
    mesh = check_mesh(mesh)
    if not isinstance(texton, Texton):
        raise TextonError(f"texton must be a Texton, got {type(texton).__name__}")
    h, w = check_shape(shape, max_pixels=MAX_RENDER_PIXELS)
    texel = default_texel_size(mesh) if texel_size is None else check_positive(texel_size, "texel_size")
    seed = check_seed(seed)
    check_method(method)
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    setup = surface_setup(texton, mni)
    texel_positions(vertices, texel, setup, "the mesh's vertices")  # refuses far meshes and tiny texels
    bg = check_background(background)
    device = resolve_device(device)
    p = surface_params(texton, setup, seed, "exact", up, side)
    (r0, r1, c0, c1), (face, bary, nrm, shade), vertices, faces = _cast_box(mesh, (h, w), camera, up, view, fov,
                                                                            light, device)
    hit = face >= 0
    pixels = np.flatnonzero(hit.reshape(-1)).astype(np.int32)
    with wp.ScopedDevice(device):
        on_cpu = wp.get_device(device).is_cpu
        img = np.empty((h, w, 3), np.float32)
        img_w = wp.array(img, dtype=wp.vec3, copy=False) if on_cpu else wp.empty((h, w), dtype=wp.vec3)
        bg32 = bg.astype(np.float32)
        split_launch(device, K, h, lambda a, b: wp.launch(K.fill_image, dim=(b - a, w),
                                                          inputs=[img_w[a:b], wp.vec3(*bg32)]))
        if pixels.size:
            # the hits in float64 texel units from their faces' vertices and weights (as
            # RayHits.points), and their normals, in one pass
            pos_w, nrm_w = wp.empty(pixels.size, dtype=wp.vec3d), wp.empty(pixels.size, dtype=wp.vec3)
            pix = wp.array(pixels, dtype=wp.int32)
            inputs = [wp.array(face.reshape(-1), dtype=wp.int32, copy=not on_cpu),
                      wp.array(bary.reshape(-1, 2), dtype=wp.vec2, copy=not on_cpu),
                      wp.array(nrm.reshape(-1, 3), dtype=wp.vec3, copy=not on_cpu),
                      wp.array(vertices, dtype=wp.vec3d), wp.array(faces.astype(np.int32).reshape(-1), dtype=wp.int32),
                      wp.float64(texel)]
            split_launch(device, K, pixels.size, lambda a, b: wp.launch(
                K.hit_points, dim=b - a, inputs=[pix[a:b], *inputs, pos_w[a:b], nrm_w[a:b]]))
            g = evaluate_points(p, setup, pos_w.numpy(), nrm_w.numpy(), None, device, method)
            g_w = wp.array(g, dtype=wp.vec3)
            shade_w = wp.array(shade.reshape(-1), dtype=wp.float32, copy=not on_cpu)
            split_launch(device, K, pixels.size, lambda a, b: wp.launch(
                K.shade_hits, dim=b - a, inputs=[pix[a:b], g_w[a:b], shade_w, c1 - c0, r0, c0,
                                                 int(texton.channels == 1), img_w]))
        if not on_cpu:
            img = img_w.numpy()
    return img
