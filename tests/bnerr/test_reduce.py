"""Tests of bnerr.reduce: a sum whose rounding does not depend on threads or devices."""

import pytest
import torch
from hypothesis import given
from hypothesis import strategies as st

from bnerr.errors import DtypeError
from bnerr.reduce import fixed_sum, fixed_sum_reference


@given(st.integers(0, 70), st.integers(0, 2**31 - 1))
def test_fixed_sum_equals_its_slow_twin_bit_for_bit(n, seed):
    x = torch.randn(n, generator=torch.Generator().manual_seed(seed), dtype=torch.float64) * 1e3
    assert torch.equal(fixed_sum(x), fixed_sum_reference(x))


@pytest.mark.parametrize("dim", [0, 1, 2])
def test_fixed_sum_over_an_axis_matches_its_twin_and_torch(dim):
    x = torch.rand(5, 7, 3, generator=torch.Generator().manual_seed(dim), dtype=torch.float64)
    got = fixed_sum(x, dim=dim)
    assert torch.equal(got, fixed_sum_reference(x, dim=dim))
    torch.testing.assert_close(got, x.sum(dim=dim), rtol=1e-14, atol=0)


def test_fixed_sum_is_the_same_on_one_and_two_threads():
    x = torch.randn(3 * 300 * 300, generator=torch.Generator().manual_seed(0), dtype=torch.float64)
    before = torch.get_num_threads()
    try:
        torch.set_num_threads(1)
        one = fixed_sum(x)
        torch.set_num_threads(2)
        two = fixed_sum(x)
    finally:
        torch.set_num_threads(before)
    assert one.item() == two.item()


def test_empty_sums_to_zero_and_non_tensors_are_refused():
    assert fixed_sum(torch.zeros(0, dtype=torch.float64)).item() == 0.0
    assert fixed_sum(torch.zeros(0, 4), dim=0).shape == (4,)
    with pytest.raises(DtypeError, match="x: expected a torch.Tensor"):
        fixed_sum([1.0, 2.0])
