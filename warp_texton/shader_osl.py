"""Texton noise as OSL shaders (Blender Cycles, Arnold, RenderMan, V-Ray).

:func:`osl_files` writes two Open Shading Language sources from one template:

* ``texton_surface.osl``: surface noise (CGF §6) at the shading point, from
  ``P`` and ``N`` alone, no UVs: the walk of ``kernels/surface.py``
  (``surface_value``: the frame rule, the cubes of ``cube_span``, the slab
  weight, CGF Prop. 3's normalisation);
* ``texton_plane.osl``: plane noise (``evaluate``: ``kernels/noise2d.py``,
  ``evaluate_points``) at a texel-space point made from the UVs or from the
  object-space x, y.

Both draw the impacts of ``kernels/impacts.py`` in its order (the cell hash
``avalanche``/``cell_state``/``cell_state3``, Warp's PCG ``rand_pcg``,
``randf``, ``randn`` and ``wp.poisson``: Knuth's product method below a mean of
10, Hörmann's PTRS with ``random_loggam`` above) in OSL's 32-bit ``int``, which
wraps on ``+``, ``-`` and ``*`` as ``uint32`` does; ``>>`` is arithmetic in OSL,
so the logical shifts mask the high bits. The constants (cell sizes, the
support box, λ, the Poisson sampler's per-noise constants, the CGF Prop. 3
shift and scale) come from the host code the kernels use
(:func:`~warp_texton.noise.noise_setup`, :func:`~warp_texton.noise.params_record`,
:func:`~warp_texton.surface.surface_setup`, :func:`~warp_texton.surface.surface_params`),
and the transcendental ones from Warp's own CPU builtins, so they are the
kernels' float32 values. The texton's padded coefficients are embedded as a
constant array (see docs/renderers.md for why, and the limit
:data:`MAX_EMBEDDED_FLOATS`).

What OSL cannot do as the kernels do: it has no float64, so cells are found
and offsets taken in float32 (the shading point arrives in float32 anyway);
near the origin this changes values by float rounding only, far from it the
offsets lose precision (docs/renderers.md gives the range).
"""

from __future__ import annotations

import math
from string import Template

import numpy as np

from ._checks import check_positive, check_seed
from ._runtime import init_warp
from .errors import TextonError
from .frames import UP
from .kernels.noise2d import PAD
from .noise import CELL_FACTOR, noise_setup, params_record
from .surface import surface_params, surface_setup
from .texton import Texton

#: Floats of padded coefficients a shader embeds at most: a 256 × 256 RGB texton
#: with its margin (a 4.7 MB source, which Blender compiles in about 2 s; the
#: default 64 × 64 of ``analyze`` takes 0.25 s: docs/renderers.md).
MAX_EMBEDDED_FLOATS = (256 + 2 * PAD) ** 2 * 3
#: The files :func:`osl_files` returns.
SURFACE_FILE = "texton_surface.osl"
PLANE_FILE = "texton_plane.osl"


#: The float literals of warp/native/rand.h's Poisson sampler and ``randn``, as C reads
#: them (float32; each decimal rounds to the same float32 directly or through float64).
RAND_H = {
    "LG0": "8.333333333333333e-02", "LG1": "-2.777777777777778e-03", "LG2": "7.936507936507937e-04",
    "LG3": "-5.952380952380952e-04", "LG4": "8.417508417508418e-04", "LG5": "-1.917526917526918e-03",
    "LG6": "6.410256410256410e-03", "LG7": "-2.955065359477124e-02", "LG8": "1.796443723688307e-01",
    "LG9": "-1.39243221690590e+00", "RANDN_EPS": "5.96e-8", "B0": "0.931", "B1": "2.53", "A0": "-0.059",
    "A1": "0.02483", "IA0": "1.1239", "IA1": "1.1328", "IA2": "3.4", "VR0": "0.9277", "VR1": "3.6224",
    "US_ACCEPT": "0.07", "US_REJECT": "0.013", "K_SHIFT": "0.43",
}
F = {k: np.float32(float(v)) for k, v in RAND_H.items()}
#: 0.5f * lg2pi and 2.f * M_PI_F, products C evaluates in float32
DERIVED = {"HALF_LG2PI": np.float32(0.5) * np.float32(1.8378770664093453),
           "TWO_PI": np.float32(2.0) * np.float32(3.14159265358979323846)}


