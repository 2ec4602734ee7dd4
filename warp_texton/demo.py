"""The demo: analyse the texture shipped with the package and write the results."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from .model.analysis import analyze
from .model.gaussian import gaussian_texture
from .files.images import read_image, write_image
from .noise.ground_plane import render_plane
from .noise.synthesis import synthesize
from .model.texton import Texton

DEMO_TEXTURE = "grass_256.png"


def demo_texture_path() -> Path:
    """Path of the demo texture: a 256² crop of scikit-image's grass (CC0).

    The examples of the documentation use it (``warp_texton/data/grass_256.png``,
    shipped with the package).

    Examples
    --------
    >>> from warp_texton import read_image
    >>> from warp_texton.demo import demo_texture_path
    >>> demo_texture_path().name, read_image(demo_texture_path()).shape
    ('grass_256.png', (256, 256, 1))
    """
    return Path(str(resources.files("warp_texton.data") / DEMO_TEXTURE))


def texton_preview(texton: Texton):
    """The texton as a viewable image: mean + α·√(r s).

    An r × s texton whose noise has the input's variance has coefficients of
    order σ/√(r s); scaling by √(r s) brings them back to the input's contrast.
    """
    import numpy as np

    return texton.mean + texton.coeffs * np.sqrt(texton.size[0] * texton.size[1])


def run_demo(out_dir, size: int = 64, seed: int = 0, progress: bool = True) -> list[Path]:
    """Write input, Gaussian version, texton, noise and a plane view to ``out_dir``.

    What ``warp-texton demo`` does (docs/cli.md): the demo texture
    (:func:`demo_texture_path`) is analysed (:func:`warp_texton.analyze`), and
    its Gaussian version, a preview of the texton, a 512 × 512 window of its
    noise and a 512 × 512 view of the ground plane are written.

    Parameters
    ----------
    out_dir : str or Path
        Created when missing.
    size : int
        As in :func:`warp_texton.analyze`.
    seed : int
        As in :func:`warp_texton.analyze`; it also seeds the noise.
    progress : bool
        Show the analysis's progress bar.

    Returns
    -------
    list of Path
        The paths written, PNG and EXR for each picture plus the texton
        itself as ``texton.exr`` and ``texton.texton``.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    u = read_image(demo_texture_path())
    texton = analyze(u, size=size, seed=seed, progress=progress)
    texton.metadata["source"] = DEMO_TEXTURE
    pictures = {
        "input": u,
        "gaussian": gaussian_texture(u, seed=seed),
        "texton_preview": texton_preview(texton),
    }
    pictures["noise"] = synthesize(texton, shape=(512, 512), seed=seed)
    pictures["plane"] = render_plane(texton, (512, 512), seed=seed)
    written = []
    for name, img in pictures.items():
        for ext in (".png", ".exr"):
            write_image(out / f"{name}{ext}", img)
            written.append(out / f"{name}{ext}")
    for ext in (".exr", ".texton"):
        texton.save(out / f"texton{ext}")
        written.append(out / f"texton{ext}")
    return written
