"""Tests of bnerr.sequences.zsobol: bit-exact agreement with a pure-Python twin written from the
pbrt-v4 rule, pbrt's own check values and worked example, the net properties pbrt's outputs have,
the sampler seam, and typed errors."""

from __future__ import annotations

import struct
import warnings

import numpy as np
import pytest
import torch
from hypothesis import given
from hypothesis import strategies as st

from bnerr.errors import DtypeError, UnknownNameError, ValueRangeError
from bnerr.sequences import SAMPLERS, ZSobolSampler, make_sampler, zsobol_1d, zsobol_2d, zsobol_keys
from bnerr.sequences.zsobol import _Layout, _zsobol_words, morton2
from tests._twins import M32, pbrt_sobol, rev32
from tests._twins import mix_bits as _mix
from tests._twins import pbrt_hash as _hash

# ------------------------------------------------------------------------------------------------
# The slow twin: Python ints, one loop per rule, written from pbrt-v4's samplers.h


def _morton(x: int, y: int) -> int:
    return sum(((x >> k) & 1) << (2 * k) | ((y >> k) & 1) << (2 * k + 1) for k in range(32))


_PERM = [[int(c) for c in p] for p in (
    "0123 0132 0213 0231 0321 0312 1023 1032 1203 1230 1320 1302 "
    "2103 2130 2013 2031 2301 2310 3120 3102 3210 3201 3021 3012").split()]  # fmt: skip


def _layout(width: int, height: int, spp: int) -> tuple[int, int]:
    log2spp = spp.bit_length() - 1
    res = 1
    while res < max(width, height):
        res *= 2
    return log2spp, res.bit_length() - 1 + (log2spp + 1) // 2


def _sample_index(morton_index: int, d: int, log2spp: int, n_digits: int) -> int:
    salt = (0x55555555 * d) & M32
    odd = log2spp & 1
    out = 0
    for i in range(n_digits - 1, odd - 1, -1):
        shift = 2 * i - odd
        digit = (morton_index >> shift) & 3
        p = (_mix((morton_index >> (shift + 2)) ^ salt) >> 24) % 24
        out |= _PERM[p][digit] << shift
    if odd:
        out |= (morton_index & 1) ^ (_mix((morton_index >> 1) ^ salt) & 1)
    return out


def _randomize(v: int, s: int, randomizer: str) -> int:
    if randomizer == "none":
        return v
    if randomizer == "permutedigits":
        return v ^ s
    if randomizer == "fastowen":
        x = rev32(v)
        x ^= (x * 0x3D20ADEA) & M32
        x = (x + s) & M32
        x = (x * ((s >> 16) | 1)) & M32
        x ^= (x * 0x05526C56) & M32
        x ^= (x * 0x53A22864) & M32
        return rev32(x)
    if s & 1:
        v ^= 1 << 31
    for b in range(1, 32):
        prefix = v & ((M32 << (32 - b)) & M32)
        if ((_mix(prefix ^ s) & M32) >> b) & 1:
            v ^= 1 << (31 - b)
    return v


def _float_bits(v: int) -> int:
    largest = np.float32(struct.unpack("<f", struct.pack("<I", 0x3F7FFFFF))[0])
    f = min(np.float32(v / 2**32), largest)  # float64 v / 2^32 is exact; float32() rounds
    return struct.unpack("<I", struct.pack("<f", f))[0]


def twin(x, y, index, dim, seed, width, height, spp, randomizer="fastowen", ndim=2) -> list[int]:
    """float32 bit patterns of pbrt's Get1D (ndim 1) or Get2D (ndim 2)."""
    log2spp, n_digits = _layout(width, height, spp)
    a = _sample_index((_morton(x, y) << log2spp) | index, dim, log2spp, n_digits)
    h = _hash(dim + ndim, seed)
    seeds = (h & M32, h >> 32)
    return [_float_bits(_randomize(pbrt_sobol(a, c), seeds[c], randomizer)) for c in range(ndim)]


def _bits(t: torch.Tensor) -> list[int]:
    return [v & M32 for v in t.contiguous().view(torch.int32).reshape(-1).tolist()]


# ------------------------------------------------------------------------------------------------
# pbrt's check values and worked example


