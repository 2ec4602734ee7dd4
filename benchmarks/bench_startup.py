"""Benchmark: what a command costs before its work, whole process (issue 33).

Each row is a child process timed from outside, start-up and exit included:
the interpreter alone, ``import numpy``, ``warp-texton --version``, and the
small render the issue's goal names (``synthesize`` of 16 × 16 pixels from an
8 × 8 texton file: the wall time to the first pixel, ≤ 0.8 s) plus a small
``analyze``. Wall seconds and the child's CPU seconds (user + system), the
median of ``--repeat`` runs, the rows taking turns. ``--base DIR`` adds the
same commands run from another source tree (a checkout of an earlier commit,
``git worktree add DIR COMMIT``; DIR/warp_texton/kernels must point at
DIR/kernels, as the installed package maps them), for a before/after table.

    python benchmarks/bench_startup.py --repeat 7
    python benchmarks/bench_startup.py --base /tmp/before --repeat 7
"""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import machine_line, report_header, run_main  # noqa: E402

import numpy as np  # noqa: E402

CLI = "import sys; from warp_texton.cli.parser import main; sys.exit(main())"  # what the console script runs


def commands(folder: Path) -> dict[str, list[str]]:
    t, img = str(folder / "t.exr"), str(folder / "u.png")
    return {
        "python -c pass": ["-c", "pass"],
        "import numpy": ["-c", "import numpy"],
        "warp-texton --version": ["-c", CLI, "--version"],
        "synthesize 16x16 from a texton file": ["-c", CLI, "synthesize", t, "-o", str(folder / "o.exr"),
                                                "--width", "16", "--height", "16", "--device", "cpu", "-q"],
        "analyze a 64x64 example, size 16": ["-c", CLI, "analyze", img, "-o", str(folder / "a.exr"),
                                             "--size", "16", "-q"],
    }


def timed(argv: list[str], env: dict, cwd: Path) -> tuple[float, float]:
    """(wall, CPU) seconds of one child process, run in ``cwd`` (not the repository's root,
    whose warp_texton/ would shadow --base's: ``-c`` puts the working folder first on sys.path)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, *argv], env=env, capture_output=True, text=True, cwd=cwd)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise RuntimeError(f"{argv}: exit {done.returncode}: {done.stderr[-500:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def run(args) -> dict:
    from warp_texton import Texton, write_image

    trees = {"this tree": None}
    if args.base is not None:
        trees["base"] = str(Path(args.base).resolve())
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        Texton(np.full((8, 8, 1), 0.1, np.float32), [0.5]).save(folder / "t.exr")
        write_image(folder / "u.png", np.random.default_rng(0).random((64, 64)).astype(np.float32))
        envs = {name: {**os.environ, **({"PYTHONPATH": path} if path else {})} for name, path in trees.items()}
        cmds = commands(folder)
        times: dict = {(t, c): [] for t in trees for c in cmds}
        for name in trees:  # warm the caches (kernels, files) once
            for argv in cmds.values():
                timed(argv, envs[name], folder)
        for _ in range(args.repeat):  # take turns, so that a change in the machine's load hits every row
            for c, argv in cmds.items():
                for name in trees:
                    times[(name, c)].append(timed(argv, envs[name], folder))
    rows = [{"tree": t, "command": c, "wall_s": statistics.median(w for w, _ in v),
             "cpu_s": statistics.median(u for _, u in v), "wall_min_s": min(w for w, _ in v)}
            for (t, c), v in times.items()]
    return {**report_header("startup", "cpu"),
            "parameters": {"repeat": args.repeat, "base": args.base}, "rows": rows}


def markdown(report: dict) -> str:
    lines = ["# Start-up: whole-process time of small commands", "",
             machine_line(report) + f" {report['date']}. Medians of {report['parameters']['repeat']} runs.", "",
             "| source | command | wall (s) | wall, best (s) | CPU (s) |", "|---|---|---:|---:|---:|"]
    lines += [f"| {r['tree']} | {r['command']} | {r['wall_s']:.2f} | {r['wall_min_s']:.2f} | {r['cpu_s']:.2f} |"
              for r in report["rows"]]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    return run_main(__doc__, "startup", run, markdown, argv, repeat=5,
                    extra_args=lambda p: p.add_argument("--base", help="another source tree to compare with"))


if __name__ == "__main__":
    sys.exit(main())
