"""The viewer's pictures: tiles as PNG (stored as ``write_image`` stores them),
and the side panel's texton and spectra as data URLs."""

from __future__ import annotations

import base64
import io

import numpy as np

from ..model.texton import Texton

#: zlib level of tile PNGs. Noise hardly compresses: level 1 makes tiles 26 % smaller
#: than level 0 (stored) but costs 6 ms instead of 2.6 ms for 256² RGB, more than
#: the noise itself, so 0 fills a view a third faster (benchmarks/bench_view.py).
#: Over a slow link (SSH from afar) a higher level can pay: ``serve(png_level=...)``.
PNG_LEVEL = 0


def to_8bit(img: np.ndarray) -> np.ndarray:
    """Values as ``write_image`` stores them in a PNG: clipped, rounded to 8 bits."""
    return np.round(np.clip(img, 0.0, 1.0) * 255.0).astype(np.uint8)


def png_bytes(img: np.ndarray, level: int = PNG_LEVEL) -> bytes:
    from PIL import Image

    q = to_8bit(img)
    buf = io.BytesIO()
    Image.fromarray(q[:, :, 0] if q.shape[2] == 1 else q).save(buf, format="PNG", compress_level=level)
    return buf.getvalue()


def data_url(img: np.ndarray, side: int | None = None, nearest: bool = False) -> str:
    from PIL import Image

    q = to_8bit(img)
    im = Image.fromarray(q[:, :, 0] if q.shape[2] == 1 else q)
    if side is not None:
        k = side / max(im.size)
        size = (max(1, round(im.size[0] * k)), max(1, round(im.size[1] * k)))
        im = im.resize(size, Image.Resampling.NEAREST if nearest else Image.Resampling.LANCZOS)
    buf = io.BytesIO()
    im.save(buf, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def texton_picture(texton: Texton) -> np.ndarray:
    """The coefficients for viewing, in the texture's colours: the noise's mean plus
    the coefficients' deviations, ±3 standard deviations (shared by the channels) spanning ±0.45."""
    a = texton.coeffs.astype(np.float64)
    a = a - a.mean(axis=(0, 1))
    spread = 3.0 * float(a.std()) or 1.0
    return (texton.mean + 0.45 * a / spread).astype(np.float32)


def log_spectra(*spectra: np.ndarray, decades: float = 5.0) -> list[np.ndarray]:
    """Power spectra (H, W) as pictures on one log scale, zero frequency at the centre."""
    logs = [np.log10(np.fft.fftshift(np.maximum(s, 1e-30))) for s in spectra]
    top = max(float(v.max()) for v in logs)
    return [np.clip((v - (top - decades)) / decades, 0.0, 1.0)[:, :, None].astype(np.float32) for v in logs]
