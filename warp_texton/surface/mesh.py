"""Meshes without UVs: their checks, vertex normals, and vertex colours of surface
noise (:func:`texture_mesh`, CGF §6, Fig. 8).

Vertex colours hold the noise at the vertices only, interpolated across faces:
they show the texture where vertices are about a texel apart (``max_edge``
subdivides until they are); a baked texture (warp_texton/surface/bake.py) shows it on
any mesh with UVs.
"""

from __future__ import annotations

import math
import numbers
import warnings
from typing import TYPE_CHECKING

import numpy as np

from ..core.checks import check_int, check_positive
from ..core.errors import TextonError
from .frames import UP, up_vector
from .points import surface_noise, surface_setup, texel_positions
from ..model.texton import Texton
from ..model.tiling import TilingModel
from .tiling import SURFACE_MNI, check_surface_model

if TYPE_CHECKING:
    import trimesh

#: Default texture scale on a mesh: this many texels along its bounding-box diagonal.
TEXELS_PER_DIAGONAL = 256


def default_texel_size(mesh) -> float:
    """World units per texel when none is given: the bounding-box diagonal /
    TEXELS_PER_DIAGONAL (1 for a mesh of zero extent)."""
    lo, hi = np.asarray(mesh.bounds, dtype=np.float64)
    return float(np.linalg.norm(hi - lo)) / TEXELS_PER_DIAGONAL or 1.0


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


#: How :func:`corner_normals` makes the normal of each face corner.
NORMAL_MODES = ("angle", "smooth", "flat", "mesh")
#: Default crease angle of ``normals="angle"``, degrees: Blender's auto smooth default.
CREASE_ANGLE = 30.0


def check_normals(normals, crease_angle) -> float:
    """The cosine of the checked ``crease_angle`` (degrees, 0 to 180) after ``normals``
    (one of :data:`NORMAL_MODES`)."""
    if not isinstance(normals, str) or normals not in NORMAL_MODES:
        raise TextonError(f"normals must be one of {', '.join(NORMAL_MODES)}, got {normals!r:.40}", "normals")
    real = isinstance(crease_angle, numbers.Real) and not isinstance(crease_angle, bool)
    angle = float(crease_angle) if real else math.nan
    if not 0.0 <= angle <= 180.0:
        raise TextonError(f"crease_angle must be a number of degrees from 0 to 180, got {crease_angle!r:.40}",
                          "crease_angle")
    return math.cos(math.radians(angle))


