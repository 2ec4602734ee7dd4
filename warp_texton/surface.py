"""Surface texton noise on meshes without UVs (CGF §6): points, vertex colours, renders.

At a surface point y with unit normal n and tangent frame (u1, u2), the noise
projects the impacts of a 3-D Poisson process of intensity λ that lie within
r/2 of the tangent plane, weighted by (1 − 2|⟨y − x, n⟩|/r)⁺:

    f(y) = Σ_i (1 − 2|⟨y − x_i, n⟩|/r)⁺ h(⟨y − x_i, u1⟩, ⟨y − x_i, u2⟩)
    g(y) = m + (f − λ (r/2) ∫h) / √(λ r/3)          (CGF Prop. 3)

so g has the texton's mean and variance on any surface. r is the larger side
of the texton's support and MNI = λ r · area(supp h) (λ r³ for a square
support). Frames follow one rule (see :func:`tangent_frames`) unless given.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import warp as wp

from ._checks import check_positive, check_seed, check_shape
from ._runtime import map_points, resolve_device, split_launch
from .errors import TextonError
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

    Returns
    -------
    float32 array (N, C)

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton, surface_noise
    >>> t = Texton(np.random.default_rng(0).standard_normal((8, 8, 1)) / 8, [0.5])
    >>> p = np.random.default_rng(1).normal(size=(5, 3))
    >>> surface_noise(t, p, p, texel_size=0.01, device="cpu").shape
    (5, 1)
    """
    if not isinstance(texton, Texton):
        raise TextonError(f"texton must be a Texton, got {type(texton).__name__}")
    pts = _points(points, "points")
    nrm = _unit_rows(_points(normals, "normals"), "normals")
    if nrm.shape != pts.shape:
        raise TextonError(f"normals has shape {nrm.shape}; it must match points {pts.shape}")
    texel = check_positive(texel_size, "texel_size")
    seed = check_seed(seed)
    setup = surface_setup(texton, mni, cell_factor)
    use_tangents = tangents is not None
    if use_tangents:
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
    pos = pts / texel
    if pos.size and np.abs(pos).max() / setup.cell >= MAX_CELL_INDEX:
        raise TextonError("points lie too far from the origin for this texel_size (more than 2**30 cells)")
    device = resolve_device(device)
    p = surface_params(texton, setup, seed, poisson, up, side)
    with wp.ScopedDevice(device):
        coeffs = wp.array(setup.coeffs, dtype=wp.vec3)
        dummy = wp.zeros(1, dtype=wp.vec3)

        def values(start, stop):
            res = wp.zeros(stop - start, dtype=wp.vec3)
            tarr = wp.array(tan[start:stop], dtype=wp.vec3) if use_tangents else dummy
            wp.launch(K.evaluate_surface, dim=stop - start,
                      inputs=[p, coeffs, wp.array(pos[start:stop], dtype=wp.vec3),
                              wp.array(nrm[start:stop], dtype=wp.vec3), tarr, int(use_tangents), res])
            return res.numpy()

        out = map_points(device, K, pts.shape[0], values)
    return np.ascontiguousarray(out[:, : texton.channels])


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
