"""Tiling models on surfaces without UVs: triplanar projection of the planar tiling.

A :class:`~warp_texton.model.tiling.TilingModel` is a function of the plane, so a
surface sees it through planes: the three planes orthogonal to the world's axes
(the frame of ``up`` and ``side``: right, front, up), each with an independent
seed, blended by the sharpened components of the normal with the tiling's own
blend (variance-preserving by default), so the blend zones keep the example's
contrast (``kernels/surface_tiling.py``). A face orthogonal to an axis shows that
plane's tiling, bit for bit: the floor (normal up) is ``evaluate(model, (x, −y) /
texel_size, seed=seed)``. Why triplanar and not the tangent frames of texton
surface noise: docs/tiling.md, "Surfaces".

The surface room's entry points (``surface_noise``, ``texture_mesh``,
``render_mesh``, ``bake_mesh``, jobs) take a tiling model through the hooks here:
:func:`check_surface_model` refuses the texton-noise options, :class:`TilingSetup` stands
for a texton's ``SurfaceSetup`` and :func:`tiling_values` evaluates points.

Kernels driven here: ``warp_texton.kernels.surface_tiling``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.checks import check_positive, check_seed
from ..core.errors import TextonError
from ..core.limits import check_work
from ..core.runtime import init_warp, map_points, resolve_device
from ..kernels import surface_tiling
from ..model.texton import Texton
from ..model.tiling import TilingModel
from ..noise.tiling import texton_options_given, tiling_colours, tiling_struct
from .frames import UP, as_points, check_lengths, frame_rule

__all__ = ["TilingSetup", "TilingParams", "check_surface_model", "tiling_setup", "tiling_params", "tiling_values",
           "tiling_surface_noise", "check_tiling_reach", "plane_seeds", "TRIPLANAR_SHARPNESS", "TILING_POINT_OPS"]

#: Exponent on the normal's components (a power of two, by repeated squaring): measured in
#: benchmarks/bench_surface_tiling.py (docs/tiling.md, "Surfaces").
TRIPLANAR_SHARPNESS = 8
#: Operations (limits.check_work's unit, 7e8 to 1e9 a second on a two-core CPU) of one
#: surface point: up to three tiling evaluations (measured, benchmarks/bench_surface_tiling.py:
#: 47 ms for 163 842 points on two cores, 0.29 µs a point, 0.37 of texton noise at MNI 60).
TILING_POINT_OPS = 300.0
#: Positions stay within ±2³⁰ texels (the tiling's int32 lattice indices).
MAX_REACH = float(1 << 30)
#: The surface functions' defaults of the texton-noise options a tiling model refuses.
SURFACE_MNI = 60.0
#: Mixed into the seed for the planes orthogonal to the right and front axes (the floor's
#: plane, orthogonal to up, takes the seed itself).
PLANE_TAGS = (0x5BD1E995, 0x27D4EB2F)


def _avalanche(x: int) -> int:
    # kernels/impacts.py's finaliser, in Python
    x &= 0xFFFFFFFF
    x ^= x >> 16
    x = (x * 0x7FEB352D) & 0xFFFFFFFF
    x ^= x >> 15
    x = (x * 0x846CA68B) & 0xFFFFFFFF
    x ^= x >> 16
    return x


def plane_seeds(seed: int) -> tuple[int, int, int]:
    """The seeds of the planes orthogonal to (right, front, up): hashes of ``seed`` for the
    first two, ``seed`` itself for the floor's."""
    return _avalanche(seed ^ PLANE_TAGS[0]), _avalanche(seed ^ PLANE_TAGS[1]), seed


def check_surface_model(texton, **options) -> None:
    """Refuse what is neither a Texton nor a TilingModel, and for a tiling model the
    texton-noise options (name=(value, default)) given other values than their defaults:
    one TextonError naming them."""
    if isinstance(texton, TilingModel):
        given = texton_options_given(options)
        if given:
            many = len(given) > 1
            raise TextonError(f"{', '.join(given)} {'do' if many else 'does'} not apply to a tiling model (method "
                              f"'tiling'): {'they are texton-noise options' if many else 'a texton-noise option'}; "
                              "on surfaces a tiling model takes seed, texel_size, up, side and the normals options "
                              "(docs/tiling.md)", param=given[0], mentions=tuple(given))
    elif not isinstance(texton, Texton):
        raise TextonError(f"texton must be a Texton or a TilingModel, got {type(texton).__name__}",
                          param="texton")



#: The name before 0.4 (runtimes.shared.check_tiling_model is the shader export's model check).
check_model = check_surface_model

@dataclass(frozen=True)
class TilingSetup:
    """What a tiling model needs before its points: the model (a texton's ``SurfaceSetup``
    holds the Poisson process's numbers instead). ``texton`` is None: no histogram transform
    maps its values."""

    model: TilingModel
    texton: None = None


