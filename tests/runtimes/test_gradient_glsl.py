"""The GLSL exports' gradients in a real headless Chromium (WebGL2 on SwiftShader): the
derivatives per pixel that the libraries' ``texton_noise_grad_at`` and ``tiling_noise_grad_at``
give (drawn by ``glsl.gradient_window``'s ``main()``) against ``gradient(model, shape=...)`` of
the same window, texton noise and tiling models with the options the value exports take.

The bounds are the value exports' (tests/runtimes/test_shader_glsl.py, test_tiling_glsl.py):
texton noise within 10⁻³ of the window's range, a tiling model within 2/255 of it on 99 % of the
pixels, here of the gradient's range. The texton's integer stream is exact, so an impact set can
differ only on the edge of a support, decided by float32 rounding, and an order-1 texton's
one-sided slope only where float32 rounding puts a point on the other side of a kink: both are
rare (at most 0.1 % of the pixels are allowed another value, as the value test allows another
impact set). The value the gradient functions return beside it is the value functions' own.
"""

from __future__ import annotations

import numpy as np
import pytest

from clients import chromium_browser
from test_tiling_glsl import BOND, COURSES, brick
from helpers import running_bond
from warp_texton import NoiseOptions, Texton, TextonError, analyze, gradient, read_image, synthesize
from warp_texton.demo import demo_texture_path
from warp_texton.model.lattice import Lattice
from warp_texton.model.tiling import TilingModel
from warp_texton.runtimes import glsl
from warp_texton.runtimes.glsl import texton as glsl_texton
from warp_texton.runtimes.glsl import tiling as glsl_tiling
from warp_texton.runtimes.shared import template

pytestmark = pytest.mark.slow
#: The texton export's bound (of the range), and the share of pixels allowed past it.
TOLERANCE = 1e-3
MAX_DIFFERING = 0.001
#: The tiling export's bound (2/255 of the range on 99 % of the pixels).
TILING_TOLERANCE = 2.0 / 255.0
TILING_AGREEMENT = 0.99

#: Draws a gradient window's data (glsl.gradient_window) with TextonNoise for tn_output 0, 1, 2, and
#: with its value main() where given: four float32 RGBA images, top row first.
DRAW = """
(d) => {
  const gl = document.createElement("canvas").getContext("webgl2");
  const specs = {};
  for (const [name, t] of Object.entries(d.textures)) {
    specs[name] = {width: t.width, height: t.height, data: TextonNoise.floats(t.data)};
  }
  const bind = TextonNoise.textures(gl, specs);
  const read = (main, output) => {
    const prog = TextonNoise.program(gl, d.library, main);
    return Array.from(TextonNoise.readFloat(gl, prog, d.width, d.height, () => {
      bind(prog);
      for (const [name, [kind, values]] of Object.entries(d.uniforms)) {
        gl["uniform" + kind](gl.getUniformLocation(prog, name), ...values);
      }
      gl.uniform1i(gl.getUniformLocation(prog, "tn_output"), output);
    }));
  };
  return [read(d.main, 0), read(d.main, 1), read(d.main, 2), read(d.value_main, 0)];
}
"""


@pytest.fixture(scope="module")
def page():
    with chromium_browser() as b:
        p = b.new_page()
        errors: list[str] = []
        p.on("pageerror", lambda e: errors.append(str(e)))
        p.set_content(f"<script>{template('texton_noise.js')}</script>")
        assert not errors, errors
        yield p


def draw(page, data: dict, value_main: str) -> list[np.ndarray]:
    """(∂/∂column, ∂/∂row, the value beside them, the value function's value), each (H, W, 4)."""
    out = page.evaluate(DRAW, {**data, "value_main": value_main})
    return [np.array(a, np.float32).reshape(data["height"], data["width"], 4) for a in out]


def compare(got: list[np.ndarray], want: np.ndarray, channels: int) -> np.ndarray:
    """Per pixel, the largest error of the two derivatives over the channels, of the gradient's range."""
    span = float(want.max() - want.min())
    err = np.stack([np.abs(got[k][..., :channels] - want[..., k]).max(axis=-1) for k in (0, 1)])
    return err.max(axis=0) / span


# ------------------------------------------------------------------- texton noise
@pytest.fixture(scope="module")
def textons():
    example = read_image(demo_texture_path())
    out = {order: analyze(example, size=16, order=order, seed=0) for order in (1, 3, 5)}
    out["hist"] = analyze(example, size=16, order=3, seed=0, histogram="preserve")
    return out


SHAPE = (48, 64)
CASES = {
    "order1": dict(texton=1, seed=1),
    "order3": dict(texton=3, seed=1),
    "order5": dict(texton=5, seed=4, scale=0.8),
    "period": dict(texton=3, seed=2, period=(20.0, 12.0), offset=(-7.25, 3.5)),
    "rotation_scale": dict(texton=1, seed=1, scale=0.6, rotation=33.0),
    "far_offset": dict(texton=3, seed=1, offset=(1.0e6, -1.0e6), rotation=-50.0, scale=1.7),
    "gaussian_counts": dict(texton=3, seed=5, poisson="gaussian", mni=12.0),
    "histogram": dict(texton="hist", seed=6, scale=0.7, rotation=20.0),
}


