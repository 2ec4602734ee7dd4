"""The texton: interpolation coefficients α, a mean colour and an order.

h(y) = Σ_k α(k) ψ(y − k) with ψ the centred B-spline of the texton's order
(CGF eq. (3)). Coefficient (row i, column j) sits at texel position
(x, y) = (j, i). Files: EXR (coefficients as pixels, the rest as header
attributes) and the version-1 ``.texton`` text format of the authors'
reference viewer.
"""

from __future__ import annotations

import numbers
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..core.checks import CHANNELS, MAX_TEXTON_SIDE, MAX_VALUE, as_real_array, check_path, check_range, check_shape
from .bspline import ORDERS, kernel_width, sampled_autocorrelation
from ..core.errors import TextonError
from .histogram import HistogramTransform
from .tiling import TilingModel, is_tiling_header, load_tiling, metadata_json, read_metadata
from .tiling import MAX_METADATA_CHARS, MAX_METADATA_DEPTH  # noqa: F401 - this module's names since 0.2
from ..core.limits import check_memory
from ..files.images import EXR, atomic_path, check_output_name, is_texton_header, read_exr, read_exr_header, write_exr

TEXTON_EXT = ".texton"
#: Version of the metadata layout in EXR textons written by this package.
EXR_TEXTON_VERSION = 1
#: Largest .texton text file read (a 4096² RGB texton in text is far smaller).
MAX_TEXTON_FILE_BYTES = 64 * 1024 * 1024


