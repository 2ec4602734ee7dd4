"""Noise on surfaces without UVs (CGF §6): frames, the 3-D block path, surface noise at points,
meshes and their files, UV atlases, ray-cast renders, bakes and batch jobs.
Kernels: ``warp_texton.kernels.surface_*``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..core.lazy import lazy_names

if TYPE_CHECKING:
    from .points import surface_noise
    from .frames import tangent_frames
    from .mesh import texture_mesh
    from .mesh_files import write_baked
    from .render import Camera, render_mesh
    from .bake import BakedMesh, bake_mesh
    from .render import render_baked
    from .jobs import SurfaceJob, run_surface_job

#: The module of each name of this room's face, imported on first use (PEP 562).
_LAZY = {
    "surface_noise": "points",
    "tangent_frames": "frames",
    "texture_mesh": "mesh",
    "write_baked": "mesh_files",
    "Camera": "render",
    "render_mesh": "render",
    "BakedMesh": "bake",
    "bake_mesh": "bake",
    "render_baked": "render",
    "SurfaceJob": "jobs",
    "run_surface_job": "jobs",
}

__all__ = ["BakedMesh", "Camera", "SurfaceJob", "bake_mesh", "render_baked", "render_mesh", "run_surface_job", "surface_noise", "tangent_frames", "texture_mesh", "write_baked"]


#: 0.2's warp_texton.surface was a module, warp_texton.surface.points now: its other names are reached here
#: with a DeprecationWarning (warp_texton.MOVED_MODULES).
__getattr__, __dir__ = lazy_names(__name__, _LAZY, moved="points")