def test_twin_reproduces_pbrt_check_values():
    assert _morton(37, 11) == 0x49B
    checks = {
        (2, 0): 0xC7530D606BB62412,
        (3, 0): 0x47CD23686E97A272,
        (5, 0): 0xFD1B61F05284D138,
        (2, 12345): 0xAA5636CE3CFFA306,
        (3, 12345): 0x221B7956FE9D6F13,
        (5, 12345): 0x6ADB8BDEB350CB88,
    }
    for (e, s), h in checks.items():
        assert _hash(e, s) == h
    assert _sample_index(0x49B5, 0, 4, 13) == 0x7BC8
    assert _sample_index(0x937, 3, 1, 12) == 0x1E47


def test_worked_example_bit_for_bit():
    kw = dict(seed=0, width=1920, height=1080, spp=16)
    x, y, i = torch.tensor(37), torch.tensor(11), torch.tensor(5)
    assert _bits(zsobol_2d(x, y, i, 0, **kw)) == [0x3EA77765, 0x3F3FD7B5]
    assert _bits(zsobol_1d(x, y, i, 2, **kw)) == [0x3E9153C5]
    assert _bits(zsobol_2d(x, y, i, 3, **kw)) == [0x3F62D3D0, 0x3F4270CB]
    odd = zsobol_2d(x, y, torch.tensor(1), 3, seed=0, width=1920, height=1080, spp=2,
                    randomizer="none")  # fmt: skip
    assert _bits(odd) == [0x3F627800, 0x3EA43000]
    assert float(zsobol_2d(x, y, i, 0, **kw)[0]) == pytest.approx(0.327082783, abs=1e-9)


# ------------------------------------------------------------------------------------------------
# Agreement with the twin


def _check(xs, ys, idx, dims, seed, width, height, spp, randomizer):
    x, y, i = (torch.tensor(v, dtype=torch.int64) for v in (xs, ys, idx))
    d = torch.tensor(dims, dtype=torch.int64)
    kw = dict(seed=seed, width=width, height=height, spp=spp, randomizer=randomizer)
    got2, got1 = _bits(zsobol_2d(x, y, i, d, **kw)), _bits(zsobol_1d(x, y, i, d, **kw))
    for n, args in enumerate(zip(xs, ys, idx, dims, strict=True)):
        assert got2[2 * n : 2 * n + 2] == twin(*args, seed, width, height, spp, randomizer), args
        assert got1[n] == twin(*args, seed, width, height, spp, randomizer, ndim=1)[0], args


