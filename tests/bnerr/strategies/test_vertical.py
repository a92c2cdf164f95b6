"""Tests for bnerr.strategies.vertical: it picks among the oracle's candidates for a lower blurred
error."""

import torch

from bnerr.strategies import (
    make_strategy,
)
from tests.bnerr.strategies._renders import hash_render


def test_vertical_picks_among_the_oracles_candidates_for_a_lower_blurred_error():
    from bnerr.permutation.vertical import blurred_objective

    oracle_seeds: list = []
    vertical_seeds: list = []
    oracle = make_strategy("oracle", 14, 18, seed=2, K=6).frame(3, hash_render(oracle_seeds))
    vertical = make_strategy("vertical", 14, 18, seed=2, K=6).frame(3, hash_render(vertical_seeds))
    assert all(
        torch.equal(a, b) for (a, _), (b, _) in zip(oracle_seeds, vertical_seeds, strict=True)
    )
    frames = [hash_render()(s, None) for s, _ in vertical_seeds]
    colors = torch.stack([f.color for f in frames]).double()
    target = colors.mean(0)
    # one candidate per pixel, every buffer from the same one
    match = (colors == vertical.color.double()[None]).all(1)
    assert bool(match.any(0).all())
    pick = match.double().argmax(0)
    albedo = torch.stack([f.albedo for f in frames])
    assert torch.equal(vertical.albedo, albedo.gather(0, pick[None, None].expand(1, 3, 14, 18))[0])
    got = blurred_objective(vertical.color, target, 2.0)
    assert got <= blurred_objective(oracle.color, target, 2.0)
    assert got < min(blurred_objective(c, target, 2.0) for c in colors)
