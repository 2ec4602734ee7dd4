"""The tiling's vertex draw has one home (``kernels/tiling_draw.py``): the C++ of the native run loop, the
GLSL and the OSL exports run code generated from its one definition, with the kernels' own constants, and no
template writes a piece of the draw (or one of its constants) by hand.

The generated code's values are checked where it runs: the native loop against ``tiling_value`` bit for bit
(tests/noise/test_tiling_raster.py), the GLSL in Chromium and the OSL in Blender against ``synthesize`` and
``evaluate`` (test_tiling_glsl.py, test_tiling_osl.py). Here: that it is the definition's, and that the
definition's integer steps and constants are the Warp reference's, bit for bit."""

from __future__ import annotations

import re

import numpy as np
import pytest
import warp as wp

from warp_texton.kernels import impacts, noise_tiling_native, tiling_draw
from warp_texton.model.tiling import TilingModel
from warp_texton.runtimes.glsl import tiling as glsl_tiling
from warp_texton.runtimes.osl import tiling as osl_tiling
from warp_texton.runtimes.shared import template

DIALECTS = ("cpp", "glsl", "osl")
#: Every constant of the draw, as the Warp functions hold it.
KERNEL_CONSTANTS = {
    "TL_TILING_TAG": int(tiling_draw.TILING_TAG), "TL_GOLDEN": int(impacts.GOLDEN),
    "TL_AVALANCHE_M1": int(impacts.AVALANCHE_M1), "TL_AVALANCHE_M2": int(impacts.AVALANCHE_M2),
    "TL_PCG_MUL": int(impacts.PCG_MUL), "TL_PCG_INC": int(impacts.PCG_INC), "TL_PCG_OUT": int(impacts.PCG_OUT),
    "TL_RANDF_SCALE": float(tiling_draw.RANDF_SCALE), "TL_SQRT3_2": float(tiling_draw.SQRT3_2),
    "TL_CUTOFF": float(tiling_draw.CUTOFF),
}
#: The draw's functions (the neutral definition's, every dialect's).
FUNCTIONS = re.findall(r"^\w+ (tl_\w+)\(", tiling_draw.DRAW, re.M)
PERIOD_FUNCTIONS = re.findall(r"^\w+ (tl_\w+)\(", tiling_draw.PERIOD_DRAW, re.M)


def model() -> TilingModel:
    rng = np.random.default_rng(0)
    return TilingModel(rng.random((40, 48, 3)).astype(np.float32), 9.5, 4, 1.0, {}, "linear")


#: The sources that run the generated draw: the native run loop (C++), a GLSL library, an OSL shader.
SOURCES = {
    "cpp": lambda: noise_tiling_native.RUN_SOURCE,
    "glsl": lambda: glsl_tiling.glsl_source(model(), 5),
    "osl": lambda: osl_tiling.tiling_osl_files(model(), 5)[osl_tiling.OSL_FILE].decode(),
}
#: The templates they come from, as written by hand.
TEMPLATES = {
    "cpp": lambda: noise_tiling_native.RUN_TEMPLATE,
    "glsl": lambda: template("tiling_noise.glsl"),
    "osl": lambda: template("tiling_noise.osl"),
}
#: How each template marks where the draw goes.
MARKERS = {"cpp": "@TILING_DRAW@", "glsl": "//@TILING_DRAW@", "osl": "$TILING_DRAW"}


def declared_constants(source: str, dialect: str) -> dict[str, float | int]:
    """The value of every constant a generated source declares (C++ and GLSL const, OSL #define)."""
    if dialect == "osl":
        pairs = re.findall(r"^#define (TL_\w+) \(?([-+0-9.e]+)\)?$", source, re.M)
    else:
        pairs = re.findall(r"^const \w+ (TL_\w+) = (0x[0-9A-F]+u|[-+0-9.e]+f?);$", source, re.M)
    out: dict[str, float | int] = {}
    for name, text in pairs:
        if name not in tiling_draw.CONSTANTS:  # the model's own constants (a GLSL library's TL_SEED, ...)
            continue
        kind = tiling_draw.CONSTANTS[name][0]
        text = text.rstrip("uf") if not text.startswith("0x") else text[:-1]
        if kind == "u32":
            out[name] = int(text, 16) if text.startswith("0x") else int(text) & 0xFFFFFFFF
        elif kind == "real" and dialect == "cpp":
            out[name] = float(text)
        else:  # float32 in every dialect (GLSL and OSL have no float64)
            out[name] = float(np.float32(float(text)))
    return out


