"""The table of the property suite: every public function, how to draw its arguments,
and what its valid output looks like.

Each :class:`Entry` names a function (``module:attribute``, imported in the worker
process of tests/property_worker.py) and gives, per parameter,

* ``valid``: a composite strategy drawing a whole set of valid arguments (parameters
  that depend on each other, such as a ρ map and the raster shape, are drawn
  together);
* ``refused``: values that must be refused with a ``TextonError`` whose message
  names the parameter (wrong types, strings where numbers are meant, NaN, wrong
  shapes, values out of range);
* ``edges``: values that may be accepted or refused, but never with another
  exception, a crash, a hang or a file left behind (huge, tiny, far away).

``check`` (a function here, run in the worker) says whether a returned value is
valid output; ``may_refuse`` is a pattern of the refusals valid arguments may
still meet (a constant image, a budget). A new public function is registered
with one more entry in ``ENTRIES``.

Wrappers at the end give the worker a picklable call for what takes a file or a
mesh: the worker writes the drawn bytes or builds the mesh, then calls the API.
"""

from __future__ import annotations

import functools
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

NAN, INF = float("nan"), float("inf")


@dataclass
class Entry:
    """One public function of the table (see the module's docstring)."""

    name: str
    target: str
    valid: st.SearchStrategy  # draws a dict of valid keyword arguments
    refused: dict = field(default_factory=dict)  # parameter -> strategy of values to refuse
    edges: dict = field(default_factory=dict)  # parameter -> strategy of values accepted or refused
    check: str | None = None  # name of a check function below: (result, kwargs) -> problem or None
    may_refuse: str = r"memory budget|work budget"  # refusals valid arguments may meet
    names: dict = field(default_factory=dict)  # parameter -> the name its messages use, if not its own
    files: tuple = ()  # parameters that name files: placed in a fresh folder per call
    xfail: str | None = None  # a known failure, reported without failing the suite: where it is tracked
    needs: tuple = ()  # optional packages (an extra) it needs: skipped where one is not installed


# ------------------------------------------------------------------ values
@dataclass(frozen=True)
class Broadcast:
    """An array view far larger than its memory (np.broadcast_to), made in the worker:
    pickling the view itself would copy all of it."""

    value: float
    shape: tuple
    dtype: str = "float32"

    def make(self):
        return np.broadcast_to(np.asarray(self.value, self.dtype), self.shape)


def floats(lo, hi):
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False)


#: Things that are not numbers (nor arrays of them); all picklable.
JUNK = st.sampled_from([None, "x", "30", "1e3", b"1", [], {}, [1, "a"], (1,), 1j, {1}, Ellipsis, True, False])
NON_FINITE = st.sampled_from([NAN, INF, -INF, np.float32("nan"), np.float64("-inf")])


def not_numbers():
    return st.one_of(JUNK, st.text(max_size=4), st.just(np.array(["1.0"])), st.just(np.str_("2")))


#: Positive numbers whose float32 copy or reciprocal leaves float32's normal range (0, ∞,
#: subnormals): every positive-real parameter refuses them (``_checks.check_positive``).
OUT_OF_FLOAT32 = st.sampled_from([5e-324, 1e-320, 1e-45, 1e-39, 1e38, 3.4e38, 1e39, 1e300, 10**40])


def refused_positive():
    """Values a finite positive number parameter must refuse."""
    return st.one_of(not_numbers(), NON_FINITE, floats(-1e300, 0.0), st.integers(-10**20, 0), OUT_OF_FLOAT32)


def refused_number():
    return st.one_of(not_numbers(), NON_FINITE)


def refused_int(minimum=None):
    bad = [not_numbers(), st.sampled_from([1.5, 2.0, np.float64(3.0), NAN, INF])]
    if minimum is not None:
        bad.append(st.integers(-10**20, minimum - 1))
    return st.one_of(*bad)


def huge_and_tiny():
    return st.sampled_from([1e-300, 1e-30, 1e-8, 1e8, 1e30, 1e300, np.float32(3.4e38), 2**63, 10**30])


def pairs(element):
    return st.tuples(element, element)


def refused_pair():
    """Values a pair of numbers must refuse: not pairs, or pairs of non-numbers."""
    return st.one_of(JUNK.filter(lambda v: not isinstance(v, tuple)), st.just("ab"), st.just((1.0, 2.0, 3.0)),
                     pairs(refused_number()))


# ------------------------------------------------------------------ arrays and images
IMAGE_DTYPES = [np.float32, np.float64, np.uint8, np.uint16, np.int16, np.bool_]


@st.composite
def images(draw, min_side=8, max_side=40, channels=(1, 3)):
    """A valid image array: float, integer (scaled by its range) or boolean, grey or RGB."""
    h = draw(st.integers(min_side, max_side))
    w = draw(st.integers(min_side, max_side))
    c = draw(st.sampled_from([None, *channels]))
    dtype = np.dtype(draw(st.sampled_from(IMAGE_DTYPES)))
    shape = (h, w) if c is None else (h, w, c)
    if dtype.kind == "f":
        scale = draw(st.sampled_from([1.0, 1.0, 1e-3, 1e3, 1e9]))
        # drawn at the array's own width: a float64 value rounded to float32 is refused by
        # Hypothesis with NumPy 1.x, and so is a float32 subnormal that NumPy flushes to zero
        width = 8 * dtype.itemsize
        bound = float(dtype.type(scale))  # the bounds too must be values of the dtype
        elements = st.floats(-bound, bound, allow_nan=False, allow_infinity=False, width=width,
                             allow_subnormal=width == 64)
        return draw(hnp.arrays(dtype, shape, elements=elements))
    return draw(hnp.arrays(dtype, shape))


def refused_images(writing=False):
    """Image arguments to refuse: not arrays, wrong shapes, non-finite or overflowing values
    (for ``writing``: beyond float32, where the analysis refuses beyond ±MAX_VALUE)."""
    rng = np.random.default_rng(0)
    base = rng.random((12, 12))
    with_nan = base.copy()
    with_nan[3, 4] = NAN
    with_inf = base.copy()
    with_inf[0, 0] = -INF
    return st.one_of(
        JUNK,
        st.sampled_from([
            np.zeros(0), np.zeros((0, 5)), np.zeros((5, 0, 3)), base[0], base[None, :, :, None],
            np.zeros((8, 8, 2)), np.zeros((8, 8, 5)), with_nan, with_inf, *([] if writing else [base * 1e20, base * 1e38]),
            np.full((8, 8), 1e300), base.astype(complex), np.array([["a", "b"], ["c", "d"]]),
            np.array([[None, 1.0], [2.0, 3.0]], dtype=object),
            Broadcast(0.5, (100_000, 100_000)),  # 40 GB as float32: over any budget
        ]),
    )


@st.composite
def textons(draw, max_side=8, channels=None, order=None, size=None):
    """A valid Texton (small, so that calls stay fast)."""
    from warp_texton import Texton

    r, s = size or (draw(st.integers(1, max_side)), draw(st.integers(1, max_side)))
    c = channels or draw(st.sampled_from([1, 3]))
    k = draw(st.sampled_from([0, 1, 3, 5])) if order is None else order
    coeffs = draw(hnp.arrays(np.float32, (r, s, c), elements=st.floats(-1.0, 1.0, width=32)))
    if not np.any(coeffs):
        coeffs[0, 0, 0] = 0.5  # an all-zero texton has no noise to make: refused, tested apart
    mean = draw(hnp.arrays(np.float64, (c,), elements=floats(-2.0, 2.0)))
    return Texton(coeffs, mean, k)


def refused_textons():
    return st.one_of(JUNK, st.just(np.ones((4, 4))), st.just({"coeffs": [[1.0]], "mean": [0.5]}))


def points(max_n=40, reach=1e5):
    return st.integers(0, max_n).flatmap(
        lambda n: hnp.arrays(np.float64, (n, 2), elements=floats(-reach, reach)))


