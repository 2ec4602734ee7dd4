"""The structure benchmarks' own pieces: the synthetic lattices (benchmarks/synthetic_lattices.py), the
lattice metrics (benchmarks/structure.py) and the selection rule of the photograph sets
(benchmarks/structure_sets.py)."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.structure import lattice_kept, lattice_lags, residual_repetition
from benchmarks.structure_sets import classify, prepare
from benchmarks.synthetic_lattices import CASES, lattice_texture, same_lattice


@pytest.mark.parametrize("kind", list(CASES))
def test_a_seamless_synthetic_lattice_tiles_exactly(kind):
    # two periods a side are the one-period image tiled: structure and tile colours wrap
    one, truth = lattice_texture(kind, noise=0.0, weathering=0.0)
    two, _ = lattice_texture(kind, noise=0.0, weathering=0.0, periods=2)
    assert np.array_equal(np.tile(one, (2, 2, 1)), two)
    assert truth.seamless and truth.rank == len(CASES[kind].vectors)


@pytest.mark.parametrize("kind", ["square", "running", "rotated"])
def test_without_colour_variation_the_texture_is_invariant_under_its_lattice(kind):
    u, truth = lattice_texture(kind, noise=0.0, weathering=0.0, variation=0.0)
    for dy, dx in truth.vectors:
        assert np.allclose(np.roll(u, (int(dy), int(dx)), axis=(0, 1)), u, atol=1e-6)


def test_a_crop_is_not_a_period():
    u, truth = lattice_texture("square", seamless=False)
    assert not truth.seamless and u.shape[0] % 32 != 0


def test_same_lattice_takes_any_basis_and_refuses_a_sublattice():
    square = ((32.0, 0.0), (0.0, 32.0))
    assert same_lattice(((0.0, 32.0), (32.0, 32.0)), square)  # another basis
    assert same_lattice(((32.3, 0.2), (-0.1, 31.8)), square)
    assert not same_lattice(((32.0, 64.0), (64.0, -32.0)), square)  # index 5
    assert not same_lattice(((33.0, 0.0), (0.0, 32.0)), square)
    assert same_lattice(((-24.2, 0.0),), ((24.0, 0.0),)) and not same_lattice(((24.0, 0.0),), square)


def test_lattice_lags_are_half_plane_combinations():
    lags = lattice_lags(((32.0, 0.0), (0.0, 32.0)), 100.0)
    assert len(lags) == 12  # (2·2 + 1)² − 1 combinations, one of each ± pair
    assert not any(np.allclose(a, -b) for a in lags for b in lags)
    assert np.allclose(lattice_lags(((24.0, 0.0),), 100.0), [[24, 0], [48, 0], [72, 0]])


def test_lattice_kept_is_one_for_the_example_tiled_and_zero_for_noise():
    u, truth = lattice_texture("running", seed=2)
    tiled = np.tile(u, (2, 2, 1))
    assert lattice_kept(tiled, u, truth.vectors) == pytest.approx(1.0, abs=0.05)
    noise = np.random.default_rng(0).random((256, 256, 3))
    assert abs(lattice_kept(noise, u, truth.vectors)) < 0.05
    assert lattice_kept(tiled, u, None) is None


def test_the_residual_of_a_purely_periodic_pattern_does_not_repeat():
    u, truth = lattice_texture("square", noise=0.0, weathering=0.0, variation=0.0, periods=2)
    v = u + 0.05 * np.random.default_rng(1).normal(size=u.shape)
    assert residual_repetition(v, None, None) > 0.5
    assert residual_repetition(v, None, truth.vectors) < 0.1


def test_residual_repetition_keeps_a_repeating_tile():
    w, truth = lattice_texture("square", seed=3)
    assert residual_repetition(np.tile(w, (2, 2, 1)), w, truth.vectors) > 0.9


@pytest.mark.parametrize("stem, kind", [("e7bricks01", "structured"), ("wall_plate_09_gk_cc", "structured"),
                                        ("dirty04", "stochastic"), ("sand1a", "stochastic"),
                                        ("bricks01_norm", None), ("rocket_wall", None), ("ab_crate_g", None),
                                        ("lamp", None)])
def test_the_selection_rule_reads_names(stem, kind):
    assert classify(stem) == kind


def test_prepare_halves_to_at_most_512_and_makes_rgb():
    u = prepare(np.zeros((1030, 2048), np.float32))
    assert u.shape == (257, 512, 3) and u.dtype == np.float32
