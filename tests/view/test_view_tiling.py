"""The viewer with a tiling model file (``analyze(..., method="tiling")``): tiles are the
``synthesize`` windows of the model (seed, offset, scale, rotation), exports are what their
commands make, the panel describes the model; what the package does not compute for a tiling
model is answered with one line; and the page in Chromium shows the server's tiles."""

from __future__ import annotations

import json
import os
import re
import shutil

import numpy as np
import pytest

from warp_texton import analyze, load_texton, read_image, synthesize
from warp_texton.view.pictures import to_8bit
from warp_texton.view.queries import Noise, Tile, tile_window, view_window
from warp_texton.view.server import serve
from warp_texton.model.lattice import Lattice
from warp_texton.model.tiling import TilingModel
from warp_texton.view.viewer import Viewer

from helpers import running_bond
from test_view import DEVICE, Client, decode_png, run_cli, small_rgb


@pytest.fixture(scope="module")
def model_path(tmp_path_factory):
    d = tmp_path_factory.mktemp("view_tiling")
    u = read_image(small_rgb(d / "rgb64.png"))
    path = d / "model.exr"
    analyze(u, method="tiling", side=12, histogram="preserve").save(path)
    return path


@pytest.fixture(scope="module")
def model(model_path):
    return load_texton(model_path)


@pytest.fixture(scope="module")
def server(model_path):
    with serve(model_path, port=0, device=DEVICE, filter="none") as handle:
        yield handle


@pytest.fixture(scope="module")
def client(server):
    return Client(server)


@pytest.mark.parametrize("z, rotation", [(0, 0.0), (1, 30.0), (-1, -75.0)])
def test_tiles_are_windows_of_one_raster(model, model_path, z, rotation):
    v = Viewer(model_path, device=DEVICE, noise=Noise(filter="none"))
    try:
        noise = Noise(seed=3, rotation=rotation, filter="none")
        t, x0, y0 = 32, 321, -78
        tiles = {(dx, dy): v.tile(Tile(z, x0 + dx, y0 + dy, t), v.defaults[0], noise) for dx in (0, 1) for dy in (0, 1)}
        joined = np.concatenate([np.concatenate([tiles[0, 0], tiles[1, 0]], axis=1),
                                 np.concatenate([tiles[0, 1], tiles[1, 1]], axis=1)], axis=0)
        s = 2.0 ** z
        whole = view_window(2 * t, 2 * t, s, rotation, x0 * t / s, y0 * t / s)
        big = synthesize(model, whole.shape, seed=3, scale=whole.scale, rotation=whole.rotation,
                         offset=whole.offset, device=DEVICE)
        assert np.abs(joined - big).max() < 2e-5
        # the seed changes the picture
        other = v.tile(Tile(z, x0, y0, t), v.defaults[0], Noise(seed=4, rotation=rotation, filter="none"))
        assert not np.array_equal(other, tiles[0, 0])
    finally:
        v.close()


def test_info_and_http_tile(client, model):
    status, _, body = client.request("/api/info")
    info = json.loads(body)
    assert status == 200 and info["kind"] == "tiling" and info["supports"]["mix"] is False
    assert "none" in info["bounds"]["filters"] and info["defaults"]["filter"] in info["bounds"]["filters"]
    status, headers, body = client.get("/tile", z=1, x=-3, y=2, seed=5, rot=20, filter="none")
    assert status == 200 and headers["Content-Type"] == "image/png"
    w = tile_window(Tile(1, -3, 2, 256), Noise(5, 30.0, 20.0, "none"))
    want = synthesize(model, w.shape, seed=5, scale=w.scale, rotation=w.rotation, offset=w.offset, device=DEVICE)
    np.testing.assert_array_equal(decode_png(body), to_8bit(want))


