"""Tests for bnerr.hashing: tensor, in-place and host forms agree with a plain-Python twin."""

import torch
from hypothesis import given
from hypothesis import strategies as st

from bnerr.hashing import (
    MASK32,
    lowbias32_,
    lowbias32_host,
    mix32_45d9f3b,
    signed32,
    srl32,
)
from bnerr.hashing import lowbias32 as lowbias32_tensor
from tests._twins import M32, lowbias32

words = st.integers(min_value=0, max_value=M32)


@given(st.lists(words, min_size=1, max_size=64))
def test_every_form_equals_the_twin(values):
    want = [lowbias32(v) for v in values]
    x = torch.tensor([signed32(v) for v in values], dtype=torch.int32)
    assert [v & MASK32 for v in lowbias32_tensor(x).tolist()] == want
    assert [lowbias32_host(v) for v in values] == want
    y = x.clone()
    assert lowbias32_(y) is y and torch.equal(y, lowbias32_tensor(x))


def test_lowbias32_is_a_bijection_on_a_range_of_words():
    x = torch.arange(-(1 << 16), 1 << 16, dtype=torch.int32)
    assert torch.unique(lowbias32_tensor(x)).numel() == x.numel()


@given(words, st.integers(min_value=1, max_value=31))
def test_srl32_is_a_logical_shift(value, k):
    assert srl32(torch.tensor([signed32(value)], dtype=torch.int32), k).item() == value >> k


def test_mix32_45d9f3b_equals_its_listing():
    def twin(x: int) -> int:
        x = (((x >> 16) ^ x) * 0x45D9F3B) & M32
        x = (((x >> 16) ^ x) * 0x45D9F3B) & M32
        return (x >> 16) ^ x

    values = [0, 1, 12345, M32, 0x80000000]
    got = mix32_45d9f3b(torch.tensor(values, dtype=torch.int64)).tolist()
    assert got == [twin(v) for v in values]
