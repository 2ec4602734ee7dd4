"""Surface texton noise on meshes without UVs (CGF §6, Proposition 3).

The model: a 3-D Poisson process of intensity λ = MNI / (r · |supp h|), r the larger side
of the texton's support box; at a surface point y with frame (u1, u2, n),

    f(y) = Σ_i (1 − 2|⟨y − x_i, n⟩|/r)⁺ h_c(⟨y − x_i, u1⟩, ⟨y − x_i, u2⟩)
    g(y) = m + (f − λ (r/2) ∫h) / √(λ r/3)

with h_c the texton centred on its support. Campbell's theorem (CGF Appendix A) gives
E g = m and Var g = ∫h² (= texton.covariance()); the n-th cumulant of g is
λ ∫w^n ∫h^n / (λ r/3)^{n/2} with ∫w⁴ = r/5, so the excess kurtosis is
9 ∫h⁴ / (5 λ r (∫h²)²). Two points whose frame cubes (side r, centred on the point) are
disjoint see disjoint parts of the process, so they are exactly independent: on a plane
with one frame, points r texels apart along u1 or u2; anywhere, points more than r√3
apart. The moment tests sample such points, so their tolerances are the i.i.d. ones.

On a plane with one normal, the impacts that reach two points are weighted alike, so the
covariance is C(τ) = ∫ h(z) h(z + τ) dz, the 2-D texton model: its periodogram on a
texel grid is the Fejér-windowed |α̂|² b̂ (CGF §4.1, eq. (4)).
"""

from __future__ import annotations

import importlib.util
import math
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.optimize as so
import trimesh
from scipy.spatial import cKDTree

from helpers import anisotropic_texton, noise_sd, random_texton
from texton_models import isolated_bumps, block_zscores, expected_periodogram, model_covariance, texton_on_nodes
from warp_texton import Camera, Texton, TextonError, render_mesh, surface_noise, tangent_frames, texture_mesh
from warp_texton.model.bspline import bspline
from warp_texton.surface.frames import UP
from warp_texton.surface.mesh import vertex_normals

# the vertex-colour spacing warning is tested in TestVertexSpacing; elsewhere it is expected
pytestmark = pytest.mark.filterwarnings("ignore:.*texels apart:UserWarning")

A = np.array(UP)  # the frame rule's `up` (0, 0, 1)
B = np.array((1.0, 0.0, 0.0))  # and its `side`


# --------------------------------------------------------------------------- #
# Textons and the model                                                       #
# --------------------------------------------------------------------------- #
def small_texton(channels=3, seed=5, sd=0.06, mean=(0.3, 0.5, 0.7)) -> Texton:
    """A texton whose noise has standard deviation ≈ ``sd`` per channel around ``mean``.

    With sd = 0.06 and means in [0.3, 0.7], 8-bit clipping to [0, 1] happens beyond 5 sd:
    a probability < 1e-6, so mean colours are unbiased by the clipping.
    """
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((8, 8, channels))
    t = Texton(a, np.asarray(mean[:channels]), 1)
    c = np.sqrt(np.diag(t.covariance()))
    return Texton(a * sd / c, np.asarray(mean[:channels]), 1)


def support_side(t: Texton) -> float:
    """r: the larger side of the support box, s + k for an s-wide texton of order k ≥ 1."""
    k = t.order
    return float(max(t.size) + (k if k > 0 else 0))


def surface_lam(t: Texton, mni: float) -> float:
    return mni / (support_side(t) * t.support_area)


def fourth_cumulant(t: Texton, mni: float) -> np.ndarray:
    """κ_ab = cum(g_a, g_a, g_b, g_b) = λ ∫w⁴ ∫h_a² h_b² / (λ r/3)² = 9 ∫h_a² h_b² / (5 λ r)."""
    h, w = texton_on_nodes(t)[:2]
    h2 = h**2
    return 9.0 * np.einsum("pq,pqa,pqb->ab", w, h2, h2) / (5.0 * surface_lam(t, mni) * support_side(t))


def frame_grid(origin, u1, u2, n_side, spacing):
    """An n_side × n_side grid of points origin + i·spacing·u1 + j·spacing·u2."""
    i, j = np.meshgrid(np.arange(n_side), np.arange(n_side), indexing="ij")
    return np.asarray(origin) + spacing * (i.reshape(-1, 1) * u1 + j.reshape(-1, 1) * u2)


def fibonacci_sphere(n, radius):
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = math.pi * (1 + math.sqrt(5)) * k
    rho = np.sqrt(1 - z**2)
    unit = np.stack([rho * np.cos(phi), rho * np.sin(phi), z], axis=1)
    return radius * unit, unit


def plane_mesh(n=9, size=1.0, z=0.0, flip=False):
    """A flat n × n vertex grid in the plane z, each quad cut along one diagonal or the other."""
    x, y = np.meshgrid(np.linspace(0, size, n), np.linspace(0, size, n))
    v = np.stack([x.ravel(), y.ravel(), np.full(n * n, z)], axis=1)
    faces = []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = i * n + j, i * n + j + 1, (i + 1) * n + j, (i + 1) * n + j + 1
            faces += [[a, b, d], [a, d, c]] if not flip else [[a, b, c], [b, d, c]]
    return trimesh.Trimesh(v, np.array(faces), process=False)


def colours(mesh) -> np.ndarray:
    return np.asarray(mesh.visual.vertex_colors)


# --------------------------------------------------------------------------- #
# 1. Frames                                                                   #
# --------------------------------------------------------------------------- #
def singular_normals():
    """The normals where v(n) = P_n(a) + ⟨a, n⟩⁴ P_n(b) vanishes.

    v = 0 forces a + c⁴ b ∥ n (c = ⟨a, n⟩), so n lies in the (a, b) plane: n = cos φ a +
    sin φ b, where v is along n⊥ = −sin φ a + cos φ b with coefficient cos⁵ φ − sin φ.
    The zeros are φ* (sin φ* = cos⁵ φ*, φ* ≈ 0.52) and φ* + π: exactly two normals.
    """
    phi = so.brentq(lambda p: math.sin(p) - math.cos(p) ** 5, 0.0, math.pi / 2)
    ns = math.cos(phi) * A + math.sin(phi) * B
    return np.stack([ns, -ns])


def rule_v(n):
    c = n @ A
    return (A - n * c[:, None]) + (B - n * (n @ B)[:, None]) * (c**4)[:, None]


def random_normals(count, seed):
    n = np.random.default_rng(seed).standard_normal((count, 3))
    return n / np.linalg.norm(n, axis=1)[:, None]


class TestTangentFrames:
    def test_orthonormal_right_handed_frames(self):
        n = np.random.default_rng(0).standard_normal((500, 3)) * np.random.default_rng(1).uniform(0.01, 50, (500, 1))
        u1, u2 = tangent_frames(n)
        nn = n / np.linalg.norm(n, axis=1)[:, None]  # normals need not be unit
        np.testing.assert_allclose(np.linalg.norm(u1, axis=1), 1.0, atol=1e-12)
        np.testing.assert_allclose(np.sum(u1 * nn, axis=1), 0.0, atol=1e-12)
        np.testing.assert_allclose(u2, np.cross(nn, u1), atol=1e-12)
        np.testing.assert_allclose(np.linalg.det(np.stack([u1, u2, nn], axis=1)), 1.0, atol=1e-12)

    def test_frame_is_the_documented_rule(self):
        n = random_normals(2000, 2)
        v = rule_v(n)
        keep = np.linalg.norm(v, axis=1) > 1e-3
        u1, _ = tangent_frames(n)
        np.testing.assert_allclose(u1[keep], (v / np.linalg.norm(v, axis=1)[:, None])[keep], atol=1e-12)

    def test_special_normals(self):
        # a plane facing up gets (side, up × side) = (x, y); facing down, u1 is still side
        u1, u2 = tangent_frames([[0, 0, 1.0], [0, 0, 7.0], [0, 0, -1.0]])
        np.testing.assert_allclose(u1, [[1, 0, 0]] * 3, atol=1e-15)
        np.testing.assert_allclose(u2, [[0, 1, 0], [0, 1, 0], [0, -1, 0]], atol=1e-15)
        # on walls (n ⊥ up) u1 points up
        th = np.linspace(0, 2 * np.pi, 13)
        walls = np.stack([np.cos(th), np.sin(th), 0 * th], axis=1)
        u1, u2 = tangent_frames(walls)
        np.testing.assert_allclose(u1, np.tile(A, (13, 1)), atol=1e-12)
        np.testing.assert_allclose(u2, np.cross(walls, A), atol=1e-12)
        # other directions of the rule
        u1, u2 = tangent_frames([[0, 1.0, 0], [1.0, 0, 0]], up=(0, 1, 0), side=(0, 0, 1))
        np.testing.assert_allclose(u1, [[0, 0, 1], [0, 1, 0]], atol=1e-12)

    def test_continuous_except_at_the_two_singular_normals(self):
        """|d u1| ≤ |dv| / |v|, and |dv| ≤ 8 |dn|: |d(⟨a, n⟩ n)| ≤ 2|dn|, |d(c⁴)| P_n b ≤ 4|dn|,
        c⁴ |d(P_n b)| ≤ 2|dn|; so frames are Lipschitz wherever v stays away from 0."""
        n = random_normals(20000, 3)
        sing = singular_normals()
        near = np.max(n @ sing.T, axis=1) > math.cos(0.1)
        n = n[~near]
        eps = 1e-6
        dn = random_normals(len(n), 4) * eps
        m = (n + dn) / np.linalg.norm(n + dn, axis=1)[:, None]
        u1, u2 = tangent_frames(n)
        w1, w2 = tangent_frames(m)
        step = np.linalg.norm(m - n, axis=1)
        vlen = np.linalg.norm(rule_v(n), axis=1)
        assert vlen.min() > 0.02  # v vanishes nowhere farther than 0.1 rad from ±n*
        bound = 8.0 * step / vlen * 1.01 + 1e-12
        assert np.all(np.linalg.norm(w1 - u1, axis=1) <= bound)
        assert np.all(np.linalg.norm(w2 - u2, axis=1) <= bound + step)
        # ... while across n* the frame turns over (a closed surface must have such points)
        c = np.cross(A, B)
        for ns in sing:
            p, q = ns + 1e-4 * c, ns - 1e-4 * c
            f = tangent_frames(np.stack([p, q]))[0]
            assert np.linalg.norm(f[0] - f[1]) > 1.0

    def test_kernel_rule_equals_host_rule(self, device):
        t = random_texton(channels=3, seed=8)
        rng = np.random.default_rng(5)
        n = np.concatenate([
            random_normals(3000, 6),
            [[0, 0, 1.0], [0, 0, -1.0], [1.0, 0, 0], [0, 1.0, 0], [0.6, 0.8, 0]],
            [[1e-3, 0, 1.0], [0, 1e-3, -1.0], [0.2, 0.1, 1.0]],
        ])
        unit = n / np.linalg.norm(n, axis=1)[:, None]
        n = n[np.max(unit @ singular_normals().T, axis=1) < math.cos(0.01)]  # 0.01 rad from ±n*
        p = rng.uniform(-3.0, 3.0, (len(n), 3))
        kw = dict(texel_size=0.05, seed=3, device=device)
        for rule in ({}, dict(up=(0, 1.0, 0), side=(0, 0, 2.0))):
            u1, u2 = tangent_frames(n, **rule)
            implicit = surface_noise(t, p, n, **rule, **kw)
            explicit = surface_noise(t, p, n, tangents=u1, **rule, **kw)
            np.testing.assert_allclose(explicit, implicit, atol=1e-4 * noise_sd(t))
            # and the tangents are used: the turned frame gives another noise
            turned = surface_noise(t, p, n, tangents=u2, **rule, **kw)
            assert np.mean(np.abs(turned - implicit) > 0.1 * noise_sd(t)) > 0.5

    def test_turning_the_frame_turns_the_texton(self, device):
        """With u1' = u2 the point sees h_c(w2, −w1), (w1, w2) its frame coordinates. For α of
        r × s and centre ((s−1)/2, (r−1)/2), that is the s × r texton β(j, r−1−i) = α(i, j)
        = np.rot90(α, −1) in the frame (u1, u2): r, |supp h| and so λ and the cells are the
        same, the impacts too, so the values agree to float rounding."""
        t = random_texton((6, 10), channels=3, seed=9)
        alpha = t.coeffs
        beta = np.empty((10, 6, 3), np.float32)
        for i in range(6):
            for j in range(10):
                beta[j, 6 - 1 - i] = alpha[i, j]
        np.testing.assert_array_equal(beta, np.rot90(alpha, -1))
        turned = Texton(beta, t.mean, 1)
        n = random_normals(2000, 10)
        p = np.random.default_rng(11).uniform(-2, 2, (2000, 3))
        u1, u2 = tangent_frames(n)
        a = surface_noise(t, p, n, 0.04, seed=1, tangents=u2, device=device)
        b = surface_noise(turned, p, n, 0.04, seed=1, tangents=u1, device=device)
        np.testing.assert_allclose(a, b, atol=1e-4 * noise_sd(t))
        # a turn the other way (rot90 by +1) is a different texture: the test sees the sense
        other = surface_noise(Texton(np.rot90(alpha, 1), t.mean, 1), p, n, 0.04, seed=1, tangents=u1, device=device)
        assert np.mean(np.abs(other - a) > 0.1 * noise_sd(t)) > 0.5


