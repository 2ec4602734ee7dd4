"""Centred cardinal B-splines: the interpolation kernels ψ of texton orders.

A texton of order k is h(y) = Σ α(j) ψ_k(y − j) with ψ_k the tensor product of
the centred B-spline of degree k (CGF eq. (3), §10). The sampled covariance of
the noise involves b = (ψ_k * ψ_k) sampled on Z², which is the B-spline of
degree 2k + 1 sampled at the integers (CGF §4.1; for k = 0, b = δ and b̂ = 1).
"""

from __future__ import annotations

from functools import lru_cache
from math import comb, factorial

import numpy as np

#: Interpolation orders a texton may have.
ORDERS = (0, 1, 3, 5)


def bspline(x, degree: int) -> np.ndarray:
    """The centred cardinal B-spline of ``degree`` evaluated at ``x``.

    Supported on [−(degree+1)/2, (degree+1)/2], integral 1; degree 0 is the box
    on [−1/2, 1/2), degree 1 the hat (1 − |x|)⁺.
    """
    x = np.asarray(x, dtype=np.float64)
    n = degree
    half = (n + 1) / 2.0
    if n == 0:
        return ((x >= -0.5) & (x < 0.5)).astype(np.float64)
    out = np.zeros_like(x)
    for j in range(n + 2):
        out += (-1) ** j * comb(n + 1, j) * np.maximum(x + half - j, 0.0) ** n
    out /= factorial(n)
    out[np.abs(x) >= half] = 0.0
    return out


@lru_cache(maxsize=None)
def sampled_autocorrelation(order: int) -> np.ndarray:
    """b on the integers −k…k: the 1-D factor of (ψ_k * ψ_k) sampled on Z.

    Order 0 gives [1]; order 1 gives [1/6, 2/3, 1/6] (CGF §4.1).
    """
    if order == 0:
        return np.ones(1)
    t = np.arange(-order, order + 1, dtype=np.float64)
    b = bspline(t, 2 * order + 1)
    b.setflags(write=False)
    return b


def bhat_1d(n: int, order: int) -> np.ndarray:
    """The DFT of the 1-D sampled autocorrelation b on a period of n samples.

    b is even, so its DFT is real: b̂(ξ) = b(0) + 2 Σ_{t≥1} b(t) cos(2π t ξ / n).
    """
    b = sampled_autocorrelation(order)
    k = order
    xi = np.arange(n, dtype=np.float64)
    out = np.full(n, b[k])
    for t in range(1, k + 1):
        out += 2.0 * b[k + t] * np.cos(2.0 * np.pi * t * xi / n)
    return out


def bhat(shape: tuple[int, int], order: int) -> np.ndarray:
    """b̂ on an M × N DFT grid (separable, strictly positive for every order)."""
    m, n = shape
    return bhat_1d(m, order)[:, None] * bhat_1d(n, order)[None, :]


def kernel_width(order: int) -> int:
    """Width in texels of the support of ψ_k: k + 1."""
    return order + 1