def test_panel_describes_the_model(client, model):
    status, _, body = client.get("/api/panel", seed=1)
    p = json.loads(body)
    assert status == 200 and p["kind"] == "tiling"
    assert "tiling model of a 64×64 example" in p["summary"] and "histogram preserved" in p["summary"]
    assert p["texton"].startswith("data:image/png") and p["spectrum_noise"].startswith("data:image/png")
    # the mean of the example in its own colours (not of the Gaussianised values the model blends)
    np.testing.assert_allclose(p["mean"], model.colours().mean(axis=(0, 1)), atol=1e-4)


def test_shader_is_the_models_glsl_port(client, model):
    """/api/shader answers a tiling model's GLSL port: the export's library with the seed a uniform,
    the example and the histogram tables as textures, and its one filter, none."""
    status, _, body = client.get("/api/shader", size=8, order=3)  # analysis settings change nothing
    assert status == 200
    p = json.loads(body)
    assert p["kind"] == "tiling" and list(p["filters"]) == ["none"] and p["channels"] == 3
    assert "uniform uint TL_SEED;" in p["library"] and "const uint TL_SEED" not in p["library"]
    assert "const bool TL_HISTOGRAM = true;" in p["library"] and "tiling_noise_at" in p["main"]
    assert sorted(p["textures"]) == ["tiling_colours", "tiling_example"]
    assert p["side"] == float(np.float32(model.side))
    assert json.loads(client.request("/api/info")[2])["supports"]["webgl"] is True


def test_panel_and_shader_name_the_wrap_and_lattice(tmp_path):
    """A wrapped lattice model's file (issue 39) loads in the viewer: its panel and its WebGL2 program
    say the axes it wraps on and its lattice, the program carries the lattice-periodic mean and the
    modulus the page places the view's anchor with, and its tiles are synthesize's."""
    u = running_bond(channels=1)
    both = (True, True)
    model = TilingModel(u, 40.0, 16, 0.0, {}, "variance", None, both, Lattice.from_vectors([(16, 0)], u.shape, both))
    path = tmp_path / "courses.exr"
    model.save(path)
    with serve(path, port=0, device=DEVICE, filter="none") as server:
        c = Client(server)
        p = json.loads(c.get("/api/panel", seed=1)[2])
        assert "wrapped on x and y, lattice (16, 0)" in p["summary"]
        shader = json.loads(c.get("/api/shader")[2])
        assert shader["modulus"] == model.lattice.modulus and "tiling_mean" in shader["textures"]
        assert "const int TL_RANK = 1;" in shader["library"]
        status, _, body = c.get("/tile", z=0, x=3, y=-2, seed=5, filter="none")
        assert status == 200
        w = tile_window(Tile(0, 3, -2, 256), Noise(5, 30.0, 0.0, "none"))
        want = synthesize(model, w.shape, seed=5, scale=w.scale, rotation=w.rotation, offset=w.offset, device=DEVICE)
        np.testing.assert_array_equal(decode_png(body)[..., 0], to_8bit(want)[..., 0])


def test_what_a_tiling_model_cannot_do_is_one_line(client):
    status, _, body = client.get("/tile", z=0, x=0, y=0, mode="mix", b="0" * 16, steps=3, start=0, end=1)
    assert status in (400, 404) and body.count(b"\n") <= 1


def test_mixing_a_tiling_model_is_refused_at_start(model_path, tmp_path):
    from warp_texton import TextonError

    png = small_rgb(tmp_path / "b.png")
    with pytest.raises(TextonError, match="tiling model"):
        Viewer(model_path, mix=png, device=DEVICE)
    with pytest.raises(TextonError, match="tiling model"):
        Viewer(png, mix=model_path, device=DEVICE)