def refused_points():
    return st.one_of(JUNK, st.sampled_from([
        np.zeros((3, 3)), np.zeros(4), np.zeros((2, 2, 2)), np.array([[NAN, 0.0]]), np.array([[0.0, INF]]),
        np.array([["1", "2"]]), [[1.0, "a"]], np.array([[1 + 2j, 0]]), [[True, False]],
    ]))


def shapes(lo=1, hi=40):
    return st.tuples(st.integers(lo, hi), st.integers(lo, hi))


def refused_shapes():
    return st.one_of(JUNK.filter(lambda v: not isinstance(v, tuple)), st.sampled_from([
        (0, 8), (8, -1), (8.0, 8), ("8", "8"), (8, 8, 8), (8,), (NAN, 8), "88", (True, 8),
    ]))


def edge_shapes():
    return st.sampled_from([(1, 1), (1, 4096), (100_000, 100_000), (2**31, 2), (16384, 16384)])


# ------------------------------------------------------------------ valid argument sets
SEEDS = st.integers(0, 2**32 - 1)
DEVICE = st.just("cpu")


@st.composite
def analyze_args(draw):
    u = draw(images())
    size = draw(st.integers(2, min(u.shape[:2])))
    return dict(u=u, size=size, order=draw(st.sampled_from([0, 1, 3, 5])), iterations=draw(st.integers(1, 4)),
                seed=draw(SEEDS), periodic=draw(st.booleans()), color_correction=draw(st.booleans()),
                support=draw(st.sampled_from(["square", "disk"])))


@st.composite
def downscale_args(draw):
    u = draw(images())
    return dict(u=u, factor=draw(st.integers(1, min(u.shape[:2]))))


@st.composite
def model_error_args(draw):
    u = draw(images())
    c = 1 if u.ndim == 2 else u.shape[2]
    side = min(u.shape[:2])
    t = draw(textons(channels=c, size=(draw(st.integers(1, min(side, 8))), draw(st.integers(1, min(side, 8))))))
    return dict(u=u, texton=t, periodic=draw(st.sampled_from([None, True, False])))


@st.composite
def gaussian_args(draw):
    return dict(u=draw(images()), shape=draw(st.one_of(st.none(), shapes())), seed=draw(SEEDS),
                periodic=draw(st.booleans()))


@st.composite
def dsn_args(draw):
    return dict(texton=draw(textons()), shape=draw(shapes()), mni=draw(floats(0.5, 60.0)), seed=draw(SEEDS))


def filters():
    from warp_texton import FilterOptions

    kinds = st.sampled_from(["none", "mip", "anisotropic", "supersample"])
    options = st.builds(FilterOptions, kinds, max_aniso=st.integers(1, 8), supersample=st.integers(1, 3),
                        fade_energy=floats(0.0, 1.0), lod_bias=st.one_of(st.none(), floats(-3.0, 3.0)))
    return st.one_of(kinds.filter(lambda k: k != "supersample"), options)


@st.composite
def synthesize_args(draw):
    shape = draw(shapes(1, 24))
    args = dict(texton=draw(textons()), shape=shape, mni=draw(floats(0.5, 40.0)), seed=draw(SEEDS),
                scale=draw(floats(0.05, 8.0)), rotation=draw(floats(-720.0, 720.0)),
                offset=draw(pairs(floats(-1e6, 1e6))), period=draw(st.one_of(st.none(), pairs(floats(1.0, 300.0)))),
                device="cpu", poisson=draw(st.sampled_from(["exact", "gaussian"])),
                cell_factor=draw(floats(0.3, 2.0)), method=draw(st.sampled_from(["auto", "splat"])),
                filter=draw(filters()))
    if draw(st.booleans()):
        args["jacobian"] = draw(hnp.arrays(np.float64, (2, 2), elements=floats(-20.0, 20.0)))
    return args


@st.composite
def evaluate_args(draw):
    return dict(texton=draw(textons()), points=draw(points()), mni=draw(floats(0.5, 40.0)), seed=draw(SEEDS),
                device="cpu", period=draw(st.one_of(st.none(), pairs(floats(1.0, 300.0)))),
                poisson=draw(st.sampled_from(["exact", "gaussian"])), cell_factor=draw(floats(0.3, 2.0)))


@st.composite
def plane_args(draw):
    return dict(texton=draw(textons()), shape=draw(shapes(1, 20)), height=draw(floats(0.01, 100.0)),
                tilt=draw(floats(0.0, 89.9)), fov=draw(floats(1.0, 170.0)), texel_size=draw(floats(1e-4, 1.0)),
                mni=draw(floats(0.5, 40.0)), seed=draw(SEEDS), filter=draw(filters()), device="cpu")


@st.composite
def mix_args(draw):
    u = draw(images(min_side=8, max_side=24))
    v = draw(st.one_of(images(min_side=8, max_side=24), textons(max_side=6)))
    sides = [min(x.shape[:2]) for x in (u, v) if isinstance(x, np.ndarray)]
    size = draw(st.integers(2, min(sides + [8])))
    rhos = draw(st.lists(floats(0.0, 1.0), min_size=1, max_size=3))
    return dict(u=u, v=v, rhos=rhos, size=size, order=draw(st.sampled_from([0, 1, 3, 5])),
                seed=draw(SEEDS), iterations=draw(st.integers(1, 3)), periodic=draw(st.booleans()),
                color_correction=draw(st.booleans()), support=draw(st.sampled_from(["square", "disk"])))


@st.composite
def mixed_args(draw):
    from warp_texton import Texton

    first = draw(textons(max_side=6))
    n = draw(st.integers(1, 3))
    ts = [first] + [Texton(first.coeffs * draw(floats(-2.0, 2.0)) + 0.01, first.mean, first.order)
                    for _ in range(n - 1)]
    shape = draw(shapes(1, 24))
    weights = draw(st.one_of(st.just("strips"), hnp.arrays(np.float64, shape, elements=floats(0.0, 1.0))))
    return dict(textons=ts, weights=weights, shape=shape, mni=draw(floats(0.5, 40.0)), seed=draw(SEEDS),
                scale=draw(floats(0.1, 8.0)), offset=draw(pairs(floats(-1e5, 1e5))), device="cpu",
                method=draw(st.sampled_from(["auto", "splat"])))


@st.composite
def texton_args(draw):
    r, s = draw(st.integers(1, 10)), draw(st.integers(1, 10))
    c = draw(st.sampled_from([1, 3]))
    coeffs = draw(hnp.arrays(draw(st.sampled_from([np.float32, np.float64, np.int16])), (r, s, c),
                             elements=st.integers(-100, 100)))
    if draw(st.booleans()):
        coeffs, c = coeffs[:, :, 0], 1  # (r, s): one channel
    return dict(coeffs=coeffs, mean=draw(hnp.arrays(np.float64, (c,), elements=floats(-5.0, 5.0))),
                order=draw(st.sampled_from([0, 1, 3, 5])),
                metadata=draw(st.dictionaries(st.text(max_size=5), st.one_of(st.integers(), st.text(max_size=5)),
                                              max_size=3)))


@st.composite
def noise_options_args(draw):
    return dict(mni=draw(floats(1e-3, 1e6)), seed=draw(SEEDS),
                period=draw(st.one_of(st.none(), pairs(floats(1e-3, 1e12)))),
                poisson=draw(st.sampled_from(["exact", "gaussian"])), cell_factor=draw(floats(1e-6, 1e6)))


@st.composite
def analysis_options_args(draw):
    return dict(size=draw(st.integers(2, 4096)), order=draw(st.sampled_from([0, 1, 3, 5])),
                iterations=draw(st.integers(1, 10**6)), seed=draw(SEEDS), periodic=draw(st.booleans()),
                color_correction=draw(st.booleans()), support=draw(st.sampled_from(["square", "disk"])),
                histogram=draw(st.sampled_from(["gaussian", "preserve"])))


