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

from ._checks import check_positive, check_seed, check_shape
from ._runtime import map_points, resolve_device, split_launch
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
#: Evaluation paths: "blocks" (points share their cubes' impacts) and "points"
#: (each point draws the impacts of its cubes itself: the reference).
METHODS = ("blocks", "points")
#: Points are grouped by blocks of this many cubes per side.
BLOCK_CUBES = 4
#: Cubes drawn per round of the block path (bounds its impact buffer).
CUBES_PER_ROUND = 1 << 20
#: Up axes: the frame rule, the default camera and the light are set for a
#: Z-up world and turned by this rotation (world = R · canonical) for the others.
#: Y-up follows glTF (+Z towards the front viewer, +X to the right).
UP_AXES = {
    "z": np.eye(3),
    "y": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),
    "x": np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
}
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


def _unit_rows(v: np.ndarray, name: str) -> np.ndarray:
    length = np.linalg.norm(v, axis=1)
    bad = np.flatnonzero(length < 1e-12)
    if bad.size:
        raise TextonError(f"{name}[{bad[0]}] has zero length ({bad.size} such rows); every {name[:-1]} must be non-zero")
    return v / length[:, None]


def _direction(v, name: str) -> np.ndarray:
    d = np.asarray(v, dtype=np.float64).reshape(-1)
    if d.shape != (3,) or not np.isfinite(d).all() or np.linalg.norm(d) < 1e-12:
        raise TextonError(f"{name} must be a non-zero 3-vector, got {v!r}")
    return d / np.linalg.norm(d)


def tangent_frames(normals, up=UP, side=SIDE) -> tuple[np.ndarray, np.ndarray]:
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
    a = _direction(up, "up")
    b = _direction(side, "side")
    ca = n @ a
    v = (a - n * ca[:, None]) + (b - n * (n @ b)[:, None]) * (ca ** 4)[:, None]
    small = np.linalg.norm(v, axis=1) < 1e-6
    if small.any():
        v[small] = b - n[small] * (n[small] @ b)[:, None]
        still = np.linalg.norm(v, axis=1) < 1e-6
        v[still] = np.cross(n[still], a)
    u1 = v / np.linalg.norm(v, axis=1)[:, None]
    return u1, np.cross(n, u1)


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
    p.up = wp.vec3(*_direction(up, "up"))
    p.side = wp.vec3(*_direction(side, "side"))
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
    side=SIDE,
    poisson: str = "exact",
    cell_factor: float = CELL_FACTOR,
    method: str = "blocks",
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
        ``"blocks"`` (default): points sorted into blocks share the impacts of
        their cubes; ``"points"``: each point draws its cubes' impacts itself
        (the reference: same values, slower).

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
    nrm = _unit_rows(_points(normals, "normals"), "normals")
    if nrm.shape != pts.shape:
        raise TextonError(f"normals has shape {nrm.shape}; it must match points {pts.shape}")
    texel = check_positive(texel_size, "texel_size")
    seed = check_seed(seed)
    check_method(method)
    setup = surface_setup(texton, mni, cell_factor)
    tan = None
    if tangents is not None:
        tan = _points(tangents, "tangents")
        if tan.shape != pts.shape:
            raise TextonError(f"tangents has shape {tan.shape}; it must match points {pts.shape}")
        raw = np.linalg.norm(tan, axis=1)
        tan = tan - nrm * np.sum(tan * nrm, axis=1)[:, None]
        flat = np.flatnonzero(np.linalg.norm(tan, axis=1) <= 1e-9 * np.maximum(raw, 1e-300))
        if flat.size:
            what = "has zero length" if raw[flat[0]] == 0 else "is parallel to its normal"
            raise TextonError(f"tangents[{flat[0]}] {what} ({flat.size} such rows); a tangent must have a "
                              "component in the tangent plane")
        tan = tan / np.linalg.norm(tan, axis=1)[:, None]
    pos = texel_positions(pts, texel, setup, "points")
    device = resolve_device(device)
    p = surface_params(texton, setup, seed, poisson, up, side)
    out = evaluate_points(p, setup, pos, nrm, tan, device, method)
    return np.ascontiguousarray(out[:, : texton.channels])


