"""The output memory that noise kernels write into, cut into strips, and its hand-over.

A :class:`Canvas` is float32 memory of some shape + (3,) that the kernels of
every path (rasters, filtered pixels, plane views, points) fill through vec3
views; the front ends cut large outputs into strips of bounded work
(:func:`strips`) and hand the result over as NumPy or as a ``wp.array``
(:func:`check_output`, :func:`result_bytes`). The hand-over is where the
textons' histogram transforms map the noise to the examples' colours
(:func:`~warp_texton.noise.colours.to_colours`), once for every path that writes
into a canvas.

Kernels driven here: ``warp_texton.kernels.noise_raster``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal, overload

import numpy as np
import warp as wp

from ..core.runtime import is_cpu
from .colours import to_colours
from ..core.errors import TextonError
from ..kernels import noise_raster
from ..model.texton import Texton

#: Work of one strip of a large raster (or one group of a batch), in raster
#: pixels: a few tenths of a second on two cores, so that a progress bar moves
#: and Ctrl-C stops within one strip.
STRIP_WORK = 1 << 22
OUTPUTS = ("numpy", "warp")
#: Bytes of one float32 vec3 value: the kernels' view of three channels.
VEC3_BYTES = 12
#: Channels a canvas holds per value: 1 (a grey texton without a histogram
#: transform: its kernels read and write one float) or 3 (vec3: every other case).
LANES = (1, 3)


def lanes_for(textons: Sequence[Texton]) -> int:
    """The lanes a canvas for ``textons`` needs: 1 when all are grey and none has a
    histogram transform (its mapping works on three lanes), else 3."""
    return 1 if all(t.channels == 1 and t.histogram is None for t in textons) else 3


class Canvas:
    """Float32 output memory ``shape`` + (lanes,) that the kernels write through
    vec3 views (``lanes`` 3, the default) or float views (``lanes`` 1, grey
    textons: see :func:`lanes_for`): NumPy on the CPU (zero pages, touched first
    by the threads that fill them), a ``wp.array`` on a CUDA device.

    ``result(channels, output, textons=...)`` hands it over as NumPy
    (``output="numpy"``; a copy from a GPU) or as a ``wp.array`` on the device
    (``output="warp"``), after mapping the values of item k (the first axis cut
    into ``len(textons)`` equal items) through ``textons[k]``'s histogram
    transform, if it has one; filtered pixels first record the share of the
    variance they kept (:meth:`keep_shares`).
    """

    def __init__(self, shape, device, lanes: int = 3):
        if lanes not in LANES:
            raise ValueError(f"lanes must be one of {LANES}, got {lanes!r}")
        self.shape = tuple(int(s) for s in shape)
        self.device = device
        self.lanes = lanes
        self.dtype = wp.float32 if lanes == 1 else wp.vec3
        if is_cpu(device):
            self.host: np.ndarray | None = np.zeros(self.shape + (lanes,), np.float32)
            self.data: wp.array = wp.array(self.host, dtype=wp.float32, device=device, copy=False)
        else:
            self.host = None
            self.data = wp.zeros(self.shape + (lanes,), dtype=wp.float32, device=device)
        self.size = int(np.prod(self.shape))
        self.shares: np.ndarray | None = None

    def keep_shares(self, start: int, stop: int, shares) -> None:
        """Values start…stop kept ``shares`` of the noise's variance (filtered pixels)."""
        if self.shares is None:
            self.shares = np.ones(self.size)
        self.shares[start:stop] = shares

    def pixels(self, start: int, stop: int) -> wp.array:
        """Values start…stop (row-major order) as a 1-D view (vec3, or float for one lane)."""
        return wp.array(ptr=self.data.ptr + start * 4 * self.lanes, dtype=self.dtype, shape=(stop - start,),
                        device=self.device)

    def rows(self, width: int) -> wp.array:
        """All values as a (size / width, width) view (vec3, or float for one lane)."""
        return wp.array(ptr=self.data.ptr, dtype=self.dtype, shape=(self.size // width, width), device=self.device)

    @overload
    def result(self, channels: int, output: Literal["numpy"], *,
               textons: Sequence[Texton | None]) -> np.ndarray: ...

    @overload
    def result(self, channels: int, output: str, *,
               textons: Sequence[Texton | None]) -> np.ndarray | wp.array: ...

    def result(self, channels: int, output: str, *,
               textons: Sequence[Texton | None]) -> np.ndarray | wp.array:
        if any(t is not None and t.histogram is not None for t in textons):
            self._to_colours(textons)
        if output == "warp":
            return self.data if channels == self.lanes else \
                self.data[(slice(None),) * len(self.shape) + (slice(0, channels),)].contiguous()
        a = self.host if self.host is not None else self.data.numpy()
        return a if channels == self.lanes else np.ascontiguousarray(a[..., :channels])

    def _to_colours(self, textons) -> None:
        assert self.lanes == 3, "histogram transforms map three lanes (lanes_for)"
        a = self.host if self.host is not None else self.data.numpy()
        flat = a.reshape(len(textons), -1, 3)
        per = flat.shape[1]
        for k, t in enumerate(textons):
            share = None if self.shares is None else self.shares[k * per:(k + 1) * per]
            to_colours(flat[k], t, share)
        if self.host is None:
            self.data.assign(a)  # mapped on the host: one upload


def fill_pixels(out, index: np.ndarray, mean, device, compute) -> None:
    """``out`` (an (N,) vec3 or float array) holds ``mean`` except at ``index``, where
    ``compute(target)`` writes its values (into ``out`` itself when every pixel
    is computed, else through a scatter on the device)."""
    n = out.shape[0]
    with wp.ScopedDevice(device):
        if index.size == n:
            compute(out)
            return
        if out.dtype == wp.float32:  # one lane
            out.fill_(float(mean[0]))
        else:
            out.fill_(wp.vec3(*(float(v) for v in mean)))
        if index.size:
            values = wp.empty(index.size, dtype=out.dtype)
            compute(values)
            wp.launch(noise_raster.scatter_values, dim=index.size, inputs=[values, wp.array(index.astype(np.int64), dtype=wp.int64), out])


def strips(h: int, w: int, cost: int = 1) -> list[tuple[int, int]]:
    """Row ranges (r0, r1) cutting an H × W raster into strips of about STRIP_WORK,
    for pixels that each cost ``cost`` raster pixels."""
    rows = max(1, STRIP_WORK // max(1, w * cost))
    return [(r0, min(h, r0 + rows)) for r0 in range(0, h, rows)]


def group_size(h: int, w: int) -> int:
    """How many H × W rasters of a batch one pass computes: about STRIP_WORK pixels."""
    return max(1, STRIP_WORK // (h * w))


def result_bytes(count: int, h: int, w: int, channels: int, device, output: str, lanes: int = 3) -> int:
    """Bytes of a float32 (count, H, W, lanes) canvas plus what handing it over copies."""
    n = count * h * w
    extra = 0
    if channels != lanes:
        extra = n * channels * 4  # the channels taken out of the canvas
    elif output == "numpy" and not is_cpu(device):
        extra = n * lanes * 4  # the copy to the host
    return n * lanes * 4 + extra


def check_output(output) -> str:
    """``"numpy"`` or ``"warp"``."""
    if not isinstance(output, str) or output not in OUTPUTS:
        raise TextonError(f"output must be one of {', '.join(OUTPUTS)}, got {output!r}")
    return output