@st.composite
def filter_options_args(draw):
    return dict(kind=draw(st.sampled_from(["none", "mip", "anisotropic", "supersample"])),
                max_aniso=draw(st.integers(1, 64)), supersample=draw(st.integers(1, 64)),
                fade_energy=draw(floats(0.0, 1.0)), lod_bias=draw(st.one_of(st.none(), floats(-64.0, 64.0))))


@st.composite
def save_args(draw):
    return dict(texton=draw(textons()), path=draw(st.sampled_from(["t.exr", "t.texton", "T.EXR"])))


def texton_file_contents():
    """Bytes of files named *.texton: well formed, truncated, binary, huge headers, NaN..."""
    good = "TEXTON\n1\n1\n0.5 0.5 0.5\n3 3\n" + "\n".join(["0 0 0"] * 4 + ["1 2 3"] + ["0 0 0"] * 4) + "\n"
    return st.one_of(
        st.just(good.encode()),
        st.binary(max_size=64),
        st.sampled_from([
            b"", b"TEXTON\n", b"TEXTON\n1\n1\n0.5 0.5 0.5\n100000 100000\n", b"\x89PNG\r\n\x1a\n" + bytes(40),
            good.replace("1 2 3", "nan 2 3").encode(), good.replace("1 2 3", "1e39 2 3").encode(),
            good.replace("1 2 3", "1e20 2 3").encode(), good.replace("3 3\n", "3 -3\n").encode(),
            good.replace("0.5 0.5 0.5", "0.5 x 0.5").encode(), good.encode() * 3, "TEXTON\nü".encode(),
        ]),
        st.text(max_size=80).map(lambda s: ("TEXTON\n" + s).encode("utf-8", "surrogatepass")),
    )


def image_file_contents():
    """(suffix, bytes) of image files: PNGs made by Pillow, EXRs of any size, texton files, junk."""
    return st.one_of(
        st.tuples(st.sampled_from([".png", ".jpg", ".exr", ".texton", ".tif", ""]), st.binary(max_size=64)),
        st.tuples(st.just(".png"), st.sampled_from(["png-grey", "png-rgba", "png-16", "png-1x1", "png-palette"])),
        st.tuples(st.just(".exr"), st.sampled_from(["exr-image", "exr-texton", "exr-nan", "exr-huge-header",
                                                    "exr-2ch", "exr-uint"])),
    )


# ------------------------------------------------------------------ meshes
@st.composite
def mesh_arrays(draw):
    """(vertices, faces) of a small closed mesh, moved and scaled."""
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=draw(st.integers(0, 1)))
    v = np.asarray(m.vertices) * draw(floats(0.01, 100.0)) + np.array(draw(pairs(floats(-10.0, 10.0))) + (0.0,))
    return v, np.asarray(m.faces, np.int64)


def directions():
    return st.tuples(floats(-1.0, 1.0), floats(-1.0, 1.0), floats(-1.0, 1.0)).filter(
        lambda d: math.hypot(*d) > 1e-3)


def refused_directions(default_none: bool = False):
    """Directions to refuse; with ``default_none`` None is left out (the documented default)."""
    junk = JUNK.filter(lambda v: v is not None) if default_none else JUNK
    # an axis name drawn as junk ("x", "Y") is a valid direction, not one to refuse
    junk = junk.filter(lambda v: not (isinstance(v, str) and v.lower() in ("x", "y", "z")))
    return st.one_of(junk, st.sampled_from(["abc", (0.0, 0.0, 0.0), (1.0, NAN, 0.0), (1.0, 2.0), ("1", "0", "0")]))


@st.composite
def surface_args(draw):
    n = draw(st.integers(0, 20))
    p = draw(hnp.arrays(np.float64, (n, 3), elements=floats(-100.0, 100.0)))
    normals = draw(hnp.arrays(np.float64, (n, 3), elements=floats(-1.0, 1.0)))
    normals[np.linalg.norm(normals, axis=1) < 1e-3] = (0.0, 0.0, 1.0)
    return dict(texton=draw(textons()), points=p, normals=normals, texel_size=draw(floats(1e-3, 10.0)),
                mni=draw(floats(1.0, 60.0)), seed=draw(SEEDS), device="cpu", up=draw(directions()),
                side=draw(directions()))


@st.composite
def tangent_args(draw):
    n = draw(st.integers(0, 20))
    normals = draw(hnp.arrays(np.float64, (n, 3), elements=floats(-1.0, 1.0)))
    normals[np.linalg.norm(normals, axis=1) < 1e-3] = (0.0, 0.0, 1.0)
    return dict(normals=normals, up=draw(directions()), side=draw(directions()))


@st.composite
def texture_mesh_args(draw):
    v, f = draw(mesh_arrays())
    return dict(vertices=v, faces=f, texton=draw(textons()), texel_size=draw(floats(1e-2, 10.0)),
                mni=draw(floats(1.0, 60.0)), seed=draw(SEEDS), max_edge=draw(st.one_of(st.none(), floats(2.0, 50.0))),
                device="cpu", max_faces=draw(st.integers(1000, 100_000)))


@st.composite
def render_mesh_args(draw):
    v, f = draw(mesh_arrays())
    return dict(vertices=v, faces=f, texton=draw(textons()), shape=draw(shapes(1, 16)),
                texel_size=draw(st.one_of(st.none(), floats(1e-3, 10.0))), mni=draw(floats(1.0, 60.0)),
                seed=draw(SEEDS), device="cpu", background=draw(st.tuples(*[floats(0.0, 1.0)] * 3)))


@st.composite
def camera_args(draw):
    position = draw(st.tuples(*[floats(-10.0, 10.0)] * 3).filter(lambda p: math.hypot(*p) > 1e-3))
    return dict(position=position, target=(0.0, 0.0, 0.0),
                up=(0.0, 0.0, 1.0), fov=draw(floats(1.0, 170.0)))



@st.composite
def batch_args(draw):
    c = draw(st.sampled_from([1, 3]))
    ts = [draw(textons(channels=c)) for _ in range(draw(st.integers(1, 3)))]
    count = draw(st.integers(1, 4))
    lo = draw(floats(0.2, 4.0))
    return dict(textons=ts, count=count, shape=draw(shapes(1, 16)), seed=draw(SEEDS), mni=draw(floats(0.5, 40.0)),
                scale=draw(st.one_of(floats(0.2, 4.0), st.just((lo, lo * draw(floats(1.0, 2.0)))))),
                rotation=draw(st.one_of(floats(-360.0, 360.0), st.just((-30.0, 30.0)))),
                offset=draw(pairs(floats(-1e5, 1e5))), filter=draw(filters()), device="cpu")


def refused_ranges():
    """Values a number-or-(lo, hi) parameter must refuse."""
    return st.one_of(not_numbers().filter(lambda v: not isinstance(v, tuple)), NON_FINITE,
                     st.sampled_from([(2.0, 1.0), (NAN, 1.0), (1.0, INF), ("1", "2"), (1.0, 2.0, 3.0)]))


@st.composite
def bake_args(draw):
    v, f = draw(mesh_arrays())
    return dict(vertices=v, faces=f, texton=draw(textons()), texel_size=draw(floats(0.05, 5.0)),
                resolution=draw(st.integers(8, 48)), mni=draw(floats(1.0, 60.0)), seed=draw(SEEDS),
                supersample=draw(st.one_of(st.none(), st.integers(1, 3))), gutter=draw(st.one_of(st.none(), st.integers(0, 4))),
                device="cpu")