def evaluate_points(p: K.SurfaceParams, setup: SurfaceSetup, pos: np.ndarray, nrm: np.ndarray, tan, device,
                    method: str = "blocks") -> np.ndarray:
    """(N, 3) float32 surface noise at checked float64 texel positions with unit
    normals (and unit tangents, or None for the frame rule)."""
    n = pos.shape[0]
    if n == 0:
        return np.zeros((0, 3), np.float32)
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
        return _gather_blocks(p, setup, coeffs, pos, nrm, tan, device)


def _blocks(pos: np.ndarray, setup: SurfaceSetup):
    """Points sorted into blocks of BLOCK_CUBES³ cubes: (order, starts, lo, hi), with
    lo/hi the first and last cube (per axis) that the points of each block can reach."""
    c = setup.cell
    own = np.floor(pos / c).astype(np.int64) // BLOCK_CUBES
    own -= own.min(axis=0)
    span = own.max(axis=0) + 1
    if float(span[0]) * float(span[1]) * float(span[2]) < 2.0**62:
        order = np.argsort((own[:, 2] * span[1] + own[:, 1]) * span[0] + own[:, 0], kind="stable")
    else:  # blocks spread over more than int64 keys hold
        order = np.lexsort((own[:, 0], own[:, 1], own[:, 2]))
    key = own[order]
    starts = np.flatnonzero(np.r_[True, np.any(key[1:] != key[:-1], axis=1)])
    # frame_extent ≤ (r/2)√3 per axis (a row of an orthogonal matrix has unit length),
    # with room for float32 rounding: every cube a point's walk visits is in its block
    reach = setup.r / 2.0 * math.sqrt(3.0) * (1.0 + 1e-5)
    ps = pos[order]
    lo = np.minimum.reduceat(np.floor((ps - reach) / c), starts, axis=0).astype(np.int64)
    hi = np.maximum.reduceat(np.floor((ps + reach) / c), starts, axis=0).astype(np.int64)
    return order, starts, lo, hi


def _gather_blocks(p, setup: SurfaceSetup, coeffs, pos, nrm, tan, device) -> np.ndarray:
    n = pos.shape[0]
    order, starts, lo, hi = _blocks(pos, setup)
    dims = hi - lo + 1
    cubes = np.prod(dims, axis=1)
    mean_count = setup.lam * setup.cell ** 3
    # one round per group of blocks holding at most CUBES_PER_ROUND cubes (a block alone may exceed it)
    check_memory(float(cubes.max()) * (16 + 12 * (mean_count + 10 * math.sqrt(mean_count) + 1))
                 + n * 64.0, f"surface noise at {n} points", "use fewer points at once or a larger texel_size")
    ends = np.r_[starts[1:], n]
    sorted_pos = np.ascontiguousarray(pos[order])
    sorted_nrm = np.ascontiguousarray(nrm[order])
    sorted_tan = np.ascontiguousarray(tan[order]) if tan is not None else None
    out = np.zeros((n, 3), np.float32)
    b0 = 0
    nb = len(starts)
    while b0 < nb:
        total = np.cumsum(cubes[b0:])
        b1 = b0 + max(1, int(np.searchsorted(total, CUBES_PER_ROUND, side="right")))
        _gather_round(p, setup, coeffs, sorted_pos, sorted_nrm, sorted_tan, device, starts[b0:b1], ends[b0:b1],
                      lo[b0:b1], dims[b0:b1], cubes[b0:b1], out)
        b0 = b1
    res = np.empty_like(out)
    res[order] = out
    return res


