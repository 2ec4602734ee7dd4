"""What every language's port shares: the shader templates, and a tiling model's export checks and settings.

The templates (``shaders/``, package data) are read here, for the GLSL and the OSL
ports alike. A tiling model exports the unfiltered plane tiling in every language:
the texton-noise, filter and surface options are refused for it in one error
(:func:`tiling_seed`, :func:`refuse_export_options`), and its description records
the same settings (:func:`tiling_settings`: the blend's, where the centres lie, the
axes the example is read wrapped on and its lattice).
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


def check_tiling_model(model) -> TilingModel:
    """``model`` if it is a :class:`~warp_texton.model.tiling.TilingModel`, else one error."""
    if not isinstance(model, TilingModel):
        raise TextonError(f"model must be a TilingModel, got {type(model).__name__}", param="texton")
    return model


def refuse_export_options(noise: NoiseOptions | None, **options) -> int:
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
    return refuse_export_options(noise, filter=None if filter in (None, "none") else filter,
                                 up=None if _default_up(up) else up, side=side)


#: 0.3's names (``warp_texton.runtimes.tiling_shaders``): the shader export's model check and option refusal,
#: named now for what they check (``surface.tiling.check_surface_model`` and ``noise.tiling.refuse_texton_options``
#: are the surfaces' and the plane's).
check_model = check_tiling_model
refuse_texton_options = refuse_export_options


def tiling_settings(model: TilingModel, seed: int) -> dict:
    """What a tiling model's export was made from, for its description file: the blend's settings, the
    centres' texels per axis (``centre_box``: [first, count] on x, then y), the axes the example is read
    wrapped on (x, y) and its lattice (``Lattice.to_json`` with its vectors (dy, dx) in texels; None
    without one)."""
    h, w, c = model.example.shape
    lattice = None
    if model.lattice is not None:
        lattice = {**model.lattice.to_json(), "vectors": [list(v) for v in model.lattice.vectors]}
    return {"method": "tiling", "seed": seed, "side": float(model.side), "sharpness": int(model.sharpness),
            "guide_weight": float(model.guide_weight), "blend": model.blend, "channels": c,
            "example": [w, h], "margin": model.margin, "centre_box": [list(b) for b in model.centre_box],
            "wrap": [bool(v) for v in model.wrap], "lattice": lattice}


def lattice_ints(model: TilingModel) -> tuple[int, int, tuple[int, int], tuple[int, int]]:
    """(rank, modulus N, k1, k2) of a tiling model's lattice as the shaders take them, the dual vectors in
    (x, y) order as ``noise.tiling.tiling_struct`` packs them for the kernels: (0, 1, (0, 0), (0, 0))
    without a lattice, k2 = (0, 0) for courses."""
    if model.lattice is None:
        return 0, 1, (0, 0), (0, 0)
    k = model.lattice.dual_matrix  # rows (ky, kx)
    k2 = (int(k[1, 1]), int(k[1, 0])) if model.lattice.rank == 2 else (0, 0)
    return model.lattice.rank, model.lattice.modulus, (int(k[0, 1]), int(k[0, 0])), k2


def model_note(model: TilingModel) -> str:
    """The wrap and the lattice of a tiling model as a short text, for a generated file's first line and
    the viewer ("" for neither): ", wrapped on x and y, lattice (16, -16); (16, 16)"."""
    note = ""
    if any(model.wrap):
        note += ", wrapped on " + " and ".join(a for a, on in zip("xy", model.wrap) if on)
    if model.lattice is not None:
        note += ", lattice " + "; ".join(f"({dy:.4g}, {dx:.4g})" for dy, dx in model.lattice.vectors)
    return note
