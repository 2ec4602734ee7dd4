"""Tiling and blending by example: the model for structured (non-Gaussian) textures.

A :class:`TilingModel` holds the example itself and the few numbers of the
blend; the noise at x is three patches of the example blended over a triangle
grid (``kernels/noise_tiling.py``, specified in docs/tiling.md). It keeps shapes —
bricks, mortar lines, cracks — that the Gaussian texton model cannot. Files:
EXR, the example as pixels and the parameters as header attributes
(``texton_kind = "tiling"``); :func:`warp_texton.load_texton` reads them.

:func:`structure_score` measures how much an example needs this model: the
multi-scale 7 × 7 patch sliced-Wasserstein distance between the example and its
own phase-randomised version (what a Gaussian model keeps of it), over that
between the example's two halves (:func:`patch_distance`, :func:`half_distance`).
"""

from __future__ import annotations

import json
import math
import numbers
import reprlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.checks import CHANNELS, MAX_VALUE, as_real_array, check_path, check_range
from .._version import __version__
from ..core.errors import TextonError
from ..files.images import EXR, check_output_name, read_exr, read_exr_header, write_exr
from .histogram import HistogramTransform
from .lattice import Lattice, lattice_mean
# the measures' and the analysis price's names where 0.3 had them (model/structure.py holds them now)
from .structure import (MAX_EXAMPLE_SIDE, PROBE_LIMIT, check_tiling_analysis, half_distance,  # noqa: F401
                        patch_distance, phase_randomised, scorable, structure_parts, structure_score,
                        tiling_affordable, tiling_analysis_cost)

__all__ = ["TilingModel", "TILING_KIND", "KIND_ATTRIBUTE", "guide_of", "structure_score", "structure_parts",
           "centre_box", "CUTOFF_FRACTION",
           "patch_distance", "half_distance", "suggest_method", "scorable", "is_tiling_header", "load_tiling",
           "SHARPNESS", "STRUCTURE_THRESHOLD", "metadata_json", "read_metadata", "tiling_analysis_cost",
           "check_tiling_analysis", "tiling_affordable"]

#: The EXR attribute naming a model's kind; absent in texton files (kind "texton").
KIND_ATTRIBUTE = "texton_kind"
TILING_KIND = "tiling"
#: Default exponent on the barycentric weights (measured in benchmarks/bench_structure.py).
SHARPNESS = 16
#: The exponents on the barycentric weights: powers of two, applied by repeated squaring.
SHARPNESSES = (1, 2, 4, 8, 16, 32, 64)
#: The blends: the weighted mean, or the variance-preserving blend of Heitz & Neyret 2018 eq. (4).
BLENDS = ("linear", "variance")
#: Default triangle side as a fraction of the example's smaller side.
SIDE_FRACTION = 0.25
#: Smallest example side (a triangle of at least 4 texels inside a margin).
MIN_SIDE = 16
#: Blend weights below this fraction of the largest are dropped: the kernels' ``tiling_draw.CUTOFF``.
CUTOFF_FRACTION = 1.0e-4
#: Above this structure score the tiling model fits better than texton noise.
STRUCTURE_THRESHOLD = 1.6


def guide_of(example: np.ndarray) -> np.ndarray:
    """The blend guide: the example's luminance (channel mean), standardised; float32 (H, W)."""
    lum = np.asarray(example, np.float64).mean(axis=2)
    sd = lum.std()
    return ((lum - lum.mean()) / (sd if sd > 0 else 1.0)).astype(np.float32)


def margin_of(side: float) -> int:
    """Texels kept between a vertex's centre and the example's border: ⌈side⌉ + 1."""
    return int(math.ceil(side)) + 1


