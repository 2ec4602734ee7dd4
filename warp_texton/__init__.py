"""warp-texton: texton noise by example.

Learn a small *texton* from an example of a Gaussian texture (NumPy FFT
analysis), then evaluate *texton noise* — randomly scattered, summed copies of
the texton — anywhere, with NVIDIA Warp kernels on the CPU or a CUDA GPU.

References
----------
EUSIPCO: B. Galerne, A. Leclaire, L. Moisan, "A Texton for Fast and Flexible
Gaussian Texture Synthesis", EUSIPCO 2014.
CGF: B. Galerne, A. Leclaire, L. Moisan, "Texton Noise", Computer Graphics
Forum 2017.
"""

from ._version import __version__
from .errors import TextonError
from .io import read_image, write_image
from .gaussian import periodic_component, gaussian_texture
from .texton import Texton, load_texton
from .analysis import analyze, model_error
from .dsn import dsn
from .filtering import FilterOptions
from .synthesis import synthesize, evaluate
from .batches import Batch, BatchParams, synthesize_batch
from .plane import render_plane
from .mixing import mix_textons, synthesize_mixed
from .frames import tangent_frames
from .surface import surface_noise
from .mesh import texture_mesh
from .render import Camera, render_mesh
from .bake import BakedMesh, bake_mesh, render_baked, write_baked

__all__ = [
    "BakedMesh",
    "Batch",
    "BatchParams",
    "Camera",
    "FilterOptions",
    "Texton",
    "TextonError",
    "__version__",
    "analyze",
    "bake_mesh",
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
]
