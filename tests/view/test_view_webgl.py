"""The viewer's WebGL2 mode in headless Chromium (WebGL2 on SwiftShader, no GPU).

The page draws the noise mode itself with the exported GLSL library; the tests
check that it shows the pixels the server's tiles show for the same view (pan,
zoom out with a filter, rotation), that the view and the noise sliders redraw
without a request, that an analysis setting fetches its texton once, that the
noise constants the page computes from the MNI are the exporter's, and that
the tiles take over where WebGL cannot draw.

Tolerance. The tiles are PNGs of ``synthesize``'s float32 values rounded to 8
bits; the shader computes the same sum of the same impacts in float32 on
another machine (other operation order, its own ``log2``/``sqrt``), so values
agree to about 1e-6, and a value that close to a rounding boundary between two
8-bit levels may land on the other side: ±1 level is rounding, more than that
would be another set of impacts (an impact on the edge of a texton's support,
decided by float32 rounding; the GLSL export's tests count those too). The
pixels beyond ±1 are counted and printed; at most 0.1 % are allowed, as for the
export. The float read-back is held to 1e-3 of the view's range (the export's
bound) on all but 0.1 % of the pixels.
"""

from __future__ import annotations

import base64
import io
import re
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from clients import chromium_browser
from test_view import DEVICE, SIZE, small_rgb
from warp_texton import analyze, read_image, synthesize
from warp_texton.runtimes.glsl.texton import glsl_noise
from warp_texton.view.server import serve
from warp_texton.view.pictures import to_8bit
from warp_texton.view.queries import view_window
from warp_texton.view.webgl import VIEW_UNIFORMS

pytestmark = pytest.mark.slow  # about a minute: a page load and SwiftShader frames per test

CANVAS = (160, 120)  # SwiftShader draws the per-pixel shader at a few microseconds a pixel: a small view
VIEWPORT = {"width": 300 + CANVAS[0], "height": CANVAS[1]}  # the side panel is 300 px wide
BEYOND_ONE = 1e-3  # the share of pixels allowed beyond ±1 level (or 1e-3 of the range, as floats)


@pytest.fixture(scope="module")
def rgb_path(tmp_path_factory) -> Path:
    return small_rgb(tmp_path_factory.mktemp("webgl") / "rgb64.png")


@pytest.fixture(scope="module")
def browser():
    with chromium_browser() as b:
        yield b


@pytest.fixture(scope="module")
def server(rgb_path, browser):  # the browser first: without one, nothing is served
    with serve(rgb_path, port=0, size=SIZE, device=DEVICE) as handle:
        yield handle


class Page:
    """A page of the viewer and the requests it made."""

    def __init__(self, browser, url: str, init_script: str | None = None):
        self.context = browser.new_context(viewport=VIEWPORT, device_scale_factor=1)
        if init_script:
            self.context.add_init_script(init_script)
        self.page = self.context.new_page()
        self.requests: list[str] = []
        self.errors: list[str] = []
        self.page.on("request", lambda r: self.requests.append(r.url))
        self.page.on("pageerror", lambda e: self.errors.append(str(e)))
        self.page.goto(url)
        self.idle()

    def idle(self) -> None:
        self.page.wait_for_function("window.viewer && window.viewer.pending() === 0", timeout=120_000)
        self.page.evaluate("window.viewer.idle()")

    def eval(self, js: str, arg=None):
        return self.page.evaluate(js, arg)

    def render(self) -> dict:
        return self.eval("window.viewer.render()")

    def pixels(self) -> np.ndarray:
        """What the page shows: the WebGL canvas when it draws, else the tiles' canvas."""
        which = "canvas-gl" if self.render()["drawing"] == "webgl" else "canvas"
        url = self.eval(f"document.getElementById('{which}').toDataURL('image/png')")
        return np.asarray(Image.open(io.BytesIO(base64.b64decode(url.split(",", 1)[1]))).convert("RGB"))

    def floats(self) -> np.ndarray:
        w, h = CANVAS
        return np.array(self.eval("window.viewer.readFloat()"), np.float32).reshape(h, w, 4)[..., :3]

    def set_input(self, selector: str, value, event: str = "input") -> None:
        self.eval("([sel, value, event]) => { const e = document.querySelector(sel); e.value = value; "
                  "e.dispatchEvent(new Event(event, { bubbles: true })); }", [selector, str(value), event])
        self.idle()

    def mode(self, render: str) -> np.ndarray:
        self.eval(f"window.viewer.setRender('{render}')")
        self.idle()
        assert self.render()["drawing"] == render
        return self.pixels()

    def close(self) -> None:
        self.context.close()
        assert not self.errors