def i32(v: int) -> int:
    """An unsigned 32-bit constant as the signed ``int`` OSL holds (the same bits)."""
    v &= 0xFFFFFFFF
    return v - (1 << 32) if v >= 1 << 31 else v


def f32(v) -> str:
    """A float32 value as an OSL literal that parses back to exactly that value."""
    x = float(np.float32(v))
    if not math.isfinite(x):
        raise TextonError(f"a shader constant is not finite ({x}); the texton or options overflow float32")
    s = repr(x)
    return s if ("e" in s or "." in s) else s + ".0"


def counts_constants(mean) -> dict[str, str]:
    """The per-noise constants of ``wp.poisson`` (warp/native/rand.h) for a cell mean,
    with Warp's CPU sqrt, log and exp, so a shader's samplers compare against the
    kernels' values: exp(−mean) for the product method, PTRS's slam, log λ, a, b,
    vr and log(1/α)."""
    wp = init_warp()
    lam = np.float32(mean)
    f = np.float32
    slam = f(wp.sqrt(wp.float32(lam)))
    b = F["B0"] + F["B1"] * slam
    a = F["A0"] + F["A1"] * b
    invalpha = F["IA0"] + F["IA1"] / (b - F["IA2"])
    vr = F["VR0"] - F["VR1"] / (b - f(2.0))
    return {
        "mean": f32(lam), "enlam": f32(wp.exp(wp.float32(-lam))), "slam": f32(slam),
        "loglam": f32(wp.log(wp.float32(lam))), "a": f32(a), "b": f32(b),
        "log_invalpha": f32(wp.log(wp.float32(invalpha))), "vr": f32(vr),
    }


def coefficient_array(coeffs: np.ndarray, channels: int) -> str:
    """The padded coefficients (rows, cols, 3) as an OSL initialiser, row-major, ``channels`` per texel."""
    flat = coeffs[:, :, :channels].reshape(-1)
    lines = []
    for start in range(0, flat.size, 8):
        lines.append("        " + ", ".join(f32(v) for v in flat[start:start + 8]))
    return ",\n".join(lines)


def colour_of(channels: int) -> str:
    return "color(T[k], T[k + 1], T[k + 2])" if channels == 3 else "color(T[k], 0.0, 0.0)"


