"""What the viewer (``warp-texton view``) computes, without HTTP: request
settings, tiles, plane views, exports and the commands that reproduce them.

A tile is a pure function of its key and the view settings. Tile (z, x, y) of
side T is the raster of ``synthesize`` at scale s = 2**z pixels per texel whose
pixel (i, j) is global pixel (y T + i, x T + j) of level z, i.e. the noise at
R(rotation) ((x T + j + ½)/s, (y T + i + ½)/s): neighbouring tiles are windows
of one raster and join without seams by construction. The rotation turns the
noise about the world origin (the page re-centres its view so that the point
under the centre of the screen stays put).

Every request's work is bounded here (tile size, zoom, MNI, texton size, export
and plane sizes, uploads), computations wait for one of a few slots, and
analyses and tiles are computed once and cached.
"""

from __future__ import annotations

import base64
import hashlib
import io
import math
import os
import shlex
import shutil
import tempfile
import threading
import warnings
from collections import OrderedDict
from concurrent.futures import Future
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import parse_qsl

import numpy as np

from ._version import __version__
from .analysis import analyze
from .errors import TextonError
from .gaussian import gaussian_texture, periodic_component
from .io import read_image, write_image
from .mixing import mix_textons, synthesize_mixed
from .plane import render_plane
from .synthesis import synthesize
from .texton import Texton, load_texton

# ----------------------------------------------------------------- bounds
#: Tile sides the server computes (pixels).
TILE_SIZES = (128, 256, 512)
#: Zoom levels (scale 2**z pixels per texel). Unfiltered tiles far out draw
#: millions of impacts for an aliased picture, so "none" stops sooner.
ZOOM_MIN = {"none": -6, "mip": -10, "anisotropic": -10}
ZOOM_MAX = 5
#: The page enlarges the deepest level's tiles up to this many levels further in,
#: and exports what it shows there.
ENLARGE = 2
#: Mixed noise has no filter, and its tiles are computed with a margin of one
#: texton side, which grows with the scale.
MIX_ZOOM = (-6, 2)
#: Tiles and exports stay within this many texels of the origin.
MAX_REACH = 1.0e9
MNI_RANGE = (0.1, 200.0)
TEXTON_SIZES = (4, 128)
ORDERS = (0, 1, 3, 5)
#: Filters the viewer offers ("supersample" is a reference, seconds per tile).
VIEW_FILTERS = ("none", "mip", "anisotropic")
MIX_STEPS = (2, 33)
#: Exports and plane views: largest side and pixel count.
MAX_EXPORT_SIDE = 4096
MAX_EXPORT_PIXELS = 4096 * 4096
MAX_PLANE_PIXELS = 2048 * 1280
#: Uploaded second inputs (mixing): bytes, pixels, how many are kept.
MAX_UPLOAD_BYTES = 32 << 20
MAX_UPLOAD_PIXELS = 4096 * 4096
MAX_UPLOADS = 4
MAX_QUERY = 2048
#: Requests waiting for a computation beyond this are answered 503.
MAX_WAITING = 512
#: Seed of every analysis the viewer makes (printed in the reproducing commands).
ANALYSIS_SEED = 0
#: zlib level of tile PNGs. Noise hardly compresses: level 1 makes tiles 26 % smaller
#: than level 0 (stored) but costs 6 ms instead of 2.6 ms for 256² RGB, more than
#: the noise itself, so 0 fills a view a third faster (benchmarks/bench_view.py).
#: Over a slow link (SSH from afar) a higher level can pay: ``serve(png_level=...)``.
PNG_LEVEL = 0


class BadRequest(Exception):
    """A request the server refuses: an HTTP status and a one-line reason."""

    def __init__(self, message: str, status: int = 400):
        super().__init__(message)
        self.status = status


class ClientGone(Exception):
    """The client closed its connection before its computation started."""