@dataclass(frozen=True, eq=False)
class Texton:
    """A texton: what texton noise needs besides a seed and an MNI.

    Attributes
    ----------
    coeffs : float32 array (r, s, C)
        Interpolation coefficients α, C in {1, 3}.
    mean : float32 array (C,)
        Mean colour m of the noise.
    order : int
        Interpolation order: 0 (nearest, the EUSIPCO SOT), 1 (bilinear, the
        CGF default), 3 or 5 (B-splines, CGF §10).
    metadata : dict
        Provenance (source image, analysis parameters, model error...); any
        JSON-serialisable values, with string keys.
    histogram : HistogramTransform, optional
        The map from the noise's Gaussian values to the example's colours
        (``analyze(..., histogram="preserve")``); every output applies it
        after the noise (docs/histogram.md). None: the noise's values are
        the output.

    Raises
    ------
    TextonError
        For coefficients or means that are not numbers, not finite or beyond
        ±10¹⁰; coefficient shapes other than (r, s) or (r, s, 1|3); sides
        above 4096; a mean of another channel count; an order other than 0,
        1, 3, 5; metadata that is not a dict with string keys; and a
        ``histogram`` that is not a HistogramTransform of the texton's
        channel count.

    See Also
    --------
    analyze : learns a texton from an example image.
    load_texton : reads one written by :meth:`save`.

    Notes
    -----
    The members the noise reads: ``support_area`` (λ = MNI / support_area),
    ``integral`` (∫h), ``covariance()`` (the noise's lag-0 colour covariance)
    and ``spectrum(shape)`` (the sampled power spectrum's square root). The
    file layouts are in docs/model.md §8.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton
    >>> t = Texton(np.random.default_rng(0).normal(size=(8, 8, 3)) * 0.01, mean=[0.5, 0.4, 0.3])
    >>> t.size, t.channels, t.support_area
    ((8, 8), 3, 81.0)
    >>> t.covariance().shape, t.spectrum((16, 16)).shape
    ((3, 3), (16, 16, 3))
    """

    coeffs: np.ndarray
    mean: np.ndarray
    order: int = 1
    metadata: dict = field(default_factory=dict)
    histogram: HistogramTransform | None = None

    def __post_init__(self):
        a = as_real_array(self.coeffs, "texton coefficients", "an array (r, s) or (r, s, C) of numbers")
        if a.ndim == 2:
            a = a[:, :, None]
        if a.ndim != 3 or a.shape[2] not in CHANNELS or min(a.shape[:2]) < 1:
            raise TextonError(
                f"texton coefficients must have shape (r, s, 1) or (r, s, 3), got {a.shape}"
            )
        if max(a.shape[:2]) > MAX_TEXTON_SIDE:
            raise TextonError(f"texton coefficients: {a.shape[1]}x{a.shape[0]}; at most {MAX_TEXTON_SIDE} "
                              "per side (textons are small by design)")
        check_range(a, "texton coefficients", MAX_VALUE, "values")
        a = np.ascontiguousarray(a, dtype=np.float32)
        m = np.atleast_1d(as_real_array(self.mean, "texton mean", "one number per channel")).ravel()
        if m.shape != (a.shape[2],):
            raise TextonError(
                f"texton mean must be {a.shape[2]} finite values (one per channel), got {self.mean!r:.80}"
            )
        check_range(m, "texton mean", MAX_VALUE, "values")
        m = m.astype(np.float32)
        if isinstance(self.order, (bool, np.bool_)) or not isinstance(self.order, numbers.Integral) \
                or self.order not in ORDERS:
            raise TextonError(f"texton order must be one of {', '.join(map(str, ORDERS))}, got {self.order!r:.60}")
        if not isinstance(self.metadata, Mapping) or not all(isinstance(k, str) for k in self.metadata):
            raise TextonError(f"texton metadata must be a dict with string keys, got {self.metadata!r:.80}")
        if self.histogram is not None and (not isinstance(self.histogram, HistogramTransform)
                                           or self.histogram.channels != a.shape[2]):
            raise TextonError(f"texton histogram must be a HistogramTransform of {a.shape[2]} channels or None, "
                              f"got {self.histogram!r:.60}", param="histogram")
        a.setflags(write=False)
        m.setflags(write=False)
        object.__setattr__(self, "coeffs", a)
        object.__setattr__(self, "mean", m)
        object.__setattr__(self, "order", int(self.order))
        object.__setattr__(self, "metadata", dict(self.metadata))

    # ------------------------------------------------------------------ model
    @property
    def channels(self) -> int:
        """C, the number of channels: 1 (grey) or 3 (RGB)."""
        return self.coeffs.shape[2]

    @property
    def size(self) -> tuple[int, int]:
        """(rows, columns) of the coefficient array."""
        return self.coeffs.shape[:2]

    @property
    def support_mask(self) -> np.ndarray:
        """Coefficients that are non-zero in some channel."""
        return np.any(self.coeffs != 0, axis=2)

    @property
    def support_area(self) -> float:
        """Area of supp h in texels²: the union of the supports of ψ(· − k) over
        the non-zero coefficients. A full r × s texton of order k covers
        (r + k)(s + k). The noise intensity is λ = MNI / support_area (CGF §3.3).
        """
        w = kernel_width(self.order)
        mask = self.support_mask
        if w > 1:
            # Each coefficient covers the w × w unit cells of its ψ support: the union
            # of the mask shifted by 0..w-1 cells each way (a dilation, without SciPy's
            # import time at every command's start).
            r, s = mask.shape
            covered = np.zeros((r + w - 1, s + w - 1), bool)
            for di in range(w):
                for dj in range(w):
                    covered[di:di + r, dj:dj + s] |= mask
            mask = covered
        return float(np.count_nonzero(mask))

    @property
    def integral(self) -> np.ndarray:
        """∫h per channel: Σ α, since every ψ integrates to 1."""
        return self.coeffs.sum(axis=(0, 1), dtype=np.float64)

    def covariance(self) -> np.ndarray:
        """Lag-0 colour covariance of the noise, C × C: ∫ h hᵀ.

        Equals Σ_τ b(τ) Σ_x α(x) α(x + τ)ᵀ with b the sampled ψ * ψ (CGF §4.1).
        """
        return lag0_covariance(self.coeffs.astype(np.float64), self.order)

    def spectrum(self, shape: tuple[int, int]) -> np.ndarray:
        """DFT of the model kernel on an M × N grid: α̂ √b̂, shape (M, N, C).

        Its squared modulus is the sampled power spectrum |α̂|² b̂ of the noise
        (CGF eq. (4)). The coefficients are placed at the grid origin.
        """
        from .bspline import bhat

        m, n = check_shape(shape)
        check_memory(40.0 * m * n * self.channels, f"the spectrum of a texton on a {n}x{m} grid", "use a smaller grid")
        r, s = self.size
        if r > m or s > n:
            raise TextonError(f"a {s}x{r} texton does not fit on a {n}x{m} grid")
        a_hat = np.fft.fft2(self.coeffs.astype(np.float64), s=(m, n), axes=(0, 1))
        return a_hat * np.sqrt(bhat((m, n), self.order))[:, :, None]

    # ------------------------------------------------------------------ files
    def save(self, path) -> None:
        """Write the texton to ``.exr`` or ``.texton`` (by extension), atomically.

        The EXR holds the coefficients as float32 with the order, mean,
        metadata and histogram transform in its header, exactly; ``.texton``
        is the text format of the authors' viewer (9 significant digits),
        which has no place for a histogram transform. NumPy values in
        ``metadata`` are stored as Python ones.

        Raises
        ------
        TextonError
            For another extension, a path that cannot be written, metadata
            values JSON cannot hold (naming their key), and a texton with a
            histogram transform saved as ``.texton``.
        """
        path = check_output_name(path, "path")
        ext = path.suffix.lower()
        if ext == EXR:
            attributes: dict[str, Any] = dict(
                texton_version=EXR_TEXTON_VERSION,
                texton_order=self.order,
                texton_mean=[float(v) for v in self.mean],
                texton_metadata=metadata_json({**self.metadata, "warp_texton": __version__}, "texton metadata"),
            )
            if self.histogram is not None:  # JSON: float64 values round-trip exactly
                attributes["texton_histogram"] = self.histogram.to_json()
            write_exr(path, self.coeffs, **attributes)
        elif ext == TEXTON_EXT:
            if self.histogram is not None:
                # the reference viewer would read the file and show Gaussian noise: a wrong texture
                raise TextonError(f"{path}: the .texton format cannot hold a histogram transform (the authors' "
                                  "viewer would show the Gaussian noise); save it as .exr", param="path")
            text = _format_texton_text(self)
            with atomic_path(path) as tmp:
                Path(tmp).write_text(text, encoding="ascii")
        else:
            raise TextonError(f"{path}: unsupported texton extension {ext or '(none)'!r}; use .exr or .texton")

    def __repr__(self) -> str:
        r, s = self.size
        extra = "" if self.histogram is None else ", histogram=preserve"
        return (f"Texton({s}x{r}, channels={self.channels}, order={self.order}, "
                f"mean={[round(float(v), 4) for v in self.mean]}{extra})")