def osl_files(
    texton: Texton,
    *,
    mni: float = 30.0,
    seed: int = 0,
    period=None,
    poisson: str = "exact",
    cell_factor: float = CELL_FACTOR,
    texel_size: float = 0.01,
    up=UP,
    side=None,
) -> dict[str, bytes]:
    """OSL sources of texton noise: a surface shader (P, N) and a plane/UV shader.

    Parameters
    ----------
    texton : Texton
        Its padded coefficients are embedded in both shaders (at most
        ``MAX_EMBEDDED_FLOATS`` floats: a 256 × 256 RGB texton).
    mni : float
        The default of both shaders' ``mni`` parameter (as in
        :func:`~warp_texton.evaluate`; surfaces want about 60,
        :func:`~warp_texton.surface_noise`).
    seed : int
        The default of the shaders' ``seed`` parameter, in [0, 2**32); OSL's
        ``int`` is signed, so seeds from 2**31 show as seed − 2**32.
    period : (Px, Py), optional
        The plane shader's period in texels (as in :func:`~warp_texton.evaluate`);
        fixed at export.
    poisson : {"exact", "gaussian"}
        The default of the shaders' ``exact_poisson`` parameter (1 or 0).
    cell_factor : float
        As in :func:`~warp_texton.evaluate` and :func:`~warp_texton.surface_noise`;
        fixed at export.
    texel_size : float
        The default of the shaders' ``texel_size`` parameter: coordinate units
        (object or world units, or UV units for the plane shader's UVs) per texel.
    up, side
        The surface frame rule's directions (:func:`~warp_texton.tangent_frames`);
        fixed at export.

    Returns
    -------
    dict
        ``{"texton_surface.osl": bytes, "texton_plane.osl": bytes}``.

    Raises
    ------
    TextonError
        For a texton too large to embed, and for the options that
        :func:`~warp_texton.evaluate` and :func:`~warp_texton.surface_noise`
        refuse.

    Notes
    -----
    The shaders draw the kernels' impacts (the same hash, PCG stream and
    Poisson sampler, in integer arithmetic) and sum the same terms in the same
    order, in float32: see docs/renderers.md for what is equal and the measured
    agreement with Blender's Cycles.

    Examples
    --------
    >>> import numpy as np
    >>> from warp_texton import Texton
    >>> from warp_texton.shader_osl import osl_files
    >>> t = Texton(np.random.default_rng(0).standard_normal((8, 8, 1)) / 8, [0.5])
    >>> files = osl_files(t, mni=30, seed=7)
    >>> sorted(files)
    ['texton_plane.osl', 'texton_surface.osl']
    >>> b"shader texton_surface(" in files["texton_surface.osl"]
    True
    """
    if not isinstance(texton, Texton):
        raise TextonError(f"texton must be a Texton, got {type(texton).__name__}")
    seed = check_seed(seed)
    texel_size = check_positive(texel_size, "texel_size")
    setup = noise_setup(texton, mni, period, cell_factor)
    rows, cols, _ = setup.coeffs.shape
    channels = texton.channels
    if rows * cols * channels > MAX_EMBEDDED_FLOATS:
        r, s = texton.size
        raise TextonError(
            f"texton of {r} x {s} texels with {channels} channels is too large for an OSL shader: "
            f"{rows * cols * channels} floats with its margin, at most {MAX_EMBEDDED_FLOATS} (a 256 x 256 RGB texton); "
            "analyze with a smaller size", param="texton")
    rec = params_record(texton, setup, seed, poisson)
    surf = surface_setup(texton, mni, cell_factor)
    sp = surface_params(texton, surf, seed, poisson, up, side)
    common = {
        **{k: f32(v) for k, v in {**F, **DERIVED}.items()},
        "COLS": str(cols), "ROWS": str(rows), "PAD": str(PAD), "CHANNELS": str(channels), "ORDER": str(texton.order),
        "TEXEL": colour_of(channels), "COEFFS": coefficient_array(setup.coeffs, channels), "N": str(rows * cols * channels),
        "M1": str(i32(0x7FEB352D)), "M2": str(i32(0x846CA68B)), "GOLDEN": str(i32(0x9E3779B9)),
        "SPACE_TAG": str(i32(0x5BD1E995)), "PCG_MUL": str(i32(747796405)), "PCG_INC": str(i32(2891336453)),
        "PCG_OUT": str(i32(277803737)), "SEED": str(i32(seed)), "MNI": f32(setup.mni), "AREA": f32(texton.support_area),
        "TEXEL_SIZE": f32(texel_size), "EXACT": "1" if poisson == "exact" else "0",
        "VALUE": "g[0]", "COLOUR": "g" if channels == 3 else "color(g[0], g[0], g[0])",
    }
    cells = rec["cells"]
    plane = dict(common, **{
        "CW": f32(cells["size"][0]), "CH": f32(cells["size"][1]), "PX": str(int(cells["period"][0])),
        "PY": str(int(cells["period"][1])), "LO0": f32(rec["lo"][0]), "LO1": f32(rec["lo"][1]),
        "HI0": f32(rec["hi"][0]), "HI1": f32(rec["hi"][1]), "LAM": f32(rec["lam"]),
        "MEAN": colour_literal(rec["mean"]), "INTEGRAL": colour_literal(rec["integral"]),
        "CELL_AREA": f32(float(np.float32(cells["size"][0])) * float(np.float32(cells["size"][1]))),
        **{f"K_{k}": v for k, v in counts_constants(cells["mean_count"]).items()},
    })
    surface = dict(common, **{
        "C": f32(sp.cells.size), "HALF": f32(sp.half), "R": f32(2.0 * sp.half),
        "CENTRE0": f32(sp.centre[0]), "CENTRE1": f32(sp.centre[1]),
        "LO0": f32(sp.lo[0]), "LO1": f32(sp.lo[1]), "HI0": f32(sp.hi[0]), "HI1": f32(sp.hi[1]),
        "SHIFT": colour_literal(sp.shift), "INV_SCALE": f32(sp.inv_scale), "MEAN": colour_literal(sp.mean),
        "INTEGRAL": colour_literal(np.pad(np.asarray(texton.integral, np.float64), (0, 3 - channels))),
        "UP": vector_literal(sp.up), "SIDE": vector_literal(sp.side),
        **{f"K_{k}": v for k, v in counts_constants(sp.cells.mean_count).items()},
    })
    return {
        SURFACE_FILE: Template(FUNCTIONS + SURFACE_SHADER).substitute(surface).encode(),
        PLANE_FILE: Template(FUNCTIONS + PLANE_SHADER).substitute(plane).encode(),
    }


