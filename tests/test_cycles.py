"""Tests of bnerr.sequences.cycles: Cycles 4.2's blue-noise keys and BLUE_NOISE_PURE / FIRST
indexing against a pure-Python twin, the nets the indexing gives, and typed errors."""

from __future__ import annotations

import pytest
import torch
from hypothesis import given
from hypothesis import strategies as st

from bnerr.errors import DtypeError, ValueRangeError
from bnerr.sequences import (
    SAMPLERS,
    CyclesFirstSampler,
    CyclesPureSampler,
    cycles_keys,
    make_sampler,
    owen_sobol,
)
from tests._twins import lowbias32 as _lowbias32

M32 = 0xFFFFFFFF

# ------------------------------------------------------------------------------------------------
# The slow twin, from Cycles' util/hash.h and kernel/sample/pattern.h


def _rev(x: int) -> int:
    return int(format(x & M32, "032b")[::-1], 2)


def _morton2d(x: int, y: int) -> int:
    out = 0
    for k in range(16):
        out |= ((y >> k) & 1) << (2 * k) | ((x >> k) & 1) << (2 * k + 1)
    return out


def _base4_owen(i: int, seed: int) -> int:
    n = _rev(i)
    n ^= (n * 0x3D20ADEA) & M32
    n ^= (n >> 1) & (n << 1) & 0x55555555
    n = (n + seed) & M32
    n = (n * ((seed >> 16) | 1)) & M32
    n ^= (n >> 1) & (n << 1) & 0x55555555
    n ^= (n * 0x05526C56) & M32
    n ^= (n * 0x53A22864) & M32
    return _rev(n)


def twin_key(x: int, y: int, seed: int) -> int:
    return _base4_owen(_morton2d(x, y), _lowbias32(seed))


def twin_sequence(key: int, sample: int, spp: int, seed0: int, first: bool) -> tuple[int, int]:
    """(sequence seed, index) of Cycles' blue_noise_indexing."""
    if not first:
        return seed0 & M32, (sample + key * spp) & M32
    if sample == 0:
        return (seed0 ^ 0x0CD0519F) & M32, key
    return seed0 & M32, ((sample - 1) + key * (spp - 1)) & M32


def test_twin_morton_puts_x_in_the_odd_bits():
    assert _morton2d(1, 0) == 2 and _morton2d(0, 1) == 1 and _morton2d(3, 5) == 0b11011


