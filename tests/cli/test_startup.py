"""What a command costs before its work (issue 33): the modules a small render imports, the
wall time its summary prints, and the rank function that replaced SciPy's."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np
import pytest

from warp_texton import Texton
from warp_texton.model.histogram import mean_ranks

_RENDER = """
import json, sys
from warp_texton.cli.parser import main
status = main(["synthesize", sys.argv[1], "-o", sys.argv[2], "--width", "16", "--height", "16", "--device", "cpu",
               "-q"])
print(json.dumps([status, sorted(m for m in sys.modules if m.split(".")[0] == "scipy")]))
"""


def test_small_render_imports_no_scipy(tmp_path):
    """A render from a texton file never imports SciPy (scipy.stats alone took 1.2 s to import)."""
    Texton(np.full((8, 8, 3), 0.1, np.float32), [0.5, 0.5, 0.5]).save(tmp_path / "t.exr")
    done = subprocess.run([sys.executable, "-c", _RENDER, str(tmp_path / "t.exr"), str(tmp_path / "o.exr")],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    status, scipy_modules = json.loads(done.stdout.strip().splitlines()[-1])
    assert status == 0 and (tmp_path / "o.exr").is_file()
    assert scipy_modules == []


def test_summary_gives_the_wall_time(tmp_path):
    """The installed program's summary gives the work's time and the wall time since the
    process started, which includes the start-up: no smaller than the work's."""
    Texton(np.full((8, 8, 1), 0.1, np.float32), [0.5]).save(tmp_path / "t.exr")
    script = [sys.executable, "-c", "import sys; from warp_texton.cli.parser import main; sys.exit(main())"]
    done = subprocess.run([*script, "synthesize", str(tmp_path / "t.exr"), "-o", str(tmp_path / "o.exr"),
                           "--width", "16", "--height", "16", "--device", "cpu"],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    found = re.search(r"\((\d+\.\d\d) s, (\d+\.\d\d) s wall\)", done.stdout)
    assert found, done.stdout
    work, wall = float(found[1]), float(found[2])
    # the interpreter and NumPy start before main: the wall time holds more than the work
    assert wall > work


@pytest.mark.parametrize("values", [
    np.array([3.0, 1.0, 2.0]),
    np.array([1.0, 1.0, 1.0, 0.0]),
    np.array([5.0]),
    np.random.default_rng(0).integers(0, 7, 2000).astype(np.float64),   # many ties
    np.random.default_rng(1).standard_normal(1001),
])
def test_mean_ranks_are_scipys(values):
    stats = pytest.importorskip("scipy.stats")
    assert np.array_equal(mean_ranks(values), stats.rankdata(values))
