"""Texton noise on the plane: the engine (``engine``: setup, parameters, points), windows of
the global raster (``raster``, ``canvas``), filtered footprints (``filtering``), the front ends
``synthesize``/``evaluate`` (``synthesis``), the ground plane (``ground_plane``), mixing,
batches and Dask arrays. Kernels: ``warp_texton.kernels.noise_*``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..core.lazy import lazy_names

if TYPE_CHECKING:
    from .synthesis import synthesize, evaluate
    from .filter_options import FilterOptions
    from .ground_plane import render_plane, PlaneCamera
    from .mixing import mix_textons, synthesize_mixed
    from .batches import Batch, BatchParams, synthesize_batch
    from .dask_arrays import synthesize_dask, write_zarr
    from .colours import to_colours
    from .noise_options import NoiseOptions
    from .relief import gradient, height_map, normal_map

#: The module of each name of this room's face, imported on first use (PEP 562).
_LAZY = {
    "synthesize": "synthesis",
    "evaluate": "synthesis",
    "FilterOptions": "filter_options",
    "render_plane": "ground_plane",
    "PlaneCamera": "ground_plane",
    "mix_textons": "mixing",
    "synthesize_mixed": "mixing",
    "Batch": "batches",
    "BatchParams": "batches",
    "synthesize_batch": "batches",
    "synthesize_dask": "dask_arrays",
    "write_zarr": "dask_arrays",
    "to_colours": "colours",
    "NoiseOptions": "noise_options",
    "gradient": "relief",
    "height_map": "relief",
    "normal_map": "relief",
}

__all__ = ["Batch", "BatchParams", "FilterOptions", "NoiseOptions", "PlaneCamera", "evaluate", "gradient", "height_map", "mix_textons", "normal_map", "render_plane", "synthesize", "synthesize_batch", "synthesize_dask", "synthesize_mixed", "to_colours", "write_zarr"]


#: 0.2's warp_texton.noise was a module, warp_texton.noise.engine now: its other names are reached here
#: with a DeprecationWarning (warp_texton.MOVED_MODULES).
__getattr__, __dir__ = lazy_names(__name__, _LAZY, moved="engine")
