"""Ray-cast renders of meshes with surface texton noise (CGF §6, Fig. 8): the
camera, the ray cast, :func:`render_mesh`, and :func:`render_baked` (a bake's texture looked up at each hit).

The defaults live in a Z-up frame (view, light) and turn with the world's up
axis (:func:`warp_texton.surface.frames.up_rotation`), so a Y-up glTF scene is seen as a
Z-up one is.

Kernels driven here: ``warp_texton.kernels.surface_render``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import warp as wp

from ..core.checks import as_real_array, check_positive, check_seed, check_shape
from ..core.runtime import resolve_device, split_launch
from ..core.errors import TextonError
from .frames import UP, as_direction, as_point, up_rotation, up_vector
from ..kernels import surface_render
from ..core.limits import check_memory, check_work
from .atlas import check_uvs, mesh_uvs
from .mesh import CREASE_ANGLE, check_mesh, check_normals, corner_normals, default_texel_size
from .points import (check_method, evaluate_points, floor_visits, plan_points, surface_params, surface_setup,
                      texel_positions)
from ..model.texton import Texton
from ..model.tiling import TilingModel
from .tiling import SURFACE_MNI, check_surface_model

#: Largest render, in pixels (64 Mpx: about 4 GB at the peak of a render).
MAX_RENDER_PIXELS = 1 << 26
#: Operations (the unit of limits.check_work) of one ray of the cast: Warp's BVH answers
#: ``mesh_query_ray`` in about 0.55 µs on one core of a two-core CPU (docs/limits.md).
CAST_OPS = 500.0
#: Default orbit of renders: azimuth and elevation (degrees) of the camera seen from
#: the mesh's centre, in the Z-up frame (azimuth 0 along +X, −90 along −Y: the front).
ORBIT = (-55.0, 25.0)
#: Default light direction in the Z-up frame (towards the light).
LIGHT = (0.4, -0.5, 1.0)


def orbit_direction(orbit, up=UP) -> np.ndarray:
    """Unit vector from a mesh's centre towards the camera for ``orbit`` =
    (azimuth, elevation) in degrees: azimuth about the up axis from the world's
    right (x), −90 looking at the front; elevation above the horizon."""
    try:
        az, el = as_real_array(orbit, "orbit", "a pair (azimuth, elevation) of numbers, in degrees").tolist()
    except (TypeError, ValueError):
        raise TextonError(f"orbit must be a pair (azimuth, elevation) in degrees, got {orbit!r:.60}") from None
    if not (math.isfinite(az) and math.isfinite(el)) or abs(el) >= 90.0:
        raise TextonError(f"orbit elevation must be finite and strictly between -90 and 90 degrees, got {orbit!r}")
    a, e = math.radians(az), math.radians(el)
    return up_rotation(up) @ np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])


@dataclass(frozen=True)
class Camera:
    """A pinhole camera: ``position`` looks at ``target``; ``fov`` is vertical, degrees.

    A frozen dataclass, checked when made; :meth:`Camera.framing` makes one that
    frames a mesh. :func:`render_mesh` takes it as ``camera``.

    Parameters
    ----------
    position : (x, y, z)
        The eye, world units.
    target : (x, y, z)
        The point the camera looks at, world units; not ``position``.
    up : (x, y, z)
        The direction that appears upwards in the image (need not be
        orthogonal to the view, nor unit); default z.
    fov : float
        Vertical field of view in degrees, 0 < fov < 180; default 35.

    Raises
    ------
    TextonError
        For a ``fov`` out of range or not a number, positions that are not
        finite (x, y, z) numbers, a ``target`` equal to ``position``, or an
        ``up`` that is zero or along the view.

    Examples
    --------
    >>> from warp_texton import Camera
    >>> Camera(position=(0.0, -6.0, 1.0), target=(0.0, 0.0, 0.0), fov=30.0)
    Camera(position=(0.0, -6.0, 1.0), target=(0.0, 0.0, 0.0), up=(0.0, 0.0, 1.0), fov=30.0)
    """

    position: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float] = UP
    fov: float = 35.0

    def __post_init__(self):
        fov = check_positive(self.fov, "camera.fov")
        if fov >= 180.0:
            raise TextonError(f"camera.fov must be below 180 degrees, got {fov}")
        eye, target = (as_point(v, name) for v, name in ((self.position, "camera.position"),
                                                         (self.target, "camera.target")))
        forward = as_direction(target - eye, "camera.target - camera.position")
        up = as_direction(self.up, "camera.up")
        if np.linalg.norm(np.cross(forward, up)) < 1e-9:
            raise TextonError("camera.up is parallel to the view direction")
        object.__setattr__(self, "position", tuple(float(v) for v in eye))
        object.__setattr__(self, "target", tuple(float(v) for v in target))
        object.__setattr__(self, "up", tuple(float(v) for v in np.asarray(self.up, np.float64).reshape(3)))
        object.__setattr__(self, "fov", fov)

    @classmethod
    def framing(cls, mesh, direction=None, fov: float = 35.0, up=UP, zoom: float = 1.0, *,
                orbit=ORBIT) -> "Camera":
        """A camera that frames ``mesh``: the one :func:`render_mesh` uses by default.

        It looks at the centre of the mesh's bounding box from ``direction``,
        or by default from ``orbit``, far enough for the bounding sphere to
        fit the view with 5 % to spare. Its ``up`` is the world's up.

        Parameters
        ----------
        mesh : trimesh.Trimesh
            Only its bounding box is read.
        direction : (x, y, z), optional
            From the centre towards the camera (any non-zero length); when
            given, ``orbit`` is not used.
        fov : float
            Vertical field of view in degrees, in (0, 180); default 35.
        up : str or (x, y, z)
            The world's up axis, "x", "y", "z" or a vector: the camera's up
            and the frame of ``orbit`` (see :func:`render_mesh`); default z.
        zoom : float
            > 0; above 1 moves closer (the distance is divided by it).
        orbit : (azimuth, elevation)
            Degrees, for the up axis ``up`` (:func:`orbit_direction`): azimuth
            about the up axis from the world's right, −90 from the front;
            elevation above the horizon, in (−90, 90). Default (−55, 25)
            (``ORBIT``).

        Returns
        -------
        Camera

        Raises
        ------
        TextonError
            For a zero ``direction``, a bad ``orbit``, ``up`` or ``fov``, and
            a ``zoom`` that is not a number > 0.

        Examples
        --------
        >>> import trimesh
        >>> from warp_texton import Camera
        >>> torus = trimesh.creation.torus(major_radius=1.0, minor_radius=0.35)
        >>> cam = Camera.framing(torus)  # the default orbit of render_mesh
        >>> cam.fov, [round(float(c), 2) for c in cam.position]
        (35.0, [3.52, -5.03, 2.86])
        >>> top = Camera.framing(torus, direction=(0, -0.2, 1), zoom=1.5)
        >>> front = Camera.framing(torus, orbit=(-90, 0))  # from the front (−y), level
        >>> [round(float(c), 2) + 0.0 for c in front.position]
        [0.0, -6.78, 0.0]
        """
        lo, hi = np.asarray(mesh.bounds, dtype=np.float64)
        centre = (lo + hi) / 2.0
        radius = max(np.linalg.norm(hi - lo) / 2.0, 1e-9)
        d = orbit_direction(orbit, up) if direction is None else as_direction(direction, "direction")
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


def cast_rays(mesh, shape, camera: Camera | None = None, *, up=UP, orbit=None, fov=None, light=None,
              device=None, normals: str = "angle", crease_angle: float = CREASE_ANGLE) -> RayHits:
    """Cast one ray per pixel at ``mesh`` (the camera, orbit, fov, up, light, normals and
    crease angle of :func:`render_mesh`): the face hit, its barycentric weights, the
    shading normal (the face's corner normals interpolated,
    :func:`warp_texton.surface.mesh.corner_normals`) and the diffuse shade. The BVH holds the vertices in float32 around the centre of their
    bounding box, so meshes far from the origin are hit as precisely as near ones.
    Only the pixels of the mesh's screen box (:func:`screen_box`) cast rays.

    Returns
    -------
    RayHits
    """
    h, w = check_shape(shape, max_pixels=MAX_RENDER_PIXELS)
    check_normals(normals, crease_angle)
    box, (face_b, bary_b, nrm_b, shade_b), vertices, faces = _cast_box(mesh, (h, w), camera, up, orbit, fov, light,
                                                                       device, (normals, crease_angle))
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


def _cast_box(mesh, shape, camera, up, orbit, fov, light, device, normals=("angle", CREASE_ANGLE)):
    """The ray cast of :func:`cast_rays` over the mesh's screen box only: (box, (face,
    bary (u, v), normal, shade) of the box's pixels, float64 vertices, int64 faces);
    ``normals`` is (mode, crease angle) of :func:`warp_texton.surface.mesh.corner_normals`."""
    mesh = check_mesh(mesh)
    h, w = shape
    rot = up_rotation(up)
    if camera is None:
        cam = Camera.framing(mesh, fov=35.0 if fov is None else fov, up=up, orbit=ORBIT if orbit is None else orbit)
    elif orbit is not None or fov is not None:
        raise TextonError("give either camera or orbit/fov, not both")
    else:
        cam = camera
    if not isinstance(cam, Camera):
        raise TextonError(f"camera must be a warp_texton.Camera, got {type(cam).__name__}")
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    origin = (lo + hi) / 2.0  # the ray cast runs in float32 around this point
    eye = np.asarray(cam.position, dtype=np.float64)
    # a Camera is checked when made: the view and up directions are non-zero and apart
    forward = as_direction(np.asarray(cam.target, dtype=np.float64) - eye, "camera.target - camera.position")
    right = np.cross(forward, as_direction(cam.up, "camera.up"))
    right /= np.linalg.norm(right)
    cam_up = np.cross(right, forward)
    light_dir = rot @ as_direction(LIGHT, "light") if light is None else as_direction(light, "light")
    check_memory(h * w * 60.0, f"a {w}x{h} render", "render fewer pixels")
    device = resolve_device(device)
    c = surface_render.Camera()
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
        points: wp.array = wp.array(vertices - origin, dtype=wp.vec3)
        indices: wp.array = wp.array(faces_np.astype(np.int32).reshape(-1), dtype=wp.int32)
        wmesh = wp.Mesh(points=points, indices=indices)
        corners: wp.array = wp.array(corner_normals(mesh, normals[0], normals[1], up).reshape(-1, 3), dtype=wp.vec3)
        outs = [wp.empty((rh, rw), dtype=t) for t in (wp.int32, wp.vec2, wp.vec3, wp.float32)]

        def band(a, b):
            wp.launch(surface_render.cast_rays, dim=(b - a, rw), inputs=[wmesh.id, corners, c, h, w, r0 + a, c0,
                                                            *(o[a:b] for o in outs)])

        split_launch(device, surface_render, rh, band)
        return (r0, r1, c0, c1), tuple(o.numpy() for o in outs), vertices, faces_np


def render_mesh(
    mesh,
    texton: Texton | TilingModel,
    shape=(512, 512),
    *,
    texel_size: float | None = None,
    camera: Camera | None = None,
    mni: float = 60.0,
    seed: int = 0,
    device=None,
    background=(0.92, 0.92, 0.92),
    light=None,
    up=UP,
    side=None,
    orbit=None,
    fov=None,
    method: str = "auto",
    normals: str = "angle",
    crease_angle: float = CREASE_ANGLE,
) -> np.ndarray:
    """Ray-cast ``mesh`` with surface texton noise and simple diffuse shading.

    The texture's detail does not depend on the tessellation (the noise is
    evaluated at every pixel's hit, not at the vertices), and a mesh far from
    the origin renders as well as one near it (see Notes). Missed pixels get
    ``background``.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        As in :func:`texture_mesh`.
    texton : Texton or TilingModel
        As in :func:`surface_noise` (a tiling model refuses ``mni`` and ``method``).
    shape : (height, width)
        Image size in pixels, at most 2**26 pixels (``MAX_RENDER_PIXELS``).
    texel_size : float, optional
        World units per texel; default: the bounding-box diagonal / 256
        (``mesh.default_texel_size``).
    camera : Camera, optional
        Default: ``Camera.framing(mesh, up=up, orbit=orbit, fov=fov)``
        (:meth:`Camera.framing`); not together with ``orbit`` or ``fov``.
    mni : float
        As in :func:`surface_noise`.
    seed : int
        As in :func:`surface_noise`.
    device : str, optional
        As in :func:`surface_noise`.
    background : (r, g, b)
        The colour of the pixels whose ray misses the mesh.
    light : (x, y, z), optional
        Towards the light (normalised here); default (0.4, −0.5, 1) for Z
        up (``LIGHT``), turned with ``up``.
    up : str or (x, y, z)
        The world's up axis, "x", "y", "z" or a vector (default z): the
        frame rule's ``up``, the default camera's up, and the frame of
        ``orbit`` and of the default light. glTF/GLB
        files are Y-up by definition (``up="y"``); a mesh batch picks it by
        file type.
    side : (x, y, z), optional
        The frame rule's ``side`` (default: the world's right for ``up``).
    orbit : (azimuth, elevation), optional
        Of the default camera, degrees: azimuth about the up axis from the
        world's right, −90 from the front (−y for Z up, +z for Y up);
        elevation above the horizon, in (−90, 90). Default (−55, 25): from
        the front left, above (:func:`orbit_direction`).
    fov : float, optional
        Vertical field of view of the default camera, degrees (default 35).
    method : {"auto", "blocks", "points"}
        As in :func:`surface_noise` (the same image).
    normals : {"angle", "smooth", "flat", "mesh"}
        The normals the noise and the shading see, interpolated across each
        face from its corners (:func:`warp_texton.surface.mesh.corner_normals`):
        "angle" (default) splits them at edges sharper than ``crease_angle``,
        as Blender's auto smooth does, so a box's faces are flat and a
        sphere is smooth; "smooth" never splits them, "flat" always does;
        "mesh" takes the vertex normals the mesh holds (a file's).
    crease_angle : float
        Degrees, 0 to 180 (default 30: Blender's); with ``normals="angle"``.

    Returns
    -------
    float32 array (height, width, 3)
        In [0, 1]; grey textons are shown grey.

    Raises
    ------
    TextonError
        For the ``mesh`` and ``texton`` errors of :func:`texture_mesh`; a bad
        ``shape``, ``texel_size``, ``seed``, ``device`` or ``method``; a
        ``camera`` that is not a :class:`Camera` or given together with
        ``orbit`` or ``fov``; a ``normals`` or ``crease_angle`` that
        :func:`warp_texton.surface.mesh.corner_normals` refuses; a ``fov`` outside (0, 180); a bad ``orbit`` or
        ``up``; a zero ``light``; a ``background`` that is not a finite RGB
        triple; the ``mni`` errors of :func:`surface_noise`; a render over
        the memory budget, or over the work budget (the ray cast and the
        noise at its hits: priced before the cast as if every pixel hit the
        mesh at the least a point can cost, then by the path the hits take);
        and vertices too far from the origin for
        ``texel_size`` (the error of :func:`surface_noise`, "the mesh's
        vertices lie too far from the origin …", also for absurd texel
        sizes such as 1e-300): never a silent background.

    Notes
    -----
    The mesh is ray-cast with Warp (a ``wp.Mesh`` BVH and
    ``wp.mesh_query_ray``), in float32 world units around the centre of its
    bounding box, only over the pixels of its screen box. Each hit is placed
    in float64 from the hit face's vertices and its barycentric weights, and
    the noise is evaluated there for all hits at once (in blocks, as
    :func:`surface_noise`), with the frame rule of :func:`tangent_frames`.
    The normal interpolates the face's corner normals (split at edges
    sharper than ``crease_angle``, as Blender's Smooth by Angle splits them;
    vertices at one position count as one, so shared and split vertices
    render alike); the shading is 0.3 + 0.7 |⟨n, light⟩|. Derivation and
    measurements: docs/model.md §12, "The renderer" and "Normals".

    References
    ----------
    CGF §6 (surface noise), Fig. 8 (textured meshes without UVs).

    Examples
    --------
    >>> import trimesh
    >>> from warp_texton import read_image, analyze, render_mesh, Camera, write_image
    >>> from warp_texton.demo import demo_texture_path
    >>> texton = analyze(read_image(demo_texture_path()), size=32, iterations=30)
    >>> torus = trimesh.creation.torus(major_radius=1.0, minor_radius=0.35)
    >>> img = render_mesh(torus, texton, (96, 128), device="cpu")
    >>> img.shape, img.dtype
    ((96, 128, 3), dtype('float32'))
    >>> write_image("torus_grass.png", img)  # the number of pixels clipped
    0

    Closer, from above, with smaller texels (a finer texture), a white
    background and light from above:

    >>> near = render_mesh(torus, texton, (96, 128), texel_size=0.004,
    ...                    camera=Camera.framing(torus, direction=(0, -0.5, 1), zoom=1.6),
    ...                    background=(1, 1, 1), light=(0, 0, 1), seed=3, device="cpu")
    >>> near[0, 0].tolist()  # a corner that sees no torus
    [1.0, 1.0, 1.0]

    A Y-up mesh (the glTF convention) seen from the front right, with a wider
    field of view:

    >>> box = trimesh.creation.box(extents=(1, 3, 1))  # tall along y
    >>> upright = render_mesh(box, texton, (96, 64), up="y", orbit=(-60, 15), fov=45, device="cpu")
    """
    mesh = check_mesh(mesh)
    check_surface_model(texton, mni=(mni, SURFACE_MNI), method=(method, "auto"))
    h, w = check_shape(shape, max_pixels=MAX_RENDER_PIXELS)
    texel = default_texel_size(mesh) if texel_size is None else check_positive(texel_size, "texel_size")
    seed = check_seed(seed)
    check_method(method)
    check_normals(normals, crease_angle)
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    setup = surface_setup(texton, mni)
    texel_positions(vertices, texel, setup, "the mesh's vertices")  # refuses far meshes and tiny texels
    bg = check_background(background)
    what, hint = f"a {w}x{h} render at MNI {mni:.6g}", "use a smaller shape or a lower mni"
    # before the cast, as if every pixel hit the mesh at the fewest operations a point costs
    check_work(h * w * (CAST_OPS + floor_visits(setup)), what, hint, param="mni", mentions=("shape", "mni"), early=True)
    device = resolve_device(device)
    p = surface_params(texton, setup, seed, "exact", up, side)
    (r0, r1, c0, c1), (face, bary, nrm, shade), vertices, faces = _cast_box(mesh, (h, w), camera, up, orbit, fov,
                                                                            light, device, (normals, crease_angle))
    cast = (r1 - r0) * (c1 - c0) * CAST_OPS
    hit = face >= 0
    pixels = np.flatnonzero(hit.reshape(-1)).astype(np.int32)
    with wp.ScopedDevice(device):
        on_cpu = wp.get_device(device).is_cpu
        img = np.empty((h, w, 3), np.float32)
        img_w = wp.array(img, dtype=wp.vec3, copy=False) if on_cpu else wp.empty((h, w), dtype=wp.vec3)
        bg32 = bg.astype(np.float32)
        split_launch(device, surface_render, h, lambda a, b: wp.launch(surface_render.fill_image, dim=(b - a, w),
                                                          inputs=[img_w[a:b], wp.vec3(*bg32)]))
        if pixels.size:
            # the hits in float64 texel units from their faces' vertices and weights (as
            # RayHits.points), and their normals, in one pass
            pos_w, nrm_w = wp.empty(pixels.size, dtype=wp.vec3d), wp.empty(pixels.size, dtype=wp.vec3)
            pix: wp.array = wp.array(pixels, dtype=wp.int32)
            inputs = [wp.array(face.reshape(-1), dtype=wp.int32, copy=not on_cpu),
                      wp.array(bary.reshape(-1, 2), dtype=wp.vec2, copy=not on_cpu),
                      wp.array(nrm.reshape(-1, 3), dtype=wp.vec3, copy=not on_cpu),
                      wp.array(vertices, dtype=wp.vec3d), wp.array(faces.astype(np.int32).reshape(-1), dtype=wp.int32),
                      wp.float64(texel)]
            split_launch(device, surface_render, pixels.size, lambda a, b: wp.launch(
                surface_render.hit_points, dim=b - a, inputs=[pix[a:b], *inputs, pos_w[a:b], nrm_w[a:b]]))
            pos, hit_nrm = pos_w.numpy(), nrm_w.numpy()
            # the cast and the hits' noise, priced by the path the hits take
            plan = plan_points(setup, pos, hit_nrm, method)
            check_work(cast + plan.operations, what, hint, param="mni", mentions=("shape", "mni"))
            g = evaluate_points(p, setup, pos, hit_nrm, None, device, plan=plan)
            g_w: wp.array = wp.array(g, dtype=wp.vec3) if g.shape[1] == 3 else wp.array(g.reshape(-1), dtype=float)
            shade_w: wp.array = wp.array(shade.reshape(-1), dtype=wp.float32, copy=not on_cpu)
            split_launch(device, surface_render, pixels.size, lambda a, b: wp.launch(
                surface_render.shade_hits, dim=b - a, inputs=[pix[a:b], g_w[a:b], shade_w, c1 - c0, r0, c0,
                                                 int(texton.channels == 1), img_w]))
        if not on_cpu:
            img = img_w.numpy()
    return img


def lookup(texture: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Bilinear lookups of ``texture`` (R, R, C) at ``uv`` (N, 2), as a renderer makes them:
    texel (i, j) at ((j + ½)/R, 1 − (i + ½)/R), clamped at the border."""
    r, c = texture.shape[0], texture.shape[1]
    x = np.asarray(uv[:, 0], np.float64) * c - 0.5
    y = (1.0 - np.asarray(uv[:, 1], np.float64)) * r - 0.5
    x0 = np.floor(x)
    y0 = np.floor(y)
    fx = (x - x0)[:, None]
    fy = (y - y0)[:, None]
    x0 = x0.astype(np.int64)
    y0 = y0.astype(np.int64)
    xs = np.clip(x0, 0, c - 1), np.clip(x0 + 1, 0, c - 1)
    ys = np.clip(y0, 0, r - 1), np.clip(y0 + 1, 0, r - 1)
    t = np.asarray(texture, np.float64)
    top = t[ys[0], xs[0]] * (1 - fx) + t[ys[0], xs[1]] * fx
    bottom = t[ys[1], xs[0]] * (1 - fx) + t[ys[1], xs[1]] * fx
    return top * (1 - fy) + bottom * fy


def render_baked(baked, shape=(512, 512), *, camera=None, up=UP, orbit=None, fov=None, light=None,
                 background=(0.92, 0.92, 0.92), device=None) -> np.ndarray:
    """Render a textured mesh as a renderer shows it: each pixel's hit looks its UV up
    in the texture (bilinear), shaded as :func:`warp_texton.render_mesh` shades.

    Parameters
    ----------
    baked : BakedMesh or trimesh.Trimesh
        A bake, or a mesh with UVs and a material holding an image (a GLB or OBJ
        written by :func:`write_baked`, read back with trimesh).
    shape : (height, width)
        As in :func:`warp_texton.render_mesh`.
    camera : Camera, optional
        As in :func:`warp_texton.render_mesh`: the same camera gives the same pixels, so the two renders
        compare pixel by pixel.
    up : str or (x, y, z)
        As in :func:`warp_texton.render_mesh`.
    orbit : (azimuth, elevation), optional
        As in :func:`warp_texton.render_mesh`.
    fov : float, optional
        As in :func:`warp_texton.render_mesh`.
    light : (x, y, z), optional
        As in :func:`warp_texton.render_mesh`.
    background : (r, g, b)
        As in :func:`warp_texton.render_mesh`.
    device : str, optional
        As in :func:`warp_texton.render_mesh`.

    Returns
    -------
    float32 array (height, width, 3) in [0, 1]

    Raises
    ------
    TextonError
        For a mesh without UVs or texture image, and the camera errors of
        :func:`warp_texton.render_mesh`.

    Notes
    -----
    Lookups are bilinear and clamped at the texture's border. With the same
    camera the render differs from :func:`warp_texton.render_mesh`'s by the
    bake's resolution only (``tests/test_bake.py`` checks a written GLB this
    way).

    Examples
    --------
    >>> import numpy as np, trimesh
    >>> from warp_texton import Texton, bake_mesh, render_baked, render_mesh
    >>> t = Texton(np.random.default_rng(0).standard_normal((8, 8, 1)) / 8, [0.5])
    >>> torus = trimesh.creation.torus(major_radius=1.0, minor_radius=0.35)
    >>> baked = bake_mesh(torus, t, texel_size=0.02, resolution=128, device="cpu")
    >>> preview = render_baked(baked, (48, 64), device="cpu")
    >>> reference = render_mesh(torus, t, (48, 64), texel_size=0.02, device="cpu")
    >>> preview.shape, reference.shape
    ((48, 64, 3), (48, 64, 3))
    """
    if isinstance(getattr(baked, "texture", None), np.ndarray) and hasattr(baked, "mesh"):  # a BakedMesh (bake.py)
        mesh, texture = baked.mesh, np.clip(baked.texture, 0.0, 1.0)
    else:
        mesh = check_mesh(baked)
        uv = mesh_uvs(mesh)
        material = getattr(mesh.visual, "material", None)
        image = getattr(material, "baseColorTexture", None) or getattr(material, "image", None)
        if uv is None or image is None:
            raise TextonError("baked must be a BakedMesh or a mesh with UVs and a texture image")
        texture = np.asarray(image.convert("RGB"), np.float64) / 255.0
    from trimesh.visual import TextureVisuals

    assert isinstance(mesh.visual, TextureVisuals), "a baked mesh, or one with UVs"
    uv = check_uvs(np.asarray(mesh.visual.uv, np.float64), len(mesh.vertices))
    bg = check_background(background)
    hits = cast_rays(mesh, shape, camera, up=up, orbit=orbit, fov=fov, light=light, device=device)
    img = np.empty(hits.face.shape + (3,), np.float32)
    img[:] = bg.astype(np.float32)
    hit = hits.hit
    if hit.any():
        tri = hits.faces[hits.face[hit]]
        at = np.einsum("nk,nkd->nd", hits.bary[hit], uv[tri])
        values = lookup(texture, at)
        if values.shape[1] == 1:
            values = np.repeat(values, 3, axis=1)
        img[hit] = values * hits.shade[hit][:, None]
    return img