# --------------------------------------------------------------------------- #
# 2. Prop. 3: mean and variance                                               #
# --------------------------------------------------------------------------- #
def independent_points(where: str, t: Texton):
    """(points, normals, texel_size): ≈ 22 500 points whose frame cubes are disjoint."""
    r = support_side(t)
    texel = 0.05
    if where == "sphere":
        # a large sphere: radius 3000 texels, Fibonacci points ≈ 35 texels apart > r√3 ≈ 15.6
        p, n = fibonacci_sphere(22500, 3000 * texel)
        return p, n, texel
    if where == "plane":
        n = np.array([0.0, 0.0, 1.0])
        origin = np.array([-40.0, 17.0, 0.3])
    else:  # a tilted plane, away from the origin
        n = np.array([1.0, 2.0, 2.0]) / 3.0
        origin = np.array([100.0, -20.0, 5.0])
    u1, u2 = tangent_frames(n[None])
    # one frame everywhere: points r + 1 texels apart along u1 or u2 have disjoint cubes
    p = frame_grid(origin, u1[0], u2[0], 150, (r + 1) * texel)
    return p, np.tile(n, (len(p), 1)), texel


class TestProposition3:
    @pytest.mark.parametrize("where", ["plane", "tilted plane", "sphere"])
    def test_mean_and_colour_covariance(self, where, device):
        t = random_texton(channels=3, seed=3, mean=(0.4, 0.5, 0.6))
        mni = 60.0
        p, n, texel = independent_points(where, t)
        if where == "sphere":
            d, _ = cKDTree(p / texel).query(p / texel, k=2)
            assert d[:, 1].min() > support_side(t) * math.sqrt(3)  # independent points
        g = surface_noise(t, p, n, texel, mni=mni, seed=7, device=device).astype(np.float64)
        count = len(g)
        cov = t.covariance()
        # i.i.d. values: Var(mean_a) = C_aa / N
        mean_sd = np.sqrt(np.diag(cov) / count)
        dev = g.mean(axis=0) - t.mean
        assert np.all(np.abs(dev) < 5 * mean_sd), (dev / mean_sd).round(2).tolist()
        # ... tight enough to see a 10 % error in the shift λ (r/2) ∫h
        lam, r = surface_lam(t, mni), support_side(t)
        shift = lam * r / 2 * np.abs(t.integral) / math.sqrt(lam * r / 3)
        assert np.all(5 * mean_sd < 0.1 * shift)
        # covariance with the known mean: Var(ĉ_ab) = (C_aa C_bb + C_ab² + κ_ab) / N
        c_hat = (g - t.mean).T @ (g - t.mean) / count
        sd = np.sqrt((np.outer(np.diag(cov), np.diag(cov)) + cov**2 + fourth_cumulant(t, mni)) / count)
        z = (c_hat - cov) / sd
        assert np.all(np.abs(z) < 5), z.round(2).tolist()
        # ... tight enough to see a 10 % error of the variance (√(λr/2) instead of √(λr/3) is 33 %)
        assert np.all(5 * np.diag(sd) < 0.1 * np.diag(cov))

    def test_gaussian_counts_keep_the_moments(self, device):
        t = random_texton(channels=1, seed=12)
        p, n, texel = independent_points("tilted plane", t)
        g = surface_noise(t, p, n, texel, seed=2, poisson="gaussian", device=device)[:, 0].astype(np.float64)
        exact = surface_noise(t, p, n, texel, seed=2, device=device)[:, 0]
        assert not np.allclose(g, exact)
        c0, count = t.covariance()[0, 0], len(g)
        assert abs(g.mean() - t.mean[0]) < 5 * math.sqrt(c0 / count)
        # the rounded Gaussian count has variance λ_c + 1/12: at most 1/(12 λ_c) ≈ 0.6 % more
        # variance (λ_c = λ (0.6 r)³ ≈ 13 impacts per cell), on top of the sampling error
        lam_c = surface_lam(t, 60.0) * (0.6 * support_side(t)) ** 3
        sd = math.sqrt((2 * c0**2 + fourth_cumulant(t, 60.0)[0, 0]) / count)
        assert abs(np.mean((g - t.mean[0]) ** 2) - c0) < 5 * sd + c0 / (12 * lam_c)

    def test_excess_kurtosis_at_low_mni(self, device):
        """κ = 9 ∫h⁴ / (5 λ r (∫h²)²): it sees λ = MNI / (r |supp h|) and the slab weight.

        A 6 × 10 texton of order 1 has a 7 × 11 support: r = 11, |supp h| = 77. λ = MNI/r³
        would change κ by 77/121, a flat slab weight (∫1 over |t| < r/2) by 5/9.
        """
        t = random_texton((6, 10), seed=13)
        assert support_side(t) == 11 and t.support_area == 77
        mni = 3.0
        h, w = texton_on_nodes(t)[:2]
        h2 = np.sum(w * h[:, :, 0] ** 2)
        np.testing.assert_allclose(h2, t.covariance()[0, 0], rtol=1e-6)
        expected = 9 * np.sum(w * h[:, :, 0] ** 4) / (5 * surface_lam(t, mni) * support_side(t) * h2**2)
        n = np.array([0.0, 0.0, 1.0])
        p = frame_grid([3.0, -2.0, 1.0], B, np.cross(A, B), 32, 12 * 0.1)  # 12 > r texels apart
        ks = []
        for seed in range(64):
            g = surface_noise(t, p, np.tile(n, (len(p), 1)), 0.1, mni=mni, seed=seed, device=device)[:, 0] - t.mean[0]
            g = g.astype(np.float64)
            ks.append(np.mean(g**4) / np.mean(g**2) ** 2 - 3.0)
        # the spread over 64 independent groups of 1024 gives the standard error honestly
        # (the ratio estimator's bias is O(1/1024), a small fraction of it)
        ks = np.array(ks)
        sd = ks.std(ddof=1) / math.sqrt(ks.size)
        assert abs(ks.mean() - expected) < 5 * sd, (ks.mean(), expected, sd)
        assert 5 * sd < 0.3 * expected  # sees 77/121 or 5/9 factors

    def test_isolated_impacts_are_the_texton(self, device):
        """At a tiny MNI each impact near the plane z = 0 adds w · h(· − p), w ∈ (0, 1]; the
        background, where none reaches, is m − λ (r/2) ∫h / √(λ r/3) exactly (CGF Prop. 3).
        An asymmetric 2 × 3 texton: a mirrored or transposed frame changes the bumps."""
        alpha = np.array([[1.0, 0.5, 0.25], [0.75, 0.3, 0.6]])
        t = Texton(alpha[:, :, None], [0.5], 1)
        r = support_side(t)
        assert r == 4 and t.support_area == 12
        lam = 20.0 / (96**2 * r)  # ≈ 20 impacts within r/2 of the 96 × 96 texel square
        mni = lam * r * t.support_area
        q = 8  # points per texel
        xs = (np.arange(96 * q) + 0.5) / q - 40.0
        ys = (np.arange(96 * q) + 0.5) / q + 13.0
        gx, gy = np.meshgrid(xs, ys)
        pts = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], axis=1)
        g = surface_noise(t, pts * 0.5, np.tile([0, 0, 1.0], (len(pts), 1)), 0.5, mni=mni, seed=5, device=device)
        g = g[:, 0].reshape(gx.shape).astype(np.float64)
        f = (g - 0.5) * math.sqrt(lam * r / 3) + lam * r / 2 * alpha.sum()  # the raw sum
        assert np.all(f > -1e-6)
        margin = 2 * q
        checked = 0
        boxes, background, count = isolated_bumps(f, 1e-6, margin)
        for y0, y1, x0, x1 in boxes:
            patch = f[y0:y1, x0:x1]
            weight = patch.sum() / q**2 / alpha.sum()  # ∫ w h = w Σα, exact on a 1/q grid
            if not 0.05 < weight <= 1.0 + 1e-4:
                continue  # two impacts on top of each other, or too faint to locate
            py, px = ys[y0:y1], xs[x0:x1]
            cy = (patch.sum(axis=1) @ py) / patch.sum() - (alpha.sum(axis=1) @ np.arange(2)) / alpha.sum()
            cx = (patch.sum(axis=0) @ px) / patch.sum() - (alpha.sum(axis=0) @ np.arange(3)) / alpha.sum()
            by = bspline((py - cy)[:, None] - np.arange(2)[None, :], 1)
            bx = bspline((px - cx)[:, None] - np.arange(3)[None, :], 1)
            np.testing.assert_allclose(patch, weight * (by @ alpha @ bx.T), atol=2e-5)
            checked += 1
        assert checked >= 5, f"only {checked} isolated impacts among {count} bumps"
        assert background.mean() > 0.2
        bg = 0.5 - lam * r / 2 * alpha.sum() / math.sqrt(lam * r / 3)
        np.testing.assert_allclose(g[background], bg, atol=1e-5)


