"""Benchmark: the block path's CPU loops (kernels/surface_native.py), vector form against plain C++.

``surface_noise`` at the vertices of the torus of bench_surface.py (about 1M
vertices, MNI 60, RGB 64² texton) with ``warp_texton.surface.blocks.SIMD`` on and
off, interleaved in one run:

* in this process, built for this CPU (Warp's ``-march=native``);
* where that build is AVX-512, also in a child process built for AVX2 only
  (Warp's CPU flags with ``-target-feature -avx512f``: what a CPU without
  AVX-512 compiles), to check that the vector form is taken there and what it
  gains.

Both builds give the same values (tests/test_surface.py); only the time differs.

    python benchmarks/bench_simd.py            # full run, writes results/simd.json and .md
    python benchmarks/bench_simd.py --quick    # smoke run
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import warp as wp  # noqa: E402

#: CPU compiler flags of a child run (set before any kernel module is built).
FLAGS_VAR = "WARP_TEXTON_BENCH_CPU_FLAGS"
if os.environ.get(FLAGS_VAR):
    wp.config.cpu_compiler_flags = os.environ[FLAGS_VAR]

import numpy as np  # noqa: E402
import trimesh  # noqa: E402

from bench_surface import interleaved  # noqa: E402
from common import machine_line, make_texture, report_header, run_main  # noqa: E402

import warp_texton.surface.blocks as S  # noqa: E402
from warp_texton import analyze, surface_noise  # noqa: E402

#: Warp's default CPU flags without AVX-512.
AVX2_FLAGS = (wp.config.cpu_compiler_flags or "-march=native").replace(
    "-march=native", "-march=native -target-feature -avx512f")


def measure(args) -> dict:
    """The loops this build holds, and the vector and scalar forms' times (interleaved)."""
    texton = analyze(make_texture(256 if args.quick else 512), size=args.size, seed=0)
    sections = 100 if args.quick else 1000
    torus = trimesh.creation.torus(major_radius=1.0, minor_radius=0.35, major_sections=sections,
                                   minor_sections=sections)
    pts, nrm = np.asarray(torus.vertices), np.asarray(torus.vertex_normals)

    def run(simd):
        def call():
            S.SIMD = simd
            try:
                return surface_noise(texton, pts, nrm, 0.004, mni=args.mni, device="cpu")
            finally:
                S.SIMD = True
        return call

    clock = time.process_time if args.clock == "cpu" else time.perf_counter
    times = interleaved({"vector": run(True), "scalar": run(False)}, args.repeat, clock)
    return {"loops": S.simd_loops("cpu"), "cpu_compiler_flags": wp.config.cpu_compiler_flags, "vertices": len(pts),
            **times, "speedup": times["scalar"]["best_s"] / times["vector"]["best_s"]}


def run(args) -> dict:
    if args.child:
        print(json.dumps(measure(args)))
        sys.exit(0)
    builds = {"native": measure(args)}
    if builds["native"]["loops"] == "avx512":
        argv = [sys.executable, str(Path(__file__).resolve()), "--child", "--repeat", str(args.repeat), "--mni",
                str(args.mni), "--size", str(args.size), "--clock", args.clock] + (["--quick"] if args.quick else [])
        done = subprocess.run(argv, env={**os.environ, FLAGS_VAR: AVX2_FLAGS}, capture_output=True, text=True,
                              check=True)
        builds["avx2_only"] = json.loads(done.stdout.strip().splitlines()[-1])
    for name, b in builds.items():
        print(f"  {name}: {b['loops']} loops {b['vector']['best_s']:.3f} s, scalar {b['scalar']['best_s']:.3f} s "
              f"(x{b['speedup']:.2f})")
    return {**report_header("simd", "cpu"),
            "parameters": {"texton": [args.size, args.size], "mni": args.mni, "texel_size": 0.004,
                           "repeat": args.repeat, "quick": args.quick, "clock": args.clock},
            "builds": builds}


def markdown(report: dict) -> str:
    p = report["parameters"]
    lines = [f"# Block path CPU loops: vector against scalar ({report['date']})", "", machine_line(report),
             f"`surface_noise` at the vertices of a torus, RGB texton {p['texton'][0]}x{p['texton'][1]}, "
             f"MNI {p['mni']:g}; best of {p['repeat']} interleaved runs (median in brackets), "
             f"{'CPU time of the process' if p['clock'] == 'cpu' else 'wall-clock time'}.", "",
             "| build | loops | points | vector (s) | scalar (s) | vector speed-up |", "|---|---|---:|---:|---:|---:|"]
    for name, b in report["builds"].items():
        lines.append(f"| {name} | {b['loops']} | {b['vertices']} | {b['vector']['best_s']:.3f} "
                     f"({b['vector']['median_s']:.3f}) | {b['scalar']['best_s']:.3f} ({b['scalar']['median_s']:.3f}) "
                     f"| x{b['speedup']:.2f} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    def extra(parser):
        parser.add_argument("--clock", choices=("wall", "cpu"), default="cpu",
                            help="wall-clock time, or the CPU time of the process (all its threads): steadier on a "
                                 "machine that others load")
        parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)  # print measure() as JSON

    return run_main(__doc__, "simd", run, markdown, argv, repeat=5, mni=60.0, extra_args=extra)


if __name__ == "__main__":
    sys.exit(main())
