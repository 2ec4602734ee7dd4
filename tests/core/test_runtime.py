"""Warp start-up (only when needed) and the CPU thread split (warp_texton.core.runtime)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from warp_texton import TextonError
from warp_texton.core.runtime import map_points, resolve_device, split_launch

# Many threads make their first Warp call at once; afterwards the process must still
# own its stderr: a line written to fd 2 must reach the parent, and fd 2 must be the
# same file as before. The threads meet at a barrier so that they really race.
RACE = r"""
import os, sys, threading
before = os.fstat(2)
import warp_texton.core.runtime as R
n = int(sys.argv[1])
barrier = threading.Barrier(n)
def first_call():
    barrier.wait()
    R.resolve_device("cpu")
threads = [threading.Thread(target=first_call) for _ in range(n)]
for t in threads: t.start()
for t in threads: t.join()
after = os.fstat(2)
assert (before.st_dev, before.st_ino) == (after.st_dev, after.st_ino), "fd 2 now points elsewhere"
os.write(2, b"STDERR-STILL-HERE\n")
print("ok")
"""


@pytest.mark.slow
@pytest.mark.parametrize("threads", [2, 8, 32])
def test_concurrent_start_up_keeps_stderr(threads):
    for attempt in range(3):  # a race shows in most tries; three fresh processes each
        done = subprocess.run([sys.executable, "-c", RACE, str(threads)], capture_output=True, text=True,
                              timeout=120)
        assert done.returncode == 0, done.stderr
        assert done.stdout.strip() == "ok"
        assert "STDERR-STILL-HERE" in done.stderr, f"try {attempt}: stderr lost: {done.stderr!r}"


def test_start_up_prints_nothing():
    """Neither Warp's greeting nor its native "no CUDA driver" note reaches the user."""
    code = "import warp_texton.core.runtime as R; R.resolve_device('cpu'); print('done')"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout == "done\n"
    assert done.stderr == ""


@pytest.mark.parametrize("name", ["tpu", "cpu:1", "cuda:99"])
def test_unknown_devices_are_refused(name):
    with pytest.raises(TextonError, match="device"):
        resolve_device(name)


@pytest.mark.parametrize("n", [0, 1, 7, 1000])
def test_split_launch_covers_every_index_once(n, device):
    import warp_texton.kernels.noise_raster as K

    hits = np.zeros(n, int)
    spans = []

    def launch(start, stop):
        assert isinstance(start, int) and isinstance(stop, int)
        spans.append((start, stop))
        hits[start:stop] += 1

    split_launch(device, K, n, launch)
    assert (hits == 1).all()
    assert all(stop > start for start, stop in spans)


def test_map_points_gathers_the_parts_in_order(device):
    import warp_texton.kernels.noise_raster as K

    got = map_points(device, K, 513, lambda a, b: np.arange(a, b)[:, None] * np.ones(3))
    np.testing.assert_array_equal(got[:, 0], np.arange(513))
    assert got.dtype == np.float32 and got.shape == (513, 3)


# The command line answers --version, --help and usage errors without starting Warp
# (a second or more), and the package imports its parts on first use.
NO_WARP = r"""
import sys
from warp_texton.cli.parser import main
for argv in (["--version"], ["--help"], ["synthesize", "--help"], ["surface", "--help"], ["view", "--help"],
             ["synthesize", "in.png", "-o", "out.png", "--width", "wide"], ["nope"], ["analyze", "in.png"]):
    try:
        status = main(argv)
    except SystemExit as exc:
        status = exc.code
    assert status == (0 if argv[-1] in ("--version", "--help") else 2), (argv, status)
import warp_texton
warp_texton.TextonError, warp_texton.__version__
loaded = sorted(m for m in sys.modules if m == "warp" or m.startswith("warp."))
print("warp modules:", loaded)
assert not loaded
# nor SciPy (a second on a cold start): the option values the commands make are imported when used
assert "scipy" not in sys.modules, sorted(m for m in sys.modules if m.startswith("scipy"))[:5]
"""


def test_command_line_start_up_does_not_import_warp():
    done = subprocess.run([sys.executable, "-c", NO_WARP], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "warp modules: []" in done.stdout


def test_package_names_are_imported_on_first_use():
    """``__all__``, the names type checkers see (imported under TYPE_CHECKING) and the
    names the package resolves are the same, and each resolves to its module's object."""
    import ast
    import importlib
    from pathlib import Path

    import warp_texton

    tree = ast.parse(Path(warp_texton.__file__).read_text())
    typed = {a.asname or a.name: node.module for stmt in tree.body if isinstance(stmt, ast.If)
             and ast.unparse(stmt.test) == "TYPE_CHECKING" for node in stmt.body for a in node.names}
    assert set(typed) | {"TextonError", "ExampleWarning", "__version__"} == set(warp_texton.__all__)
    for name, module in typed.items():
        assert getattr(warp_texton, name) is getattr(importlib.import_module(f"warp_texton.{module}"), name), name
    assert set(warp_texton.__all__) <= set(dir(warp_texton))
    with pytest.raises(AttributeError, match="no_such_name"):
        warp_texton.no_such_name  # noqa: B018