@dataclass(frozen=True, eq=False)
class TilingModel:
    """Tiling and blending of an example: what the structured method needs besides a seed.

    Attributes
    ----------
    example : float32 array (H, W, C), C in {1, 3}
        The example texture, read with bilinear interpolation.
    side : float
        Side of the triangles of the blend grid, in noise units (texels at
        scale 1). Each vertex's patch is seen up to ``side`` from it; the
        example must be wider than 2 (⌈side⌉ + 1) + 1 texels on each axis so
        that patches never cross its border.
    sharpness : int
        Exponent on the barycentric weights, a power of two from 1 to 64: 1 is the classic linear
        blend, larger values narrow the blend zones (Mikkelsen 2022's contrast
        sharpening, in power form).
    guide_weight : float
        Weight β ≥ 0 of the luminance guide: weights × exp(β (g − max g)). 0
        (the default) blends by position only.
    metadata : dict
        Provenance and the measured structure score: standard JSON values (NumPy
        scalars and arrays are taken as numbers and lists; no NaN or infinity), at
        most 64 levels deep and 1 MiB as JSON, as a file holds them.
    blend : {"linear", "variance"}
        The weighted mean of the patches, or the variance-preserving blend
        (Heitz & Neyret 2018, eq. (4)).
    histogram : HistogramTransform, optional
        ``analyze(..., method="tiling", histogram="preserve")``: ``example`` holds
        the example Gaussianised per channel (:meth:`HistogramTransform.to_gaussian`)
        and every output maps the blended values back through these tables,
        after the blend, exactly as texton noise applies a texton's
        (:func:`warp_texton.noise.colours.to_colours`, standardised by the
        Gaussianised example's own :attr:`mean` and :meth:`covariance`). None:
        the example's colours are blended directly.
    wrap : (bool, bool)
        Whether the example is read wrapped across its x (columns) and y (rows)
        borders: a seamless example (:func:`warp_texton.model.lattice_detection.seam_ratios`)
        whose patch centres may lie anywhere on that axis, its patches crossing
        the border; (False, False), the default, keeps them ``margin`` inside it.
        A wrapped axis takes a ``side`` up to the example's own size on it.
    lattice : Lattice, optional
        The example's lattice (:class:`~warp_texton.model.lattice.Lattice`): every
        vertex's centre is snapped so that the example's lattice lines up across
        the plane, and the blend mixes the residuals around the lattice-periodic
        mean (:attr:`mean_image`), which it keeps (docs/tiling.md, "Lattices").
        On an axis read clamped the centres keep the lattice's half extent more
        from the border.

    Raises
    ------
    TextonError
        For an example that is not an (H, W) or (H, W, 1|3) array of finite
        numbers, too small for its ``side``, parameters out of range, or
        metadata a file cannot hold (naming its key).
    """

    example: np.ndarray
    side: float
    sharpness: int = SHARPNESS
    guide_weight: float = 0.0
    metadata: dict = field(default_factory=dict)
    blend: str = "linear"
    histogram: HistogramTransform | None = None
    wrap: tuple[bool, bool] = (False, False)
    lattice: Lattice | None = None

    def __post_init__(self):
        a = as_real_array(self.example, "example", "an array (H, W) or (H, W, C) of numbers")
        if a.ndim == 2:
            a = a[:, :, None]
        if a.ndim != 3 or a.shape[2] not in CHANNELS:
            raise TextonError(f"example must have shape (H, W), (H, W, 1) or (H, W, 3), got {a.shape}",
                              param="example")
        if max(a.shape[:2]) > MAX_EXAMPLE_SIDE:
            raise TextonError(f"example: {a.shape[0]}x{a.shape[1]}; at most {MAX_EXAMPLE_SIDE} per side",
                              param="example")
        check_range(a, "example", MAX_VALUE, "values")
        side = _number(self.side, "side", 2.0, None)
        wrap = _wrap_flags(self.wrap)
        if self.lattice is not None and not isinstance(self.lattice, Lattice):
            raise TextonError(f"lattice must be a Lattice or None, got {self.lattice!r:.60}", param="lattice")
        centre_box(a.shape, side, wrap, self.lattice)  # refuses a side the example cannot hold
        if isinstance(self.sharpness, (bool, np.bool_)) or not isinstance(self.sharpness, numbers.Integral) \
                or self.sharpness not in SHARPNESSES:
            raise TextonError(f"sharpness must be one of {', '.join(map(str, SHARPNESSES))} (a power of two), "
                              f"got {self.sharpness!r:.60}", param="sharpness")
        sharp = int(self.sharpness)
        beta = _number(self.guide_weight, "guide_weight", 0.0, 32.0)
        if self.blend not in BLENDS:
            raise TextonError(f"blend must be one of {', '.join(BLENDS)}, got {self.blend!r:.60}", param="blend")
        if not isinstance(self.metadata, Mapping) or not all(isinstance(k, str) for k in self.metadata):
            raise TextonError(f"metadata must be a dict with string keys, got {self.metadata!r:.80}",
                              param="metadata")
        metadata_json(self.metadata)  # JSON a file can hold and its reader reads back: refused now, not at save
        if self.histogram is not None and (not isinstance(self.histogram, HistogramTransform)
                                           or self.histogram.channels != a.shape[2]):
            raise TextonError(f"histogram must be a HistogramTransform of {a.shape[2]} channel(s) or None, got "
                              f"{self.histogram!r:.60}", param="histogram")
        a = np.ascontiguousarray(a, dtype=np.float32)
        a.setflags(write=False)
        object.__setattr__(self, "example", a)
        object.__setattr__(self, "side", side)
        object.__setattr__(self, "sharpness", sharp)
        object.__setattr__(self, "guide_weight", beta)
        object.__setattr__(self, "metadata", dict(self.metadata))
        object.__setattr__(self, "wrap", wrap)
        m3 = np.zeros(3, np.float32)
        m3[:a.shape[2]] = a.mean(axis=(0, 1), dtype=np.float64)
        m3.setflags(write=False)
        object.__setattr__(self, "_mean3", m3)

    @property
    def channels(self) -> int:
        """C: 1 (grey) or 3 (RGB)."""
        return int(self.example.shape[2])

    @property
    def kind(self) -> str:
        """The model's kind: ``"tiling"`` (a :class:`~warp_texton.Texton` is ``"texton"``)."""
        return TILING_KIND

    @property
    def margin(self) -> int:
        """Texels between any vertex's centre and the example's border."""
        return margin_of(self.side)

    @property
    def centre_box(self) -> tuple[tuple[int, int], tuple[int, int]]:
        """((lo, n) on x, (lo, n) on y): the centres' texels per axis, lo to lo + n − 1 (kernels/tiling_draw.py):
        (0, size) on a wrapped axis, else ``margin`` (plus the lattice's half extent) from each border."""
        return centre_box(self.example.shape, self.side, self.wrap, self.lattice)

    @property
    def mean_image(self) -> np.ndarray | None:
        """The lattice-periodic mean of the example (:func:`~warp_texton.model.lattice.lattice_mean`), float32
        (H, W, C), that a lattice model's blend keeps; None without a lattice. Computed once."""
        if self.lattice is None:
            return None
        cached = self.__dict__.get("_mean_image")
        if cached is None:
            cached = lattice_mean(self.example, self.lattice, self.wrap)
            cached.setflags(write=False)
            object.__setattr__(self, "_mean_image", cached)
        return cached

    @property
    def guide(self) -> np.ndarray:
        """The blend guide (:func:`guide_of`), float32 (H, W)."""
        return guide_of(self.example)

    @property
    def mean(self) -> np.ndarray:
        """The example's mean colour, float64 (C,)."""
        return self.example.mean(axis=(0, 1), dtype=np.float64)

    def covariance(self) -> np.ndarray:
        """The example's colour covariance (all texels), float64 (C, C): what the variance-preserving
        blend keeps; with a histogram transform, its diagonal standardises the blend before the tables."""
        flat = self.example.reshape(-1, self.channels).astype(np.float64)
        flat = flat - flat.mean(axis=0)
        return flat.T @ flat / max(flat.shape[0], 1)

    @property
    def mean3(self) -> np.ndarray:
        """The example's mean colour as the kernels hold it: float32 (3,), zeros past its channels."""
        return self._mean3  # type: ignore[attr-defined]

    @property
    def structure(self) -> float | None:
        """The structure score measured by ``analyze`` (``metadata["structure"]``), or None."""
        s = self.metadata.get("structure")
        return float(s) if isinstance(s, (int, float)) else None

    def save(self, path) -> None:
        """Write the model as an EXR: the example as pixels (float32), the rest as header attributes."""
        path = check_output_name(path, "path")
        if path.suffix.lower() != EXR:
            raise TextonError(f"{path}: a tiling model is saved as .exr only", param="path")
        attributes: dict[str, Any] = {
            KIND_ATTRIBUTE: TILING_KIND,
            "tiling_side": float(self.side),
            "tiling_sharpness": int(self.sharpness),
            "tiling_guide_weight": float(self.guide_weight),
            "tiling_blend": self.blend,
            "texton_metadata": metadata_json({**self.metadata, "warp_texton_version": __version__}),
        }
        if self.histogram is not None:  # as texton files store theirs: JSON, float64 values exactly
            attributes["texton_histogram"] = self.histogram.to_json()
        if any(self.wrap):
            attributes["tiling_wrap"] = json.dumps([int(self.wrap[0]), int(self.wrap[1])])
        if self.lattice is not None:
            attributes["tiling_lattice"] = json.dumps(self.lattice.to_json())
        write_exr(path, self.example, **attributes)

    def __repr__(self) -> str:
        h, w, c = self.example.shape
        extra = "" if self.histogram is None else ", histogram=preserve"
        if any(self.wrap):
            extra += f", wrap={self.wrap}"
        if self.lattice is not None:
            extra += ", lattice=" + "; ".join(f"({dy:.4g}, {dx:.4g})" for dy, dx in self.lattice.vectors)
        return (f"TilingModel(example {w}x{h}x{c}, side={self.side:g}, sharpness={self.sharpness:g}, "
                f"guide_weight={self.guide_weight:g}, blend={self.blend!r}{extra})")

    def colours(self) -> np.ndarray:
        """The example in its own colours (float32 (H, W, C)): ``example`` itself, or mapped
        back through the histogram tables when the model holds a Gaussianised example."""
        if self.histogram is None:
            return self.example
        flat = self.example.reshape(-1, self.channels)
        mean, std = self.mean, np.sqrt(np.maximum(np.diag(self.covariance()), 1e-30))
        return self.histogram.to_colours((flat - mean) / std).reshape(self.example.shape).astype(np.float32)