# --------------------------------------------------------------------------- #
# 3. The plane: the 2-D spectrum                                              #
# --------------------------------------------------------------------------- #
L, GAP, PER_SIDE, BLOCK = 32, 14, 8, 4  # GAP ≥ r = 13: windows see disjoint impacts


class TestPlaneSpectrum:
    @pytest.mark.slow
    def test_plane_noise_has_the_2d_texton_spectrum(self, device):
        t = anisotropic_texton()
        assert support_side(t) == 13
        texel = 0.25
        side = PER_SIDE * (L + GAP)
        idx = (np.arange(side) + 0.5) * texel
        gx, gy = np.meshgrid(idx, idx)  # rows follow y (u2), columns x (u1)
        acc, windows = np.zeros((L, L)), 0
        for seed, (ox, oy, oz) in ((1, (0.0, 0.0, 0.0)), (2, (-700.0, 350.0, 12.5)), (3, (40.0, -90.0, -3.0))):
            pts = np.stack([gx.ravel() + ox, gy.ravel() + oy, np.full(gx.size, oz)], axis=1)
            g = surface_noise(t, pts, np.tile([0, 0, 1.0], (len(pts), 1)), texel, mni=60.0, seed=seed, device=device)
            g = g[:, 0].reshape(side, side).astype(np.float64) - t.mean[0]
            for y in range(0, side, L + GAP):
                for x in range(0, side, L + GAP):
                    acc += np.abs(np.fft.fft2(g[y:y + L, x:x + L])) ** 2
                    windows += 1
        measured = acc / (windows * L * L)
        cov = model_covariance(t)[0, 0]
        model = expected_periodogram(cov, L)
        rel, z, rel_sd = block_zscores(measured, model, windows, BLOCK)
        assert windows == 192
        # 192 windows × 16 frequencies per block: relative sd ≈ 1/√3072 ≈ 1.8 %
        assert np.all(rel_sd < 0.04)
        # 64 blocks: P(|z| > 5) ≈ 6e-7 each
        assert np.abs(z).max() < 5.0, f"worst block z = {np.abs(z).max():.2f}"
        # conjugate pairs: ≈ 32 independent blocks, mean z² = 1 ± √(2/32) = 0.25; 4σ bound
        assert np.mean(z**2) < 2.0, f"mean z² = {np.mean(z**2):.3f}"
        # a gain error: the mean relative deviation of 32 blocks has sd ≈ 1.8 %/√32 ≈ 0.3 %
        assert abs(rel.mean()) < 5 * np.sqrt(np.mean(rel_sd**2) / 32), rel.mean()
        # the frame is (x, y): the transposed model (a frame (y, x)) is far off
        _, z_wrong, _ = block_zscores(measured, expected_periodogram(cov.T, L), windows, BLOCK)
        assert np.abs(z_wrong).max() > 20.0


# --------------------------------------------------------------------------- #
# 4. Triangulation, determinism, scale                                        #
# --------------------------------------------------------------------------- #
class TestTriangulation:
    def test_values_depend_only_on_point_and_frame(self, device):
        """The same point with the same normal has the same noise in any mesh, batch or order."""
        t = random_texton(channels=3, seed=20)
        coarse = trimesh.creation.icosphere(subdivisions=2, radius=2.0)
        fine = trimesh.creation.icosphere(subdivisions=3, radius=2.0)
        vc, vf = np.asarray(coarse.vertices), np.asarray(fine.vertices)
        d, match = cKDTree(vf).query(vc)
        assert d.max() < 1e-12
        a = surface_noise(t, vc, vc, 0.02, seed=4, device=device)  # analytic normals: the radius
        b = surface_noise(t, vf, vf, 0.02, seed=4, device=device)[match]
        np.testing.assert_allclose(a, b, atol=1e-5 * noise_sd(t))
        perm = np.random.default_rng(0).permutation(len(vc))[:37]
        np.testing.assert_array_equal(surface_noise(t, vc[perm], vc[perm], 0.02, seed=4, device=device), a[perm])
        one = surface_noise(t, vc[5:6], vc[5:6], 0.02, seed=4, device=device)
        np.testing.assert_array_equal(one, a[5:6])
        assert a.std(axis=0).min() > 0.3 * noise_sd(t)  # not a constant

    def test_planar_mesh_triangulated_two_ways(self, device):
        t = small_texton(sd=0.15)
        texel = 0.01
        m1 = plane_mesh(n=41, z=0.25)
        m2 = plane_mesh(n=41, z=0.25, flip=True)
        v3, f3 = trimesh.remesh.subdivide(m1.vertices, m1.faces)
        m3 = trimesh.Trimesh(v3, f3, process=False)
        c1 = colours(texture_mesh(m1, t, texel, seed=3, device=device))
        c2 = colours(texture_mesh(m2, t, texel, seed=3, device=device))
        c3 = colours(texture_mesh(m3, t, texel, seed=3, device=device))
        n0 = len(m1.vertices)
        np.testing.assert_array_equal(np.asarray(m3.vertices[:n0]), np.asarray(m1.vertices))
        # a plane z = const has exactly the normal (0, 0, 1) whatever the triangulation
        np.testing.assert_array_equal(c1, c2)
        np.testing.assert_array_equal(c3[:n0], c1)
        assert c1[:, :3].std() > 10  # a texture, not a flat colour
        # max_edge subdivision keeps the original vertices, and their colours
        c4 = colours(texture_mesh(m1, t, texel, seed=3, max_edge=1.0, device=device))
        np.testing.assert_array_equal(c4[:n0], c1)

    def test_tilted_planar_mesh_triangulated_two_ways(self, device):
        t = small_texton(sd=0.15)
        rot = trimesh.transformations.rotation_matrix(0.7, [1.0, 2.0, 0.5])
        m1, m2 = plane_mesh(n=31), plane_mesh(n=31, flip=True)
        m1.apply_transform(rot)
        m2.apply_transform(rot)
        c1 = colours(texture_mesh(m1, t, 0.01, device=device)).astype(int)
        c2 = colours(texture_mesh(m2, t, 0.01, device=device)).astype(int)
        # the normals agree to rounding (≈1e-16): colours to the 8-bit rounding step
        assert np.abs(c1 - c2).max() <= 1
        assert np.mean(c1 != c2) < 0.01

    def test_texture_mesh_colours_are_the_surface_noise(self, device):
        t = small_texton(channels=1, sd=0.2)
        mesh = trimesh.creation.torus(1.0, 0.4)
        assert mesh.visual.kind is None
        out = texture_mesh(mesh, t, 0.01, mni=40.0, seed=6, device=device)
        assert out is not mesh and len(out.vertices) == len(mesh.vertices)
        n = vertex_normals(out)
        g = surface_noise(t, out.vertices, n, 0.01, mni=40.0, seed=6, device=device)
        expect = np.round(np.clip(g, 0, 1) * 255).astype(int)
        c = colours(out).astype(int)
        np.testing.assert_array_equal(c[:, :3], np.repeat(expect, 3, axis=1))  # grey spread to RGB
        assert np.all(c[:, 3] == 255)
        # the frame rule's directions reach the kernel
        rule = dict(up=(0.0, 1.0, 0.0), side=(0.0, 0.0, 1.0))
        other = colours(texture_mesh(mesh, t, 0.01, mni=40.0, seed=6, device=device, **rule))
        g = surface_noise(t, out.vertices, n, 0.01, mni=40.0, seed=6, device=device, **rule)
        np.testing.assert_array_equal(other[:, 0], np.round(np.clip(g[:, 0], 0, 1) * 255))
        assert np.mean(other[:, 0] != c[:, 0]) > 0.5
        assert mesh.visual.kind is None  # the input is left uncoloured

    def test_scale_invariance_and_seeds(self, device):
        t = random_texton(channels=3, seed=21)
        n = random_normals(500, 22)
        p = np.random.default_rng(23).uniform(-1, 1, (500, 3))
        a = surface_noise(t, p, n, 0.01, seed=9, device=device)
        b = surface_noise(t, p * 1000.0, n * 3.0, 10.0, seed=9, device=device)
        np.testing.assert_allclose(a, b, atol=1e-4 * noise_sd(t))
        c = surface_noise(t, p, n, 0.01, seed=10, device=device)
        assert np.mean(np.abs(a - c) > 0.1 * noise_sd(t)) > 0.5
        assert a.dtype == np.float32 and a.shape == (500, 3)


# --------------------------------------------------------------------------- #
# 5. Degenerate input                                                         #
# --------------------------------------------------------------------------- #
T1 = random_texton(seed=30)
P1 = [[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]]
N1 = [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]


class TestSurfaceNoiseErrors:
    @pytest.mark.parametrize(
        "kw, match",
        [
            (dict(normals=[[0, 0, 1.0], [0, 0, 0.0]]), r"normals\[1\] has zero length"),
            (dict(normals=[[0, 0, 1.0]]), r"normals has shape \(1, 3\); it must match points \(2, 3\)"),
            (dict(normals=[[0, 0, float("nan")], [0, 0, 1.0]]), "normals contain 1 NaN"),
            (dict(points=[[0, 0, float("inf")], [0, 0, 1.0]]), "points contain 1 NaN or infinite"),
            (dict(points=np.zeros((2, 2))), r"points must have shape \(N, 3\)"),
            (dict(points=[["a", "b", "c"]]), r"points must be an array of shape \(N, 3\)"),
            (dict(tangents=[[0, 0, 1.0], [1.0, 0, 0]]), r"tangents\[0\] is parallel to its normal"),
            (dict(tangents=[[1.0, 0, 0]]), "tangents has shape"),
            (dict(texel_size=0.0), "texel_size"),
            (dict(texel_size=float("nan")), "texel_size"),
            (dict(mni=0.0), "mni"),
            (dict(mni=-5.0), "mni"),
            (dict(seed=-1), "seed"),
            (dict(seed=2**32), "seed"),
            (dict(up=(0, 0, 0)), "up must be a non-zero 3-vector"),
            (dict(side=(1, 0)), "side must be a non-zero 3-vector"),
            (dict(poisson="bogus"), "poisson must be one of exact, gaussian"),
            (dict(cell_factor=0.0), "cell_factor"),
            (dict(cell_factor=0.01), "cell_factor 0.01 is too small"),
            (dict(texton=np.ones((8, 8, 1))), "texton must be a Texton"),
            (dict(texel_size=1e-10), "too far from the origin"),
            (dict(device="tpu"), "device"),
        ],
    )
    def test_errors(self, kw, match, device):
        args = dict(texton=T1, points=P1, normals=N1, texel_size=1.0, device=device)
        args.update(kw)
        with pytest.raises(TextonError, match=match):
            surface_noise(**args)

    def test_no_points(self, device):
        assert surface_noise(T1, np.zeros((0, 3)), np.zeros((0, 3)), 1.0, device=device).shape == (0, 1)


