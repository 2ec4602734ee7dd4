"""Second-order models of texton noise shared by the statistical tests.

Exact references computed from the coefficients alone, independent of the code
under test: the sampled covariance (CGF §4.1), the Fejér-windowed expected
periodogram of a window, block z-scores of a mean periodogram, and the texton
h on Gauss–Legendre nodes for exact integrals of its powers.
"""

from __future__ import annotations

import numpy as np
import scipy.ndimage as ndi
import scipy.signal as sps

from warp_texton import Texton
from warp_texton.model.bspline import bspline, sampled_autocorrelation

def model_covariance(texton: Texton) -> np.ndarray:
    """C[a, b][dy, dx] = E[(g_a(x) − m_a)(g_b(x + τ) − m_b)] on integer lags τ = (dx, dy).

    C_ab = R_ab * b with R_ab(d) = Σ_k α_a(k) α_b(k + d) and b = b₁ ⊗ b₁ the sampled
    ψ * ψ (CGF §4.1). Lag 0 sits at the centre of each (2r − 1 + 2k) × (2s − 1 + 2k) array.
    """
    a = texton.coeffs.astype(np.float64)
    b1 = sampled_autocorrelation(texton.order)
    b2 = np.outer(b1, b1)
    c = texton.channels
    out = []
    for i in range(c):
        row = []
        for j in range(c):
            r_ab = sps.correlate(a[:, :, j], a[:, :, i], mode="full", method="direct")
            row.append(sps.convolve(r_ab, b2, mode="full", method="direct"))
        out.append(row)
    return np.array(out)


def texton_on_nodes(texton: Texton):
    """h on Gauss–Legendre nodes of the unit cells covering supp h, with their weights.

    h is a polynomial of degree ≤ k per axis on each cell (knots on the integers for odd
    k, on the half-integers for k = 0), so 2k + 1 nodes per axis integrate h⁴ exactly.
    Returns h (P, Q, C), weights (P, Q) and the nodes per cell n: node p lies in cell p // n
    at the same relative position for every cell, which lets integrals over [0, 1)² of
    periodised functions be computed by folding.
    """
    a = texton.coeffs.astype(np.float64)
    r, s, _ = a.shape
    k = texton.order
    n = 2 * k + 1
    x, w = np.polynomial.legendre.leggauss(n)
    x, w = (x + 1) / 2, w / 2

    def axis(count):
        edges = -(k + 1) / 2 + np.arange(count + k)
        y = (edges[:, None] + x[None, :]).ravel()
        return bspline(y[:, None] - np.arange(count)[None, :], k), np.tile(w, count + k)

    by, wy = axis(r)
    bx, wx = axis(s)
    h = np.einsum("pi,ijc,qj->pqc", by, a, bx)
    return h, wy[:, None] * wx[None, :], n


def expected_periodogram(cov: np.ndarray, size: int) -> np.ndarray:
    """E |DFT(g − m)|² / L² = Σ_τ C(τ)(1 − |τx|/L)(1 − |τy|/L) e^{−2iπ⟨ξ, τ⟩/L}."""
    ny, nx = cov.shape[0] // 2, cov.shape[1] // 2
    assert 2 * max(ny, nx) < size
    ly, lx = np.arange(-ny, ny + 1), np.arange(-nx, nx + 1)
    arr = np.zeros((size, size))
    arr[np.ix_(ly % size, lx % size)] = cov * np.outer(1 - np.abs(ly) / size, 1 - np.abs(lx) / size)
    return np.fft.fft2(arr).real


def self_conjugate(size: int) -> np.ndarray:
    """Frequencies ξ ≡ −ξ (mod L): their periodogram is χ²₁ (variance 2 E²), not χ²₂."""
    f = np.arange(size)
    s = (f == 0) | (2 * f == size)
    return s[:, None] & s[None, :]


def blocks(a: np.ndarray, b: int) -> np.ndarray:
    n = a.shape[0] // b
    return a.reshape(n, b, n, b).sum(axis=(1, 3))


def block_zscores(measured, model, windows, b):
    """Relative deviation and z-score of each b × b block of the mean periodogram.

    Over K independent windows each periodogram value is an exponential variable
    (χ²₂/2, variance E²; χ²₁ at self-conjugate ξ, variance 2E²), and distinct Fourier
    frequencies of one window are nearly uncorrelated, so a block sum of the mean
    periodogram has variance Σ_f v_f E_f² / K. (The non-Gaussian part of texton noise
    adds a fourth-cumulant term of relative size ~|supp h| / (L² MNI) < 1e-3.)
    """
    v = np.where(self_conjugate(model.shape[0]), 2.0, 1.0)
    e = blocks(model, b)
    sd = np.sqrt(blocks(v * model**2, b) / windows)
    m = blocks(measured, b)
    return (m - e) / e, (m - e) / sd, sd / e


def isolated_bumps(f: np.ndarray, threshold: float, margin: int):
    """Boxes around the isolated bumps of a sparse field ``f`` (one impact each, at low MNI).

    Bumps are the connected parts of ``f > threshold``; each box is the bump's
    bounding box grown by ``margin`` pixels (to hold the sub-threshold tails).
    Boxes that leave the raster or hold part of another bump are left out.
    Returns the boxes (y0, y1, x0, x1), the mask of pixels outside every grown
    box (where no impact reaches), and the number of bumps.
    """
    labels, count = ndi.label(f > threshold)
    background = np.ones(f.shape, bool)
    boxes = []
    for idx, box in enumerate(ndi.find_objects(labels), start=1):
        y0, y1 = box[0].start - margin, box[0].stop + margin
        x0, x1 = box[1].start - margin, box[1].stop + margin
        background[max(y0, 0):y1, max(x0, 0):x1] = False
        if y0 < 0 or x0 < 0 or y1 > f.shape[0] or x1 > f.shape[1]:
            continue
        if np.any((labels[y0:y1, x0:x1] != 0) & (labels[y0:y1, x0:x1] != idx)):
            continue  # another bump nearby
        boxes.append((y0, y1, x0, x1))
    return boxes, background, count
