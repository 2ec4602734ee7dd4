"""The viewer's requests: their bounds, their parameters, and the settings they carry.

Every request's work is bounded here (tile size, zoom, MNI, texton size, export
and plane sizes, query length): a query string is read into frozen values
(:class:`Analysis`, :class:`Noise`, :class:`Tile`, :class:`Plane`,
:class:`Mix`), or refused with a :class:`BadRequest` that names the parameter.
A :class:`Window` is the ``synthesize`` raster a tile or a view stands for.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING
from urllib.parse import parse_qsl

import numpy as np

from ..noise.filter_options import FILTERS
from ..noise.noise_options import NoiseOptions

if TYPE_CHECKING:
    from ..model.analysis_options import AnalysisOptions

# ----------------------------------------------------------------- bounds
#: Tile sides the server computes (pixels).
TILE_SIZES = (128, 256, 512)
#: Filters the viewer offers: those quick enough for its tiles ("supersample"
#: is a reference, seconds per tile).
VIEW_FILTERS = tuple(name for name, kind in FILTERS.items() if kind.interactive)
#: Zoom levels (scale 2**z pixels per texel). Unfiltered tiles far out draw
#: millions of impacts for an aliased picture, so a filter without footprints stops sooner.
ZOOM_MIN = {name: -10 if FILTERS[name].footprint else -6 for name in VIEW_FILTERS}
ZOOM_MAX = 5
#: The page enlarges the deepest level's tiles up to this many levels further in,
#: and exports what it shows there.
ENLARGE = 2
#: Mixed noise has no filter, and its tiles are computed with a margin of one
#: texton side, which grows with the scale.
MIX_ZOOM = (-6, 2)
#: Tiles and exports stay within this many texels of the origin.
MAX_REACH = 1.0e9
MNI_RANGE = (0.1, 200.0)
TEXTON_SIZES = (4, 128)
ORDERS = (0, 1, 3, 5)
MIX_STEPS = (2, 33)
#: Exports and plane views: largest side and pixel count.
MAX_EXPORT_SIDE = 4096
MAX_EXPORT_PIXELS = 4096 * 4096
MAX_PLANE_PIXELS = 2048 * 1280
MAX_QUERY = 2048
#: Seed of every analysis the viewer makes (printed in the reproducing commands).
ANALYSIS_SEED = 0


class BadRequest(Exception):
    """A request the server refuses: an HTTP status and a one-line reason."""

    def __init__(self, message: str, status: int = 400):
        super().__init__(message)
        self.status = status


# ------------------------------------------------------------ parameters
class Query:
    """The parameters of one request: each read at most once, unknown or repeated ones refused."""

    def __init__(self, text: str):
        if len(text) > MAX_QUERY:
            raise BadRequest(f"query string longer than {MAX_QUERY} characters")
        try:
            pairs = parse_qsl(text, keep_blank_values=True, strict_parsing=bool(text), max_num_fields=64)
        except ValueError as exc:
            raise BadRequest(f"malformed query string ({exc})") from None
        self._values: dict[str, str] = {}
        for k, v in pairs:
            if k in self._values:
                raise BadRequest(f"parameter {k!r} given twice")
            self._values[k] = v

    def __contains__(self, name: str) -> bool:
        return name in self._values

    def text(self, name: str, default=None) -> str:
        if name not in self._values:
            if default is None:
                raise BadRequest(f"missing parameter {name!r}")
            return default
        return self._values.pop(name)

    def integer(self, name: str, lo: int, hi: int, default=None) -> int:
        raw = self.text(name, None if default is None else str(default))
        try:
            v = int(raw, 10)
        except ValueError:
            raise BadRequest(f"{name} must be an integer in [{lo}, {hi}], got {raw!r}") from None
        if not lo <= v <= hi:
            raise BadRequest(f"{name} must be an integer in [{lo}, {hi}], got {v}")
        return v

    def number(self, name: str, lo: float, hi: float, default=None) -> float:
        raw = self.text(name, None if default is None else repr(float(default)))
        try:
            v = float(raw)
        except ValueError:
            raise BadRequest(f"{name} must be a number in [{lo:g}, {hi:g}], got {raw!r}") from None
        if not (math.isfinite(v) and lo <= v <= hi):
            raise BadRequest(f"{name} must be a number in [{lo:g}, {hi:g}], got {raw!r}")
        return v

    def choice(self, name: str, choices, default=None) -> str:
        raw = self.text(name, default)
        if raw not in choices:
            raise BadRequest(f"{name} must be one of {', '.join(map(str, choices))}, got {raw!r}")
        return raw

    def finish(self) -> None:
        if self._values:
            raise BadRequest(f"unknown parameter {sorted(self._values)[0]!r}")


@dataclass(frozen=True)
class Analysis:
    """Analysis settings of the texton (unused when the input is a texton file)."""

    size: int = 64
    order: int = 1
    color_correction: bool = True

    def options(self) -> AnalysisOptions:
        """The analysis these controls ask for, with the viewer's seed :data:`ANALYSIS_SEED`."""
        # imported here: it brings SciPy (the histogram checks), which the command line's
        # --help, importing this module for its bounds, does without
        from ..model.analysis_options import AnalysisOptions

        return AnalysisOptions(size=self.size, order=self.order, seed=ANALYSIS_SEED,
                               color_correction=self.color_correction)