def corner_normals(mesh, normals: str = "angle", crease_angle: float = CREASE_ANGLE, up=UP) -> np.ndarray:
    """Unit normals of every face corner of ``mesh``: (F, 3, 3) float64, corner k of
    face f at ``[f, k]``, the normals renders, bakes and vertex colours interpolate.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    normals : {"angle", "smooth", "flat", "mesh"}
        "angle" (default): a corner's normal is the mean of the normals of the
        faces around its vertex that its face reaches across edges no sharper
        than ``crease_angle`` (Blender's Smooth by Angle, or auto smooth: flat
        faces stay flat, curved ones smooth). "smooth": the mean of all the
        faces around the vertex. "flat": the face's normal. "mesh": the vertex
        normals the mesh holds (those read from its file, glTF/OBJ/PLY; for a
        mesh without, trimesh's smooth ones), as they are. The means weight
        each face by its corner angle at the vertex.
    crease_angle : float
        Degrees, 0 to 180 (default 30, ``CREASE_ANGLE``); only "angle" reads it.
    up : str or (x, y, z)
        The normal of corners that have none (every face around them has zero
        area).

    Returns
    -------
    float64 array (F, 3, 3)

    Raises
    ------
    TextonError
        For a ``normals`` not in :data:`NORMAL_MODES` and a ``crease_angle``
        outside [0, 180].

    Notes
    -----
    An edge is sharp where its two faces' normals part by more than the
    crease angle; boundary edges, edges of three faces or more and edges of
    zero-area faces are sharp too. Around a vertex, the sharp edges cut the
    faces into fans, and every corner of a fan takes the fan's mean.
    Vertices at equal positions count as one, so corners split only to carry
    other attributes (UV seams, a triangle soup read from STL) are smooth
    across the split. Faces of zero area count for none, and their corners
    take the mean of all the faces at the vertex. Where one fan holds all
    of a vertex's corners and no other vertex shares its position, its
    corners take trimesh's vertex normal (the same mean, summed in trimesh's
    order), so smooth meshes keep their normals to the bit. Derivation and
    measurements against Blender: docs/model.md, "Normals".

    Examples
    --------
    >>> import trimesh
    >>> from warp_texton.surface.mesh import corner_normals
    >>> box = trimesh.creation.box()  # 8 vertices, each on 3 faces at 90 degrees
    >>> n = corner_normals(box)
    >>> bool((n == box.face_normals[:, None, :]).all())  # flat faces, split at the edges
    True
    >>> smooth = corner_normals(box, "smooth")
    >>> [round(abs(float(c)), 3) for c in smooth[0, 0]]  # along the corner's diagonal
    [0.577, 0.577, 0.577]
    """
    import trimesh

    cos = check_normals(normals, crease_angle)
    if normals != "angle":
        cos = -1.0  # "smooth": every face around the vertex
    faces = np.asarray(mesh.faces, dtype=np.int64)
    if normals == "mesh":
        return vertex_normals(mesh, up)[faces]
    v = np.asarray(mesh.vertices, dtype=np.float64)
    fn = np.asarray(mesh.face_normals, dtype=np.float64)
    ok = (fn ** 2).sum(axis=1) > 0.5  # trimesh's own test of a face with a normal
    angles = np.where(ok[:, None], np.nan_to_num(np.asarray(mesh.face_angles, dtype=np.float64)), 0.0)
    # trimesh's vertex normals, computed rather than read (a file's normals are "mesh")
    smooth = _unit_or_up(trimesh.geometry.weighted_vertex_normals(len(v), faces, fn, angles), up)
    if normals == "flat":
        out = np.repeat(fn[:, None, :], 3, axis=1)
        out[~ok] = smooth[faces[~ok]]
        return out
    weld = _positions(v)
    flat = faces.reshape(-1)
    corner = weld[flat]  # the position of each corner (3 f + k)
    weighted = (fn[:, None, :] * angles[:, :, None]).reshape(-1, 3)
    fan = corner if cos <= -1.0 else _fans(corner.reshape(-1, 3), fn, ok, cos)
    out = _sums(fan, weighted, len(fan))[fan]
    if not ok.all():  # the corners of zero-area faces: the full mean at their position
        bad = ~np.repeat(ok, 3)
        out[bad] = _sums(corner, weighted, len(v))[corner[bad]]
    length = np.sqrt(np.einsum("nd,nd->n", out, out))
    good = length > 1e-12
    out /= np.where(good, length, 1.0)[:, None]
    if not good.all():
        out[~good] = up_vector(up)
    # a vertex alone at its position whose fan holds all its corners: trimesh's normal, to the bit
    whole = np.bincount(fan)[fan] == np.bincount(corner)[corner]
    same = whole & (np.bincount(weld, minlength=len(v))[corner] == 1)
    out = np.where(same[:, None], smooth[flat], out)
    return out.reshape(-1, 3, 3)


def _sums(index: np.ndarray, values: np.ndarray, count: int) -> np.ndarray:
    """(count, 3): the rows of ``values`` summed by ``index``."""
    return np.stack([np.bincount(index, values[:, d], minlength=count) for d in range(3)], axis=1)


