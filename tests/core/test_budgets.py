"""The bomb harness (tests/bombs.py) itself: it must tell a clean refusal from a
crash, a time-out and an allocation past its address-space limit, or the budget
tests that use it (tests/test_budgets_*.py) could pass without checking anything."""

from __future__ import annotations

import pytest

from bombs import ADDRESS_SPACE, api_bomb, assert_refused, run_bomb

pytestmark = pytest.mark.slow

TEXTON = "t = wt.Texton(np.full((8, 8, 1), 0.1), [0.5])"


def test_a_clean_refusal_passes():
    out = run_bomb(api_bomb("wt.synthesize(t, (10**6, 10**6), device='cpu')", TEXTON))
    assert_refused(out, r"shape \(1000000, 1000000\), a 1000000x1000000 raster, is too large")
    assert out.peak_bytes is not None and out.peak_bytes < ADDRESS_SPACE


def test_an_allocation_past_the_limit_fails():
    out = run_bomb("import numpy as np\nx = np.ones(" + str(ADDRESS_SPACE) + ")\n")
    assert out.returncode not in (0, None) and "MemoryError" in out.stderr
    with pytest.raises(AssertionError):
        assert_refused(out)


def test_a_time_out_fails():
    out = run_bomb("import time\ntime.sleep(30)\n", timeout=1.0)
    assert out.returncode is None
    with pytest.raises(AssertionError):
        assert_refused(out)


def test_an_accepted_call_fails():
    out = run_bomb(api_bomb("wt.synthesize(t, (8, 8), device='cpu')", TEXTON))
    assert out.stdout.startswith("accepted")
    with pytest.raises(AssertionError):
        assert_refused(out)
