"""warp-texton: texton noise by example.

Learn a small *texton* from an example of a Gaussian texture (NumPy FFT
analysis), then evaluate *texton noise* — randomly scattered, summed copies of
the texton — anywhere, with NVIDIA Warp kernels on the CPU or a CUDA GPU.

The names below are imported on first use (PEP 562), so that importing a part
of the package that needs no Warp (the command line's ``--help``, the errors)
does not start it.

References
----------
EUSIPCO: B. Galerne, A. Leclaire, L. Moisan, "A Texton for Fast and Flexible
Gaussian Texture Synthesis", EUSIPCO 2014.
CGF: B. Galerne, A. Leclaire, L. Moisan, "Texton Noise", Computer Graphics
Forum 2017.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from ._version import __version__
from .errors import ExampleWarning, TextonError

if TYPE_CHECKING:  # what type checkers and documentation tools see; at run time, __getattr__
    from .analysis import analyze, model_error
    from .bake import BakedMesh, bake_mesh, render_baked
    from .dsn import dsn
    from .analysis_options import AnalysisOptions
    from .example_checks import downscale
    from .filter_options import FilterOptions
    from .noise_options import NoiseOptions
    from .gaussian import gaussian_texture, periodic_component
    from .io import read_image, write_image
    from .mixing import mix_textons, synthesize_mixed
    from .plane import render_plane
    from .batches import Batch, BatchParams, synthesize_batch
    from .frames import tangent_frames
    from .mesh import texture_mesh
    from .mesh_files import write_baked
    from .render import Camera, render_mesh
    from .surface import surface_noise
    from .synthesis import evaluate, synthesize
    from .texton import Texton, load_texton
    from .shader import export_shader

#: The module of each public name that is imported on first use.
_LAZY = {
    "analyze": "analysis", "model_error": "analysis",
    "BakedMesh": "bake", "bake_mesh": "bake", "render_baked": "bake", "write_baked": "mesh_files",
    "dsn": "dsn",
    "FilterOptions": "filter_options", "NoiseOptions": "noise_options", "AnalysisOptions": "analysis_options",
    "downscale": "example_checks",
    "gaussian_texture": "gaussian", "periodic_component": "gaussian",
    "read_image": "io", "write_image": "io",
    "mix_textons": "mixing", "synthesize_mixed": "mixing",
    "render_plane": "plane",
    "Camera": "render", "render_mesh": "render", "surface_noise": "surface", "tangent_frames": "frames",
    "texture_mesh": "mesh",
    "Batch": "batches", "BatchParams": "batches", "synthesize_batch": "batches",
    "evaluate": "synthesis", "synthesize": "synthesis",
    "Texton": "texton", "load_texton": "texton",
    "export_shader": "shader",
}

__all__ = [
    "AnalysisOptions",
    "BakedMesh",
    "Batch",
    "BatchParams",
    "Camera",
    "ExampleWarning",
    "FilterOptions",
    "NoiseOptions",
    "Texton",
    "TextonError",
    "__version__",
    "analyze",
    "bake_mesh",
    "downscale",
    "dsn",
    "evaluate",
    "gaussian_texture",
    "load_texton",
    "mix_textons",
    "model_error",
    "periodic_component",
    "read_image",
    "render_baked",
    "render_mesh",
    "render_plane",
    "surface_noise",
    "synthesize",
    "synthesize_batch",
    "synthesize_mixed",
    "tangent_frames",
    "texture_mesh",
    "write_baked",
    "write_image",
    "export_shader",
]


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value  # once: later lookups do not come here
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
