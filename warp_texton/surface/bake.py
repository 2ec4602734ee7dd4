"""Baked textures: surface texton noise written into an image on a mesh's UVs.

Renderers, game engines, Blender and MeshLab show a texture through UV
coordinates. :func:`bake_mesh` keeps the mesh's own UVs when they are usable,
or makes a UV atlas with xatlas (the optional extra ``mesh``), then

1. rasterises the UV triangles: each texel centre gets its triangle, its
   barycentric position, the 3-D point and the interpolated normal there
   (the renderer's rule: the face normal across creases sharper than 30°);
2. evaluates the surface noise (CGF §6) there, averaging ``n_x × n_y``
   samples over the texel's footprint on the surface where one texel covers
   more than a texton texel (the supersampling anti-aliases a coarse bake);
3. extends every chart by a gutter of ``gutter`` texels: a texel past a chart
   edge takes the triangle of the nearest chart texel and the noise where that
   triangle's plane continues (the chart's surface, extrapolated), so bilinear
   and mip-mapped lookups near chart edges see the noise continue, no seam.

Colours: the texture holds the noise's own values, which are sRGB-coded like
the example images (PNG and glTF base-colour textures are sRGB); EXR textures
hold them as they are unless ``linear=True`` asks for the sRGB decoding.

Kernels driven here: ``warp_texton.kernels.surface_bake``.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import warp as wp

from ..core.checks import check_int, check_positive, check_seed
from ..core.runtime import progress_bar, resolve_device, split_launch
from ..core.progress import NamedSteps
from .atlas import CHART_METHODS, check_uvs, make_atlas, mesh_uvs, overlap_note, uv_coverage, uv_face_notes
from ..noise.colours import mean_colour
from ..core.errors import TextonError
from ..kernels import surface_bake
from ..core.limits import check_memory, check_work
from .frames import UP, up_vector
from .mesh import CREASE_ANGLE, check_mesh, check_normals, corner_normals, split_corners
from .mesh_files import PNG_DTYPES, texture_8bit
from .render import lookup, render_baked  # noqa: F401 (the bake's names in 0.2: warp_texton.bake)
from .points import (check_method, check_surface_work, evaluate_points, floor_visits, surface_params,
                      surface_setup, texel_positions)
from ..model.texton import Texton
from ..model.tiling import TilingModel
from .tiling import SURFACE_MNI, check_surface_model

if TYPE_CHECKING:
    import trimesh

#: UV sources: the mesh's own UVs when it has them ("auto"), always them ("mesh"), or a new atlas ("atlas").
UV_MODES = ("auto", "mesh", "atlas")
#: Largest texture side.
MAX_RESOLUTION = 16384
#: Supersampling: samples per texton texel along each side of a texel's
#: footprint (measured: see docs/model.md, "Baked textures"), and at most this
#: many samples per side.
SAMPLE_DENSITY = 1.0
MAX_SAMPLES_SIDE = 8
#: Operations (limits.check_work) of a bake's setup per texel (claims, gutter, maps: about
#: 3 µs a texel on a two-core CPU, docs/limits.md); and the least share of the texture an
#: atlas covers, for the estimate of the samples before the atlas (xatlas packs tighter).
BAKE_TEXEL_OPS = 2000.0
ATLAS_COVERAGE = 0.25
#: Most samples per texel side that an explicit ``supersample`` may ask for: 64² =
#: 4096 evaluations per texel, the bound the filters put on theirs (a texel's
#: work grows with its square).
MAX_SUPERSAMPLE = 64
#: Samples evaluated at once (bounds the memory of a bake).
SAMPLES_PER_ROUND = 1 << 21
#: Host memory of a bake per texel of the texture, at the peak.
BYTES_PER_TEXEL = 360.0
#: Host memory per sample of a round: its offset (2 float64) and texel (int64),
#: its barycentric weights, 3-D point and normal (3 float64 each) and its value
#: (3 float32), 108 bytes, with the temporaries between them: about 120.
BYTES_PER_SAMPLE = 120.0
#: Host memory that each baked texel keeps while the rounds run: its sums
#: (3 float64), sample counts per side, row, column and face (5 int64).
BYTES_PER_BAKED_TEXEL = 64.0
#: Refuse mesh UVs when more than this fraction of the covered texels is claimed twice.
MAX_OVERLAP = 0.02


@dataclass(frozen=True)
class BakedMesh:
    """What :func:`bake_mesh` makes (a frozen dataclass).

    Attributes
    ----------
    mesh : trimesh.Trimesh
        The mesh with UVs (vertices split along the atlas's seams and where
        the corner normals split, at creases), the vertex normals the noise
        was evaluated with (smooth across seams) and a PBR material whose base-colour texture is ``texture``
        (8-bit sRGB).
    texture : float32 array (RES, RES, C)
        The noise on the texture's texels (row 0 at the top, v = 1), gutter
        included; texels outside every chart and gutter hold the texton's mean.
    coverage : bool array (RES, RES)
        Texels whose centre lies on a triangle (the gutter around them is not counted).
    texels_per_texton_texel : float
        Median, over the covered texels, of the texture's texels per texton
        texel on the surface (√ of the footprint's area): below 1 a texel
        averages several texton texels.
    samples : float
        Mean number of noise samples per covered texel.
    uv_source : str
        "mesh" or "atlas".
    up : (x, y, z)
        The unit up vector of the bake's world (its ``up``): :func:`write_baked`
        turns a GLB's geometry from it to glTF's +Y.
    dtype : str
        The sample type of the PNG textures :func:`write_baked` writes:
        "uint8" or "uint16" (the mesh's material holds the 8-bit image).

    Notes
    -----
    Below one texel per texton texel (``texels_per_texton_texel`` < 1) the
    texture averages several texton texels: raise the resolution for more
    detail.
    """

    mesh: trimesh.Trimesh
    texture: np.ndarray
    coverage: np.ndarray
    texels_per_texton_texel: float
    samples: float
    uv_source: str
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    dtype: str = "uint8"

    @property
    def resolution(self) -> int:
        """The texture's side in texels."""
        return int(self.texture.shape[0])

    @property
    def covered(self) -> float:
        """The share of the texture's texels that lie on a triangle (``coverage``'s mean)."""
        return float(np.mean(self.coverage))


#: Most texels of gutter: a renderer's mip chain needs a few; a gutter of a sizeable share
#: of the texture only wastes it (and xatlas keeps charts two gutters apart).
MAX_GUTTER = 64


def default_gutter(resolution: int) -> int:
    """Texels of gutter around each chart: 2 up to 512², then 1/256 of the side (8 at 2048)."""
    return max(2, resolution // 256)


def _claim(corners: np.ndarray, resolution: int, device) -> tuple[np.ndarray, np.ndarray]:
    """(owner, cover): per texel, the face that owns it (−1: none) and how many faces hold its centre."""
    n_faces = corners.shape[0] // 3
    with wp.ScopedDevice(device):
        c: wp.array = wp.array(corners, dtype=wp.vec2d)
        owner = wp.full((resolution, resolution), -1, dtype=wp.int32)
        cover = wp.zeros((resolution, resolution), dtype=wp.int32)

        def launch(a, b):
            wp.launch(surface_bake.claim_texels, dim=b - a, inputs=[c, a, owner, cover])

        # atomics make the parts safe to run side by side on the CPU's threads
        split_launch(device, surface_bake, n_faces, launch)
        return owner.numpy(), cover.numpy()


def _claimed(uvs: np.ndarray, faces: np.ndarray, res: int, device, name: str):
    """(texel corners of the faces, owner of each texel, share of the covered texels on two faces or more)."""
    # texel coordinates: x = u W, y = (1 − v) H (row 0 at the top)
    corners = np.ascontiguousarray(np.stack([uvs[:, 0] * res, (1.0 - uvs[:, 1]) * res], axis=1)[faces].reshape(-1, 2))
    owner, cover = _claim(corners, res, device)
    n_cov = int(np.count_nonzero(owner >= 0))
    if n_cov == 0:
        raise TextonError(f"{name}: no texel centre lies on a triangle of its UVs at {res}x{res}; use a larger "
                          "resolution")
    return corners, owner, float(np.count_nonzero(cover > 1)) / n_cov


def _corners_of(cnormals: np.ndarray, faces: np.ndarray, vmap: np.ndarray, new_faces: np.ndarray) -> np.ndarray:
    """The corner normals of an atlas's faces (``new_faces``, one per input face, in order,
    indexing ``vmap``'s vertices): each corner takes the input corner of its vertex."""
    orig = vmap[new_faces]
    match = orig[:, :, None] == faces[:, None, :]  # corner k of the atlas is corner k' of the input
    pick = np.where(match.any(axis=2), match.argmax(axis=2), np.arange(3))
    return np.take_along_axis(cnormals, pick[:, :, None], axis=1)


def bake_mesh(
    mesh,
    texton: Texton | TilingModel,
    texel_size: float,
    *,
    resolution: int = 1024,
    mni: float = 60.0,
    seed: int = 0,
    uv: str = "auto",
    supersample: int | None = None,
    gutter: int | None = None,
    device=None,
    up=UP,
    side=None,
    name: str = "mesh",
    method: str = "auto",
    charts: str = "normals",
    progress: bool = False,
    dtype: str = "uint8",
    normals: str = "angle",
    crease_angle: float = CREASE_ANGLE,
) -> BakedMesh:
    """Bake surface texton noise into a ``resolution``² texture on the mesh's UVs.

    The noise (the same noise as :func:`warp_texton.surface_noise` and
    :func:`warp_texton.render_mesh`) is evaluated at the surface point under
    every texel of a texture laid on the mesh's UVs, or on a UV atlas made by
    xatlas (``pip install "warp-texton[mesh]"``), so renderers, game engines,
    Blender and MeshLab show it through ordinary UV coordinates;
    :func:`write_baked` writes the result. Conventions and measurements:
    docs/model.md, "baked textures".

    Parameters
    ----------
    mesh : trimesh.Trimesh
    texton : Texton or TilingModel
        As in :func:`warp_texton.surface_noise` (a tiling model refuses ``mni`` and ``method``).
    texel_size : float
        World units per texton texel (as :func:`warp_texton.texture_mesh`).
    resolution : int
        Texture side in texels (1 to 16384).
    mni : float
        Mean number of impacts per point (default 60), as in :func:`warp_texton.surface_noise`.
    seed : int
        As in :func:`warp_texton.surface_noise`.
    device : str, optional
        As in :func:`warp_texton.surface_noise`.
    up : str or (x, y, z)
        The frame rule's up direction, as in :func:`warp_texton.surface_noise`.
    side : (x, y, z), optional
        The frame rule's second direction, as in :func:`warp_texton.surface_noise`.
    method : {"auto", "blocks", "points"}
        As in :func:`warp_texton.surface_noise`.
    uv : "auto", "mesh" or "atlas"
        "auto": the mesh's UVs when it has them, else an xatlas atlas; "mesh":
        its UVs or an error; "atlas": a new atlas, ignoring any UVs.
    charts : {"normals", "xatlas"}
        How an atlas is charted (:func:`warp_texton.surface.atlas.make_atlas`):
        "normals" (default) by clusters of the faces' normals, packed by
        xatlas, in about a second for 100k faces (xatlas's own charting when
        a chart would overlap itself); "xatlas": xatlas's own charts, fewer
        seams, about 40× slower (docs/benchmarks.md, "Atlases").
    progress : bool
        A progress bar of named steps, its total fixed from the start: the
        atlas's charting and packing (when it makes one) and the sampling,
        whose rounds show beside the count (shown after 2 s).
    dtype : {"uint8", "uint16"}
        The PNG sample type :func:`write_baked` writes the texture with (GLB,
        OBJ and the texture alone; 16 bits keep 256 times finer steps, for
        textures that are graded or displaced later).
    normals : {"angle", "smooth", "flat", "mesh"}
        The normals the noise sees, as in :func:`warp_texton.render_mesh`
        (default "angle": split at edges sharper than ``crease_angle``); the
        baked mesh carries them (its vertices split where they do).
    crease_angle : float
        As in :func:`warp_texton.render_mesh` (degrees, default 30).
    supersample : int, optional
        Samples per side of each texel (1: the texel centre only). Default:
        per texel, ``ceil(SAMPLE_DENSITY ×`` texton texels along each side of
        its footprint``)``, from 1 to ``MAX_SAMPLES_SIDE``.
    gutter : int, optional
        Texels by which every chart is extended (default
        :func:`default_gutter`: 2, or ``resolution / 256`` from 512 on).
    name : str
        How errors name the mesh.

    Returns
    -------
    BakedMesh

    Raises
    ------
    TextonError
        For the ``mesh`` and ``texton`` errors of
        :func:`warp_texton.texture_mesh`; a ``resolution`` that is not an
        integer in [1, 16384]; a bad ``normals`` or ``crease_angle``; a bad ``uv``, ``charts``, ``dtype`` (a type PNG
        cannot hold, such as "float32"), ``supersample`` (≥ 1, ≤ 64) or
        ``gutter`` (≥ 0); UVs that cannot hold a bake, naming the mesh and the
        problem with the hint ``uv='atlas'``: not one (u, v) per vertex, NaN
        or infinite, outside [0, 1] (a repeated texture), or overlapping (more
        than 2 % of the covered texels on two triangles); no UVs with
        ``uv="mesh"``; a missing xatlas when an atlas is needed ("making a UV
        atlas needs the xatlas package: pip install 'warp-texton[mesh]'"); xatlas
        crashing, running past its time limit or over its memory cap (it runs
        in a process of its own: :func:`warp_texton.surface.atlas.run_worker`); a
        bake over the memory budget (about 360 bytes per texel at the peak:
        1.5 GB at 2048², 6 GB at 4096²) or the work budget (the texels' setup
        and the samples by their path, first before the atlas: docs/limits.md);
        vertices too far from the origin.

    References
    ----------
    CGF §6 (surface noise without UVs, evaluated here at the texels' surface points).

    Examples
    --------
    >>> import numpy as np, trimesh
    >>> from warp_texton import Texton, bake_mesh
    >>> t = Texton(np.random.default_rng(0).standard_normal((8, 8, 1)) / 8, [0.5])
    >>> plane = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]],
    ...                         visual=trimesh.visual.TextureVisuals(uv=[[0, 0], [1, 0], [1, 1], [0, 1]]))
    >>> baked = bake_mesh(plane, t, texel_size=1 / 64, resolution=64, device="cpu")
    >>> baked.texture.shape, baked.uv_source, round(baked.texels_per_texton_texel, 3)
    ((64, 64, 1), 'mesh', 1.0)

    A mesh without UVs gets an xatlas atlas; the GLB that :func:`write_baked`
    writes keeps its UVs, so a bake of it read back uses them:

    >>> import trimesh
    >>> from warp_texton import read_image, analyze, bake_mesh, write_baked
    >>> from warp_texton.demo import demo_texture_path
    >>> texton = analyze(read_image(demo_texture_path()), size=32, iterations=30)
    >>> torus = trimesh.creation.torus(major_radius=1.0, minor_radius=0.35)
    >>> baked = bake_mesh(torus, texton, texel_size=0.05, resolution=64, device="cpu")
    >>> baked.uv_source, baked.texture.shape
    ('atlas', (64, 64, 1))
    >>> write_baked(baked, "torus_baked", fmt="glb", texture="png")
    [PosixPath('torus_baked.glb'), PosixPath('torus_baked_texture.png')]
    >>> (glb,) = trimesh.load("torus_baked.glb").geometry.values()
    >>> bake_mesh(glb, texton, texel_size=0.05, resolution=64, device="cpu").uv_source
    'mesh'
    """
    import trimesh

    mesh = check_mesh(mesh)
    check_surface_model(texton, mni=(mni, SURFACE_MNI), method=(method, "auto"))
    texel = check_positive(texel_size, "texel_size")
    res = check_int(resolution, "resolution", minimum=1)
    if res > MAX_RESOLUTION:
        raise TextonError(f"resolution must be at most {MAX_RESOLUTION}, got {res}")
    supersample, gutter = _check_choices(res, uv, supersample, gutter, charts, dtype)
    seed = check_seed(seed)
    check_method(method)
    check_normals(normals, crease_angle)
    # the owners, the distance transform of the gutter and each texel's face, map, footprint
    # and sums: about BYTES_PER_TEXEL at the peak (measured: 1.7 GB for 2048²)
    check_memory(res * res * BYTES_PER_TEXEL, f"a {res}x{res} bake", "use a smaller resolution")
    setup = surface_setup(texton, mni)
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    texel_positions(vertices, texel, setup, "the mesh's vertices")
    cnormals = corner_normals(mesh, normals, crease_angle, up)  # (F, 3 corners, 3)
    try:
        own_uv = mesh_uvs(mesh) if uv != "atlas" else None
    except TextonError as exc:
        raise TextonError(f"{name}: {exc}; use uv='atlas' (--uv atlas) to ignore them") from None
    if own_uv is None and uv == "mesh":
        raise TextonError(f"{name}: has no UVs (uv='mesh'); use uv='auto' or 'atlas' to make an atlas")
    # priced before the atlas from the mesh's area (texton texels²) and the texels it will cover
    work_hint, texels2 = "use a smaller resolution, a smaller supersample or a lower mni", mesh.area / texel**2
    covered = res * res * (ATLAS_COVERAGE if own_uv is None else uv_coverage(own_uv, faces))
    n = covered * supersample**2 if supersample else max(covered, min(texels2, MAX_SAMPLES_SIDE**2 * covered))
    check_surface_work(setup, n, n / max(texels2, 1e-300), f"a {res}x{res} bake with about "
                       f"{n:.3g} samples at MNI {mni:.6g}", work_hint, param="supersample",
                       mentions=("resolution", "supersample", "mni"), early=True, other=res * res * BAKE_TEXEL_OPS)
    device = resolve_device(device)
    names = ["sampling"] if own_uv is not None else ["charts", "packing", "sampling"]
    bar = NamedSteps(progress_bar(progress, len(names), f"bake: {names[0]}", "step"), names, "bake")
    source, vertices, cnormals, faces, uvs, corners, owner = _bake_uvs(
        mesh, vertices, cnormals, faces, own_uv, res, gutter, charts, device, name, bar)
    covered = owner >= 0
    n_cov = int(covered.sum())
    tx = _texel_faces(_extend(owner, covered, gutter), covered, faces, corners, vertices, cnormals, texel)
    per_texel = float(np.median(1.0 / np.sqrt(np.maximum(tx.area[tx.inner], 1e-300))))
    nx, ny = _sample_counts(tx, supersample)
    total = int(np.sum(nx * ny))
    check_memory(min(total, SAMPLES_PER_ROUND) * BYTES_PER_SAMPLE + len(tx.f) * BYTES_PER_BAKED_TEXEL,
                 f"a {res}x{res} bake with {total} samples",
                 "use a smaller resolution or supersample")
    # every sample is a point of the surface noise, as dense as the samples over their texels
    check_surface_work(setup, total, total / max(float(tx.area.sum()), 1e-300),
                       f"a {res}x{res} bake with {total} samples at MNI {mni:.6g}", work_hint, param="supersample",
                       mentions=("resolution", "supersample", "mni"), other=res * res * BAKE_TEXEL_OPS)
    p = surface_params(texton, setup, seed, "exact", up, side)
    sums = _sample_sums(p, setup, tx, nx, ny, cnormals, texel, device, method, bar)
    bar.close()
    values = (sums / (nx * ny)[:, None]).astype(np.float32)
    c = texton.channels
    texture = np.empty((res, res, c), np.float32)
    texture[:] = texton.mean3[:c] if isinstance(texton, TilingModel) else mean_colour(texton)
    texture[tx.rows, tx.cols] = values[:, :c]
    # one normal per vertex for the file (glTF NORMAL): vertices split where their corners' do
    vsplit, faces, vnormals = split_corners(faces, cnormals, len(vertices))
    out = _textured(vertices[vsplit], faces, uvs[vsplit], vnormals, texture, trimesh)
    axis = up_vector(up)
    return BakedMesh(out, texture, covered, per_texel, float(np.sum((nx * ny)[tx.inner])) / n_cov, source,
                     (float(axis[0]), float(axis[1]), float(axis[2])), dtype)


def _bake_uvs(mesh, vertices, cnormals, faces, own_uv, res, gutter, charts, device, name, bar):
    """The bake's UVs and the texels their triangles claim: the mesh's own (checked, refused where
    they overlap), or an atlas. -> (source, vertices, corner normals, faces, uvs, corners, owner), the
    first four re-indexed by the atlas's vertex map when there is one."""
    if own_uv is not None:
        uvs, notes = _mesh_uvs(own_uv, vertices, faces, name)
        source, (corners, owner, overlap) = "mesh", _claimed(uvs, faces, res, device, name)
        if overlap > MAX_OVERLAP:
            raise TextonError(f"{name}: its UVs overlap ({100 * overlap:.1f} % of the covered texels lie on two or "
                              "more triangles), so one texel would stand for several surface points; use "
                              "uv='atlas' (--uv atlas) to ignore them")
        for note in notes + overlap_note(overlap):  # Blender's and xatlas's users are told the same
            warnings.warn(f"{name}: {note}", stacklevel=2)
    else:
        source = "atlas"
        # xatlas keeps charts 2 paddings apart (measured: 9 texels or more on the bunny at 1024² with a
        # padding of 4), so each gutter texel is nearer its own chart than any other
        vmap, faces, uvs, _ = make_atlas(vertices, faces, res, max(gutter, 1), charts=charts, name=name,
                                         step=bar.step)
        corners, owner, overlap = _claimed(uvs, faces, res, device, name)
        if overlap > MAX_OVERLAP and charts != "xatlas":
            # a chart of normal clusters that overlaps itself (a helix seen along its axis): xatlas's own charts
            vmap, faces, uvs, _ = make_atlas(vertices, np.asarray(mesh.faces, np.int64), res, max(gutter, 1),
                                             charts="xatlas", name=name)
            corners, owner, overlap = _claimed(uvs, faces, res, device, name)
        cnormals = _corners_of(cnormals, np.asarray(mesh.faces, np.int64), vmap, faces)
        vertices = vertices[vmap]
    return source, vertices, cnormals, faces, uvs, corners, owner


@dataclass(frozen=True)
class _TexelFaces:
    """The baked texels (``rows``, ``cols``; ``inner``: covered, not gutter) and, for each, its
    face ``f`` (3-D corners ``p3``, unit normal ``fn``), the face's first UV
    corner ``a2`` and the inverse ``inv`` of its UV edge matrix (texel offsets → barycentric
    weights), and the texel's footprint in texton texels (``side_x``, ``side_y``, ``area``)."""

    rows: np.ndarray
    cols: np.ndarray
    inner: np.ndarray
    f: np.ndarray
    a2: np.ndarray
    inv: np.ndarray
    p3: np.ndarray
    fn: np.ndarray
    side_x: np.ndarray
    side_y: np.ndarray
    area: np.ndarray


def _host_view(a: np.ndarray, dtype) -> wp.array:
    """A Warp array on the host over ``a`` (int64 for ``wp.int64``, float64 otherwise; no copy
    where ``a`` already is one)."""
    return wp.array(np.ascontiguousarray(a, np.int64 if dtype is wp.int64 else np.float64), dtype=dtype,
                    device="cpu", copy=False)


def _texel_faces(owner, covered, faces, corners, vertices, cnormals, texel) -> _TexelFaces:
    """Each baked texel's face and that face's affine map (texel coordinates → barycentric
    weights, 3-D point), with the texel's footprint on the surface (``kernels/surface_bake.py``
    ``texel_faces``, one thread per texel)."""
    rows, cols = np.nonzero(owner >= 0)
    inner = covered[rows, cols]
    f = owner[rows, cols].astype(np.int64)
    n = len(f)
    a2 = np.empty((n, 2), np.float64)
    inv = np.empty((n, 2, 2), np.float64)
    p3 = np.empty((n, 3, 3), np.float64)
    fn = np.empty((n, 3), np.float64)
    footprint = np.empty((n, 3), np.float64)

    view = _host_view
    inputs = [view(f, wp.int64), view(faces, wp.int64), view(corners, wp.vec2d), view(vertices, wp.vec3d),
              view(cnormals, wp.vec3d), wp.float64(texel)]
    outputs = [view(a2, wp.vec2d), view(inv, wp.mat22d), view(p3, wp.vec3d), view(fn, wp.vec3d), view(footprint, wp.vec3d)]
    split_launch("cpu", surface_bake, n, lambda s0, s1: wp.launch(
        surface_bake.texel_faces, dim=s1 - s0, device="cpu", inputs=[*inputs, s0, *outputs]))
    return _TexelFaces(rows, cols, inner, f, a2, inv, p3, fn, footprint[:, 0], footprint[:, 1], footprint[:, 2])


def _sample_counts(tx: _TexelFaces, supersample) -> tuple[np.ndarray, np.ndarray]:
    """Samples per texel along its x and y sides: ``supersample`` each, or as many as its
    footprint needs (SAMPLE_DENSITY per texton texel, at most MAX_SAMPLES_SIDE)."""
    if supersample is None:
        nx = np.clip(np.ceil(tx.side_x * SAMPLE_DENSITY), 1, MAX_SAMPLES_SIDE).astype(np.int64)
        ny = np.clip(np.ceil(tx.side_y * SAMPLE_DENSITY), 1, MAX_SAMPLES_SIDE).astype(np.int64)
    else:
        nx = ny = np.full(len(tx.f), supersample, np.int64)
    return nx, ny


def _sample_arrays(tx: _TexelFaces, cnormals: np.ndarray) -> dict:
    """The texels' face data as Warp arrays on the host (views of the NumPy arrays), for
    :func:`_sample_points`."""
    view = _host_view
    return {"cols": view(tx.cols, wp.int64), "rows": view(tx.rows, wp.int64), "a2": view(tx.a2, wp.vec2d),
            "inv": view(tx.inv, wp.mat22d), "p3": view(tx.p3, wp.vec3d), "faces": view(tx.f, wp.int64),
            "cnormals": view(cnormals, wp.vec3d), "fn": view(tx.fn, wp.vec3d)}


def _sample_points(arrays: dict, g: np.ndarray, offsets: np.ndarray, texel: float) -> tuple[np.ndarray, np.ndarray]:
    """(points in texton texels, unit normals), float64 (len(g) · len(offsets), 3): the samples of
    texels ``g`` at ``offsets`` from their centres (``kernels/surface_bake.py`` ``sample_points``)."""
    n = len(g) * len(offsets)
    pts = np.empty((n, 3), np.float64)
    nrm = np.empty((n, 3), np.float64)
    texels: wp.array = wp.array(np.ascontiguousarray(g, np.int64), dtype=wp.int64, device="cpu", copy=False)
    offs: wp.array = wp.array(np.ascontiguousarray(offsets, np.float64), dtype=wp.vec2d, device="cpu")
    wp_pts: wp.array = wp.array(pts, dtype=wp.vec3d, device="cpu", copy=False)
    wp_nrm: wp.array = wp.array(nrm, dtype=wp.vec3d, device="cpu", copy=False)
    a = arrays
    split_launch("cpu", surface_bake, n, lambda s0, s1: wp.launch(
        surface_bake.sample_points, dim=s1 - s0, device="cpu",
        inputs=[texels, offs, a["cols"], a["rows"], a["a2"], a["inv"], a["p3"], a["faces"], a["cnormals"], a["fn"],
                wp.float64(texel), s0, wp_pts, wp_nrm]))
    return pts, nrm


def _sample_sums(p, setup, tx: _TexelFaces, nx, ny, cnormals, texel, device, method, bar) -> np.ndarray:
    """The sum of the surface noise over each texel's nx × ny samples, in rounds of at most
    SAMPLES_PER_ROUND samples of texels with the same counts."""
    sums = np.zeros((len(tx.f), 3), np.float64)
    arrays = _sample_arrays(tx, cnormals)
    kinds = sorted(set(zip(nx.tolist(), ny.tolist())))
    per_kind = [max(1, SAMPLES_PER_ROUND // (sx * sy)) for sx, sy in kinds]
    rounds = sum(-(-int(np.count_nonzero((nx == sx) & (ny == sy))) // n) for (sx, sy), n in zip(kinds, per_kind))
    done = 0
    for (sx, sy), per_round in zip(kinds, per_kind):
        group = np.flatnonzero((nx == sx) & (ny == sy))
        ox, oy = np.meshgrid((np.arange(sx) + 0.5) / sx - 0.5, (np.arange(sy) + 0.5) / sy - 0.5)
        offsets = np.stack([ox.ravel(), oy.ravel()], axis=1)  # sample offsets from the texel centre
        for g0 in range(0, len(group), per_round):
            g = group[g0:g0 + per_round]
            pts, nrm = _sample_points(arrays, g, offsets, texel)
            vals = evaluate_points(p, setup, pts, nrm, None, device, method)
            if vals.shape[1] == 1:
                # one channel: each texel's samples added one after another, the order
                # in which NumPy sums the strided axis of the three-channel form
                sums[g, :1] += np.ascontiguousarray(vals.reshape(len(g), len(offsets)).T).sum(axis=0)[:, None]
            else:
                sums[g] += vals.reshape(len(g), len(offsets), 3).sum(axis=1)  # g holds distinct texels
            done += 1
            bar.round(done, rounds)
    return sums


def check_bake_arguments(texton: Texton | TilingModel, resolution: int, *, mni: float = 60.0, supersample: int | None = None,
                         uv: str = "auto") -> None:
    """Refuse, from the arguments alone (before any mesh is read), a bake that no mesh could
    make within the budgets.

    What does not depend on the mesh: the memory of the texture's setup
    (``BYTES_PER_TEXEL`` a texel), the work of its texels' setup (``BAKE_TEXEL_OPS``
    a texel), and the fewest samples it can take, each at the fewest operations a
    point can cost (:func:`~warp_texton.surface.points.floor_visits`): ``supersample``² per
    covered texel, over at least ``ATLAS_COVERAGE`` of the texture for ``uv="atlas"``
    (a mesh's own UVs may cover less, so other choices count the setup alone).
    :func:`bake_mesh` prices each mesh again, from its area and UVs, before its atlas.

    Raises
    ------
    TextonError
        Over the memory or the work budget, naming ``resolution``, ``supersample``
        and ``mni``; and the errors of :func:`bake_mesh` for these arguments.
    """
    check_surface_model(texton, mni=(mni, SURFACE_MNI))
    res = check_int(resolution, "resolution", minimum=1, maximum=MAX_RESOLUTION)
    supersample, _ = _check_choices(res, uv, supersample, None, CHART_METHODS[0], PNG_DTYPES[0])
    what = f"a {res}x{res} bake" + ("" if supersample is None else f" with {supersample}x{supersample} samples a texel")
    check_memory(res * res * BYTES_PER_TEXEL, what, "use a smaller resolution", param="resolution")
    setup = surface_setup(texton, mni)
    samples = (ATLAS_COVERAGE * res * res if uv == "atlas" else 1.0) * (supersample or 1) ** 2
    check_work(res * res * BAKE_TEXEL_OPS + samples * floor_visits(setup), f"{what} at MNI {mni:.6g}",
               "use a smaller resolution, a smaller supersample or a lower mni", param="supersample",
               mentions=("resolution", "supersample", "mni"), early=True)


def _mesh_uvs(own_uv: np.ndarray, vertices: np.ndarray, faces: np.ndarray, name: str):
    """(the mesh's UVs checked, the warnings a bake on them gives); UVs that cannot hold
    a bake are one TextonError naming the mesh, with the ``uv='atlas'`` hint."""
    try:
        uvs = check_uvs(own_uv, len(vertices))
        return uvs, uv_face_notes(uvs, faces, vertices)
    except TextonError as exc:
        raise TextonError(f"{name}: {exc}; use uv='atlas' (--uv atlas) to ignore them") from None


def _check_choices(res: int, uv, supersample, gutter, charts, dtype) -> tuple[int | None, int]:
    """The checked ``supersample`` and ``gutter`` of a bake (its default for None), after
    ``uv``, ``charts`` and ``dtype``."""
    if not isinstance(uv, str) or uv not in UV_MODES:  # an array would compare element by element
        raise TextonError(f"uv must be one of {', '.join(UV_MODES)}, got {uv!r:.40}".replace("\n", " "))
    if supersample is not None:
        supersample = check_int(supersample, "supersample", minimum=1)
        if supersample > MAX_SUPERSAMPLE:
            raise TextonError(f"supersample must be at most {MAX_SUPERSAMPLE} samples per side, got {supersample}")
    gutter = default_gutter(res) if gutter is None else check_int(gutter, "gutter", minimum=0,
                                                                   maximum=min(MAX_GUTTER, max(2, res // 4)))
    if not isinstance(charts, str) or charts not in CHART_METHODS:
        raise TextonError(f"charts must be one of {', '.join(CHART_METHODS)}, got {charts!r:.40}")
    if isinstance(dtype, np.ndarray) or dtype not in PNG_DTYPES:
        raise TextonError(f"dtype must be 'uint8' or 'uint16' (the PNG sample types a baked texture is written "
                          f"with), got {dtype!r:.40}; for float values write the texture as EXR (texture='exr')",
                          "dtype")
    return supersample, gutter


def _extend(owner: np.ndarray, covered: np.ndarray, gutter: int) -> np.ndarray:
    """The owner map with the gutter: texels within ``gutter`` of a chart (and in none)
    take the triangle of the nearest chart texel."""
    if gutter <= 0 or covered.all():
        return owner
    import scipy.ndimage as ndi

    dist, (ii, jj) = ndi.distance_transform_edt(~covered, return_indices=True)
    ring = (dist > 0) & (dist <= gutter)
    out = owner.copy()
    out[ring] = owner[ii[ring], jj[ring]]
    return out


def to_8bit(texture: np.ndarray) -> np.ndarray:
    """RGB 8-bit of a texture (grey spread to RGB): the rule of every written 8-bit
    texture (:func:`warp_texton.surface.mesh_files.texture_8bit`), values clipped to [0, 1]."""
    return texture_8bit(texture)[0]


def _textured(vertices, faces, uvs, normals, texture, trimesh):
    # the bake's normals travel with the mesh (glTF NORMAL), so that renderers shade
    # across the atlas's seams as the noise was evaluated: smoothly
    from PIL import Image

    image = Image.fromarray(to_8bit(texture))
    material = trimesh.visual.material.PBRMaterial(name="warp_texton", baseColorTexture=image,
                                                   metallicFactor=0.0, roughnessFactor=1.0)
    visual = trimesh.visual.TextureVisuals(uv=uvs, material=material)
    return trimesh.Trimesh(vertices=vertices, faces=faces, vertex_normals=normals, visual=visual, process=False)