def degenerate_mesh():
    """A proper triangle, a zero-area (collinear) one, a face of one repeated vertex, and an
    unreferenced vertex: vertices 3, 4 and 5 have no area around them."""
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0], [0.5, 0.5, 3.0], [4.0, 4.0, 4.0]])
    f = np.array([[0, 1, 2], [0, 1, 3], [4, 4, 4]])
    return trimesh.Trimesh(v, f, process=False)


class TestMeshes:
    def test_zero_area_triangles_get_defined_colours(self, device):
        t = small_texton(channels=3, sd=0.15)
        mesh = degenerate_mesh()
        out = texture_mesh(mesh, t, 0.05, device=device)
        c = colours(out)
        assert c.shape == (6, 4) and c.dtype == np.uint8 and np.all(c[:, 3] == 255)
        # vertices with no area around them take the normal UP: a defined value
        n = vertex_normals(out)
        np.testing.assert_array_equal(n[3:], np.tile(A, (3, 1)))
        g = surface_noise(t, out.vertices, n, 0.05, device=device)
        np.testing.assert_array_equal(c[:, :3], np.round(np.clip(g, 0, 1) * 255))
        img = render_mesh(mesh, t, (24, 24), texel_size=0.05, device=device)
        assert np.isfinite(img).all() and img.min() >= 0 and img.max() <= 1

    @pytest.mark.parametrize(
        "mesh, match",
        [
            (trimesh.Trimesh(), "mesh is empty"),
            (trimesh.Trimesh(np.eye(3), np.zeros((0, 3), int), process=False), "mesh is empty"),
            (trimesh.Trimesh(np.eye(3), [[0, 1, 5]], process=False), "faces index vertices that do not exist"),
            (trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, float("nan"), 0]], [[0, 1, 2]], process=False),
             "NaN or infinite vertex"),
            (np.eye(3), "mesh must be a trimesh.Trimesh"),
            (trimesh.Scene(), "mesh must be a trimesh.Trimesh"),
        ],
        ids=["no-vertices", "no-faces", "bad-index", "nan", "array", "scene"],
    )
    def test_bad_meshes(self, mesh, match, device):
        with pytest.raises(TextonError, match=match):
            texture_mesh(mesh, T1, 0.1, device=device)
        with pytest.raises(TextonError, match=match):
            render_mesh(mesh, T1, (8, 8), device=device)

    @pytest.mark.parametrize("kind", ["triangle", "open-grid", "non-manifold"])
    def test_open_and_non_manifold_meshes(self, kind, device):
        if kind == "triangle":
            mesh = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0.2]], [[0, 1, 2]], process=False)
        elif kind == "open-grid":
            mesh = plane_mesh(n=12)
        else:  # three triangles sharing the edge (0, 1)
            mesh = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, 0, 1], [0.5, -0.7, -0.7]],
                                   [[0, 1, 2], [0, 1, 3], [0, 1, 4]], process=False)
        assert not mesh.is_watertight
        t = small_texton(channels=3, sd=0.15)
        out = texture_mesh(mesh, t, 0.02, device=device)
        n = vertex_normals(out)
        np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-12)
        g = surface_noise(t, out.vertices, n, 0.02, device=device)
        np.testing.assert_array_equal(colours(out)[:, :3], np.round(np.clip(g, 0, 1) * 255))
        img = render_mesh(mesh, t, (32, 32), texel_size=0.02, device=device)
        bg = np.float32(0.92)
        hit = np.any(img != bg, axis=2)
        assert 0 < hit.mean() < 1 and np.isfinite(img).all()

    @pytest.mark.parametrize(
        "kw, match",
        [
            (dict(texel_size=0.0), "texel_size"),
            (dict(texel_size=-1.0), "texel_size"),
            (dict(max_edge=0.0), "max_edge"),
            (dict(max_edge=float("nan")), "max_edge"),
            (dict(seed=-3), "seed"),
            (dict(mni=0.0), "mni"),
            (dict(texton="wood.exr"), "texton must be a Texton"),
        ],
    )
    def test_texture_mesh_errors(self, kw, match, device):
        args = dict(mesh=trimesh.creation.icosphere(subdivisions=1), texton=T1, texel_size=0.1, device=device)
        args.update(kw)
        with pytest.raises(TextonError, match=match):
            texture_mesh(**args)


# --------------------------------------------------------------------------- #
# 6. Subdivision                                                              #
# --------------------------------------------------------------------------- #
def edge_lengths(mesh):
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    return np.linalg.norm(v[f[:, [1, 2, 0]]] - v[f], axis=2)


class TestMaxEdge:
    @pytest.mark.parametrize("max_edge", [0.8, 2.5])
    def test_edges_are_short_enough(self, max_edge, device):
        t = small_texton()
        mesh = trimesh.creation.icosphere(subdivisions=1, radius=1.0)
        texel = 0.03
        out = texture_mesh(mesh, t, texel, max_edge=max_edge, device=device)
        assert edge_lengths(mesh).max() > 4 * max_edge * texel  # there was work to do
        assert edge_lengths(out).max() <= max_edge * texel * (1 + 1e-9)
        assert len(colours(out)) == len(out.vertices) > len(mesh.vertices)
        # no cracks: a watertight input stays watertight, shared positions share one vertex
        assert out.is_watertight
        assert len(np.unique(np.round(np.asarray(out.vertices), 9), axis=0)) == len(out.vertices)
        # the new vertices lie on the input's faces: the area and the volume are unchanged
        assert out.area == pytest.approx(mesh.area, rel=1e-9)
        assert out.volume == pytest.approx(mesh.volume, rel=1e-9)

    def test_too_many_faces_is_refused(self, device):
        mesh = trimesh.creation.icosphere(subdivisions=1)
        with pytest.raises(TextonError, match=r"max_edge 0\.01 texels would make about \d+ faces"):
            texture_mesh(mesh, T1, 0.01, max_edge=0.01, device=device)
        with pytest.raises(TextonError, match=r"at most 100\)"):
            texture_mesh(mesh, T1, 0.1, max_edge=1.0, max_faces=100, device=device)

    def test_max_faces_bounds_the_result(self, device):
        # an equilateral triangle of side 1 cut to edges ≤ 0.24: estimate ceil(1/0.24)² = 25 faces,
        # but bisection needs edges 1/8 < 0.24, i.e. 64 faces
        tri = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0.5, math.sqrt(3) / 2, 0]], [[0, 1, 2]], process=False)
        try:
            out = texture_mesh(tri, T1, 1.0, max_edge=0.24, max_faces=25, device=device)
        except TextonError:
            return  # refused: the bound holds
        assert len(out.faces) <= 25, f"{len(out.faces)} faces with max_faces=25"


# --------------------------------------------------------------------------- #
# 7. Rendering                                                                #
# --------------------------------------------------------------------------- #
LIGHT = np.array([0.4, -0.5, 1.0]) / np.linalg.norm([0.4, -0.5, 1.0])


