"""The vertical bound (bnerr.permutation.vertical): greedy choice of one candidate per pixel against
the exact minimum of an exhaustive search on tiny frames."""

from __future__ import annotations

import pytest
import torch

from bnerr.errors import ShapeError, ValueRangeError
from bnerr.permutation.vertical import blurred_objective, exhaustive_select, vertical_select

pytestmark = pytest.mark.usefixtures("one_thread")


def _case(seed: int, k: int = 2, c: int = 1, h: int = 3, w: int = 4):
    gen = torch.Generator().manual_seed(seed)
    cands = torch.rand(k, c, h, w, generator=gen, dtype=torch.float64)
    return cands, cands.mean(0)


def _j(cands, choice, target, sigma):
    image = cands.gather(0, choice[None, None].expand(1, *cands.shape[1:]))[0]
    return blurred_objective(image, target, sigma)


@pytest.mark.parametrize("sigma", [0.3, 0.7, 2.0])
def test_greedy_lies_between_the_exhaustive_minimum_and_where_it_started(sigma):
    for seed in range(6):
        cands, target = _case(seed)
        best = exhaustive_select(cands, target, sigma=sigma)
        start = torch.zeros(3, 4, dtype=torch.long)
        got = vertical_select(cands, target, sigma=sigma, init=start)
        j_best, j_got = _j(cands, best, target, sigma), _j(cands, got, target, sigma)
        assert j_best <= j_got * (1 + 1e-12) and j_got <= _j(cands, start, target, sigma)
        # the exact minimum is a fixed point: no single pixel's move lowers it
        assert torch.equal(vertical_select(cands, target, sigma=sigma, init=best), best)


def test_with_nearly_independent_pixels_greedy_finds_the_exhaustive_minimum():
    # sigma 0.3: a neighbour weighs exp(-1 / 0.18) = 0.4 % of the centre; one pass per pixel
    # is then the exact minimum
    for seed in range(6):
        cands, target = _case(seed, k=3, h=2, w=4)
        best = exhaustive_select(cands, target, sigma=0.3)
        assert torch.equal(vertical_select(cands, target, sigma=0.3), best)


def test_the_objective_is_the_zero_padded_blur_of_the_error():
    img = torch.zeros(1, 9, 9, dtype=torch.float64)
    img[0, 4, 4] = 1.0  # one unit error in the middle: J = sum of the squared 2-D taps
    taps = torch.exp(-0.5 * (torch.arange(-3, 4, dtype=torch.float64) / 1.0) ** 2)
    taps = taps / taps.sum()
    want = float(taps.square().sum() ** 2)
    assert blurred_objective(img, torch.zeros_like(img), 1.0) == pytest.approx(want, rel=1e-12)


def test_bad_input_raises_typed_errors():
    cands, target = _case(0)
    with pytest.raises(ShapeError):
        vertical_select(cands, target[:, :2])
    with pytest.raises(ValueRangeError):
        vertical_select(cands, target, init=torch.full((3, 4), 5))
    with pytest.raises(ShapeError):
        exhaustive_select(*_case(0, k=4, h=4, w=4))
    with pytest.raises(ValueRangeError):
        vertical_select(cands, target, sigma=-1.0)


def test_same_inputs_give_the_same_choice():
    cands, target = _case(3, k=4, c=3, h=20, w=24)
    a = vertical_select(cands, target, sigma=1.0)
    assert torch.equal(a, vertical_select(cands.clone(), target.clone(), sigma=1.0))
    assert a.dtype == torch.int64 and a.shape == (20, 24)