@st.composite
def dask_args(draw):
    h, w = draw(shapes(1, 24))
    chunks = draw(st.one_of(st.integers(1, min(h, w)), st.tuples(st.integers(1, h), st.integers(1, w))))
    return dict(texton=draw(textons()), shape=(h, w), chunks=chunks,
                mni=draw(floats(0.5, 40.0)), seed=draw(SEEDS), scale=draw(floats(0.1, 4.0)),
                rotation=draw(floats(-360.0, 360.0)), offset=draw(pairs(floats(-1e5, 1e5))), device="cpu")


# ------------------------------------------------------------------ checks (run in the worker)
def _array(result, shape, channels=None) -> str | None:
    if not isinstance(result, np.ndarray):
        return f"returned {type(result).__name__}, not an array"
    if result.dtype != np.float32:
        return f"dtype {result.dtype}, not float32"
    if shape is not None and result.shape[: len(shape)] != tuple(shape):
        return f"shape {result.shape}, expected {tuple(shape)}"
    if channels is not None and result.shape[-1] != channels:
        return f"{result.shape[-1]} channels, expected {channels}"
    if not np.isfinite(result).all():
        return f"{int((~np.isfinite(result)).sum())} non-finite values"
    return None


def _channels(u) -> int:
    a = np.asarray(u)
    return 1 if a.ndim == 2 else min(a.shape[2], 3)


def check_texton(result, kw) -> str | None:
    from warp_texton import Texton

    if not isinstance(result, Texton):
        return f"returned {type(result).__name__}, not a Texton"
    if not (np.isfinite(result.coeffs).all() and np.isfinite(result.mean).all()):
        return "non-finite texton"
    if "size" in kw and result.size != (kw["size"], kw["size"]):
        return f"texton size {result.size}, expected {kw['size']}"
    return None


def check_textons(result, kw) -> str | None:
    if not isinstance(result, list) or len(result) != len(kw["rhos"]):
        return "not one texton per rho"
    return next((p for p in (check_texton(t, kw) for t in result) if p), None)


def check_image(result, kw) -> str | None:
    return _array(result, np.asarray(kw["u"]).shape[:2], _channels(kw["u"]))


