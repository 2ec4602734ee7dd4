"""The viewer page in a real headless Chromium (Debian's ``chromium`` driven by Playwright).

What the canvas shows is read back from it and compared with ``synthesize`` of
the same window: exactly, tile by tile, and within one 8-bit step against one
big window (which a seam would break). Skipped where no Chromium is installed;
CI (.ci/run) installs it.
"""

from __future__ import annotations

import base64
import io
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from warp_texton import analyze, read_image, render_plane, synthesize
from warp_texton.view.server import serve
from warp_texton.view.pictures import to_8bit
from warp_texton.view.queries import Noise, Tile, tile_window, view_window

from test_view import DEVICE, SIZE, run_cli, small_rgb

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="no Chromium on PATH (Debian: apt-get install chromium); "
                                                         "the viewer's browser tests need one")
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed (pip install playwright)")

VIEWPORT = {"width": 300 + 480, "height": 360}  # the side panel is 300 px wide: a 480 x 360 canvas


@pytest.fixture(scope="module")
def rgb_path(tmp_path_factory) -> Path:
    return small_rgb(tmp_path_factory.mktemp("browser") / "rgb64.png")


@pytest.fixture(scope="module")
def server(rgb_path):
    with serve(rgb_path, port=0, size=SIZE, device=DEVICE, filter="anisotropic") as handle:
        yield handle


@pytest.fixture(scope="module")
def browser():
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        yield b
        b.close()


@pytest.fixture
def page(browser, server):
    context = browser.new_context(viewport=VIEWPORT, device_scale_factor=1, accept_downloads=True)
    page = context.new_page()
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(server.url)
    wait_idle(page)
    yield page
    context.close()
    assert not errors


def wait_idle(page, panel: bool = False) -> None:
    page.wait_for_function("window.viewer && window.viewer.pending() === 0", timeout=60_000)
    page.evaluate("window.viewer.idle()")
    if panel:
        page.wait_for_function("!window.viewer.panelPending()", timeout=60_000)


def canvas_pixels(page) -> np.ndarray:
    url = page.evaluate("document.getElementById('canvas').toDataURL('image/png')")
    a = np.asarray(Image.open(io.BytesIO(base64.b64decode(url.split(",", 1)[1]))).convert("RGB"))
    return a


def texton_of(rgb_path, size=SIZE, order=1, cc=True):
    return analyze(read_image(rgb_path), size=size, order=order, seed=0, color_correction=cc)


def expected(page, texton, noise: Noise):
    """(from the tiles, from one window) for the canvas of the current view, 8-bit."""
    v = page.evaluate("window.viewer.view()")
    s, z, t = v["scale"], v["level"], v["tile"]
    assert s == 2.0 ** z, "the test needs a whole zoom level: one canvas pixel per tile pixel"
    j0, i0 = v["left"] * s, v["top"] * s
    assert j0 == int(j0) and i0 == int(i0)
    j0, i0, w, h = int(j0), int(i0), v["width"], v["height"]
    x0, y0 = math.floor(j0 / t), math.floor(i0 / t)
    x1, y1 = math.floor((j0 + w - 1) / t), math.floor((i0 + h - 1) / t)
    rows = []
    for y in range(y0, y1 + 1):
        row = []
        for x in range(x0, x1 + 1):
            win = tile_window(Tile(z, x, y, t), noise)
            row.append(synthesize(texton, win.shape, mni=noise.mni, seed=noise.seed, scale=win.scale, rotation=win.rotation, offset=win.offset,
                                  device=DEVICE, filter=noise.filter))
        rows.append(np.concatenate(row, axis=1))
    tiles = np.concatenate(rows, axis=0)[i0 - y0 * t:i0 - y0 * t + h, j0 - x0 * t:j0 - x0 * t + w]
    win = view_window(w, h, s, noise.rotation, v["left"], v["top"])
    whole = synthesize(texton, win.shape, mni=noise.mni, seed=noise.seed, scale=win.scale, rotation=win.rotation, offset=win.offset,
                       device=DEVICE, filter=noise.filter)
    return to_8bit(tiles), to_8bit(whole)