# ------------------------------------------------------------ parameters
class Query:
    """The parameters of one request: each read at most once, unknown or repeated ones refused."""

    def __init__(self, text: str):
        if len(text) > MAX_QUERY:
            raise BadRequest(f"query string longer than {MAX_QUERY} characters")
        try:
            pairs = parse_qsl(text, keep_blank_values=True, strict_parsing=bool(text), max_num_fields=64)
        except ValueError as exc:
            raise BadRequest(f"malformed query string ({exc})") from None
        self._values: dict[str, str] = {}
        for k, v in pairs:
            if k in self._values:
                raise BadRequest(f"parameter {k!r} given twice")
            self._values[k] = v

    def text(self, name: str, default=None) -> str:
        if name not in self._values:
            if default is None:
                raise BadRequest(f"missing parameter {name!r}")
            return default
        return self._values.pop(name)

    def integer(self, name: str, lo: int, hi: int, default=None) -> int:
        raw = self.text(name, None if default is None else str(default))
        try:
            v = int(raw, 10)
        except ValueError:
            raise BadRequest(f"{name} must be an integer in [{lo}, {hi}], got {raw!r}") from None
        if not lo <= v <= hi:
            raise BadRequest(f"{name} must be an integer in [{lo}, {hi}], got {v}")
        return v

    def number(self, name: str, lo: float, hi: float, default=None) -> float:
        raw = self.text(name, None if default is None else repr(float(default)))
        try:
            v = float(raw)
        except ValueError:
            raise BadRequest(f"{name} must be a number in [{lo:g}, {hi:g}], got {raw!r}") from None
        if not (math.isfinite(v) and lo <= v <= hi):
            raise BadRequest(f"{name} must be a number in [{lo:g}, {hi:g}], got {raw!r}")
        return v

    def choice(self, name: str, choices, default=None) -> str:
        raw = self.text(name, default)
        if raw not in choices:
            raise BadRequest(f"{name} must be one of {', '.join(map(str, choices))}, got {raw!r}")
        return raw

    def finish(self) -> None:
        if self._values:
            raise BadRequest(f"unknown parameter {sorted(self._values)[0]!r}")


@dataclass(frozen=True)
class Analysis:
    """Analysis settings of the texton (unused when the input is a texton file)."""

    size: int = 64
    order: int = 1
    color_correction: bool = True


@dataclass(frozen=True)
class Noise:
    seed: int = 0
    mni: float = 30.0
    rotation: float = 0.0
    filter: str = "anisotropic"


@dataclass(frozen=True)
class Mix:
    """Mixing from the input A (ρ = 0) to a second input B (ρ = 1) along a ramp in x:
    ρ(x) = clip((x − start) / (end − start), 0, 1), x in texels; ``steps`` textons."""

    b: str
    steps: int
    start: float
    end: float

    def rho(self, x: np.ndarray) -> np.ndarray:
        return np.clip((x - self.start) / (self.end - self.start), 0.0, 1.0)


@dataclass(frozen=True)
class Tile:
    z: int
    x: int
    y: int
    size: int = 256


@dataclass(frozen=True)
class Plane:
    width: int
    height: int
    tilt: float = 70.0
    camera_height: float = 1.0
    fov: float = 40.0
    texel_size: float = 0.002


@dataclass(frozen=True)
class Window:
    """A raster of the (rotated) noise: what ``synthesize`` is given."""

    shape: tuple[int, int]
    scale: float
    rotation: float
    offset: tuple[float, float]
    period: tuple[float, float] | None = None


@dataclass(frozen=True)
class Export:
    name: str
    plan: dict
    make: object  # () -> float32 image


def rotate(rotation: float, u) -> tuple[float, float]:
    """R(rotation) u, as ``synthesize`` turns raster coordinates into noise positions."""
    th = math.radians(rotation)
    c, s = math.cos(th), math.sin(th)
    return (c * u[0] - s * u[1], s * u[0] + c * u[1])


def tile_window(tile: Tile, noise: Noise) -> Window:
    """The ``synthesize`` window of a tile: pixel (i, j) is the noise at
    R(rotation) ((x T + j + ½)/s, (y T + i + ½)/s), s = 2**z."""
    s = 2.0 ** tile.z
    u = (tile.x * tile.size / s, tile.y * tile.size / s)
    return Window((tile.size, tile.size), s, noise.rotation, rotate(noise.rotation, u))


def view_window(width: int, height: int, scale: float, rotation: float, left: float, top: float) -> Window:
    """A width × height raster whose top-left corner is at (left, top) in the page's
    (unrotated) view coordinates, texels; the page shows this window at scale 1:1."""
    return Window((height, width), scale, rotation, rotate(rotation, (left, top)))


def parse_analysis(q: Query, default: Analysis) -> Analysis:
    return Analysis(q.integer("size", *TEXTON_SIZES, default=default.size),
                    int(q.choice("order", tuple(map(str, ORDERS)), default=str(default.order))),
                    q.choice("cc", ("0", "1"), default="1" if default.color_correction else "0") == "1")


def parse_noise(q: Query, default: Noise, rotation: bool = True) -> Noise:
    return Noise(q.integer("seed", 0, 2**32 - 1, default=default.seed),
                 q.number("mni", *MNI_RANGE, default=default.mni),
                 q.number("rot", -360.0, 360.0, default=0.0) if rotation else 0.0,
                 q.choice("filter", VIEW_FILTERS, default=default.filter))


