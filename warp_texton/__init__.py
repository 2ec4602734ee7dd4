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
import importlib.abc
import importlib.util
import sys
import types
import warnings
from typing import TYPE_CHECKING

from .core.lazy import lazy_names

from ._version import __version__
from .core.errors import ExampleWarning, TextonError

if TYPE_CHECKING:  # what type checkers and documentation tools see; at run time, __getattr__
    from .model.analysis import analyze, model_error
    from .surface.bake import BakedMesh, bake_mesh
    from .surface.render import render_baked
    from .model.spot_noise import dsn
    from .model.analysis_options import AnalysisOptions
    from .model.example_checks import downscale
    from .noise.filter_options import FilterOptions
    from .noise.noise_options import NoiseOptions
    from .model.gaussian import gaussian_texture, periodic_component
    from .files.images import read_image, write_image
    from .noise.mixing import mix_textons, synthesize_mixed
    from .noise.ground_plane import render_plane
    from .noise.batches import Batch, BatchParams, synthesize_batch
    from .surface.frames import tangent_frames
    from .surface.mesh import texture_mesh
    from .surface.mesh_files import write_baked
    from .surface.render import Camera, render_mesh
    from .surface.points import surface_noise
    from .noise.synthesis import evaluate, synthesize
    from .noise.relief import gradient, height_map, normal_map
    from .model.texton import Texton, load_texton
    from .runtimes.export import export_shader