def assert_shows(page, texton, noise: Noise) -> None:
    got = canvas_pixels(page)
    tiles, whole = expected(page, texton, noise)
    np.testing.assert_array_equal(got, np.broadcast_to(tiles, got.shape))
    # one big window differs only by float rounding (a seam would be far larger)
    diff = np.abs(got.astype(int) - whole.astype(int))
    assert diff.max() <= 1 and (diff > 0).mean() < 1e-2


def set_input(page, selector: str, value, event: str = "input") -> None:
    page.evaluate("([sel, value, event]) => { const e = document.querySelector(sel); e.value = value; "
                  "e.dispatchEvent(new Event(event, { bubbles: true })); }", [selector, str(value), event])


def test_canvas_shows_the_noise(page, rgb_path):
    v = page.evaluate("window.viewer.view()")
    assert (v["width"], v["height"], v["level"]) == (480, 360, 0)
    assert_shows(page, texton_of(rgb_path), Noise(0, 30.0, 0.0, "anisotropic"))
    # the side panel reports the model error of that texton
    wait_idle(page, panel=True)
    shown = page.inner_text("#model-error")
    assert shown == f"{texton_of(rgb_path).metadata['model_error']:.3f}"


def test_drag_keeps_the_tiles_joined(page, rgb_path):
    before = page.evaluate("window.viewer.view()")
    box = page.locator("#canvas").bounding_box()
    page.mouse.move(box["x"] + 300, box["y"] + 200)
    page.mouse.down()
    for k in range(1, 6):
        page.mouse.move(box["x"] + 300 - 31 * k, box["y"] + 200 + 13 * k)
    page.mouse.up()
    wait_idle(page)
    after = page.evaluate("window.viewer.view()")
    assert (after["left"] - before["left"], after["top"] - before["top"]) == (155, -65)
    assert_shows(page, texton_of(rgb_path), Noise(0, 30.0, 0.0, "anisotropic"))


def test_sliders_rerender_with_the_new_setting(page, rgb_path):
    texton = texton_of(rgb_path)
    first = canvas_pixels(page)
    set_input(page, "#mni", 10)
    wait_idle(page)
    assert page.inner_text("#mni-out") == "10"
    assert not np.array_equal(canvas_pixels(page), first)
    assert_shows(page, texton, Noise(0, 10.0, 0.0, "anisotropic"))
    set_input(page, "#rot", 30)
    wait_idle(page)
    assert_shows(page, texton, Noise(0, 10.0, 30.0, "anisotropic"))
    set_input(page, "#seed", 7)
    wait_idle(page)
    assert_shows(page, texton, Noise(7, 10.0, 30.0, "anisotropic"))


def test_zooming_out_uses_the_filter(page, rgb_path):
    page.click("#zoom-out")
    page.click("#zoom-out")
    wait_idle(page)
    assert page.evaluate("window.viewer.view()")["level"] == -2
    texton = texton_of(rgb_path)
    assert_shows(page, texton, Noise(0, 30.0, 0.0, "anisotropic"))
    set_input(page, "#filter", "none", "change")
    wait_idle(page)
    assert_shows(page, texton, Noise(0, 30.0, 0.0, "none"))


def test_analysis_settings_reanalyse(page, rgb_path):
    set_input(page, "#size", 8, "change")
    set_input(page, "#order", 3, "change")
    page.uncheck("#cc")
    wait_idle(page, panel=True)
    texton = texton_of(rgb_path, size=8, order=3, cc=False)
    assert_shows(page, texton, Noise(0, 30.0, 0.0, "anisotropic"))
    assert page.inner_text("#model-error") == f"{texton.metadata['model_error']:.3f}"
    assert page.inner_text("#texton-info").startswith("8×8 texton, order 3")


def test_bad_parameter_is_answered_400(page, server):
    got = page.evaluate("""async (src) => {
        const r = await fetch(`/tile?src=${src}&z=0&x=0&y=0&mni=abc`);
        return [r.status, r.headers.get('content-type'), await r.text()];
    }""", server.viewer.src)
    assert got[0] == 400 and got[1].startswith("text/plain")
    assert got[2] == "mni must be a number in [0.1, 200], got 'abc'\n"


