"""Tests of bnerr.ldbn.integrands: the test integrands' values, the estimates, and the features
(standardized, principal components) that keep the distances between error vectors."""

from __future__ import annotations

import pytest
import torch

from bnerr.errors import ShapeError, ValueRangeError
from bnerr.ldbn.integrands import error_features, estimates, feature_basis, make_integrands


def test_integrands_are_half_edges_half_bumps_and_deterministic():
    tests = make_integrands(10, seed=3)
    assert len(tests) == 10
    points = torch.rand(50, 2, generator=torch.Generator().manual_seed(0))
    values = tests(points)
    assert values.shape == (50, 10)
    assert set(values[:, :5].unique().tolist()) <= {0.0, 1.0}
    assert bool(((values[:, 5:] > 0) & (values[:, 5:] <= 1)).all())
    assert torch.equal(values, make_integrands(10, seed=3)(points))
    assert not torch.equal(values, make_integrands(10, seed=4)(points))


def test_edges_pass_through_a_point_of_the_square_and_bumps_peak_at_their_centre():
    tests = make_integrands(400, seed=1)
    # the edge's offset n.c lies within the projections of the square's corners
    corners = torch.tensor([[0.0, 0.0], [0.0, 1.0], [1.0, 0.0], [1.0, 1.0]])
    proj = corners @ tests.normal.T
    assert bool(((tests.offset >= proj.min(0).values) & (tests.offset <= proj.max(0).values)).all())
    at_centre = tests(tests.centre)[torch.arange(200), 200 + torch.arange(200)]
    assert torch.allclose(at_centre, torch.ones(200))


def test_estimates_are_the_sample_means():
    tests = make_integrands(6)
    points = torch.rand(7, 5, 2, generator=torch.Generator().manual_seed(2))
    want = torch.stack([tests(p).mean(0) for p in points])
    assert torch.allclose(estimates(points, tests), want)


def test_features_keep_the_distances_of_the_standardized_vectors():
    values = torch.rand(40, 12, generator=torch.Generator().manual_seed(5), dtype=torch.float64)
    feats = error_features(values, components=12).double()
    z = (values - values.mean(0)) / values.std(0)
    assert torch.allclose(torch.cdist(feats, feats), torch.cdist(z, z), atol=1e-4)
    fewer = error_features(values, components=3)
    assert fewer.shape == (40, 3)
    # the leading components carry the most variance, in order
    var = fewer.var(0)
    assert bool((var[:-1] >= var[1:]).all())
    assert torch.equal(fewer, error_features(values, components=3))


def test_bad_input_is_refused():
    with pytest.raises(ValueRangeError):
        make_integrands(1)
    with pytest.raises(ShapeError):
        estimates(torch.rand(3, 2), make_integrands(4))
    with pytest.raises(ShapeError, match="at least 2 keys"):
        error_features(torch.rand(1, 4))


def test_4d_tests_are_edges_in_the_pair_moving_a_little_with_the_jitter():
    tests = make_integrands(40, 5, dims=4)
    assert tests.dims == 4 and tests.normal.shape == (20, 4) and tests.centre.shape == (20, 4)
    assert torch.allclose(tests.normal[:, 2:].norm(dim=1), torch.ones(20), atol=1e-6)
    coupling = tests.normal[:, :2].norm(dim=1)
    assert float(coupling.max()) <= 0.5 and float(coupling.min()) >= 0
    points = torch.rand(3, 7, 4, generator=torch.Generator().manual_seed(6))
    values = tests(points)
    side = (points @ tests.normal.T > tests.offset).float()
    assert torch.equal(values[..., :20], side)
    # bumps: width s in the pair's square, 1 in the jitter's; 1 at the centre
    at_centre = tests(tests.centre)[torch.arange(20), 20 + torch.arange(20)]
    assert torch.allclose(at_centre, torch.ones(20), atol=1e-5)
    moved = tests.centre + torch.tensor([0.5, 0.0, 0.0, 0.0])
    expected = torch.exp(torch.tensor(-0.125)).expand(20)
    assert torch.allclose(
        tests(moved)[torch.arange(20), 20 + torch.arange(20)], expected, atol=1e-5
    )
    assert torch.allclose(estimates(points, tests), values.mean(1))
    with pytest.raises(ShapeError, match="4 coordinates"):
        estimates(points[..., :2], tests)
    with pytest.raises(ValueRangeError, match="2 or 4"):
        make_integrands(8, 0, dims=3)


def test_a_fixed_basis_projects_other_vectors_as_it_projects_its_own():
    gen = torch.Generator().manual_seed(8)
    values = torch.rand(50, 12, generator=gen)
    basis = feature_basis(values, 5)
    assert torch.equal(basis.project(values), error_features(values, 5))
    other = torch.rand(7, 12, generator=gen)
    both = basis.project(torch.cat([values[:3], other]))
    assert torch.equal(both[:3], basis.project(values[:3]))
    expected = ((other.double() - basis.mean) / basis.scale) @ basis.axes.T
    assert torch.allclose(both[3:].double(), expected, atol=1e-5)
