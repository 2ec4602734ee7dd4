"""Benchmark: which method for which texture — the quality of texton noise against its peers.

Over real textures of two kinds, Gaussian-like (scikit-image's grass and
gravel, GIMP's walnut, marble and Moonfoot) and structured (scikit-image's brick, GIMP's burlap weave
and leaves; the GIMP patterns when Debian's ``gimp-data`` is installed), each
method of ``METHODS`` makes one output from the example, and the output is
measured against it:

* **spectrum** — mean |Δ ln P| between the radial profiles of the periodograms
  of output and example (periodic components, per channel): 0 for the same
  spectrum, 0.69 for a factor of 2 at every frequency;
* **W1** — the 1-D Wasserstein distance between the marginal histograms of
  output and example, per channel (``scipy.stats.wasserstein_distance``),
  averaged over channels, in image units (values in [0, 1]);
* **clipped** — the fraction of pixels with a channel outside [0, 1], which an
  8-bit file clips;
* **repetition** — the largest normalised autocorrelation of the output off
  the origin (outside a small central radius): about 1 when a tile repeats,
  near 0 for white noise; the example's own value is given beside it;
* **time** — seconds per megapixel of output (best of ``--repeat``), and the
  one-off set-up (analysis, or the histogram transform) in seconds.

Methods (a row of ``METHODS`` each; a new method is one more row): texton
noise (``analyze`` then ``synthesize``), histogram-preserving texton noise
(``analyze(..., histogram="preserve")``), the FFT sample of the same Gaussian
model (``gaussian_texture``, the ADSN) and tiling and blending with the
histogram-preserving operator (``peers.TilingBlending``).

    python benchmarks/bench_quality.py            # full run → results/quality.{json,md}, docs/images/quality/
    python benchmarks/bench_quality.py --quick    # 2 textures, 256² outputs, nothing written
"""

from __future__ import annotations

import functools
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import scipy.fft as sfft
from scipy.stats import wasserstein_distance

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from common import GIMP_PATTERNS, machine_line, read_gpat, read_openarena, report_header, run_main  # noqa: E402

from warp_texton import analyze, gaussian_texture, periodic_component, synthesize  # noqa: E402
from warp_texton.files.images import atomic_path  # noqa: E402

GRID = HERE.parent / "docs" / "images" / "quality" / "grid.png"
#: Side of a panel of the image grid, in pixels of the outputs (shown 1:1).
PANEL = 256

# ---------------------------------------------------------------- metrics


def _channels(u) -> np.ndarray:
    u = np.asarray(u, np.float64)
    return u[:, :, None] if u.ndim == 2 else u


def radial_log_spectrum(u, bins: int) -> np.ndarray:
    """ln of the periodogram of u's periodic component averaged over ``bins`` rings, (C, bins).

    Rings of radius (0, ½] cycles per pixel, the DC left out; the periodogram
    |û|² / (H W) estimates the same spectral density at any image size. A ring
    without a frequency is NaN.
    """
    p = _channels(periodic_component(_channels(u)))
    h, w, c = p.shape
    power = np.abs(sfft.fft2(p - p.mean(axis=(0, 1)), axes=(0, 1))) ** 2 / (h * w)
    r = np.hypot(*np.meshgrid(sfft.fftfreq(h), sfft.fftfreq(w), indexing="ij"))
    ring = np.ceil(r / 0.5 * bins).astype(int) - 1  # (0, 0.5/bins] → ring 0; DC → −1
    keep = (ring >= 0) & (ring < bins)
    counts = np.bincount(ring[keep], minlength=bins)
    out = np.full((c, bins), np.nan)
    for k in range(c):
        sums = np.bincount(ring[keep], weights=power[..., k][keep], minlength=bins)
        with np.errstate(invalid="ignore", divide="ignore"):
            out[k] = np.log(sums / counts + 1e-30)
    return out