def lag0_covariance(alpha: np.ndarray, order: int) -> np.ndarray:
    """∫ h hᵀ for coefficients alpha (r, s, C): Σ_τ b(τ) Σ_x α(x) α(x+τ)ᵀ."""
    b = sampled_autocorrelation(order)
    k = order
    r, s, c = alpha.shape
    out = np.zeros((c, c))
    for dy in range(-k, k + 1):
        for dx in range(-k, k + 1):
            if abs(dy) >= r or abs(dx) >= s:
                continue  # no pair at this lag (and the slices below would wrap)
            w = b[k + dy] * b[k + dx]
            # pairs (x, x + τ) that both lie inside the coefficient array
            a0 = alpha[max(0, -dy): r - max(0, dy), max(0, -dx): s - max(0, dx)]
            a1 = alpha[max(0, dy): r + min(0, dy), max(0, dx): s + min(0, dx)]
            if a0.size:
                out += w * a0.reshape(-1, c).T @ a1.reshape(-1, c)
    return 0.5 * (out + out.T)


# ---------------------------------------------------------------- .texton text
def _format_texton_text(t: Texton) -> str:
    """The reference viewer's version-1 layout.

    Lines: ``TEXTON``; version ``1``; the order; the RGB mean; ``width height``
    of the stored array, which carries a one-texel zero frame (the viewer needs
    the kernel to vanish on the texture border); then width × height lines of
    three coefficients, bottom row first, each row left to right (OpenGL
    order); then a free ``Original image: NAME (W x H)`` line. Grey textons are
    stored as three equal channels.
    """
    a = t.coeffs
    mean = t.mean
    if t.channels == 1:
        a = np.repeat(a, 3, axis=2)
        mean = np.repeat(mean, 3)
    framed = np.pad(a, ((1, 1), (1, 1), (0, 0)))
    h, w = framed.shape[:2]
    rows = framed[::-1].reshape(-1, 3)
    lines = ["TEXTON", "1", str(t.order), " ".join(f"{float(v):.9e}" for v in mean), f"{w} {h}"]
    lines.extend(f"{x:.9e} {y:.9e} {z:.9e}" for x, y, z in rows.tolist())
    # The format is ASCII: a non-ASCII source name must not make the save fail.
    src = str(t.metadata.get("source", "unknown")).replace("\n", " ")
    src = src.encode("ascii", "replace").decode("ascii")
    try:
        src_rows, src_cols = (int(v) for v in t.metadata.get("source_shape") or (0, 0))
    except (TypeError, ValueError, OverflowError):
        src_rows, src_cols = 0, 0  # the line is informative only
    lines.append(f"Original image: {src} ({src_cols} x {src_rows})")
    return "\n".join(lines) + "\n"


