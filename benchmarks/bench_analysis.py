"""Benchmark: texton analysis, package vs. a plain NumPy version of the same algorithm.

Both sides run EUSIPCO Algorithm 2 / CGF §4.2 Algorithm 1 on the same colour
texture, from the same random phase, with the same target |t̂_u|/√b̂, the same
periodic component and normalisation, and the same 3 × 3 colour correction;
both end with the relative model error of the result. They differ only in how
they compute:

* baseline (this file): complex128 ``np.fft.fft2`` / ``np.fft.ifft2`` of the
  full M × N × C grid at every iteration, the phase as ``exp(1j·angle(·))``;
* package: ``warp_texton.analyze``, float32 real FFTs that skip the rows and
  columns outside the support (see ``warp_texton/model/analysis.py``).

The script checks that the two model errors agree within 0.01, prints a
Markdown table and writes ``analysis.json`` and ``analysis.md`` (or
``analysis_quick.*`` with ``--quick``) into ``--out``.

    python benchmarks/bench_analysis.py            # 512 × 512 RGB, the recorded run
    python benchmarks/bench_analysis.py --quick    # 256 × 256 smoke run
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from warp_texton import Texton, analyze
from warp_texton.model.analysis import correct_colors, initial_phase
from warp_texton.model.bspline import bhat
from warp_texton.model.gaussian import normalized_kernel, relative_model_error

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import git_commit, git_dirty, machine_info, make_texture, write_atomic  # noqa: E402

HERE = Path(__file__).resolve().parent
RME_TOLERANCE = 0.01

# Channel mixing of the three grey scikit-image textures: every channel sees
# every source, so the RGB channels are correlated like those of a photograph.




def full_phase(shape: tuple[int, int], seed: int) -> np.ndarray:
    """The package's initial phase (rfft half-plane) extended to the full DFT grid.

    A real image's DFT is Hermitian: φ(−ξ) = conj φ(ξ), which fills the columns
    the half-plane leaves out.
    """
    m, n = shape
    half = initial_phase(shape, seed)
    full = np.empty((m, n), dtype=np.complex128)
    nc = half.shape[1]
    full[:, :nc] = half
    rows = (-np.arange(m)) % m
    cols = np.arange(nc, n)
    full[:, nc:] = np.conj(half[rows][:, (n - cols) % n])
    return full


def baseline_analyze(u: np.ndarray, size: int, order: int, iterations: int, seed: int) -> Texton:
    """The straightforward NumPy analysis: full complex128 FFTs at every iteration."""
    mean, t = normalized_kernel(u, periodic=True)  # float64 (M, N, C)
    m, n, c = t.shape
    t_hat = np.fft.fft2(t, axes=(0, 1))
    target = t_hat / np.sqrt(bhat((m, n), order))[:, :, None]
    target_conj = np.conj(target)
    mask = np.zeros((m, n, 1))
    mask[:size, :size] = 1.0

    # the same start as the package: the white noise's phase, in every channel, projected
    a_hat = np.repeat(full_phase((m, n), seed)[:, :, None], c, axis=2)
    alpha = np.zeros((m, n, c))
    for it in range(iterations):
        if it:
            a_hat = np.fft.fft2(alpha, axes=(0, 1))
        # angle(0) = 0 gives phase 1 where the product vanishes (EUSIPCO eq. (2)
        # sets 0 there); the target is ~0 at such frequencies, so it does not matter.
        phase = np.exp(1j * np.angle(np.sum(a_hat * target_conj, axis=2, keepdims=True)))
        alpha = np.fft.ifft2(target * phase, axes=(0, 1)).real * mask

    flat = t.reshape(-1, c)
    coeffs = correct_colors(alpha[:size, :size], order, flat.T @ flat)
    texton = Texton(coeffs, mean.astype(np.float32), order, {"periodic": True})
    texton.metadata["model_error"] = relative_model_error(t_hat, texton.spectrum((m, n)))
    return texton


def timed(fn) -> tuple[float, object]:
    """Seconds one call of ``fn`` takes, and its result."""
    t0 = time.perf_counter()
    result = fn()
    return time.perf_counter() - t0, result














def markdown(report: dict) -> str:
    p, r, mach = report["parameters"], report["results"], report["machine"]
    b, k = r["baseline"], r["package"]
    lines = [
        f"Texton analysis of a {p['image'][0]}×{p['image'][1]} RGB texture, size {p['size']}, "
        f"order {p['order']}, {p['iterations']} iterations, best and median of {p['repeat']} runs.",
        "",
        "| implementation | best (s) | median (s) | model error (RME) |",
        "| --- | ---: | ---: | ---: |",
        f"| NumPy baseline (complex128, full grid) | {b['best_s']:.3f} | {b['median_s']:.3f} | {b['rme']:.4f} |",
        f"| `warp_texton.analyze` | {k['best_s']:.3f} | {k['median_s']:.3f} | {k['rme']:.4f} |",
        "",
        f"Of the package's time, {r['package_one_iteration']['best_s']:.3f} s (best) is fixed cost: the same "
        "call with one iteration (periodic component, target, colour correction, model error).",
        "",
        f"Speed ratio (baseline / package): **{r['speedup_best']:.1f}×** on best times, "
        f"{r['speedup_median']:.1f}× on medians; |ΔRME| = {r['rme_difference']:.4f}.",
        "",
        f"Machine: {mach['processor']}, {mach['cpu_count']} CPUs, {mach['platform']}; "
        f"Python {mach['python']}, NumPy {mach['numpy']}, SciPy {mach['scipy']}; "
        f"device {report['device']}; {report['date']}; commit {report['git_commit'] or 'unknown'}.",
    ]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        description="Time warp_texton.analyze against a plain NumPy version of the same analysis.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    parser.add_argument("--quick", action="store_true",
                        help="smoke run: 256x256 image, 2 repeats, results in analysis_quick.*")
    parser.add_argument("--out", type=Path, default=HERE / "results", help="folder for the results")
    parser.add_argument("--repeat", type=int, default=None,
                        help="timed runs of each implementation; None means 7, or 2 with --quick")
    parser.add_argument("--size", type=int, default=64, help="texton side")
    parser.add_argument("--order", type=int, default=1, choices=(0, 1, 3, 5), help="interpolation order")
    parser.add_argument("--iterations", type=int, default=50, help="alternating projections")
    parser.add_argument("--seed", type=int, default=0, help="seed of the initial phase")
    args = parser.parse_args(argv)

    # The checkout's state when the package was imported, i.e. the code that runs.
    commit, dirty = git_commit(), git_dirty()
    side = 256 if args.quick else 512
    repeat = args.repeat if args.repeat is not None else (2 if args.quick else 7)
    if repeat < 1:
        parser.error("--repeat must be at least 1")
    args.out.mkdir(parents=True, exist_ok=True)

    u = make_texture(side)
    params = dict(size=args.size, order=args.order, iterations=args.iterations, seed=args.seed)
    print(f"image {side}x{side}x3, {params}, {repeat} timed runs each", flush=True)

    # One untimed warm-up each (imports, FFT plans), then interleaved timed runs
    # so that a slow spell of the machine hits both alike.
    baseline_analyze(u, **params)
    analyze(u, **params)
    base_times, pkg_times = [], []
    for _ in range(repeat):
        tb, base = timed(lambda: baseline_analyze(u, **params))
        tp, pkg = timed(lambda: analyze(u, **params))
        base_times.append(tb)
        pkg_times.append(tp)
    # The package's fixed cost (periodic component, target, colour correction,
    # RME): the same call with a single iteration.
    fixed_times = [timed(lambda: analyze(u, **{**params, "iterations": 1}))[0] for _ in range(repeat)]

    rme_base = float(base.metadata["model_error"])
    rme_pkg = float(pkg.metadata["model_error"])
    diff = abs(rme_base - rme_pkg)
    if diff > RME_TOLERANCE:
        print(f"error: model errors differ by {diff:.4f} (baseline {rme_base:.4f}, "
              f"package {rme_pkg:.4f}); tolerance {RME_TOLERANCE}", file=sys.stderr)
        return 1
    coeff_diff = float(np.abs(base.coeffs - pkg.coeffs).max() / np.abs(base.coeffs).max())

    def summary(times, rme):
        return {"best_s": min(times), "median_s": statistics.median(times), "times_s": times, "rme": rme}

    report = {
        "benchmark": "analysis",
        "device": "cpu",
        "date": _dt.datetime.now(_dt.timezone.utc).astimezone().isoformat(timespec="seconds"),
        "git_commit": commit,
        "git_dirty": dirty,
        "machine": machine_info(),
        "parameters": {"image": [side, side, 3], "texture": "skimage grass/gravel/brick mixed", **params,
                       "repeat": repeat, "quick": bool(args.quick)},
        "results": {
            "baseline": summary(base_times, rme_base),
            "package": summary(pkg_times, rme_pkg),
            "package_one_iteration": {"best_s": min(fixed_times),
                                      "median_s": statistics.median(fixed_times), "times_s": fixed_times},
            "speedup_best": min(base_times) / min(pkg_times),
            "speedup_median": statistics.median(base_times) / statistics.median(pkg_times),
            "rme_difference": diff,
            "rme_tolerance": RME_TOLERANCE,
            "coeff_max_rel_difference": coeff_diff,
        },
    }
    md = markdown(report)
    print()
    print(md, end="")
    stem = "analysis_quick" if args.quick else "analysis"
    write_atomic(args.out / f"{stem}.json", json.dumps(report, indent=2) + "\n")
    write_atomic(args.out / f"{stem}.md", md)
    print(f"\nwrote {args.out / (stem + '.json')} and {args.out / (stem + '.md')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