def colour_literal(v) -> str:
    return f"color({f32(v[0])}, {f32(v[1])}, {f32(v[2])})"


def vector_literal(v) -> str:
    return f"vector({f32(v[0])}, {f32(v[1])}, {f32(v[2])})"


#: The functions both shaders share: the impact stream and the texton lookup.
FUNCTIONS = r"""// Texton noise (Galerne, Leclaire, Moisan, CGF 2017), generated by warp-texton.
// Draws the impacts of warp_texton's Warp kernels: the same cell hash, PCG stream and
// Poisson sampler in 32-bit integer arithmetic. OSL's int is signed: + - * wrap as
// uint32 does, and >> is arithmetic, so srl masks the bits it shifts in.

struct Counts {
    int exact;  // 1: Poisson counts (wp.poisson); 0: rounded Gaussian
    float mean, enlam, slam, loglam, a, b, log_invalpha, vr;
};

int srl(int x, int k)
{
    return (x >> k) & ((1 << (32 - k)) - 1);
}

int avalanche(int v)
{
    int x = v;
    x = x ^ srl(x, 16);
    x = x * $M1;
    x = x ^ srl(x, 15);
    x = x * $M2;
    x = x ^ srl(x, 16);
    return x;
}

int rand_pcg(int state)
{
    int b = state * $PCG_MUL + $PCG_INC;
    int c = (srl(b, srl(b, 28) + 4) ^ b) * $PCG_OUT;
    return srl(c, 22) ^ c;
}

float randf(output int state)
{
    state = rand_pcg(state);
    return float(srl(state, 8)) * 5.960464477539063e-08;
}

float randn(output int state)
{
    float u1 = randf(state);
    float u2 = randf(state);
    return sqrt(-2.0 * log(u1 + $RANDN_EPS)) * cos($TWO_PI * u2);
}

float loggam(float x)
{
    if (x == 1.0 || x == 2.0)
        return 0.0;
    int n = 0;
    if (x < 7.0)
        n = int(7.0 - x);
    float x0 = x + float(n);
    float x2 = (1.0 / x0) * (1.0 / x0);
    float coef[10] = {$LG0, $LG1, $LG2, $LG3, $LG4,
                      $LG5, $LG6, $LG7, $LG8, $LG9};
    float gl0 = coef[9];
    for (int i = 8; i >= 0; i--) {
        gl0 *= x2;
        gl0 += coef[i];
    }
    float gl = gl0 / x0 + $HALF_LG2PI + (x0 - 0.5) * log(x0) - x0;
    if (x < 7.0) {
        for (int k = 1; k <= n; k++) {
            gl -= log(x0 - 1.0);
            x0 -= 1.0;
        }
    }
    return gl;
}

int poisson(output int state, Counts c)
{
    if (c.mean >= 10.0) {
        // Hörmann's transformed rejection (PTRS), as warp/native/rand.h random_poisson
        int result = -1;
        while (result < 0) {
            float U = randf(state) - 0.5;
            float V = randf(state);
            float us = 0.5 - fabs(U);
            float k = floor((2.0 * c.a / us + c.b) * U + c.mean + $K_SHIFT);
            if (us >= $US_ACCEPT && V <= c.vr) {
                result = int(k);
            } else if (!(k < 0.0 || (us < $US_REJECT && V > us))) {
                if (log(V) + c.log_invalpha - log(c.a / (us * us) + c.b)
                        <= -c.mean + k * c.loglam - loggam(k + 1.0))
                    result = int(k);
            }
        }
        return result;
    }
    if (c.mean == 0.0)
        return 0;
    // the product of uniforms (random_poisson_mult)
    int n = 0;
    float prod = 1.0;
    int going = 1;
    while (going) {
        prod *= randf(state);
        if (prod > c.enlam)
            n += 1;
        else
            going = 0;
    }
    return n;
}

int draw_count(output int state, Counts c)
{
    if (c.exact != 0)
        return poisson(state, c);
    float g = randn(state);
    return max(int(floor(c.mean + 0.5 + sqrt(c.mean) * g)), 0);
}

Counts counts_for(float mean, int exact)
{
    // the sampler's constants for a mean other than the exported one, with OSL's
    // sqrt, log and exp (the exported mean uses Warp's values)
    Counts c;
    c.exact = exact;
    c.mean = mean;
    c.enlam = exp(-mean);
    c.slam = sqrt(mean);
    c.loglam = log(mean);
    c.b = $B0 + $B1 * c.slam;
    c.a = $A0 + $A1 * c.b;
    c.log_invalpha = log($IA0 + $IA1 / (c.b - $IA2));
    c.vr = $VR0 - $VR1 / (c.b - 2.0);
    return c;
}

Counts exported_counts(int exact)
{
    Counts c;
    c.exact = exact;
    c.mean = $K_mean;
    c.enlam = $K_enlam;
    c.slam = $K_slam;
    c.loglam = $K_loglam;
    c.a = $K_a;
    c.b = $K_b;
    c.log_invalpha = $K_log_invalpha;
    c.vr = $K_vr;
    return c;
}

// the sRGB decoding (IEC 61966-2-1): the model's values are those an image stores
color srgb_to_linear(color c)
{
    color l;
    for (int i = 0; i < 3; i++)
        l[i] = c[i] <= 0.04045 ? c[i] / 12.92 : pow((c[i] + 0.055) / 1.055, 2.4);
    return l;
}

int clampi(int i, int lo, int hi)
{
    return min(max(i, lo), hi);
}

int wrapi(int i, int n)
{
    if (n <= 0)
        return i;
    int r = i % n;
    if (r < 0)
        r += n;
    return r;
}

// the padded coefficient (row i, column j): $ROWS x $COLS texels, $CHANNELS channel(s), zero margin of $PAD
color coeff(float T[], int i, int j)
{
    int k = (i * $COLS + j) * $CHANNELS;
    return $TEXEL;
}

float bspline_weight(float t, int order)
{
    float a = fabs(t);
    if (order == 0)
        return (t >= -0.5 && t < 0.5) ? 1.0 : 0.0;
    if (order == 1)
        return max(1.0 - a, 0.0);
    if (order == 3) {
        if (a < 1.0)
            return (4.0 - 6.0 * a * a + 3.0 * a * a * a) / 6.0;
        if (a < 2.0) {
            float b = 2.0 - a;
            return b * b * b / 6.0;
        }
        return 0.0;
    }
    float s = 0.0;
    float c[4] = {1.0, -6.0, 15.0, -20.0};
    for (int j = 0; j < 4; j++) {
        float u = 3.0 - a - float(j);
        if (u > 0.0)
            s = s + c[j] * u * u * u * u * u;
    }
    return s / 120.0;
}

// h(y), y in texton coordinates (column, row), for y inside the support
color texton_value(float T[], float y0, float y1, int order)
{
    if (order == 1) {
        float fx = floor(y0);
        float fy = floor(y1);
        float tx = y0 - fx;
        float ty = y1 - fy;
        int j = clampi(int(fx) + $PAD, 0, $COLS - 2);
        int i = clampi(int(fy) + $PAD, 0, $ROWS - 2);
        color top = coeff(T, i, j) * (1.0 - tx) + coeff(T, i, j + 1) * tx;
        color bottom = coeff(T, i + 1, j) * (1.0 - tx) + coeff(T, i + 1, j + 1) * tx;
        return top * (1.0 - ty) + bottom * ty;
    }
    if (order == 0)
        return coeff(T, clampi(int(floor(y1 + 0.5)) + $PAD, 0, $ROWS - 1),
                     clampi(int(floor(y0 + 0.5)) + $PAD, 0, $COLS - 1));
    int half = (order + 1) / 2;
    int j0 = int(floor(y0)) - half + 1;
    int i0 = int(floor(y1)) - half + 1;
    color acc = 0;
    for (int a = 0; a < order + 1; a++) {
        int i = i0 + a;
        float wy = bspline_weight(y1 - float(i), order);
        int ii = clampi(i + $PAD, 0, $ROWS - 1);
        color row = 0;
        for (int b = 0; b < order + 1; b++) {
            int j = j0 + b;
            float wx = bspline_weight(y0 - float(j), order);
            row = row + coeff(T, ii, clampi(j + $PAD, 0, $COLS - 1)) * wx;
        }
        acc = acc + row * wy;
    }
    return acc;
}
"""

