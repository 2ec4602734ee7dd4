"""Benchmark: what the work budget means in seconds, path by path.

Every function whose running time grows with its arguments estimates the
operations it will do and refuses beyond ``WARP_TEXTON_WORK_BUDGET``
(``warp_texton.core.limits``). This script runs one workload per path, reads the
estimate each call checked (``limits.work_log``), times the call (best of N,
median in brackets) and reports operations per second and the time the default
budget stands for on this machine. It is how ``noise.WALK_COST`` (a point
walk's visit against a raster lookup) and the default budget were chosen;
docs/limits.md quotes its table.

    python benchmarks/bench_limits.py            # full run, writes results/
    python benchmarks/bench_limits.py --quick    # smoke run
    python benchmarks/bench_limits.py --only preserve,tiling --out benchmarks/results/issue42  # some paths
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import machine_line, make_texture, report_header, run_main  # noqa: E402

from warp_texton import (FilterOptions, analyze, bake_mesh, dsn, evaluate, gaussian_texture,  # noqa: E402
                         mix_textons, render_mesh, render_plane, surface_noise, synthesize, synthesize_mixed)
from warp_texton.core.runtime import resolve_device  # noqa: E402
from warp_texton.core.limits import DEFAULT_WORK_BUDGET, work_log  # noqa: E402


def workloads(texton, u, device, quick: bool, mni: float):
    """(name, call) pairs, each taking a fraction of a second to a few seconds on a CPU."""
    k = 4 if quick else 1
    n = 1024 // k
    pts = np.random.default_rng(0).uniform(-5000, 5000, (200_000 // k, 2))
    textons = mix_textons(u[:128, :128], u[:128, :128].transpose(1, 0, 2), [0.0, 0.5, 1.0], size=32, iterations=10)
    side = 1448 // k  # past REFINE_MAX_PIXELS (2²⁰) at full size: the analysis without the judges
    big_grey = np.tile(u.mean(axis=2, keepdims=True), (3, 3, 1))[:side, :side]
    return [
        ("synthesize, raster (splat on the grid)", lambda: synthesize(texton, (n, n), mni=mni, device=device)),
        ("synthesize, rotated raster", lambda: synthesize(texton, (n, n), mni=mni, rotation=30, device=device)),
        ("synthesize_mixed, strips", lambda: synthesize_mixed(textons, "strips", (n, n), mni=mni, device=device)),
        ("evaluate, points", lambda: evaluate(texton, pts, mni=mni, device=device)),
        ("render_plane, filter none", lambda: render_plane(texton, (n // 2, n // 2), mni=mni, filter="none",
                                                           device=device)),
        ("render_plane, filter mip", lambda: render_plane(texton, (n // 2, n // 2), mni=mni, filter="mip",
                                                          device=device)),
        ("render_plane, filter anisotropic", lambda: render_plane(texton, (n // 2, n // 2), mni=mni,
                                                                  filter="anisotropic", device=device)),
        ("synthesize, filter supersample 4", lambda: synthesize(
            texton, (n // 4, n // 4), mni=mni, scale=0.25, filter=FilterOptions("supersample", supersample=4),
            device=device)),
        ("analyze, 50 iterations", lambda: analyze(u, size=64, iterations=50)),
        ("analyze, histogram preserve (judged), 50 iterations",
         lambda: analyze(u, size=64, iterations=50, histogram="preserve")),
        ("analyze, histogram preserve, grey > 2²⁰ pixels (not judged)",
         lambda: analyze(big_grey, size=64, iterations=50, histogram="preserve")),
        ("analyze, method tiling (structure score)", lambda: analyze(u, method="tiling")),
        ("analyze, method tiling, histogram preserve", lambda: analyze(u, method="tiling", histogram="preserve")),
        ("mix_textons, 3 textons", lambda: mix_textons(u[:256, :256], u[:256, :256].transpose(1, 0, 2),
                                                       [0.0, 0.5, 1.0], size=64)),
        ("gaussian_texture", lambda: gaussian_texture(u, shape=(2 * n, 2 * n))),
        ("dsn", lambda: dsn(texton, (n, n), mni=mni)),
        *surface_workloads(texton, device, quick),
    ]


def surface_workloads(texton, device, quick: bool):
    """The surface paths, priced by the path they take: a dense torus (the blocks), points a
    few cubes apart (the walk), a render and a bake (MNI 60, the surface default)."""
    import trimesh

    sections = 250 if quick else 1000
    torus = trimesh.creation.torus(1.0, 0.35, major_sections=sections, minor_sections=sections)
    pts, nrm = np.asarray(torus.vertices), np.asarray(torus.vertex_normals)
    rng = np.random.default_rng(0)
    apart, normals = rng.uniform(-1, 1, (20_000 // (4 if quick else 1), 3)), rng.normal(size=(20_000, 3))
    sphere = trimesh.creation.icosphere(subdivisions=4 if quick else 6)
    m = 256 if quick else 1024
    return [
        (f"surface_noise, blocks ({len(pts)} torus vertices)",
         lambda: surface_noise(texton, pts, nrm, 0.004, device=device)),
        (f"surface_noise, walk ({len(apart)} points apart)",
         lambda: surface_noise(texton, apart, normals[:len(apart)], 0.0005, device=device)),
        (f"render_mesh {m}², blocks", lambda: render_mesh(sphere, texton, (m, m), texel_size=1 / 128, device=device)),
        (f"bake_mesh torus {m // 2}²", lambda: bake_mesh(trimesh.creation.torus(1.0, 0.35), texton, 0.004,
                                                         resolution=m // 2, device=device)),
    ]


def run(args) -> dict:
    device = resolve_device(args.device)
    u = make_texture(256 if args.quick else 512)
    texton = analyze(u, size=args.size, seed=0)
    rows = []
    for name, call in workloads(texton, u, device, args.quick, args.mni):
        if args.only and not any(word in name for word in args.only.split(",")):
            continue
        with work_log() as log:
            call()  # the first call compiles kernels and warms caches: not timed
        ops = sum(v for _, v in log)
        times = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            call()
            times.append(time.perf_counter() - t0)
        best, median = min(times), statistics.median(times)
        row = {"path": name, "operations": ops, "best_s": best, "median_s": median,
               "ops_per_s": ops / best, "budget_s": DEFAULT_WORK_BUDGET * best / ops}
        rows.append(row)
        print(f"  {name}: {ops:.3g} operations in {best:.3f} s: {ops / best:.3g} /s, "
              f"default budget = {row['budget_s']:.0f} s", flush=True)
    return {
        **report_header("limits", device),
        "parameters": {"texton": list(texton.size), "channels": texton.channels, "mni": args.mni,
                       "repeat": args.repeat, "quick": args.quick, "default_work_budget": DEFAULT_WORK_BUDGET},
        "results": rows,
    }


def markdown(report: dict) -> str:
    p = report["parameters"]
    lines = [
        f"# The work budget in seconds ({report['date']})",
        "",
        machine_line(report),
        f"RGB texton {p['texton'][0]}x{p['texton'][1]}, MNI {p['mni']:g}; operations as each call estimated them "
        f"(`limits.work_log`); time: best of {p['repeat']} runs after a warm-up call (median in brackets). "
        f"The last column is the time a request of the default budget ({p['default_work_budget']:.0e} "
        "operations) would take on this path.",
        "",
        "| path | operations | time (s) | operations / s | default budget (s) |",
        "|---|---:|---:|---:|---:|",
    ]
    for r in report["results"]:
        lines.append(f"| {r['path']} | {r['operations']:.3g} | {r['best_s']:.3f} ({r['median_s']:.3f}) | "
                     f"{r['ops_per_s']:.3g} | {r['budget_s']:.0f} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    def only(parser):
        parser.add_argument("--only", help="comma-separated words: run the paths whose name holds one of them")

    return run_main(__doc__, "limits", run, markdown, argv, repeat=3, extra_args=only)


if __name__ == "__main__":
    sys.exit(main())
