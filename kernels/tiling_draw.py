"""The tiling model's vertex draw, defined once: the Warp functions and the code of every other evaluator.

Vertex (a, b) of the triangle lattice shows the example translated by whole texels so that a texel
c(a, b), drawn from the vertex's hash, sits on the vertex (docs/tiling.md, "Specification"):

1. the vertex's 32-bit state: the impact stream's avalanche finaliser over (seed ⊕ TILING_TAG) +
   GOLDEN, then a, then b (``seed_state``, ``vertex_state``);
2. two draws of Warp's PCG from it (``wp.randf``), u_x then u_y;
3. per axis the centre texel lo + min(⌊u n⌋, n − 1), one of the n texels from lo that centres
   range over (``centre_axis``; the tiling passes (lo, n) = (margin, size − 2 · margin) on an axis
   that is read clamped, with the lattice's half extent added to the margin, and (0, size) on an
   axis the example wraps on);
4. the vertex position p(a, b) = side (a + b/2, b √3/2) rounded to whole texels in float64
   (``rounded_position``); on a periodic lattice the period's own vertex (a', b') is drawn and
   placed, shifted by the whole periods between them (``period_vertex``, ``period_position``);
5. with a lattice (integer dual vectors k over a modulus N, ``warp_texton.model.lattice``), the
   centre moved by whole texels so that the example's phase k · c / N at the centre equals the
   plane's at the vertex, k · p / N: the phase difference, centred in [−½, ½), taken back along the
   lattice and rounded to texels, in 32-bit integers only (``lattice_snap``; p enters as p mod N,
   ``position_mod``; a periodic lattice snaps at the period's own vertex, so periods repeat);
6. the example's addressing, clamp to edge (``texel_index``) or wrapped on an axis where the
   example is seamless (``texel_address``), which every lookup uses.

The ``@wp.func`` below are the reference: ``kernels/noise_tiling.py`` calls them, and so every Warp
kernel and users' kernels (the device API). The other evaluators run code generated here from one
language-neutral definition (:data:`DRAW`, :data:`PERIOD_DRAW`), rendered per dialect by
:func:`draw_code`: C++ for the native CPU run loop (``kernels/noise_tiling_native.py``), GLSL and
OSL for the shader exports (``warp_texton.runtimes``, which inject it into their templates). The
constants exist once, as the ``wp.constant`` values here and in ``impacts.py``; :data:`CONSTANTS`
writes them into each dialect's code. A change to the draw is made here, twice at most: in a Warp
function and in the neutral definition beside it.

The neutral definition is C-like code with four types (``u32``, ``i32``, ``f32`` and ``real``, the
lattice's float: float64 in C++, float32 in GLSL and OSL, which have no float64), output parameters
(``out``, ``inout``), ``floor`` and the logical right shift ``tl_shr``: C++ writes ``unsigned`` and
lambdas with reference parameters, GLSL ``uint``, OSL its signed 32-bit ``int`` (``+``, ``-``, ``*``
wrap as uint32 does; ``>>`` is arithmetic, so ``tl_shr`` masks the bits it shifts in). Integer steps
are exact in every dialect; float steps are the reference's operations in its order (the native
loop turns floating-point contraction off).

A general 2 × 2 basis of the triangle grid would be ``rounded_position`` (ports:
``tl_vertex_position``).

Driven by: ``warp_texton.runtimes.glsl.tiling``, ``warp_texton.runtimes.osl.tiling`` (the generated
code); its functions run in the kernels of ``kernels/noise_tiling.py``.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import warp as wp

from .impacts import AVALANCHE_M1, AVALANCHE_M2, GOLDEN, PCG_INC, PCG_MUL, PCG_OUT, avalanche, next_impact

wp.set_module_options({"enable_backward": False, "optimization_level": 3})

#: Mixed into the seed, so that the tiling's vertex stream is independent of the impacts' cells.
TILING_TAG = wp.constant(wp.uint32(0x2C1B3C6D))
#: √3/2, the triangle lattice's row height over its side (float64).
SQRT3_2 = wp.constant(wp.float64(0.8660254037844386))
#: Blend weights below this fraction of the largest are zero (their patches are not read).
CUTOFF = wp.constant(1.0e-4)
#: 2⁻²⁴: ``wp.randf``'s scale of the state's top 24 bits (exact).
RANDF_SCALE = wp.constant(1.0 / 16777216.0)


# ------------------------------------------------------------------ the reference (Warp)
@wp.func
def seed_state(seed: wp.uint32):
    # the seed's part of every vertex's hash
    return avalanche((seed ^ TILING_TAG) + GOLDEN)


@wp.func
def vertex_state(hs: wp.uint32, a: int, b: int):
    # the PCG state of vertex (a, b), from the seed's state hs
    h = avalanche(hs ^ wp.uint32(a))
    return avalanche(h ^ wp.uint32(b))


@wp.func
def centre_axis(u: float, lo: int, n: int):
    # the texel of one axis a uniform u in [0, 1) draws among the n texels from lo
    return lo + wp.min(int(wp.floor(u * float(n))), n - 1)


@wp.func
def vertex_centre(hs: wp.uint32, a: int, b: int, lo: wp.vec2i, n: wp.vec2i):
    # the example texel (column, row) that vertex (a, b) shows on itself: two PCG uniforms, column first
    u, s = next_impact(vertex_state(hs, a, b))  # the stream's two uniforms, as a plane impact's
    return wp.vec2i(centre_axis(u[0], lo[0], n[0]), centre_axis(u[1], lo[1], n[1]))


@wp.func
def rounded_position(side: wp.float64, a: int, b: int):
    # p(a, b) rounded to whole texels (float64, so far points are exact)
    px = side * (wp.float64(a) + wp.float64(b) * wp.float64(0.5))
    py = side * wp.float64(b) * SQRT3_2
    return wp.vec2d(wp.floor(px + wp.float64(0.5)), wp.floor(py + wp.float64(0.5)))


@wp.func
def floor_div(n: int, d: int):
    q = n / d
    if q * d > n:
        q = q - 1
    return q


@wp.func
def period_vertex(a: int, b: int, cols: int, rows: int):
    # (a', b', ka, kb): the period's own vertex of (a, b) on a periodic lattice of `cols` vertices across
    # and `rows` (even) rows, b' = b mod rows, a' = (a + (b − b') / 2) mod cols, and the periods between them
    kb = floor_div(b, rows)
    bb = b - kb * rows
    a1 = a + kb * (rows / 2)
    ka = floor_div(a1, cols)
    return wp.vec4i(a1 - ka * cols, bb, ka, kb)


@wp.func
def period_position(dx: wp.float64, dy: wp.float64, px: wp.float64, py: wp.float64, v: wp.vec4i):
    # the rounded position of period_vertex's v on the periodic lattice of spacing (dx, dy) and periods
    # (px, py): round(p(a', b')) shifted by the whole periods (ka, kb)
    qx = dx * (wp.float64(v[0]) + wp.float64(v[1]) * wp.float64(0.5))
    qy = dy * wp.float64(v[1])
    return wp.vec2d(wp.floor(qx + wp.float64(0.5)) + wp.float64(v[2]) * px,
                    wp.floor(qy + wp.float64(0.5)) + wp.float64(v[3]) * py)


@wp.func
def texel_index(i: int, n: int):
    # the example's addressing: texel i of an axis of n texels, clamped to the edge
    return wp.clamp(i, 0, n - 1)


@wp.func
def texel_address(i: int, n: int, wrap: int):
    # the example's addressing on an axis: wrapped where the example is seamless on it (wrap ≠ 0; patch
    # points stay within a side and a lattice cell of a centre, so i ≥ −4 n), else clamped (texel_index)
    if wrap != 0:
        return (i + 4 * n) % n
    return wp.clamp(i, 0, n - 1)


@wp.func
def mod_product(k: int, d: int, n: int):
    # (k · d) mod n in [0, n) for |k| ≤ n / 6, 0 ≤ d < n, n ≤ 2¹⁶: every intermediate below 2³¹
    return (k * d + n * (n / 6 + 1)) % n


@wp.func
def round_div(a: int, b: int):
    # a / b rounded to the nearest integer, halves away from zero, for b > 0 (non-negative divisions only)
    m = (2 * wp.abs(a) + b) / (2 * b)
    if a < 0:
        return -m
    return m


@wp.func
def lattice_snap(c: wp.vec2i, pmx: int, pmy: int, rank: int, n: int, k1: wp.vec2i, k2: wp.vec2i):
    # the centre c (column, row) moved by the whole texels that put the example's lattice phase at the
    # vertex position (pmx, pmy) (its position mod n) on the plane's: the phase k · (c − p) / n of each dual
    # vector k (x, y order) taken to the nearest 0 mod 1 (docs/tiling.md, "Lattices"); c itself for rank 0
    if rank == 0:
        return c
    dx = (c[0] - pmx + n) % n
    dy = (c[1] - pmy + n) % n
    r1 = (mod_product(k1[0], dx, n) + mod_product(k1[1], dy, n)) % n
    if 2 * r1 >= n:
        r1 = r1 - n
    if rank == 1:
        kk = k1[0] * k1[0] + k1[1] * k1[1]
        return wp.vec2i(c[0] - round_div(k1[0] * r1, kk), c[1] - round_div(k1[1] * r1, kk))
    r2 = (mod_product(k2[0], dx, n) + mod_product(k2[1], dy, n)) % n
    if 2 * r2 >= n:
        r2 = r2 - n
    det = k1[0] * k2[1] - k1[1] * k2[0]
    nx = k2[1] * r1 - k1[1] * r2
    ny = k1[0] * r2 - k2[0] * r1
    if det < 0:
        det = -det
        nx = -nx
        ny = -ny
    return wp.vec2i(c[0] - round_div(nx, det), c[1] - round_div(ny, det))


@wp.func
def position_mod(p: wp.float64, n: int):
    # a rounded vertex coordinate mod n, in [0, n) (float64 holds the integer exactly)
    fn = wp.float64(n)
    return int(p - fn * wp.floor(p / fn))


# ------------------------------------------------------------------ the same draw for other evaluators
#: The draw in the neutral dialect (see the module): every port renders all of it. tl_vertex_position
#: takes an origin (ox, oy) added before the rounding: 0 reproduces rounded_position; the GLSL port,
#: which has no float64, places vertices relative to an anchor vertex and passes its fraction.
DRAW = """
u32 tl_shr(u32 x, u32 k) {
    return @SHR@;
}

