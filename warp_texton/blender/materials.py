"""What the Blender add-on computes, without ``bpy``: the model of an image, its OSL shader, its bakes.

The add-on (``addon/__init__.py``, in Blender) turns these into nodes. Kept here, in the package
that Blender installs from the extension's wheel, so that the work is tested and typed as the rest
of the package is, and the add-on holds only Blender's side (properties, nodes, images).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..core.errors import TextonError
from ..files.images import read_image
from ..model.analysis import analyze
from ..model.texton import Texton
from ..model.tiling import TilingModel
from ..noise.noise_options import NoiseOptions
from ..runtimes import osl
from ..runtimes.osl.texton import SURFACE_FILE
from ..runtimes.osl.tiling import OSL_FILE as TILING_FILE

#: Progress: called with the fraction done, in [0, 1], and what is being done.
Progress = Callable[[float, str], None]
#: The MNI of the surface shader and bakes (surface noise wants about 60: ``surface_noise``).
SURFACE_MNI = 60.0
METHODS = ("auto", "texton", "tiling")


def _quiet(fraction: float, message: str) -> None:
    return None


def model_of_image(path, *, method: str = "auto", seed: int = 0,
                   progress: Progress | None = None) -> Texton | TilingModel:
    """The model of the image file ``path``: :func:`~warp_texton.analyze` with ``method`` ("auto": the
    texton or the tiling model, as the structure score chooses)."""
    say = progress or _quiet
    if method not in METHODS:
        raise TextonError(f"method must be one of {', '.join(METHODS)}, got {method!r}", param="method")
    say(0.0, f"reading {path}")
    image = read_image(path)
    say(0.1, "analysing the image" + (" (texton or tiling, by the structure score)" if method == "auto" else ""))
    model = analyze(image, method=method, seed=seed)
    say(0.5, f"the {model_kind(model)} model")
    return model


def model_kind(model) -> str:
    """``"tiling"`` or ``"texton"``."""
    return "tiling" if isinstance(model, TilingModel) else "texton"


@dataclass(frozen=True)
class OslShader:
    """An OSL shader for a Script node: its ``name`` (the text block's), its ``source``, and how its
    coordinates come: ``"surface"`` (P and N, the texton's surface noise) or ``"plane"`` (a point of
    the plane, given through the ``Vector`` input: the add-on projects the object's coordinates on
    three planes)."""

    name: str
    source: str
    coordinates: str


def osl_shader(model, *, texel_size: float = 0.01, seed: int = 0) -> OslShader:
    """The OSL shader of ``model`` with ``texel_size`` object units per texel: texton noise on the
    surface (infinite, no UVs), or the tiling model's plane shader."""
    if isinstance(model, TilingModel):
        files = osl.files(model, noise=NoiseOptions(seed=seed), texel_size=texel_size)
        return OslShader(TILING_FILE, files[TILING_FILE].decode(), "plane")
    files = osl.files(model, noise=NoiseOptions(mni=SURFACE_MNI, seed=seed), texel_size=texel_size)
    return OslShader(SURFACE_FILE, files[SURFACE_FILE].decode(), "surface")


@dataclass(frozen=True)
class Bake:
    """A bake on a mesh's UVs: ``colour`` (RES, RES, 3) in the values the example stores (sRGB-coded)
    and ``normal`` (RES, RES, 3) in [0, 1], tangent space (OpenGL's convention, Blender's), row 0 at
    the top (v = 1)."""

    colour: np.ndarray
    normal: np.ndarray


def bake_corners(model, positions, normals, uvs, *, texel_size: float = 0.01, resolution: int = 1024,
                 seed: int = 0, strength: float = 1.0, progress: Progress | None = None) -> Bake:
    """Bake ``model`` on a triangle mesh given by its corners, as Blender's loop triangles hold them:
    ``positions``, ``normals`` (the corner normals) and ``uvs``, each (3 T, 3 or 2), three rows a
    triangle. The noise is the surface noise (:func:`~warp_texton.bake_mesh`) at the points the UVs
    map; the normal texture comes from the colour's luminance (:func:`warp_texton.surface.relief.baked_normals`)."""
    import trimesh

    from ..surface.bake import bake_mesh
    from ..surface.relief import baked_normals

    say = progress or _quiet
    p = np.asarray(positions, np.float64).reshape(-1, 3)
    n = np.asarray(normals, np.float64).reshape(-1, 3)
    uv = np.asarray(uvs, np.float64).reshape(-1, 2)
    if not (len(p) == len(n) == len(uv)) or len(p) == 0 or len(p) % 3:
        raise TextonError(f"positions, normals and uvs must hold three corners a triangle, as many of each; got "
                          f"{len(p)}, {len(n)} and {len(uv)}", param="positions")
    faces = np.arange(len(p)).reshape(-1, 3)
    mesh = trimesh.Trimesh(p, faces, vertex_normals=n, visual=trimesh.visual.TextureVisuals(uv=uv), process=False)
    say(0.6, f"baking {resolution} x {resolution} texels")
    # a tiling model takes the default MNI only (it has none): SURFACE_MNI is that default
    baked = bake_mesh(mesh, model, texel_size, resolution=resolution, mni=SURFACE_MNI, seed=seed, uv="mesh",
                      normals="mesh", name="the object")
    colour = np.asarray(baked.texture, np.float32)
    if colour.shape[2] == 1:
        colour = np.repeat(colour, 3, axis=2)
    say(0.9, "the normal map")
    return Bake(colour, baked_normals(baked, strength))
