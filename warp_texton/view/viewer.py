"""What the viewer (``warp-texton view``) computes, without HTTP: tiles, plane
views, the side panel and exports, from one input.

A tile is a pure function of its key and the view settings. Tile (z, x, y) of
side T is the raster of ``synthesize`` at scale s = 2**z pixels per texel whose
pixel (i, j) is global pixel (y T + i, x T + j) of level z, i.e. the noise at
R(rotation) ((x T + j + ½)/s, (y T + i + ½)/s): neighbouring tiles are windows
of one raster and join without seams by construction. The rotation turns the
noise about the world origin (the page re-centres its view so that the point
under the centre of the screen stays put).

Every request's work is bounded before it starts (:mod:`~warp_texton.view.queries`
reads and bounds the parameters, :mod:`~warp_texton.view.inputs` the uploads),
computations wait for one of a few slots, and analyses and tiles are computed
once and cached (:mod:`~warp_texton.view.cache`); exports carry the commands
that reproduce them (:mod:`~warp_texton.view.commands`).

A tiling model file (``analyze(..., method="tiling")``) is shown too: its tiles,
exports and panel are the same functions of ``synthesize`` (offset, scale,
rotation, seed), drawn by the server's kernels; the page's WebGL2 mode draws
its unfiltered views with the model's GLSL port (:data:`WEBGL_TILING`);
the filters, the ground plane and seamless tiles are offered for a tiling model
where the package supports them for it (probed at start:
:meth:`Viewer.tiling_support`); mixing takes textons and images only.
"""

from __future__ import annotations

import math
import shutil
import tempfile
import threading
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np

from ..core.runtime import resolve_device
from .._version import __version__
from ..model.analysis import analyze
from ..noise.filter_options import FILTERS
from ..model.gaussian import gaussian_texture, periodic_component
from ..core.errors import OverBudget, TextonError
from ..files.images import write_image
from ..core.limits import Cancelled, cancellable, format_bytes, memory_budget, scoped_budget, work_budget
from ..noise.mixing import mix_textons, synthesize_mixed
from ..noise.ground_plane import render_plane
from ..noise.synthesis import synthesize
from ..model.texton import Texton
from ..model.tiling import TilingModel
from ..runtimes.shared import model_note
from .cache import Memo
from .commands import plan_mix, plan_noise, plan_plane
from .pictures import PNG_LEVEL, data_url, log_spectra, png_bytes, texton_picture
from .inputs import (MAX_UPLOAD_BYTES, MAX_UPLOADS, Source, decode_upload, digest, load_source,
                          price_upload, safe_name)
from .webgl import shader_payload, tiling_payload
from .queries import (ENLARGE, MAX_EXPORT_PIXELS, MAX_EXPORT_SIDE, MAX_PLANE_PIXELS, MAX_REACH,
                         MIX_STEPS, MIX_ZOOM, MNI_RANGE, ORDERS, TEXTON_SIZES, TILE_SIZES, VIEW_FILTERS, ZOOM_MAX,
                         ZOOM_MIN, Analysis, BadRequest, Mix, Noise, Plane, Query, Tile, Window, parse_analysis,
                         parse_mix, parse_noise, parse_plane, parse_size, parse_tile, tile_window, view_window)

#: Requests waiting for a computation beyond this are answered 503.
MAX_WAITING = 512
#: A request's memory: its share of the memory budget (what the image cache
#: leaves, divided among the slots), and at most this.
MAX_REQUEST_BYTES = 1 << 30
#: A tile's, plane view's or panel's memory: tiles that need more draw tens of
#: millions of impacts, seconds of work for a picture of a few hundred pixels.
MAX_VIEW_BYTES = 256 << 20
#: A tile's, plane view's or panel's work (operations, as limits.check_work
#: counts them): about a second of a few CPU cores. Exports have the process's
#: work budget.
MAX_VIEW_WORK = 2.0e9
#: Uploaded images kept for mixing, at most (the oldest go first; the newest stays).
MAX_KEPT_UPLOAD_BYTES = 256 << 20
#: The smallest share of memory a slot may have.
MIN_SLOT_BYTES = 64 << 20
#: The page's WebGL2 mode for tiling models: a function model -> the page's program
#: (``webgl.tiling_payload``, the GLSL port's library, warp_texton.runtimes.glsl.tiling); None: the
#: page draws the server's tiles for them.
WEBGL_TILING: Callable[[TilingModel], dict] | None = tiling_payload


