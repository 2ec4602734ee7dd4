"""Outputs recorded before refactors, to prove that moves keep every value bit-identical.

Each case is a small call of the public API that exercises one kernel path
(grid splat, general splat, gather, points, the filters, the plane, surface
points, the mesh renderer, vertex colours, mixed noise). ``python
tests/make_reference.py`` records them into ``tests/data/reference_outputs.npz``
on the CPU; ``tests/test_reference.py`` recomputes them and compares bit for
bit. Re-record only when an issue asks for a change of values, and say so in
the commit.
"""

from __future__ import annotations

import numpy as np

import warp_texton as wt

DEVICE = "cpu"


def _texton(shape=(10, 12), channels=3, order=1, seed=0, mean=0.5) -> wt.Texton:
    rng = np.random.default_rng(seed)
    coeffs = 0.15 * rng.standard_normal(shape + (channels,)) / np.sqrt(shape[0] * shape[1]) + 0.01
    return wt.Texton(coeffs, [mean] * channels, order=order)


def _points(n=64, spread=200.0, seed=1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    pts = rng.uniform(-spread, spread, (n, 2))
    pts[:4] += [[1e6, -2e6], [-3.5e6, 7.25e5], [1e7, 1e7], [-123456.75, 9876.5]]
    return pts


def _mesh():
    import trimesh

    return trimesh.creation.icosphere(subdivisions=2, radius=1.0)


def _surface_points(n=48, seed=2):
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    p /= np.linalg.norm(p, axis=1)[:, None]
    return p, p.copy()


def case_grid_splat():
    return wt.synthesize(_texton(), (40, 56), mni=30.0, seed=7, offset=(3.25, -9.5), device=DEVICE)


def case_general_splat_order3():
    return wt.synthesize(_texton(order=3), (36, 44), mni=20.0, seed=3, scale=0.7, rotation=30.0, offset=(-11.0, 4.5),
                         device=DEVICE)


def case_order0_grey():
    return wt.synthesize(_texton(channels=1, order=0), (32, 32), mni=10.0, seed=5, device=DEVICE)


def case_order5_scaled():
    return wt.synthesize(_texton(order=5, shape=(8, 8)), (30, 34), mni=30.0, seed=9, scale=1.7, device=DEVICE)


def case_gather_cpu():
    return wt.synthesize(_texton(), (30, 38), mni=30.0, seed=11, rotation=10.0, offset=(5.0, 6.0), device=DEVICE,
                         method="gather")


def case_period_gaussian_counts():
    return wt.synthesize(_texton(), (48, 40), mni=30.0, seed=1, period=(40.0, 24.0), poisson="gaussian", device=DEVICE)


def case_far_offset():
    return wt.synthesize(_texton(channels=1), (24, 24), mni=30.0, seed=2, offset=(1.0e6, -3.0e6), device=DEVICE)


def case_evaluate_points():
    return wt.evaluate(_texton(), _points(), mni=30.0, seed=4, device=DEVICE)


def case_evaluate_period_order3():
    return wt.evaluate(_texton(order=3, channels=1), _points(seed=5), mni=15.0, seed=6, device=DEVICE, period=(50.0, 70.0))


def case_filter_mip():
    return wt.synthesize(_texton(), (24, 28), mni=30.0, seed=8, scale=0.15, rotation=20.0, device=DEVICE, filter="mip")


def case_filter_anisotropic_jacobian():
    J = np.array([[6.0, 1.0], [-0.5, 0.8]])
    return wt.synthesize(_texton(order=3), (20, 26), mni=30.0, seed=8, device=DEVICE, filter="anisotropic", jacobian=J)


def case_filter_supersample():
    return wt.synthesize(_texton(channels=1), (12, 14), mni=30.0, seed=8, scale=0.4, device=DEVICE,
                         filter=wt.FilterOptions("supersample", supersample=3))


def case_plane_anisotropic():
    return wt.render_plane(_texton(), (40, 48), height=1.0, tilt=75.0, fov=40.0, texel_size=0.004, mni=30.0, seed=3, filter="anisotropic", device=DEVICE)


def case_plane_mip_fade0():
    return wt.render_plane(_texton(channels=1), (32, 32), height=1.0, tilt=70.0, fov=45.0, texel_size=0.01, mni=30.0, seed=3,
                           filter=wt.FilterOptions("mip", fade_energy=0.0), device=DEVICE)


def case_plane_none():
    return wt.render_plane(_texton(), (24, 24), height=1.0, tilt=60.0, fov=40.0, texel_size=0.01, mni=30.0, seed=3, filter="none", device=DEVICE)


def case_plane_supersample():
    return wt.render_plane(_texton(channels=1), (12, 16), height=1.0, tilt=70.0, fov=40.0, texel_size=0.01, mni=30.0, seed=3,
                           filter=wt.FilterOptions("supersample", supersample=2), device=DEVICE)


def case_surface_points():
    p, n = _surface_points()
    return wt.surface_noise(_texton(), p * 3.0, n, 0.05, mni=60.0, seed=4, device=DEVICE)


def case_surface_tangents_order3():
    p, n = _surface_points(seed=3)
    t = np.cross(n, [0.3, 0.4, 0.5])
    return wt.surface_noise(_texton(order=3, channels=1), p, n, 0.04, mni=40.0, seed=5, tangents=t, device=DEVICE)


def case_render_mesh():
    return wt.render_mesh(_mesh(), _texton(), (32, 40), seed=1, device=DEVICE)


def case_texture_mesh():
    mesh = wt.texture_mesh(_mesh(), _texton(), 0.05, mni=60.0, seed=2, max_edge=8.0, device=DEVICE, warn=False)
    return np.asarray(mesh.visual.vertex_colors)


def case_mixed_strips():
    ts = [_texton(seed=s, mean=0.2 + 0.3 * s) for s in range(3)]
    return wt.synthesize_mixed(ts, "strips", (24, 60), mni=30.0, seed=4, device=DEVICE)


def case_mixed_map():
    ts = [_texton(seed=s, channels=1, mean=0.3 + 0.4 * s) for s in range(2)]
    rho = np.linspace(0.0, 1.0, 30 * 36).reshape(30, 36)
    return wt.synthesize_mixed(ts, rho, (30, 36), mni=30.0, seed=5, scale=0.8, device=DEVICE)


def _torus_vertices():
    import trimesh

    mesh = trimesh.creation.torus(major_radius=1.0, minor_radius=0.35, major_sections=96, minor_sections=48)
    return np.asarray(mesh.vertices), np.asarray(mesh.vertex_normals)


def _block_path(points, normals, simd, texel_size=0.05, **kw):
    """surface_noise through the block path (gather_blocks) with the SIMD loops on or off.

    At texel_size 0.05 the torus puts about ten points in each cluster cell (the
    cluster loops); the sparse cases, at 0.01, leave single points (the walk fallback)."""
    from warp_texton.surface import blocks as B

    before = B.SIMD
    B.SIMD = simd
    try:
        return wt.surface_noise(_texton(), points, normals, texel_size, mni=60.0, seed=7, device=DEVICE, method="blocks", **kw)
    finally:
        B.SIMD = before


def case_blocks_dense_simd():
    p, n = _torus_vertices()
    return _block_path(p, n, True)


def case_blocks_dense_scalar():
    p, n = _torus_vertices()
    return _block_path(p, n, False)


def case_blocks_sparse_simd():
    p, n = _surface_points(n=6000, seed=8)
    return _block_path(p * 40.0 + [2.5e4, -1.5e4, 300.0], n, True, texel_size=0.01)


def case_blocks_sparse_scalar():
    p, n = _surface_points(n=6000, seed=8)
    return _block_path(p * 40.0 + [2.5e4, -1.5e4, 300.0], n, False, texel_size=0.01)


def case_blocks_dense_tangents():
    p, n = _torus_vertices()
    return _block_path(p, n, True, tangents=np.cross(n, [0.3, 0.4, 0.5]))


CASES = {name[len("case_"):]: fn for name, fn in sorted(globals().items()) if name.startswith("case_")}