@pytest.mark.parametrize("fmt, size", [("png", None), ("exr", (64, 48))])
def test_export_downloads_the_promised_file(page, rgb_path, tmp_path, fmt, size):
    set_input(page, "#rot", -20)
    wait_idle(page)
    if size is not None:
        set_input(page, "#export-w", size[0], "change")
        set_input(page, "#export-h", size[1], "change")
    set_input(page, "#export-format", fmt, "change")
    with page.expect_download() as info:
        page.click("#export")
    download = info.value
    promised = page.inner_text("#export-file")
    name = promised.split(" ")[0]
    assert download.suggested_filename == name
    w, h = (480, 360) if size is None else size
    assert promised == f"{name} ({w}×{h})" and name.endswith(f".{fmt}")
    path = tmp_path / "download" / name
    path.parent.mkdir()
    download.save_as(path)
    got = read_image(path)
    assert got.shape == (h, w, 3)
    # the command line the page shows makes the same file
    cli = page.inner_text("#export-cli").splitlines()
    run_cli(cli, tmp_path)
    made = read_image(tmp_path / name)
    np.testing.assert_allclose(made, got, atol=1e-6 if fmt == "exr" else 0)
    if size is None:  # the current view at its own size: what the canvas shows
        diff = np.abs(to_8bit(got).astype(int) - canvas_pixels(page).astype(int))
        assert diff.max() <= 1 and (diff > 0).mean() < 1e-2
    else:  # the same centre and width at another size
        v = page.evaluate("window.viewer.view()")
        scale = v["scale"] * w / v["width"]
        cx, cy = v["left"] + v["width"] / 2 / v["scale"], v["top"] + v["height"] / 2 / v["scale"]
        win = view_window(w, h, scale, -20.0, cx - w / 2 / scale, cy - h / 2 / scale)
        want = synthesize(texton_of(rgb_path), win.shape, mni=30.0, seed=0, scale=win.scale, rotation=win.rotation, offset=win.offset,
                          device=DEVICE, filter="anisotropic")
        np.testing.assert_allclose(got, want, atol=1e-5)
    python = page.inner_text("#export-python")
    assert "synthesize(texton" in python and f"write_image({name!r}, image)" in python


def test_ground_plane_mode(page, rgb_path):
    page.check("input[name=mode][value=plane]")
    set_input(page, "#plane-res", 1, "change")
    set_input(page, "#tilt", 60)
    wait_idle(page)
    want = render_plane(texton_of(rgb_path), (360, 480), height=1.0, tilt=60.0, fov=40.0, texel_size=0.002,
                        mni=30.0, seed=0, filter="anisotropic", device=DEVICE)
    np.testing.assert_array_equal(canvas_pixels(page), to_8bit(want))


def test_mixing_mode_with_an_upload(page, tmp_path, rgb_path):
    page.check("input[name=mode][value=mix]")
    # the page writes the message when it has handled the mode change (later under load)
    page.wait_for_function("document.querySelector('#message').innerText.includes('upload')", timeout=30_000)
    assert "upload" in page.inner_text("#message")
    b = tmp_path / "b.png"
    g = read_image(rgb_path)
    Image.fromarray(to_8bit(0.9 - 0.5 * g[::-1, ::-1, ::-1])).save(b)  # another texture, of another colour
    page.set_input_files("#mix-file", str(b))
    page.wait_for_function("window.viewer.state.mix.b !== null")
    wait_idle(page)
    assert page.is_hidden("#message")
    pixels = canvas_pixels(page).astype(float)
    # rho goes from A (left quarter) to B (right quarter) across the view: the colours change
    left, right = pixels[:, :100].mean(axis=(0, 1)), pixels[:, -100:].mean(axis=(0, 1))
    assert np.abs(left - right).max() > 5


def test_size_menu_of_a_small_input(browser, tmp_path):
    """A 64 × 64 input at the default size 64: the menu offers the sizes up to half the
    input and the size in use, which it shows (it was empty, issue 33)."""
    path = small_rgb(tmp_path / "rgb64.png")
    with serve(path, port=0, size=64, device=DEVICE) as handle:
        context = browser.new_context(viewport=VIEWPORT, device_scale_factor=1)
        page = context.new_page()
        page.goto(handle.url)
        wait_idle(page)
        options = page.eval_on_selector_all("#size option", "os => os.map(o => Number(o.value))")
        value = page.eval_on_selector("#size", "s => s.value")
        context.close()
    assert options == [8, 16, 24, 32, 64] and value == "64"
