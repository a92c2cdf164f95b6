"""Shared by the sampler tests: the slow, obviously-correct twin of the white and Owen-Sobol
samplers (Python ints, loops, Burley's listings), adversarial integers, and small samplers and
lanes."""

from __future__ import annotations

import torch
from hypothesis import strategies as st

from bnerr.sequences import (
    BNDSSampler,
)
from tests._twins import lowbias32 as _lowbias32

M32 = 0xFFFFFFFF


ADVERSARIAL = [0, 1, 2**31 - 1, 2**31, 2**32 - 1, 2**32, -1, 2**63 - 1, -(2**63)]


def reverse_bits(x: int) -> int:
    return int(format(x & M32, "032b")[::-1], 2)


def laine_karras(x: int, key: int) -> int:
    x = (x + key) & M32
    for c in (0x6C50B47C, 0xB82F1E52, 0xC7AFE638, 0x8D22F6E6):
        x ^= (x * c) & M32
    return x


def nested_uniform_scramble(x: int, key: int) -> int:
    return reverse_bits(laine_karras(reverse_bits(x), key))


def sobol_directions(dim: int) -> list[int]:
    """Sobol dimension 0 (van der Corput) and 1 (polynomial x + 1: v_k = v_(k-1) ^ v_(k-1) >> 1)."""
    if dim == 0:
        return [1 << (31 - k) for k in range(32)]
    v = [1 << 31]
    while len(v) < 32:
        v.append(v[-1] ^ (v[-1] >> 1))
    return v


def sobol_point(index: int, directions: list[int]) -> int:
    value = 0
    for bit, v in enumerate(directions):
        if (index >> bit) & 1:
            value ^= v
    return value


def twin_white(seed: int, index: int, dim: int) -> float:
    h = _lowbias32(
        _lowbias32(_lowbias32((seed & M32) ^ 0x9E3779B9) ^ (index & M32))
        ^ _lowbias32((dim & M32) ^ 0x85EBCA6B)
    )
    return (h >> 8) / 2**24


def twin_owen_sobol(seed: int, index: int, dim: int) -> float:
    pair, role = dim // 2, dim % 2
    seed_hash = _lowbias32((seed & M32) ^ 0xC2B2AE35)

    def key(r: int) -> int:
        return _lowbias32(seed_hash ^ _lowbias32(((pair * 4 + r) & M32) ^ 0x27D4EB2F))

    shuffled = nested_uniform_scramble(index & M32, key(2))
    return (
        nested_uniform_scramble(sobol_point(shuffled, sobol_directions(role)), key(role)) >> 8
    ) / 2**24


ints64 = st.integers(-(2**63), 2**63 - 1)


def small_bnds(dims: int = 4, size: int = 16, seed0: int = 3) -> BNDSSampler:
    g = torch.Generator().manual_seed(0)
    return BNDSSampler(torch.rand(dims, size, size, generator=g), offset=(5, 9), seed0=seed0)


def lanes(n: int = 4):
    return torch.zeros(n, dtype=torch.int64), torch.arange(n, dtype=torch.int64)