def _gather_round(p, setup, coeffs, pos, nrm, tan, device, starts, ends, lo, dims, cubes, out) -> None:
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
    counts = wp.zeros(total + 1, dtype=wp.int32)
    split_launch(device, K, total, lambda a, b: wp.launch(K.count_cubes, dim=b - a,
                                                          inputs=[p, cube_arr[a:b], counts[a:b]]))
    offsets = wp.zeros(total + 1, dtype=wp.int32)
    wp.utils.array_scan(counts, offsets, inclusive=False)
    n_impacts = int(offsets[total:total + 1].numpy()[0])
    impacts = wp.zeros(max(n_impacts, 1), dtype=wp.vec3)
    if n_impacts:
        split_launch(device, K, total, lambda a, b: wp.launch(K.emit_cubes, dim=b - a,
                                                              inputs=[p, cube_arr[a:b], offsets[a:], impacts]))
    blocks = K.CubeBlocks()
    blocks.origin = wp.array(lo.astype(np.int32), dtype=wp.vec3i)
    blocks.dims = wp.array(dims.astype(np.int32), dtype=wp.vec3i)
    blocks.base = wp.array(base.astype(np.int32), dtype=wp.int32)
    blocks.offsets = offsets
    blocks.impacts = impacts
    pts = wp.array(pos[p0:p1], dtype=wp.vec3d)
    nrms = wp.array(nrm[p0:p1], dtype=wp.vec3)
    tans = wp.array(tan[p0:p1], dtype=wp.vec3) if tan is not None else wp.zeros(1, dtype=wp.vec3)
    owners = wp.array(block_of, dtype=wp.int32)
    on_cpu = wp.get_device(device).is_cpu
    res = wp.array(out[p0:p1], dtype=wp.vec3, copy=False) if on_cpu else wp.zeros(p1 - p0, dtype=wp.vec3)

    def launch(a, b):
        wp.launch(K.gather_surface, dim=b - a, inputs=[p, coeffs, pts, nrms, tans, int(tan is not None), owners,
                                                      blocks, a, res])

    split_launch(device, K, p1 - p0, launch)
    if not on_cpu:
        out[p0:p1] = res.numpy()


def _check_mesh(mesh):
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
    n[bad] = _direction(up, "up")
    return n / np.linalg.norm(n, axis=1)[:, None]


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
    side=SIDE,
    max_faces: int = 5_000_000,
):
    """A copy of ``mesh`` with per-vertex colours from surface texton noise.

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

    Returns
    -------
    trimesh.Trimesh with ``visual.vertex_colors`` (RGBA, 8 bits).
    """
    import trimesh

    mesh = _check_mesh(mesh)
    texel = check_positive(texel_size, "texel_size")
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    if max_edge is not None:
        edge = check_positive(max_edge, "max_edge") * texel
        lengths = np.linalg.norm(vertices[faces[:, [1, 2, 0]]] - vertices[faces], axis=2)
        # trimesh halves edges: a face whose longest edge is L splits 4^k ways, 2^k ≥ L / edge
        halvings = np.ceil(np.log2(np.maximum(lengths.max(axis=1) / edge, 1.0)))
        factor = 4.0 ** halvings  # an upper bound on the faces each face becomes
        if factor.sum() > max_faces:
            raise TextonError(
                f"max_edge {max_edge:g} texels would make about {int(factor.sum())} faces (at most {max_faces}); "
                "use a larger max_edge or texel_size"
            )
        vertices, faces = trimesh.remesh.subdivide_to_size(vertices, faces, max_edge=edge, max_iter=64)
    out = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    colours = surface_noise(texton, vertices, vertex_normals(out, up), texel, mni, seed, device=device, up=up,
                            side=side)
    if colours.shape[1] == 1:
        colours = np.repeat(colours, 3, axis=1)
    rgba = np.empty((len(vertices), 4), np.uint8)
    rgba[:, :3] = np.round(np.clip(colours, 0.0, 1.0) * 255.0)
    rgba[:, 3] = 255
    out.visual.vertex_colors = rgba
    return out


