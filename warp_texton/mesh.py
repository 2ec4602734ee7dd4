"""Meshes without UVs: their checks, vertex normals, and vertex colours of surface
noise (:func:`texture_mesh`, CGF §6, Fig. 8).

Vertex colours hold the noise at the vertices only, interpolated across faces:
they show the texture where vertices are about a texel apart (``max_edge``
subdivides until they are); a baked texture (warp_texton/bake.py) shows it on
any mesh with UVs.
"""

from __future__ import annotations

import math
import warnings
from typing import TYPE_CHECKING

import numpy as np

from ._checks import check_int, check_positive
from .errors import TextonError
from .frames import UP, up_vector
from .surface import surface_noise, surface_setup, texel_positions
from .texton import Texton

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
    texton: Texton,
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
) -> trimesh.Trimesh:
    """A copy of ``mesh`` with per-vertex colours from surface texton noise.

    A new mesh with the noise of :func:`surface_noise` at every vertex as
    8-bit RGBA vertex colours (``mesh.visual.vertex_colors``; grey textons
    give three equal channels, alpha 255), ready to export as PLY, OBJ or
    GLB. The input is not modified. Vertex colours hold one value per vertex,
    interpolated across faces: they show the texture only where vertices are
    about a texel apart (see Warns). For a texture that does not depend on
    the tessellation, bake one on the mesh's UVs (:func:`bake_mesh`).

    Parameters
    ----------
    mesh : trimesh.Trimesh
        At least one triangle.
    texton : Texton
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
        As in :func:`surface_noise`; the normals are the mesh's vertex
        normals, and a vertex that touches only zero-area faces takes
        ``up``.
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

    Returns
    -------
    trimesh.Trimesh
        With ``visual.vertex_colors`` (N, 4) uint8 RGBA; the subdivided
        vertices and faces when ``max_edge`` is given, else the input's.

    Raises
    ------
    TextonError
        For a ``mesh`` that is not a ``trimesh.Trimesh``, has no triangles,
        has NaN or infinite vertices or faces that index missing vertices; a
        ``texel_size`` or ``max_edge`` that is not a finite number > 0; a
        ``max_faces`` that is not an integer ≥ 1; a subdivision estimated
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
    colours = surface_noise(texton, vertices, vertex_normals(out, up), texel, mni=mni, seed=seed, device=device, up=up,
                            side=side)
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