def parse_tile(q: Query, noise: Noise, mixing: bool) -> Tile:
    size = int(q.choice("ts", tuple(map(str, TILE_SIZES)), default="256"))
    lo, hi = MIX_ZOOM if mixing else (ZOOM_MIN[noise.filter], ZOOM_MAX)
    z = q.integer("z", lo, hi)
    s = 2.0 ** z
    reach = int(MAX_REACH * s / size)
    x = q.integer("x", -reach, reach)
    y = q.integer("y", -reach, reach)
    return Tile(z, x, y, size)


def parse_mix(q: Query) -> Mix:
    b = q.text("b")
    steps = q.integer("steps", *MIX_STEPS, default=9)
    start = q.number("ra", -MAX_REACH, MAX_REACH)
    end = q.number("rb", -MAX_REACH, MAX_REACH)
    if not end > start:
        raise BadRequest(f"the ramp must end to the right of its start: ra {start:g} >= rb {end:g}")
    return Mix(b, steps, start, end)


def parse_plane(q: Query) -> Plane:
    w = q.integer("w", 1, MAX_EXPORT_SIDE)
    h = q.integer("h", 1, MAX_EXPORT_SIDE)
    if w * h > MAX_PLANE_PIXELS:
        raise BadRequest(f"a plane view has at most {MAX_PLANE_PIXELS} pixels, got {w}x{h}")
    return Plane(w, h, q.number("tilt", 0.0, 89.0, default=70.0), q.number("height", 1e-3, 1e3, default=1.0),
                 q.number("fov", 1.0, 120.0, default=40.0), q.number("texel", 1e-6, 1e3, default=0.002))


def parse_size(q: Query) -> tuple[int, int]:
    w = q.integer("w", 1, MAX_EXPORT_SIDE)
    h = q.integer("h", 1, MAX_EXPORT_SIDE)
    if w * h > MAX_EXPORT_PIXELS:
        raise BadRequest(f"an export has at most {MAX_EXPORT_PIXELS} pixels, got {w}x{h}")
    return w, h


# ---------------------------------------------------------------- caches
class Memo:
    """A bounded LRU of computed values; concurrent callers of one key share one
    computation (the others wait for it). Failures are not kept."""

    def __init__(self, budget: float, weight=lambda value: 1):
        self._budget = budget
        self._weight = weight
        self._total = 0
        self._lock = threading.Lock()
        self._done: OrderedDict = OrderedDict()
        self._pending: dict = {}

    def get(self, key, compute):
        with self._lock:
            if key in self._done:
                self._done.move_to_end(key)
                return self._done[key]
            future = self._pending.get(key)
            owner = future is None
            if owner:
                future = self._pending[key] = Future()
        if not owner:
            return future.result()
        try:
            value = compute()
        except BaseException as exc:
            with self._lock:
                del self._pending[key]
            future.set_exception(exc)
            raise
        with self._lock:
            del self._pending[key]
            self._done[key] = value
            self._total += self._weight(value)
            while self._total > self._budget and len(self._done) > 1:
                _, old = self._done.popitem(last=False)
                self._total -= self._weight(old)
        future.set_result(value)
        return value

    def __contains__(self, key) -> bool:
        with self._lock:
            return key in self._done

    def __len__(self) -> int:
        with self._lock:
            return len(self._done)


# --------------------------------------------------------------- inputs
@dataclass(frozen=True)
class Source:
    """An input given at start (or uploaded): an image to analyse, or a texton."""

    name: str
    path: str | None
    image: np.ndarray | None
    texton: Texton | None
    digest: str

    @property
    def kind(self) -> str:
        return "texton" if self.texton is not None else "image"


def digest(*parts) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(p if isinstance(p, bytes) else str(p).encode())
        h.update(b"\0")
    return h.hexdigest()[:16]


def _is_texton_file(path: Path) -> bool:
    if path.suffix.lower() == ".texton":
        return True
    if path.suffix.lower() != ".exr":
        return False
    try:
        load_texton(path)
    except TextonError:
        return False
    return True