def check_downscale(result, kw) -> str | None:
    m, n = np.asarray(kw["u"]).shape[:2]
    f = kw["factor"]
    return _array(result, (m // f, n // f), _channels(kw["u"]))


def check_gaussian(result, kw) -> str | None:
    shape = kw["shape"] if kw.get("shape") is not None else np.asarray(kw["u"]).shape[:2]
    return _array(result, shape, _channels(kw["u"]))


def check_raster(result, kw) -> str | None:
    return _array(result, kw["shape"], kw["texton"].channels)


def check_points(result, kw) -> str | None:
    return _array(result, (len(kw["points"]),), kw["texton"].channels)


def check_mixed(result, kw) -> str | None:
    return _array(result, kw["shape"], kw["textons"][0].channels)


def check_rme(result, kw) -> str | None:
    return None if isinstance(result, float) and math.isfinite(result) and result >= 0 else f"model error {result!r}"


def check_surface(result, kw) -> str | None:
    return _array(result, (len(kw["points"]),), kw["texton"].channels)


def check_render(result, kw) -> str | None:
    return _array(result, kw["shape"], 3)


def check_written(result, kw) -> str | None:
    path = Path(kw["path"])
    return None if path.is_file() and path.stat().st_size > 0 else f"{path} was not written"


# ------------------------------------------------------------------ wrappers (run in the worker)
def save(texton, path):
    texton.save(path)


def spectrum(texton, shape):
    out = texton.spectrum(shape)
    if out.shape != (*shape, texton.channels) or not np.isfinite(out).all():
        raise AssertionError(f"spectrum of shape {out.shape} for {shape}")


def read_image_file(folder, name, content):
    return _read_file(folder, name, content, "read_image")


def load_texton_file(folder, name, content):
    return _read_file(folder, name, content, "load_texton")


def _read_file(folder, name, content, fn):
    import warp_texton

    path = Path(folder) / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        make_image_file(path, content)
    result = getattr(warp_texton, fn)(path)
    if fn == "read_image":
        problem = _array(result, None)
        if problem:
            raise AssertionError(f"read_image returned an invalid image: {problem}")
    return result


def make_image_file(path: Path, kind: str) -> None:
    """Files of a few kinds, written with the libraries (not with the package's writers)."""
    import OpenEXR
    from PIL import Image

    rng = np.random.default_rng(0)
    exr = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    if kind == "png-grey":
        Image.fromarray((rng.random((9, 7)) * 255).astype(np.uint8)).save(path, format="PNG")
    elif kind == "png-rgba":
        Image.fromarray((rng.random((9, 7, 4)) * 255).astype(np.uint8), "RGBA").save(path, format="PNG")
    elif kind == "png-16":
        Image.fromarray((rng.random((9, 7)) * 65535).astype(np.uint16)).save(path, format="PNG")
    elif kind == "png-1x1":
        Image.new("L", (1, 1)).save(path, format="PNG")
    elif kind == "png-palette":
        Image.new("P", (5, 5)).save(path, format="PNG")
    elif kind == "exr-image":
        OpenEXR.File(exr, {"RGB": rng.random((6, 5, 3)).astype(np.float32)}).write(str(path))
    elif kind == "exr-texton":
        OpenEXR.File({**exr, "texton_order": 1, "texton_mean": [0.5]},
                     {"Y": rng.random((4, 4)).astype(np.float32)}).write(str(path))
    elif kind == "exr-nan":
        OpenEXR.File(exr, {"Y": np.full((4, 4), NAN, np.float32)}).write(str(path))
    elif kind == "exr-huge-header":
        header = {**exr, "dataWindow": (np.array([0, 0], np.int32), np.array([199_999, 199_999], np.int32)),
                  "displayWindow": (np.array([0, 0], np.int32), np.array([199_999, 199_999], np.int32))}
        try:
            OpenEXR.File(header, {"Y": np.zeros((2, 2), np.float32)}).write(str(path))
        except Exception:
            path.write_bytes(b"")  # this OpenEXR refuses: an empty file then
    elif kind == "exr-2ch":
        OpenEXR.File(exr, {"A": np.zeros((4, 4), np.float32), "Z": np.zeros((4, 4), np.float32)}).write(str(path))
    elif kind == "exr-uint":
        OpenEXR.File(exr, {"Y": np.arange(16, dtype=np.uint32).reshape(4, 4)}).write(str(path))
    else:
        raise ValueError(kind)


def write_image_to(folder, name, img, **options):
    from warp_texton import write_image

    write_image(Path(folder) / name, img, **options)


def serve_and_close(**settings):
    """``serve`` a small texton on a free port with ``settings``, then stop it."""
    from warp_texton import Texton
    from warp_texton.view.server import serve

    texton = Texton(np.full((4, 4, 1), 0.1), [0.5])
    with serve(texton, port=0, device="cpu", **settings):
        return None


def atomic_write(folder, name, data):
    from warp_texton.files.images import atomic_path

    with atomic_path(Path(folder) / name) as tmp:
        Path(tmp).write_bytes(data)


def with_budget(setter, value):
    """set_memory_budget / set_work_budget with ``value``, then back to the default."""
    from warp_texton.core import limits

    fn = getattr(limits, setter)
    try:
        fn(value)
        return None
    finally:
        # the worker runs under budgets it set through the environment: go back to them
        fn(None)


def texture_mesh_of(vertices, faces, **kw):
    import trimesh
    from warp_texton import texture_mesh

    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    out = texture_mesh(mesh, **kw)
    colours = np.asarray(out.visual.vertex_colors)
    if colours.shape[0] != len(out.vertices):
        raise AssertionError("texture_mesh: one colour per vertex expected")
    return None


def render_mesh_of(vertices, faces, **kw):
    import trimesh
    from warp_texton import render_mesh

    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    return render_mesh(mesh, **kw)


def camera_framing(position, target, up, fov):
    import trimesh
    from warp_texton import Camera

    Camera(position, target, up, fov)
    return Camera.framing(trimesh.creation.box(), direction=position, fov=fov, up=up)

def synthesize_batch_of(**kw):
    from warp_texton import synthesize_batch

    batch = synthesize_batch(**kw)
    images, c = batch.images, kw["textons"][0].channels
    if images.shape != (kw["count"], *kw["shape"], c) or images.dtype != np.float32 or not np.isfinite(images).all():
        raise AssertionError(f"synthesize_batch: images {images.shape} {images.dtype}, expected "
                             f"({kw['count']}, {kw['shape']}, {c}) finite float32")
    return None


def pack_of(packer, **kw):
    """A device API packer (``pack_plane``, ``pack_filtered``, ``pack_surface``): its struct
    stays in the worker (a Warp struct does not pickle)."""
    from warp_texton.runtimes import warp_api as device

    getattr(device, packer)(**kw)
    return None


@st.composite
def pack_args(draw, packer):
    args = dict(packer=packer, texton=draw(textons()), mni=draw(floats(0.5, 60.0)), seed=draw(SEEDS), device="cpu",
                poisson=draw(st.sampled_from(["exact", "gaussian"])), cell_factor=draw(floats(0.3, 2.0)))
    if packer == "pack_surface":
        args.update(texel_size=draw(floats(1e-3, 1.0)), up=draw(st.sampled_from(["x", "y", "z"])))
    else:
        args["period"] = draw(st.one_of(st.none(), pairs(floats(1.0, 300.0))))
    if packer == "pack_filtered":
        args["filter"] = draw(st.sampled_from(["mip", "anisotropic"]))
    return args


def export_shader_to(folder, name, **kw):
    from warp_texton import export_shader

    out = export_shader(out_dir=Path(folder) / name, **kw)
    if not (out / ("texton_noise.json" if kw["lang"] == "glsl" else "texton_noise_osl.json")).is_file():
        raise AssertionError(f"export_shader: {out} has no description file")
    return None


def _mesh(vertices, faces):
    import trimesh

    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False)


def bake_mesh_of(vertices, faces, **kw):
    from warp_texton import bake_mesh

    baked = bake_mesh(_mesh(vertices, faces), **kw)
    t = baked.texture
    if t.shape[:2] != (kw["resolution"], kw["resolution"]) or not np.isfinite(t).all():
        raise AssertionError(f"bake_mesh: texture {t.shape}, expected {kw['resolution']}² finite values")
    return None


@functools.cache
def _small_bake():
    """One bake per worker process: the write_baked and render_baked properties are about
    writing and rendering it, and each new atlas would be one more run of xatlas on a loaded machine."""
    import trimesh

    from warp_texton import Texton, bake_mesh

    t = Texton(np.full((2, 2, 1), 0.1, np.float32), [0.5])
    return bake_mesh(trimesh.creation.box(), t, 0.2, resolution=16, device="cpu")


def write_baked_to(folder, stem, **kw):
    from warp_texton import write_baked

    paths = write_baked(_small_bake(), Path(folder) / stem, **kw)
    if not paths or not all(Path(p).is_file() for p in paths):
        raise AssertionError(f"write_baked: missing outputs {paths}")
    return None


def render_baked_of(**kw):
    from warp_texton import render_baked

    img = render_baked(_small_bake(), **kw)
    if img.shape != (*kw.get("shape", (512, 512)), 3) or not np.isfinite(img).all():
        raise AssertionError(f"render_baked: image {img.shape}")
    return None


def synthesize_dask_of(**kw):
    from warp_texton.noise.dask_arrays import synthesize_dask

    arr = synthesize_dask(**kw)
    img = arr.compute(scheduler="synchronous")
    if img.shape != (*kw["shape"], kw["texton"].channels) or not np.isfinite(img).all():
        raise AssertionError(f"synthesize_dask: {img.shape}, expected {kw['shape']}")
    return None



def warm_up():
    """Compile every kernel module once (the first calls of a clean machine build them)."""
    import trimesh
    from warp_texton import (Texton, evaluate, render_mesh, render_plane, surface_noise, synthesize,
                             synthesize_mixed)

    t = Texton(np.full((4, 4, 1), 0.1), [0.5])
    synthesize(t, (8, 8), device="cpu")
    synthesize(t, (8, 8), scale=0.1, filter="anisotropic", device="cpu")
    evaluate(t, [[0.5, 0.5]], device="cpu")
    render_plane(t, (8, 8), filter="mip", device="cpu")
    synthesize_mixed([t, t], "strips", (8, 8), device="cpu")
    surface_noise(t, [[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]], 0.1, device="cpu")
    render_mesh(trimesh.creation.icosphere(0), t, (8, 8), device="cpu")


# ------------------------------------------------------------------ the table
def _analysis_refused():
    return {"u": refused_images(), "size": refused_int(2), "order": st.one_of(refused_int(), st.sampled_from([2, 4, -1])),
            "iterations": refused_int(1), "seed": st.one_of(refused_int(0), st.just(2**32)),
            "periodic": st.sampled_from(["yes", 1, None, 0.0]), "color_correction": st.sampled_from(["no", 1, None]),
            "support": st.one_of(JUNK, st.just("hexagon"))}


ENTRIES: list[Entry] = [
    Entry("analyze", "warp_texton:analyze", analyze_args(), _analysis_refused(),
          edges={"size": st.sampled_from([10**9, 4097, 2**63]), "iterations": st.sampled_from([10**9, 10**15])},
          check="check_texton", may_refuse=r"constant|memory budget|work budget"),
    Entry("model_error", "warp_texton:model_error", model_error_args(),
          {"u": refused_images(), "texton": refused_textons(), "periodic": st.sampled_from(["yes", 1, 0.0])},
          check="check_rme", may_refuse=r"constant|does not fit|memory budget|work budget"),
    Entry("downscale", "warp_texton:downscale", downscale_args(),
          {"u": refused_images(), "factor": refused_int(1)},
          edges={"factor": st.sampled_from([10**9, 2**63])}, check="check_downscale"),
    Entry("periodic_component", "warp_texton:periodic_component", images().map(lambda u: dict(u=u)),
          {"u": refused_images()}, check="check_image"),
    Entry("gaussian_texture", "warp_texton:gaussian_texture", gaussian_args(),
          {"u": refused_images(), "shape": refused_shapes().filter(lambda v: v is not None), "seed": refused_int(0),
           "periodic": st.sampled_from(["yes", 1, None])},
          edges={"shape": edge_shapes()}, check="check_gaussian", may_refuse=r"constant|memory budget|work budget"),
    Entry("dsn", "warp_texton:dsn", dsn_args(),
          {"texton": refused_textons(), "shape": refused_shapes(), "mni": refused_positive(), "seed": refused_int(0)},
          edges={"mni": huge_and_tiny(), "shape": edge_shapes()}, check="check_raster"),
    Entry("synthesize", "warp_texton:synthesize", synthesize_args(),
          {"texton": refused_textons(), "shape": refused_shapes(), "mni": refused_positive(), "seed": refused_int(0),
           "scale": refused_positive(), "rotation": refused_number(), "offset": refused_pair(),
           "period": st.one_of(refused_pair().filter(lambda v: v is not None), pairs(floats(-5.0, 0.0))),
           "device": st.sampled_from(["gpu", "cuda:99", 5, "", "cpu:1"]), "poisson": st.one_of(JUNK, st.just("poisson")),
           "cell_factor": refused_positive(), "method": st.one_of(JUNK, st.just("fast")),
           "jacobian": st.one_of(st.sampled_from(["J", [[1, 2]], np.zeros((3, 2)), [[NAN, 0], [0, 1]],
                                                  [["1", "0"], ["0", "1"]]])),
           "filter": st.one_of(JUNK, st.just("bilinear"))},
          edges={"mni": huge_and_tiny(), "scale": huge_and_tiny(), "offset": pairs(st.sampled_from([1e300, -1e12, 1e9])),
                 "period": pairs(huge_and_tiny()), "cell_factor": huge_and_tiny(), "shape": edge_shapes(),
                 "rotation": st.sampled_from([1e300, -1e20])},
          check="check_raster", may_refuse=r"memory budget|work budget|cells of|impacts|reach|too small|too large"),
    Entry("evaluate", "warp_texton:evaluate", evaluate_args(),
          {"texton": refused_textons(), "points": refused_points(), "mni": refused_positive(), "seed": refused_int(0),
           "period": pairs(refused_number()), "poisson": st.just("exactly"), "cell_factor": refused_positive()},
          edges={"mni": huge_and_tiny(), "period": pairs(huge_and_tiny()), "cell_factor": huge_and_tiny(),
                 "points": st.sampled_from([np.full((2, 2), 1e300), np.full((1, 2), 1e10), np.zeros((10**6, 2))])},
          check="check_points", may_refuse=r"memory budget|work budget|cells of|reach"),
    Entry("render_plane", "warp_texton:render_plane", plane_args(),
          {"texton": refused_textons(), "shape": refused_shapes(), "height": refused_positive(),
           "tilt": st.one_of(refused_number(), st.sampled_from([90.0, -1.0, 400.0])),
           "fov": st.one_of(refused_number(), st.sampled_from([0.0, 180.0, -5.0])), "texel_size": refused_positive(),
           "mni": refused_positive(), "seed": refused_int(0), "filter": st.one_of(JUNK, st.just("trilinear"))},
          edges={"texel_size": huge_and_tiny(), "height": huge_and_tiny(), "mni": huge_and_tiny(),
                 "shape": edge_shapes()},
          names={"height": "height (the camera"},
          check="check_raster", may_refuse=r"memory budget|work budget|cells of"),
    Entry("mix_textons", "warp_texton:mix_textons", mix_args(),
          {**{k: v for k, v in _analysis_refused().items() if k != "u"},
           "u": refused_images(), "v": refused_images(),
           "rhos": st.one_of(JUNK.filter(lambda v: v not in ([], (1,)) and not isinstance(v, bool)),
                             st.sampled_from([[], [1.5], [-0.1], [NAN], ["0.5"], np.zeros((2, 2))]))},
          edges={"rhos": st.sampled_from([np.linspace(0, 1, 10**5), [0.0] * 50]),
                 "iterations": st.sampled_from([10**9])},
          names={"u": "u", "v": "v"}, check="check_textons",
          may_refuse=r"constant|does not fit|memory budget|work budget"),
    Entry("synthesize_mixed", "warp_texton:synthesize_mixed", mixed_args(),
          {"textons": st.one_of(JUNK.filter(lambda v: v is not None and v != [] and v != (1,)),
                                st.just([]), st.just([np.ones((2, 2))])),
           "weights": st.one_of(st.just("stripes"), st.just(np.full((3, 3), 0.5)), st.just([["0.5"]]),
                                st.just(np.array([[NAN]]))),
           "shape": refused_shapes(), "mni": refused_positive(), "seed": refused_int(0), "scale": refused_positive(),
           "offset": refused_pair(), "method": st.just("fast")},
          edges={"mni": huge_and_tiny(), "scale": huge_and_tiny()},
          names={"textons": "texton", "weights": "weights"},
          check="check_mixed", may_refuse=r"memory budget|work budget|cells of|reach"),
    Entry("Texton", "warp_texton:Texton", texton_args(),
          {"coeffs": st.one_of(JUNK, st.sampled_from([np.zeros(4), np.zeros((2, 2, 2)), np.zeros((0, 3)),
                                                      np.full((2, 2), NAN), np.full((2, 2), 1e20), [["a"]],
                                                      Broadcast(1.0, (5000, 5000))])),
           "mean": st.one_of(JUNK.filter(lambda v: v not in (True, False, (1,))),  # (1,) is a grey texton's mean
                             st.sampled_from([[NAN], [1e30], "x"])),
           "order": st.one_of(refused_int(), st.sampled_from([2, 7])),
           "metadata": st.one_of(st.sampled_from([[1, 2], "meta", 5, {1: "a"}]))},
          names={"coeffs": "coefficients", "mean": "mean", "order": "order", "metadata": "metadata"},
          check=None, may_refuse=r"(?!)"),
    Entry("Texton.spectrum", "property_api:spectrum", st.builds(lambda t, m, n: dict(texton=t, shape=(m, n)),
                                                                 textons(), st.integers(8, 40), st.integers(8, 40)),
          {"shape": refused_shapes()}, edges={"shape": st.sampled_from([(1, 1), (16384, 16384), (4, 100)])},
          may_refuse=r"does not fit|budget"),
    Entry("Texton.save", "property_api:save", save_args(),
          {"path": st.sampled_from(["t.png", "t", "t.exr.bak"])}, names={"path": "extension"},
          files=("path",), check="check_written"),
    Entry("load_texton", "property_api:load_texton_file",
          texton_file_contents().map(lambda c: dict(name="t.texton", content=c)), files=("folder",),
          may_refuse=r"."),  # most drawn files are malformed: refusals are the point
    Entry("read_image", "property_api:read_image_file",
          image_file_contents().map(lambda sc: dict(name="f" + sc[0], content=sc[1])), files=("folder",),
          may_refuse=r"."),
    Entry("write_image", "property_api:write_image_to",
          st.tuples(st.sampled_from(["o.png", "o.exr", "o.jpg", "O.JPEG"]), images(min_side=1, max_side=12)).map(
              lambda a: dict(name=a[0], img=a[1])),
          {"img": refused_images(writing=True),
           "name": st.sampled_from(["o.bmp", "o", "x" * 300 + ".png", "missing/o.png"])},
          names={"img": "img", "name": "o"}, files=("folder",)),
    # the argument kinds of issue 22 (item 10): dtypes as ints, arrays where scalars go, infinities, None
    Entry("write_image (dtype, compression)", "property_api:write_image_to",
          st.tuples(st.sampled_from(["o.png", "o.exr"]), images(min_side=1, max_side=8)).map(
              lambda a: dict(name=a[0], img=a[1])),
          {"dtype": st.sampled_from([0, 16, np.array([4, 4]), INF, "uint9", np.float16(1), [np.uint8]]),
           "compression": st.sampled_from([np.array([4, 4]), INF, -1, 1.5, "zip9", [4], NAN])},
          files=("folder",)),
    Entry("serve", "property_api:serve_and_close",
          st.builds(lambda c, s, lv: dict(cache_mb=c, slots=s, png_level=lv), st.sampled_from([0, 1, 16.5]),
                    st.integers(1, 4), st.integers(0, 9)),
          {"cache_mb": st.sampled_from([INF, -INF, NAN, None, -1, np.array([4, 4]), "16", True, 1e300]),
           "slots": st.one_of(refused_int(1), st.sampled_from([np.array([2, 2]), INF, 65])),
           "png_level": st.one_of(refused_int(0), st.sampled_from([np.array([1]), INF, 10])),
           "mni": st.sampled_from([INF, NAN, None, np.array([30.0, 30.0]), 0, 1e9]),
           "seed": st.sampled_from([INF, None, np.array([1, 2]), -1, 2**40, 1.5]),
           "size": st.sampled_from([INF, None, np.array([64]), 3, 10**9])},
          may_refuse=r"memory budget|work budget|leave .* to each computation"),
    Entry("atomic_path", "property_api:atomic_write",
          st.tuples(st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="/\x00"), min_size=1,
                            max_size=260).filter(lambda s: s not in (".", "..")), st.binary(max_size=64)).map(
              lambda a: dict(name=a[0], data=a[1])),
          files=("folder",), may_refuse=r"file name|file system|is a folder"),
    Entry("FilterOptions", "warp_texton:FilterOptions", filter_options_args(),
          {"kind": st.one_of(JUNK, st.just("bilinear")), "max_aniso": refused_int(1),
           "supersample": refused_int(1), "fade_energy": st.one_of(refused_number(), st.sampled_from(["0.1", 1.5, -0.1])),
           "lod_bias": st.one_of(st.sampled_from(["0", NAN, INF, 1e300, True]))},
          names={"kind": "filter"}, may_refuse=r"(?!)"),
    Entry("NoiseOptions", "warp_texton:NoiseOptions", noise_options_args(),
          {"mni": st.one_of(refused_number(), st.sampled_from([0, -1.0, 1e-4])),
           "seed": st.sampled_from([-1, 2**32, 1.5, True, "1", None, np.array([1])]),
           "period": st.one_of(refused_pair().filter(lambda v: v is not None), pairs(floats(-5.0, 0.0))),
           "poisson": st.one_of(JUNK, st.just("fast")),
           "cell_factor": st.one_of(refused_number(), st.sampled_from([0, -0.6]))},
          may_refuse=r"(?!)"),
    Entry("AnalysisOptions", "warp_texton:AnalysisOptions", analysis_options_args(),
          {"size": st.one_of(refused_int(2), st.just(4097)), "order": st.one_of(refused_int(), st.sampled_from([2, 4])),
           "iterations": refused_int(1), "seed": st.sampled_from([-1, 2**32, 1.5, True, "1", None]),
           "periodic": st.sampled_from([1, 0, "yes", None, 1.0]),
           "color_correction": st.sampled_from([1, 0, "no", None]),
           "support": st.one_of(JUNK, st.just("circle")), "histogram": st.one_of(JUNK, st.just("uniform"))},
          may_refuse=r"(?!)"),
    Entry("set_memory_budget", "property_api:with_budget",
          st.one_of(st.integers(1, 2**60), st.sampled_from(["2G", "512M", "1.5T", "100"])).map(
              lambda v: dict(setter="set_memory_budget", value=v)),
          {"value": st.sampled_from([0, -5, True, "x", [1], NAN, INF, -INF, np.float64("inf"), np.array([4, 4]),
                                     "0.5", "-1G", "inf"])}, names={"value": "budget"}),
    Entry("set_work_budget", "property_api:with_budget",
          st.one_of(st.integers(1, 2**60), st.sampled_from(["1e12", "5G", "100"])).map(
              lambda v: dict(setter="set_work_budget", value=v)),
          {"value": st.sampled_from([0, -5, True, "x", [1], NAN, INF, -INF, np.array([4, 4]), "-1", "inf"])},
          names={"value": "budget"}),
    Entry("is_texton_path", "warp_texton.model.texton:is_texton_path",
          st.sampled_from(["a.texton", "b.exr", "c.png", "d"]).map(lambda p: dict(path=p)),
          {"path": st.sampled_from([None, 5, b"x.exr", ["a"]])}),
    # ---- meshes
    Entry("tangent_frames", "warp_texton:tangent_frames", tangent_args(),
          {"normals": refused_points(), "up": refused_directions(), "side": refused_directions(default_none=True)}),
    Entry("surface_noise", "warp_texton:surface_noise", surface_args(),
          {"texton": refused_textons(), "points": refused_points(), "normals": refused_points(),
           "texel_size": refused_positive(), "mni": refused_positive(), "seed": refused_int(0),
           "up": refused_directions(), "side": refused_directions(default_none=True)},
          edges={"texel_size": huge_and_tiny(), "mni": huge_and_tiny()},
          check="check_surface", may_refuse=r"memory budget|work budget|too far|cells"),
    Entry("texture_mesh", "property_api:texture_mesh_of", texture_mesh_args(),
          {"texton": refused_textons(), "texel_size": refused_positive(), "mni": refused_positive(),
           "seed": refused_int(0), "max_edge": refused_positive().filter(lambda v: v is not None),
           "max_faces": refused_int(1)},
          edges={"texel_size": huge_and_tiny(), "max_edge": huge_and_tiny()},
          may_refuse=r"memory budget|work budget|too far|faces|cells"),
    Entry("render_mesh", "property_api:render_mesh_of", render_mesh_args(),
          {"texton": refused_textons(), "shape": refused_shapes(), "texel_size": refused_positive().filter(
              lambda v: v is not None), "mni": refused_positive(), "seed": refused_int(0),
           "background": refused_directions()},
          edges={"texel_size": huge_and_tiny(), "shape": edge_shapes()},
          check="check_render", may_refuse=r"memory budget|work budget|too far|cells|too large"),
    Entry("Camera", "property_api:camera_framing", camera_args(),
          {"fov": st.one_of(refused_number(), st.sampled_from([0.0, 180.0, -1.0])), "up": refused_directions()},
          may_refuse=r"parallel"),
    Entry("run_jobs", "warp_texton.surface.jobs:run_jobs", st.just(dict(jobs=[])),
          {"jobs": st.sampled_from([None, 3, "a.ply", INF, b"x"])}),
    Entry("expand_meshes", "warp_texton.surface.jobs:expand_meshes",
          st.lists(st.sampled_from(["a.ply", "b/*.obj", "c.glb"]), max_size=3).map(lambda a: dict(args=a)),
          {"args": st.sampled_from([[None], [5], None, [b"x"], 7])}),
    Entry("synthesize_batch", "property_api:synthesize_batch_of", batch_args(),
          {"textons": st.one_of(st.sampled_from([[], None, "t", [None], [1.0], 5])),
           "count": refused_int(1), "shape": refused_shapes(), "seed": refused_int(0), "mni": refused_positive(),
           "scale": refused_ranges(), "rotation": refused_ranges(), "offset": refused_pair(),
           "filter": st.one_of(JUNK, st.just("bilinear")), "device": st.sampled_from(["gpu", "cuda:99", 5])},
          edges={"count": st.sampled_from([10**6, 10**12, 2**40]), "shape": edge_shapes(), "mni": huge_and_tiny(),
                 "scale": st.sampled_from([1e-30, 1e30, (1e-30, 1.0), (1.0, 1e30)])},
          may_refuse=r"memory budget|work budget|cells|impacts|reach|too small|too large"),
    # ---- the device API and shader exports
    *[Entry(packer, "property_api:pack_of", pack_args(packer),
            {"texton": refused_textons(), "mni": refused_positive(), "seed": refused_int(0),
             "cell_factor": refused_positive(), "poisson": st.one_of(JUNK, st.just("poisson")),
             **({"texel_size": refused_positive()} if packer == "pack_surface" else
                {"period": pairs(refused_number())})},
            edges={"mni": huge_and_tiny(), "cell_factor": huge_and_tiny(),
                   **({"texel_size": huge_and_tiny()} if packer == "pack_surface" else
                      {"period": pairs(huge_and_tiny())})},
            may_refuse=r"memory budget|work budget|cells|impacts")
      for packer in ("pack_plane", "pack_filtered", "pack_surface")],
    Entry("export_shader", "property_api:export_shader_to",
          st.tuples(textons(), st.sampled_from(["glsl", "osl"]), floats(0.5, 60.0), SEEDS).map(
              lambda a: dict(name="export", texton=a[0], lang=a[1], mni=a[2], seed=a[3])),
          {"texton": refused_textons(), "lang": st.one_of(JUNK, st.just("hlsl")), "mni": refused_positive(),
           "seed": refused_int(0), "cell_factor": refused_positive()},
          edges={"name": st.sampled_from(["x" * 300, "a\x00b", "y" * 255, "z" * 200]), "mni": huge_and_tiny(),
                 "cell_factor": huge_and_tiny()},
          # a texton whose coefficients are all zero has no support: its constants are not finite
          may_refuse=r"memory budget|work budget|cells|impacts|order|texture side|not finite", files=("folder",)),
    Entry("bake_mesh", "property_api:bake_mesh_of", bake_args(),
          {"texton": refused_textons(), "texel_size": refused_positive(), "resolution": refused_int(1),
           "mni": refused_positive(), "seed": refused_int(0), "supersample": refused_int(1).filter(lambda v: v is not None),
           "gutter": st.sampled_from([-1, 1.5, "2", NAN])},
          edges={"resolution": st.sampled_from([1, 2, 100_000, 10**9]), "texel_size": huge_and_tiny(),
                 "supersample": st.sampled_from([9, 64, 10**6]), "gutter": st.sampled_from([10**6])},
          may_refuse=r"memory budget|work budget|too far|cells|xatlas|resolution|supersample|gutter"),
    Entry("write_baked", "property_api:write_baked_to",
          st.tuples(st.sampled_from(["a", "mesh.v2"]), st.sampled_from(["glb", "obj"]),
                    st.sampled_from([None, "png", "exr"]), st.booleans()).map(
              lambda a: dict(stem=a[0], fmt=a[1], texture=a[2], linear=a[3])),
          {"fmt": st.one_of(JUNK, st.sampled_from(["ply", "GLB ", ""])),
           "texture": st.one_of(JUNK.filter(lambda v: v is not None), st.just("tiff")),
           "stem": st.sampled_from(["x" * 300, "missing/a"])},
          names={"stem": "a"}, files=("folder",), needs=("xatlas",)),
    Entry("render_baked", "property_api:render_baked_of",
          st.tuples(shapes(1, 24), st.one_of(st.none(), st.tuples(floats(-180.0, 180.0), floats(-89.0, 89.0))),
                    st.one_of(st.none(), floats(5.0, 120.0))).map(lambda a: dict(shape=a[0], orbit=a[1], fov=a[2], device="cpu")),
          {"shape": refused_shapes(), "orbit": st.one_of(st.sampled_from(["x", (NAN, 0.0), (1.0,), ("1", "2")])),
           # fov=None is the documented default (35 degrees), not a refusal
           "fov": st.one_of(refused_number().filter(lambda v: v is not None), st.sampled_from([0.0, 180.0, -5.0]))},
          edges={"shape": edge_shapes()},
          may_refuse=r"memory budget|work budget|too large", needs=("xatlas",)),
    Entry("synthesize_dask", "property_api:synthesize_dask_of", dask_args(),
          {"texton": refused_textons(), "shape": refused_shapes(), "chunks": st.one_of(
              st.sampled_from([0, -4, "8", 1.5, (0, 4), (4,), None])), "mni": refused_positive(),
           "seed": refused_int(0), "scale": refused_positive(), "offset": refused_pair()},
          edges={"shape": st.sampled_from([(1, 1), (10**6, 10**6), (2**40, 2)]), "chunks": st.sampled_from([10**9, (1, 10**9)])},
          may_refuse=r"memory budget|work budget|cells|impacts|reach|too small|too large|chunks", needs=("dask",)),
]