@pytest.mark.parametrize("case", CASES)
def test_texton_gradient_equals_gradient(case, textons, page, record_property):
    kw = dict(CASES[case])
    texton = textons[kw.pop("texton")]
    place = {k: kw.pop(k) for k in ("scale", "rotation", "offset") if k in kw}
    kw.setdefault("mni", 30.0)
    data = glsl.gradient_window(texton, SHAPE, noise=NoiseOptions(**kw), **place)
    got = draw(page, data, glsl_texton.PREVIEW_MAIN)
    want = gradient(texton, shape=SHAPE, device="cpu", **place, **kw)
    c = texton.channels
    err = compare(got, want, c)
    value = synthesize(texton, SHAPE, device="cpu", **place, **kw)
    value_err = np.abs(got[2][..., :c] - value).max() / float(value.max() - value.min())
    record_property("max_error_of_range", float(err.max()))
    print(f"{case}: gradient max error {err.max():.2e} of its range, median {np.median(err):.1e}, "
          f"{int((err > TOLERANCE).sum())} of {err.size} pixels beyond {TOLERANCE:g}; value {value_err:.1e}")
    assert float(np.abs(want).max()) > 0.0
    assert np.mean(err > TOLERANCE) <= MAX_DIFFERING
    assert value_err <= TOLERANCE
    # the value beside the gradient is the value function's, bit for bit
    assert np.array_equal(got[2][..., :c], got[3][..., :c])
    if texton.histogram is not None:  # the tables' slopes are applied: the Gaussian gradient differs
        raw = gradient(without_tables(texton), shape=SHAPE, device="cpu", **place, **kw)
        assert np.abs(raw - want).max() > 0.1 * float(np.abs(want).max())


def without_tables(texton: Texton) -> Texton:
    """The same texton without its histogram transform: the Gaussian noise."""
    return Texton(texton.coeffs, texton.mean, texton.order)


# ------------------------------------------------------------------- tiling models
@pytest.fixture(scope="module")
def models():
    rgb, grey = running_bond(channels=3), running_bond(channels=1)
    both = (True, True)
    hist = analyze(brick(3), method="tiling", histogram="preserve")
    return {
        "grey": TilingModel(brick(1), 32.0, 16, 0.0, {}, "variance"),
        # a fractional side, linear blend, sharpness 4 and the luminance guide (exp in the weights)
        "guide": TilingModel(brick(3), 37.3, 4, 2.0, {}, "linear"),
        "hist_rgb": TilingModel(hist.example, 41.3, 8, 1.0, {}, hist.blend, hist.histogram),
        "wrapped_x": TilingModel(rgb, 37.3, 4, 2.0, {}, "linear", None, (True, False)),
        "lattice": TilingModel(rgb, 40.0, 16, 0.0, {}, "variance", None, both,
                               Lattice.from_vectors(BOND, rgb.shape, both)),
        "lattice_clamped": TilingModel(rgb, 21.5, 8, 1.0, {}, "variance", None, (False, False),
                                       Lattice.from_vectors(BOND, rgb.shape)),
        "courses_grey": TilingModel(grey, 45.0, 16, 0.0, {}, "variance", None, both,
                                    Lattice.from_vectors(COURSES, grey.shape, both)),
    }


TILING_SHAPE = (96, 128)
TILING_CASES = {
    "grey_scale1": dict(model="grey", seed=1),
    "guide_placed": dict(model="guide", seed=2**32 - 1, scale=0.9, rotation=70.0, offset=(-5000.0, 20.0)),
    "hist_rgb_placed": dict(model="hist_rgb", seed=7, scale=0.8, rotation=15.0, offset=(2.0e5, -640.5)),
    "wrapped_x_placed": dict(model="wrapped_x", seed=9, scale=0.6, rotation=33.0, offset=(-4.0e4, 917.25)),
    "lattice_far": dict(model="lattice", seed=11, scale=0.7, rotation=-20.0, offset=(1.0e6, -3.0e7)),
    "lattice_clamped_placed": dict(model="lattice_clamped", seed=12, scale=1.3, rotation=50.0, offset=(-2.5e5, 61.5)),
    "courses_grey_placed": dict(model="courses_grey", seed=13, scale=0.5, rotation=5.0, offset=(333.0, -7.0e6)),
}


@pytest.mark.parametrize("case", TILING_CASES)
def test_tiling_gradient_equals_gradient(case, models, page, record_property):
    kw = dict(TILING_CASES[case])
    model = models[kw.pop("model")]
    seed = kw.pop("seed")
    data = glsl_tiling.gradient_window(model, TILING_SHAPE, seed=seed, **kw)
    got = draw(page, data, glsl_tiling.PREVIEW_MAIN)
    want = gradient(model, shape=TILING_SHAPE, seed=seed, device="cpu", **kw)
    c = model.channels
    err = compare(got, want, c)
    fraction = float(np.mean(err <= TILING_TOLERANCE))
    record_property("fraction_within_2_255", fraction)
    print(f"{case}: {fraction:.5f} of the pixels within 2/255 of the gradient's range, max {err.max():.2e}, "
          f"median {np.median(err):.1e}, {int((err > TOLERANCE).sum())} of {err.size} beyond {TOLERANCE:g}")
    assert float(np.abs(want).max()) > 0.0
    assert fraction >= TILING_AGREEMENT
    assert np.array_equal(got[2][..., :c], got[3][..., :c])


def test_gradient_window_refuses(textons, models):
    with pytest.raises(TextonError, match="at most 2048 pixels"):
        glsl.gradient_window(textons[3], (16, 4096))
    with pytest.raises(TextonError, match="defined within"):
        glsl.gradient_window(textons[3], (16, 16), offset=(1e13, 0))
    with pytest.raises(TextonError, match="mni do not apply"):
        glsl.gradient_window(models["grey"], (16, 16), noise=NoiseOptions(mni=10.0))
    with pytest.raises(TextonError, match="defined within"):
        glsl.gradient_window(models["grey"], (16, 16), offset=(3e9, 0))
