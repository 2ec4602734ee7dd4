"""Benchmark: spatially varying (mixed) texton noise against plain texton noise.

Times ``synthesize_mixed`` with 21 textons across the width (CGF §7, Fig. 5)
against ``synthesize`` with one texton of the same size, at the same MNI and
raster size, interleaved in one run. Goal: the mix costs at most 1.5× the plain
noise.

    python benchmarks/bench_mixing.py            # full run, writes results/
    python benchmarks/bench_mixing.py --quick    # smoke run (CI)
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

from warp_texton import mix_textons, synthesize, synthesize_mixed  # noqa: E402
from warp_texton.core.runtime import resolve_device  # noqa: E402


def run(args) -> dict:
    device = resolve_device(args.device)
    side = 256 if args.quick else 512
    u = make_texture(side)
    v = np.ascontiguousarray(u.transpose(1, 0, 2)[:, :, ::-1])  # the same material turned 90°, channels swapped
    t0 = time.perf_counter()
    textons = mix_textons(u, v, np.linspace(0.0, 1.0, args.steps), size=args.size, seed=0)
    t_mix_analysis = time.perf_counter() - t0
    sizes = [(256, 256)] if args.quick else [(1024, 1024), (2160, 3840)]
    synthesize(textons[0], (64, 64), device=device)
    synthesize_mixed(textons, "strips", (64, 64), device=device)
    rows = []
    for shape in sizes:
        plain, mixed = [], []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            synthesize(textons[args.steps // 2], shape, mni=args.mni, seed=1, device=device)
            plain.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            synthesize_mixed(textons, "strips", shape, mni=args.mni, seed=1, device=device)
            mixed.append(time.perf_counter() - t0)
        row = {"shape": list(shape),
               "plain": {"best_s": min(plain), "median_s": statistics.median(plain)},
               "mixed": {"best_s": min(mixed), "median_s": statistics.median(mixed)}}
        row["ratio_best"] = row["mixed"]["best_s"] / row["plain"]["best_s"]
        row["ratio_median"] = row["mixed"]["median_s"] / row["plain"]["median_s"]
        rows.append(row)
        print(f"  {shape[1]}x{shape[0]}: mixed {row['mixed']['best_s']:.3f} s, plain {row['plain']['best_s']:.3f} s, "
              f"ratio {row['ratio_best']:.2f}", flush=True)
    return {
        **report_header("mixing", device),
        "parameters": {"textons": args.steps, "texton": list(textons[0].size), "channels": textons[0].channels,
                       "mni": args.mni, "repeat": args.repeat, "quick": args.quick},
        "mix_textons_seconds": t_mix_analysis,
        "results": rows,
    }


def markdown(report: dict) -> str:
    p = report["parameters"]
    lines = [
        f"# Mixed vs plain texton noise ({report['date']})",
        "",
        machine_line(report),
        f"{p['textons']} RGB textons of {p['texton'][0]}x{p['texton'][1]} in strips vs one texton, MNI {p['mni']:g}; "
        f"best of {p['repeat']} interleaved runs (median in brackets). "
        f"`mix_textons` for the {p['textons']} textons took {report['mix_textons_seconds']:.2f} s.",
        "",
        "| raster | mixed (s) | plain (s) | ratio mixed/plain |",
        "|---|---|---|---|",
    ]
    for r in report["results"]:
        h, w = r["shape"]
        lines.append(f"| {w}x{h} | {r['mixed']['best_s']:.3f} ({r['mixed']['median_s']:.3f}) | "
                     f"{r['plain']['best_s']:.3f} ({r['plain']['median_s']:.3f}) | "
                     f"{r['ratio_best']:.2f} ({r['ratio_median']:.2f}) |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    return run_main(__doc__, "mixing", run, markdown, argv,
                    extra_args=lambda p: p.add_argument("--steps", type=int, default=21, help="number of mixed textons"))


if __name__ == "__main__":
    sys.exit(main())