#: Entries by name (the tests' ids).
BY_NAME = {e.name: e for e in ENTRIES}


# ------------------------------------------------------------------ the command line
#: Options each command takes, with values to draw (valid ones first); inputs are made by the worker.
CLI_OPTIONS = {
    "analyze": {"--size": ["8", "2", "0", "-3", "1e3", "x", "100000000000"], "--order": ["1", "2"],
                "--iterations": ["2", "0", "1000000000000"], "--seed": ["1", "-1", "4294967296"],
                "--support": ["disk", "hex"]},
    "gaussian": {"--width": ["16", "0", "-5", "1000000", "x"], "--height": ["16", "99999999"],
                 "--seed": ["3", "-2"]},
    "synthesize": {"--width": ["16", "0", "100000"], "--height": ["12", "-1"], "--mni": ["20", "0", "nan", "inf",
                   "-3", "1e-300", "1e300", "30000"], "--seed": ["2", "-1"], "--scale": ["0.5", "0", "1e-9", "1e9"],
                   "--rotation": ["30", "nan", "1e300"], "--offset": [["1", "2"], ["nan", "0"], ["1e300", "0"]],
                   "--period": [["32", "32"], ["0", "5"], ["167503724661", "167503724661"]],
                   "--filter": ["mip", "supersample", "x"], "--supersample": ["2", "0", "65"],
                   "--max-aniso": ["4", "0"], "--fade-energy": ["0.5", "2", "nan"], "--size": ["8", "500"],
                   "--order": ["3"], "--iterations": ["2", "0"]},
    "render-plane": {"--width": ["16", "0"], "--height": ["12", "100000"], "--mni": ["20", "0"],
                     "--camera-height": ["1", "0", "nan"], "--tilt": ["60", "90", "nan"], "--fov": ["40", "180"],
                     "--texel-size": ["0.01", "0", "1e-300", "1e300"], "--filter": ["none", "mip"],
                     "--supersample": ["2"], "--max-aniso": ["2", "100"], "--fade-energy": ["0", "-1"]},
    "mix": {"--steps": ["3", "1", "100000", "1000000000000"], "--width": ["16", "0"], "--height": ["8", "-2"],
            "--mni": ["10", "0"], "--size": ["8", "40", "1"], "--iterations": ["1", "0"], "--seed": ["1", "-1"]},
}
#: The inputs the worker makes for each command's positional arguments.
CLI_INPUTS = {"analyze": ["image"], "gaussian": ["image"], "synthesize": ["image|texton|texton-as-image"],
              "render-plane": ["image|texton"], "mix": ["image|texton", "image|texton"]}
