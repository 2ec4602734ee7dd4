"""Histogram tables for the MNI in use.

A histogram-preserving texton's tables (``analyze(..., histogram="preserve")``) map its standardised
noise to the example's marginals: lut = F_u⁻¹ ∘ F_noise, F_noise the compound-Poisson CDF of texton
noise at the MNI the analysis fitted them for (``metadata["histogram_mni"]``, 30). The noise's
marginal depends on the MNI (skewed at 10, nearly Gaussian at 120), so a call at another MNI maps a
noise whose CDF the tables were not made for. The transform also keeps the tables at the Gaussian
quantiles (``gaussian_lut`` = F_u⁻¹ ∘ Φ), so the tables of any MNI follow without the example:

    lut_MNI(g) = F_u⁻¹(F_MNI(g)) = gaussian_lut(Φ⁻¹(F_MNI(g))),

F_MNI by :func:`~warp_texton.model.translation.noise_cdf` (an FFT of the compound Poisson
characteristic function, a few milliseconds a channel). :func:`at_mni` gives the texton carrying
those tables; every output path (rasters, points, batches, Dask, surfaces, bakes, relief, the
device API, the shader exports, the viewer) calls it with its MNI, so one model file serves every
MNI (docs/histogram.md, "Tables for the MNI in use"). At the fitted MNI the texton is returned
unchanged (outputs bit-identical to the tables the analysis wrote).
"""

from __future__ import annotations

import functools
from dataclasses import replace
from typing import TypeVar

import numpy as np

from .histogram import NOISE_MNI, HistogramTransform, gauss_grid
from .texton import Texton
from .translation import noise_cdf

M = TypeVar("M")

#: CDF values are kept this far inside (0, 1) before Φ⁻¹ (beyond the tables' ±5 anyway).
CDF_GUARD = 1e-12


def fitted_mni(texton: Texton) -> float | None:
    """The MNI a texton's tables were fitted for (None: tables of a Gaussian input, which no MNI
    changes, or no tables)."""
    tr = texton.histogram
    if tr is None or tr.gaussian_lut is None:
        return None
    try:
        return float(texton.metadata.get("histogram_mni", NOISE_MNI))
    except (TypeError, ValueError):
        return NOISE_MNI


def at_mni(model: M, mni: float) -> M:
    """``model`` with the histogram tables of its noise at ``mni`` (a checked MNI).

    Textons without tables, with tables of a Gaussian input, at the MNI their tables were fitted
    for, and every other model (tiling models have no MNI) are returned as they are. Otherwise a
    copy of the texton (cached: the same object for the same texton and MNI, so the colour maps
    built from it are cached too) whose ``histogram`` holds F_u⁻¹ ∘ F_mni and whose metadata says
    ``histogram_mni=mni``."""
    if not isinstance(model, Texton):
        return model
    fitted = fitted_mni(model)
    if fitted is None or float(mni) == fitted:
        return model
    return _at_mni(model, float(mni))  # type: ignore[return-value]


@functools.lru_cache(maxsize=32)
def _at_mni(texton: Texton, mni: float) -> Texton:
    from scipy.special import ndtri  # imported here: the command line starts without SciPy

    tr = texton.histogram
    assert tr is not None and tr.gaussian_lut is not None
    grid = gauss_grid(tr.lut.shape[1])
    cdf = np.clip(noise_cdf(texton, mni, grid), CDF_GUARD, 1.0 - CDF_GUARD)
    positions = ndtri(cdf)  # where each noise value's probability sits on the Gaussian grid
    lut = np.array([np.interp(positions[c], grid, tr.gaussian_lut[c]) for c in range(tr.channels)])
    tables = HistogramTransform(tr.matrix, tr.centre, np.maximum.accumulate(lut, axis=1), tr.gaussian_lut)
    return replace(texton, histogram=tables, metadata={**texton.metadata, "histogram_mni": mni})