u32 tl_avalanche(u32 x) {
    x = x ^ tl_shr(x, 16u);
    x = x * TL_AVALANCHE_M1;
    x = x ^ tl_shr(x, 15u);
    x = x * TL_AVALANCHE_M2;
    x = x ^ tl_shr(x, 16u);
    return x;
}

u32 tl_pcg(u32 state) {
    u32 b = state * TL_PCG_MUL + TL_PCG_INC;
    u32 c = (tl_shr(b, tl_shr(b, 28u) + 4u) ^ b) * TL_PCG_OUT;
    return tl_shr(c, 22u) ^ c;
}

f32 tl_randf(inout u32 state) {
    state = tl_pcg(state);
    return f32(tl_shr(state, 8u)) * TL_RANDF_SCALE;
}

u32 tl_seed_state(u32 seed) {
    return tl_avalanche((seed ^ TL_TILING_TAG) + TL_GOLDEN);
}

u32 tl_vertex_state(u32 hs, i32 a, i32 b) {
    u32 h = tl_avalanche(hs ^ u32(a));
    return tl_avalanche(h ^ u32(b));
}

i32 tl_centre_axis(f32 u, i32 lo, i32 n) {
    i32 k = i32(floor(u * f32(n)));
    return lo + (k < n - 1 ? k : n - 1);
}