@pytest.mark.parametrize("dialect", DIALECTS)
def test_generated_sources_declare_the_kernels_constants(dialect):
    source = SOURCES[dialect]()
    got = declared_constants(source, dialect)
    assert set(got) == set(tiling_draw.CONSTANTS) == set(KERNEL_CONSTANTS)
    for name, value in KERNEL_CONSTANTS.items():
        kind = tiling_draw.CONSTANTS[name][0]
        want = value if kind == "u32" or (kind == "real" and dialect == "cpp") else float(np.float32(value))
        assert got[name] == want, (dialect, name, got[name], want)
    assert source.count(tiling_draw.constants_code(dialect)) == 1


@pytest.mark.parametrize("dialect", DIALECTS)
def test_generated_sources_hold_the_one_definition(dialect):
    """The source holds the rendered definition once, every function of it defined once, in the
    dialect's own spelling (no neutral type or output keyword left)."""
    periodic = dialect == "cpp"
    code = tiling_draw.draw_code(dialect, periodic=periodic)
    source = SOURCES[dialect]()
    assert source.count(code) == 1
    for name in FUNCTIONS + (PERIOD_FUNCTIONS if periodic else []):
        defined = rf"const auto {name} = \[&\]\(" if dialect == "cpp" else rf"^\w+ {name}\("
        assert len(re.findall(defined, source, re.M)) == 1, (dialect, name)
    assert not re.search(r"\b(u32|i32|f32|real)\b", code)
    assert (re.search(r"\bout(put)? ", code) is None) == (dialect == "cpp")
    if not periodic:
        assert not any(name in source for name in PERIOD_FUNCTIONS)


def spellings(name: str, kind: str, value) -> list[str]:
    """The ways a template could write a constant by hand (lower-cased)."""
    if kind == "u32":
        return [f"{value:08x}", str(value), str(value - (1 << 32))]
    digits = f"{value:.6e}".split("e")[0].replace(".", "")  # the first 7 significant digits
    out = [] if digits.endswith("00000") else [digits[:6]]  # 8660254..., 5960464...
    if name == "TL_CUTOFF":
        out += ["0.0001", "1e-4", "1.0e-4", "1e-04", "9.999999"]
    if name == "TL_RANDF_SCALE":
        out += ["16777216"]
    return out


@pytest.mark.parametrize("dialect", DIALECTS)
def test_no_template_writes_the_draw_by_hand(dialect):
    """The templates leave the draw to the definition: none holds a draw constant in any spelling, nor
    defines the hash, the PCG step or the draws; each marks the one place the draw goes."""
    text = TEMPLATES[dialect]()
    lowered = text.lower()
    for name, (kind, value) in tiling_draw.CONSTANTS.items():
        for s in spellings(name, kind, value):
            assert s not in lowered, (dialect, name, s)
    assert text.count(MARKERS[dialect]) == 1
    # no hash, PCG step or draw of its own: neither a function (GLSL, OSL) nor a lambda (C++)
    assert not re.search(r"^\s*\w+\s+\w*(aval|pcg|rand)\w*\s*\(|\w*(aval|pcg|rand)\w*\s*=\s*\[", text, re.M)
    assert "wp::randf" not in text and "floor_div" not in text


def test_the_rules_catch_a_constant_written_by_hand():
    """The checks above are not vacuous: a template with a hand-written tag or √3/2 fails them."""
    bad = template("tiling_noise.glsl").replace("TL_SQRT3_2", "0.8660254")
    assert any(s in bad.lower() for s in spellings("TL_SQRT3_2", "real", float(tiling_draw.SQRT3_2)))
    tag = int(tiling_draw.TILING_TAG)
    assert any(s in f"h ^ 0x{tag:08X}u".lower() for s in spellings("TL_TILING_TAG", "u32", tag))


# ------------------------------------------------------------------ the definition is the reference's
@wp.kernel
def _draw_reference(seeds: wp.array(dtype=wp.uint32), ab: wp.array(dtype=wp.vec2i), lo: wp.vec2i, n: wp.vec2i,
                    states: wp.array(dtype=wp.uint32), uniforms: wp.array(dtype=wp.vec2),
                    centres: wp.array(dtype=wp.vec2i), period: wp.array(dtype=wp.vec4i)):
    k = wp.tid()
    hs = tiling_draw.seed_state(seeds[k])
    s = tiling_draw.vertex_state(hs, ab[k][0], ab[k][1])
    states[k] = s
    ux = wp.randf(s)
    uy = wp.randf(s)
    uniforms[k] = wp.vec2(ux, uy)
    centres[k] = tiling_draw.vertex_centre(hs, ab[k][0], ab[k][1], lo, n)
    period[k] = tiling_draw.period_vertex(ab[k][0], ab[k][1], 7, 6)