#: Surface noise at the shading point (kernels/surface.py, surface_value).
SURFACE_SHADER = r"""
// u1 from the rule v = P_n(a) + <a, n>^4 P_n(b), u2 = n x u1 (kernels/surface.py, tangent_frame)
void tangent_frame(vector n, vector a, vector b, output vector u1, output vector u2)
{
    float ca = dot(a, n);
    float c4 = ca * ca * ca * ca;
    vector v = (a - n * ca) + (b - n * dot(b, n)) * c4;
    float len = length(v);
    if (len < 1e-06) {
        v = b - n * dot(b, n);
        len = length(v);
        if (len < 1e-06) {
            v = cross(n, a);
            len = length(v);
        }
    }
    u1 = v / len;
    u2 = cross(n, u1);
}

shader texton_surface(
    float texel_size = $TEXEL_SIZE,  // units of `space` per texel
    string space = "object",  // the space P and N are taken in: "object", "world", ...
    int seed = $SEED,
    float mni = $MNI,  // mean number of impacts per point
    int exact_poisson = $EXACT,  // 1: Poisson counts; 0: rounded Gaussian
    output color Color = 0,  // the noise, in the values the example image stores (sRGB-coded)
    output color Linear = 0,  // Color decoded from sRGB: for a renderer's linear colour (emission, base colour)
    output float Value = 0)  // the first channel
{
    float T[$N] = {
$COEFFS
    };
    Counts cnt = exported_counts(exact_poisson);
    color shift = $SHIFT;
    float inv_scale = $INV_SCALE;
    if (mni != $MNI) {
        float lam = mni / ($R * $AREA);
        cnt = counts_for(lam * $C * $C * $C, exact_poisson);
        shift = lam * $R / 2.0 * $INTEGRAL;
        inv_scale = 1.0 / sqrt(lam * $R / 3.0);
    }
    point y = transform(space, P) / texel_size;
    normal n = normalize(transform(space, N));
    vector u1, u2;
    tangent_frame(n, $UP, $SIDE, u1, u2);
    float half_r = $HALF;
    vector ext = vector(half_r * (fabs(u1[0]) + fabs(u2[0]) + fabs(n[0])),
                        half_r * (fabs(u1[1]) + fabs(u2[1]) + fabs(n[1])),
                        half_r * (fabs(u1[2]) + fabs(u2[2]) + fabs(n[2])));
    int x0 = int(floor((y[0] - ext[0]) / $C));
    int x1 = int(floor((y[0] + ext[0]) / $C));
    int y0 = int(floor((y[1] - ext[1]) / $C));
    int y1 = int(floor((y[1] + ext[1]) / $C));
    int z0 = int(floor((y[2] - ext[2]) / $C));
    int z1 = int(floor((y[2] + ext[2]) / $C));
    int h0 = avalanche((seed ^ $SPACE_TAG) + $GOLDEN);
    color acc = 0;
    for (int cz = z0; cz <= z1; cz++) {
        for (int cy = y0; cy <= y1; cy++) {
            for (int cx = x0; cx <= x1; cx++) {
                int s = avalanche(avalanche(avalanche(h0 ^ cx) ^ cy) ^ cz);
                int count = draw_count(s, cnt);
                vector rel = vector(y[0] - float(cx) * $C, y[1] - float(cy) * $C, y[2] - float(cz) * $C);
                for (int k = 0; k < count; k++) {
                    float ux = randf(s);
                    float uy = randf(s);
                    float uz = randf(s);
                    vector d = rel - vector(ux, uy, uz) * $C;
                    float t = dot(d, n);
                    if (fabs(t) < half_r) {
                        float q0 = dot(d, u1) + $CENTRE0;
                        float q1 = dot(d, u2) + $CENTRE1;
                        if (q0 >= $LO0 && q0 <= $HI0 && q1 >= $LO1 && q1 <= $HI1)
                            acc = acc + texton_value(T, q0, q1, $ORDER) * (1.0 - fabs(t) / half_r);
                    }
                }
            }
        }
    }
    color g = $MEAN + (acc - shift) * inv_scale;
    Color = $COLOUR;
    Linear = srgb_to_linear(Color);
    Value = $VALUE;
}
"""