@dataclass(frozen=True)
class Noise:
    seed: int = 0
    mni: float = 30.0
    rotation: float = 0.0
    filter: str = "anisotropic"

    def options(self) -> NoiseOptions:
        """The noise these controls ask for (the rotation and the filter only sample it)."""
        return NoiseOptions(mni=self.mni, seed=self.seed)


@dataclass(frozen=True)
class Mix:
    """Mixing from the input A (ρ = 0) to a second input B (ρ = 1) along a ramp in x:
    ρ(x) = clip((x − start) / (end − start), 0, 1), x in texels; ``steps`` textons."""

    b: str
    steps: int
    start: float
    end: float

    def rho(self, x: np.ndarray) -> np.ndarray:
        return np.clip((x - self.start) / (self.end - self.start), 0.0, 1.0)


@dataclass(frozen=True)
class Tile:
    z: int
    x: int
    y: int
    size: int = 256


@dataclass(frozen=True)
class Plane:
    width: int
    height: int
    tilt: float = 70.0
    camera_height: float = 1.0
    fov: float = 40.0
    texel_size: float = 0.002


@dataclass(frozen=True)
class Window:
    """A raster of the (rotated) noise: what ``synthesize`` is given."""

    shape: tuple[int, int]
    scale: float
    rotation: float
    offset: tuple[float, float]
    period: tuple[float, float] | None = None


def rotate(rotation: float, u) -> tuple[float, float]:
    """R(rotation) u, as ``synthesize`` turns raster coordinates into noise positions."""
    th = math.radians(rotation)
    c, s = math.cos(th), math.sin(th)
    return (c * u[0] - s * u[1], s * u[0] + c * u[1])


def tile_window(tile: Tile, noise: Noise) -> Window:
    """The ``synthesize`` window of a tile: pixel (i, j) is the noise at
    R(rotation) ((x T + j + ½)/s, (y T + i + ½)/s), s = 2**z."""
    s = 2.0 ** tile.z
    u = (tile.x * tile.size / s, tile.y * tile.size / s)
    return Window((tile.size, tile.size), s, noise.rotation, rotate(noise.rotation, u))


def view_window(width: int, height: int, scale: float, rotation: float, left: float, top: float) -> Window:
    """A width × height raster whose top-left corner is at (left, top) in the page's
    (unrotated) view coordinates, texels; the page shows this window at scale 1:1."""
    return Window((height, width), scale, rotation, rotate(rotation, (left, top)))


def parse_analysis(q: Query, default: Analysis) -> Analysis:
    return Analysis(q.integer("size", *TEXTON_SIZES, default=default.size),
                    int(q.choice("order", tuple(map(str, ORDERS)), default=str(default.order))),
                    q.choice("cc", ("0", "1"), default="1" if default.color_correction else "0") == "1")


def parse_noise(q: Query, default: Noise, rotation: bool = True) -> Noise:
    return Noise(q.integer("seed", 0, 2**32 - 1, default=default.seed),
                 q.number("mni", *MNI_RANGE, default=default.mni),
                 q.number("rot", -360.0, 360.0, default=0.0) if rotation else 0.0,
                 q.choice("filter", VIEW_FILTERS, default=default.filter))


def parse_tile(q: Query, noise: Noise, mixing: bool) -> Tile:
    size = int(q.choice("ts", tuple(map(str, TILE_SIZES)), default="256"))
    lo, hi = MIX_ZOOM if mixing else (ZOOM_MIN[noise.filter], ZOOM_MAX)
    z = q.integer("z", lo, hi)
    s = 2.0 ** z
    reach = int(MAX_REACH * s / size)
    x = q.integer("x", -reach, reach)
    y = q.integer("y", -reach, reach)
    return Tile(z, x, y, size)


def parse_mix(q: Query) -> Mix:
    b = q.text("b")
    steps = q.integer("steps", *MIX_STEPS, default=9)
    start = q.number("ra", -MAX_REACH, MAX_REACH)
    end = q.number("rb", -MAX_REACH, MAX_REACH)
    if not end > start:
        raise BadRequest(f"the ramp must end to the right of its start: ra {start:g} >= rb {end:g}")
    return Mix(b, steps, start, end)


def parse_plane(q: Query) -> Plane:
    w = q.integer("w", 1, MAX_EXPORT_SIDE)
    h = q.integer("h", 1, MAX_EXPORT_SIDE)
    if w * h > MAX_PLANE_PIXELS:
        raise BadRequest(f"a plane view has at most {MAX_PLANE_PIXELS} pixels, got {w}x{h}")
    return Plane(w, h, q.number("tilt", 0.0, 89.0, default=70.0), q.number("height", 1e-3, 1e3, default=1.0),
                 q.number("fov", 1.0, 120.0, default=40.0), q.number("texel", 1e-6, 1e3, default=0.002))


def parse_size(q: Query) -> tuple[int, int]:
    w = q.integer("w", 1, MAX_EXPORT_SIDE)
    h = q.integer("h", 1, MAX_EXPORT_SIDE)
    if w * h > MAX_EXPORT_PIXELS:
        raise BadRequest(f"an export has at most {MAX_EXPORT_PIXELS} pixels, got {w}x{h}")
    return w, h