void tl_vertex_centre(u32 hs, i32 a, i32 b, i32 lox, i32 nx, i32 loy, i32 ny, out i32 cx, out i32 cy) {
    u32 s = tl_vertex_state(hs, a, b);
    f32 ux = tl_randf(s);
    f32 uy = tl_randf(s);
    cx = tl_centre_axis(ux, lox, nx);
    cy = tl_centre_axis(uy, loy, ny);
}

void tl_vertex_position(real ox, real oy, real side, i32 a, i32 b, out real px, out real py) {
    px = floor(ox + side * (real(a) + real(b) * 0.5) + 0.5);
    py = floor(oy + side * real(b) * TL_SQRT3_2 + 0.5);
}

i32 tl_texel_index(i32 i, i32 n) {
    return i < 0 ? 0 : (i > n - 1 ? n - 1 : i);
}

i32 tl_texel_address(i32 i, i32 n, i32 wrap) {
    return wrap != 0 ? (i + 4 * n) % n : tl_texel_index(i, n);
}

i32 tl_mod_product(i32 k, i32 d, i32 n) {
    return (k * d + n * (n / 6 + 1)) % n;
}

i32 tl_round_div(i32 a, i32 b) {
    i32 m = (2 * (a < 0 ? -a : a) + b) / (2 * b);
    return a < 0 ? -m : m;
}

