"""Issue 22's image-reading bombs, each in a child process with a 2 GiB address
space and a time-out (tests/bombs.py): files whose headers declare huge images are
refused from the header, with one TextonError or one CLI line, in well under a
second; and a large EXR write notices Ctrl-C at once, leaving nothing behind."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

from bombs import ADDRESS_SPACE, api_bomb, assert_refused, run_bomb
from image_bombs import png_declaring, tiff_declaring
from helpers import ctrl_c_default
import numpy as np
import pytest

pytestmark = pytest.mark.slow

BUDGET = {"WARP_TEXTON_MEMORY_BUDGET": "1G"}
CLI = "import sys\nfrom warp_texton.cli.parser import main\nsys.exit(main(sys.argv[1:]))\n"


def _refused_quickly(out, match):
    assert_refused(out, match, within=10.0)
    assert out.peak_bytes is not None and out.peak_bytes < ADDRESS_SPACE // 4


# the three files: a 16000² 16-bit RGB PNG, a 30000² TIFF, a 12000² RGB PNG
FILES = {
    "png48": lambda d: png_declaring(d / "rgb16.png", 16000, 16000, bits=16),
    "tiff": lambda d: tiff_declaring(d / "big.tif", 30000, 30000, samples=3, dtype=np.uint16),
    "png24": lambda d: png_declaring(d / "rgb8.png", 12000, 12000),
    "la16": lambda d: png_declaring(d / "la16.png", 16000, 16000, mode="LA", bits=16),
    "palette": lambda d: png_declaring(d / "p.png", 30000, 30000, mode="P"),
    "grey-tiff": lambda d: tiff_declaring(d / "g.tif", 60000, 60000, samples=1, dtype=np.uint8),
}


@pytest.mark.parametrize("kind", sorted(FILES))
def test_read_image_refuses_from_the_header(tmp_path, kind):
    path = FILES[kind](tmp_path)
    out = run_bomb(api_bomb("wt.read_image(sys.argv[1])", "import sys"), str(path), env=BUDGET)
    _refused_quickly(out, rf"refused: .*{path.name}: a \d+x\d+ image .*over the memory budget of 1 GiB"
                          r".*WARP_TEXTON_MEMORY_BUDGET")


@pytest.mark.parametrize("kind", ["png48", "tiff", "png24"])
def test_analyze_is_priced_before_reading(tmp_path, kind):
    """The analysis is priced from the header: refused with its own estimate,
    even under a budget that would let the reading through."""
    path = FILES[kind](tmp_path)
    out = run_bomb(CLI, "analyze", str(path), "-o", str(tmp_path / "t.exr"), env={"WARP_TEXTON_MEMORY_BUDGET": "16G"})
    _refused_quickly(out, r"analysing a \d+x\d+ image needs about .* over the memory budget of 16 GiB")
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]


def test_pillow_says_nothing_beside_the_refusal(tmp_path):
    """Above Pillow's own limit (89 M pixels): no DecompressionBombWarning line."""
    path = png_declaring(tmp_path / "grey.png", 15000, 15000, mode="L")
    out = run_bomb(CLI, "analyze", str(path), "-o", str(tmp_path / "t.exr"), env=BUDGET)
    _refused_quickly(out, r"grey\.png: a 15000x15000 image|analysing a 15000x15000 image")
    assert "Decompression" not in out.stderr


WRITE = """
import sys, time, numpy as np, warp_texton as wt
img = np.random.default_rng(0).random((3000, 3000, 3), dtype=np.float32)
print("start", flush=True)
t = time.perf_counter()
try:
    wt.write_image(sys.argv[1], img)
except KeyboardInterrupt:
    print(f"interrupted {time.perf_counter() - t:.2f}", flush=True)
else:
    print(f"written {time.perf_counter() - t:.2f}", flush=True)
"""


def test_a_large_exr_write_notices_ctrl_c(tmp_path):
    target = tmp_path / "big.exr"
    child = subprocess.Popen([sys.executable, "-c", WRITE, str(target)], stdout=subprocess.PIPE, text=True,
                             preexec_fn=ctrl_c_default)
    assert child.stdout is not None and child.stdout.readline().startswith("start")
    deadline = time.monotonic() + 10
    while not any(tmp_path.iterdir()) and time.monotonic() < deadline:
        time.sleep(0.01)  # the temporary file: the write has begun
    time.sleep(0.2)
    sent = time.monotonic()
    child.send_signal(signal.SIGINT)
    out = child.communicate(timeout=20)[0]
    waited = time.monotonic() - sent
    assert out.startswith("interrupted"), out
    assert waited < 1.5, f"the write noticed the signal after {waited:.2f} s"
    assert list(tmp_path.iterdir()) == []
