"""Benchmark: where one frame of texton noise spends its time, grey against RGB.

A 1920×1080 frame at MNI 30 from a 64² texton (the grey mean of the test
texture, and the RGB texture itself), on the CPU:

* **frames** — the grey frame, the RGB frame and FastNoiseLite's OpenSimplex2
  frame (``pyfastnoiselite``, ``gen_from_coords``, one thread; skipped when
  absent), interleaved, wall-clock and CPU time of the process;
* **phases** — the CPU time of each kernel of a frame (its threads' own
  clocks): drawing the impacts (``count_impacts``, ``emit_impacts``), splatting
  (``splat_impacts``), normalising (``normalize_rows``), and the rest of the
  process's CPU time (set-up, the canvas, hand-over) — best of the runs;
* **memory against arithmetic** — the same number of (pixel, impact) pairs
  splatted into a 512² grey raster (1 MiB, held in L2) at a higher MNI, per
  pair against the frame (8 MiB of output, beyond L2);
* **thread split** — the grey frame in a child process pinned to one core,
  against the threads of this process (one per core), wall-clock and CPU time.

    python benchmarks/bench_frame.py            # full run → results/frame.{json,md}
    python benchmarks/bench_frame.py --quick    # smoke run (480×270, texton 32²)
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(1, str(HERE.parent))

from common import machine_line, make_texture, report_header, run_main  # noqa: E402

import warp as wp  # noqa: E402

import warp_texton.noise.raster as raster_module  # noqa: E402
from warp_texton import analyze, synthesize  # noqa: E402

#: Floating-point operations of one (pixel, channel, impact) term of a grid splat:
#: the vertical blend (2 products, 1 sum), the horizontal (2, 1), the accumulation.
FLOPS_PER_TERM = 7


def textons(args):
    u = make_texture(256 if args.quick else 512)
    grey = analyze(np.ascontiguousarray(u.mean(axis=2, keepdims=True)), size=args.size, seed=0)
    return grey, analyze(u, size=args.size, seed=0)


def best(times):
    return {"best_s": min(times), "median_s": float(np.median(times)), "runs": len(times)}


def interleaved(methods: dict, repeat: int) -> dict:
    """Wall-clock and process CPU time of each method, in turns, after one untimed call each."""
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
    return {k: {"wall": best(wall[k]), "cpu": best(cpu[k])} for k in methods}


class KernelClock:
    """Thread CPU time of each kernel launched by warp_texton.noise.raster (one launch runs on one thread)."""

    def __init__(self):
        self.seconds: dict = collections.defaultdict(float)
        self._launch = raster_module.wp.launch

    def __enter__(self):
        def launch(kernel, *a, **kw):
            t0 = time.thread_time()
            self._launch(kernel, *a, **kw)
            self.seconds[kernel.key] += time.thread_time() - t0

        raster_module.wp.launch = launch
        return self

    def __exit__(self, *exc):
        raster_module.wp.launch = self._launch


def phases(texton, shape, mni, repeat) -> dict:
    """The run with the least process CPU time: its kernels' thread CPU times and the rest."""
    synthesize(texton, shape, mni=mni, seed=1, device="cpu")
    chosen = None
    for _ in range(repeat):
        with KernelClock() as clock:
            c0 = time.process_time()
            synthesize(texton, shape, mni=mni, seed=1, device="cpu")
            total = time.process_time() - c0
        if chosen is None or total < chosen["total_s"]:
            chosen = {"total_s": total, **{k: v for k, v in clock.seconds.items()}}
    kernels = sum(v for k, v in chosen.items() if k != "total_s")
    chosen["host_s"] = chosen["total_s"] - kernels
    return chosen


def child(args) -> None:
    """The grey frame on one core (this process pinned to it): JSON on stdout."""
    os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    grey, _ = textons(args)
    shape = frame_shape(args)
    r = interleaved({"grey": lambda: synthesize(grey, shape, mni=args.mni, seed=1, device="cpu")}, args.repeat)
    print(json.dumps(r["grey"]))


def frame_shape(args):
    return (270, 480) if args.quick else (1080, 1920)