class TestRender:
    @pytest.mark.parametrize("where", ["framed", "off to the side", "around the eye", "behind"])
    def test_rays_outside_the_screen_box_would_miss(self, where, device, monkeypatch):
        # only the pixels of the mesh's screen box cast rays: casting every pixel must give
        # the same hits, bit for bit, whether the mesh fills the view, leaves it partly,
        # surrounds the eye (the whole image is cast) or lies behind it (none is)
        import warp_texton.surface.render as R
        from warp_texton.surface.render import cast_rays

        mesh = trimesh.creation.torus(1.0, 0.4, major_sections=40, minor_sections=20)
        cam = {"framed": Camera((3.0, -4.0, 2.0), (0, 0, 0), (0, 0, 1), 40.0),
               "off to the side": Camera((3.0, -4.0, 2.0), (2.5, 0.5, 0), (0, 0, 1), 40.0),
               "around the eye": Camera((0.0, 1.0, 0.0), (1.0, 1.0, 0.3), (0, 0, 1), 80.0),
               "behind": Camera((0.0, -5.0, 0.0), (0.0, -9.0, 0.0), (0, 0, 1), 40.0)}[where]
        boxes = []
        real_box = R.screen_box
        monkeypatch.setattr(R, "screen_box", lambda *a: boxes.append(real_box(*a)) or boxes[-1])
        got = cast_rays(mesh, (60, 80), cam, device=device)
        monkeypatch.setattr(R, "screen_box", lambda rel, f, r, u, t, a, h, w: (0, h, 0, w))
        want = cast_rays(mesh, (60, 80), cam, device=device)
        for a, b in ((got.face, want.face), (got.bary, want.bary), (got.normal, want.normal),
                     (got.shade, want.shade)):
            np.testing.assert_array_equal(a, b)
        r0, r1, c0, c1 = boxes[0]
        if where == "framed":
            assert 0 < (r1 - r0) * (c1 - c0) < 0.8 * 60 * 80 and want.hit.mean() > 0.1
        elif where == "off to the side":
            assert 0 < (r1 - r0) * (c1 - c0) < 60 * 80 and want.hit.any() and not want.hit.all()
        elif where == "around the eye":
            assert (r0, r1, c0, c1) == (0, 60, 0, 80) and want.hit.any()
        else:
            assert (r1 - r0) * (c1 - c0) == 0 and not want.hit.any()

    def test_sphere_render_is_shaded_noise_with_the_texton_mean(self, device):
        """Pixel = clip(g) (0.3 + 0.7 |⟨n, light⟩|) on hits, background elsewhere.

        Camera at (0, 0, 5) looking at the origin, up y: right = +x. Pixel (i, j) looks along
        d = normalize(−z + sx x + sy y), sx = (2(j + ½)/W − 1) tan(fov/2), sy = (1 − 2(i + ½)/H)
        tan(fov/2); the analytic sphere gives n at the hit. 48 × 48 pixels on a unit sphere
        are ≥ 0.045 apart: 22 texels of 0.002 > r√3 = 15.6, so hit pixels are independent.
        """
        t = small_texton(channels=1, sd=0.08, mean=(0.55,))
        mesh = trimesh.creation.icosphere(subdivisions=5, radius=1.0)
        cam = Camera(position=(0, 0, 5.0), target=(0, 0, 0), up=(0, 1.0, 0), fov=30.0)
        h = w = 48
        img = render_mesh(mesh, t, (h, w), texel_size=0.002, camera=cam, seed=2, device=device)
        assert img.shape == (h, w, 3) and img.dtype == np.float32
        tan = math.tan(math.radians(15.0))
        sy, sx = np.meshgrid((1 - 2 * (np.arange(h) + 0.5) / h) * tan, (2 * (np.arange(w) + 0.5) / w - 1) * tan,
                             indexing="ij")
        d = np.stack([sx, sy, -np.ones_like(sx)], axis=2)
        d /= np.linalg.norm(d, axis=2)[:, :, None]
        o = np.array([0, 0, 5.0])
        b = d @ o
        miss_dist = np.sqrt(np.maximum(o @ o - b**2, 0))  # distance from the centre to the ray
        bg = np.float32(0.92)
        outside = miss_dist > 1.02
        inside = miss_dist < 0.97
        assert np.all(img[outside] == bg)
        assert np.all(np.any(img[inside] != bg, axis=1))
        # grey noise is spread to the three channels
        np.testing.assert_array_equal(img[inside][:, 1], img[inside][:, 0])
        np.testing.assert_array_equal(img[inside][:, 2], img[inside][:, 0])
        tt = -b - np.sqrt(np.maximum(1 - miss_dist**2, 0))
        hitp = o + tt[:, :, None] * d
        shade = 0.3 + 0.7 * np.abs(hitp @ LIGHT)
        g = img[inside][:, 0] / shade[inside]
        count = g.size
        assert count > 900
        # i.i.d. values of g (clipping beyond 5 sd is negligible): sd of the mean σ/√N
        sd = noise_sd(t)
        assert abs(g.mean() - t.mean[0]) < 5 * sd / math.sqrt(count), (g.mean(), t.mean[0])
        assert abs(g.std() / sd - 1) < 5 * math.sqrt(0.5 / count) + 0.02  # 2 %: shading from mesh normals
        # the shading is the documented one: g does not depend on it
        corr = np.corrcoef(g, shade[inside])[0, 1]
        assert abs(corr) < 5 / math.sqrt(count), corr

    def test_image_orientation(self, device):
        # a small ball up (y > 0) lands in the top rows, one to the right (x > 0) in the right columns
        t = small_texton()
        cam = Camera(position=(0, 0, 10.0), target=(0, 0, 0), up=(0, 1.0, 0), fov=30.0)
        up_ball = trimesh.creation.icosphere(subdivisions=2, radius=0.3)
        up_ball.apply_translation((0, 1.5, 0))
        img = render_mesh(up_ball, t, (40, 40), camera=cam, device=device)
        rows, cols = np.nonzero(np.any(img != np.float32(0.92), axis=2))
        assert rows.size and rows.max() < 20 and abs(cols.mean() - 19.5) < 2
        right_ball = up_ball.copy()
        right_ball.apply_translation((1.5, -1.5, 0))
        img = render_mesh(right_ball, t, (40, 40), camera=cam, device=device)
        rows, cols = np.nonzero(np.any(img != np.float32(0.92), axis=2))
        assert cols.size and cols.min() >= 20 and abs(rows.mean() - 19.5) < 2

    def test_camera_that_misses_sees_the_background(self, device):
        t = small_texton()
        mesh = trimesh.creation.icosphere(subdivisions=2)
        cam = Camera(position=(0, 0, 5.0), target=(0, 0, 10.0), up=(0, 1.0, 0))  # looking away
        bg = (0.1, 0.2, 0.3)
        img = render_mesh(mesh, t, (16, 24), camera=cam, background=bg, device=device)
        assert img.shape == (16, 24, 3)
        np.testing.assert_array_equal(img, np.broadcast_to(np.float32(bg), img.shape))

    def test_default_camera_frames_the_mesh(self, device):
        t = small_texton()
        mesh = trimesh.creation.torus(1.0, 0.3)
        img = render_mesh(mesh, t, (32, 48), device=device)
        hit = np.any(img != np.float32(0.92), axis=2)
        assert 0.05 < hit.mean() < 0.9
        # nothing is cut off: the border rows and columns see the background
        assert not hit[0].any() and not hit[-1].any() and not hit[:, 0].any() and not hit[:, -1].any()
        np.testing.assert_array_equal(img, render_mesh(mesh, t, (32, 48), device=device))

    @pytest.mark.parametrize("args, kw, match", [
        (((0, 0, 5.0), (0, 0, 0)), dict(fov=180.0), "camera.fov must be below 180"),
        (((0, 0, 5.0), (0, 0, 0)), dict(fov=0.0), "camera.fov"),
        (((0, 0, 5.0), (0, 0, 0)), dict(fov=float("nan")), "camera.fov"),
        (((0, 0, 5.0), (0, 0, 0)), dict(up=(0, 0, 1.0)), "camera.up is parallel"),
        (((0, 0, 5.0), (0, 0, 0)), dict(up="abc"), "camera.up must be a non-zero 3-vector"),
        (((0, 0, 0.0), (0, 0, 0)), {}, "camera.target - camera.position must be a non-zero"),
        (((0, 0, float("inf")), (0, 0, 0)), {}, "camera.position must be a point"),
        ((("0", 0, 5.0), (0, 0, 0)), {}, "camera.position must be a point"),
    ])
    def test_bad_cameras(self, args, kw, match):
        """A Camera is checked when it is made, so a bad one never reaches a render."""
        with pytest.raises(TextonError, match=match):
            Camera(*args, **kw)

    @pytest.mark.parametrize(
        "kw, match",
        [
            (dict(shape=(0, 8)), r"shape\[0\] \(height\) must be at least 1"),
            (dict(shape=8), "shape must be a pair"),
            (dict(shape=(100000, 100000)), "too large"),
            (dict(camera=((0, 0, 5.0), (0, 0, 0))), "camera must be a warp_texton.Camera"),
            (dict(texel_size=0.0), "texel_size"),
            (dict(seed=1.5), "seed"),
            (dict(texton=None), "texton must be a Texton"),
        ],
    )
    def test_render_errors(self, kw, match, device):
        args = dict(mesh=trimesh.creation.icosphere(subdivisions=1), texton=T1, shape=(8, 8), device=device)
        args.update(kw)
        with pytest.raises(TextonError, match=match):
            render_mesh(**args)


# --------------------------------------------------------------------------- #
# 8. Real meshes (pyvista's example files, read with trimesh)                 #
# --------------------------------------------------------------------------- #
def _pyvista_examples():
    spec = importlib.util.find_spec("pyvista")  # no import: pyvista needs VTK
    if spec is None or not spec.submodule_search_locations:
        return None
    folder = Path(spec.submodule_search_locations[0]) / "examples"
    return folder if folder.is_dir() else None


PYVISTA_EXAMPLES = _pyvista_examples()


def _bunny():
    """The Stanford bunny (a range scan with holes, Z up) as pymeshfix ships it, or None."""
    spec = importlib.util.find_spec("pymeshfix")  # no import: pymeshfix needs VTK
    if spec is None or not spec.submodule_search_locations:
        return None
    path = Path(spec.submodule_search_locations[0]) / "examples" / "StanfordBunny.ply"
    return path if path.is_file() else None


BUNNY = _bunny()
REAL_MESHES = ("nut.ply", "ant.ply", "airplane.ply", "sphere.ply")


@pytest.fixture(params=REAL_MESHES)
def real_mesh(request):
    if PYVISTA_EXAMPLES is None or not (PYVISTA_EXAMPLES / request.param).is_file():
        pytest.skip("pyvista's example meshes are not installed (pip install --no-deps pyvista)")
    mesh = trimesh.load(PYVISTA_EXAMPLES / request.param, force="mesh", process=False)
    assert isinstance(mesh, trimesh.Trimesh) and len(mesh.faces) > 0
    return request.param, mesh


class TestRealMeshes:
    def test_texture_mesh_mean_colour(self, real_mesh, device):
        name, mesh = real_mesh
        t = small_texton()  # means (0.3, 0.5, 0.7), sd 0.06
        lo, hi = mesh.bounds
        texel = float(np.linalg.norm(hi - lo)) / 1024  # r√3 texels ≈ 1.5 % of the diagonal
        out = texture_mesh(mesh, t, texel, seed=1, device=device)
        c = colours(out)
        # a vertex for each side of a crease (the default normals split them)
        assert c.shape == (len(out.vertices), 4) and len(out.vertices) >= len(mesh.vertices)
        assert np.all(c[:, 3] == 255)
        g = c[:, :3].astype(np.float64) / 255
        # Var(mean) = (1/N²) Σ_ij Cov(g_i, g_j) ≤ C_aa · (mean count of vertices within r√3,
        # self included) / N, since |Cov| ≤ C_aa and values farther apart are independent
        # (duplicate vertices count as neighbours). 8-bit rounding moves the mean by ≤ 0.5/255.
        v = np.asarray(out.vertices) / texel
        neighbours = np.mean([len(x) for x in cKDTree(v).query_ball_point(v, support_side(t) * math.sqrt(3))])
        sd = np.sqrt(np.diag(t.covariance()) * neighbours / len(v))
        dev = g.mean(axis=0) - t.mean
        assert np.all(np.abs(dev) < 5 * sd + 0.5 / 255), (name, dev.round(4).tolist(), sd.round(4).tolist())
        # the channels are where they belong: means 0.2 apart ≫ the tolerance
        assert np.all(5 * sd + 0.5 / 255 < 0.1)

    def test_render(self, real_mesh, device):
        name, mesh = real_mesh
        t = small_texton()
        img = render_mesh(mesh, t, (32, 40), seed=3, device=device)
        assert img.shape == (32, 40, 3) and np.isfinite(img).all()
        assert img.min() >= 0.0 and img.max() <= 1.0
        bg = np.float32(0.92)
        hit = np.any(img != bg, axis=2)
        assert 0.02 < hit.mean() < 0.95, name
        assert np.all(img[~hit] == bg)
        # shaded colours: channel order kept (means 0.3 < 0.5 < 0.7, sd 0.06) on most hits
        order = (img[hit][:, 0] < img[hit][:, 1]) & (img[hit][:, 1] < img[hit][:, 2])
        assert order.mean() > 0.9


# --------------------------------------------------------------------------- #
# 9. CUDA                                                                     #
# --------------------------------------------------------------------------- #

