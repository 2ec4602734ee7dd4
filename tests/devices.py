"""Which devices the tests can use: CUDA tests skip (with the reason) where there is none."""

from __future__ import annotations

import pytest


def cuda_available() -> bool:
    """Whether Warp sees a CUDA device (initialised quietly, as the package does)."""
    try:
        import warp_texton.synthesis as S

        return S._warp().is_cuda_available()
    except Exception:
        return False


#: Marks a test or class that needs a CUDA device.
needs_cuda = pytest.mark.skipif(not cuda_available(), reason="needs a CUDA device")