class ClientGone(Exception):
    """The client closed its connection before its computation started."""


@dataclass(frozen=True)
class Export:
    """A file the page asked for: its name, the commands that make it, and its computation."""

    name: str
    plan: dict
    make: Callable[[], np.ndarray]  # the float32 image


class Viewer:
    """Everything the page can ask for, without HTTP: tiles, plane views, exports
    and the side panel, from one input (and optional second inputs for mixing).

    Thread-safe: computations are limited to ``slots`` at a time; analyses and
    tiles are cached (LRU) and computed once however many requests ask for them.
    """

    def __init__(self, input, *, mix=None, device=None, analysis: Analysis = Analysis(),
                 noise: Noise = Noise(), slots: int = 2, cache_bytes: int = 256 << 20, png_level: int = PNG_LEVEL):
        self.source = load_source(input)
        if mix is not None and self.source.kind == "tiling":
            raise TextonError("mix: the input is a tiling model (method 'tiling'), which cannot be mixed; mixing "
                              "takes images and textons", param="mix")
        self.png_level = png_level
        self.device = device
        self.defaults = (analysis, noise)
        self._slots = threading.BoundedSemaphore(slots)
        share = (memory_budget() - cache_bytes - MAX_KEPT_UPLOAD_BYTES) // slots
        if share < MIN_SLOT_BYTES:
            raise TextonError(f"cache_mb={cache_bytes / (1 << 20):g} and slots={slots} leave "
                              f"{format_bytes(max(share, 0))} of the memory budget of {format_bytes(memory_budget())} "
                              f"(less {format_bytes(MAX_KEPT_UPLOAD_BYTES)} for uploads) to each computation (at least {format_bytes(MIN_SLOT_BYTES)}); use a smaller "
                              "cache_mb or fewer slots", param="cache_mb", mentions=("slots",))
        #: the bounds of one request's computation
        self.request_bytes = min(MAX_REQUEST_BYTES, share)
        self._waiting = 0
        self._waiting_lock = threading.Lock()
        self._textons = Memo(16)
        self._mixes = Memo(4)
        self._panels = Memo(16)
        self._shaders = Memo(8)
        self._images = Memo(cache_bytes, weight=len)
        self._uploads: OrderedDict[str, Source] = OrderedDict()
        self._uploads_lock = threading.Lock()
        if mix is not None:
            b = load_source(mix, "mix", tiling=False)
            self._uploads[b.digest] = b
            self.start_b: str | None = b.digest
        else:
            self.start_b = None
        # an input that cannot be analysed with the start settings fails now, not in the page
        texton = self.texton(analysis)
        self.src = digest(self.source.digest, __version__, device or "default")
        #: what the package computes for a tiling model (all of it for textons): tiling_support()
        self.supports: dict[str, Any] = {"filters": VIEW_FILTERS, "plane": True, "periodic": True}
        self._warm_up(texton)
        self.workdir = Path(tempfile.mkdtemp(prefix="warp-texton-view-"))

    def close(self) -> None:
        shutil.rmtree(self.workdir, ignore_errors=True)

    # -- inputs
    def _warm_up(self, texton: Texton | TilingModel) -> None:
        """Compile the kernel modules before the first request needs them."""
        if isinstance(texton, TilingModel):
            self.supports = self.tiling_support(texton)
            return
        synthesize(texton, (8, 8), device=self.device)
        synthesize(texton, (8, 8), scale=0.1, filter="anisotropic", device=self.device)

    def tiling_support(self, model: TilingModel) -> dict:
        """The view's filters, the ground plane and seamless tiles that the package computes for a
        tiling model: each tried once on a few pixels (a refusal says it does not)."""
        def works(fn) -> bool:
            try:
                fn()
            except (TextonError, TypeError, AttributeError):
                return False
            return True

        synthesize(model, (8, 8), device=self.device)
        filters = tuple(f for f in VIEW_FILTERS if f == "none" or works(
            lambda f=f: synthesize(model, (8, 8), scale=0.1, filter=f, device=self.device)))
        return {"filters": filters,
                "plane": works(lambda: render_plane(cast(Any, model), (4, 4), seed=0, filter=filters[-1], device=self.device)),
                "periodic": works(lambda: synthesize(model, (8, 8), period=(8.0, 8.0), device=self.device))}

    def texton(self, analysis: Analysis) -> Texton | TilingModel:
        if self.source.texton is not None:
            return self.source.texton
        return self._textons.get(analysis, lambda: self._analyze(analysis))

    def _analyze(self, a: Analysis) -> Texton:
        texton = analyze(self.source.image, options=a.options())
        texton.metadata["source"] = self.source.name
        return texton

    def add_upload(self, data: bytes, name: str, alive=None) -> Source:
        """Decode an upload in a computation slot, within a request's bounds."""
        b = self._compute(alive, lambda: decode_upload(data, safe_name(name), self.workdir), MAX_VIEW_WORK,
                          self.request_bytes, price=lambda: price_upload(data))
        with self._uploads_lock:
            self._uploads[b.digest] = b
            self._uploads.move_to_end(b.digest)
            while len(self._uploads) > 1 + (self.start_b is not None) and (
                    len(self._uploads) > MAX_UPLOADS + (self.start_b is not None)
                    or self._kept_upload_bytes() > MAX_KEPT_UPLOAD_BYTES):
                oldest = next(k for k in self._uploads if k not in (self.start_b, b.digest))
                del self._uploads[oldest]
        return b

    def _kept_upload_bytes(self) -> int:
        return sum(u.image.nbytes for k, u in self._uploads.items() if k != self.start_b and u.image is not None)

    def second(self, digest: str) -> Source:
        with self._uploads_lock:
            b = self._uploads.get(digest)
        if b is None:
            raise BadRequest(f"unknown second input {digest!r}: upload it again", 404)
        return b

    def mixed_textons(self, analysis: Analysis, mix: Mix) -> list[Texton]:
        if self.source.kind == "tiling":
            raise BadRequest("mixing takes images and textons; the input is a tiling model (method 'tiling')")
        b = self.second(mix.b)

        def compute():
            a = self.source.texton if self.source.texton is not None else self.source.image
            v = b.texton if b.texton is not None else b.image
            return mix_textons(a, v, np.linspace(0.0, 1.0, mix.steps), options=analysis.options())

        return self._mixes.get((analysis, mix.b, mix.steps), compute)

    # -- work
    def _compute(self, alive, fn, work: float = MAX_VIEW_WORK, memory: float | None = None, price=None):
        """Run ``fn`` in a computation slot, within ``work`` and ``memory`` (default:
        a view's, :data:`MAX_VIEW_BYTES` at most): the library's own estimates
        refuse it before it allocates (413, naming the bound); ``price()``, the
        checks that need no computation, refuses it before it waits for a slot.
        Give up if the client has gone meanwhile, or goes while ``fn`` computes
        (between its strips)."""
        memory = min(MAX_VIEW_BYTES, self.request_bytes) if memory is None else memory
        if price is not None:
            try:
                with scoped_budget(memory, work):
                    price()
            except OverBudget as exc:
                raise _over(exc, memory, work) from None
        with self._waiting_lock:
            if self._waiting >= MAX_WAITING:
                raise BadRequest(f"busy: {MAX_WAITING} requests are already waiting", 503)
            self._waiting += 1
        try:
            with self._slots:
                if alive is not None and not alive():
                    raise ClientGone()
                with scoped_budget(memory, work), cancellable(alive):
                    return fn()
        except Cancelled:
            raise ClientGone() from None
        except OverBudget as exc:
            raise _over(exc, memory, work) from None
        finally:
            with self._waiting_lock:
                self._waiting -= 1

    def tile(self, tile: Tile, analysis: Analysis, noise: Noise, mix: Mix | None = None) -> np.ndarray:
        """The float32 (T, T, C) values of a tile."""
        if mix is None:
            w = tile_window(tile, noise)
            model = self.texton(analysis)
            if isinstance(model, TilingModel):
                return self.tiling_raster(model, w.shape, noise, w.scale, w.rotation, w.offset)
            # output="numpy" (the default) gives NumPy
            return cast(np.ndarray, synthesize(model, w.shape, noise=noise.options(),
                                               scale=w.scale, rotation=w.rotation, offset=w.offset,
                                               device=self.device, filter=noise.filter))
        return self.mixed_tile(tile, analysis, noise, mix)

    def tiling_raster(self, model: TilingModel, shape, noise: Noise, scale: float, rotation: float, offset,
                      period=None) -> np.ndarray:
        """``synthesize`` of a tiling model: the seed and the placement (the MNI is texton noise's);
        the view's filter and a period where the package supports them for tiling models."""
        self._tiling_check(noise, period)
        extra: dict = {} if period is None else {"period": period}
        if noise.filter != "none":
            extra["filter"] = noise.filter
        return cast(np.ndarray, synthesize(model, shape, seed=noise.seed, scale=scale, rotation=rotation,
                                           offset=offset, device=self.device, **extra))

    def _tiling_check(self, noise: Noise, period=None) -> None:
        if noise.filter not in self.supports["filters"]:
            raise BadRequest(f"filter {noise.filter!r} does not apply to a tiling model yet; this viewer offers "
                             f"{', '.join(self.supports['filters'])} for it")
        if period is not None and not self.supports["periodic"]:
            raise BadRequest("seamless tiles (periodic outputs) of a tiling model are not supported yet; export "
                             "the view")

    def mixed_tile(self, tile: Tile, analysis: Analysis, noise: Noise, mix: Mix) -> np.ndarray:
        """A tile of mixed noise (no rotation, no filter). An impact takes the texton of
        ρ at the pixel where its texton's centre lies, and pixels outside the raster
        count as its border column, so the tile is computed with a margin holding the
        centre of every impact that reaches it: half a texton side plus the ψ reach on
        each side (ρ depends on x only, so rows need none). ρ is a function of the
        global pixel: tiles join."""
        textons = self.mixed_textons(analysis, mix)
        s = 2.0 ** tile.z
        order = textons[0].order
        reach = 0.5 if order == 0 else (order + 1) / 2.0
        left = right = math.ceil(((textons[0].size[1] - 1) / 2 + reach) * s) + 2
        t = tile.size
        w = t + left + right
        j0 = tile.x * t - left  # global pixel column of the raster's first column
        rho = np.broadcast_to(mix.rho((j0 + np.arange(w) + 0.5) / s)[None, :], (t, w))
        out = synthesize_mixed(textons, rho, (t, w), mni=noise.mni, seed=noise.seed, scale=s, offset=(j0 / s, tile.y * t / s),
                               device=self.device)
        return np.ascontiguousarray(out[:, left:left + t])

    # -- requests: the query of a GET whose src was checked -> (key, make(alive) -> PNG bytes);
    #    the image is a pure function of its key (and of the input), so the key makes its ETag
    def tile_request(self, q: Query) -> tuple[tuple, Callable[..., bytes]]:
        mixing = q.choice("mode", ("noise", "mix"), default="noise") == "mix"
        analysis = parse_analysis(q, self.defaults[0])
        noise = parse_noise(q, self.defaults[1], rotation=not mixing)
        if mixing:
            noise = Noise(noise.seed, noise.mni, 0.0, "none")
        tile = parse_tile(q, noise, mixing)
        mix = parse_mix(q) if mixing else None
        q.finish()
        if mix is not None:
            self.second(mix.b)
        key = ("tile", tile, self._analysis_key(analysis), noise, mix)
        return key, lambda alive: self._memo_image(
            key, alive, lambda: png_bytes(self.tile(tile, analysis, noise, mix), self.png_level), analysis, mix)

    def plane_request(self, q: Query) -> tuple[tuple, Callable[..., bytes]]:
        analysis = parse_analysis(q, self.defaults[0])
        noise = parse_noise(q, self.defaults[1], rotation=False)
        plane = parse_plane(q)
        q.finish()
        key = ("plane", plane, self._analysis_key(analysis), noise)
        return key, lambda alive: self._memo_image(
            key, alive, lambda: png_bytes(self.plane(plane, analysis, noise), self.png_level), analysis)

    def panel_request(self, q: Query) -> dict:
        analysis = parse_analysis(q, self.defaults[0])
        seed = q.integer("seed", 0, 2**32 - 1, default=0)
        q.finish()
        return self.panel(analysis, seed)

    def shader_request(self, q: Query, alive=None) -> dict:
        """The page's WebGL2 program for an analysis (:func:`~warp_texton.view.webgl.shader_payload`):
        the analysis first, as for a tile, then the library and textures within a view's bounds."""
        analysis = parse_analysis(q, self.defaults[0])
        # the MNI of the view: a texton's histogram tables are those of its noise at that MNI
        mni = q.number("mni", *MNI_RANGE) if "mni" in q else None
        q.finish()
        model = self.source.texton
        if isinstance(model, TilingModel):
            if WEBGL_TILING is None:
                raise BadRequest("the WebGL mode draws texton models; a tiling model is drawn by the server's "
                                 "tiles", 501)
            return self._shaders.get(None, lambda: self._compute(alive, lambda: WEBGL_TILING(model)))
        key = self._analysis_key(analysis)
        if key not in self._shaders:
            self._analysed(alive, analysis)
        return self._shaders.get((key, mni), lambda: self._compute(alive, lambda: shader_payload(
            cast(Texton, self.texton(analysis)), filters=VIEW_FILTERS, mni=mni)))

    def _analysis_key(self, analysis: Analysis) -> Analysis | None:
        """Analysis settings change nothing when the input is a texton file."""
        return analysis if self.source.texton is None else None

    def _analysed(self, alive, analysis: Analysis, mix: Mix | None = None) -> None:
        """Compute the analyses a view needs first, as a request of their own: they
        are shared by every view of their settings, and priced with a request's
        share of the memory and the process's work budget, not a view's."""
        if (self.source.texton is None and analysis not in self._textons) or \
                (mix is not None and (analysis, mix.b, mix.steps) not in self._mixes):
            self._compute(alive, lambda: (self.texton(analysis), mix and self.mixed_textons(analysis, mix)),
                          work_budget(), self.request_bytes)

    def _memo_image(self, key, alive, make, analysis: Analysis, mix: Mix | None = None) -> bytes:
        if key not in self._images:
            self._analysed(alive, analysis, mix)
        for _ in range(2):  # a shared computation whose first asker left is retried once
            try:
                return self._images.get(key, lambda: self._compute(alive, make))
            except ClientGone:
                if alive is None or not alive():
                    raise
        raise ClientGone()

    def plane(self, plane: Plane, analysis: Analysis, noise: Noise) -> np.ndarray:
        model = self.texton(analysis)
        if isinstance(model, TilingModel):
            if not self.supports["plane"]:
                raise BadRequest("the ground plane of a tiling model is not supported yet (render_plane takes "
                                 "textons); use the noise mode")
            self._tiling_check(noise)
            # render_plane takes tiling models where the package supports them (self.supports["plane"])
            return cast(np.ndarray, render_plane(cast(Any, model), (plane.height, plane.width),
                                                 height=plane.camera_height, tilt=plane.tilt, fov=plane.fov,
                                                 texel_size=plane.texel_size, seed=noise.seed,
                                                 filter=noise.filter, device=self.device))
        return cast(np.ndarray, render_plane(model, (plane.height, plane.width),
                                             height=plane.camera_height, tilt=plane.tilt, fov=plane.fov,
                                             texel_size=plane.texel_size, mni=noise.mni, seed=noise.seed,
                                             filter=noise.filter, device=self.device))

    # -- side panel
    def panel(self, analysis: Analysis, seed: int) -> dict:
        key = (self._analysis_key(analysis), seed)
        if key not in self._panels:
            self._analysed(None, analysis)
        return self._panels.get(key, lambda: self._compute(None, lambda: self._panel(analysis, seed)))

    def _tiling_panel(self, model: TilingModel, seed: int) -> dict:
        """The side panel of a tiling model: its example (in its colours), its numbers, and the
        periodograms of the example and of the blend (on the example's grid, at most 256²)."""
        h, w, c = model.example.shape
        example = model.colours()
        summary = (f"tiling model of a {w}×{h} example, triangle side {model.side:g}, sharpness {model.sharpness}, "
                   f"{model.blend} blend" + (", histogram preserved" if model.histogram is not None else "") +
                   model_note(model) + f", {'grey' if c == 1 else 'RGB'}")
        info = {"kind": "tiling", "summary": summary, "texton": data_url(example, 160),
                "texton_size": [h, w], "order": None, "channels": c,
                "mean": [round(float(m), 5) for m in example.mean(axis=(0, 1), dtype=np.float64)],
                "model_error": None, "structure": model.structure}
        grid = (min(h, 256), min(w, 256))
        crop = example[(h - grid[0]) // 2:(h - grid[0]) // 2 + grid[0],
                       (w - grid[1]) // 2:(w - grid[1]) // 2 + grid[1]].astype(np.float64)
        crop -= crop.mean(axis=(0, 1))
        spectrum = (np.abs(np.fft.fft2(crop, axes=(0, 1))) ** 2).sum(axis=2) / (grid[0] * grid[1])
        g = cast(np.ndarray, synthesize(model, grid, seed=seed, device=self.device)).astype(np.float64)
        g -= g.mean(axis=(0, 1))
        measured = (np.abs(np.fft.fft2(g, axes=(0, 1))) ** 2).sum(axis=2) / (grid[0] * grid[1])
        for name, pic in zip(("spectrum_texton", "spectrum_noise"), log_spectra(spectrum, measured)):
            info[name] = data_url(pic, 160)
        return info

    def _panel(self, analysis: Analysis, seed: int) -> dict:
        texton = self.texton(analysis)
        if isinstance(texton, TilingModel):
            return self._tiling_panel(texton, seed)
        r, s = texton.size
        info = {"texton": data_url(texton_picture(texton), 160, nearest=True),
                "texton_size": [r, s], "order": texton.order, "channels": texton.channels,
                "mean": [round(float(m), 5) for m in texton.mean],
                "model_error": texton.metadata.get("model_error")}
        # spectra on the input's grid (at most 256² about its centre), or twice the texton's
        if self.source.image is not None:
            u = self.source.image
            gh, gw = min(u.shape[0], 256), min(u.shape[1], 256)
            y0, x0 = (u.shape[0] - gh) // 2, (u.shape[1] - gw) // 2
            crop = periodic_component(u[y0:y0 + gh, x0:x0 + gw]).astype(np.float64)
            crop -= crop.mean(axis=(0, 1))
            model = (np.abs(np.fft.fft2(crop, axes=(0, 1))) ** 2).sum(axis=2) / (gh * gw)
            info["input"] = data_url(u, 256)
            info["gaussian"] = data_url(gaussian_texture(u, seed=seed), 256)
            info["input_size"] = [u.shape[1], u.shape[0]]
        else:
            gh = gw = max(64, 1 << math.ceil(math.log2(2 * max(r, s))))
            model = None
        grid = (max(gh, r), max(gw, s))
        noise_model = (np.abs(texton.spectrum(grid)) ** 2).sum(axis=2)
        # the noise's periodogram, averaged over 4 windows: its expectation is |α̂|² b̂ (CGF eq. (4))
        measured = np.zeros(grid)
        for k in range(4):
            g = cast(np.ndarray, synthesize(texton, grid, mni=30.0, seed=seed, offset=(k * 10.0 * grid[1], 0.0),
                                            device=self.device))
            g = g.astype(np.float64) - g.mean(axis=(0, 1))
            measured += (np.abs(np.fft.fft2(g, axes=(0, 1))) ** 2).sum(axis=2) / (grid[0] * grid[1] * 4)
        pictures = log_spectra(*([] if model is None else [model]), noise_model, measured)
        names = ([] if model is None else ["spectrum_input"]) + ["spectrum_texton", "spectrum_noise"]
        for name, pic in zip(names, pictures):
            info[name] = data_url(pic, 160)
        return info

    # -- export
    def export_job(self, q: Query) -> Export:
        """The export a request asks for: its file name, the commands that make the
        same file, and the computation (not run yet)."""
        mode = q.choice("mode", ("noise", "plane", "mix"), default="noise")
        analysis = parse_analysis(q, self.defaults[0])
        fmt = q.choice("format", ("png", "exr"), default="png")
        if mode == "plane":
            noise = parse_noise(q, self.defaults[1], rotation=False)
            plane = parse_plane(q)
            q.finish()
            name = f"plane_{plane.width}x{plane.height}_seed{noise.seed}.{fmt}"
            return Export(name, plan_plane(name, plane, analysis, noise, self.source, self.device),
                          lambda: self.plane(plane, analysis, noise))
        if mode == "mix":
            noise = parse_noise(q, self.defaults[1], rotation=False)
            mix = parse_mix(q)
            w, h = parse_size(q)
            scale = q.number("scale", 2.0 ** MIX_ZOOM[0], 2.0 ** (MIX_ZOOM[1] + ENLARGE))
            corner = (q.number("left", -MAX_REACH, MAX_REACH), q.number("top", -MAX_REACH, MAX_REACH))
            q.finish()
            name = f"mix_{w}x{h}_seed{noise.seed}.{fmt}"
            plan = plan_mix(name, (h, w), scale, corner, analysis, noise, mix, self.source, self.second(mix.b),
                            self.device)

            def make_mix() -> np.ndarray:
                x = corner[0] + (np.arange(w) + 0.5) / scale
                rho = np.broadcast_to(mix.rho(x)[None, :], (h, w))
                return synthesize_mixed(self.mixed_textons(analysis, mix), rho, (h, w), mni=noise.mni, seed=noise.seed,
                                        scale=scale, offset=corner, device=self.device)

            return Export(name, plan, make_mix)
        noise = parse_noise(q, self.defaults[1])
        kind = q.choice("kind", ("view", "tile"), default="view")
        w, h = parse_size(q)
        scale = q.number("scale", 2.0 ** min(ZOOM_MIN.values()), 2.0 ** (ZOOM_MAX + ENLARGE))
        if kind == "tile":
            # a seamless tile: the raster at offset 0 covers exactly one period, unrotated
            window = Window((h, w), scale, 0.0, (0.0, 0.0), (w / scale, h / scale))
        else:
            window = view_window(w, h, scale, noise.rotation, q.number("left", -MAX_REACH, MAX_REACH),
                                 q.number("top", -MAX_REACH, MAX_REACH))
        q.finish()
        name = f"{kind if kind == 'tile' else 'noise'}_{w}x{h}_seed{noise.seed}.{fmt}"

        model = self.texton(analysis)
        if isinstance(model, TilingModel):
            self._tiling_check(noise, window.period)

            def make_tiling() -> np.ndarray:
                return self.tiling_raster(model, window.shape, noise, window.scale,
                                          window.rotation, window.offset, window.period)

            return Export(name, plan_noise(name, window, analysis, noise, self.source, self.device), make_tiling)

        def make() -> np.ndarray:
            return cast(np.ndarray, synthesize(self.texton(analysis), window.shape,
                                               noise=noise.options().replace(period=window.period),
                                               scale=window.scale, rotation=window.rotation, offset=window.offset,
                                               device=self.device, filter=noise.filter))

        return Export(name, plan_noise(name, window, analysis, noise, self.source, self.device), make)

    def export_bytes(self, job: Export, alive=None) -> bytes:
        """The file of an export, written by ``write_image`` as the CLI writes it;
        its computation stops between strips once ``alive()`` is False."""
        def work():
            img = job.make()
            d = Path(tempfile.mkdtemp(dir=self.workdir))
            try:
                write_image(d / job.name, img)
                return (d / job.name).read_bytes()
            finally:
                shutil.rmtree(d, ignore_errors=True)

        return self._compute(alive, work, work_budget(), self.request_bytes)

    def info(self) -> dict:
        analysis, noise = self.defaults
        image = self.source.image
        with self._uploads_lock:
            start_b = self._uploads.get(self.start_b) if self.start_b else None
        return {
            "version": __version__, "src": self.src, "name": self.source.name, "kind": self.source.kind,
            "channels": self.source.channels,
            "input_size": None if image is None else [image.shape[1], image.shape[0]],
            "device": str(resolve_device(self.device)),  # the one the noise runs on, also when not chosen
            "defaults": {"size": analysis.size, "order": analysis.order, "cc": analysis.color_correction,
                         "seed": noise.seed, "mni": noise.mni,
                         "filter": noise.filter if noise.filter in self.supports["filters"] else "none"},
            "bounds": {"zoom_min": ZOOM_MIN, "zoom_max": ZOOM_MAX, "enlarge": ENLARGE, "mix_zoom": list(MIX_ZOOM),
                       "mni": list(MNI_RANGE), "texton_size": list(TEXTON_SIZES), "orders": list(ORDERS),
                       "tile_sizes": list(TILE_SIZES), "mix_steps": list(MIX_STEPS), "export_side": MAX_EXPORT_SIDE,
                       "export_pixels": MAX_EXPORT_PIXELS, "plane_pixels": MAX_PLANE_PIXELS,
                       "filters": list(self.supports["filters"]), "upload_bytes": MAX_UPLOAD_BYTES},
            "filter_notes": {name: FILTERS[name].description for name in VIEW_FILTERS},
            "mix_b": None if start_b is None else {"id": start_b.digest, "name": start_b.name},
            "supports": {"plane": self.supports["plane"], "periodic": self.supports["periodic"],
                         "mix": self.source.kind != "tiling", "webgl": self.source.kind != "tiling"
                         or WEBGL_TILING is not None},
        }


def _over(exc: OverBudget, memory: float, work: float) -> BadRequest:
    return BadRequest(f"{exc} [this server's bounds per request: memory {format_bytes(memory)}, "
                      f"work {work:.3g} operations]", 413)