class TestDeviceMatchesCpu:
    """The --device (a GPU) gives the CPU's noise: the same impacts, to float rounding."""

    def test_surface_noise_matches_cpu(self, gpu):
        t = random_texton(channels=3, seed=40)
        n = random_normals(4000, 41)
        p = np.random.default_rng(42).uniform(-5, 5, (4000, 3))
        a = surface_noise(t, p, n, 0.03, seed=5, device="cpu")
        b = surface_noise(t, p, n, 0.03, seed=5, device=gpu)
        np.testing.assert_allclose(a, b, atol=1e-4 * noise_sd(t))

    def test_blocks_match_cpu(self, gpu):
        # clusters, lists and the gather on the device: the CPU walk's values
        t = random_texton(channels=3, seed=43)
        mesh = trimesh.creation.icosphere(subdivisions=5)
        n = vertex_normals(mesh)
        a = surface_noise(t, mesh.vertices, n, 0.01, seed=6, device="cpu", method="points")
        b = surface_noise(t, mesh.vertices, n, 0.01, seed=6, device=gpu, method="blocks")
        np.testing.assert_allclose(a, b, atol=1e-4 * noise_sd(t))

    def test_bake_matches_cpu(self, gpu):
        from warp_texton import bake_mesh

        t = small_texton()
        mesh = trimesh.creation.icosphere(subdivisions=3)
        mesh.visual = trimesh.visual.TextureVisuals(uv=(mesh.vertices[:, :2] + 1) / 2)  # overlapping: refused
        with pytest.raises(TextonError, match="overlap"):
            bake_mesh(mesh, t, 0.02, resolution=64, device=gpu)
        plane = plane_mesh(n=5)
        plane.visual = trimesh.visual.TextureVisuals(uv=np.asarray(plane.vertices)[:, :2])
        a = bake_mesh(plane, t, 1 / 64, resolution=64, device="cpu").texture
        b = bake_mesh(plane, t, 1 / 64, resolution=64, device=gpu).texture
        np.testing.assert_allclose(a, b, atol=1e-4 * noise_sd(t))

    def test_render_matches_cpu(self, gpu):
        t = small_texton()
        mesh = trimesh.creation.torus(1.0, 0.3)
        a = render_mesh(mesh, t, (40, 40), device="cpu")
        b = render_mesh(mesh, t, (40, 40), device=gpu)
        # a ray grazing an edge may hit another face on the other device: allow a few pixels
        assert np.mean(np.any(np.abs(a - b) > 1e-4, axis=2)) < 0.01


# --------------------------------------------------------------------------- #
# 10. Blocks of points = the per-point walk                                   #
# --------------------------------------------------------------------------- #
def _same_values(a, b, t, device):
    """The block path and the walk sum the same terms in the same order.

    On the CPU both kernels compile the same @wp.func expressions (cube_offset,
    impact_offset3, slab_term) into the same operations, so they agree bit for bit.
    Elsewhere a compiler may fuse a·b + c differently in the two kernels: each
    term then moves by a few float32 ulps (≈ 1e-6 of it) and a sum of ≤ 10³ terms
    of size ≤ 1 by ≤ 1e-3 · 1e-6 · 10³ … well below 1e-4 of the noise's sd.
    """
    if str(device) == "cpu":
        np.testing.assert_array_equal(a, b)
    else:
        np.testing.assert_allclose(a, b, atol=1e-4 * noise_sd(t))


def _host_simd() -> str:
    """The vector instruction set the CPU loops should be built for here: "avx512",
    "avx2", "neon" (every AArch64 CPU has it) or "scalar"."""
    if platform.machine().lower() in ("arm64", "aarch64"):
        return "neon"
    try:
        flags = Path("/proc/cpuinfo").read_text().split("\nflags", 1)[1].split("\n", 1)[0].split()
    except (OSError, IndexError):
        pytest.skip("no /proc/cpuinfo flags on this system")
    return "avx512" if "avx512f" in flags else "avx2" if "avx2" in flags else "scalar"


def _dense_cluster_points(rng):
    """Dense points (about a texel apart at texel 0.05, dozens per cluster cell), so that
    the clusters list their impacts; far from the origin; mesh normals and random ones."""
    mesh = trimesh.creation.torus(2.0, 0.7, major_sections=200, minor_sections=80)
    offset = np.array([5e3, -2e3, 1e3])
    p = np.concatenate([mesh.vertices, rng.uniform(-0.5, 0.5, (3000, 3))]) + offset
    n = np.concatenate([vertex_normals(mesh), rng.normal(size=(3000, 3))])
    return p, n


#: Run in a fresh process: the block path built for AVX2 (no AVX-512, no masked
#: builtins) against the walk, with the vector loops and without.
AVX2_ONLY = """
import numpy as np, trimesh, warp as wp
wp.config.quiet = True
wp.config.cpu_compiler_flags = (wp.config.cpu_compiler_flags or "-march=native").replace(
    "-march=native", "-march=native -target-feature -avx512f -D WT_MASKED=0")
import warp_texton.surface.blocks as S
from warp_texton import Texton, surface_noise
print(S.simd_loops("cpu"))
rng = np.random.default_rng(5)
mesh = trimesh.creation.torus(2.0, 0.7, major_sections=120, minor_sections=50)
p = mesh.vertices + np.array([5e3, -2e3, 1e3])
n = np.asarray(mesh.vertex_normals)
for c in (3, 1):  # the three-channel loops and the one-channel ones
    t = Texton(0.05 * rng.standard_normal((12, 10, c)), [0.5] * c)
    b = surface_noise(t, p, n, 0.05, seed=2, mni=40.0, method="points", device="cpu")
    for simd in (True, False):
        S.SIMD = simd
        print(np.array_equal(surface_noise(t, p, n, 0.05, seed=2, mni=40.0, method="blocks", device="cpu"), b))
"""