CLI_OUTPUTS = {"analyze": ["o.exr", "o.texton", "o.png"], "gaussian": ["o.png", "o.exr", "o.txt"],
               "synthesize": ["o.png", "o.exr"], "render-plane": ["o.png"], "mix": ["o.png", "o.jpg"]}


@st.composite
def cli_argv(draw):
    """(command, inputs, output, options): a command line the worker completes with files."""
    command = draw(st.sampled_from(sorted(CLI_OPTIONS)))
    inputs = [draw(st.sampled_from(kind.split("|"))) for kind in CLI_INPUTS[command]]
    output = draw(st.sampled_from(CLI_OUTPUTS[command]))
    chosen = draw(st.lists(st.sampled_from(sorted(CLI_OPTIONS[command])), max_size=4, unique=True))
    options = []
    for opt in chosen:
        values = CLI_OPTIONS[command][opt]
        value = draw(st.one_of(st.just(values[0]), st.sampled_from(values)))  # the valid first value half the time
        options += [opt, *(value if isinstance(value, list) else [value])]
    return command, inputs, output, options


def run_cli(folder, command, inputs, output, options):
    """The worker's side of a command line: write the inputs, run ``main``, return
    (status, stderr, files left in the folder)."""
    import contextlib
    import io

    from warp_texton import Texton
    from warp_texton.cli.parser import main

    folder = Path(folder)
    rng = np.random.default_rng(1)
    paths = []
    for k, kind in enumerate(inputs):
        if kind == "image":
            p = folder / f"in{k}.png"
            make_image_file(p, "png-grey")
        elif kind == "texton":
            p = folder / f"in{k}.exr"
            Texton(0.1 * rng.standard_normal((6, 6, 1)) + 0.02, [0.5]).save(p)
        else:  # a texton file given where the command analyses an image: still a texton, read as one
            p = folder / f"in{k}.texton"
            Texton(0.1 * rng.standard_normal((6, 6, 1)) + 0.02, [0.5]).save(p)
        paths.append(str(p))
    before = set(os.listdir(folder))
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            status = main([command, *paths, "-o", str(folder / output), "-q", *options]
                          + ([] if command in ("analyze", "gaussian", "mix") else ["--device", "cpu"]))
        except SystemExit as exc:
            status = exc.code
    return status, err.getvalue(), sorted(set(os.listdir(folder)) - before)


# type alias for readers of the table
Check = Callable[[object, dict], "str | None"]
