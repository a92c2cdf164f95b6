"""Tests of bnerr.ldbn.swaps: the kernel, the energy against a double loop, the matchings, and
both descents (each a permutation or a choice that lowers the energy)."""

from __future__ import annotations

import itertools

import pytest
import torch

from bnerr.errors import ShapeError
from bnerr.ldbn.swaps import (
    _matching,
    energy,
    energy_kernel,
    flip_descent,
    joint_swap_descent,
    swap_descent,
)


def _slow_energy(x: torch.Tensor, kernel: torch.Tensor) -> float:
    f, t = kernel.shape[0], kernel.shape[1]
    coords = list(itertools.product(range(f), range(t), range(t)))
    total = 0.0
    for p, (a, b, c) in enumerate(coords):
        for q, (d, e, g) in enumerate(coords):
            if p != q:
                w = float(kernel[(a - d) % f, (b - e) % t, (c - g) % t])
                total += w * float(x[p].double() @ x[q].double())
    return total


def test_kernel_is_zero_at_the_origin_symmetric_and_toroidal():
    k = energy_kernel(8, 4, sigma=2.1, sigma_t=1.9)
    assert k.shape == (4, 8, 8) and float(k[0, 0, 0]) == 0.0
    assert torch.equal(k[0, 1:, :], k[0, 1:, :].flip(0).roll(0, 0)[torch.arange(6, -1, -1)])
    assert float(k[0, 0, 1]) == pytest.approx(torch.exp(torch.tensor(-1 / 2.1**2)).item())
    assert (
        float(k[1, 0, 0])
        == float(k[3, 0, 0])
        == pytest.approx(torch.exp(torch.tensor(-1 / 1.9**2)).item())
    )
    assert float(k[1, 0, 1]) == 0.0  # separable 2D x 1D: no cross terms
    auto = energy_kernel(8, sigma=0.75, autocorrelation=True)
    assert float(auto[0, 0, 1]) == pytest.approx(torch.exp(torch.tensor(-1 / 2.25)).item())


@pytest.mark.parametrize("frames", [1, 2])
def test_energy_matches_the_double_loop(frames):
    k = energy_kernel(4, frames)
    x = torch.randn(16 * frames, 3, generator=torch.Generator().manual_seed(frames))
    assert energy(x, k) == pytest.approx(_slow_energy(x, k), rel=1e-9, abs=1e-9)
    with pytest.raises(ShapeError):
        energy(x[:5], k)


@pytest.mark.parametrize("shape", [(1, 8, 8), (4, 4, 4), (1, 6, 6), (1, 5, 5)])
def test_matchings_are_disjoint_pairs(shape):
    gen = torch.Generator().manual_seed(0)
    n = shape[0] * shape[1] * shape[2]
    for _ in range(20):
        a, b = _matching(shape, gen)
        both = torch.cat([a, b])
        assert both.unique().numel() == both.numel() == n - n % 2


def test_swap_descent_permutes_and_lowers_the_energy():
    gen = torch.Generator().manual_seed(1)
    k = energy_kernel(16)
    x = torch.randn(256, 4, generator=gen)
    perm = swap_descent(x, k, 60, gen)
    assert torch.equal(perm.sort().values, torch.arange(256))
    before, after = energy(x, k), energy(x[perm], k)
    # the descent moves the energy far below random arrangements' (measured: 7.7 of their
    # standard deviations below the start after 60 iterations)
    shuffled = [energy(x[torch.randperm(256, generator=gen)], k) for _ in range(8)]
    spread = torch.tensor(shuffled).std().item()
    assert after < before - 5 * spread


def test_swap_descent_is_deterministic():
    k = energy_kernel(8)
    x = torch.randn(64, 3, generator=torch.Generator().manual_seed(2))
    a = swap_descent(x, k, 20, torch.Generator().manual_seed(3))
    b = swap_descent(x, k, 20, torch.Generator().manual_seed(3))
    assert torch.equal(a, b)