#: The module of each public name that is imported on first use.
_LAZY = {
    "analyze": "model.analysis", "model_error": "model.analysis",
    "BakedMesh": "surface.bake", "bake_mesh": "surface.bake", "render_baked": "surface.render", "write_baked": "surface.mesh_files",
    "dsn": "model.spot_noise",
    "FilterOptions": "noise.filter_options", "NoiseOptions": "noise.noise_options", "AnalysisOptions": "model.analysis_options",
    "downscale": "model.example_checks",
    "gaussian_texture": "model.gaussian", "periodic_component": "model.gaussian",
    "read_image": "files.images", "write_image": "files.images",
    "mix_textons": "noise.mixing", "synthesize_mixed": "noise.mixing",
    "render_plane": "noise.ground_plane",
    "Camera": "surface.render", "render_mesh": "surface.render", "surface_noise": "surface.points", "tangent_frames": "surface.frames",
    "texture_mesh": "surface.mesh",
    "Batch": "noise.batches", "BatchParams": "noise.batches", "synthesize_batch": "noise.batches",
    "evaluate": "noise.synthesis", "synthesize": "noise.synthesis",
    "gradient": "noise.relief", "height_map": "noise.relief", "normal_map": "noise.relief",
    "Texton": "model.texton", "load_texton": "model.texton",
    "export_shader": "runtimes.export",
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
    "gradient",
    "height_map",
    "load_texton",
    "mix_textons",
    "model_error",
    "normal_map",
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


_lazy_getattr, __dir__ = lazy_names(__name__, _LAZY)


def __getattr__(name: str):
    """A public name, imported on first use; or a module of 0.2 as an attribute (``wt.limits``),
    imported, with its DeprecationWarning, the first time it is reached."""
    if name not in _LAZY and f"{__name__}.{name}" in MOVED_MODULES:
        return importlib.import_module(f"{__name__}.{name}")
    return _lazy_getattr(name)


#: Module paths of 0.2 (one flat folder, tests/data/modules_0_2.json) and where they live now;
#: importing an old path, or reaching it as an attribute of its package, still works for one
#: release, with a DeprecationWarning naming the new one (docs/architecture.md). The rooms
#: ``noise``, ``surface``, ``view`` and ``cli`` were modules in 0.2: their paths import the rooms,
#: whose faces reach the names of those modules where they live now (``lazy_names``'s ``moved``).
#: A module whose names went to several modules maps to all of them, searched in order.
MOVED_MODULES: dict[str, str | tuple[str, ...]] = {
    "warp_texton.errors": "warp_texton.core.errors",
    "warp_texton.limits": "warp_texton.core.limits",
    "warp_texton._checks": "warp_texton.core.checks",
    "warp_texton._runtime": "warp_texton.core.runtime",
    "warp_texton.io": "warp_texton.files.images",
    "warp_texton.image_readers": "warp_texton.files.readers",
    "warp_texton.folders": "warp_texton.files.folders",
    "warp_texton.texton": "warp_texton.model.texton",
    "warp_texton.analysis": "warp_texton.model.analysis",
    "warp_texton.gaussian": "warp_texton.model.gaussian",
    "warp_texton.histogram": "warp_texton.model.histogram",
    "warp_texton.bspline": "warp_texton.model.bspline",
    "warp_texton.dsn": "warp_texton.model.spot_noise",
    "warp_texton.noise": "warp_texton.noise.engine",
    "warp_texton.canvas": "warp_texton.noise.canvas",
    "warp_texton.raster": "warp_texton.noise.raster",
    "warp_texton.filter_options": "warp_texton.noise.filter_options",
    "warp_texton.filtering": "warp_texton.noise.filtering",
    "warp_texton.colours": "warp_texton.noise.colours",
    "warp_texton.synthesis": "warp_texton.noise.synthesis",
    "warp_texton.plane": "warp_texton.noise.ground_plane",
    "warp_texton.mixing": "warp_texton.noise.mixing",
    "warp_texton.batches": "warp_texton.noise.batches",
    "warp_texton.dask": "warp_texton.noise.dask_arrays",
    "warp_texton.frames": "warp_texton.surface.frames",
    "warp_texton.blocks": "warp_texton.surface.blocks",
    "warp_texton.mesh": "warp_texton.surface.mesh",
    "warp_texton.mesh_files": "warp_texton.surface.mesh_files",
    "warp_texton.surface": "warp_texton.surface.points",
    "warp_texton.atlas": "warp_texton.surface.atlas",
    "warp_texton.atlas_worker": "warp_texton.surface.atlas_worker",
    "warp_texton.render": "warp_texton.surface.render",
    "warp_texton.bake": "warp_texton.surface.bake",
    "warp_texton.jobs": "warp_texton.surface.jobs",
    "warp_texton.device": "warp_texton.runtimes.warp_api",
    "warp_texton.shader": "warp_texton.runtimes.export",
    "warp_texton.shader_glsl": ("warp_texton.runtimes.glsl.texton", "warp_texton.runtimes.glsl.page"),
    "warp_texton.shader_osl": "warp_texton.runtimes.osl.texton",
    "warp_texton.view": "warp_texton.view.server",
    "warp_texton.view_core": "warp_texton.view.viewer",
    "warp_texton.view_query": "warp_texton.view.queries",
    "warp_texton.view_cache": "warp_texton.view.cache",
    "warp_texton.view_images": "warp_texton.view.pictures",
    "warp_texton.view_inputs": "warp_texton.view.inputs",
    "warp_texton.view_commands": "warp_texton.view.commands",
    "warp_texton.view_webgl": "warp_texton.view.webgl",
    "warp_texton.viewer": "warp_texton.view.static",
    "warp_texton.cli": "warp_texton.cli.parser",
    "warp_texton.cli_options": "warp_texton.cli.options",
    "warp_texton.cli_images": "warp_texton.cli.image_commands",
    "warp_texton.cli_surface": "warp_texton.cli.surface",
    "warp_texton.cli_shader": "warp_texton.cli.shader",
    "warp_texton.cli_view": "warp_texton.cli.view",
    "warp_texton.tiling": ("warp_texton.model.tiling", "warp_texton.model.tiling_fit"),
    "warp_texton.tiling_noise": "warp_texton.noise.tiling",
    "warp_texton.example_checks": "warp_texton.model.example_checks",
    "warp_texton.analysis_options": "warp_texton.model.analysis_options",
    "warp_texton.noise_options": "warp_texton.noise.noise_options",
    "warp_texton.progress": "warp_texton.core.progress",
    "warp_texton.kernels.noise2d": "warp_texton.kernels.noise_raster",
    "warp_texton.kernels.filter2d": "warp_texton.kernels.noise_filter",
    "warp_texton.kernels.colours": "warp_texton.kernels.noise_colours",
    "warp_texton.kernels.surface": ("warp_texton.kernels.surface_points", "warp_texton.kernels.surface_clusters"),
    "warp_texton.kernels.blocks": "warp_texton.kernels.surface_blocks",
    "warp_texton.kernels.render": "warp_texton.kernels.surface_render",
    "warp_texton.kernels.bake": "warp_texton.kernels.surface_bake",
    "warp_texton.kernels.tiling": ("warp_texton.kernels.noise_tiling", "warp_texton.kernels.tiling_draw"),
    # 0.3's tiling shaders (GLSL and OSL in one module): each language's port now, and what both share
    "warp_texton.runtimes.tiling_shaders": ("warp_texton.runtimes.glsl.tiling", "warp_texton.runtimes.osl.tiling",
                                            "warp_texton.runtimes.shared"),
    # 0.3's three images.py, two of them named now for what they hold (files.images, image files, stays)
    "warp_texton.view.images": "warp_texton.view.pictures",
    "warp_texton.cli.images": "warp_texton.cli.image_commands",
}


def _outside_imports() -> int:
    """The ``stacklevel``, for a warning of this function's caller, of the first frame that is
    neither the import system's nor this package's machinery: the user's line, where Python's
    default filters show a DeprecationWarning (of ``__main__``). ``warnings`` itself skips the
    frames of ``importlib._bootstrap``; ``importlib.import_module`` and this module's
    ``__getattr__`` (``wt.limits``) are counted."""
    frame: types.FrameType | None = sys._getframe(2)
    level = 2
    while frame is not None:
        name = frame.f_code.co_filename
        if not ("importlib" in name and "_bootstrap" in name):
            if frame.f_globals.get("__name__") not in _MACHINERY:
                break
            level += 1
        frame = frame.f_back
    return level


#: The modules between a user's line and the import of an old path: import_module, and the
#: ``__getattr__`` of this package and of ``warp_texton.kernels`` (0.2's modules as attributes).
_MACHINERY = {"importlib", __name__, f"{__name__}.kernels"}


class _MovedModule(importlib.abc.Loader):
    """Imports an old module path as the module at its new path, with a DeprecationWarning."""

    def create_module(self, spec):
        return None

    def exec_module(self, module) -> None:
        new = MOVED_MODULES[module.__name__]
        paths = (new,) if isinstance(new, str) else new
        warnings.warn(f"{module.__name__} moved to {' and '.join(paths)}; the old path goes in the next release",
                      DeprecationWarning, stacklevel=_outside_imports())
        targets = [importlib.import_module(p) for p in paths]

        def moved(name: str):
            for target in targets:
                if hasattr(target, name):
                    return getattr(target, name)
            raise AttributeError(f"module {module.__name__!r} has no attribute {name!r}")

        module.__getattr__ = moved
        module.__dir__ = lambda: sorted(set(vars(module)).union(*(dir(t) for t in targets)))
        module.__all__ = [n for t in targets for n in getattr(t, "__all__", [n for n in vars(t) if not n.startswith("_")])]
        module.__doc__ = targets[0].__doc__


class _MovedFinder(importlib.abc.MetaPathFinder):
    # last on sys.meta_path: a path that a file still holds (the rooms) never gets here
    def find_spec(self, fullname, path=None, target=None):
        if fullname in MOVED_MODULES:
            return importlib.util.spec_from_loader(fullname, _MovedModule())
        return None


if not any(isinstance(f, _MovedFinder) for f in sys.meta_path):
    sys.meta_path.append(_MovedFinder())


class _Package(types.ModuleType):
    """This package's module type: the import system binds an imported submodule on its package,
    and 0.2's ``warp_texton.dsn`` (a moved path) would then hide the public function ``dsn``
    for the rest of the process; the public name wins (``from warp_texton.dsn import dsn``
    still reaches the old path's names)."""

    def __setattr__(self, name: str, value) -> None:
        if name in _LAZY and getattr(value, "__name__", None) == f"{__name__}.{name}" \
                and f"{__name__}.{name}" in MOVED_MODULES:
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