@pytest.mark.parametrize("fmt", ["png", "exr"])
def test_export_is_what_its_commands_make(client, model, tmp_path, fmt):
    params = dict(w=64, h=40, scale=0.75, left=-1234.25, top=87.5, rot=-33, seed=6, filter="none", format=fmt)
    plan = json.loads(client.get("/api/plan", **params)[2])
    assert "--mni" not in plan["cli"][-1] and "mni=" not in plan["python"]
    status, _, data = client.get("/export", **params)
    assert status == 200
    got = tmp_path / "download" / plan["file"]
    got.parent.mkdir()
    got.write_bytes(data)
    w = view_window(64, 40, 0.75, -33.0, -1234.25, 87.5)
    want = synthesize(model, w.shape, seed=6, scale=w.scale, rotation=w.rotation, offset=w.offset, device=DEVICE)
    values = read_image(got)
    if fmt == "png":
        np.testing.assert_array_equal(to_8bit(values), to_8bit(want))
    else:
        np.testing.assert_allclose(values, want, atol=1e-6)
    run_cli(plan["cli"], tmp_path)
    np.testing.assert_allclose(read_image(tmp_path / plan["file"]), values, atol=1e-6 if fmt == "exr" else 0)
    scope: dict = {}
    old = os.getcwd()
    os.chdir(tmp_path / "download")
    try:
        exec(plan["python"], scope)
    finally:
        os.chdir(old)
    np.testing.assert_allclose(scope["image"], want, atol=1e-6)


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium on PATH")
def test_page_shows_the_tiling_model(server, model):
    sync_api = pytest.importorskip("playwright.sync_api")
    from test_view_browser import VIEWPORT, assert_shows, wait_idle

    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        try:
            context = b.new_context(viewport=VIEWPORT, device_scale_factor=1)
            page = context.new_page()
            errors: list = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(server.url)  # render=auto: a software rasterizer (SwiftShader) keeps to the tiles
            wait_idle(page, panel=True)
            assert page.evaluate("window.viewer.render()")["drawing"] == "tiles"
            assert "software" in page.inner_text("#render-note")
            assert_shows(page, model, Noise(0, 30.0, 0.0, "none"))
            assert "tiling model" in page.inner_text("#texton-info")
            assert page.is_disabled("input[name=mode][value=mix]") and page.is_disabled("#mni")
            assert not errors
        finally:
            b.close()


def test_default_filter_is_one_the_viewer_offers_for_tiling(model_path):
    # the CLI's default start filter is anisotropic: the page starts with a filter the package
    # computes for tiling models (probed at start), and every offered filter makes a tile
    v = Viewer(model_path, device=DEVICE)
    try:
        info = v.info()
        assert info["defaults"]["filter"] in info["bounds"]["filters"]
        for f in info["bounds"]["filters"]:
            tile = v.tile(Tile(-2, 0, 0, 16), v.defaults[0], Noise(filter=f))
            assert tile.shape == (16, 16, 3) and np.isfinite(tile).all()
    finally:
        v.close()