def spectrum_distance(u, v, bins: int | None = None) -> float:
    """Mean |ln P_u − ln P_v| over the rings of :func:`radial_log_spectrum` and the channels.

    ``bins`` defaults to a quarter of the smaller side of the two images (at most
    32), so that every ring of either holds frequencies.
    """
    if bins is None:
        bins = max(2, min(32, min(*np.shape(u)[:2], *np.shape(v)[:2]) // 4))
    a, b = radial_log_spectrum(u, bins), radial_log_spectrum(v, bins)
    if a.shape[0] != b.shape[0]:
        raise ValueError(f"channels differ: {a.shape[0]} and {b.shape[0]}")
    return float(np.nanmean(np.abs(a - b)))


def marginal_w1(u, v) -> list[float]:
    """The 1-D Wasserstein distance of the marginal histograms of u and v, per channel."""
    a, b = _channels(u), _channels(v)
    return [float(wasserstein_distance(a[..., k].ravel(), b[..., k].ravel())) for k in range(a.shape[2])]


def clipped_fraction(u) -> float:
    """The fraction of pixels with a channel outside [0, 1]."""
    a = _channels(u)
    return float(np.mean(np.any((a < 0.0) | (a > 1.0), axis=2)))


def autocorrelation(u) -> np.ndarray:
    """The normalised autocorrelation of u (mean removed, channels summed), lags |dy| ≤ H/2, |dx| ≤ W/2.

    Not circular: the image is zero-padded and each lag divided by the number of
    pixel pairs it overlaps, so a non-periodic image has no wrap-around peak.
    The result (H + 1 or so, W + 1 or so) is centred on lag 0, where it is 1.
    """
    a = _channels(u)
    a = a - a.mean(axis=(0, 1))
    h, w, _ = a.shape
    grid = (2 * h, 2 * w)
    f = sfft.rfft2(a, s=grid, axes=(0, 1))
    corr = sfft.irfft2((np.abs(f) ** 2).sum(axis=2), s=grid)
    dy, dx = sfft.fftfreq(2 * h, 1 / (2 * h)), sfft.fftfreq(2 * w, 1 / (2 * w))
    overlap = np.outer(h - np.abs(dy), w - np.abs(dx))
    corr = corr / np.maximum(overlap, 1)
    corr = sfft.fftshift(corr / corr[0, 0])
    cy, cx = h, w
    return corr[cy - h // 2:cy + h // 2 + 1, cx - w // 2:cx + w // 2 + 1]


def repetition(u, radius: float | None = None) -> float:
    """The largest peak of the normalised autocorrelation outside ``radius`` pixels of the origin.

    A peak is a local maximum (of its 3 × 3 neighbours), so the slope of a long
    correlation away from the origin does not count. About 1 when u repeats a
    tile, near 0 for white noise. ``radius`` defaults to a sixteenth of the
    smaller side (at least 4): within it, every texture is correlated with itself.
    """
    from scipy.ndimage import maximum_filter

    corr = autocorrelation(u)
    h, w = corr.shape
    if radius is None:
        radius = max(4.0, min(_channels(u).shape[:2]) / 16)
    yy, xx = np.meshgrid(np.arange(h) - h // 2, np.arange(w) - w // 2, indexing="ij")
    peaks = (corr == maximum_filter(corr, size=3, mode="nearest")) & (np.hypot(yy, xx) > radius)
    return float(corr[peaks].max()) if peaks.any() else 0.0


def measure(example, out, radius: float | None = None) -> dict:
    """Every metric of ``out`` against ``example`` (``radius``: that of :func:`repetition`)."""
    w1 = marginal_w1(out, example)
    return {"spectrum": spectrum_distance(out, example), "w1": float(np.mean(w1)), "w1_channels": w1,
            "clipped": clipped_fraction(out), "repetition": repetition(out, radius)}


# ---------------------------------------------------------------- textures


@dataclass(frozen=True)
class Texture:
    """An example: its name, kind, where it comes from, how to load it, whether it tiles."""

    name: str
    kind: str  # "Gaussian-like" or "structured"
    source: str
    load: Callable[[], np.ndarray]
    periodic: bool = False  # seamless: tiling and blending reads it wrapped

    def available(self) -> str | None:
        """None, or why the texture cannot be loaded here."""
        try:
            self.load()
        except (OSError, ValueError) as exc:
            return str(exc)
        return None


def _skimage(name: str) -> Callable[[], np.ndarray]:
    def load():
        from skimage import data

        return getattr(data, name)().astype(np.float32) / 255.0

    return load


def _gimp(path: str) -> Callable[[], np.ndarray]:
    return lambda: read_gpat(GIMP_PATTERNS / path)


def _openarena(member: str) -> Callable[[], np.ndarray]:
    return lambda: read_openarena(member)


OA = "openarena-081-textures, 512² RGB, GPL-2+"
TEXTURES = (
    Texture("grass", "Gaussian-like", "scikit-image, 512² grey, CC0", _skimage("grass")),
    Texture("gravel", "Gaussian-like", "scikit-image, 512² grey, CC0", _skimage("gravel")),
    Texture("walnut", "Gaussian-like", "GIMP Wood/walnut, 128² RGB, GPL-3+", _gimp("Wood/walnut.pat"), True),
    Texture("marble", "Gaussian-like", "GIMP Stone/marble1, grey, GPL-3+", _gimp("Stone/marble1.pat"), True),
    Texture("moonfoot", "Gaussian-like", "GIMP Stone/Moonfoot, grey, GPL-3+", _gimp("Stone/Moonfoot.pat"), True),
    Texture("sand", "Gaussian-like", f"{OA}: textures/acc_dm5/sand.jpg", _openarena("textures/acc_dm5/sand.jpg"), True),
    Texture("rock", "Gaussian-like", f"{OA}: textures/cosmo_block/rock01.jpg",
            _openarena("textures/cosmo_block/rock01.jpg"), True),
    Texture("lawn", "Gaussian-like", f"{OA}: textures/czest3ctf/grass_lush.tga",
            _openarena("textures/czest3ctf/grass_lush.tga"), True),
    Texture("wood", "Gaussian-like", f"{OA}: textures/acc_dm5/wood01.jpg", _openarena("textures/acc_dm5/wood01.jpg"), True),
    Texture("cliff", "Gaussian-like", f"{OA}: textures/stone/pjrock21.jpg", _openarena("textures/stone/pjrock21.jpg"), True),
    Texture("brick", "structured", "scikit-image, 512² grey, CC0", _skimage("brick")),
    Texture("burlap", "structured", "GIMP Fabric/burlap (a weave), 96² RGB, GPL-3+", _gimp("Fabric/burlap.pat"), True),
    Texture("leaves", "structured", "GIMP Plant/leaves, 50² RGB, GPL-3+", _gimp("Plant/leaves.pat"), True),
    Texture("tiles", "structured", f"{OA}: textures/clown/stone_tile.jpg",
            _openarena("textures/clown/stone_tile.jpg"), True),
)
QUICK_TEXTURES = ("grass", "brick")

# ---------------------------------------------------------------- methods


@dataclass(frozen=True)
class Setup:
    """What every method is given besides the example."""

    texton: int  # texton side (at most the example's smaller side)
    mni: float
    device: str
    periodic: bool  # the example tiles seamlessly


Sampler = Callable[[tuple, int], np.ndarray]  # (shape, seed) → (H, W, C) float32


def texton_noise(u: np.ndarray, setup: Setup, **analysis) -> Sampler:
    """``analyze`` (keyword arguments ``analysis`` added), then ``synthesize`` per output."""
    texton = analyze(u, size=min(setup.texton, *u.shape[:2]), seed=0, **analysis)
    return lambda shape, seed: synthesize(texton, shape, mni=setup.mni, seed=seed, device=setup.device)


def fft_sample(u: np.ndarray, setup: Setup) -> Sampler:
    """``gaussian_texture``: the ADSN of the example's Gaussian model (all of it per output)."""
    return lambda shape, seed: gaussian_texture(u, shape, seed=seed)


def tiling_blending(u: np.ndarray, setup: Setup) -> Sampler:
    """``peers.TilingBlending``: the histogram transform once, then each output."""
    from benchmarks.peers import TilingBlending

    tb = TilingBlending(u, periodic=setup.periodic)
    return lambda shape, seed: tb(shape, seed=seed)


@dataclass(frozen=True)
class Method:
    """A row of the comparison: its name, how it prepares an example, whether it runs on the host only."""

    name: str
    prepare: Callable[[np.ndarray, Setup], Sampler]
    host: bool  # NumPy on the host whatever the device


#: The methods compared, in table order.
METHODS = (
    Method("texton noise", texton_noise, host=False),
    Method("texton noise (preserve)", functools.partial(texton_noise, histogram="preserve"), host=False),
    Method("FFT sample", fft_sample, host=True),
    Method("tiling and blending", tiling_blending, host=True),
)

# ---------------------------------------------------------------- the run


def compare(textures, methods, shape, *, texton: int, mni: float, device: str, repeat: int,
            seed: int = 1, log=print) -> tuple[list[dict], dict]:
    """Measure each method on each texture; returns the rows and the images {texture: {column: image}}.

    Each method prepares once (timed: ``setup_s``), makes the measured output with
    ``seed``, then is timed ``repeat`` times, the methods taking turns.
    """
    h, w = shape
    radius = max(4.0, min(shape) / 16)  # one radius for the outputs and the examples
    rows, images = [], {}
    for tex in textures:
        u = tex.load()
        setup = Setup(texton=texton, mni=mni, device=device, periodic=tex.periodic)
        base = {"texture": tex.name, "kind": tex.kind, "example": list(u.shape)}
        images[tex.name] = {"example": u}
        rows.append({**base, "method": "example", "repetition": repetition(u, radius)})
        samplers, setup_s = {}, {}
        for m in methods:
            t0 = time.perf_counter()
            samplers[m.name] = m.prepare(u, setup)
            setup_s[m.name] = time.perf_counter() - t0
        outs = {name: fn(shape, seed) for name, fn in samplers.items()}  # also warms every method up
        times: dict[str, list[float]] = {name: [] for name in samplers}
        for _ in range(repeat):
            for name, fn in samplers.items():
                t0 = time.perf_counter()
                fn(shape, seed + 1)
                times[name].append(time.perf_counter() - t0)
        for m in methods:
            out = outs[m.name]
            images[tex.name][m.name] = out
            row = {**base, "method": m.name, "device": "host" if m.host else device, "shape": [h, w],
                   **measure(u, out, radius), "setup_s": setup_s[m.name],
                   "s_per_mpix": min(times[m.name]) / (h * w / 1e6), "times_s": times[m.name]}
            rows.append(row)
            log(f"  {tex.name:8s} {m.name:22s} spectrum {row['spectrum']:.3f}  W1 {row['w1']:.4f}  "
                f"clipped {100 * row['clipped']:5.2f} %  repetition {row['repetition']:.3f}  "
                f"{row['s_per_mpix']:.3f} s/Mpix")
    return rows, images


def select(names=None) -> tuple[list[Texture], list[dict]]:
    """The textures of ``names`` (all by default) that load here, and why the others do not."""
    chosen = [t for t in TEXTURES if names is None or t.name in names]
    ok, skipped = [], []
    for t in chosen:
        why = t.available()
        if why is None:
            ok.append(t)
        else:
            skipped.append({"case": f"texture {t.name}", "reason": why})
    return ok, skipped


def grid(images: dict, path: Path, title: str) -> Path:
    """A PNG of the example and each method's output per texture, PANEL² each, 1:1."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    columns = list(next(iter(images.values())))
    fig, axes = plt.subplots(len(images), len(columns), figsize=(2.3 * len(columns), 2.4 * len(images)),
                             squeeze=False)
    for i, (name, row) in enumerate(images.items()):
        for j, col in enumerate(columns):
            ax = axes[i][j]
            img = np.clip(_channels(row[col]), 0.0, 1.0)
            img = img[:PANEL, :PANEL]  # outputs: the top-left corner; examples: as large as it fits
            canvas = np.full((PANEL, PANEL, img.shape[2]), 1.0)
            y0, x0 = (PANEL - img.shape[0]) // 2, (PANEL - img.shape[1]) // 2
            canvas[y0:y0 + img.shape[0], x0:x0 + img.shape[1]] = img
            ax.imshow(canvas[..., 0] if canvas.shape[2] == 1 else canvas, cmap="gray", vmin=0, vmax=1,
                      interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            if i == 0:
                ax.set_title(col, fontsize=9)
            if j == 0:
                ax.set_ylabel(name, fontsize=9)
    fig.suptitle(title, fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=72, format="png")
    plt.close(fig)
    return path


def run(args) -> dict:
    names = QUICK_TEXTURES if args.quick else None
    textures, skipped = select(names)
    shape = (256, 256) if args.quick else (512, 512)
    rows, images = compare(textures, METHODS, shape, texton=args.size, mni=args.mni, device=args.device,
                           repeat=args.repeat)
    report = {
        **report_header("quality", args.device),
        "parameters": {"shape": list(shape), "texton": args.size, "mni": args.mni, "order": 1, "seed": 1,
                       "repeat": args.repeat, "quick": args.quick, "methods": [m.name for m in METHODS],
                       "textures": {t.name: {"kind": t.kind, "source": t.source, "periodic": t.periodic}
                                    for t in textures}},
        "results": rows,
        "skipped": skipped,
    }
    if args.grid is not None or not args.quick:
        path = args.grid or GRID
        title = f"{report['machine']['processor']}, {report['date'][:10]}, commit {(report['git_commit'] or '?')[:10]}"
        print(f"wrote {grid(images, path, title)}")
    return report


def _cell(value, fmt: str) -> str:
    return "—" if value is None else format(value, fmt)


def table_lines(report: dict) -> list[str]:
    """The Markdown table of a report's rows (also the runner's quality section)."""
    lines = ["| texture | kind | method | spectrum | W1 | clipped | repetition | s / Mpix | set-up (s) |",
             "|---|---|---|---:|---:|---:|---:|---:|---:|"]
    for r in report["results"]:
        if r["method"] == "example":
            lines.append(f"| {r['texture']} | {r['kind']} | *example* ({r['example'][1]}×{r['example'][0]}) | "
                         f"0 | 0 | 0 | {r['repetition']:.3f} | | |")
            continue
        lines.append(f"| {r['texture']} | {r['kind']} | {r['method']} | {r['spectrum']:.3f} | {r['w1']:.4f} | "
                     f"{100 * r['clipped']:.2f} % | {r['repetition']:.3f} | {r['s_per_mpix']:.3f} | "
                     f"{r['setup_s']:.3f} |")
    return lines


def markdown(report: dict) -> str:
    p = report["parameters"]
    h, w = p["shape"]
    lines = [
        f"# Quality: texton noise against its peers ({report['date']})",
        "",
        machine_line(report),
        f"Outputs {w}×{h}, seed {p['seed']}; texton noise: texton {p['texton']}² (at most the example's side), "
        f"order {p['order']}, MNI {p['mni']:g}. spectrum: mean |Δ ln P| of the radial periodogram profiles; "
        "W1: Wasserstein distance of the marginal histograms, mean over channels; clipped: pixels with a channel "
        "outside [0, 1]; repetition: largest normalised autocorrelation off the origin (the example's own on its "
        f"row); s / Mpix: best of {p['repeat']}.",
        "",
        *table_lines(report),
    ]
    if report["skipped"]:
        lines += ["", *[f"* not measured: {s['case']} ({s['reason']})" for s in report["skipped"]]]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:

    def extra(parser):
        parser.add_argument("--grid", type=Path, default=None,
                            help=f"PNG of the image grid; default {GRID.relative_to(HERE.parent)} "
                                 "(none with --quick)")

    return run_main(__doc__, "quality", run, markdown, argv, repeat=3, extra_args=extra)


if __name__ == "__main__":
    sys.exit(main())