def _fans(positions: np.ndarray, fn: np.ndarray, ok: np.ndarray, cos: float) -> np.ndarray:
    """A label per corner (3 f + k) of ``positions`` (F, 3): corners at one position share
    it when their faces connect through edges that are not sharp (two faces with normals
    within the angle, ``cos``); boundary edges, edges of three faces or more, and faces
    without a normal are sharp. Blender's Smooth by Angle splits the same way."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = positions.size
    start = positions.reshape(-1)  # edge k of face f runs from corner 3 f + k ...
    after = 3 * (np.arange(n) // 3) + (np.arange(n) + 1) % 3  # ... to corner 3 f + (k + 1) % 3
    end = start[after]
    lo, hi = np.minimum(start, end), np.maximum(start, end)
    edges = np.flatnonzero(lo != hi)
    key = lo[edges] * (int(positions.max()) + 1) + hi[edges]  # the unordered edge as one integer
    order = np.argsort(key)
    edges, key = edges[order], key[order]
    same = key[1:] == key[:-1]
    # an edge of exactly two faces: equal to the next, and neither the one before nor the one after
    pair = same & np.r_[True, ~same[:-1]] & np.r_[~same[1:], True]
    e1, e2 = edges[:-1][pair], edges[1:][pair]
    f1, f2 = e1 // 3, e2 // 3
    smooth = ok[f1] & ok[f2] & (np.einsum("nd,nd->n", fn[f1], fn[f2]) >= cos)
    e1, e2 = e1[smooth], e2[smooth]
    flipped = start[e1] == start[e2]  # the two faces wind the edge the same way
    rows = np.r_[e1, after[e1]]
    cols = np.r_[np.where(flipped, e2, after[e2]), np.where(flipped, after[e2], e2)]
    graph = coo_matrix((np.ones(len(rows), np.int8), (rows, cols)), shape=(n, n))
    labels = connected_components(graph, directed=False)[1]
    # corners at different positions never join: an edge joins corners at its own ends
    return labels.astype(np.int64)


def _positions(v: np.ndarray) -> np.ndarray:
    """Each vertex's position index: vertices at equal coordinates share one."""
    key = np.ascontiguousarray(v + 0.0).view(np.dtype((np.void, 24))).reshape(-1)  # + 0.0: -0.0 is 0.0
    return np.unique(key, return_inverse=True)[1].reshape(-1)


def _unit_or_up(n: np.ndarray, up) -> np.ndarray:
    n = np.asarray(n, dtype=np.float64).copy()
    length = np.linalg.norm(n, axis=1)
    bad = ~np.isfinite(length) | (length < 1e-12)
    n[bad] = up_vector(up)
    return n / np.linalg.norm(n, axis=1)[:, None]


def split_corners(faces: np.ndarray, normals: np.ndarray, vertex_count: int):
    """The vertices of ``faces`` split where their corners' ``normals`` differ, so that
    each vertex has one normal: what a file with one normal or colour per vertex needs.

    Parameters
    ----------
    faces : int array (F, 3)
    normals : float array (F, 3, 3)
        Corner k of face f at ``[f, k]`` (:func:`corner_normals`).
    vertex_count : int
        The number of vertices ``faces`` index.

    Returns
    -------
    (vertex map, faces, vertex normals)
        ``vertex map`` (V',) gives each new vertex's input vertex, ordered by it;
        the faces (F, 3) index the new vertices, in the same order, each corner
        keeping its position; the normals are (V', 3). Without a split the
        input's vertices are kept as they are: the map is the identity, unused
        vertices included (their normal zero), and the faces are the input's.

    Examples
    --------
    >>> import trimesh
    >>> from warp_texton.surface.mesh import corner_normals, split_corners
    >>> box = trimesh.creation.box()
    >>> vmap, faces, normals = split_corners(box.faces, corner_normals(box), len(box.vertices))
    >>> len(vmap), bool((vmap[faces] == box.faces).all())  # 8 corners, on 3 faces each
    (24, True)
    """
    faces = np.asarray(faces, dtype=np.int64)
    flat = faces.reshape(-1)
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    order = np.lexsort((n[:, 2], n[:, 1], n[:, 0], flat))
    fs, ns = flat[order], n[order]
    new = np.r_[True, (fs[1:] != fs[:-1]) | np.any(ns[1:] != ns[:-1], axis=1)]
    if np.count_nonzero(new) == np.count_nonzero(np.r_[True, fs[1:] != fs[:-1]]):
        vn = np.zeros((int(vertex_count), 3))  # one normal per used vertex: nothing splits
        vn[flat] = n
        return np.arange(int(vertex_count)), faces, vn
    index = np.empty(len(flat), np.int64)
    index[order] = np.cumsum(new) - 1
    return fs[new], index.reshape(-1, 3), ns[new]


