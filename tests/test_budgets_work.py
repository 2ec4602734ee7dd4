"""Bombs of issue 22 on the work paths: batches, surface noise and bakes, mix, Zarr planning
and mesh outputs. Each runs in a child process (tests/bombs.py) with a 2 GiB address space
and a 20 s time-out and must end in one clean refusal, leaving nothing behind."""

from __future__ import annotations

import pytest

from bombs import ADDRESS_SPACE, api_bomb, assert_refused, run_bomb

pytestmark = pytest.mark.slow

TEXTON = "t = wt.Texton(np.full((8, 8, 1), 0.1), [0.5])"


def _refused(code: str, match: str = ""):
    out = run_bomb(code)
    assert_refused(out, match, within=10.0)
    assert out.peak_bytes is not None and out.peak_bytes < ADDRESS_SPACE // 2
    return out


@pytest.mark.parametrize("count, shape, mni", [(200, (256, 256), 2000), (2000, (64, 64), 2000)])
def test_batch_priced_whole(count, shape, mni):
    setup = TEXTON + "\nfrom warp_texton.limits import set_work_budget\nset_work_budget(1e10)"
    _refused(api_bomb(f"wt.synthesize_batch(t, {count}, {shape}, mni={mni}, device='cpu')", setup),
             rf"a batch of {count} .* over the work budget")


@pytest.mark.parametrize("count", [1_000_000, 10**8])
def test_batch_of_tiny_items(count):
    _refused(api_bomb(f"wt.synthesize_batch(t, {count}, (1, 1), device='cpu')", TEXTON),
             rf"a batch of {count} 1x1 rasters .* over the (work|memory) budget")
