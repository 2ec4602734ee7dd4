"""Benchmark: surface texton noise on meshes (CGF §6).

Measures ``surface_noise`` throughput (points per second) at the vertices of a
35,000-vertex torus at MNI 60, ``texture_mesh`` on the same mesh, and
``render_mesh`` at 1024 × 1024, for an RGB 64² texton.

    python benchmarks/bench_surface.py            # full run, writes results/
    python benchmarks/bench_surface.py --quick    # smoke run (CI)
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import machine_line, make_texture, report_header, run_main  # noqa: E402

import trimesh  # noqa: E402

from warp_texton import analyze, render_mesh, surface_noise, texture_mesh  # noqa: E402
from warp_texton._runtime import resolve_device  # noqa: E402


def best(fn, repeat):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return {"best_s": min(times), "median_s": statistics.median(times)}


def run(args) -> dict:
    device = resolve_device(args.device)
    texton = analyze(make_texture(256 if args.quick else 512), size=args.size, seed=0)
    sections = (50, 28) if args.quick else (250, 140)
    mesh = trimesh.creation.torus(major_radius=1.0, minor_radius=0.35, major_sections=sections[0],
                                  minor_sections=sections[1])
    texel = 0.004  # about 1,600 texels around the torus
    pts, nrm = mesh.vertices, mesh.vertex_normals
    surface_noise(texton, pts[:16], nrm[:16], texel, device=device)  # load the kernels
    shape = (128, 128) if args.quick else (1024, 1024)
    points = best(lambda: surface_noise(texton, pts, nrm, texel, mni=args.mni, device=device), args.repeat)
    textured = best(lambda: texture_mesh(mesh, texton, texel, mni=args.mni, device=device), args.repeat)
    render = best(lambda: render_mesh(mesh, texton, shape, texel_size=texel, mni=args.mni, device=device),
                  max(1, args.repeat // 2))
    n = len(pts)
    print(f"  surface_noise: {n} points in {points['best_s']:.3f} s ({n / points['best_s']:,.0f} points/s)")
    print(f"  render_mesh {shape[1]}x{shape[0]}: {render['best_s']:.3f} s")
    return {
        **report_header("surface", device),
        "parameters": {"texton": list(texton.size), "channels": texton.channels, "mni": args.mni,
                       "vertices": n, "faces": len(mesh.faces), "texel_size": texel,
                       "render_shape": list(shape), "repeat": args.repeat, "quick": args.quick},
        "surface_noise": {**points, "points_per_s": n / points["best_s"]},
        "texture_mesh": textured,
        "render_mesh": render,
    }


def markdown(report: dict) -> str:
    p = report["parameters"]
    s, t, r = report["surface_noise"], report["texture_mesh"], report["render_mesh"]
    h, w = p["render_shape"]
    return "\n".join([
        f"# Surface texton noise ({report['date']})",
        "",
        machine_line(report),
        f"RGB texton {p['texton'][0]}x{p['texton'][1]}, MNI {p['mni']:g}; torus of {p['vertices']} vertices, "
        f"{p['faces']} faces; best of {p['repeat']} runs (median in brackets).",
        "",
        "| operation | time (s) | throughput |",
        "|---|---|---|",
        f"| surface_noise at {p['vertices']} vertices | {s['best_s']:.3f} ({s['median_s']:.3f}) | "
        f"{s['points_per_s']:,.0f} points/s |",
        f"| texture_mesh (noise + vertex colours) | {t['best_s']:.3f} ({t['median_s']:.3f}) | |",
        f"| render_mesh {w}x{h} | {r['best_s']:.3f} ({r['median_s']:.3f}) | "
        f"{w * h / r['best_s']:,.0f} pixels/s |",
    ]) + "\n"


def main(argv=None) -> int:
    return run_main(__doc__, "surface", run, markdown, argv, repeat=5, mni=60.0)


if __name__ == "__main__":
    sys.exit(main())