def _u32(x):
    return np.asarray(x, np.uint64) & np.uint64(0xFFFFFFFF)


def _definition(seeds, a, b, lo, n):
    """The neutral definition's integer steps, followed literally with its CONSTANTS (NumPy uint64 mod 2³²)."""
    c = {name: np.uint64(v) if kind == "u32" else v for name, (kind, v) in tiling_draw.CONSTANTS.items()}

    def aval(x):
        x = x ^ (x >> np.uint64(16))
        x = _u32(x * c["TL_AVALANCHE_M1"])
        x = x ^ (x >> np.uint64(15))
        x = _u32(x * c["TL_AVALANCHE_M2"])
        return x ^ (x >> np.uint64(16))

    def pcg(s):
        bb = _u32(s * c["TL_PCG_MUL"] + c["TL_PCG_INC"])
        cc = _u32(((bb >> ((bb >> np.uint64(28)) + np.uint64(4))) ^ bb) * c["TL_PCG_OUT"])
        return (cc >> np.uint64(22)) ^ cc

    hs = aval(_u32((_u32(seeds) ^ c["TL_TILING_TAG"]) + c["TL_GOLDEN"]))
    s = aval(aval(hs ^ _u32(a.astype(np.int64))) ^ _u32(b.astype(np.int64)))
    s1 = pcg(s)
    s2 = pcg(s1)
    u = np.stack([(s1 >> np.uint64(8)).astype(np.float32), (s2 >> np.uint64(8)).astype(np.float32)], -1)
    u = u * np.float32(c["TL_RANDF_SCALE"])
    k = np.floor(u * np.float32(n)).astype(np.int64)
    centre = lo + np.minimum(k, np.array(n) - 1)
    return s, u, centre