def _number(value, name: str, lo: float, hi: float | None) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real) \
            or not math.isfinite(float(value)) or float(value) < lo or (hi is not None and float(value) > hi):
        bound = f"in [{lo:g}, {hi:g}]" if hi is not None else f"≥ {lo:g}"
        raise TextonError(f"{name} must be a finite number {bound}, got {value!r:.60}", param=name)
    return float(value)


def _wrap_flags(value) -> tuple[bool, bool]:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2 \
            or not all(isinstance(v, (bool, np.bool_)) for v in value):
        raise TextonError(f"wrap must be a pair of booleans (x, y), got {value!r:.60}", param="wrap")
    return bool(value[0]), bool(value[1])


def centre_box(shape, side: float, wrap: tuple[bool, bool], lattice: Lattice | None):
    """((lo, n) on x, (lo, n) on y) of :attr:`TilingModel.centre_box`; a TextonError for a side the
    example cannot hold on an axis (past its size wrapped; patches crossing its border clamped)."""
    ext = (0, 0) if lattice is None else lattice.half_extent()[::-1]  # (x, y)
    box = []
    for axis, size in enumerate((shape[1], shape[0])):
        if wrap[axis]:
            if side > size:
                raise TextonError(f"side {side:g} is larger than the wrapped example ({shape[1]}x{shape[0]}); a "
                                  f"side of at most {size} shows no patch twice", param="side")
            box.append((0, int(size)))
            continue
        lo = margin_of(side) + ext[axis]
        if size <= 2 * lo + 1:
            more = " and its lattice's half cell" if ext[axis] else ""
            raise TextonError(f"side {side:g} needs an example larger than {2 * lo + 1} texels across "
                              f"{'xy'[axis]} (patches{more} stay inside it), got {shape[1]}x{shape[0]}; use a "
                              f"smaller side", param="side")
        box.append((lo, int(size) - 2 * lo))
    return box[0], box[1]


