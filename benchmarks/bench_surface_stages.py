"""Benchmark: where the time of surface noise and bakes goes, stage by stage (issue 41, item 1).

Two subjects, each beside the raster of as many samples of the same texton, in the same run:

* ``surface_noise`` at 1M random points of a unit sphere (texel 1/128, MNI 30), RGB and grey,
  against the 1024² raster at MNI 30;
* ``bake_mesh`` of the Stanford bunny (as pymeshfix ships it; a torus without pymeshfix) at 1024²
  from its own UVs (``uv="mesh"``: the UVs of a first bake, no atlas made), MNI 60, against the
  1024² raster at MNI 60.

Stages come from one profiled call (``cProfile``; a few hundred Python calls, so its overhead is
small): the cumulative time of the host functions that make each stage, the rest of the call as
"other host". Kernel launches run on the launch pool's threads, so a stage that launches kernels
holds their time too. Totals are the best of ``--repeat`` unprofiled calls, taking turns with the
raster.

    python benchmarks/bench_surface_stages.py            # writes results/surface_stages.{json,md}
    python benchmarks/bench_surface_stages.py --quick    # smoke run (100k points, a torus at 256²)
"""

from __future__ import annotations

import cProfile
import pstats
import sys
import time
import warnings
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import machine_line, make_texture, report_header, run_main  # noqa: E402

import numpy as np  # noqa: E402
import trimesh  # noqa: E402

from warp_texton import analyze, bake_mesh, surface_noise, synthesize  # noqa: E402
from warp_texton.core.runtime import resolve_device  # noqa: E402
from warp_texton.surface.mesh import default_texel_size  # noqa: E402

#: Stage name → the functions (file stem, function name) whose cumulative time it is.
NOISE_STAGES = {
    "checks and setup": [("points", "_prepare_points"), ("points", "check_reach"), ("points", "surface_setup")],
    "sort into blocks (host + key kernels)": [("blocks", "sort_into_blocks")],
    "plan (visits, work price)": [("points", "block_visits")],
    "noise kernels (impacts, gathers)": [("blocks", "gather_blocks")],
}
BAKE_STAGES = {
    "UVs and texel claims": [("bake", "_bake_uvs")],
    "corner normals": [("mesh", "corner_normals")],
    "gutter (distance transform)": [("bake", "_extend")],
    "texel → face maps": [("bake", "_texel_faces")],
    "sample placement": [("bake", "_sample_points")],
    "noise (sort, kernels)": [("points", "evaluate_points")],
    "output mesh (split corners)": [("mesh", "split_corners"), ("bake", "_textured")],
}


def staged(fn, stages: dict) -> tuple[float, dict]:
    """(total s, {stage: s}) of one profiled call of ``fn``."""
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    fn()
    prof.disable()
    total = time.perf_counter() - t0
    stats = pstats.Stats(prof).stats  # type: ignore[attr-defined]
    cum: dict[tuple[str, str], float] = {}
    for (path, _line, name), (_cc, _nc, _tt, ct, _callers) in stats.items():
        cum[(Path(path).stem, name)] = cum.get((Path(path).stem, name), 0.0) + ct
    out = {stage: sum(cum.get(key, 0.0) for key in keys) for stage, keys in stages.items()}
    out["other host"] = max(0.0, total - sum(out.values()))
    return total, out


def best(fns: dict, repeat: int) -> dict:
    """Best of ``repeat`` timed calls of each, taking turns (one untimed call first)."""
    for fn in fns.values():
        fn()
    times: dict = {k: [] for k in fns}
    for _ in range(repeat):
        for k, fn in fns.items():
            t0 = time.perf_counter()
            fn()
            times[k].append(time.perf_counter() - t0)
    return {k: min(v) for k, v in times.items()}