def test_flip_descent_chooses_and_lowers_the_energy():
    gen = torch.Generator().manual_seed(4)
    k = energy_kernel(16)
    options = torch.randn(2, 256, 4, generator=gen)
    choice = flip_descent(options, k, 60, gen)
    assert set(choice.unique().tolist()) <= {0, 1}
    picked = options[choice, torch.arange(256)]
    randoms = [
        energy(options[torch.randint(0, 2, (256,), generator=gen), torch.arange(256)], k)
        for _ in range(8)
    ]
    spread = torch.tensor(randoms).std().item()
    assert energy(picked, k) < min(randoms) - 5 * spread
    with pytest.raises(ShapeError):
        flip_descent(options[0], k, 5, gen)


def _texel_features(seed: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Keys whose features depend on the texel: key row r in texel p gives a[r] + b[p] * a[r]."""
    gen = torch.Generator().manual_seed(seed)
    return torch.randn(256, 4, generator=gen), torch.rand(256, 1, generator=gen)


def test_joint_swap_descent_permutes_and_lowers_the_texel_dependent_energy():
    a, b = _texel_features(5)

    def evaluate(texels, rows):
        return a[rows] * (1 + b[texels])

    gen = torch.Generator().manual_seed(6)
    k = energy_kernel(16)
    perm = joint_swap_descent(evaluate, k, 60, gen)
    assert torch.equal(perm.sort().values, torch.arange(256))
    every = torch.arange(256)
    after = energy(evaluate(every, perm), k)
    shuffled = [energy(evaluate(every, torch.randperm(256, generator=gen)), k) for _ in range(8)]
    spread = torch.tensor(shuffled).std().item()
    assert after < min(shuffled) - 5 * spread
    again = joint_swap_descent(evaluate, k, 60, torch.Generator().manual_seed(6))
    assert torch.equal(perm, again)


def test_joint_swap_descent_is_swap_descent_when_features_ignore_the_texel():
    x = torch.randn(64, 3, generator=torch.Generator().manual_seed(7))
    k = energy_kernel(8)
    plain = swap_descent(x, k, 20, torch.Generator().manual_seed(9))
    joint = joint_swap_descent(lambda t, r: x[r], k, 20, torch.Generator().manual_seed(9))
    assert torch.equal(plain, joint)


def test_joint_swap_descent_with_a_self_weight_lowers_raw_and_cross_terms_together():
    # Features whose size depends on the texel: lowering the cross terms alone may grow the raw
    # part; with w(0) = 1 the descent lowers the sum, below what the cross terms alone reach.
    a, b = _texel_features(11)

    def evaluate(texels, rows):
        return a[rows] * (1 + 2 * b[texels].abs())

    k = energy_kernel(16, sigma=2.0, autocorrelation=True)
    every = torch.arange(256)

    def total(perm):
        x = evaluate(every, perm)
        return float(x.double().square().sum()) + energy(x, k)

    cross = joint_swap_descent(evaluate, k, 60, torch.Generator().manual_seed(12))
    both = joint_swap_descent(evaluate, k, 60, torch.Generator().manual_seed(12), self_weight=1.0)
    assert torch.equal(both.sort().values, every)
    assert total(both) < total(every) and total(both) < total(cross)


def test_a_measured_kernel_is_wrapped_symmetrized_and_checked():
    from bnerr.errors import ValueRangeError
    from bnerr.ldbn.swaps import measured_kernel

    d = torch.arange(-3, 4, dtype=torch.float64)
    auto = torch.exp(-(d[:, None] ** 2 + d[None, :] ** 2) / (4 * 1.2**2))
    w = measured_kernel(2 * auto, 16)  # scaled to 1 at the centre
    assert torch.allclose(w, energy_kernel(16, sigma=1.2, autocorrelation=True) * (w > 0))
    assert float(w[0, 0, 0]) == 0.0 and float(w[0, 0, 4]) == 0.0  # beyond the window: none
    skew = auto.clone()
    skew[3, 4] += 0.5
    ws = measured_kernel(skew, 16)
    assert torch.equal(ws[0, 0, 1], ws[0, 0, 15])  # w(d) = w(-d)
    frames = measured_kernel(auto, 8, frames=4)
    assert frames.shape == (4, 8, 8) and float(frames[1, 0, 0]) > 0
    with pytest.raises(ShapeError, match="K odd"):
        measured_kernel(torch.ones(4, 4), 8)
    with pytest.raises(ValueRangeError, match="positive centre"):
        measured_kernel(-auto, 8)