@given(width=st.integers(1, 300), height=st.integers(1, 300), seed=st.integers(-(2**40), 2**40))
def test_keys_match_the_twin(width, height, seed):
    keys = cycles_keys(height, width, seed)
    assert keys.shape == (height, width) and keys.dtype == torch.int64
    for y, x in {(0, 0), (height - 1, width - 1), (height // 2, width // 3), (0, width - 1)}:
        assert int(keys[y, x]) == twin_key(x, y, seed)


def test_keys_of_aligned_blocks_are_aligned_blocks():
    keys = cycles_keys(16, 16, seed=7)
    assert sorted(keys.reshape(-1).tolist()) != list(range(256))  # scrambled ...
    for j in (1, 2, 3):
        size = 2**j
        blocks = keys.reshape(16 // size, size, 16 // size, size).permute(0, 2, 1, 3)
        blocks = blocks.reshape(-1, size * size)
        lo = blocks.min(dim=1).values
        # ... but each aligned 2^j x 2^j block holds one aligned run of 4^j keys
        assert bool((lo % (size * size) == 0).all())
        assert bool((blocks.max(dim=1).values - lo == size * size - 1).all())


@pytest.mark.parametrize("cls", [CyclesPureSampler, CyclesFirstSampler])
@pytest.mark.parametrize("spp", [1, 4, 6, 16])
def test_samplers_match_the_twin(cls, spp):
    sampler = cls(spp, seed0=11)
    keys = cycles_keys(9, 7, seed=3).reshape(-1)
    lane = torch.arange(keys.numel() * spp)
    key, index = keys[lane // spp], lane % spp
    got = sampler.sample(key, index, 1, 5)
    pairs = [twin_sequence(k, i, spp, 11, cls.first) for k, i in zip(key.tolist(), index.tolist())]
    seeds = torch.tensor([p[0] for p in pairs])
    indices = torch.tensor([p[1] for p in pairs])
    for j, d in enumerate(range(1, 6)):
        assert torch.equal(got[:, j], owen_sobol(seeds, indices, d)), d


def _is_net(points: torch.Tensor, m: int) -> bool:
    cells = (points.double() * 2**24).long()
    for a in range(m + 1):
        cell = (cells[:, 0] >> (24 - a)) * 2 ** (m - a) + (cells[:, 1] >> (24 - (m - a)))
        if not bool((torch.bincount(cell, minlength=2**m) == 1).all()):
            return False
    return True


def _image_points(sampler, size: int, spp: int, dim: int) -> torch.Tensor:
    """``[size, size, spp, 2]`` points of the pair at ``dim``."""
    keys = cycles_keys(size, size, seed=5).reshape(-1)
    lane = torch.arange(keys.numel() * spp)
    pts = sampler.sample(keys[lane // spp], lane % spp, dim, 2)
    return pts.reshape(size, size, spp, 2)


@pytest.mark.parametrize("spp, k", [(1, 0), (4, 1), (16, 2)])
def test_pure_pixels_and_aligned_quads_are_nets(spp, k):
    pts = _image_points(CyclesPureSampler(spp), 8, spp, 2)
    for y in range(8):
        for x in range(8):
            assert _is_net(pts[y, x], 2 * k)
    for y in range(0, 8, 2):
        for x in range(0, 8, 2):
            assert _is_net(pts[y : y + 2, x : x + 2].reshape(-1, 2), 2 * k + 2)


def test_first_samples_of_aligned_quads_are_nets():
    # FIRST's sample 0 is a 1-spp blue-noise pattern: one point per pixel, a net per quad
    pts = _image_points(CyclesFirstSampler(4), 8, 4, 0)[:, :, 0]
    for y in range(0, 8, 2):
        for x in range(0, 8, 2):
            assert _is_net(pts[y : y + 2, x : x + 2].reshape(-1, 2), 2)


def test_a_permuted_key_moves_the_sequence():
    sampler = CyclesPureSampler(4)
    keys = cycles_keys(4, 4).reshape(-1)
    index = torch.full((16,), 3)
    perm = torch.randperm(16, generator=torch.Generator().manual_seed(2))
    assert torch.equal(
        sampler.sample(keys[perm], index, 0, 3), sampler.sample(keys, index, 0, 3)[perm]
    )


def test_registration_and_errors():
    assert SAMPLERS["cycles_pure"] is CyclesPureSampler
    assert SAMPLERS["cycles_first"] is CyclesFirstSampler
    assert make_sampler("cycles_first", spp=4, seed0=2).seed0 == 2
    s = CyclesPureSampler(4)
    with pytest.raises(ValueRangeError, match=r"index: expected sample indices in \[0, 4\)"):
        s.sample(torch.zeros(2, dtype=torch.int64), torch.tensor([0, 4]), 0, 1)
    with pytest.raises(ValueRangeError, match="spp: expected an integer >= 1, got 0"):
        CyclesPureSampler(0)
    with pytest.raises(DtypeError, match="seed0: expected an int, got str"):
        CyclesFirstSampler(4, seed0="1")
    with pytest.raises(DtypeError, match="seed: expected an int, got float"):
        cycles_keys(4, 4, seed=1.5)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
def test_runs_on_cuda_and_agrees_with_cpu():
    keys = cycles_keys(8, 8, seed=1)
    assert torch.equal(cycles_keys(8, 8, seed=1, device="cuda").cpu(), keys)
    key, index = keys.reshape(-1).repeat(4), torch.arange(256) // 64
    for cls in (CyclesPureSampler, CyclesFirstSampler):
        cpu = cls(4).sample(key, index, 0, 6)
        assert torch.equal(cls(4).sample(key.cuda(), index.cuda(), 0, 6).cpu(), cpu)