@pytest.mark.parametrize("randomizer", ["fastowen", "none", "permutedigits", "owen"])
@pytest.mark.parametrize(
    "width, height, spp",
    [(64, 64, 16), (1920, 1080, 1), (1920, 1080, 2), (37, 5, 4), (1, 1, 64), (100, 300, 6),
     (17, 17, 3), (640, 480, 64)],
)  # fmt: skip
def test_edge_cases_match_the_twin(randomizer, width, height, spp):
    log2spp, _ = _layout(width, height, spp)
    last_x, last_y, last_i = width - 1, height - 1, (1 << log2spp) - 1
    pixels = [(0, 0), (last_x, last_y), (last_x, 0), (0, last_y), (width // 2, height // 3)]
    cases = [(px, py, i, d) for px, py in pixels for i in {0, last_i} for d in range(0, 41, 5)]
    xs, ys, idx, dims = (list(c) for c in zip(*cases, strict=True))
    for seed in (0, 12345, -1, 2**31 - 1):
        _check(xs, ys, idx, dims, seed, width, height, spp, randomizer)


@given(
    width=st.integers(1, 5000),
    height=st.integers(1, 5000),
    log2spp=st.integers(0, 8),
    seed=st.integers(-(2**31), 2**31 - 1),
    data=st.data(),
)
def test_random_inputs_match_the_twin(width, height, log2spp, seed, data):
    spp = (1 << log2spp) + data.draw(st.integers(0, (1 << log2spp) - 1))  # not always a power
    n = 6
    xs = data.draw(st.lists(st.integers(0, width - 1), min_size=n, max_size=n))
    ys = data.draw(st.lists(st.integers(0, height - 1), min_size=n, max_size=n))
    idx = data.draw(st.lists(st.integers(0, (1 << log2spp) - 1), min_size=n, max_size=n))
    dims = data.draw(st.lists(st.integers(0, 40), min_size=n, max_size=n))
    _check(xs, ys, idx, dims, seed, width, height, spp, "fastowen")


def test_large_indices_use_sobol_columns_above_32():
    # 16384^2 pixels at spp 65536 need global indices >= 2^32 (pbrt's columns 32..51)
    x, y, i = [16383, 9000], [16383, 12345], [65535, 777]
    _check(x, y, i, [0, 7], 5, 16384, 16384, 65536, "none")
    _check(x, y, i, [3, 40], 5, 16384, 16384, 65536, "fastowen")


def test_the_seed_enters_only_through_the_value_scramble():
    x, y, i = torch.arange(8), torch.arange(8) % 3, torch.arange(8) % 4
    kw = dict(width=8, height=8, spp=4, randomizer="none")
    assert torch.equal(zsobol_2d(x, y, i, 3, seed=0, **kw), zsobol_2d(x, y, i, 3, seed=9, **kw))
    kw["randomizer"] = "fastowen"
    assert not torch.equal(zsobol_2d(x, y, i, 3, seed=0, **kw), zsobol_2d(x, y, i, 3, seed=9, **kw))


# ------------------------------------------------------------------------------------------------
# Nets (pbrt's observed properties)


def _net_failures(cells: torch.Tensor, m: int) -> int:
    """Groups of points (``[G, 2^m, 2]`` u32 words, int64) that are not (0, m, 2)-nets."""
    ok = torch.ones(cells.shape[0], dtype=torch.bool)
    for a in range(m + 1):
        cell = (cells[..., 0] >> (32 - a)) * 2 ** (m - a) + (cells[..., 1] >> (32 - (m - a)))
        counts = torch.zeros(cells.shape[0], 2**m, dtype=torch.long)
        counts.scatter_add_(1, cell, torch.ones_like(cell))
        ok &= (counts == 1).all(dim=1)
    return int((~ok).sum())


def _grid(size: int, spp: int, start: int = 0):
    y, x, i = torch.meshgrid(torch.arange(start, start + size), torch.arange(start, start + size),
                             torch.arange(spp), indexing="ij")  # fmt: skip
    return x, y, i


def _blocks(values: torch.Tensor, size: int, spp: int, block: int) -> torch.Tensor:
    """``[size, size, spp, 2]`` -> each aligned block's points, ``[blocks, block^2 spp, 2]``."""
    nb = size // block
    values = values.reshape(nb, block, nb, block, spp, 2).permute(0, 2, 1, 3, 4, 5)
    return values.reshape(nb * nb, block * block * spp, 2)


def _float_cells(size: int, spp: int, block: int, dim: int, seed: int, start: int = 0):
    x, y, i = _grid(size, spp, start)
    pts = zsobol_2d(x, y, i, dim, seed=seed, width=size + start, height=size + start, spp=spp)
    return _blocks((pts.double() * 2**32).long(), size, spp, block)


def _word_cells(size: int, spp: int, block: int, dim: int, seed: int):
    """The scrambled u32 words (before the float conversion) in the same block layout."""
    x, y, i = _grid(size, spp)
    layout = _Layout(size, size, spp)
    morton = (morton2(x, y) << layout.log2spp) | i
    words = _zsobol_words(morton, dim, 2, (0, 1), layout, seed, "fastowen")
    return _blocks(torch.stack(words, -1).to(torch.int64) & M32, size, spp, block)


@pytest.mark.parametrize("spp, k", [(1, 0), (4, 1), (16, 2), (64, 3)])
@pytest.mark.parametrize("dim", [0, 3])
def test_each_pixel_is_a_net_and_each_aligned_quad_a_larger_one(spp, k, dim):
    # Exact for the scrambled u32 words (the rule's property); for the float32 values rounding
    # to nearest can push a word just below a cell boundary onto it (pbrt's outputs do the
    # same): measured here, 1 of 64 quads at spp 64, seed 0, dimension 3, none elsewhere.
    for seed in (0, 12345):
        assert _net_failures(_word_cells(16, spp, 1, dim, seed), 2 * k) == 0
        assert _net_failures(_word_cells(16, spp, 2, dim, seed), 2 * k + 2) == 0
        assert _net_failures(_float_cells(16, spp, 1, dim, seed), 2 * k) == 0
        assert _net_failures(_float_cells(16, spp, 2, dim, seed), 2 * k + 2) <= 1
    assert _net_failures(_word_cells(16, 16, 4, 0, 0), 8) == 0  # aligned 4 x 4 blocks too


def test_each_pixels_1d_values_fall_one_per_stratum():
    y, x, i = torch.meshgrid(torch.arange(16), torch.arange(16), torch.arange(16), indexing="ij")
    v = zsobol_1d(x, y, i, 2, width=16, height=16, spp=16).reshape(256, 16)
    strata = (v.double() * 16).long().sort(dim=1).values
    assert torch.equal(strata, torch.arange(16).expand(256, 16))


def test_unaligned_quads_are_not_nets():
    assert _net_failures(_float_cells(16, 16, 2, 0, 0), 6) == 0
    assert _net_failures(_float_cells(16, 16, 2, 0, 0, start=1), 6) > 32  # offset by one pixel


# ------------------------------------------------------------------------------------------------
# The sampler seam


def test_sampler_with_identity_keys_gives_pbrt_pairs():
    width, height, spp = 12, 7, 8
    sampler = make_sampler("zsobol", width=width, height=height, spp=spp, seed=3)
    keys = zsobol_keys(height, width)
    y, x = torch.meshgrid(torch.arange(height), torch.arange(width), indexing="ij")
    lane = torch.arange(height * width * spp)
    pix, index = lane // spp, lane % spp
    got = sampler.sample(keys.reshape(-1)[pix], index, 1, 6)
    for j, d in enumerate(range(1, 7)):
        pair = zsobol_2d(x.reshape(-1)[pix], y.reshape(-1)[pix], index, d - d % 2, seed=3,
                         width=width, height=height, spp=spp)  # fmt: skip
        assert torch.equal(got[:, j], pair[:, d % 2]), d


def test_sampler_moves_the_sequence_with_the_key():
    sampler = ZSobolSampler(8, 8, 4)
    keys = zsobol_keys(8, 8).reshape(-1)
    index = torch.zeros(64, dtype=torch.int64)
    perm = torch.randperm(64, generator=torch.Generator().manual_seed(1))
    a = sampler.sample(keys, index, 0, 4)
    assert torch.equal(sampler.sample(keys[perm], index, 0, 4), a[perm])


def test_sampler_registration_and_errors():
    assert SAMPLERS["zsobol"] is ZSobolSampler
    s = make_sampler("zsobol", width=4, height=4, spp=4)
    keys = torch.zeros(3, dtype=torch.int64)
    with pytest.raises(ValueRangeError, match=r"index: expected sample indices in \[0, 4\)"):
        s.sample(keys, torch.tensor([0, 1, 4]), 0, 2)
    with pytest.warns(UserWarning, match="spp 6 is not a power of two; pbrt-v4 takes 4"):
        assert ZSobolSampler(4, 4, 6).samples_per_pixel == 4
    with pytest.raises(UnknownNameError, match="unknown randomizer 'sobol'"):
        ZSobolSampler(4, 4, 4, randomizer="sobol")
    with pytest.raises(DtypeError, match="seed: expected an int, got float"):
        ZSobolSampler(4, 4, 4, seed=1.0)
    with pytest.raises(ValueRangeError, match="spp: expected an integer >= 1, got 0"):
        ZSobolSampler(4, 4, 0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ZSobolSampler(4, 4, 16)


def test_entry_points_reject_bad_input():
    t = torch.tensor([0, 1])
    kw = dict(width=4, height=2, spp=4)
    with pytest.raises(ValueRangeError, match=r"x: expected values in \[0, 4\)"):
        zsobol_1d(torch.tensor([4]), t, t, 0, **kw)
    with pytest.raises(ValueRangeError, match=r"y: expected values in \[0, 2\)"):
        zsobol_1d(t, torch.tensor([-1]), t, 0, **kw)
    with pytest.raises(ValueRangeError, match=r"index: expected values in \[0, 4\) \(pbrt takes"):
        zsobol_2d(t, t, torch.tensor([4]), 0, width=4, height=2, spp=6)
    with pytest.raises(DtypeError, match="x: expected dtype int64, got float32"):
        zsobol_1d(t.float(), t, t, 0, **kw)
    with pytest.raises(ValueRangeError, match="dimension: expected an integer >= 0, got -1"):
        zsobol_1d(t, t, t, -1, **kw)


def test_morton_and_keys():
    assert int(morton2(torch.tensor(37), torch.tensor(11))) == 0x49B
    keys = zsobol_keys(3, 5)
    assert keys.shape == (3, 5) and int(keys[2, 4]) == _morton(4, 2)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
def test_runs_on_cuda_and_agrees_with_cpu():
    y, x, i = torch.meshgrid(torch.arange(9), torch.arange(13), torch.arange(4), indexing="ij")
    for randomizer in ("fastowen", "owen"):
        kw = dict(width=13, height=9, spp=4, seed=-5, randomizer=randomizer)
        cpu = zsobol_2d(x, y, i, 7, **kw)
        gpu = zsobol_2d(x.cuda(), y.cuda(), i.cuda(), 7, **kw)
        assert gpu.device.type == "cuda" and torch.equal(gpu.cpu(), cpu)