def tiling_setup(model: TilingModel, mni: float = SURFACE_MNI) -> TilingSetup:
    check_surface_model(model, mni=(mni, SURFACE_MNI))
    return TilingSetup(model)


@dataclass(frozen=True)
class TilingParams:
    """The kernels' inputs of one seed and frame: the model, the three planes' seeds
    (:func:`plane_seeds`) and the ``Triplanar`` blend; the planes' ``Tiling`` structs
    are made on the device of the call (:func:`tiling_values`)."""

    model: TilingModel
    seeds: tuple[int, int, int]
    blend: surface_tiling.Triplanar


def tiling_params(model: TilingModel, seed: int, up, side_dir) -> TilingParams:
    """The planes' seeds and the ``Triplanar`` blend of the frame rule's (up, side): ``side_dir`` is the public
    ``side``, a direction (``model.side`` is the triangles' side, a length)."""
    wp = init_warp()
    seed = check_seed(seed)
    a, b = frame_rule(up, side_dir)
    right = b - a * float(a @ b)
    norm = float(np.linalg.norm(right))
    if norm < 1e-9:
        raise TextonError("side is parallel to up: the triplanar frame needs two directions", param="side")
    right = right / norm
    front = np.cross(a, right)
    f = surface_tiling.Triplanar()
    f.right, f.front, f.up = (wp.vec3d(*(float(c) for c in v)) for v in (right, front, a))
    f.right32, f.front32, f.up32 = (wp.vec3(*(float(c) for c in v)) for v in (right, front, a))
    f.squarings = int(TRIPLANAR_SHARPNESS).bit_length() - 1
    f.variance_preserving = int(model.blend == "variance")
    f.mean = wp.vec3(*model.mean3.tolist())
    return TilingParams(model, plane_seeds(seed), f)


def check_tiling_reach(pos: np.ndarray, what: str) -> None:
    """Refuse texel positions beyond ±2³⁰ texels (or overflowed: a tiny texel_size)."""
    with np.errstate(over="ignore", invalid="ignore"):
        far = float(np.abs(pos).max()) if pos.size else 0.0
    if not far <= MAX_REACH:
        where = f"{far:.3g} texels" if math.isfinite(far) else "beyond floating point range"
        raise TextonError(f"{what} lie too far from the origin for this texel_size: {where}, where a tiling model "
                          f"is defined within ±{MAX_REACH:.3g} texels; use a larger texel_size or move them nearer "
                          "the origin")


def tiling_values(p: TilingParams, pos: np.ndarray, nrm: np.ndarray, device) -> np.ndarray:
    """(N, 3) float32: the triplanar tiling at float64 texel positions with unit normals (through the
    model's histogram tables, if it has them)."""
    wp = init_warp()
    device = resolve_device(device)
    n = len(pos)
    if n == 0:
        return np.zeros((0, 3), np.float32)
    planes = [tiling_struct(p.model, s, device) for s in p.seeds]
    pos = np.ascontiguousarray(pos, np.float64)
    nrm = np.ascontiguousarray(nrm, np.float32)

    def values(start, stop):
        out = wp.empty(stop - start, dtype=wp.vec3, device=device)
        wp.launch(surface_tiling.triplanar_points, dim=stop - start, device=device,
                  inputs=[*planes, p.blend, wp.array(pos[start:stop], dtype=wp.vec3d, device=device),
                          wp.array(nrm[start:stop], dtype=wp.vec3, device=device), out])
        return out.numpy()

    out = map_points(device, surface_tiling, n, values)
    tiling_colours(p.model, out)  # a histogram-preserving model: its tables, after the triplanar blend
    return out


def tiling_surface_noise(model: TilingModel, points, normals, texel_size, *, seed=0, device=None, up=UP,
                         side=None, options: dict | None = None) -> np.ndarray:
    """``surface_noise`` for a tiling model: (N, C) float32; ``options`` the texton-noise
    options as name=(value, default), refused unless at their defaults."""
    check_surface_model(model, **(options or {}))
    pts = as_points(points, "points")
    raw = as_points(normals, "normals")
    if raw.shape != pts.shape:
        raise TextonError(f"normals has shape {raw.shape}; it must match points {pts.shape}")
    texel = check_positive(texel_size, "texel_size")
    seed = check_seed(seed)
    length = np.sqrt(raw[:, 0] * raw[:, 0] + raw[:, 1] * raw[:, 1] + raw[:, 2] * raw[:, 2])
    check_lengths(length, "normals")
    with np.errstate(over="ignore", invalid="ignore"):
        pos = pts / texel
    check_tiling_reach(pos, "points")
    check_work(len(pts) * TILING_POINT_OPS, f"surface tiling at {len(pts)} points", "use fewer points",
               param="points")
    device = resolve_device(device)
    p = tiling_params(model, seed, up, side)
    out = tiling_values(p, pos, raw / length[:, None], device)
    return np.ascontiguousarray(out[:, :model.channels])