@pytest.fixture
def gl_page(browser, server):
    p = Page(browser, server.url + "?render=webgl")
    yield p
    p.close()


def texton_of(rgb_path, size=SIZE, order=1, cc=True):
    return analyze(read_image(rgb_path), size=size, order=order, seed=0, color_correction=cc)


def view_values(p: Page, texton, *, mni, seed, filter) -> np.ndarray:
    """``synthesize`` of the page's view (the raster its tiles are windows of), float32."""
    v = p.eval("window.viewer.view()")
    win = view_window(v["width"], v["height"], v["scale"], v["rot"], v["left"], v["top"])
    return synthesize(texton, win.shape, mni=mni, seed=seed, scale=win.scale, rotation=win.rotation,
                      offset=win.offset, device=DEVICE, filter=filter)


def beyond_one(a: np.ndarray, b: np.ndarray, what: str) -> int:
    """Pixels of two 8-bit pictures more than one level apart (printed and bounded)."""
    d = np.abs(a.astype(int) - b.astype(int)).max(axis=-1)
    n = int((d > 1).sum())
    print(f"{what}: {int((d == 1).sum())} pixels 1 level apart, {n} beyond, of {d.size}")
    assert n <= BEYOND_ONE * d.size
    return n


def test_webgl_shows_the_tiles_pixels(gl_page, rgb_path):
    p = gl_page
    r = p.render()
    assert r["drawing"] == "webgl" and "SwiftShader" in r["renderer"] and r["floatTargets"]
    # a view off the origin, zoomed out (the anisotropic filter at work), turned and re-seeded
    p.eval("window.viewer.setView({ left: 1234.5, top: -321.25 })")
    p.page.click("#zoom-out")
    p.idle()
    p.set_input("#rot", 35)
    p.set_input("#mni", 20)
    p.set_input("#seed", 3)
    v = p.eval("window.viewer.view()")
    assert (v["level"], v["rot"], v["scale"]) == (-1, 35, 0.5)
    gl = p.pixels()
    values = p.floats()
    tiles = p.mode("tiles")
    assert not p.eval("document.getElementById('canvas-gl').checkVisibility()")
    beyond_one(gl, tiles, "WebGL against the tiles")
    # the canvas holds the float values rounded as the tiles' PNGs round them
    np.testing.assert_array_equal(gl, to_8bit(values))
    want = view_values(p, texton_of(rgb_path), mni=20.0, seed=3, filter="anisotropic")
    err = np.abs(values - want).max(axis=-1) / np.ptp(want)
    print(f"float read-back: max error {err.max():.2e} of the range, {int((err > 1e-3).sum())} pixels beyond 1e-3")
    assert (err > 1e-3).mean() <= BEYOND_ONE and np.median(err) < 1e-5
    # between whole levels the tiles are scaled bitmaps; WebGL draws the noise at the view's own scale,
    # which is what an export of the view computes
    p.mode("webgl")
    p.eval("window.viewer.setView({ zoom: -0.5 })")
    p.idle()
    assert p.eval("window.viewer.view().scale") == 2 ** -0.5
    want = view_values(p, texton_of(rgb_path), mni=20.0, seed=3, filter="anisotropic")
    beyond_one(p.pixels(), to_8bit(want), "WebGL at 0.71 px/texel against synthesize")


