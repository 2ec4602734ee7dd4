"""Benchmark: surface texton noise on meshes (CGF §6), blocks against the per-point walk.

Measures, interleaved in one run so that all see the same machine load:

* ``surface_noise`` at the vertices of a torus of about 1M vertices (MNI 60),
  in blocks (the default) and with the per-point walk (``method="points"``),
  against a 1024 × 1024 ``synthesize`` raster of the same texton (MNI 30, the
  2-D default): the goal is surface noise at 1M points within 20× the
  time of that raster;
* ``render_mesh`` at 1024 × 1024 of an icosphere, blocks against the walk
  (the goal: at least 5× faster than commit 3c913e1, whose only path was the
  walk; ``compare_commits.py --base 3c913e1`` measures that directly);
* ``bake_mesh`` of the torus (1024², xatlas atlas) and, on a plane, the error
  of the default supersampling against a densely supersampled reference;
* grey against RGB: ``surface_noise`` at the torus's vertices and a bake of the
  torus (its atlas made once, so that the bakes time the surface noise of their
  samples), for a grey texton (one float a texel through the kernels) and the
  RGB one, interleaved, wall-clock and the process's CPU time, the ratios
  printed (goal by analogy with the plane: grey ≤ 0.5× RGB).

RGB 64² texton analysed from the benchmark texture; the grey one from its grey mean.

    python benchmarks/bench_surface.py            # full run, writes results/
    python benchmarks/bench_surface.py --quick    # smoke run (CI)
    python benchmarks/bench_surface.py --only grey   # the grey/RGB pair alone (results/surface_grey.*)
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import machine_line, make_texture, report_header, run_main  # noqa: E402

import numpy as np  # noqa: E402
import trimesh  # noqa: E402

from warp_texton import analyze, bake_mesh, render_mesh, surface_noise, synthesize  # noqa: E402
from warp_texton.core.runtime import resolve_device  # noqa: E402
from warp_texton.surface.blocks import simd_loops  # noqa: E402


def interleaved(methods: dict, repeat: int, clock=time.perf_counter) -> dict:
    """Best and median of ``repeat`` timed runs of each callable, taking turns (one untimed call first);
    ``clock``: wall-clock by default, ``time.process_time`` for the process's CPU time (steadier on a
    machine that others load)."""
    for fn in methods.values():
        fn()
    times = {name: [] for name in methods}
    for _ in range(repeat):
        for name, fn in methods.items():
            t0 = clock()
            fn()
            times[name].append(clock() - t0)
    return {name: {"best_s": min(t), "median_s": statistics.median(t)} for name, t in times.items()}


def plane_with_uvs():
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    uv = v[:, :2].copy()
    return trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], visual=trimesh.visual.TextureVisuals(uv=uv), process=False)


def supersampling_errors(texton, device, quick: bool) -> list[dict]:
    """RMS error of a bake's texels against the footprint mean (a 16 × 16-sample reference),
    relative to the noise's sd, at texton texels per bake texel 4 and 8, for densities
    (samples per texton texel along each side) 0 (one sample at the centre) to 2."""
    rows = []
    res = 16 if quick else 64
    sd = float(np.sqrt(np.diag(texton.covariance()).mean()))
    for footprint in (4, 8):
        texel = 1.0 / (res * footprint)
        ref = bake_mesh(plane_with_uvs(), texton, texel, resolution=res, supersample=16, device=device).texture
        for n in sorted({1, footprint // 4, footprint // 2, footprint, 2 * footprint} - {0}):
            t0 = time.perf_counter()
            got = bake_mesh(plane_with_uvs(), texton, texel, resolution=res, supersample=n, device=device).texture
            dt = time.perf_counter() - t0
            rows.append({"footprint": footprint, "samples_per_side": n, "density": n / footprint,
                         "rms_error_sd": float(np.sqrt(np.mean((got - ref) ** 2)) / sd), "time_s": dt})
    return rows


def both_clocks(methods: dict, repeat: int) -> dict:
    """Wall-clock and process CPU time (best and median) of each callable, taking turns after one untimed call."""
    for fn in methods.values():
        fn()
    wall: dict = {k: [] for k in methods}
    cpu: dict = {k: [] for k in methods}
    for _ in range(repeat):
        for name, fn in methods.items():
            c0, t0 = time.process_time(), time.perf_counter()
            fn()
            wall[name].append(time.perf_counter() - t0)
            cpu[name].append(time.process_time() - c0)
    return {k: {clock: {"best_s": min(v[k]), "median_s": statistics.median(v[k])}
                for clock, v in (("wall", wall), ("cpu", cpu))} for k in methods}


def grey_pair(args, device, texture, pts, nrm, texel) -> dict:
    """surface_noise at the points and a bake, grey texton against RGB, interleaved."""
    grey = analyze(np.ascontiguousarray(texture.mean(axis=2, keepdims=True)), size=args.size, seed=0)
    rgb = analyze(texture, size=args.size, seed=0)
    res = 256 if args.quick else 1024
    # the torus with an atlas made once: the bakes then time the noise of their samples
    atlas = bake_mesh(trimesh.creation.torus(1.0, 0.35), rgb, texel, resolution=res, device=device).mesh
    times = both_clocks({
        "surface_noise grey": lambda: surface_noise(grey, pts, nrm, texel, mni=args.mni, device=device),
        "surface_noise RGB": lambda: surface_noise(rgb, pts, nrm, texel, mni=args.mni, device=device),
        "bake grey": lambda: bake_mesh(atlas, grey, texel, resolution=res, uv="mesh", mni=args.mni, device=device),
        "bake RGB": lambda: bake_mesh(atlas, rgb, texel, resolution=res, uv="mesh", mni=args.mni, device=device),
    }, args.repeat)
    ratios = {f"{what} {clock}": times[f"{what} grey"][clock]["best_s"] / times[f"{what} RGB"][clock]["best_s"]
              for what in ("surface_noise", "bake") for clock in ("wall", "cpu")}
    for what in ("surface_noise", "bake"):
        g, c = times[f"{what} grey"], times[f"{what} RGB"]
        print(f"  {what}: grey {g['wall']['best_s']:.3f} s, RGB {c['wall']['best_s']:.3f} s: grey/RGB "
              f"{ratios[what + ' wall']:.2f} wall, {ratios[what + ' cpu']:.2f} CPU (goal by analogy: <= 0.5)")
    return {"points": len(pts), "bake": res, "times": times, "ratios": ratios}


def pair_markdown(report: dict) -> str:
    p, g = report["parameters"], report["grey_pair"]
    t = g["times"]
    lines = [f"# Surface noise, grey against RGB ({report['date']})", "", machine_line(report),
             f"Textons {p['texton'][0]}x{p['texton'][1]} (grey: the benchmark texture's grey mean), MNI {p['mni']:g}; "
             f"best of {p['repeat']} interleaved runs (median in brackets); CPU cluster loops: {p['cpu_loops']}.", "",
             "| operation | grey wall (s) | RGB wall (s) | grey/RGB wall | grey CPU (s) | RGB CPU (s) | grey/RGB CPU |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for what, label in (("surface_noise", f"`surface_noise`, {g['points']} points"),
                        ("bake", f"`bake_mesh` torus {g['bake']}² (atlas made once)")):
        a, b = t[f"{what} grey"], t[f"{what} RGB"]
        lines.append(f"| {label} | {_cell(a['wall'])} | {_cell(b['wall'])} | {g['ratios'][what + ' wall']:.2f} | "
                     f"{_cell(a['cpu'])} | {_cell(b['cpu'])} | {g['ratios'][what + ' cpu']:.2f} |")
    return "\n".join(lines) + "\n"


def run(args) -> dict:
    device = resolve_device(args.device)
    texture = make_texture(256 if args.quick else 512)
    texton = analyze(texture, size=args.size, seed=0)
    sections = (100, 100) if args.quick else (1000, 1000)
    torus = trimesh.creation.torus(major_radius=1.0, minor_radius=0.35, major_sections=sections[0],
                                   minor_sections=sections[1])
    texel = 0.004  # about 1,600 texels around the torus
    pts, nrm = np.asarray(torus.vertices), np.asarray(torus.vertex_normals)
    if args.only == "grey":
        return {**report_header("surface_grey", device),
                "parameters": {"texton": list(texton.size), "mni": args.mni, "vertices": len(pts), "texel_size": texel,
                               "repeat": args.repeat, "quick": args.quick,
                               "cpu_loops": simd_loops(device) if device == "cpu" else "none (GPU)"},
                "grey_pair": grey_pair(args, device, texture, pts, nrm, texel)}
    raster = (128, 128) if args.quick else (1024, 1024)
    sphere = trimesh.creation.icosphere(subdivisions=4 if args.quick else 6)
    shape = (128, 128) if args.quick else (1024, 1024)
    surface_noise(texton, pts[:16], nrm[:16], texel, device=device)  # load the kernels
    noise = interleaved({
        "blocks": lambda: surface_noise(texton, pts, nrm, texel, mni=args.mni, device=device),
        "points": lambda: surface_noise(texton, pts, nrm, texel, mni=args.mni, device=device, method="points"),
        "synthesize": lambda: synthesize(texton, raster, mni=30.0, device=device),
    }, args.repeat)
    render = interleaved({
        "blocks": lambda: render_mesh(sphere, texton, shape, texel_size=1 / 128, mni=args.mni, device=device),
        "points": lambda: render_mesh(sphere, texton, shape, texel_size=1 / 128, mni=args.mni, device=device,
                                      method="points"),
    }, max(1, args.repeat // 2))
    bake_res = 256 if args.quick else 1024
    t0 = time.perf_counter()
    baked = bake_mesh(trimesh.creation.torus(1.0, 0.35), texton, texel, resolution=bake_res, mni=args.mni, device=device)
    bake_s = time.perf_counter() - t0
    errors = supersampling_errors(texton, device, args.quick)
    pair = grey_pair(args, device, texture, pts, nrm, texel)
    n = len(pts)
    ratio = noise["blocks"]["best_s"] / noise["synthesize"]["best_s"] * (raster[0] * raster[1]) / n
    print(f"  surface_noise: {n} points in {noise['blocks']['best_s']:.3f} s (walk {noise['points']['best_s']:.3f} s)"
          f"; x{ratio:.1f} the time of a raster of as many pixels")
    print(f"  render_mesh {shape[1]}x{shape[0]}: {render['blocks']['best_s']:.3f} s "
          f"(walk {render['points']['best_s']:.3f} s)")
    return {
        **report_header("surface", device),
        "parameters": {"texton": list(texton.size), "channels": texton.channels, "mni": args.mni,
                       "vertices": n, "texel_size": texel, "raster": list(raster), "raster_mni": 30.0,
                       "render_shape": list(shape), "render_vertices": len(sphere.vertices), "bake": bake_res,
                       "repeat": args.repeat, "quick": args.quick,
                       "cpu_loops": simd_loops(device) if device == "cpu" else "none (GPU)"},
        "surface_noise": noise,
        "surface_vs_raster": ratio,
        "render_mesh": render,
        "render_speedup": render["points"]["best_s"] / render["blocks"]["best_s"],
        "walk_speedup": noise["points"]["best_s"] / noise["blocks"]["best_s"],
        "bake": {"resolution": bake_res, "time_s": bake_s, "texels_per_texton_texel": baked.texels_per_texton_texel,
                 "samples_per_texel": baked.samples, "coverage": float(baked.coverage.mean())},
        "supersampling": errors,
        "grey_pair": pair,
    }


def _cell(t: dict) -> str:
    return f"{t['best_s']:.3f} ({t['median_s']:.3f})"


def markdown(report: dict) -> str:
    if "surface_noise" not in report:  # --only grey
        return pair_markdown(report)
    p = report["parameters"]
    s, r, b = report["surface_noise"], report["render_mesh"], report["bake"]
    h, w = p["render_shape"]
    rh, rw = p["raster"]
    lines = [
        f"# Surface texton noise ({report['date']})",
        "",
        machine_line(report),
        f"RGB texton {p['texton'][0]}x{p['texton'][1]}, MNI {p['mni']:g}; torus of {p['vertices']} vertices; "
        f"best of {p['repeat']} interleaved runs (median in brackets); CPU cluster loops: {p.get('cpu_loops', '?')}.",
        "",
        "| operation | time (s) | rate |",
        "|---|---:|---:|",
        f"| `surface_noise`, {p['vertices']} points, blocks | {_cell(s['blocks'])} | "
        f"{p['vertices'] / s['blocks']['best_s'] / 1e6:.2f} Mpoints/s |",
        f"| `surface_noise`, {p['vertices']} points, per-point walk | {_cell(s['points'])} | "
        f"{p['vertices'] / s['points']['best_s'] / 1e6:.2f} Mpoints/s |",
        f"| `synthesize` {rw}x{rh}, MNI {p['raster_mni']:g} | {_cell(s['synthesize'])} | "
        f"{rw * rh / s['synthesize']['best_s'] / 1e6:.1f} Mpix/s |",
        f"| `render_mesh` {w}x{h}, blocks | {_cell(r['blocks'])} | {w * h / r['blocks']['best_s'] / 1e6:.2f} Mpix/s |",
        f"| `render_mesh` {w}x{h}, per-point walk | {_cell(r['points'])} | "
        f"{w * h / r['points']['best_s'] / 1e6:.2f} Mpix/s |",
        f"| `bake_mesh` torus {b['resolution']}² (xatlas, default supersampling) | {b['time_s']:.3f} | "
        f"{b['texels_per_texton_texel']:.2f} texels per texton texel, {b['samples_per_texel']:.2f} samples per texel |",
        "",
        f"Surface noise per point costs x{report['surface_vs_raster']:.1f} a raster pixel (goal: x20 or less); "
        f"blocks are x{report['walk_speedup']:.2f} faster than the walk for points and "
        f"x{report['render_speedup']:.2f} for the render (the walk also got faster: the goal, a render x5 faster "
        "than commit 3c913e1, is measured by `compare_commits.py --base 3c913e1`).",
        "",
        "Supersampling of a bake (plane; error of the texels against a 16 × 16-sample mean of each footprint, "
        "in noise standard deviations):",
        "",
        "| texton texels per bake texel | samples per side | per texton texel | RMS error (sd) | time (s) |",
        "|---:|---:|---:|---:|---:|",
    ]
    for e in report["supersampling"]:
        lines.append(f"| {e['footprint']} | {e['samples_per_side']} | {e['density']:.2f} | {e['rms_error_sd']:.3f} | "
                     f"{e['time_s']:.3f} |")
    if "grey_pair" in report:
        lines += ["", pair_markdown(report).split("\n", 3)[3]]  # its table, without its heading and machine line
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    # --only grey: the grey/RGB pair alone, written as surface_grey.*
    name = "surface_grey" if "grey" in argv and "--only" in argv else "surface"
    return run_main(__doc__, name, run, markdown, argv, repeat=3, mni=60.0,
                    extra_args=lambda p: p.add_argument("--only", choices=["grey"], default=None,
                                                        help="run the grey/RGB pair alone"))


if __name__ == "__main__":
    sys.exit(main())