def bake_subject(quick: bool):
    """(mesh with its own UVs, texel size, name): a first bake's output mesh of the bunny, or a torus."""
    mesh, name = None, "torus"
    if not quick:
        from bench_atlas import bunny

        mesh = bunny()
        name = "Stanford bunny"
    if mesh is None:
        mesh = trimesh.creation.torus(1.0, 0.35)
    texel = default_texel_size(mesh)
    texton = analyze(make_texture(128), size=16, seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a few overlapping texels of the scan's atlas
        baked = bake_mesh(mesh, texton, texel, resolution=256, up="z", charts="normals")
    return baked.mesh, texel, name


def run(args) -> dict:
    device = resolve_device(args.device)
    texture = make_texture(256 if args.quick else 512)
    rgb = analyze(texture, size=args.size, seed=0)
    grey = analyze(texture.mean(axis=2, keepdims=True), size=args.size, seed=0)
    n = 100_000 if args.quick else 1_000_000
    side = int(round(np.sqrt(n)))
    rng = np.random.default_rng(1)
    pts = rng.normal(size=(n, 3))
    pts /= np.linalg.norm(pts, axis=1, keepdims=True)
    rows = []
    for label, texton in (("RGB", rgb), ("grey", grey)):
        def noise(t=texton):
            return surface_noise(t, pts, pts, texel_size=1 / 128, mni=30.0, seed=1, device=device)

        def raster(t=texton):
            return synthesize(t, (side, side), mni=30.0, seed=1, device=device)

        b = best({"surface": noise, "raster": raster}, args.repeat)
        _, stages = staged(noise, NOISE_STAGES)
        rows.append({"subject": f"surface_noise {n} sphere points, {label}", "samples": n, "total_s": b["surface"],
                     "raster_s": b["raster"], "raster_shape": [side, side], "ratio": b["surface"] / b["raster"] * side * side / n,
                     "stages_s": stages})
    mesh, texel, name = bake_subject(args.quick)
    res = 256 if args.quick else 1024

    def bake():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return bake_mesh(mesh, rgb, texel, resolution=res, mni=60.0, uv="mesh", up="z", device=device)

    def raster60():
        return synthesize(rgb, (res, res), mni=60.0, seed=1, device=device)

    b = best({"bake": bake, "raster": raster60}, max(1, args.repeat // 2))
    _, stages = staged(bake, BAKE_STAGES)
    rows.append({"subject": f"bake_mesh {name} {res}² uv='mesh', RGB", "samples": res * res, "total_s": b["bake"],
                 "raster_s": b["raster"], "raster_shape": [res, res], "ratio": b["bake"] / b["raster"],
                 "stages_s": stages})
    return {**report_header("surface_stages", device),
            "parameters": {"texton": list(rgb.size), "points": n, "bake_resolution": res, "repeat": args.repeat,
                           "quick": args.quick},
            "rows": rows}


def markdown(report: dict) -> str:
    lines = [f"# Surface noise and bakes, stage by stage ({report['date']})", "", machine_line(report), "",
             "Totals: best of the runs (taking turns with the raster of as many samples, same texton); stages: one "
             "profiled call (cumulative time of the host functions of each stage, kernels included where they "
             "launch them).", ""]
    for r in report["rows"]:
        lines += [f"## {r['subject']}", "",
                  f"{r['total_s'] * 1e3:.0f} ms; the {r['raster_shape'][1]}×{r['raster_shape'][0]} raster "
                  f"{r['raster_s'] * 1e3:.1f} ms: **{r['ratio']:.1f}×** per sample.", "",
                  "| stage | ms | share |", "|---|---:|---:|"]
        whole = sum(r["stages_s"].values()) or 1.0
        for stage, s in r["stages_s"].items():
            lines.append(f"| {stage} | {s * 1e3:.0f} | {100 * s / whole:.0f} % |")
        lines.append("")
    return "\n".join(lines)


def main(argv=None) -> int:
    return run_main(__doc__, "surface_stages", run, markdown, argv, repeat=3)


if __name__ == "__main__":
    sys.exit(main())