#: The longest JSON text of a model file's tiling_wrap or tiling_lattice attribute.
MAX_ATTRIBUTE_CHARS = 4096


def _attribute_json(header: dict, key: str):
    raw = header.get(key)
    if raw is None:
        return None
    if not isinstance(raw, str) or len(raw) > MAX_ATTRIBUTE_CHARS:
        raise ValueError(f"{key} is not a short JSON text")
    try:
        return json.loads(raw, parse_constant=_not_json)
    except (ValueError, RecursionError):
        raise ValueError(f"{key} is not JSON") from None


def is_tiling_header(header: dict) -> bool:
    """True when EXR header attributes are those of a tiling model."""
    return header.get(KIND_ATTRIBUTE) == TILING_KIND


def load_tiling(path) -> TilingModel:
    """Read a :class:`TilingModel` written by :meth:`TilingModel.save`."""
    path = check_path(path, "path")
    if not path.is_file():
        raise TextonError(f"{path}: no such file", param="path")
    if not is_tiling_header(read_exr_header(path)):
        raise TextonError(f"{path}: not a tiling model EXR (attribute {KIND_ATTRIBUTE} is not {TILING_KIND!r})",
                          param="path")
    example, header = read_exr(path, max_side=MAX_EXAMPLE_SIDE, what="tiling model")
    raw = header.get("texton_metadata", "{}")
    metadata = read_metadata(raw, f"{path}: malformed tiling model EXR") if isinstance(raw, str) else {}
    try:
        side, sharp, beta = (header[k] for k in ("tiling_side", "tiling_sharpness", "tiling_guide_weight"))
        if not isinstance(metadata, dict):
            raise ValueError("metadata is not a JSON object")
        metadata.pop("warp_texton_version", None)
        histogram = None
        if "texton_histogram" in header:
            histogram = HistogramTransform.from_json(header["texton_histogram"], f"{path}")
        wrap = _attribute_json(header, "tiling_wrap")
        wrap = (False, False) if wrap is None else tuple(v in (1, True) for v in wrap) if (
            isinstance(wrap, list) and len(wrap) == 2 and all(v in (0, 1) for v in wrap)) else wrap
        lattice = _attribute_json(header, "tiling_lattice")
        lattice = None if lattice is None else Lattice.from_json(lattice)
        return TilingModel(example, side, sharp, beta, metadata, header.get("tiling_blend", "linear"), histogram,
                           wrap, lattice)
    except (KeyError, ValueError, TypeError, TextonError) as exc:
        raise TextonError(f"{path}: malformed tiling model EXR: {exc}", param="path") from None