void tl_lattice_snap(i32 cx, i32 cy, i32 pmx, i32 pmy, i32 rank, i32 n, i32 k1x, i32 k1y, i32 k2x, i32 k2y,
                     out i32 sx, out i32 sy) {
    sx = cx;
    sy = cy;
    if (rank != 0) {
        i32 dx = (cx - pmx + n) % n;
        i32 dy = (cy - pmy + n) % n;
        i32 r1 = (tl_mod_product(k1x, dx, n) + tl_mod_product(k1y, dy, n)) % n;
        r1 = 2 * r1 >= n ? r1 - n : r1;
        if (rank == 1) {
            i32 kk = k1x * k1x + k1y * k1y;
            sx = cx - tl_round_div(k1x * r1, kk);
            sy = cy - tl_round_div(k1y * r1, kk);
        } else {
            i32 r2 = (tl_mod_product(k2x, dx, n) + tl_mod_product(k2y, dy, n)) % n;
            r2 = 2 * r2 >= n ? r2 - n : r2;
            i32 det = k1x * k2y - k1y * k2x;
            i32 sg = det < 0 ? -1 : 1;
            sx = cx - tl_round_div(sg * (k2y * r1 - k1y * r2), sg * det);
            sy = cy - tl_round_div(sg * (k1x * r2 - k2x * r1), sg * det);
        }
    }
}
"""

#: The periodic lattice's vertex reduction (period_vertex, period_position), for the dialects whose
#: evaluator takes a period: C++ (the shader exports refuse a period, and GLSL ES leaves the
#: division of negative integers undefined).
PERIOD_DRAW = """
i32 tl_floor_div(i32 n, i32 d) {
    i32 q = n / d;
    return q * d > n ? q - 1 : q;
}

void tl_period_vertex(i32 a, i32 b, i32 cols, i32 rows, out i32 va, out i32 vb, out i32 ka, out i32 kb) {
    kb = tl_floor_div(b, rows);
    vb = b - kb * rows;
    i32 a1 = a + kb * (rows / 2);
    ka = tl_floor_div(a1, cols);
    va = a1 - ka * cols;
}