#: Plane noise at a texel-space point (kernels/noise2d.py, evaluate_points).
PLANE_SHADER = r"""
shader texton_plane(
    float texel_size = $TEXEL_SIZE,  // coordinate units per texel
    string coordinates = "object",  // a space ("object", "world"): (x, -y) of P in it; "input": (x, 1 - y) of Vector
    vector Vector = 0,  // coordinates == "input": connect UVs here (a UV Map or Texture Coordinate node)
    int seed = $SEED,
    float mni = $MNI,  // mean number of impacts per point
    int exact_poisson = $EXACT,  // 1: Poisson counts; 0: rounded Gaussian
    output color Color = 0,  // the noise, in the values the example image stores (sRGB-coded)
    output color Linear = 0,  // Color decoded from sRGB: for a renderer's linear colour (emission, base colour)
    output float Value = 0)  // the first channel
{
    float T[$N] = {
$COEFFS
    };
    Counts cnt = exported_counts(exact_poisson);
    float lam = $LAM;
    if (mni != $MNI) {
        lam = mni / $AREA;
        cnt = counts_for(lam * $CW * $CH, exact_poisson);
    }
    float x0, x1;
    if (coordinates == "input") {
        x0 = Vector[0] / texel_size;
        x1 = (1.0 - Vector[1]) / texel_size;
    } else {
        point q = transform(coordinates, P);
        x0 = q[0] / texel_size;
        x1 = -q[1] / texel_size;
    }
    int cx_lo = int(floor((x0 - $HI0) / $CW));
    int cx_hi = int(floor((x0 - $LO0) / $CW));
    int cy_lo = int(floor((x1 - $HI1) / $CH));
    int cy_hi = int(floor((x1 - $LO1) / $CH));
    int h0 = avalanche(seed + $GOLDEN);
    color acc = 0;
    for (int cy = cy_lo; cy <= cy_hi; cy++) {
        for (int cx = cx_lo; cx <= cx_hi; cx++) {
            float r0 = x0 - float(cx) * $CW;
            float r1 = x1 - float(cy) * $CH;
            int s = avalanche(avalanche(h0 ^ wrapi(cx, $PX)) ^ wrapi(cy, $PY));
            int count = draw_count(s, cnt);
            for (int k = 0; k < count; k++) {
                float u0 = randf(s);
                float u1 = randf(s);
                float d0 = r0 - u0 * $CW;
                float d1 = r1 - u1 * $CH;
                if (d0 >= $LO0 && d0 <= $HI0 && d1 >= $LO1 && d1 <= $HI1)
                    acc = acc + texton_value(T, d0, d1, $ORDER);
            }
        }
    }
    color g = $MEAN + (acc - $INTEGRAL * lam) / sqrt(lam);
    Color = $COLOUR;
    Linear = srgb_to_linear(Color);
    Value = $VALUE;
}
"""
