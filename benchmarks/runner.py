"""The CPU/GPU benchmark runner: ``python -m benchmarks``.

Times, on each device asked for, the texton analysis, 2-D texton noise
(``synthesize``), filtering, surface noise and mixing, with the peers measured
in the same run and interleaved with texton noise so that all see the same
machine load (see ``peers.py``):

* the FFT sample of the same Gaussian model (the spectral method) and the
  discrete spot noise (``warp_texton.dsn``), NumPy on the host;
* Warp's built-in Perlin noise ``wp.pnoise``, the cost floor of a procedural
  noise, on the same device;
* FastNoiseLite's OpenSimplex2 frame (``pyfastnoiselite``'s ``gen_from_coords``,
  one thread, host), against a grey and an RGB texton's frame (1920×1080,
  MNI 30, texton 64²), with the ratios;
* a naive per-pixel texton noise (``evaluate`` at every pixel centre, no
  shared impacts), to show what drawing the impacts once per raster gains.

A bake with its UV atlas is timed against a re-bake from the UVs it made
(``bench_atlas.py``: a torus at 256² in the quick suite, the Stanford bunny at
1024² in the full one).

Then, once (on the first device), the quality of texton noise against the FFT
sample and tiling and blending on real textures (``bench_quality.py``:
spectrum, marginal histograms, clipped pixels, repetition, time per megapixel;
grass and brick at 256² in the quick suite, every texture at 512² in the full),
and the viewer's frame time in headless Chromium, its WebGL2 mode against its
tiles (``bench_viewer_webgl.py``: a 1280×720 canvas, 320×180 in the quick suite).
The tiling model against tiling and blending read wrapped and not, on seamless and
regular examples (``bench_seamless.py``: patch distance, lattice kept, residual
repetition; three small examples in the quick suite, the synthetic lattices in the
full one: the photograph sets run from the script), and the method advice against
labels (``bench_advice.py``, the quick suite's three small examples).

Two parameter sets: ``--quick`` (CI smoke run: 256² and 512², MNI 30, texton
32², one run each) and the full one (256² to 3840×2160, MNI 5 to 60, textons
16² to 128², best of 5). Writes ``runner.json`` (machine, devices, Warp
version, date, git commit, every timing), ``runner.md`` (tables) and PNG plots
of time against output size, MNI and texton size into ``--out``.

    python -m benchmarks                       # full run, every device, benchmarks/results/runner/
    python -m benchmarks --quick --out /tmp/b  # smoke run (CI)
    python -m benchmarks --device cuda:0
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import statistics
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from warp_texton.files.images import atomic_path

from .common import git_commit, git_dirty, machine_info, make_texture, write_atomic

HERE = Path(__file__).resolve().parent
DEFAULT_OUT = HERE / "results" / "runner"

#: Method names, in table order; HOST methods run on NumPy whatever the device.
TEXTON = "texton noise"
NAIVE = "naive per-pixel"
FFT = "FFT sample"
DSN = "DSN"
PERLIN = "wp.pnoise"
METHODS = (TEXTON, NAIVE, PERLIN, FFT, DSN)
#: The frame case's methods: texton noise from a grey and an RGB texton, FastNoiseLite.
GREY = "texton noise, grey"
RGB = "texton noise, RGB"
FNL = "FastNoiseLite OpenSimplex2"
FRAME_METHODS = (GREY, RGB, FNL)
HOST_METHODS = (FFT, DSN, FNL)
#: Surface noise needs more impacts than the plane (CGF §6); the package default.
SURFACE_MNI = 60.0


@dataclass(frozen=True)
class Suite:
    """One parameter set. Shapes are (height, width)."""

    name: str
    sizes: tuple  # output sizes at (ref_mni, ref_texton)
    mnis: tuple  # MNI sweep at (ref_shape, ref_texton)
    texton_sizes: tuple  # texton sweep at (ref_shape, ref_mni); also the analysis sizes
    ref_shape: tuple
    ref_mni: float
    ref_texton: int
    repeat: int
    image_side: int  # side of the RGB test texture the textons are analysed from
    naive_max_pixels: int  # the naive per-pixel peer is skipped above this
    mix_steps: int
    mix_sizes: tuple
    surface_subdivisions: int  # icosphere: 3 → 642 vertices, 6 → 40 962, 8 → 655 362
    surface_render: tuple  # (height, width) of the surface render
    quality_textures: tuple | None  # names of bench_quality.TEXTURES; None: all that load here
    quality_shape: tuple  # (height, width) of the quality outputs
    viewer_view: tuple = (1280, 720)  # (width, height) of the viewer's canvas, WebGL2 against tiles
    seamless_set: str = "quick"  # bench_seamless.py's examples: "quick" or one of its --set choices
    frame_shape: tuple = (1080, 1920)  # (height, width) of the grey/RGB/FastNoiseLite frames
    frame_texton: int = 64


QUICK = Suite(
    name="quick", sizes=((256, 256), (512, 512)), mnis=(30.0,), texton_sizes=(32,),
    ref_shape=(512, 512), ref_mni=30.0, ref_texton=32, repeat=1, image_side=256,
    naive_max_pixels=512 * 512, mix_steps=5, mix_sizes=((256, 256),),
    surface_subdivisions=3, surface_render=(128, 128),
    quality_textures=("grass", "brick"), quality_shape=(256, 256), viewer_view=(320, 180),
    frame_shape=(270, 480), frame_texton=32,
)
FULL = Suite(
    name="full", sizes=((256, 256), (512, 512), (1024, 1024), (2048, 2048), (2160, 3840)),
    mnis=(5.0, 10.0, 30.0, 60.0), texton_sizes=(16, 32, 64, 128),
    ref_shape=(1024, 1024), ref_mni=30.0, ref_texton=64, repeat=5, image_side=512,
    naive_max_pixels=1024 * 1024, mix_steps=21, mix_sizes=((1024, 1024), (2160, 3840)),
    surface_subdivisions=8, surface_render=(1024, 1024),
    quality_textures=None, quality_shape=(512, 512), seamless_set="synthetic",
)


@dataclass
class Report:
    """What a run measured, and what it could not."""

    rows: list = field(default_factory=list)
    skipped: list = field(default_factory=list)

    def add(self, **row):
        self.rows.append(row)

    def skip(self, case: str, reason: str):
        print(f"  skipped {case}: {reason}", flush=True)
        self.skipped.append({"case": case, "reason": reason})


def timings(times: list[float]) -> dict:
    return {"best_s": min(times), "median_s": statistics.median(times), "runs": len(times),
            "times_s": [round(t, 6) for t in times]}


def interleaved(methods: dict, repeat: int, caps: dict | None = None, cpu: bool = False) -> dict:
    """Best-of-``repeat`` timings of each callable, taking turns so that all see the same load.

    One untimed call of each first (kernel loading, FFT plans, first-touch
    pages). ``caps`` limits the timed runs of slow methods. ``cpu``: also the
    CPU time of the process (all its threads) of each run, as ``cpu``.
    """
    caps = caps or {}
    for fn in methods.values():
        fn()
    times: dict = {name: [] for name in methods}
    cpu_times: dict = {name: [] for name in methods}
    for r in range(repeat):
        for name, fn in methods.items():
            if r < caps.get(name, repeat):
                c0, t0 = time.process_time(), time.perf_counter()
                fn()
                times[name].append(time.perf_counter() - t0)
                cpu_times[name].append(time.process_time() - c0)
    if cpu:
        return {name: {**timings(t), "cpu": timings(cpu_times[name])} for name, t in times.items()}
    return {name: timings(t) for name, t in times.items()}


def resolve_devices(spec: str) -> list[str]:
    """``all`` → the CPU and every CUDA device present; else one checked device name."""
    from warp_texton.core.runtime import init_warp, resolve_device

    if spec != "all":
        return [resolve_device(spec)]
    wp = init_warp()
    return ["cpu"] + [f"cuda:{k}" for k in range(wp.get_cuda_device_count())]


def device_info(device: str) -> dict:
    from warp_texton.core.runtime import cpu_threads, init_warp

    d = init_warp().get_device(device)
    info = {"name": device, "description": getattr(d, "name", device)}
    if d.is_cpu:
        info["threads"] = cpu_threads()
    else:
        info["memory_gib"] = round(getattr(d, "total_memory", 0) / 2**30, 1)
        info["arch"] = getattr(d, "arch", None)
    return info


# ---------------------------------------------------------------- cases


def analysis_case(suite: Suite, u: np.ndarray, report: Report) -> dict:
    """``analyze`` of the test texture at each texton size (host, NumPy); returns the textons."""
    from warp_texton import analyze

    textons = {}
    print(f"analysis of a {suite.image_side}² RGB texture", flush=True)
    for size in sorted(set(suite.texton_sizes) | {suite.ref_texton}):
        def fn(size=size):
            textons[size] = analyze(u, size=size, seed=0)

        t = interleaved({"analysis": fn}, suite.repeat)["analysis"]
        report.add(case="analysis", method="analyze", device="host", texton=size,
                   image=[suite.image_side, suite.image_side, 3], **t)
        print(f"  texton {size}²: {t['best_s']:.3f} s", flush=True)
    return textons


def synthesis_cases(suite: Suite) -> list[dict]:
    """The (shape, mni, texton) points of the three sweeps, each once, with the sweeps it belongs to."""
    points = {}
    for shape in suite.sizes:
        points.setdefault((tuple(shape), suite.ref_mni, suite.ref_texton), []).append("size")
    for mni in suite.mnis:
        points.setdefault((tuple(suite.ref_shape), mni, suite.ref_texton), []).append("mni")
    for t in suite.texton_sizes:
        points.setdefault((tuple(suite.ref_shape), suite.ref_mni, t), []).append("texton")
    return [{"shape": s, "mni": m, "texton": t, "sweeps": sw} for (s, m, t), sw in points.items()]


def synthesis_case(suite: Suite, textons: dict, device: str, host_too: bool, report: Report) -> None:
    """2-D texton noise and its peers at every point of the sweeps, on one device."""
    from . import peers

    print(f"2-D synthesis on {device}", flush=True)
    for case in synthesis_cases(suite):
        shape, mni, texton = case["shape"], case["mni"], textons[case["texton"]]
        h, w = shape
        methods = {TEXTON: peers.TextonNoise(texton, shape, mni, device)}
        if h * w <= suite.naive_max_pixels or device != "cpu":  # slow on the CPU only
            methods[NAIVE] = peers.NaivePerPixel(texton, shape, mni, device)
        methods[PERLIN] = peers.PerlinRaster(shape, texton.channels, device)
        if host_too:
            methods[FFT] = peers.FFTSample(texton, shape)
            methods[DSN] = peers.DSNSample(texton, shape, mni)
        # the naive path is 30-60x slower: fewer runs keep the suite short
        results = interleaved(methods, suite.repeat, caps={NAIVE: min(suite.repeat, 2)})
        parts = []
        for name, t in results.items():
            report.add(case="synthesis", method=name, device="host" if name in HOST_METHODS else device,
                       shape=list(shape), mni=mni, texton=case["texton"], channels=texton.channels,
                       sweeps=case["sweeps"], mpix_per_s=h * w / t["best_s"] / 1e6, **t)
            parts.append(f"{name} {t['best_s']:.4f}")
        if NAIVE not in methods and "size" in case["sweeps"]:
            note = f"{w}x{h} is above {suite.naive_max_pixels} pixels"
            report.skip(f"naive per-pixel {w}x{h} on {device}", f"{note}; it is slow")
        print(f"  {w}x{h} MNI {mni:g} texton {case['texton']}²: " + ", ".join(parts) + " s", flush=True)


def frame_case(suite: Suite, u: np.ndarray, device: str, host_too: bool, cache: dict, report: Report) -> None:
    """One frame of texton noise from a grey texton and from an RGB one (the same
    texture, its grey mean for the first), and FastNoiseLite's OpenSimplex2 frame
    (host, one thread; skipped without pyfastnoiselite), interleaved; the ratios
    grey / RGB and grey / FastNoiseLite."""
    from warp_texton import analyze

    from . import peers

    h, w = suite.frame_shape
    size = suite.frame_texton
    if "frame" not in cache:
        grey = np.ascontiguousarray(u.mean(axis=2, keepdims=True))
        cache["frame"] = (analyze(grey, size=size, seed=0), analyze(u, size=size, seed=0))
    grey_t, rgb_t = cache["frame"]
    methods = {GREY: peers.TextonNoise(grey_t, (h, w), suite.ref_mni, device),
               RGB: peers.TextonNoise(rgb_t, (h, w), suite.ref_mni, device)}
    missing = peers.fastnoiselite_missing()
    if host_too and missing is None:
        methods[FNL] = peers.FastNoiseLiteFrame((h, w))
    elif host_too:
        report.skip("FastNoiseLite frame", missing)
    print(f"frames on {device}: {w}x{h}, MNI {suite.ref_mni:g}, texton {size}²", flush=True)
    results = interleaved(methods, suite.repeat, cpu=True)
    for name, t in results.items():
        report.add(case="frame", method=name, device="host" if name in HOST_METHODS else device, shape=[h, w],
                   mni=suite.ref_mni, texton=size, channels=1 if name != RGB else 3,
                   mpix_per_s=h * w / t["best_s"] / 1e6, **t)
    line = ", ".join(f"{name} {t['best_s'] * 1e3:.1f} ms (CPU {t['cpu']['best_s'] * 1e3:.1f} ms)"
                     for name, t in results.items())
    g = results[GREY]["best_s"]
    line += f"; grey / RGB {g / results[RGB]['best_s']:.2f}"
    fnl = results.get(FNL) or _find(report.rows, case="frame", method=FNL, shape=[h, w])
    if fnl is not None:
        line += f", grey / FastNoiseLite {g / fnl['best_s']:.2f}, RGB / FastNoiseLite " \
                f"{results[RGB]['best_s'] / fnl['best_s']:.2f}"
    print("  " + line, flush=True)


def mixing_case(suite: Suite, u: np.ndarray, device: str, textons_cache: dict, report: Report) -> None:
    """``synthesize_mixed`` over ``mix_steps`` textons in strips vs ``synthesize`` with one."""
    from warp_texton import mix_textons, synthesize, synthesize_mixed

    print(f"mixing on {device}", flush=True)
    if "mix" not in textons_cache:
        v = np.ascontiguousarray(u.transpose(1, 0, 2)[:, :, ::-1])  # the same material turned 90°
        t0 = time.perf_counter()
        textons_cache["mix"] = mix_textons(u, v, np.linspace(0.0, 1.0, suite.mix_steps),
                                           size=suite.ref_texton, seed=0)
        seconds = time.perf_counter() - t0
        report.add(case="mixing", method="mix_textons", device="host", steps=suite.mix_steps,
                   texton=suite.ref_texton, **timings([seconds]))
        print(f"  mix_textons, {suite.mix_steps} textons of {suite.ref_texton}²: {seconds:.2f} s", flush=True)
    textons = textons_cache["mix"]
    for shape in suite.mix_sizes:
        h, w = shape
        methods = {
            "synthesize_mixed": lambda: synthesize_mixed(textons, "strips", shape, mni=suite.ref_mni,
                                                         seed=1, device=device),
            "synthesize": lambda: synthesize(textons[len(textons) // 2], shape, mni=suite.ref_mni,
                                             seed=1, device=device),
        }
        results = interleaved(methods, suite.repeat)
        for name, t in results.items():
            report.add(case="mixing", method=name, device=device, shape=list(shape), mni=suite.ref_mni,
                       steps=suite.mix_steps, texton=suite.ref_texton, mpix_per_s=h * w / t["best_s"] / 1e6, **t)
        ratio = results["synthesize_mixed"]["best_s"] / results["synthesize"]["best_s"]
        print(f"  {w}x{h}: mixed {results['synthesize_mixed']['best_s']:.4f} s, "
              f"plain {results['synthesize']['best_s']:.4f} s, ratio {ratio:.2f}", flush=True)


def filtering_case(suite: Suite, textons: dict, device: str, report: Report) -> None:
    """Anti-aliased noise on a plane in perspective (CGF §5): ``render_plane`` with
    "none", "mip" and "anisotropic" at the reference size, the view of
    bench_filtering.py, and each filter's RMSE against an 8×8 supersampled
    reference on every 8th row and column of the far half.
    """
    from .bench_filtering import far_half_sample, plane_view

    from warp_texton import FilterOptions
    from warp_texton.noise.ground_plane import plane_pixels

    texton = textons[suite.ref_texton]
    side = suite.ref_shape[0]
    view = plane_view(side)
    every = np.arange(side * side)
    kw = dict(mni=suite.ref_mni, seed=1, device=device)
    print(f"filtering on {device}: plane {side}x{side}", flush=True)
    sample = far_half_sample(view, 8)
    ref = plane_pixels(texton, view, sample, filter=FilterOptions("supersample", supersample=8), **kw)
    images = {}

    def render(f):
        images[f] = plane_pixels(texton, view, every, filter=f, **kw)

    methods = {f: (lambda f=f: render(f)) for f in ("none", "mip", "anisotropic")}
    results = interleaved(methods, suite.repeat)
    err = {f: float(np.sqrt(np.mean((images[f][sample] - ref) ** 2))) for f in methods}
    for f, t in results.items():
        report.add(case="filtering", method=f, device=device, shape=[side, side], mni=suite.ref_mni,
                   texton=suite.ref_texton, cost=t["best_s"] / results["none"]["best_s"],
                   error_ratio=err[f] / err["none"], **t)
        print(f"  {f}: {t['best_s']:.4f} s (x{t['best_s'] / results['none']['best_s']:.2f}), "
              f"error x{err[f] / err['none']:.3f} of unfiltered", flush=True)


def surface_case(suite: Suite, textons: dict, device: str, report: Report) -> None:
    """Surface noise on meshes (CGF §6): ``surface_noise`` points per second at
    MNI 60 at the vertices of an icosphere, in blocks and with the per-point walk
    (the reference), against a ``synthesize`` raster (MNI 30) of the same texton
    measured in the same turns; and one ``render_mesh`` frame, blocks and walk; and
    ``surface_noise`` of a grey texton (the first channel of the same texton: one float
    a texel through the kernels), with the ratio grey / RGB.
    """
    import trimesh

    from warp_texton import Texton, render_mesh, surface_noise, synthesize

    from warp_texton import analyze

    texton = textons[suite.ref_texton]
    tiling = analyze(make_texture(suite.image_side), method="tiling")  # triplanar on surfaces (docs/tiling.md)
    grey = Texton(np.ascontiguousarray(texton.coeffs[..., :1]), texton.mean[:1], order=texton.order)
    # unit sphere, 128 texels per unit: about 800 texels round the equator
    mesh = trimesh.creation.icosphere(subdivisions=suite.surface_subdivisions, radius=1.0)
    texel = 1.0 / 128.0
    vertices, normals = mesh.vertices, mesh.vertex_normals
    nv = len(vertices)
    rh, rw = suite.ref_shape
    print(f"surface on {device}: icosphere of {nv} vertices, render {suite.surface_render[1]}x"
          f"{suite.surface_render[0]}", flush=True)
    methods = {
        "surface_noise": lambda: surface_noise(texton, vertices, normals, texel, mni=SURFACE_MNI, seed=1,
                                               device=device),
        "surface_noise (walk)": lambda: surface_noise(texton, vertices, normals, texel, mni=SURFACE_MNI, seed=1,
                                                      device=device, method="points"),
        "surface_noise (tiling)": lambda: surface_noise(tiling, vertices, normals, texel, seed=1, device=device),
        "surface_noise (grey)": lambda: surface_noise(grey, vertices, normals, texel, mni=SURFACE_MNI, seed=1,
                                                      device=device),
        "synthesize": lambda: synthesize(texton, suite.ref_shape, mni=suite.ref_mni, seed=1, device=device),
        "render_mesh": lambda: render_mesh(mesh, texton, suite.surface_render, texel_size=texel, mni=SURFACE_MNI, seed=1,
                                           device=device),
        "render_mesh (walk)": lambda: render_mesh(mesh, texton, suite.surface_render, texel_size=texel, mni=SURFACE_MNI,
                                                  seed=1, device=device, method="points"),
    }
    results = interleaved(methods, suite.repeat)
    raster = results["synthesize"]
    per_pixel = raster["best_s"] / (rh * rw)
    for name in ("surface_noise", "surface_noise (walk)", "surface_noise (grey)", "surface_noise (tiling)"):
        t = results[name]
        report.add(case="surface", method=name, device=device, vertices=nv, mni=SURFACE_MNI,
                   texton=suite.ref_texton, mpoints_per_s=nv / t["best_s"] / 1e6,
                   vs_raster_pixel=t["best_s"] / nv / per_pixel, **t)
    report.add(case="surface", method="synthesize", device=device, shape=[rh, rw], mni=suite.ref_mni,
               texton=suite.ref_texton, mpix_per_s=rh * rw / raster["best_s"] / 1e6, **raster)
    h, w = suite.surface_render
    for name in ("render_mesh", "render_mesh (walk)"):
        r = results[name]
        report.add(case="surface", method=name, device=device, vertices=nv, mni=SURFACE_MNI,
                   texton=suite.ref_texton, shape=[h, w], mpix_per_s=h * w / r["best_s"] / 1e6, **r)
    t, r = results["surface_noise"], results["render_mesh"]
    print(f"  surface_noise: {t['best_s']:.4f} s ({nv / t['best_s'] / 1e6:.2f} Mpoints/s, x"
          f"{t['best_s'] / nv / per_pixel:.1f} a raster pixel; walk x"
          f"{results['surface_noise (walk)']['best_s'] / t['best_s']:.2f} slower; grey / RGB "
          f"{results['surface_noise (grey)']['best_s'] / t['best_s']:.2f}); render_mesh {w}x{h}: "
          f"{r['best_s']:.4f} s (walk x{results['render_mesh (walk)']['best_s'] / r['best_s']:.2f} slower)",
          flush=True)


def atlas_case(suite: Suite, textons: dict, device: str, report: Report) -> None:
    """A bake with its UV atlas (normal charts packed by xatlas) against a re-bake from the UVs it
    made, measured in turns (``bench_atlas.py``; its full run adds xatlas's own charting)."""
    import importlib.util

    if importlib.util.find_spec("xatlas") is None:
        report.skip("atlas", "xatlas is not installed (pip install 'warp-texton[mesh]')")
        return
    from . import bench_atlas

    mesh, name, res = bench_atlas.subject(suite.name == "quick")
    print(f"atlas on {device}: {name}, {len(mesh.faces)} faces at {res}²", flush=True)
    (row,) = bench_atlas.measure(textons[suite.ref_texton], mesh, res, device, repeat=suite.repeat,
                                 mni=SURFACE_MNI, chartings=("normals",))
    report.add(case="atlas", method="bake_mesh", device=device, mesh=name, faces=len(mesh.faces), resolution=res,
               **row)
    print(f"  bake {row['bake_s']:.2f} s, re-bake {row['rebake_s']:.2f} s (x{row['ratio']:.2f}), coverage "
          f"{100 * row['coverage']:.1f} %", flush=True)


def quality_case(suite: Suite, device: str, report: Report) -> None:
    """Which method for which texture: ``bench_quality.compare`` of texton noise and its
    peers on real textures (spectrum, marginals, clipping, repetition, time)."""
    from . import bench_quality

    textures, skipped = bench_quality.select(suite.quality_textures)
    for s in skipped:
        report.skip(s["case"], s["reason"])
    h, w = suite.quality_shape
    print(f"quality on {device}: {len(textures)} textures, outputs {w}x{h}", flush=True)
    rows, _ = bench_quality.compare(textures, bench_quality.METHODS, suite.quality_shape, texton=suite.ref_texton,
                                    mni=suite.ref_mni, device=device, repeat=suite.repeat)
    for r in rows:
        report.add(case="quality", **r)


def seamless_case(suite: Suite, report: Report) -> None:
    """The tiling model against tiling and blending read wrapped and not (``bench_seamless.py``), and the
    method advice against its labels (``bench_advice.py``, quick examples, labels not cached); host
    analyses, the package's outputs on the CPU."""
    from . import bench_advice, bench_seamless

    quick = suite.seamless_set == "quick"
    examples, skipped = bench_seamless.examples_of(suite.seamless_set, quick)
    shape = bench_seamless.QUICK_SHAPE if quick else bench_seamless.SHAPE
    seeds = bench_seamless.SEEDS[:1] if quick else bench_seamless.SEEDS
    print(f"seamless and regular examples: {len(examples)}, outputs {shape[1]}x{shape[0]}", flush=True)
    for row in bench_seamless.collect(examples, shape, seeds, skipped):
        report.add(case="seamless", method="bench_seamless", device="cpu", **row)
    examples, more = bench_advice.examples_of("all", True)
    skipped += more
    print(f"method advice: {len(examples)} examples", flush=True)
    rows, scores = bench_advice.collect(examples, bench_advice.QUICK_SHAPE, bench_advice.SEEDS[:1], skipped)
    for row in rows:
        report.add(case="advice", method="bench_advice", device="cpu", **row)
    report.add(case="advice agreement", method="bench_advice", device="cpu", agreement=scores)
    for s in skipped:
        report.skip(s["case"], s["reason"])


def viewer_case(suite: Suite, device: str, report: Report) -> None:
    """The viewer's frame time in headless Chromium: its WebGL2 mode against its tiles
    (``bench_viewer_webgl.py``; the server computes the tiles on ``device``)."""
    from . import bench_viewer_webgl

    why = bench_viewer_webgl.available()
    if why is not None:
        report.skip("viewer: WebGL2 against tiles", why)
        return
    quick = suite.name == "quick"
    print(f"viewer on {device}: a {suite.viewer_view[0]}x{suite.viewer_view[1]} canvas in Chromium", flush=True)
    r = bench_viewer_webgl.measure(suite.viewer_view, frames=2 if quick else 5, runs=max(2, suite.repeat),
                                   texton=suite.ref_texton, mni=suite.ref_mni, image_side=suite.image_side,
                                   device=device)
    report.add(case="viewer", **r)
    print(f"  WebGL2 {r['webgl']['mean_ms']:.0f} ms a frame ({r['renderer']}); tiles cold "
          f"{r['tiles_cold']['mean_ms']:.0f} ms, warm {r['tiles_warm']['mean_ms']:.0f} ms", flush=True)


# ---------------------------------------------------------------- the run


def run(suite: Suite, devices: list[str]) -> dict:
    import warp

    commit, dirty = git_commit(), git_dirty()  # the checkout as the code was imported
    start = time.perf_counter()
    report = Report()
    u = make_texture(suite.image_side)
    textons = analysis_case(suite, u, report)
    cache = {}
    for k, device in enumerate(devices):
        synthesis_case(suite, textons, device, host_too=(k == 0), report=report)
        frame_case(suite, u, device, host_too=(k == 0), cache=cache, report=report)
        filtering_case(suite, textons, device, report)
        surface_case(suite, textons, device, report)
        mixing_case(suite, u, device, cache, report)
        atlas_case(suite, textons, device, report)
    quality_case(suite, devices[0], report)  # the measures do not depend on the device
    seamless_case(suite, report)
    viewer_case(suite, devices[0], report)
    machine = machine_info()
    machine["threads"] = os.cpu_count()
    return {
        "benchmark": "runner",
        "suite": suite.name,
        "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "git_commit": commit,
        "git_dirty": dirty,
        "machine": machine,
        "warp": warp.config.version,
        "devices": [device_info(d) for d in devices],
        "parameters": {**asdict(suite), "texture": "skimage grass/gravel/brick mixed to RGB (CC0)",
                       "order": 1, "seed": 1},
        "seconds": round(time.perf_counter() - start, 1),
        "results": report.rows,
        "skipped": report.skipped,
    }


# ---------------------------------------------------------------- output


def _find(rows, **match):
    for r in rows:
        if all(r.get(k) == v for k, v in match.items()):
            return r
    return None


def _cell(row) -> str:
    if row is None:
        return "—"
    return f"{row['best_s']:.4f} ({row['median_s']:.4f})" if row["runs"] > 1 else f"{row['best_s']:.4f}"


def _method_device(method: str, device: str) -> str:
    return "host" if method in HOST_METHODS else device


def _synthesis_lines(report: dict) -> list[str]:
    """The tables of texton noise and its peers, per device."""
    p, rows = report["parameters"], report["results"]
    lines: list[str] = []
    ref_h, ref_w = p["ref_shape"]
    for d in report["devices"]:
        dev = d["name"]

        def get(method, **kw):
            return _find(rows, case="synthesis", method=method, device=_method_device(method, dev), **kw)

        lines += ["", f"## Texton noise and peers by output size on `{dev}` "
                  f"(MNI {p['ref_mni']:g}, texton {p['ref_texton']}²)", "",
                  "| output | " + " | ".join(METHODS) + " | texton noise Mpix/s | noise / FFT |",
                  "|---|" + "---:|" * (len(METHODS) + 2)]
        for h, w in p["sizes"]:
            kw = dict(shape=[h, w], mni=p["ref_mni"], texton=p["ref_texton"])
            cells = [get(mt, **kw) for mt in METHODS]
            tn, ff = cells[0], cells[3]
            ratio = f"{tn['best_s'] / ff['best_s']:.2f}" if tn and ff else "—"
            rate = f"{tn['mpix_per_s']:.0f}" if tn else "—"
            lines.append(f"| {w}×{h} | " + " | ".join(_cell(c) for c in cells) + f" | {rate} | {ratio} |")
        if len(p["mnis"]) > 1:
            lines += ["", f"### By MNI at {ref_w}×{ref_h} (texton {p['ref_texton']}²) on `{dev}`", "",
                      "| MNI | " + " | ".join(METHODS) + " |", "|---|" + "---:|" * len(METHODS)]
            for mni in p["mnis"]:
                kw = dict(shape=[ref_h, ref_w], mni=mni, texton=p["ref_texton"])
                lines.append(f"| {mni:g} | " + " | ".join(_cell(get(mt, **kw)) for mt in METHODS) + " |")
        if len(p["texton_sizes"]) > 1:
            lines += ["", f"### By texton size at {ref_w}×{ref_h} (MNI {p['ref_mni']:g}) on `{dev}`", "",
                      "| texton | " + " | ".join(METHODS) + " |", "|---|" + "---:|" * len(METHODS)]
            for t in p["texton_sizes"]:
                kw = dict(shape=[ref_h, ref_w], mni=p["ref_mni"], texton=t)
                lines.append(f"| {t}² | " + " | ".join(_cell(get(mt, **kw)) for mt in METHODS) + " |")
    return lines


def _frame_lines(report: dict) -> list[str]:
    """The grey/RGB/FastNoiseLite frames and their ratios, per device."""
    rows = [r for r in report["results"] if r["case"] == "frame"]
    if not rows:
        return []
    h, w = rows[0]["shape"]
    p = report["parameters"]
    lines = ["", f"## One frame, {w}×{h}: grey and RGB textons against FastNoiseLite (MNI {p['ref_mni']:g}, "
             f"texton {rows[0]['texton']}²; FastNoiseLite: OpenSimplex2, `gen_from_coords`, one thread, host)", "",
             "| device | " + " | ".join(FRAME_METHODS) + " | grey / RGB | grey / FastNoiseLite | RGB / FastNoiseLite |",
             "|---|" + "---:|" * (len(FRAME_METHODS) + 3)]
    fnl = _find(rows, method=FNL)
    for d in report["devices"]:
        grey, rgb = _find(rows, method=GREY, device=d["name"]), _find(rows, method=RGB, device=d["name"])
        if grey is None or rgb is None:
            continue

        def ratio(a, b):
            return f"{a['best_s'] / b['best_s']:.2f}" if a and b else "—"

        lines.append(f"| `{d['name']}` | {_cell(grey)} | {_cell(rgb)} | {_cell(fnl)} | {ratio(grey, rgb)} | "
                     f"{ratio(grey, fnl)} | {ratio(rgb, fnl)} |")
        if d["name"] == "cpu" and "cpu" in grey:
            cpu = [r["cpu"] if r is not None and "cpu" in r else None for r in (grey, rgb, fnl)]
            lines.append(f"| `cpu`, CPU time of the process | {_cell(cpu[0])} | {_cell(cpu[1])} | {_cell(cpu[2])} | "
                         f"{ratio(cpu[0], cpu[1])} | {ratio(cpu[0], cpu[2])} | {ratio(cpu[1], cpu[2])} |")
    return lines


def _analysis_lines(report: dict) -> list[str]:
    """The table of analysis times."""
    p, rows = report["parameters"], report["results"]
    lines: list[str] = []
    lines += ["", f"## Analysis (`analyze`, {p['image_side']}² RGB, 50 iterations, host)", "",
              "| texton | time (s) |", "|---|---:|"]
    for r in rows:
        if r["case"] == "analysis":
            lines.append(f"| {r['texton']}² | {_cell(r)} |")
    return lines


def _mixing_lines(report: dict) -> list[str]:
    """The table of mixed noise against plain noise."""
    p, rows = report["parameters"], report["results"]
    lines: list[str] = []
    mix = [r for r in rows if r["case"] == "mixing"]
    if mix:
        first = mix[0]
        lines += ["", f"## Mixing ({first['steps']} textons of {first['texton']}² in strips, MNI {p['ref_mni']:g})",
                  "", f"`mix_textons` for the {first['steps']} textons: {first['best_s']:.2f} s (host).", "",
                  "| device | output | `synthesize_mixed` | `synthesize` (one texton) | ratio |",
                  "|---|---|---:|---:|---:|"]
        for r in mix:
            if r["method"] == "synthesize_mixed":
                plain = _find(mix, method="synthesize", device=r["device"], shape=r["shape"])
                h, w = r["shape"]
                lines.append(f"| `{r['device']}` | {w}×{h} | {_cell(r)} | {_cell(plain)} | "
                             f"{r['best_s'] / plain['best_s']:.2f} |")
    return lines


def _filtering_lines(report: dict) -> list[str]:
    """The table of filters: cost and error against no filtering."""
    p, rows = report["parameters"], report["results"]
    lines: list[str] = []
    filt = [r for r in rows if r["case"] == "filtering"]
    if filt:
        h, w = filt[0]["shape"]
        lines += ["", f"## Filtering (plane in perspective, {w}×{h}, MNI {p['ref_mni']:g}, texton "
                  f"{p['ref_texton']}²; error against an 8×8 supersampled far half)", "",
                  "| device | filter | time (s) | cost vs none | error vs none |", "|---|---|---:|---:|---:|"]
        for r in filt:
            lines.append(f"| `{r['device']}` | {r['method']} | {_cell(r)} | {r['cost']:.2f} | "
                         f"{r['error_ratio']:.3f} |")
    return lines


def _surface_lines(report: dict) -> list[str]:
    """The table of surface noise and renders."""
    p, rows = report["parameters"], report["results"]
    lines: list[str] = []
    surf = [r for r in rows if r["case"] == "surface"]
    if surf:
        lines += ["", f"## Surface noise (MNI {SURFACE_MNI:g}, texton {p['ref_texton']}², unit icosphere, "
                  "128 texels per unit; blocks against the per-point walk, and against a raster of the same "
                  "texton measured in the same turns)", "",
                  "| device | what | time (s) | rate | per point / per raster pixel | walk / blocks |",
                  "|---|---|---:|---:|---:|---:|"]
        for r in surf:
            if r["method"].startswith("surface_noise"):
                walk = _find(surf, method="surface_noise (walk)", device=r["device"])
                ratio = f"{walk['best_s'] / r['best_s']:.2f}" if r["method"] == "surface_noise" else ""
                lines.append(f"| `{r['device']}` | `{r['method']}`, {r['vertices']} vertices | {_cell(r)} | "
                             f"{r['mpoints_per_s']:.2f} Mpoints/s | {r['vs_raster_pixel']:.1f} | {ratio} |")
            elif r["method"] == "synthesize":
                h, w = r["shape"]
                lines.append(f"| `{r['device']}` | `synthesize` {w}×{h}, MNI {r['mni']:g} | {_cell(r)} | "
                             f"{r['mpix_per_s']:.1f} Mpix/s | 1 | |")
            else:
                h, w = r["shape"]
                walk = _find(surf, method="render_mesh (walk)", device=r["device"])
                ratio = f"{walk['best_s'] / r['best_s']:.2f}" if r["method"] == "render_mesh" else ""
                lines.append(f"| `{r['device']}` | `{r['method']}`, {w}×{h} | {_cell(r)} | "
                             f"{r['mpix_per_s']:.1f} Mpix/s | | {ratio} |")
    return lines


def _atlas_lines(report: dict) -> list[str]:
    """The table of bakes with their atlas against re-bakes from its UVs."""
    rows = [r for r in report["results"] if r["case"] == "atlas"]
    if not rows:
        return []
    return ["", "## Bakes with a UV atlas (bench_atlas.py; goal: within 3× the re-bake from its UVs)", "",
            "| device | mesh | bake with atlas (s) | re-bake from its UVs (s) | ratio | coverage |",
            "|---|---|---:|---:|---:|---:|"] + [
        f"| `{r['device']}` | {r['mesh']}, {r['faces']} faces at {r['resolution']}² | {r['bake_s']:.2f} | "
        f"{r['rebake_s']:.2f} | {r['ratio']:.2f} | {100 * r['coverage']:.1f} % |" for r in rows]


def _quality_lines(report: dict) -> list[str]:
    """The quality table (bench_quality.py)."""
    from .bench_quality import table_lines

    rows = [r for r in report["results"] if r["case"] == "quality"]
    if not rows:
        return []
    shape = next((r["shape"] for r in rows if "shape" in r), [0, 0])
    return ["", f"## Quality on real textures ({shape[1]}×{shape[0]} outputs, texton {report['parameters']['ref_texton']}², "
            "see docs/quality.md)", "", *table_lines({"results": rows})]


def _seamless_lines(report: dict) -> list[str]:
    """The seamless/regular examples' table (bench_seamless.py) and the advice's agreement (bench_advice.py)."""
    from .bench_seamless import table_lines

    rows = [r for r in report["results"] if r["case"] == "seamless"]
    lines = []
    if rows:
        lines += ["", "## Seamless and regular examples (bench_seamless.py)", "", *table_lines({"results": rows})]
    agreement = next((r["agreement"] for r in report["results"] if r["case"] == "advice agreement"), None)
    if agreement:
        lines += ["", "## Method advice against labels (bench_advice.py)", "", "| advice | agreement |", "|---|---|"]
        for name, a in agreement.items():
            pct = "–" if a["all"]["percent"] is None else f"{a['all']['percent']:.0f} % ({a['all']['agree']}/{a['all']['n']})"
            lines.append(f"| {name} | {pct} |")
    return lines


def _viewer_lines(report: dict) -> list[str]:
    """The viewer's WebGL2 mode against its tiles (bench_viewer_webgl.py)."""
    from .bench_viewer_webgl import table_lines

    rows = [r for r in report["results"] if r["case"] == "viewer"]
    return [line for r in rows for line in ("", "## Viewer: WebGL2 against tiles (see docs/viewer.md)", "",
                                            *table_lines(r))]


def markdown(report: dict) -> str:
    m, p = report["machine"], report["parameters"]
    devices = ", ".join(
        f"`{d['name']}` ({d['description']}" + (f", {d['threads']} threads)" if "threads" in d else
                                                f", {d['memory_gib']} GiB)") for d in report["devices"])
    commit = (report["git_commit"] or "unknown")[:10]
    if p["repeat"] == 1:
        runs = "one timed run each"
    else:
        runs = (f"best of {p['repeat']} interleaved runs, median in brackets "
                f"(naive per-pixel: best of {min(p['repeat'], 2)})")
    lines = [
        f"# warp-texton benchmark runner, {p['name']} suite",
        "",
        f"{report['date']}; commit `{commit}`{' (uncommitted changes)' if report['git_dirty'] else ''}; "
        f"{m['processor']}, {m['usable_cpus']} usable CPUs, {m['platform']}; Python {m['python']}, "
        f"NumPy {m['numpy']}, SciPy {m['scipy']}, Warp {report['warp']}, warp-texton {m['warp_texton']}. "
        f"Devices: {devices}. The whole run took {report['seconds']:.0f} s.",
        "",
        f"Textons analysed from a {p['image_side']}² RGB test texture ({p['texture']}), order 1; "
        f"rasters RGB except the grey frame. Times in seconds after one untimed call of each method: {runs}. FFT sample and DSN "
        "run on the host (NumPy) whatever the device. Every method returns the finished raster in host memory.",
    ]
    for section in (_synthesis_lines, _frame_lines, _analysis_lines, _mixing_lines, _filtering_lines, _surface_lines,
                    _atlas_lines, _quality_lines, _seamless_lines, _viewer_lines):
        lines += section(report)
    if report["skipped"]:
        lines += ["", "## Not measured", ""]
        lines += [f"* {s['case']}: {s['reason']}." for s in report["skipped"]]
    return "\n".join(lines) + "\n"




def plots(report: dict, out: Path) -> list[Path]:
    """Log-log time against output pixels, and time against MNI and texton size at the reference size."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    p, rows = report["parameters"], report["results"]
    ref = list(p["ref_shape"])
    colours = dict(zip(METHODS, plt.rcParams["axes.prop_cycle"].by_key()["color"]))
    styles = ["-", "--", ":", "-."]
    title_tail = f"{report['machine']['processor']}, {report['date'][:10]}"
    figures = [
        ("time_vs_size.png", "size", "output size (megapixels)",
         lambda r: r["shape"][0] * r["shape"][1] / 1e6,
         f"MNI {p['ref_mni']:g}, texton {p['ref_texton']}², RGB", True),
        ("time_vs_mni.png", "mni", "MNI (mean number of impacts per point)", lambda r: r["mni"],
         f"{ref[1]}×{ref[0]}, texton {p['ref_texton']}², RGB", False),
        ("time_vs_texton.png", "texton", "texton side (texels)", lambda r: r["texton"],
         f"{ref[1]}×{ref[0]}, MNI {p['ref_mni']:g}, RGB", True),
    ]
    written = []
    for name, sweep, xlabel, xof, subtitle, logx in figures:
        fig, ax = plt.subplots(figsize=(7, 4.5))
        for k, d in enumerate(report["devices"]):
            for method in METHODS:
                dev = _method_device(method, d["name"])
                if dev == "host" and k > 0:
                    continue
                pts = sorted((xof(r), r["best_s"]) for r in rows
                             if r["case"] == "synthesis" and r["method"] == method and r["device"] == dev
                             and sweep in r["sweeps"])
                if pts:
                    xs, ys = zip(*pts)
                    label = f"{method} ({dev})"
                    ax.plot(xs, ys, styles[k % len(styles)], marker="o", color=colours[method], label=label)
        ax.set_yscale("log")
        if logx:
            ax.set_xscale("log", base=2 if sweep == "texton" else 10)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("time (s), best of runs")
        ax.set_title(f"{subtitle}\n{title_tail}", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        path = out / name
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=110, format="png")
        plt.close(fig)
        written.append(path)
    return written


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Show defaults, except the None and False that mean "see the help text" or "off"."""

    def _get_help_string(self, action):
        if action.default is None or action.default is False:
            return action.help
        return super()._get_help_string(action)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks",
        description="Time texton analysis, 2-D texton noise, filtering, surface noise and mixing against "
                    "their peers (FFT sample, discrete spot noise, wp.pnoise, FastNoiseLite, naive per-pixel "
                    "texton noise).",
        formatter_class=_HelpFormatter,
    )
    parser.add_argument("--device", default="all",
                        help="cpu, cuda, cuda:N, or all (the CPU and every CUDA device present)")
    parser.add_argument("--quick", action="store_true",
                        help="CI-sized smoke run: 256² and 512², MNI 30, texton 32², one run each")
    parser.add_argument("--out", type=Path, default=None,
                        help="folder for runner.json, runner.md and the plots; default benchmarks/results/runner "
                             "for a full run, a new temporary folder for --quick")
    parser.add_argument("--repeat", type=int, default=None,
                        help="timed runs of each method (best is reported); default 5, 1 with --quick")
    args = parser.parse_args(argv)
    suite = QUICK if args.quick else FULL
    if args.repeat is not None:
        if args.repeat < 1:
            parser.error("--repeat must be at least 1")
        suite = Suite(**{**asdict(suite), "repeat": args.repeat})
    from warp_texton import TextonError

    try:
        devices = resolve_devices(args.device)
    except TextonError as exc:
        print(f"python -m benchmarks: error: {exc}", file=sys.stderr)
        return 2
    if args.device == "all" and devices == ["cpu"]:
        print("no CUDA device present: measuring the CPU only", flush=True)
    out = args.out
    if out is None:
        out = Path(tempfile.mkdtemp(prefix="warp-texton-bench-")) if args.quick else DEFAULT_OUT
    out.mkdir(parents=True, exist_ok=True)
    print(f"{suite.name} suite on {', '.join(devices)}; writing into {out}", flush=True)

    report = run(suite, devices)
    text = markdown(report)
    print()
    print(text, end="")
    write_atomic(out / "runner.json", json.dumps(report, indent=2) + "\n")
    write_atomic(out / "runner.md", text)
    written = [out / "runner.json", out / "runner.md", *plots(report, out)]
    print("\nwrote " + ", ".join(str(p) for p in written))
    return 0