def test_view_and_sliders_redraw_without_a_request(gl_page, rgb_path):
    p = gl_page
    shaders = [u for u in p.requests if "/api/shader?" in u]
    assert len(shaders) == 1 and not [u for u in p.requests if "/tile?" in u]
    first = p.pixels()
    p.requests.clear()
    seen = [first]
    box = p.page.locator("#canvas").bounding_box()
    p.page.mouse.move(box["x"] + 100, box["y"] + 60)
    p.page.mouse.down()
    p.page.mouse.move(box["x"] + 60, box["y"] + 80)
    p.page.mouse.up()
    p.idle()
    seen.append(p.pixels())
    for selector, value, event in (("#mni", 12, "input"), ("#seed", 5, "input"), ("#rot", -40, "input")):
        p.set_input(selector, value, event)
        seen.append(p.pixels())
    p.page.click("#zoom-out")
    p.idle()
    seen.append(p.pixels())
    p.set_input("#filter", "mip", "change")  # at 1 px/texel both filters read level 0: after zooming out
    seen.append(p.pixels())
    # every change redrew the canvas, and no tile (nor texton) was asked for
    assert [k for k in range(1, len(seen)) if np.array_equal(seen[k - 1], seen[k])] == []
    asked = [u for u in p.requests if re.search(r"/(tile|plane|api/shader)\?", u)]
    assert asked == [], asked
    assert p.render()["drawing"] == "webgl"
    want = view_values(p, texton_of(rgb_path), mni=12.0, seed=5, filter="mip")
    beyond_one(seen[-1], to_8bit(want), "WebGL after the sliders against synthesize")


def test_analysis_setting_fetches_the_texton_once(gl_page, rgb_path):
    p = gl_page
    p.requests.clear()
    p.set_input("#size", 8, "change")
    p.set_input("#order", 3, "change")
    shaders = [u for u in p.requests if "/api/shader?" in u]
    assert len(shaders) == 2 and "size=8&order=1" in shaders[0] and "size=8&order=3" in shaders[1]
    assert not [u for u in p.requests if "/tile?" in u]
    want = view_values(p, texton_of(rgb_path, size=8, order=3), mni=30.0, seed=0, filter="anisotropic")
    beyond_one(p.pixels(), to_8bit(want), "WebGL, order 3, against synthesize")
    # back to an analysis drawn before: fetched again (the page keeps one texton), once
    p.requests.clear()
    p.set_input("#size", SIZE, "change")
    p.set_input("#order", 1, "change")
    assert len([u for u in p.requests if "/api/shader?" in u]) == 2


def _constants(source: str) -> dict:
    out = {}
    for name, kind in VIEW_UNIFORMS.items():
        m = re.search(rf"^const {kind} {name} = (.*);$", source, flags=re.M)
        assert m, name
        raw = m.group(1)
        if kind == "uint":
            out[name] = int(raw.rstrip("u"))
        elif kind == "int":
            out[name] = int(raw)
        else:
            out[name] = [float(np.float32(x)) for x in re.sub(r"^vec\d\(|\)$", "", raw).split(", ")]
    return out


@pytest.mark.parametrize("size, order", [(SIZE, 1), (8, 3)])
def test_page_computes_the_exporters_constants(gl_page, rgb_path, size, order):
    """The uniforms the page derives from the MNI, seed and filter are the exported library's
    constants, bit for bit, over the MNI slider's range and beyond."""
    p = gl_page
    if (size, order) != (SIZE, 1):
        p.set_input("#size", size, "change")
        p.set_input("#order", order, "change")
    texton = texton_of(rgb_path, size=size, order=order)
    for mni in (0.1, 1.0, 2.5, 7.0, 12.0, 30.0, 64.5, 100.0, 200.0):
        for seed, filter in ((0, "anisotropic"), (4294967295, "mip"), (77, "none")):
            want = _constants(glsl_noise(texton, mni=mni, seed=seed, filter=filter).source)
            got = p.eval("([m, s, f]) => window.viewer.noiseUniforms(m, s, f)", [mni, seed, filter])
            for name, value in want.items():
                g = got[name]
                g = g if isinstance(value, int) else [float(np.float32(x)) for x in np.atleast_1d(g)]
                if name == "TN_PTRS2":  # its second value is unused (0)
                    g, value = g[:1], value[:1]
                assert g == value, (mni, seed, filter, name)


