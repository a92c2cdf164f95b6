"""Tests of bnerr.tensor_memo: values derived once per tensor, again after an in-place edit."""

from __future__ import annotations

import torch

from bnerr.tensor_memo import TensorMemo


def _counting(memo: TensorMemo[float], tensor: torch.Tensor, tag: object, calls: list) -> float:
    def make() -> float:
        calls.append(tag)
        return float(tensor.sum())

    return memo.get(tensor, tag, make)


def test_a_value_is_made_once_per_tensor_and_tag():
    memo: TensorMemo[float] = TensorMemo()
    a, b, calls = torch.ones(3), torch.ones(3), []
    assert [_counting(memo, a, "x", calls) for _ in range(3)] == [3.0] * 3
    assert _counting(memo, a, "y", calls) == 3.0 and _counting(memo, b, "x", calls) == 3.0
    assert calls == ["x", "y", "x"]  # equal contents, another tensor: made again


def test_an_edit_in_place_is_seen():
    memo: TensorMemo[float] = TensorMemo()
    a, calls = torch.ones(3), []
    assert _counting(memo, a, 0, calls) == 3.0
    a.mul_(2)
    assert _counting(memo, a, 0, calls) == 6.0 and len(calls) == 2


def test_a_freed_tensor_is_not_mistaken_for_a_new_one():
    memo: TensorMemo[float] = TensorMemo()
    calls: list = []
    for k in range(5):  # ids of freed tensors are reused: the weak reference tells them apart
        assert _counting(memo, torch.full((2,), float(k)), 0, calls) == 2.0 * k
    assert len(calls) == 5


def test_inference_tensors_are_made_every_call_and_the_oldest_entry_goes_first():
    memo: TensorMemo[float] = TensorMemo(capacity=2)
    with torch.inference_mode():
        frozen = torch.ones(2)
    calls: list = []
    _counting(memo, frozen, 0, calls), _counting(memo, frozen, 0, calls)
    assert len(calls) == 2 and not memo.entries
    kept = [torch.ones(1) for _ in range(3)]
    for tensor in kept:
        _counting(memo, tensor, 0, calls)
    assert len(memo.entries) == 2
    _counting(memo, kept[0], 0, calls)  # dropped: made again
    _counting(memo, kept[2], 0, calls)  # kept
    assert len(calls) == 2 + 3 + 1