def run(args) -> dict:
    if args.child:
        child(args)
        sys.exit(0)
    grey, rgb = textons(args)
    shape = frame_shape(args)
    h, w = shape
    methods = {"grey": lambda: synthesize(grey, shape, mni=args.mni, seed=1, device="cpu"),
               "RGB": lambda: synthesize(rgb, shape, mni=args.mni, seed=1, device="cpu")}
    try:
        sys.path.insert(0, str(HERE.parent))
        from benchmarks.peers import FastNoiseLiteFrame, fastnoiselite_missing
        if fastnoiselite_missing() is None:
            methods["FastNoiseLite"] = FastNoiseLiteFrame(shape)
    except ImportError:
        pass
    frames = interleaved(methods, args.repeat)
    print("frames: " + ", ".join(f"{k} {v['wall']['best_s'] * 1e3:.1f} ms (CPU {v['cpu']['best_s'] * 1e3:.1f})"
                                 for k, v in frames.items()), flush=True)
    parts = {"grey": phases(grey, shape, args.mni, args.repeat), "RGB": phases(rgb, shape, args.mni, args.repeat)}
    # the same (pixel, impact) pairs into a raster that L2 holds
    side = 128 if args.quick else 512
    small_mni = args.mni * h * w / (side * side)
    parts["grey, L2-resident"] = phases(grey, (side, side), small_mni, args.repeat)
    argv = [sys.executable, str(Path(__file__).resolve()), "--child", "--repeat", str(args.repeat), "--mni",
            str(args.mni), "--size", str(args.size)] + (["--quick"] if args.quick else [])
    done = subprocess.run(argv, capture_output=True, text=True, check=True)
    one_core = json.loads(done.stdout.strip().splitlines()[-1])
    pairs = h * w * args.mni
    return {**report_header("frame", "cpu"),
            "parameters": {"shape": [h, w], "mni": args.mni, "texton": args.size, "repeat": args.repeat,
                           "quick": args.quick, "threads": len(os.sched_getaffinity(0)),
                           "l2_side": side, "l2_mni": small_mni, "flops_per_term": FLOPS_PER_TERM},
            "frames": frames, "phases": parts, "one_core": one_core, "pairs": pairs,
            "simd": wp.config.cpu_compiler_flags}


def ms(x: float) -> str:
    return f"{x * 1e3:.1f}"


def markdown(report: dict) -> str:
    p, f, ph = report["parameters"], report["frames"], report["phases"]
    h, w = p["shape"]
    pairs = report["pairs"]
    lines = [f"# One frame, grey against RGB ({report['date']})", "", machine_line(report),
             f"{w}×{h}, MNI {p['mni']:g}, texton {p['texton']}², {p['threads']} threads; best of {p['repeat']} "
             "interleaved runs (median in brackets).", "",
             "| frame | wall (ms) | CPU of the process (ms) | ÷ grey (wall) | ÷ grey (CPU) |", "|---|---:|---:|---:|---:|"]
    g = f["grey"]
    for k, v in f.items():
        lines.append(f"| {k} | {ms(v['wall']['best_s'])} ({ms(v['wall']['median_s'])}) | {ms(v['cpu']['best_s'])} "
                     f"({ms(v['cpu']['median_s'])}) | {v['wall']['best_s'] / g['wall']['best_s']:.2f} | "
                     f"{v['cpu']['best_s'] / g['cpu']['best_s']:.2f} |")
    lines += ["", "CPU time by phase (ms; kernels on their threads' clocks, the run with the least process CPU time):",
              "", "| raster | impacts (count + emit) | splat | normalize | host | total | splat rate |",
              "|---|---:|---:|---:|---:|---:|---:|"]
    for k, v in ph.items():
        channels = 3 if k == "RGB" else 1
        terms = pairs * channels
        rate = terms * p["flops_per_term"] / v.get("splat_impacts", float("nan")) / 1e9
        lines.append(f"| {k} | {ms(v.get('count_impacts', 0.0) + v.get('emit_impacts', 0.0))} | "
                     f"{ms(v.get('splat_impacts', 0.0))} | {ms(v.get('normalize_rows', 0.0))} | {ms(v['host_s'])} | "
                     f"{ms(v['total_s'])} | {rate:.1f} GFLOP/s |")
    one = report["one_core"]
    lines += ["", f"Grey frame on one core: wall {ms(one['wall']['best_s'])} ms, CPU {ms(one['cpu']['best_s'])} ms; "
              f"on {p['threads']} threads: wall {ms(g['wall']['best_s'])} ms (×{one['wall']['best_s'] / g['wall']['best_s']:.2f}), "
              f"CPU {ms(g['cpu']['best_s'])} ms (×{g['cpu']['best_s'] / one['cpu']['best_s']:.2f} of one core's)."]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    def extra(parser):
        parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)  # one core, JSON out

    return run_main(__doc__, "frame", run, markdown, argv, repeat=7, mni=30.0, extra_args=extra)


if __name__ == "__main__":
    sys.exit(main())
