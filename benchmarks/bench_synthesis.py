"""Benchmark: texton noise rasters on the CPU (or CUDA) against the FFT sample.

Times ``warp_texton.synthesize`` for an RGB texton of 64², MNI 30, at 1024²
and 3840×2160, against the NumPy/SciPy FFT sample of the same Gaussian model
(white noise → rfft2 → multiply by the model's transfer function α̂√b̂ → irfft2,
float32, all cores), measured in the same run and interleaved so that both
see the same machine load. Also times, at 1024², the naive per-pixel path
(``evaluate`` at every pixel centre: each pixel draws its cells' impacts
itself, nothing shared) to show what sharing the impacts gains.

    python benchmarks/bench_synthesis.py            # full run, writes results/
    python benchmarks/bench_synthesis.py --quick    # smoke run (CI)
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np
import scipy.fft as sfft

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import machine_line, make_texture, report_header, run_main  # noqa: E402

from warp_texton import analyze, evaluate, synthesize  # noqa: E402
from warp_texton.model.bspline import bhat  # noqa: E402
from warp_texton.core.runtime import resolve_device  # noqa: E402


class FFTSample:
    """The spectral method: m + (α̂√b̂) ⊛ W on an H × W grid, float32."""

    def __init__(self, texton, shape):
        self.shape = shape
        self.mean = texton.mean
        a_hat = sfft.rfft2(texton.coeffs, s=shape, axes=(0, 1), workers=-1)
        nc = shape[1] // 2 + 1
        self.transfer = (a_hat * np.sqrt(bhat(shape, texton.order))[:, :nc, None]).astype(np.complex64)
        self.rng = np.random.default_rng(0)

    def __call__(self):
        w = self.rng.standard_normal(self.shape, dtype=np.float32)
        w_hat = sfft.rfft2(w, workers=-1)
        g = sfft.irfft2(self.transfer * w_hat[:, :, None], s=self.shape, axes=(0, 1), workers=-1)
        return g + self.mean


def best_and_median(times):
    return {"best_s": min(times), "median_s": statistics.median(times), "runs": len(times)}


def run(args) -> dict:
    device = resolve_device(args.device)
    side = 256 if args.quick else 512
    texton = analyze(make_texture(side), size=args.size, seed=0)
    sizes = [(256, 256)] if args.quick else [(1024, 1024), (2160, 3840)]
    synthesize(texton, (64, 64), device=device)  # compile / load the kernels outside the timing
    rows = []
    for shape in sizes:
        fft = FFTSample(texton, shape)
        t_noise, t_fft = [], []
        for _ in range(args.repeat):  # interleaved: both see the same load
            t0 = time.perf_counter()
            synthesize(texton, shape, mni=args.mni, seed=1, device=device)
            t_noise.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            fft()
            t_fft.append(time.perf_counter() - t0)
        row = {"shape": list(shape), "texton_noise": best_and_median(t_noise), "fft": best_and_median(t_fft)}
        row["ratio_best"] = row["texton_noise"]["best_s"] / row["fft"]["best_s"]
        row["ratio_median"] = row["texton_noise"]["median_s"] / row["fft"]["median_s"]
        rows.append(row)
        print(f"  {shape[1]}x{shape[0]}: texton noise {row['texton_noise']['best_s']:.3f} s, "
              f"FFT {row['fft']['best_s']:.3f} s, ratio {row['ratio_best']:.2f}", flush=True)
    naive = None
    if not args.quick:
        h, w = 1024, 1024
        jj, ii = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
        pts = np.stack([jj.ravel(), ii.ravel()], axis=1)
        t0 = time.perf_counter()
        evaluate(texton, pts, mni=args.mni, seed=1, device=device)
        naive = {"shape": [h, w], "seconds": time.perf_counter() - t0}
        print(f"  naive per-pixel 1024x1024: {naive['seconds']:.3f} s", flush=True)
    return {
        **report_header("synthesis", device),
        "parameters": {"texton": list(texton.size), "channels": texton.channels, "order": texton.order,
                       "mni": args.mni, "repeat": args.repeat, "quick": args.quick},
        "results": rows,
        "naive_per_pixel": naive,
    }


def markdown(report: dict) -> str:
    p = report["parameters"]
    lines = [
        f"# Texton noise vs FFT synthesis ({report['date']})",
        "",
        machine_line(report),
        f"Texton {p['texton'][0]}x{p['texton'][1]} RGB, order {p['order']}, MNI {p['mni']:g}; "
        f"best of {p['repeat']} interleaved runs (median in brackets).",
        "",
        "| raster | texton noise (s) | FFT sample (s) | ratio noise/FFT |",
        "|---|---|---|---|",
    ]
    for r in report["results"]:
        h, w = r["shape"]
        lines.append(f"| {w}x{h} | {r['texton_noise']['best_s']:.3f} ({r['texton_noise']['median_s']:.3f}) | "
                     f"{r['fft']['best_s']:.3f} ({r['fft']['median_s']:.3f}) | "
                     f"{r['ratio_best']:.2f} ({r['ratio_median']:.2f}) |")
    if report["naive_per_pixel"]:
        n = report["naive_per_pixel"]
        lines += ["", f"Naive per-pixel evaluation (no shared impacts), 1024x1024: {n['seconds']:.3f} s."]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    return run_main(__doc__, "synthesis", run, markdown, argv)


if __name__ == "__main__":
    sys.exit(main())