@dataclass(frozen=True)
class Camera:
    """A pinhole camera: ``position`` looks at ``target``; ``fov`` is vertical, degrees."""

    position: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float] = UP
    fov: float = 35.0

    @classmethod
    def framing(cls, mesh, direction=(1.0, -1.3, 0.9), fov: float = 35.0, up=UP, zoom: float = 1.0) -> "Camera":
        """A camera looking at the mesh's bounding-box centre from ``direction``,
        far enough for its bounding sphere to fit the view (``zoom`` > 1 moves closer)."""
        lo, hi = np.asarray(mesh.bounds, dtype=np.float64)
        centre = (lo + hi) / 2.0
        radius = max(np.linalg.norm(hi - lo) / 2.0, 1e-9)
        d = _direction(direction, "direction")
        dist = radius / math.sin(math.radians(fov) / 2.0) * 1.05 / check_positive(zoom, "zoom")
        return cls(tuple(centre + d * dist), tuple(centre), tuple(up), fov)


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
    light=(0.4, -0.5, 1.0),
    up=UP,
    side=SIDE,
) -> np.ndarray:
    """Ray-cast ``mesh`` with surface texton noise and simple diffuse shading.

    Each pixel's ray hits the mesh (``wp.Mesh`` BVH, ``wp.mesh_query_ray``);
    the noise is evaluated at the hit with the interpolated vertex normal (the
    face normal across creases sharper than 30°) and the frame rule, then shaded by 0.3 + 0.7 |⟨n, light⟩|. Missed pixels get
    ``background``.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    texton : Texton
    shape : (height, width)
    texel_size : float, optional
        World units per texel; default: the bounding-box diagonal / 256.
    camera : Camera, optional
        Default: :meth:`Camera.framing` of the mesh.
    mni, seed, device
        As in :func:`surface_noise`.

    Returns
    -------
    float32 array (height, width, 3) in [0, 1]
    """
    mesh = _check_mesh(mesh)
    if not isinstance(texton, Texton):
        raise TextonError(f"texton must be a Texton, got {type(texton).__name__}")
    h, w = check_shape(shape, max_pixels=MAX_RENDER_PIXELS)
    texel = default_texel_size(mesh) if texel_size is None else check_positive(texel_size, "texel_size")
    seed = check_seed(seed)
    cam = Camera.framing(mesh, up=up) if camera is None else camera
    if not isinstance(cam, Camera):
        raise TextonError(f"camera must be a warp_texton.Camera, got {type(cam).__name__}")
    fov = check_positive(cam.fov, "camera.fov")
    if fov >= 180.0:
        raise TextonError(f"camera.fov must be below 180 degrees, got {fov}")
    eye = np.asarray(cam.position, dtype=np.float64)
    forward = _direction(np.asarray(cam.target, dtype=np.float64) - eye, "camera target - position")
    right = np.cross(forward, _direction(cam.up, "camera.up"))
    if np.linalg.norm(right) < 1e-9:
        raise TextonError("camera.up is parallel to the view direction")
    right /= np.linalg.norm(right)
    cam_up = np.cross(right, forward)
    setup = surface_setup(texton, mni)
    device = resolve_device(device)
    p = surface_params(texton, setup, seed, "exact", up, side)
    c = K.Camera()
    c.origin = wp.vec3(*(eye / texel))
    c.right = wp.vec3(*right)
    c.up = wp.vec3(*cam_up)
    c.forward = wp.vec3(*forward)
    c.tan_half_fov = math.tan(math.radians(fov) / 2.0)
    c.aspect = w / h
    c.light = wp.vec3(*_direction(light, "light"))
    try:
        bg = np.asarray(background, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise TextonError(f"background must be an RGB triple, got {background!r}") from None
    if not np.isfinite(bg).all():
        raise TextonError(f"background must be finite, got {background!r}")
    c.background = wp.vec3(*bg)
    with wp.ScopedDevice(device):
        points = wp.array(np.asarray(mesh.vertices, dtype=np.float64) / texel, dtype=wp.vec3)
        indices = wp.array(np.asarray(mesh.faces, dtype=np.int32).reshape(-1), dtype=wp.int32)
        wmesh = wp.Mesh(points=points, indices=indices)
        normals = wp.array(vertex_normals(mesh, up), dtype=wp.vec3)
        coeffs = wp.array(setup.coeffs, dtype=wp.vec3)
        out = wp.zeros((h, w), dtype=wp.vec3)

        def band(r0, r1):
            wp.launch(K.render_surface, dim=(r1 - r0, w), inputs=[p, coeffs, wmesh.id, normals, indices, c, r0, out])

        split_launch(device, K, h, band)
        img = out.numpy()
    if texton.channels == 1:
        # grey noise lives in channel 0: spread it (with the shading) to RGB
        hit = np.any(img != np.asarray(c.background, np.float32), axis=2)
        img[hit, 1] = img[hit, 0]
        img[hit, 2] = img[hit, 0]
    return np.ascontiguousarray(img, dtype=np.float32)