@pytest.mark.slow
@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium on PATH")
@pytest.mark.parametrize("which", ["preserving", "plain_guided", "lattice"])
def test_webgl_draws_the_tiling_model(which, model_path, model, tmp_path):
    """The page's WebGL2 mode draws the model with its GLSL port (the histogram tables after the
    blend): a view off the origin, zoomed out, turned and re-seeded, pans and the seed slider
    redraw without a request, and the canvas is ``synthesize`` of the view, held to the texton
    WebGL test's bounds (8-bit pixels: at most 0.1 % beyond ±1 level of the tiles and of
    ``synthesize``; floats: at most 0.1 % beyond 1e-3 of the range) and to the issue's (at least
    99 % within 2/255). A filter other than none is drawn by the tiles. "lattice": a seamless running bond
    read wrapped and snapped to its lattice (issue 39), loaded from its file: the page places the view's
    anchor mod the lattice's modulus itself."""
    from clients import chromium_browser
    from test_view_webgl import BEYOND_ONE, CANVAS, Page, beyond_one

    if which == "plain_guided":  # no tables, a fractional side and the luminance guide; filters offered
        u = read_image(small_rgb(tmp_path / "rgb64.png"))
        model = TilingModel(u, 13.3, 8, 1.5, {}, "variance")
        model_path = tmp_path / "plain.exr"
        model.save(model_path)
    if which == "lattice":
        u = running_bond()
        both = (True, True)
        model = TilingModel(u, 30.0, 16, 0.0, {}, "variance", None, both,
                            Lattice.from_vectors([(16, 16), (16, -16)], u.shape, both))
        model_path = tmp_path / "lattice.exr"
        model.save(model_path)
        assert load_texton(model_path).lattice == model.lattice
    with serve(model_path, port=0, device=DEVICE, filter="none") as server, chromium_browser() as browser:
        p = Page(browser, server.url + "?render=webgl")
        try:
            r = p.render()
            assert r["drawing"] == "webgl" and "SwiftShader" in r["renderer"]
            if which == "lattice":
                payload = json.loads(Client(server).get("/api/shader")[2])
                assert payload["modulus"] == 128 and sorted(payload["textures"]) == ["tiling_example", "tiling_mean"]
                assert "lattice (16, -16); (16, 16)" in payload["texton"]
            shaders = [u for u in p.requests if "/api/shader?" in u]
            assert len(shaders) == 1 and not [u for u in p.requests if "/tile?" in u]
            p.eval("window.viewer.setView({ left: 5234.5, top: -1321.25 })")
            p.page.click("#zoom-out")
            p.idle()
            p.set_input("#rot", -35)
            p.set_input("#seed", 7)
            v = p.eval("window.viewer.view()")
            assert (v["level"], v["rot"], v["scale"]) == (-1, -35, 0.5)

            def want(seed):
                v = p.eval("window.viewer.view()")
                w = view_window(v["width"], v["height"], v["scale"], v["rot"], v["left"], v["top"])
                return synthesize(model, w.shape, seed=seed, scale=w.scale, rotation=w.rotation, offset=w.offset,
                                  device=DEVICE)

            def compare(what, seed):
                ref = want(seed)
                values = p.floats()
                err = np.abs(values - ref).max(axis=-1)
                rel = err / float(np.ptp(ref))
                fraction = float(np.mean(err <= 2.0 / 255.0))
                print(f"{what}: {fraction:.5f} of the pixels within 2/255, max error {err.max():.2e} "
                      f"({rel.max():.2e} of the range), {int((rel > 1e-3).sum())} beyond 1e-3 of the range")
                assert fraction >= 0.99 and (rel > 1e-3).mean() <= BEYOND_ONE
                shown = p.pixels()
                np.testing.assert_array_equal(shown, to_8bit(values))
                beyond_one(shown, to_8bit(ref), f"{what}, canvas against synthesize")
                return shown

            gl = compare("WebGL, zoomed out and turned", 7)
            assert gl.shape[:2] == (CANVAS[1], CANVAS[0])
            beyond_one(gl, p.mode("tiles"), "WebGL against the tiles")
            p.mode("webgl")
            # pan and re-seed: redrawn without a request
            p.requests.clear()
            p.eval("window.viewer.setView({ zoom: 0.5, left: -80.75, top: 33.0 })")
            p.idle()
            p.set_input("#seed", 4294967295)
            assert not [u for u in p.requests if re.search(r"/(tile|plane|api/shader)\?", u)]
            compare("WebGL at 1.41 px/texel, seed 2**32 - 1", 2**32 - 1)
            # a filter the GLSL port does not draw: the tiles, saying why
            others = [f for f in json.loads(Client(server).request("/api/info")[2])["bounds"]["filters"] if f != "none"]
            assert bool(others) == (model.histogram is None)  # mip, anisotropic: not for a model with tables
            if others:
                p.set_input("#filter", others[0], "change")
                assert p.render()["drawing"] == "tiles"
                assert "draws a tiling model unfiltered" in p.page.inner_text("#hud")
        finally:
            p.close()