def test_the_definitions_integer_steps_are_the_warp_references():
    """The hash, Warp's PCG draws and the centre texel as the neutral definition writes them, with the
    constants it declares, are the Warp functions' (wp.randf's own PCG included), bit for bit."""
    rng = np.random.default_rng(1)
    m = 4000
    seeds = rng.integers(0, 2**32, m, dtype=np.uint64)
    seeds[:2] = [0, 2**32 - 1]
    ab = rng.integers(-2**30, 2**30, (m, 2)).astype(np.int32)
    ab[:4] = [[0, 0], [-1, -1], [2**31 - 1, -2**31], [7, -13]]
    lo, n = (5, 6), (29, 17)
    dev = "cpu"
    out = [wp.zeros(m, dtype=t, device=dev) for t in (wp.uint32, wp.vec2, wp.vec2i, wp.vec4i)]
    wp.launch(_draw_reference, dim=m, inputs=[wp.array(seeds.astype(np.uint32), dtype=wp.uint32, device=dev),
                                              wp.array(ab, dtype=wp.vec2i, device=dev), wp.vec2i(*lo),
                                              wp.vec2i(*n)], outputs=out, device=dev)
    states, uniforms, centres, period = (o.numpy() for o in out)
    s, u, centre = _definition(seeds, ab[:, 0], ab[:, 1], np.array(lo), n)
    assert np.array_equal(states.astype(np.uint64), s)
    assert np.array_equal(uniforms, u) and u.min() >= 0 and u.max() < 1
    assert np.array_equal(centres, centre)
    assert centres[:, 0].min() >= lo[0] and centres[:, 0].max() <= lo[0] + n[0] - 1
    # the periodic vertex: b' = b mod rows, a' = (a + (b − b') / 2) mod cols, a = a' + ka cols − kb rows/2
    va, vb, ka, kb = period.T.astype(np.int64)
    a, b = ab[:, 0].astype(np.int64), ab[:, 1].astype(np.int64)
    assert np.array_equal(vb, b % 6) and np.array_equal(kb, b // 6)
    assert np.array_equal(va, (a + kb * 3) % 7) and np.array_equal(ka, (a + kb * 3) // 7)


# ------------------------------------------------------------------ the generated C++ is the reference
#: A native function's body around the generated C++ (the native run loop's setting: no contraction).
_PRELUDE = "#if defined(__clang__)\n#pragma clang fp contract(off)\n#endif\n" + tiling_draw.draw_code("cpp", True)


@wp.func_native(_PRELUDE + """
int cx, cy;
tl_vertex_centre(tl_seed_state(seed), a, b, lo[0], n[0], lo[1], n[1], cx, cy);
return wp::vec2i(cx, cy);
""")
def generated_centre(seed: wp.uint32, a: int, b: int, lo: wp.vec2i, n: wp.vec2i) -> wp.vec2i:
    ...


@wp.func_native(_PRELUDE + """
double px, py;
if (period[0] == 0) {
    tl_vertex_position(0.0, 0.0, side, a, b, px, py);
} else {
    int va, vb, ka, kb;
    tl_period_vertex(a, b, period[0], period[1], va, vb, ka, kb);
    tl_period_position(spacing[0], spacing[1], extent[0], extent[1], va, vb, ka, kb, px, py);
}
return wp::vec2d(px, py);
""")
def generated_position(side: wp.float64, a: int, b: int, period: wp.vec2i, spacing: wp.vec2d,
                       extent: wp.vec2d) -> wp.vec2d:
    ...


@wp.func_native(_PRELUDE + "return tl_texel_index(i, n);\n")
def generated_texel(i: int, n: int) -> int:
    ...


@wp.kernel
def _generated_against_reference(seeds: wp.array(dtype=wp.uint32), ab: wp.array(dtype=wp.vec2i),
                                 sides: wp.array(dtype=wp.float64), lo: wp.vec2i, n: wp.vec2i,
                                 differ: wp.array(dtype=int)):
    k = wp.tid()
    a = ab[k][0]
    b = ab[k][1]
    hs = tiling_draw.seed_state(seeds[k])
    bad = int(0)
    c = generated_centre(seeds[k], a, b, lo, n)
    cw = tiling_draw.vertex_centre(hs, a, b, lo, n)
    if c[0] != cw[0] or c[1] != cw[1]:
        bad = bad + 1
    plain = generated_position(sides[k], a, b, wp.vec2i(0, 0), wp.vec2d(), wp.vec2d())
    pw = tiling_draw.rounded_position(sides[k], a, b)
    if plain[0] != pw[0] or plain[1] != pw[1]:
        bad = bad + 2
    # a periodic lattice of 7 × 6 vertices, spacing (dx, dy) = side · (1, 0.9), periods (7 dx, 6 dy)
    dx = sides[k]
    dy = sides[k] * wp.float64(0.9)
    v = tiling_draw.period_vertex(a, b, 7, 6)
    want = tiling_draw.period_position(dx, dy, wp.float64(7.0) * dx, wp.float64(6.0) * dy, v)
    got = generated_position(sides[k], a, b, wp.vec2i(7, 6), wp.vec2d(dx, dy),
                             wp.vec2d(wp.float64(7.0) * dx, wp.float64(6.0) * dy))
    if got[0] != want[0] or got[1] != want[1]:
        bad = bad + 4
    i = a / 65536
    if generated_texel(i, 3000) != tiling_draw.texel_index(i, 3000):
        bad = bad + 8
    differ[k] = bad


def test_the_generated_cpp_is_the_warp_reference():
    """The C++ rendering of the definition (the native run loop's draw), compiled by Warp beside the
    reference functions: the same centres, rounded positions (plain and periodic lattices, float64) and
    addressing, bit for bit, at vertices up to ±2³⁰ and sides from 2 to 300 texels."""
    rng = np.random.default_rng(2)
    m = 20000
    seeds = rng.integers(0, 2**32, m, dtype=np.uint64).astype(np.uint32)
    ab = np.concatenate([rng.integers(-2**30, 2**30, (m // 2, 2)), rng.integers(-300, 300, (m - m // 2, 2))])
    sides = np.exp(rng.uniform(np.log(2.0), np.log(300.0), m))
    differ = wp.zeros(m, dtype=int, device="cpu")
    wp.launch(_generated_against_reference, dim=m,
              inputs=[wp.array(seeds, dtype=wp.uint32, device="cpu"), wp.array(ab.astype(np.int32), dtype=wp.vec2i,
                                                                               device="cpu"),
                      wp.array(sides, dtype=wp.float64, device="cpu"), wp.vec2i(5, 6), wp.vec2i(29, 17)],
              outputs=[differ], device="cpu")
    assert not differ.numpy().any(), np.bincount(differ.numpy())