# ---------------------------------------------------------------- metadata (texton and tiling files)
#: Bounds of a model file's metadata (the JSON of its ``texton_metadata``): characters, and
#: nesting depth (Python's parser recurses once per level). Metadata is held to them when it is
#: saved (a tiling model's when it is made), so that every file written can be read back.
MAX_METADATA_CHARS = 1 << 20
MAX_METADATA_DEPTH = 64


def _json_value(value):
    # NumPy scalars and arrays are common in metadata: store them as their Python values
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(type(value).__name__)


def _short(value) -> str:
    """A value for a message: a few levels and characters of its repr (never the whole of a deep one)."""
    r = reprlib.Repr()
    r.maxlevel, r.maxstring, r.maxother = 3, 40, 40
    return r.repr(value)[:60]


def _out_of_bounds(raw: str) -> str | None:
    """What puts a metadata JSON text past MAX_METADATA_CHARS or MAX_METADATA_DEPTH, or None."""
    if len(raw) > MAX_METADATA_CHARS:
        return f"metadata of {len(raw)} characters (at most {MAX_METADATA_CHARS})"
    depth = 0
    in_string = escaped = False
    for ch in raw:  # brackets outside strings
        if in_string:
            if escaped:
                escaped = False
            elif ch == "\\":
                escaped = True
            elif ch == '"':
                in_string = False
        elif ch == '"':
            in_string = True
        elif ch in "[{":
            depth += 1
            if depth > MAX_METADATA_DEPTH:
                return f"metadata nested deeper than {MAX_METADATA_DEPTH} levels"
        elif ch in "]}":
            depth -= 1
    return None


def metadata_json(metadata: Mapping, what: str = "metadata") -> str:
    """``metadata`` as standard JSON (NumPy values as Python ones; no NaN or infinity) within the
    bounds a model file's reader takes; a value JSON cannot hold is refused naming its key."""
    for key, value in metadata.items():
        try:
            json.dumps(value, default=_json_value, allow_nan=False)
        except (TypeError, ValueError, RecursionError) as exc:
            why = f"nested deeper than {MAX_METADATA_DEPTH} levels" if isinstance(exc, RecursionError) else exc
            raise TextonError(f"{what}[{key!r}]: {type(value).__name__} value {_short(value)} cannot be saved "
                              f"(metadata must be JSON: numbers, strings, lists, dicts; {why})",
                              param="metadata") from None
    text = json.dumps(dict(metadata), default=_json_value, allow_nan=False)
    problem = _out_of_bounds(text)
    if problem is not None:
        raise TextonError(f"{what} cannot be saved: {problem}, which a model file's reader refuses",
                          param="metadata")
    return text


def _not_json(constant: str):
    raise ValueError(f"{constant} is not standard JSON")


def read_metadata(raw: str, where: str):
    """The JSON of a model file's metadata, its size and nesting bounded before it is parsed (and
    NaN or infinity refused, which :func:`metadata_json` never writes); a TextonError naming
    ``where`` (``"FILE: malformed texton EXR"``) otherwise."""
    problem = _out_of_bounds(raw)
    if problem is not None:
        raise TextonError(f"{where}: {problem}")
    try:
        return json.loads(raw, parse_constant=_not_json)
    except (ValueError, RecursionError):  # json.JSONDecodeError is a ValueError
        raise TextonError(f"{where}: metadata is not JSON") from None


def suggest_method(score: float) -> str:
    """The method that fits a texture of this structure score: ``"tiling"`` or ``"texton"``."""
    return TILING_KIND if score > STRUCTURE_THRESHOLD else "texton"


# ---------------------------------------------------------------- evaluation
