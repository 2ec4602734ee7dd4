"""Mixed noise in strips of rows: the values of one pass, and a computation whose caller
has gone stops between two strips (limits.cancellable), as synthesize's strips do."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from helpers import random_texton
from warp_texton import synthesize_mixed
from warp_texton.core.limits import Cancelled, cancellable

SHAPE = (96, 80)


def _textons():
    return [random_texton(seed=s) for s in range(3)]


def _rho():
    y, x = np.mgrid[:SHAPE[0], :SHAPE[1]]
    return np.clip((30 - np.hypot(x - 40, y - 48)) / 10, 0, 1).astype(np.float32)


@pytest.fixture
def small_strips(monkeypatch):
    """Strips of 512 pixels (rows of 6 or 7 at width 80) instead of 4M: many strips."""
    import warp_texton.noise.canvas as C

    monkeypatch.setattr(C, "STRIP_WORK", 512)


@pytest.mark.parametrize("weights", ["strips", "map"])
@pytest.mark.parametrize("method", ["splat", "gather"])
def test_strips_give_the_values_of_one_pass(monkeypatch, weights, method):
    import warp_texton.noise.canvas as C

    w = "strips" if weights == "strips" else _rho()
    one = synthesize_mixed(_textons(), w, SHAPE, seed=3, offset=(17.25, -5.5), method=method, device="cpu")
    monkeypatch.setattr(C, "STRIP_WORK", 512)
    assert len(C.strips(*SHAPE)) > 10
    many = synthesize_mixed(_textons(), w, SHAPE, seed=3, offset=(17.25, -5.5), method=method, device="cpu")
    assert np.array_equal(one, many)


def test_cancelled_mixed_stops(small_strips, monkeypatch):
    import warp_texton.noise.raster as R

    launched = []
    real = R.rasters
    monkeypatch.setattr(R, "rasters", lambda *a, **k: launched.append(a) or real(*a, **k))
    calls = itertools.count()
    with cancellable(lambda: next(calls) < 3), pytest.raises(Cancelled):
        synthesize_mixed(_textons(), _rho(), SHAPE, device="cpu")
    assert len(launched) == 3  # three strips, then the caller was gone
    launched.clear()
    synthesize_mixed(_textons(), _rho(), SHAPE, device="cpu")  # outside cancellable: every strip
    assert len(launched) > 10