void tl_period_position(real dx, real dy, real lpx, real lpy, i32 va, i32 vb, i32 ka, i32 kb, out real px,
                        out real py) {
    px = floor(dx * (real(va) + real(vb) * 0.5) + 0.5) + real(ka) * lpx;
    py = floor(dy * real(vb) + 0.5) + real(kb) * lpy;
}
"""

#: The draw's constants, each with its neutral type: the wp.constant values the Warp functions use
#: (Warp's PCG multipliers are those its wp.randf draws with), written into every dialect's code.
CONSTANTS: dict[str, tuple[str, float | int]] = {
    "TL_TILING_TAG": ("u32", int(TILING_TAG)),
    "TL_GOLDEN": ("u32", int(GOLDEN)),
    "TL_AVALANCHE_M1": ("u32", int(AVALANCHE_M1)),
    "TL_AVALANCHE_M2": ("u32", int(AVALANCHE_M2)),
    "TL_PCG_MUL": ("u32", int(PCG_MUL)),
    "TL_PCG_INC": ("u32", int(PCG_INC)),
    "TL_PCG_OUT": ("u32", int(PCG_OUT)),
    "TL_RANDF_SCALE": ("f32", float(RANDF_SCALE)),
    "TL_SQRT3_2": ("real", float(SQRT3_2)),
    "TL_CUTOFF": ("f32", float(CUTOFF)),
}


def _f32(v: float) -> str:
    # a float32 as a decimal that reads back to the same float32 (nine significant digits)
    return f"{float(np.float32(v)):.9e}"


def _osl_float(v: float) -> str:
    # the float32 value's shortest float64 decimal (exact; OSL reads float literals to float32)
    s = repr(float(np.float32(v)))
    return s if ("e" in s or "." in s) else s + ".0"


def _i32(v: int) -> str:
    # an unsigned 32-bit value as the signed int with the same bits (parenthesised when negative)
    v &= 0xFFFFFFFF
    return str(v) if v < 1 << 31 else f"({v - (1 << 32)})"


@dataclass(frozen=True)
class Dialect:
    """How the neutral definition is written in one language."""

    types: dict[str, str]  # u32, i32, f32, real -> the language's types
    literal: dict[str, Callable[[float], str]]  # neutral type -> (value -> its literal)
    constant: str  # a constant's declaration: {type}, {name}, {value}
    function: str  # a function's first line: {ret}, {name}, {params}
    end: str  # a function's last line
    output: str  # an output parameter: {type}, {name}
    shift: str  # tl_shr's body: the logical right shift of x by k
    floor: str  # floor of a float or a real
    cast: str  # a conversion to {type} of the parenthesised expression that follows
    unsigned_suffix: bool  # whether unsigned literals keep their "u"


DIALECTS = {
    "cpp": Dialect(
        types={"u32": "unsigned", "i32": "int", "f32": "float", "real": "double"},
        literal={"u32": lambda v: f"0x{int(v):08X}u", "f32": lambda v: _f32(v) + "f", "real": repr},
        constant="const {type} {name} = {value};",
        function="const auto {name} = [&]({params}) -> {ret} {{", end="};", output="{type}& {name}",
        shift="x >> k", floor="wp::floor", cast="({type})", unsigned_suffix=True),
    "glsl": Dialect(
        types={"u32": "uint", "i32": "int", "f32": "float", "real": "float"},
        literal={"u32": lambda v: f"0x{int(v):08X}u", "f32": _f32, "real": _f32},
        constant="const {type} {name} = {value};",
        function="{ret} {name}({params}) {{", end="}", output="{mode} {type} {name}",
        shift="x >> k", floor="floor", cast="{type}", unsigned_suffix=True),
    "osl": Dialect(
        types={"u32": "int", "i32": "int", "f32": "float", "real": "float"},
        literal={"u32": _i32, "f32": _osl_float, "real": _osl_float},
        constant="#define {name} {value}",
        function="{ret} {name}({params})\n{{", end="}", output="output {type} {name}",
        shift="(x >> k) & ((1 << (32 - k)) - 1)", floor="floor", cast="{type}", unsigned_suffix=False),
}

_TYPES = re.compile(r"\b(u32|i32|f32|real)\b")
_HEADER = re.compile(r"^(\w+) (tl_\w+)\(([^)]*)\) \{$", re.M | re.S)
_OUTPUT = re.compile(r"^(out|inout) (\w+) (\w+)$")


def _params(params: str, d: Dialect) -> str:
    out = []
    for p in (p.strip() for p in params.split(",")):
        m = _OUTPUT.match(p)
        if m:
            mode, kind, name = m.groups()
            out.append(d.output.format(mode=mode, type=d.types[kind], name=name))
        else:
            kind, name = p.split()
            out.append(f"{d.types[kind]} {name}")
    return ", ".join(out)


def _render(source: str, d: Dialect) -> str:
    source = source.replace("@SHR@", d.shift)
    source = _HEADER.sub(lambda m: d.function.format(ret=d.types.get(m[1], m[1]), name=m[2],
                                                     params=_params(m[3], d)), source)
    source = re.sub(r"^\}$", d.end, source, flags=re.M)
    source = re.sub(r"\bfloor\(", d.floor + "(", source)
    if not d.unsigned_suffix:
        source = re.sub(r"\b(\d+)u\b", r"\1", source)
    # conversions (Warp's generated C++ defines float(x) and int(x) as macros: C++ writes C casts)
    source = re.sub(r"\b(u32|i32|f32|real)\(", lambda m: d.cast.format(type=d.types[m[1]]) + "(", source)
    return _TYPES.sub(lambda m: d.types[m[1]], source)


def constants_code(dialect: str) -> str:
    """The draw's constants (:data:`CONSTANTS`) declared in ``dialect`` ("cpp", "glsl", "osl")."""
    d = DIALECTS[dialect]
    return "\n".join(d.constant.format(type=d.types[kind], name=name, value=d.literal[kind](value))
                     for name, (kind, value) in CONSTANTS.items())


def draw_code(dialect: str, periodic: bool = False) -> str:
    """The vertex draw in ``dialect`` ("cpp": lambdas for a native snippet's body; "glsl", "osl": functions
    and constants for a shader's global scope): its constants, then :data:`DRAW` (and, with
    ``periodic``, :data:`PERIOD_DRAW`) rendered (see the module)."""
    d = DIALECTS[dialect]
    body = DRAW + (PERIOD_DRAW if periodic else "")
    header = ("// the tiling's vertex draw, generated from kernels/tiling_draw.py (docs/tiling.md, "
              "\"Specification\"): do not edit here")
    return header + "\n" + constants_code(dialect) + "\n" + _render(body, d).strip("\n") + "\n"