def _texton_header(lines: list[str], bad) -> tuple[int, np.ndarray, int, int]:
    """(order, mean, width, height) from the five header lines of a .texton file."""
    if not lines or lines[0].strip() != "TEXTON":
        raise bad("the first line must be TEXTON")
    try:
        version = int(lines[1])
        order = int(lines[2])
        mean = np.array([float(v) for v in lines[3].split()], dtype=np.float64)
        w, h = (int(v) for v in lines[4].split())
    except (IndexError, ValueError):
        raise bad("the header must be TEXTON, version, order, three mean values, 'width height'") from None
    if version != 1:
        raise bad(f"version {version} is not supported (only version 1)")
    if order not in ORDERS:
        raise bad(f"order {order} is not one of {', '.join(map(str, ORDERS))}")
    if mean.shape != (3,) or not np.isfinite(mean).all():
        raise bad("the mean line must hold three finite values")
    if not (1 <= w <= MAX_TEXTON_SIDE and 1 <= h <= MAX_TEXTON_SIDE):
        raise bad(f"size {w} x {h} is outside 1..{MAX_TEXTON_SIDE}")
    return order, mean, w, h


def _parse_texton_text(path: Path) -> Texton:
    def bad(what):
        return TextonError(f"{path}: malformed .texton file: {what}")

    try:
        with open(path, "rb") as f:
            raw = f.read(MAX_TEXTON_FILE_BYTES + 1)
    except OSError as exc:
        raise TextonError(f"{path}: cannot read ({exc.strerror})") from None
    if len(raw) > MAX_TEXTON_FILE_BYTES:
        raise bad(f"larger than {MAX_TEXTON_FILE_BYTES >> 20} MiB")
    try:
        text = raw.decode("ascii")
    except UnicodeDecodeError:
        raise bad("not ASCII text") from None
    lines = text.splitlines()
    order, mean, w, h = _texton_header(lines, bad)
    body = lines[5: 5 + w * h]
    if len(body) < w * h:
        raise bad(f"expected {w * h} coefficient lines, found {len(body)}")
    try:
        vals = np.array(" ".join(body).split(), dtype=np.float64)
    except ValueError:
        raise bad("a coefficient line holds something other than numbers") from None
    # per line too: a 4-value line next to a 2-value one would shift every texel
    if vals.size != 3 * w * h or any(len(line.split()) != 3 for line in body):
        raise bad(f"expected 3 values on each of {w * h} coefficient lines")
    if not np.isfinite(vals).all():
        raise bad("coefficients must be finite")
    a = vals.reshape(h, w, 3)[::-1]
    # Strip the zero frame the format carries, when it is there.
    if h >= 3 and w >= 3 and not (a[0].any() or a[-1].any() or a[:, 0].any() or a[:, -1].any()):
        a = a[1:-1, 1:-1]
    metadata: dict[str, object] = {"format": "texton-v1"}
    tail = " ".join(lines[5 + w * h:]).strip()
    m = re.match(r"Original image:\s*(.*?)\s*\((\d+)\s*x\s*(\d+)\)\s*$", tail)
    if m:
        metadata["source"] = m.group(1)
        metadata["source_shape"] = [int(m.group(3)), int(m.group(2))]
    if np.array_equal(a[:, :, 0], a[:, :, 1]) and np.array_equal(a[:, :, 0], a[:, :, 2]) and mean[0] == mean[1] == mean[2]:
        a, mean = a[:, :, :1], mean[:1]
    return _checked_texton(path, a, mean, order, metadata)


def _checked_texton(path: Path, coeffs, mean, order, metadata, histogram=None) -> Texton:
    # values a Texton refuses (beyond MAX_VALUE, say) are a malformed file, named as such
    try:
        return Texton(coeffs, mean, order, metadata, histogram)
    except TextonError as exc:
        raise TextonError(f"{path}: malformed texton file: {exc}") from None


