"""Every kernel path gives, bit for bit, the values recorded in tests/data.

The values in tests/data/reference_outputs.npz were made on the CPU by
tests/make_reference.py from the cases in reference_cases.py. A move or merge
of code that changes one bit of any of them fails here.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from reference_cases import CASES

RECORDED = Path(__file__).parent / "data" / "reference_outputs.npz"


@pytest.fixture(scope="module")
def recorded():
    with np.load(RECORDED) as data:
        return {k: data[k] for k in data.files}


def test_every_case_is_recorded(recorded):
    assert set(CASES) == set(recorded) - {"commit"}


@pytest.mark.parametrize("name", sorted(CASES))
def test_bit_identical_to_recorded(name, recorded):
    value = np.asarray(CASES[name]())
    want = recorded[name]
    assert value.dtype == want.dtype and value.shape == want.shape
    np.testing.assert_array_equal(value, want, err_msg=f"{name} differs from the values recorded at {recorded['commit']}")
