"""What every language's port shares: the shader templates, and a tiling model's export checks and settings.

The templates (``shaders/``, package data) are read here, for the GLSL and the OSL
ports alike. A tiling model exports the unfiltered plane tiling in every language:
the texton-noise, filter and surface options are refused for it in one error
(:func:`tiling_seed`, :func:`refuse_texton_options`), and its description records
the same settings (:func:`tiling_settings`).
"""

from __future__ import annotations

from importlib import resources

import numpy as np

from ..core.errors import TextonError
from ..model.tiling import TilingModel
from ..noise.noise_options import NoiseOptions
from ..surface.frames import UP


def template(name: str) -> str:
    """The text of the shader template ``shaders/<name>`` (package data of ``warp_texton.runtimes``)."""
    return resources.files("warp_texton.runtimes").joinpath("shaders").joinpath(name).read_text(encoding="utf-8")


def check_model(model) -> TilingModel:
    """``model`` if it is a :class:`~warp_texton.model.tiling.TilingModel`, else one error."""
    if not isinstance(model, TilingModel):
        raise TextonError(f"model must be a TilingModel, got {type(model).__name__}", param="texton")
    return model


def refuse_texton_options(noise: NoiseOptions | None, **options) -> int:
    """The seed of a tiling model's export; one error naming the texton-noise options given
    (``noise``'s mni, period, poisson, cell_factor other than their defaults, and any of
    ``options`` that is not None)."""
    default = NoiseOptions()
    given = []
    seed = 0
    if noise is not None:
        given = [name for name in ("mni", "period", "poisson", "cell_factor")
                 if getattr(noise, name) != getattr(default, name)]
        seed = noise.seed
    given += [name for name, value in options.items() if value is not None]
    if given:
        raise TextonError(f"{', '.join(given)} do not apply to the shader export of a tiling model (method "
                          "'tiling'): its shaders are the unfiltered plane tiling (docs/tiling.md)", param=given[0])
    return seed


def _default_up(up) -> bool:
    """Whether ``up`` is the surface frame rule's default (+z), as a name or a vector."""
    if isinstance(up, str):
        return up == "z"
    try:
        return bool(np.array_equal(np.asarray(up, np.float64), UP))
    except (TypeError, ValueError):
        return False


def tiling_seed(noise: NoiseOptions | None, filter, up, side) -> int:
    """The seed of a tiling model's export in any language, refusing (one error) the texton-noise
    options, a filter other than "none" and the surface frame options (no surface variant)."""
    return refuse_texton_options(noise, filter=None if filter in (None, "none") else filter,
                                 up=None if _default_up(up) else up, side=side)


def tiling_settings(model: TilingModel, seed: int) -> dict:
    """What a tiling model's export was made from, for its description file."""
    h, w, c = model.example.shape
    return {"method": "tiling", "seed": seed, "side": float(model.side), "sharpness": int(model.sharpness),
            "guide_weight": float(model.guide_weight), "blend": model.blend, "channels": c,
            "example": [w, h], "margin": model.margin}