def _load_exr_texton(path: Path) -> Texton:
    if not is_texton_header(read_exr_header(path)):
        raise TextonError(
            f"{path}: not a texton EXR (missing attribute texton_order); "
            "an image must be analysed first (warp-texton analyze)"
        )
    coeffs, header = read_exr(path, max_side=MAX_TEXTON_SIDE, what="texton")
    missing = [k for k in ("texton_order", "texton_mean") if k not in header]
    if missing:
        raise TextonError(
            f"{path}: not a texton EXR (missing attribute {', '.join(missing)}); "
            "an image must be analysed first (warp-texton analyze)"
        )
    order = header["texton_order"]
    if not isinstance(order, int) or isinstance(order, bool) or order not in ORDERS:
        raise TextonError(f"{path}: malformed texton EXR: order {order!r} is not one of {ORDERS}")
    try:
        mean = np.asarray(header["texton_mean"], dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise TextonError(f"{path}: malformed texton EXR: texton_mean is not a list of numbers") from None
    if mean.shape != (coeffs.shape[2],):
        raise TextonError(
            f"{path}: malformed texton EXR: {mean.size} mean values for {coeffs.shape[2]} channels"
        )
    metadata = {}
    raw = header.get("texton_metadata")
    if isinstance(raw, str):
        metadata = read_metadata(raw, f"{path}: malformed texton EXR")
        if not isinstance(metadata, dict):
            raise TextonError(f"{path}: malformed texton EXR: metadata is not a JSON object")
    histogram = None
    if "texton_histogram" in header:
        histogram = HistogramTransform.from_json(header["texton_histogram"], f"{path}")
    return _checked_texton(path, coeffs, mean, order, metadata, histogram)


def load_texton(path) -> Texton | TilingModel:
    """Read a texton from ``.exr`` (written by :meth:`Texton.save`) or ``.texton``.

    ``.texton`` files from the authors' reference viewer are accepted: their
    zero frame is removed and three equal channels become one grey channel.

    Parameters
    ----------
    path : str or Path
        A ``.exr`` or ``.texton`` file (layouts in docs/model.md §8).

    Returns
    -------
    Texton or TilingModel
        A :class:`~warp_texton.model.tiling.TilingModel` for an EXR whose attribute
        ``texton_kind`` is ``"tiling"`` (``TilingModel.save``); files without
        the attribute are textons, as before.

    Raises
    ------
    TextonError
        Missing file, unknown extension, or a malformed file (including sizes
        and values the :class:`Texton` constructor refuses, and files over
        the memory budget).

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton, load_texton
    >>> t = Texton(np.random.default_rng(0).normal(size=(8, 8, 3)) * 0.01, mean=[0.5, 0.4, 0.3])
    >>> t.save("small.exr")
    >>> t.save("small.texton")
    >>> back = load_texton("small.exr")
    >>> bool(np.array_equal(back.coeffs, t.coeffs))
    True
    >>> again = load_texton("small.texton")      # 9 significant digits in text
    >>> bool(np.allclose(again.coeffs, t.coeffs, rtol=1e-7, atol=1e-12))
    True
    """
    path = check_path(path, "path")
    if not path.is_file():
        raise TextonError(f"{path}: no such file")
    ext = path.suffix.lower()
    if ext == EXR:
        if is_tiling_header(read_exr_header(path)):
            return load_tiling(path)
        return _load_exr_texton(path)
    if ext == TEXTON_EXT:
        return _parse_texton_text(path)
    raise TextonError(f"{path}: unsupported texton extension {ext or '(none)'!r}; use .exr or .texton")


def is_texton_path(path) -> bool:
    """True when ``path`` names a texton file rather than an image."""
    path = check_path(path, "path")
    ext = path.suffix.lower()
    if ext == TEXTON_EXT:
        return True
    if ext == EXR and path.is_file():
        try:
            return is_texton_header(read_exr_header(path))
        except TextonError:
            return False
    return False


def as_texton(model, what: str) -> Texton:
    """``model`` when it is a :class:`Texton`; a tiling model is refused with one clear error naming ``what``."""
    if isinstance(model, TilingModel):
        raise TextonError(f"{what} takes a texton; tiling models (method 'tiling') work with synthesize and "
                          "evaluate only so far (docs/tiling.md)", param="texton")
    return model
