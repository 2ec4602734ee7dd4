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

__version__ = "0.1.0"

from .errors import TextonError
from .io import read_image, write_image
from .gaussian import periodic_component, gaussian_texture
from .texton import Texton, load_texton
from .analysis import analyze, model_error
from .dsn import dsn

__all__ = [
    "TextonError",
    "Texton",
    "analyze",
    "dsn",
    "gaussian_texture",
    "load_texton",
    "model_error",
    "periodic_component",
    "read_image",
    "write_image",
]

from .synthesis import synthesize, evaluate  # noqa: E402

__all__ += ["synthesize", "evaluate"]

from .mixing import mix_textons, synthesize_mixed  # noqa: E402

__all__ += ["mix_textons", "synthesize_mixed"]

from .surface import Camera, render_mesh, surface_noise, tangent_frames, texture_mesh  # noqa: E402

__all__ += ["Camera", "render_mesh", "surface_noise", "tangent_frames", "texture_mesh"]

from .filtering import render_plane  # noqa: E402

__all__ += ["render_plane"]