def test_tiles_draw_what_webgl_does_not(gl_page, browser, server):
    p = gl_page
    # the ground plane and mixing are tiles (plane views), in a page that draws the noise with WebGL
    p.page.check("input[name=mode][value=plane]")
    p.idle()
    assert p.render()["drawing"] == "tiles" and any("/plane?" in u for u in p.requests)
    p.page.check("input[name=mode][value=noise]")
    p.idle()
    assert p.render()["drawing"] == "webgl"
    # the toggle
    assert p.page.locator("#render").input_value() == "webgl"
    p.page.select_option("#render", "tiles")
    p.idle()
    assert p.render()["drawing"] == "tiles"
    # auto, the default, on a software rasterizer (SwiftShader): tiles, which are faster there
    auto = Page(browser, server.url)
    try:
        r = auto.render()
        assert (r["requested"], r["render"], r["drawing"]) == ("auto", "tiles", "tiles")
        assert "software" in auto.page.inner_text("#render-note")
    finally:
        auto.close()
    # no WebGL2 in the browser: tiles, and the toggle cannot choose WebGL
    nogl = Page(browser, server.url + "?render=webgl", init_script="""
        const getContext = HTMLCanvasElement.prototype.getContext;
        HTMLCanvasElement.prototype.getContext = function (kind, ...rest) {
            return kind === "webgl2" ? null : getContext.call(this, kind, ...rest);
        };""")
    try:
        assert nogl.render()["drawing"] == "tiles"
        assert nogl.page.locator("#render option[value=webgl]").is_disabled()
        assert "not available" in nogl.page.inner_text("#render-note")
        assert any("/tile?" in u for u in nogl.requests)
    finally:
        nogl.close()


@pytest.mark.parametrize("query, status, text", [
    ("size=3", 400, "size must be an integer in [4, 128], got 3"),
    ("order=2", 400, "order must be one of 0, 1, 3, 5, got '2'"),
    ("seed=1", 400, "unknown parameter 'seed'"),
])
def test_shader_endpoint_refuses_bad_requests(gl_page, server, query, status, text):
    got = gl_page.eval("""async (q) => {
        const r = await fetch(`/api/shader?${q}`);
        return [r.status, r.headers.get('content-type'), await r.text()];
    }""", f"src={server.viewer.src}&{query}")
    assert got[0] == status and got[1].startswith("text/plain") and got[2] == text + "\n"


def test_shader_endpoint_names_its_input(gl_page):
    got = gl_page.eval("fetch('/api/shader?src=0000&size=16').then((r) => r.status)")
    assert got == 409
    got = gl_page.eval("fetch('/?render=gpu').then(async (r) => [r.status, await r.text()])")
    assert got == [400, "render must be one of auto, webgl, tiles, got 'gpu'\n"]


def test_lost_context_hands_over_to_the_tiles(gl_page):
    p = gl_page
    p.eval("document.getElementById('canvas-gl').getContext('webgl2').getExtension('WEBGL_lose_context')"
           ".loseContext()")
    p.page.wait_for_function("window.viewer.render().drawing === 'tiles'")
    p.idle()
    assert "lost" in p.page.inner_text("#render-note") and p.page.locator("#render").input_value() == "tiles"
    assert any("/tile?" in u for u in p.requests)
    assert not p.eval("document.getElementById('canvas-gl').checkVisibility()")


def test_webgl_shows_the_colours_of_a_histogram_transform(browser, rgb_path, tmp_path):
    """The exported GLSL maps the noise through a texton's histogram transform: WebGL shows
    the tiles' pixels (the example's colours), near and zoomed out (the prefiltered tables), and
    at another MNI with that MNI's tables."""
    texton = analyze(read_image(rgb_path), size=SIZE, seed=0, histogram="preserve")
    path = tmp_path / "preserve.exr"
    texton.save(path)
    with serve(path, port=0, size=SIZE, device=DEVICE) as handle:
        p = Page(browser, handle.url + "?render=webgl")
        try:
            for zoom, mni in ((0, None), (-3, None), (0, 12)):
                if mni is not None:  # another MNI: the tables of that MNI (a new program), as the tiles'
                    p.set_input("#mni", mni)
                p.eval(f"window.viewer.setView({{ zoom: {zoom}, left: -40.5, top: 17.25 }})")
                p.idle()
                assert p.render()["drawing"] == "webgl"
                gl, values = p.pixels(), p.floats()
                s = p.eval("window.viewer.state")
                want = view_values(p, texton, mni=float(s["mni"]), seed=s["seed"], filter=s["filter"])
                err = np.abs(values - want).max(axis=-1) / np.ptp(texton.histogram.lut)
                print(f"zoom {zoom}: max error {err.max():.2e} of the tables' range")
                assert (err > 1e-3).mean() <= BEYOND_ONE
                beyond_one(gl, p.mode("tiles"), f"WebGL against the tiles at zoom {zoom}, histogram-preserving")
                p.mode("webgl")
        finally:
            p.close()