def load_source(input, what: str = "input") -> Source:
    """A Source from a path (texton file or image) or a Texton."""
    if isinstance(input, Texton):
        return Source("texton", None, None, input, digest(input.coeffs.tobytes(), input.mean.tobytes(), input.order))
    if not isinstance(input, (str, os.PathLike)):
        raise TextonError(f"{what} must be the path of an image or texton file, or a Texton, "
                          f"got {type(input).__name__}")
    path = Path(input)
    if not path.is_file():
        raise TextonError(f"{what}: {path}: no such file")
    with open(path, "rb") as f:
        key = digest(f.read())
    resolved = str(path.resolve())
    if _is_texton_file(path):
        return Source(path.name, resolved, None, load_texton(path), key)
    return Source(path.name, resolved, read_image(path), None, key)


def decode_upload(data: bytes, name: str, workdir: Path) -> Source:
    """An uploaded image, parsed defensively: size-checked before decoding, read by
    the package's reader from a private temporary file."""
    from PIL import Image

    if len(data) > MAX_UPLOAD_BYTES:
        raise BadRequest(f"upload larger than {MAX_UPLOAD_BYTES >> 20} MiB", 413)
    if data[:4] == b"\x76\x2f\x31\x01":  # an EXR header may declare any size: not from a request
        raise BadRequest("upload a PNG or JPEG image; give an EXR or a texton file at start (--mix)")
    try:
        with Image.open(io.BytesIO(data)) as im:  # reads the header only
            w, h = im.size
    except Exception:
        raise BadRequest("the upload is not an image that can be read") from None
    if w * h > MAX_UPLOAD_PIXELS:
        raise BadRequest(f"the uploaded image is {w}x{h}; at most {MAX_UPLOAD_PIXELS} pixels")
    fd, tmp = tempfile.mkstemp(dir=workdir, suffix=".img")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            image = read_image(tmp)
    except TextonError:
        raise BadRequest("the upload is not an image that can be read") from None
    finally:
        os.unlink(tmp)
    return Source(name, None, image, None, digest(data))


def _safe_name(name: str) -> str:
    keep = "".join(c for c in name if c.isalnum() or c in "._-")[:64]
    return keep or "upload"


# --------------------------------------------------------------- images
def to_8bit(img: np.ndarray) -> np.ndarray:
    """Values as ``write_image`` stores them in a PNG: clipped, rounded to 8 bits."""
    return np.round(np.clip(img, 0.0, 1.0) * 255.0).astype(np.uint8)


def png_bytes(img: np.ndarray, level: int = PNG_LEVEL) -> bytes:
    from PIL import Image

    q = to_8bit(img)
    buf = io.BytesIO()
    Image.fromarray(q[:, :, 0] if q.shape[2] == 1 else q).save(buf, format="PNG", compress_level=level)
    return buf.getvalue()


def _data_url(img: np.ndarray, side: int | None = None, nearest: bool = False) -> str:
    from PIL import Image

    q = to_8bit(img)
    im = Image.fromarray(q[:, :, 0] if q.shape[2] == 1 else q)
    if side is not None:
        k = side / max(im.size)
        size = (max(1, round(im.size[0] * k)), max(1, round(im.size[1] * k)))
        im = im.resize(size, Image.NEAREST if nearest else Image.LANCZOS)
    buf = io.BytesIO()
    im.save(buf, format="PNG")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def texton_picture(texton: Texton) -> np.ndarray:
    """The coefficients for viewing, in the texture's colours: the noise's mean plus
    the coefficients' deviations, ±3 standard deviations (shared by the channels) spanning ±0.45."""
    a = texton.coeffs.astype(np.float64)
    a = a - a.mean(axis=(0, 1))
    spread = 3.0 * float(a.std()) or 1.0
    return (texton.mean + 0.45 * a / spread).astype(np.float32)


def log_spectra(*spectra: np.ndarray, decades: float = 5.0) -> list[np.ndarray]:
    """Power spectra (H, W) as pictures on one log scale, zero frequency at the centre."""
    logs = [np.log10(np.fft.fftshift(np.maximum(s, 1e-30))) for s in spectra]
    top = max(float(v.max()) for v in logs)
    return [np.clip((v - (top - decades)) / decades, 0.0, 1.0)[:, :, None].astype(np.float32) for v in logs]


# ------------------------------------------------------------ commands
def _num(v: float) -> str:
    """A float as the shortest positional text that reads back as the same double
    (argparse takes "-0.000015" for a number but "-1.5e-05" for an option)."""
    return np.format_float_positional(float(v), unique=True, trim="0")


def _arg(v) -> str:
    return shlex.quote(_num(v) if isinstance(v, float) else str(v))


def _py(v) -> str:
    if isinstance(v, float):
        return _num(v)
    if isinstance(v, tuple):
        return "(" + ", ".join(_py(x) for x in v) + ")"
    return repr(v)