class TestBlocks:
    @pytest.mark.parametrize("order", [0, 1, 3, 5])
    def test_blocks_equal_the_walk_on_random_points(self, order, device):
        rng = np.random.default_rng(100 + order)
        t = random_texton(tuple(int(v) for v in rng.integers(3, 11, 2)), channels=3, order=order, seed=rng)
        p = rng.uniform(-40, 40, (4000, 3))
        n = rng.normal(size=(4000, 3))
        for tangents in (None, np.cross(n, rng.normal(size=3))):
            kw = dict(seed=int(rng.integers(0, 2**32)), mni=float(rng.uniform(5, 80)), tangents=tangents,
                      device=device)
            a = surface_noise(t, p, n, 0.07, method="blocks", **kw)
            b = surface_noise(t, p, n, 0.07, method="points", **kw)
            _same_values(a, b, t, device)
            assert a.std(axis=0).min() > 0.3 * noise_sd(t)

    @pytest.mark.parametrize("shape", ["sphere", "torus", "noisy"])
    def test_blocks_equal_the_walk_on_meshes(self, shape, device):
        rng = np.random.default_rng(7)
        t = random_texton(channels=1, seed=8)
        if shape == "sphere":
            mesh = trimesh.creation.icosphere(subdivisions=4, radius=3.0)
        elif shape == "torus":
            mesh = trimesh.creation.torus(2.0, 0.6)
            mesh.apply_translation((-3e4, 1e4, 2e3))  # far from the origin too
        else:  # normals that jump from vertex to vertex: clusters with wide frames
            mesh = trimesh.creation.icosphere(subdivisions=3)
            mesh.vertices = mesh.vertices + rng.normal(scale=0.05, size=mesh.vertices.shape)
        n = vertex_normals(mesh)
        a = surface_noise(t, mesh.vertices, n, 0.01, seed=3, device=device, method="blocks")
        b = surface_noise(t, mesh.vertices, n, 0.01, seed=3, device=device, method="points")
        _same_values(a, b, t, device)

    @pytest.mark.parametrize("simd", [True, False])
    @pytest.mark.parametrize("channels", [3, 1])
    def test_simd_and_scalar_loops_equal_the_walk(self, channels, simd, device, monkeypatch):
        # the CPU lists and gathers clusters with kernels/surface_native.py: the vector form
        # where the CPU has AVX2, AVX-512 or NEON, plain C++ otherwise, for three channels
        # and for one (a grey texton's float loops); both must sum the walk's terms in its order
        import warp_texton.surface.blocks as blk

        monkeypatch.setattr(blk, "SIMD", simd)
        rng = np.random.default_rng(31)
        t = random_texton((16, 12), channels=channels, order=1, seed=rng)
        p, n = _dense_cluster_points(rng)
        for tangents in (None, np.cross(n, rng.normal(size=3))):
            kw = dict(seed=11, mni=float(rng.uniform(20, 90)), tangents=tangents, device=device)
            a = surface_noise(t, p, n, 0.05, method="blocks", **kw)
            b = surface_noise(t, p, n, 0.05, method="points", **kw)
            _same_values(a, b, t, device)
            assert a.std(axis=0).min() > 0.3 * noise_sd(t)

    @pytest.mark.parametrize("order", [1, 3])
    @pytest.mark.parametrize("method", ["blocks", "points"])
    def test_grey_values_are_the_first_channel_of_three(self, order, method, device):
        # a grey texton runs the one-channel kernels (one float a texel); a texton whose
        # first channel is that texton runs the three-channel ones: the same values in
        # that channel, bit for bit, with the frame rule and with tangents
        rng = np.random.default_rng(40 + order)
        grey = random_texton((14, 11), channels=1, order=order, seed=rng)
        three = Texton(np.concatenate([grey.coeffs, 0.03 * rng.standard_normal(grey.coeffs.shape[:2] + (2,))],
                                      axis=2), [grey.mean[0], 0.2, 0.7], order=order)
        p, n = _dense_cluster_points(rng)
        for tangents in (None, np.cross(n, rng.normal(size=3))):
            kw = dict(seed=13, mni=45.0, tangents=tangents, device=device, method=method)
            g = surface_noise(grey, p, n, 0.05, **kw)
            assert g.shape == (len(p), 1) and g.dtype == np.float32
            assert np.array_equal(g[:, 0], surface_noise(three, p, n, 0.05, **kw)[:, 0])
            assert g.std() > 0.3 * noise_sd(grey)

    def test_vector_loops_are_built_where_the_cpu_has_simd(self):
        # a build that silently lost the vector loops would give the same values, only
        # about 2x slower: check that Warp's CPU code (compiled for this CPU) has them
        # wherever the CPU has AVX2, AVX-512 or NEON
        import warp_texton.surface.blocks as S

        assert S.simd_loops("cpu") == _host_simd()

    @pytest.mark.slow
    def test_avx2_build_takes_the_vector_loops(self, tmp_path):
        # on an AVX-512 CPU, the build for AVX2 only (Warp's CPU flags without avx512f,
        # in a fresh process: the flags are part of every module's build) must still take
        # the vector form and give the walk's values bit for bit; built with the plain
        # tail loads and compaction that Clang before 21 gets (WT_MASKED=0), so that
        # both of the vector form's variants run here
        if _host_simd() != "avx512":
            pytest.skip("needs an AVX-512 CPU (an AVX2 one runs this form in every test)")
        script = tmp_path / "avx2.py"
        script.write_text(AVX2_ONLY)
        done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr[-2000:]
        assert done.stdout.split() == ["avx2"] + ["True"] * 4

    def test_blocks_spread_beyond_int64_keys(self, device):
        # two dense groups 10^7 texels apart on every axis: (10^7 / block side)^3 blocks
        # do not fit one int64 sort key, and the blocks are sorted by their coordinates
        rng = np.random.default_rng(12)
        t = random_texton((8, 8), channels=3, order=1, seed=rng)
        p = np.concatenate([rng.uniform(-4, 4, (3000, 3)) - 5e6, rng.uniform(-4, 4, (3000, 3)) + 5e6])
        n = rng.normal(size=p.shape)
        a = surface_noise(t, p, n, 1.0, seed=5, device=device, method="blocks")
        b = surface_noise(t, p, n, 1.0, seed=5, device=device, method="points")
        _same_values(a, b, t, device)
        assert a[:3000].std() > 0.3 * noise_sd(t) and a[3000:].std() > 0.3 * noise_sd(t)

    def test_overflowing_cluster_lists_fall_back_to_the_block(self, device, monkeypatch):
        import warp_texton.surface.blocks as blk

        t = random_texton(channels=3, seed=9)
        mesh = trimesh.creation.icosphere(subdivisions=4)
        n = vertex_normals(mesh)
        want = surface_noise(t, mesh.vertices, n, 0.02, device=device, method="points")
        for cap, per_round, cubes in ((8, 1 << 13, 1 << 20), (1024, 3, 50)):  # every list overflows; tiny rounds
            monkeypatch.setattr(blk, "CLUSTER_CAP", cap)
            monkeypatch.setattr(blk, "CLUSTERS_PER_ROUND", per_round)
            monkeypatch.setattr(blk, "CUBES_PER_ROUND", cubes)
            _same_values(surface_noise(t, mesh.vertices, n, 0.02, device=device, method="blocks"), want, t, device)

    def test_blocks_without_normals_sort_alike(self):
        # points without normals (a volume's) sort into the same blocks, cubes and
        # clusters, with the same sorted positions
        from warp_texton.surface.blocks import sort_into_blocks

        rng = np.random.default_rng(8)
        p = rng.uniform(-20, 20, (5000, 3)) + 1e4
        n = rng.normal(size=p.shape)
        a = sort_into_blocks(p, n, 1.5, 2.6)
        b = sort_into_blocks(p, None, 1.5, 2.6)
        assert b.nrm is None and a.nrm.shape == (5000, 3)
        for name in ("order", "pos", "starts", "lo", "hi", "clusters"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
        np.testing.assert_array_equal(a.pos, p[a.order])
        np.testing.assert_array_equal(a.nrm, n[a.order].astype(np.float32))
        assert 1 < len(a.starts) < len(a.clusters) < len(p)

    def test_auto_walks_few_points_and_blocks_many(self, device, monkeypatch):
        import warp_texton.surface.points as S

        t = random_texton(channels=1, seed=3)
        p = np.random.default_rng(4).normal(size=(300, 3))
        used = []
        monkeypatch.setattr(S, "gather_blocks", lambda p, coeffs, pos, *a, **kw: used.append("blocks") or
                            np.zeros((len(pos), 3), np.float32))
        surface_noise(t, p, p, 0.05, device=device)
        assert used == []
        monkeypatch.setattr(S, "AUTO_MIN_POINTS", 100)
        monkeypatch.setattr(S, "AUTO_MIN_DENSITY", 0.0)  # the density rule: tests/test_mesh_assets.py
        surface_noise(t, p, p, 0.05, device=device)
        assert used == ["blocks"]

    def test_memory_budget(self, device):
        from warp_texton.core.limits import set_memory_budget

        p = np.random.default_rng(5).normal(size=(5000, 3))
        set_memory_budget("1M")
        try:
            with pytest.raises(TextonError, match=r"surface noise at 5000 points needs about .* over the memory "
                                                  r"budget of 1 MiB"):
                surface_noise(T1, p, p, 0.05, device=device, method="blocks")
        finally:
            set_memory_budget(None)

    def test_method_is_checked(self, device):
        with pytest.raises(TextonError, match="method must be one of auto, blocks, points"):
            surface_noise(T1, P1, N1, 1.0, device=device, method="fast")
        with pytest.raises(TextonError, match="method must be one of auto, blocks, points"):
            render_mesh(trimesh.creation.icosphere(1), T1, (8, 8), device=device, method="fast")


# --------------------------------------------------------------------------- #
# 11. Far from the origin: float64 cube lookup                                #
# --------------------------------------------------------------------------- #
class TestFarFromOrigin:
    def test_noise_varies_at_sub_texel_steps_far_away(self, device):
        """At 3·10⁸ texels a float32 position has a step of 32 texels: points 10⁻² texel apart
        would share their offsets and values. In float64 the values move continuously:
        by at most Lip·δ, and by something on nearly every point."""
        t = random_texton(channels=1, seed=11)
        rng = np.random.default_rng(12)
        n = rng.normal(size=(3000, 3))
        u1, _ = tangent_frames(n)
        far = np.array([3e8, -2e8, 1e8]) + rng.uniform(-500, 500, (3000, 3))
        delta = 1e-2
        a = surface_noise(t, far, n, 1.0, seed=4, device=device)[:, 0]
        b = surface_noise(t, far + delta * u1, n, 1.0, seed=4, device=device)[:, 0]
        assert np.mean(a != b) > 0.95
        # continuous: in the linear regime twice the step moves the values twice as much
        # (float32 offsets would give 0 or jumps of the order of the sd instead)
        c = surface_noise(t, far + 2 * delta * u1, n, 1.0, seed=4, device=device)[:, 0]
        ratio = np.abs(c - a).mean() / np.abs(b - a).mean()
        assert 1.7 < ratio < 2.3, ratio
        assert np.abs(a - b).max() < 0.1 * noise_sd(t)
        # the values far away have the texton's mean and variance (points ≥ r√3 apart: independent)
        p, nn, texel = independent_points("tilted plane", t)
        g = surface_noise(t, p + np.array([3e8, -2e8, 1e8]) * texel, nn, texel, seed=5, device=device)[:, 0]
        c0 = t.covariance()[0, 0]
        assert abs(g.mean() - t.mean[0]) < 5 * math.sqrt(c0 / len(g))
        assert abs(g.var() / c0 - 1) < 5 * math.sqrt(2 / len(g)) + 0.05

    def test_render_of_a_far_mesh(self, device):
        t = small_texton(channels=1, sd=0.08, mean=(0.55,))
        near = trimesh.creation.icosphere(subdivisions=4)
        far = near.copy()
        far.apply_translation((2e6, -1e6, 5e5))  # 1.5e8 texels at texel 0.01: float32 steps of 8 texels
        cam_near = Camera(position=(0, -4.0, 1.0), target=(0, 0, 0), fov=40.0)
        shift = np.array([2e6, -1e6, 5e5])
        cam_far = Camera(tuple(np.array(cam_near.position) + shift), tuple(shift), fov=40.0)
        a = render_mesh(near, t, (48, 48), texel_size=0.01, camera=cam_near, device=device)
        b = render_mesh(far, t, (48, 48), texel_size=0.01, camera=cam_far, device=device)
        hit_a, hit_b = np.any(a != np.float32(0.92), axis=2), np.any(b != np.float32(0.92), axis=2)
        assert np.mean(hit_a != hit_b) < 0.01 and hit_b.mean() > 0.3  # the same silhouette
        # noise, not flat patches: neighbouring hit pixels differ as much as near the origin
        da = np.abs(np.diff(a[:, :, 0], axis=1))[hit_a[:, 1:] & hit_a[:, :-1]].mean()
        db = np.abs(np.diff(b[:, :, 0], axis=1))[hit_b[:, 1:] & hit_b[:, :-1]].mean()
        assert 0.7 < db / da < 1.4

    def test_meshes_beyond_the_cube_range_raise_the_surface_noise_error(self, device):
        mesh = trimesh.creation.icosphere(subdivisions=1)
        mesh.apply_translation((1e8, 0, 0))
        with pytest.raises(TextonError, match="too far from the origin") as points_error:
            surface_noise(T1, mesh.vertices, mesh.vertices, 0.01, device=device)
        with pytest.raises(TextonError, match="too far from the origin") as render_error:
            render_mesh(mesh, T1, (8, 8), texel_size=0.01, device=device)
        tail = str(points_error.value).split(": ", 1)[1]
        assert str(render_error.value).endswith(tail)  # the same limit and advice
        with pytest.raises(TextonError, match="too far from the origin"):
            texture_mesh(mesh, T1, 0.01, device=device)

    @pytest.mark.parametrize("texel", [1e-300, 1e-12])
    def test_absurd_texel_sizes_are_refused(self, texel, device):
        mesh = trimesh.creation.icosphere(subdivisions=1)
        # 1e-300 is past float32 (its reciprocal overflows): refused as such, before the mesh is looked at
        match = "texel_size must be between" if texel < 1e-38 else "too far from the origin for this texel_size"
        with pytest.raises(TextonError, match=match):
            render_mesh(mesh, T1, (8, 8), texel_size=texel, device=device)


# --------------------------------------------------------------------------- #
# 12. Up axes, views, vertex spacing                                          #
# --------------------------------------------------------------------------- #
class TestUpAxis:
    @pytest.mark.parametrize("up", ["x", "y", "z", (1.0, 2.0, -0.5)])
    def test_up_rotation_is_a_rotation_taking_z_to_up(self, up):
        from warp_texton.surface.frames import up_rotation, up_vector

        r = up_rotation(up)
        np.testing.assert_allclose(r.T @ r, np.eye(3), atol=1e-12)
        assert np.linalg.det(r) == pytest.approx(1.0)
        np.testing.assert_allclose(r[:, 2], up_vector(up), atol=1e-12)

    def test_y_up_is_gltf(self):
        from warp_texton.surface.frames import frame_rule, up_rotation

        # glTF: +Y up, +Z towards the front viewer, +X right; the Z-up frame's front is −Y
        r = up_rotation("y")
        np.testing.assert_array_equal(r @ [0, -1.0, 0], [0, 0, 1.0])
        np.testing.assert_array_equal(r @ [1.0, 0, 0], [1.0, 0, 0])
        a, b = frame_rule("y")
        np.testing.assert_array_equal(a, [0, 1.0, 0])
        np.testing.assert_array_equal(b, [1.0, 0, 0])
        # the default side of the x axis is y (x itself would be parallel to up)
        np.testing.assert_array_equal(frame_rule("x")[1], [0, 1.0, 0])

    def test_orbit_direction(self):
        from warp_texton.surface.render import orbit_direction

        np.testing.assert_allclose(orbit_direction((-90, 0)), [0, -1, 0], atol=1e-12)  # the front
        np.testing.assert_allclose(orbit_direction((0, 90 - 1e-9)), [0, 0, 1], atol=1e-9)
        np.testing.assert_allclose(orbit_direction((-90, 0), up="y"), [0, 0, 1], atol=1e-12)
        for bad in ((0, 90), (0, float("nan")), (1, 2, 3), "ab"):
            with pytest.raises(TextonError, match="orbit"):
                orbit_direction(bad)

    @pytest.mark.parametrize("up", ["y", "x"])
    def test_a_tall_box_renders_upright_for_its_up_axis(self, up, device):
        """A box 3 units tall along the up axis: its silhouette must be taller than wide
        when rendered with that up (sideways with the Z default)."""
        t = small_texton()
        extents = {"y": (1.0, 3.0, 1.0), "x": (3.0, 1.0, 1.0)}[up]
        box = trimesh.creation.box(extents=extents)
        for axis, tall in ((up, True), ("z", False)):
            img = render_mesh(box, t, (64, 64), up=axis, orbit=(-60, 10), device=device)
            rows, cols = np.nonzero(np.any(img != np.float32(0.92), axis=2))
            height, width = np.ptp(rows), np.ptp(cols)
            assert (height > 1.5 * width) == tall, (axis, height, width)

    def test_real_meshes_upright_by_default(self, device):
        """pyvista's airplane (and the Stanford bunny shipped by pymeshfix): Z-up PLY files. Upright: the
        up axis projects upwards in the image (the camera's up is the world's), and the mesh's
        lowest parts (along up) land in the lowest rows of the render."""
        for name, path in (("airplane", PYVISTA_EXAMPLES and PYVISTA_EXAMPLES / "airplane.ply"),
                           ("bunny", BUNNY)):
            if path is None or not Path(path).is_file():
                pytest.skip(f"{name} mesh not installed (pip install --no-deps pyvista pymeshfix)")
            mesh = trimesh.load(path, force="mesh", process=False)
            cam = Camera.framing(mesh)
            np.testing.assert_array_equal(cam.up, [0, 0, 1.0])
            t = small_texton()
            img = render_mesh(mesh, t, (64, 64), device=device)
            hit = np.any(img != np.float32(0.92), axis=2)
            rows = np.nonzero(hit)[0]
            # the bottom slab of the mesh (lowest 10 % along z) projects below its top slab
            v = np.asarray(mesh.vertices)
            z = v[:, 2]
            low, high = v[z < np.percentile(z, 10)].mean(axis=0), v[z > np.percentile(z, 90)].mean(axis=0)
            eye, target = np.array(cam.position), np.array(cam.target)
            f = (target - eye) / np.linalg.norm(target - eye)
            right = np.cross(f, cam.up)
            right /= np.linalg.norm(right)
            up_img = np.cross(right, f)
            assert (low - eye) @ up_img / ((low - eye) @ f) < (high - eye) @ up_img / ((high - eye) @ f), name
            assert rows.size > 100, name


class TestVertexSpacing:
    def test_spacing_and_the_warning(self, device):
        from warp_texton.surface.mesh import vertex_spacing

        mesh = plane_mesh(n=11, size=1.0)  # edges 0.1 and diagonals 0.141: median 0.1
        assert vertex_spacing(mesh, 0.01) == pytest.approx(10.0)
        with pytest.warns(UserWarning, match=r"^floor\.ply: vertices are 10 texels apart .*--bake RES\).*"
                                             r"--max-edge 1\)"):
            texture_mesh(mesh, T1, 0.01, name="floor.ply", device=device)
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("error")
            texture_mesh(mesh, T1, 0.01, max_edge=1.0, device=device)  # subdivided: no warning
            texture_mesh(mesh, T1, 0.2, device=device)  # edges of half a texel


# the first call of a fresh process: Warp starts quietly before any launch
FIRST_CALLS = {
    "surface_noise": "wt.surface_noise(t, p, p, 0.01, device='cpu')",
    "render_mesh": "wt.render_mesh(trimesh.creation.icosphere(subdivisions=1), t, (8, 8), device='cpu')",
    "texture_mesh": "wt.texture_mesh(trimesh.creation.icosphere(subdivisions=1), t, 0.01, device='cpu', warn=False)",
}


@pytest.mark.slow
@pytest.mark.parametrize("call", sorted(FIRST_CALLS))
def test_first_call_prints_nothing(call):
    """Warp's greeting ("Warp 1.x initialized") and its module-load lines reach neither
    stdout nor stderr when a surface entry point is a process's first Warp call."""
    code = ("import numpy as np, trimesh, warp_texton as wt\n"
            "t = wt.Texton(np.random.default_rng(0).standard_normal((8, 8, 1)) / 8, [0.5])\n"
            "p = np.random.default_rng(1).normal(size=(5, 3))\n"
            f"{FIRST_CALLS[call]}\nprint('done')")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout == "done\n"
    assert done.stderr == ""


class TestWorkBudget:
    """Surface noise prices its points' walks (surface.surface_visits) before computing."""

    def test_refused_before_any_launch(self, monkeypatch):
        import warp_texton.surface.points as S
        from warp_texton.core.limits import set_work_budget, work_log

        t = small_texton()
        rng = np.random.default_rng(0)
        pts, nrm = rng.uniform(-5, 5, (2000, 3)), rng.normal(size=(2000, 3))
        with work_log() as log:
            surface_noise(t, pts[:10], nrm[:10], 0.1, mni=50, device="cpu")
        per_point = log[-1][1] / 10
        launched = []
        monkeypatch.setattr(S, "evaluate_points", lambda *a, **k: launched.append(a))
        assert per_point == pytest.approx(S.surface_visits(S.surface_setup(t, 50)))
        set_work_budget(per_point * 1999)
        try:
            with pytest.raises(TextonError, match=r"surface noise at 2000 points at MNI 50 .* use fewer points "
                                                  r"or a lower mni") as info:
                surface_noise(t, pts, nrm, 0.1, mni=50, device="cpu")
        finally:
            set_work_budget(None)
        assert info.value.param == "mni" and not launched

    def test_dense_sets_priced_by_blocks(self, monkeypatch):
        """A dense set is priced by the blocks it is sorted into, far below lone walks: the
        estimate the call checks is block_visits of its sorted points, and a torus ten times
        as dense (10**7 points) fits the default budget at MNI 60, which lone walks do not."""
        import warp_texton.surface.points as S
        from warp_texton.core.limits import DEFAULT_WORK_BUDGET, set_work_budget, work_log

        t = Texton(np.random.default_rng(0).standard_normal((64, 64, 3)) / 64, [0.5, 0.5, 0.5])
        torus = trimesh.creation.torus(1.0, 0.35, major_sections=200, minor_sections=200)
        pts, nrm = np.asarray(torus.vertices), np.asarray(torus.vertex_normals)
        texel = 0.02  # about the density of 10**6 vertices at texel 0.004, in points per texel²
        setup = S.surface_setup(t, 60)
        plan = S.plan_points(setup, pts / texel, S.unit_rows(nrm, "n").astype(np.float32))
        assert plan.method == "blocks"
        assert plan.operations == pytest.approx(S.block_visits(setup, plan.blocked))
        per_point = plan.operations / len(pts)
        assert per_point * 10**7 < DEFAULT_WORK_BUDGET < S.surface_visits(setup) * 10**7
        # the estimate before the points exist (renders, bakes) agrees with the sorted one within 3x
        area = 4 * np.pi**2 * 1.0 * 0.35 / texel**2
        assert 1 / 3 < S.density_visits(setup, len(pts) / area) / per_point < 3
        with work_log() as log:
            surface_noise(t, pts, nrm, texel, device="cpu")
        assert log[-1][1] == pytest.approx(plan.operations)
        # just over the budget: refused once sorted, before any evaluation
        launched = []
        monkeypatch.setattr(S, "evaluate_points", lambda *a, **k: launched.append(a) or np.zeros((len(a[2]), 3)))
        set_work_budget(plan.operations * 0.99)
        try:
            with pytest.raises(TextonError, match=r"surface noise at 40000 points at MNI 60 .* over the work budget"):
                surface_noise(t, pts, nrm, texel, device="cpu")
            set_work_budget(plan.operations * 1.01)
            surface_noise(t, pts, nrm, texel, device="cpu")
        finally:
            set_work_budget(None)
        assert len(launched) == 1

    def test_bomb_refused_before_sorting(self, monkeypatch):
        """Points that no path could evaluate within the budget are refused before they are
        prepared or sorted."""
        import warp_texton.surface.points as S
        from warp_texton.core.limits import DEFAULT_WORK_BUDGET

        work = []
        monkeypatch.setattr(S, "sort_into_blocks", lambda *a, **k: work.append("sort"))
        monkeypatch.setattr(S, "_prepare_points", lambda *a, **k: work.append("prepare"))
        pts = np.random.default_rng(0).uniform(-10, 10, (1_000_000, 3))
        with pytest.raises(TextonError, match=r"surface noise at 1000000 points at MNI 50000 .* over the work budget"):
            surface_noise(small_texton(), pts, pts, 0.1, mni=50_000, device="cpu")
        assert not work
        assert 10**6 * S.floor_visits(S.surface_setup(small_texton(), 50_000)) > DEFAULT_WORK_BUDGET

    def test_work_grows_with_mni(self):
        import warp_texton.surface.points as S

        t = small_texton()
        a, b = (S.surface_visits(S.surface_setup(t, m)) for m in (50, 500))
        assert b == pytest.approx(10 * a)


class TestRenderWork:
    """render_mesh prices its ray cast and the noise at its hits by the path the hits take."""

    def test_priced_by_path(self):
        import warp_texton.surface.render as R
        from warp_texton.core.limits import DEFAULT_WORK_BUDGET, work_log
        from warp_texton.surface.points import floor_visits, surface_setup, surface_visits

        sphere = trimesh.creation.icosphere(subdivisions=4)
        t = small_texton()
        with work_log() as log:
            render_mesh(sphere, t, (256, 256), texel_size=1 / 128, device="cpu")
        (what, ops), = log
        assert what == "a 256x256 render at MNI 60"
        setup = surface_setup(t, 60.0)
        # the hits go to blocks: far below lone walks, and a 16x larger render fits the default budget
        assert ops < 0.25 * 256 * 256 * (R.CAST_OPS + surface_visits(setup))
        assert ops * 256 < DEFAULT_WORK_BUDGET
        # and the early estimate of a 4096x4096 render passes
        assert 4096**2 * (R.CAST_OPS + floor_visits(setup)) < DEFAULT_WORK_BUDGET

    @pytest.mark.parametrize("shape, mni", [((2048, 2048), 200_000), ((8192, 8192), 5000)])
    def test_absurd_refused_before_the_cast(self, monkeypatch, shape, mni):
        import warp_texton.surface.render as R

        cast = []
        monkeypatch.setattr(R, "_cast_box", lambda *a, **k: cast.append(a))
        with pytest.raises(TextonError, match=rf"a {shape[1]}x{shape[0]} render at MNI {mni} needs about .* over "
                                              r"the work budget .*use a smaller shape or a lower mni") as info:
            render_mesh(trimesh.creation.icosphere(subdivisions=2), small_texton(), shape, mni=mni, device="cpu")
        assert not cast and info.value.param == "mni"