def srgb_to_linear(v) -> np.ndarray:
    """The sRGB decoding (IEC 61966-2-1) of values in [0, 1]: what glTF's linear
    ``COLOR_0`` holds for a colour an image stores as ``v``.

    >>> srgb_to_linear([0.0, 0.5, 1.0]).round(4).tolist()
    [0.0, 0.214, 1.0]
    """
    v = np.asarray(v, dtype=np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def vertex_spacing(mesh, texel_size: float) -> float:
    """The median edge length of ``mesh`` in texels: how far apart vertex colours are."""
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    if len(f) == 0:
        return 0.0
    return float(np.median(np.linalg.norm(v[f[:, [1, 2, 0]]] - v[f], axis=2))) / texel_size


def texture_mesh(
    mesh,
    texton: Texton | TilingModel,
    texel_size: float,
    *,
    mni: float = 60.0,
    seed: int = 0,
    max_edge: float | None = None,
    device=None,
    up=UP,
    side=None,
    max_faces: int = 5_000_000,
    linear: bool = False,
    name: str = "mesh",
    warn: bool = True,
    normals: str = "angle",
    crease_angle: float = CREASE_ANGLE,
) -> trimesh.Trimesh:
    """A copy of ``mesh`` with per-vertex colours from surface texton noise.

    A new mesh with the noise of :func:`surface_noise` at every vertex as
    8-bit RGBA vertex colours, its vertices split where their corners'
    normals differ (:func:`corner_normals`: at the edges of a box, so each
    face holds the noise of its own plane) (``mesh.visual.vertex_colors``; grey textons
    give three equal channels, alpha 255), ready to export as PLY, OBJ or
    GLB. The input is not modified. Vertex colours hold one value per vertex,
    interpolated across faces: they show the texture only where vertices are
    about a texel apart (see Warns). For a texture that does not depend on
    the tessellation, bake one on the mesh's UVs (:func:`bake_mesh`).

    Parameters
    ----------
    mesh : trimesh.Trimesh
        At least one triangle.
    texton : Texton or TilingModel
        As in :func:`surface_noise` (a tiling model refuses ``mni``).
    texel_size : float
        World units per texel, > 0.
    mni : float
        As in :func:`surface_noise`.
    seed : int
        As in :func:`surface_noise`.
    max_edge : float, optional
        In texels: first subdivide the mesh
        (``trimesh.remesh.subdivide_to_size``) until no edge is longer, so
        that vertex colours resolve the texture (about 1 to 4 texels).
    device : str, optional
        As in :func:`surface_noise`.
    up : str or (x, y, z)
        As in :func:`surface_noise`; a vertex that touches only zero-area
        faces has ``up`` for normal.
    side : (x, y, z), optional
        As in :func:`surface_noise`.
    max_faces : int
        Refuse a subdivision whose estimated face count exceeds this.
    linear : bool
        Store the sRGB decoding of the values (glTF's ``COLOR_0`` is linear
        by definition) instead of the values themselves (PLY, OBJ).
    name : str
        How the spacing warning names the mesh (a file name in a batch).
    warn : bool
        Whether to warn about vertices further apart than a texel (a batch
        reports it itself).
    normals : {"angle", "smooth", "flat", "mesh"}
        The normals the noise sees at the vertices, as in
        :func:`render_mesh` (default "angle": split at edges sharper than
        ``crease_angle``).
    crease_angle : float
        As in :func:`render_mesh` (degrees, default 30).

    Returns
    -------
    trimesh.Trimesh
        With ``visual.vertex_colors`` (N, 4) uint8 RGBA; the subdivided
        vertices and faces when ``max_edge`` is given, else the input's, and
        a vertex for each normal where the corner normals split one (the
        faces in their order).

    Raises
    ------
    TextonError
        For a ``mesh`` that is not a ``trimesh.Trimesh``, has no triangles,
        has NaN or infinite vertices or faces that index missing vertices; a
        ``texel_size`` or ``max_edge`` that is not a finite number > 0; a
        ``max_faces`` that is not an integer ≥ 1; a bad ``normals`` or
        ``crease_angle`` (:func:`corner_normals`); a subdivision estimated
        above ``max_faces``; and the errors of :func:`surface_noise`
        (vertices too far from the origin for ``texel_size`` among them).

    Warns
    -----
    UserWarning
        When ``warn`` is true and the median edge is longer than one texel:
        names the mesh (``name``) and the spacing, and suggests a baked
        texture or ``max_edge``.

    References
    ----------
    CGF §6 (the noise on surfaces without UVs) and its Fig. 8.

    Examples
    --------
    >>> import warnings
    >>> import trimesh
    >>> from warp_texton import read_image, analyze, texture_mesh
    >>> from warp_texton.demo import demo_texture_path
    >>> texton = analyze(read_image(demo_texture_path()), size=32, iterations=30)
    >>> sphere = trimesh.creation.icosphere(subdivisions=3)  # 1280 faces
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     coloured = texture_mesh(sphere, texton, texel_size=0.01, device="cpu")
    >>> print(caught[0].message)  # doctest: +ELLIPSIS
    mesh: vertices are 15.1 texels apart (median edge), so vertex colours blur the texture; ...
    >>> len(coloured.vertices), coloured.visual.vertex_colors.shape
    (642, (642, 4))

    Edges of at most 4 texels (3.2 texels at the median: still above one,
    so the warning is turned off here), exported as a PLY file with vertex
    colours:

    >>> fine = texture_mesh(sphere, texton, texel_size=0.01, max_edge=4, warn=False, device="cpu")
    >>> len(fine.faces)
    35840
    >>> _ = fine.export("sphere_grass.ply")
    """
    import trimesh

    mesh = check_mesh(mesh)
    texel = check_positive(texel_size, "texel_size")
    max_faces = check_int(max_faces, "max_faces", minimum=1)
    check_normals(normals, crease_angle)
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    check_surface_model(texton, mni=(mni, SURFACE_MNI))
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
        source = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    else:
        source = mesh  # its own normals for normals="mesh"
    # a vertex per normal where the corners around it split: the noise differs on each side of a crease
    split, faces, vnormals = split_corners(faces, corner_normals(source, normals, crease_angle, up), len(vertices))
    vertices = vertices[split]
    out = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    spacing = vertex_spacing(out, texel)
    if warn and spacing > 1.0:
        warnings.warn(f"{name}: vertices are {spacing:.3g} texels apart (median edge), so vertex colours blur the "
                      "texture; bake a texture (--bake RES) or subdivide (--max-edge 1)", stacklevel=2)
    vnormals[~np.any(vnormals, axis=1)] = up_vector(up)  # vertices of no face
    colours = surface_noise(texton, vertices, vnormals, texel, mni=mni, seed=seed, device=device,
                            up=up, side=side)
    if colours.shape[1] == 1:
        colours = np.repeat(colours, 3, axis=1)
    colours = np.clip(colours, 0.0, 1.0)
    if linear:
        colours = srgb_to_linear(colours)
    rgba = np.empty((len(vertices), 4), np.uint8)
    rgba[:, :3] = np.round(colours * 255.0)
    rgba[:, 3] = 255
    visual = out.visual
    assert isinstance(visual, trimesh.visual.ColorVisuals), "a new Trimesh without UVs"
    visual.vertex_colors = rgba
    return out