def _python(lines: list[str]) -> str:
    """The lines of a Python snippet with its ``from warp_texton import`` lines merged on top."""
    prefix = "from warp_texton import "
    names = sorted({n.strip() for ln in lines if ln.startswith(prefix) for n in ln[len(prefix):].split(",")})
    head = [ln for ln in lines if ln.startswith("import ")]
    body = [ln for ln in lines if not ln.startswith((prefix, "import "))]
    return "\n".join(head + [prefix + ", ".join(names)] + body)


def _load_expr(kind: str, path: str) -> str:
    return f"load_texton({path!r})" if kind == "texton" else f"read_image({path!r})"


def _pycall(fn: str, *args, **kwargs) -> str:
    parts = [*args, *(f"{k}={v}" for k, v in kwargs.items())]
    return f"{fn}({', '.join(parts)})"


# ---------------------------------------------------------------- viewer
class Viewer:
    """Everything the page can ask for, without HTTP: tiles, plane views, exports
    and the side panel, from one input (and optional second inputs for mixing).

    Thread-safe: computations are limited to ``slots`` at a time; analyses and
    tiles are cached (LRU) and computed once however many requests ask for them.
    """

    def __init__(self, input, *, mix=None, device=None, analysis: Analysis = Analysis(),
                 noise: Noise = Noise(), slots: int = 2, cache_bytes: int = 256 << 20, png_level: int = PNG_LEVEL):
        self.source = load_source(input)
        self.png_level = png_level
        self.device = device
        self.defaults = (analysis, noise)
        self._slots = threading.BoundedSemaphore(slots)
        self._waiting = 0
        self._waiting_lock = threading.Lock()
        self._textons = Memo(16)
        self._mixes = Memo(4)
        self._panels = Memo(16)
        self._images = Memo(cache_bytes, weight=len)
        self._uploads: OrderedDict[str, Source] = OrderedDict()
        self._uploads_lock = threading.Lock()
        if mix is not None:
            b = load_source(mix, "mix")
            self._uploads[b.digest] = b
            self.start_b = b.digest
        else:
            self.start_b = None
        # an input that cannot be analysed with the start settings fails now, not in the page
        texton = self.texton(analysis)
        self.src = digest(self.source.digest, __version__, device or "default")
        self._warm_up(texton)
        self.workdir = Path(tempfile.mkdtemp(prefix="warp-texton-view-"))

    def close(self) -> None:
        shutil.rmtree(self.workdir, ignore_errors=True)

    # -- inputs
    def _warm_up(self, texton: Texton) -> None:
        """Compile the kernel modules before the first request needs them."""
        synthesize(texton, (8, 8), device=self.device)
        synthesize(texton, (8, 8), scale=0.1, filter="anisotropic", device=self.device)

    def texton(self, analysis: Analysis) -> Texton:
        if self.source.texton is not None:
            return self.source.texton
        return self._textons.get(analysis, lambda: self._analyze(analysis))

    def _analyze(self, a: Analysis) -> Texton:
        texton = analyze(self.source.image, size=a.size, order=a.order, seed=ANALYSIS_SEED,
                         color_correction=a.color_correction)
        texton.metadata["source"] = self.source.name
        return texton

    def add_upload(self, data: bytes, name: str) -> Source:
        b = decode_upload(data, _safe_name(name), self.workdir)
        with self._uploads_lock:
            self._uploads[b.digest] = b
            self._uploads.move_to_end(b.digest)
            while len(self._uploads) > MAX_UPLOADS + (self.start_b is not None):
                oldest = next(k for k in self._uploads if k != self.start_b)
                del self._uploads[oldest]
        return b

    def second(self, digest: str) -> Source:
        with self._uploads_lock:
            b = self._uploads.get(digest)
        if b is None:
            raise BadRequest(f"unknown second input {digest!r}: upload it again", 404)
        return b

    def mixed_textons(self, analysis: Analysis, mix: Mix) -> list[Texton]:
        b = self.second(mix.b)

        def compute():
            a = self.source.texton if self.source.texton is not None else self.source.image
            v = b.texton if b.texton is not None else b.image
            return mix_textons(a, v, np.linspace(0.0, 1.0, mix.steps), size=analysis.size, order=analysis.order,
                               seed=ANALYSIS_SEED, color_correction=analysis.color_correction)

        return self._mixes.get((analysis, mix.b, mix.steps), compute)

    # -- work
    def _compute(self, alive, fn):
        """Run ``fn`` in a computation slot; give up if the client has gone meanwhile."""
        with self._waiting_lock:
            if self._waiting >= MAX_WAITING:
                raise BadRequest(f"busy: {MAX_WAITING} requests are already waiting", 503)
            self._waiting += 1
        try:
            with self._slots:
                if alive is not None and not alive():
                    raise ClientGone()
                return fn()
        finally:
            with self._waiting_lock:
                self._waiting -= 1

    def tile(self, tile: Tile, analysis: Analysis, noise: Noise, mix: Mix | None = None) -> np.ndarray:
        """The float32 (T, T, C) values of a tile."""
        if mix is None:
            w = tile_window(tile, noise)
            return synthesize(self.texton(analysis), w.shape, noise.mni, noise.seed, w.scale, w.rotation, w.offset,
                              device=self.device, filter=noise.filter)
        return self.mixed_tile(tile, analysis, noise, mix)

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
        out = synthesize_mixed(textons, rho, (t, w), noise.mni, noise.seed, s, (j0 / s, tile.y * t / s),
                               device=self.device)
        return np.ascontiguousarray(out[:, left:left + t])

    # -- requests: the query of a GET whose src was checked -> (key, make(alive) -> PNG bytes);
    #    the image is a pure function of its key (and of the input), so the key makes its ETag
    def tile_request(self, q: Query):
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
            key, alive, lambda: png_bytes(self.tile(tile, analysis, noise, mix), self.png_level))

    def plane_request(self, q: Query):
        analysis = parse_analysis(q, self.defaults[0])
        noise = parse_noise(q, self.defaults[1], rotation=False)
        plane = parse_plane(q)
        q.finish()
        key = ("plane", plane, self._analysis_key(analysis), noise)
        return key, lambda alive: self._memo_image(
            key, alive, lambda: png_bytes(self.plane(plane, analysis, noise), self.png_level))

    def panel_request(self, q: Query) -> dict:
        analysis = parse_analysis(q, self.defaults[0])
        seed = q.integer("seed", 0, 2**32 - 1, default=0)
        q.finish()
        return self.panel(analysis, seed)

    def _analysis_key(self, analysis: Analysis) -> Analysis | None:
        """Analysis settings change nothing when the input is a texton file."""
        return analysis if self.source.texton is None else None

    def _memo_image(self, key, alive, make) -> bytes:
        for _ in range(2):  # a shared computation whose first asker left is retried once
            try:
                return self._images.get(key, lambda: self._compute(alive, make))
            except ClientGone:
                if alive is None or not alive():
                    raise
        raise ClientGone()

    def plane(self, plane: Plane, analysis: Analysis, noise: Noise) -> np.ndarray:
        return render_plane(self.texton(analysis), (plane.height, plane.width), height=plane.camera_height,
                            tilt=plane.tilt, fov=plane.fov, texel_size=plane.texel_size, mni=noise.mni,
                            seed=noise.seed, filter=noise.filter, device=self.device)

    # -- side panel
    def panel(self, analysis: Analysis, seed: int) -> dict:
        key = (self._analysis_key(analysis), seed)
        return self._panels.get(key, lambda: self._compute(None, lambda: self._panel(analysis, seed)))

    def _panel(self, analysis: Analysis, seed: int) -> dict:
        texton = self.texton(analysis)
        r, s = texton.size
        info = {"texton": _data_url(texton_picture(texton), 160, nearest=True),
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
            info["input"] = _data_url(u, 256)
            info["gaussian"] = _data_url(gaussian_texture(u, seed=seed), 256)
            info["input_size"] = [u.shape[1], u.shape[0]]
        else:
            gh = gw = max(64, 1 << math.ceil(math.log2(2 * max(r, s))))
            model = None
        grid = (max(gh, r), max(gw, s))
        noise_model = (np.abs(texton.spectrum(grid)) ** 2).sum(axis=2)
        # the noise's periodogram, averaged over 4 windows: its expectation is |α̂|² b̂ (CGF eq. (4))
        measured = np.zeros(grid)
        for k in range(4):
            g = synthesize(texton, grid, 30.0, seed, offset=(k * 10.0 * grid[1], 0.0), device=self.device)
            g = g.astype(np.float64) - g.mean(axis=(0, 1))
            measured += (np.abs(np.fft.fft2(g, axes=(0, 1))) ** 2).sum(axis=2) / (grid[0] * grid[1] * 4)
        pictures = log_spectra(*([] if model is None else [model]), noise_model, measured)
        names = ([] if model is None else ["spectrum_input"]) + ["spectrum_texton", "spectrum_noise"]
        for name, pic in zip(names, pictures):
            info[name] = _data_url(pic, 160)
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
            return Export(name, self._plan_plane(name, plane, analysis, noise),
                          lambda: self.plane(plane, analysis, noise))
        if mode == "mix":
            noise = parse_noise(q, self.defaults[1], rotation=False)
            mix = parse_mix(q)
            w, h = parse_size(q)
            scale = q.number("scale", 2.0 ** MIX_ZOOM[0], 2.0 ** (MIX_ZOOM[1] + ENLARGE))
            corner = (q.number("left", -MAX_REACH, MAX_REACH), q.number("top", -MAX_REACH, MAX_REACH))
            q.finish()
            name = f"mix_{w}x{h}_seed{noise.seed}.{fmt}"
            plan = self._plan_mix(name, (h, w), scale, corner, analysis, noise, mix)

            def make():
                x = corner[0] + (np.arange(w) + 0.5) / scale
                rho = np.broadcast_to(mix.rho(x)[None, :], (h, w))
                return synthesize_mixed(self.mixed_textons(analysis, mix), rho, (h, w), noise.mni, noise.seed,
                                        scale, corner, device=self.device)

            return Export(name, plan, make)
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

        def make():
            return synthesize(self.texton(analysis), window.shape, noise.mni, noise.seed, window.scale,
                              window.rotation, window.offset, window.period, device=self.device,
                              filter=noise.filter)

        return Export(name, self._plan_noise(name, window, analysis, noise), make)

    def export_bytes(self, job: Export) -> bytes:
        """The file of an export, written by ``write_image`` as the CLI writes it."""
        def work():
            img = job.make()
            d = Path(tempfile.mkdtemp(dir=self.workdir))
            try:
                write_image(d / job.name, img)
                return (d / job.name).read_bytes()
            finally:
                shutil.rmtree(d, ignore_errors=True)

        return self._compute(None, work)

    def _texton_steps(self, analysis: Analysis) -> tuple[list[str], list[str], str]:
        """(CLI lines, Python lines, the CLI's texton argument) that give the texton."""
        src = self.source
        path = src.path or ("INPUT.exr" if src.kind == "texton" else "INPUT.png")
        if src.kind == "texton":
            return [], ["from warp_texton import load_texton", f"texton = load_texton({path!r})"], shlex.quote(path)
        stem = Path(src.name).stem or "input"
        cc = "" if analysis.color_correction else "_nocc"
        texton_file = f"{stem}_texton_{analysis.size}_o{analysis.order}{cc}.exr"
        cli = ["warp-texton", "analyze", shlex.quote(path), "-o", shlex.quote(texton_file),
               "--size", str(analysis.size), "--order", str(analysis.order), "--seed", str(ANALYSIS_SEED)]
        if not analysis.color_correction:
            cli.append("--no-color-correction")
        call = _pycall("analyze", f"read_image({path!r})", size=analysis.size, order=analysis.order,
                       seed=ANALYSIS_SEED, color_correction=analysis.color_correction)
        py = ["from warp_texton import analyze, read_image", f"texton = {call}"]
        return [" ".join(cli)], py, shlex.quote(texton_file)

    def _device_args(self) -> tuple[list[str], dict]:
        if self.device is None:
            return [], {}
        return ["--device", shlex.quote(str(self.device))], {"device": repr(str(self.device))}

    def _plan_noise(self, name: str, w: Window, analysis: Analysis, noise: Noise) -> dict:
        cli, py, texton_arg = self._texton_steps(analysis)
        dev_cli, dev_py = self._device_args()
        h, wd = w.shape
        line = ["warp-texton", "synthesize", texton_arg, "-o", shlex.quote(name), "--width", str(wd),
                "--height", str(h), "--mni", _arg(noise.mni), "--seed", str(noise.seed), "--scale", _arg(w.scale),
                "--rotation", _arg(w.rotation), "--offset", _arg(w.offset[0]), _arg(w.offset[1])]
        if w.period is not None:
            line += ["--period", _arg(w.period[0]), _arg(w.period[1])]
        line += ["--filter", noise.filter, *dev_cli]
        kwargs = dict(mni=_py(noise.mni), seed=noise.seed, scale=_py(w.scale), rotation=_py(w.rotation),
                      offset=_py(w.offset))
        if w.period is not None:
            kwargs["period"] = _py(w.period)
        kwargs.update(filter=repr(noise.filter), **dev_py)
        py = py + ["from warp_texton import synthesize, write_image",
                   f"image = {_pycall('synthesize', 'texton', _py(w.shape), **kwargs)}",
                   f"write_image({name!r}, image)"]
        return {"file": name, "width": wd, "height": h, "cli": cli + [" ".join(line)], "python": _python(py)}

    def _plan_plane(self, name: str, p: Plane, analysis: Analysis, noise: Noise) -> dict:
        cli, py, texton_arg = self._texton_steps(analysis)
        dev_cli, dev_py = self._device_args()
        line = ["warp-texton", "render-plane", texton_arg, "-o", shlex.quote(name), "--width", str(p.width),
                "--height", str(p.height), "--mni", _arg(noise.mni), "--seed", str(noise.seed),
                "--camera-height", _arg(p.camera_height), "--tilt", _arg(p.tilt), "--fov", _arg(p.fov),
                "--texel-size", _arg(p.texel_size), "--filter", noise.filter, *dev_cli]
        call = _pycall("render_plane", "texton", _py((p.height, p.width)), height=_py(p.camera_height),
                       tilt=_py(p.tilt), fov=_py(p.fov), texel_size=_py(p.texel_size), mni=_py(noise.mni),
                       seed=noise.seed, filter=repr(noise.filter), **dev_py)
        py = py + ["from warp_texton import render_plane, write_image", f"image = {call}",
                   f"write_image({name!r}, image)"]
        return {"file": name, "width": p.width, "height": p.height, "cli": cli + [" ".join(line)],
                "python": _python(py)}

    def _plan_mix(self, name: str, shape, scale: float, corner, analysis: Analysis, noise: Noise,
                  mix: Mix) -> dict:
        a = self.source
        b = self.second(mix.b)
        a_expr = _load_expr(a.kind, a.path or ("A.exr" if a.kind == "texton" else "A.png"))
        b_expr = _load_expr(b.kind, b.path or b.name)
        dev_py = self._device_args()[1]
        h, w = shape
        x0, start, end = _py(corner[0]), _py(mix.start), _py(mix.end)
        textons = _pycall("mix_textons", a_expr, b_expr, f"np.linspace(0.0, 1.0, {mix.steps})", size=analysis.size,
                          order=analysis.order, seed=ANALYSIS_SEED, color_correction=analysis.color_correction)
        image = _pycall("synthesize_mixed", "textons", "rho", _py((h, w)), mni=_py(noise.mni), seed=noise.seed,
                        scale=_py(scale), offset=_py(tuple(corner)), **dev_py)
        py = ["import numpy as np",
              "from warp_texton import load_texton, mix_textons, read_image, synthesize_mixed, write_image",
              f"textons = {textons}",
              f"# rho in noise space: 0 left of x = {start}, 1 right of x = {end}",
              f"x = {x0} + (np.arange({w}) + 0.5) / {_py(scale)}",
              f"rho = np.broadcast_to(np.clip((x - {start}) / ({end} - {start}), 0, 1), ({h}, {w}))",
              f"image = {image}",
              f"write_image({name!r}, image)"]
        return {"file": name, "width": w, "height": h,
                "cli": ["# no single warp-texton command: 'mix' takes its rho map from an image in the raster's "
                        "frame, this ramp lives in noise space; use the Python call"],
                "python": _python(py)}

    def info(self) -> dict:
        analysis, noise = self.defaults
        image = self.source.image
        with self._uploads_lock:
            start_b = self._uploads.get(self.start_b) if self.start_b else None
        return {
            "version": __version__, "src": self.src, "name": self.source.name, "kind": self.source.kind,
            "channels": (self.source.texton.channels if image is None else image.shape[2]),
            "input_size": None if image is None else [image.shape[1], image.shape[0]],
            "device": self.device,
            "defaults": {"size": analysis.size, "order": analysis.order, "cc": analysis.color_correction,
                         "seed": noise.seed, "mni": noise.mni, "filter": noise.filter},
            "bounds": {"zoom_min": ZOOM_MIN, "zoom_max": ZOOM_MAX, "enlarge": ENLARGE, "mix_zoom": list(MIX_ZOOM),
                       "mni": list(MNI_RANGE), "texton_size": list(TEXTON_SIZES), "orders": list(ORDERS),
                       "tile_sizes": list(TILE_SIZES), "mix_steps": list(MIX_STEPS), "export_side": MAX_EXPORT_SIDE,
                       "export_pixels": MAX_EXPORT_PIXELS, "plane_pixels": MAX_PLANE_PIXELS,
                       "filters": list(VIEW_FILTERS), "upload_bytes": MAX_UPLOAD_BYTES},
            "mix_b": None if start_b is None else {"id": start_b.digest, "name": start_b.name},
        }
