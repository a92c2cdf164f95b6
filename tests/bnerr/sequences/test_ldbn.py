"""Tests of bnerr.sequences.ldbn: the LDBN lookup against a slow per-lane twin, stratification of
every power-of-two prefix per pixel and pair, the ranks' bijection, the rules past the tile's spp
and dimensions, determinism and typed errors; the keyed lookup (texel read from the seed) against
the plain one. The lookup's properties are checked on both paths (``path``: the native kernel,
skipped without a compiler, and the torch path); tests/bnerr/sequences/test_native.py compares
the two bit for bit."""

from __future__ import annotations

import pytest
import torch

from bnerr.errors import DtypeError, ShapeError, ValueRangeError
from bnerr.sequences import (
    LDBNKeyedSampler,
    LDBNKeys,
    LDBNSampler,
    ldbn_key_image,
    make_sampler,
    native,
    owen_sobol,
)
from bnerr.sequences.ldbn import ldbn_level

M32 = 0xFFFFFFFF


def _keys(levels: int = 4, size: int = 4, dims: int = 4, seed: int = 0) -> LDBNKeys:
    gen = torch.Generator().manual_seed(seed)
    scramble = torch.randint(0, 1 << 24, (levels, size, size, dims), generator=gen)
    rank = torch.stack(
        [torch.randint(0, 1 << lv, (size, size, dims // 2), generator=gen) for lv in range(levels)]
    )
    return LDBNKeys(scramble.to(torch.int32), rank.to(torch.int32), seed0=7)


def _lanes(size: int, spp: int, seed: int = 0):
    """Every pixel of a ``size x size`` image (offset by 3, 5) times spp samples."""
    ys, xs = torch.meshgrid(torch.arange(size), torch.arange(size), indexing="ij")
    pixel = torch.stack([ys.reshape(-1) + 3, xs.reshape(-1) + 5], 1).repeat_interleave(spp, 0)
    index = torch.arange(spp).repeat(size * size)
    seeds = (torch.arange(size * size, dtype=torch.int64) * 7919 + seed).repeat_interleave(spp)
    return seeds, index, pixel


@pytest.fixture(params=["native", "torch"])
def path(request, monkeypatch):
    """The sampler's path under test: ``native`` (skipped when the kernels do not load) or
    ``torch`` (the native dispatch turned off, as on CUDA or without a compiler)."""
    if request.param == "torch":
        monkeypatch.setattr(native, "uses_native", lambda *tensors: False)
    elif native.LIBRARY.load() is None:
        pytest.skip(f"native sampler kernels unavailable: {native.LIBRARY.status()}")
    return request.param


def twin(keys: LDBNKeys, spp: int, offset, seed: int, i: int, d: int, y: int, x: int) -> float:
    """The lookup, one lane at a time, from the docstring's four steps."""
    level = min((spp - 1).bit_length(), keys.levels - 1)
    if d >= keys.dims:
        return float(owen_sobol(torch.tensor([seed]), torch.tensor([i]), d)[0])
    ty, tx = (y + offset[0]) % keys.size, (x + offset[1]) % keys.size
    permuted = i ^ int(keys.rank[level, ty, tx, d // 2])
    word = int(owen_sobol(torch.tensor([keys.seed0]), torch.tensor([permuted]), d)[0] * 2**24)
    return (word ^ int(keys.scramble[level, ty, tx, d])) / 2**24


@pytest.mark.parametrize("spp", [1, 3, 8, 32])
@pytest.mark.parametrize("dim,count", [(0, 6), (1, 2), (3, 3)])
def test_sampler_matches_the_slow_twin_bit_for_bit(path, spp, dim, count):
    keys = _keys()
    sampler = LDBNSampler(keys, spp=spp, offset=(1, 2))
    seeds, index, pixel = _lanes(3, spp)
    got = sampler.sample(seeds, index, dim, count, pixel)
    for lane in range(0, seeds.shape[0], max(1, seeds.shape[0] // 12)):
        y, x = int(pixel[lane, 0]), int(pixel[lane, 1])
        for j in range(count):
            want = twin(keys, spp, (1, 2), int(seeds[lane]), int(index[lane]), dim + j, y, x)
            assert float(got[lane, j]) == want


def test_indices_past_the_table_are_evaluated_lane_by_lane_exactly(path):
    keys = _keys()
    seeds, index, pixel = _lanes(3, 4)
    far = index + (1 << 20)  # past the shared table's limit
    got = LDBNSampler(keys, spp=4).sample(seeds, far, 0, 4, pixel)
    for lane in range(0, far.shape[0], 5):
        y, x = int(pixel[lane, 0]), int(pixel[lane, 1])
        for d in range(4):
            want = twin(keys, 4, (0, 0), int(seeds[lane]), int(far[lane]), d, y, x)
            assert float(got[lane, d]) == want


def _stratified(points: torch.Tensor) -> bool:
    """Whether ``points [n, 2]`` (n = 2^m) is a (0, m, 2)-net: every elementary box holds one."""
    n = points.shape[0]
    m = n.bit_length() - 1
    for a in range(m + 1):
        cells = (points[:, 0] * (1 << a)).floor() * (1 << (m - a)) + (
            points[:, 1] * (1 << (m - a))
        ).floor()
        if torch.unique(cells).numel() != n:
            return False
    return True


@pytest.mark.parametrize("spp", [4, 16])
def test_every_power_of_two_prefix_of_every_pixel_and_pair_is_a_net(path, spp):
    keys = _keys(levels=5, size=4, dims=6)
    sampler = LDBNSampler(keys, spp=spp)
    seeds, index, pixel = _lanes(4, 2 * spp)  # past the tile's spp too
    values = sampler.sample(seeds, index, 0, 6, pixel).reshape(16, 2 * spp, 6)
    for p in range(16):
        for pair in range(3):
            for m in range((2 * spp).bit_length()):
                assert _stratified(values[p, : 1 << m, 2 * pair : 2 * pair + 2]), (p, pair, m)


def test_ranks_are_a_bijection_of_each_block_and_scrambling_is_a_digital_shift(path):
    keys = _keys(levels=4, size=4, dims=2)
    sampler = LDBNSampler(keys, spp=8)
    seeds, index, pixel = _lanes(4, 16)
    values = sampler.sample(seeds, index, 0, 2, pixel).reshape(16, 16, 2)
    shared = owen_sobol(torch.tensor([7]), torch.arange(16), 0)
    words = (values[..., 0] * 2**24).to(torch.int64)
    for p in range(16):
        key = int(keys.scramble[3].reshape(16, 2)[(p // 4 + 3) % 4 * 4 + (p % 4 + 5) % 4, 0])
        unscrambled = (words[p] ^ key).to(torch.float64) / 2**24
        for block in range(2):
            got = sorted(unscrambled[8 * block : 8 * block + 8].tolist())
            assert got == sorted(shared[8 * block : 8 * block + 8].double().tolist())


def test_past_the_optimized_dims_the_pixels_own_owen_sobol(path):
    keys = _keys(dims=2)
    seeds, index, pixel = _lanes(3, 4)
    got = LDBNSampler(keys, spp=4).sample(seeds, index, 2, 3, pixel)
    for j in range(3):
        assert torch.equal(got[:, j], owen_sobol(seeds, index, 2 + j))


def test_deterministic_and_offset_is_a_toroidal_shift(path):
    keys = _keys(size=4)
    seeds, index, pixel = _lanes(4, 2)
    a = LDBNSampler(keys, spp=2, offset=(1, 3)).sample(seeds, index, 0, 4, pixel)
    b = LDBNSampler(keys, spp=2, offset=(1, 3)).sample(seeds, index, 0, 4, pixel)
    assert torch.equal(a, b)
    shifted = pixel + torch.tensor([1, 3])
    c = LDBNSampler(keys, spp=2).sample(seeds, index, 0, 4, shifted)
    assert torch.equal(a, c)
    assert float(a.min()) >= 0 and float(a.max()) < 1


def test_levels_are_chosen_by_spp():
    assert [ldbn_level(s, 5) for s in (1, 2, 3, 4, 5, 16, 17, 64)] == [0, 1, 2, 2, 3, 4, 4, 4]


def test_registered_and_refuses_bad_input():
    keys = _keys()
    assert isinstance(make_sampler("ldbn", keys=keys, spp=2), LDBNSampler)
    with pytest.raises(DtypeError):
        LDBNSampler(keys.scramble)  # type: ignore[arg-type]
    with pytest.raises(ShapeError, match="pixel"):
        LDBNSampler(keys).sample(torch.zeros(2, dtype=torch.int64), torch.zeros(2).long(), 0, 1)
    with pytest.raises(ShapeError, match="even"):
        LDBNKeys(keys.scramble[..., :3], keys.rank[..., :1])
    bad_rank = keys.rank.clone()
    bad_rank[1, 0, 0, 0] = 2
    with pytest.raises(ValueRangeError, match="level 1"):
        LDBNKeys(keys.scramble, bad_rank)
    with pytest.raises(ValueRangeError, match="24-bit"):
        LDBNKeys(keys.scramble | (1 << 24), keys.rank)
    with pytest.raises(DtypeError):
        LDBNKeys(keys.scramble.long(), keys.rank)
    with pytest.raises(ValueRangeError, match="halton"):
        LDBNKeys(keys.scramble, keys.rank, base="halton")
    with pytest.raises(ValueRangeError, match="zorder chunks"):
        LDBNKeys(keys.scramble, keys.rank, base="zorder")  # 24-bit words, not chunks


# ------------------------------------------------------------------------------------------------
# The keyed lookup: the texel comes from the seed


def _image_lanes(seeds: torch.Tensor, spp: int):
    """Every pixel of a seed image times spp samples: (seed, index, pixel) lanes."""
    h, w = seeds.shape
    ys, xs = torch.meshgrid(torch.arange(h), torch.arange(w), indexing="ij")
    pixel = torch.stack([ys.reshape(-1), xs.reshape(-1)], 1).repeat_interleave(spp, 0)
    index = torch.arange(spp).repeat(h * w)
    return seeds.reshape(-1).repeat_interleave(spp), index, pixel


@pytest.mark.parametrize("spp", [1, 4, 8])
def test_keyed_sampler_on_the_key_image_is_the_plain_lookup_bit_for_bit(spp):
    keys = _keys(size=4, dims=4)
    gen = torch.Generator().manual_seed(3)
    seeds = torch.randint(0, 1 << 32, (5, 7), generator=gen)
    seeds[0, :2] = torch.tensor([0, (1 << 32) - 1])  # the extreme 32-bit seeds
    image = ldbn_key_image(seeds, keys.size, (1, 6))
    plain_lanes, keyed_lanes = _image_lanes(seeds, spp), _image_lanes(image, spp)
    want = LDBNSampler(keys, spp=spp, offset=(1, 6)).sample(*plain_lanes[:2], 0, 7, plain_lanes[2])
    got = LDBNKeyedSampler(keys, spp=spp).sample(*keyed_lanes[:2], 0, 7)  # 4 keyed dims, 3 past
    assert torch.equal(got, want)


def test_key_image_is_the_seed_above_the_texel_index():
    seeds = torch.tensor([[5, 9, 0]], dtype=torch.int64)
    image = ldbn_key_image(seeds, 64, (2, 63))
    assert image.tolist() == [[5 << 12 | 2 * 64 + 63, 9 << 12 | 2 * 64 + 0, 0 << 12 | 2 * 64 + 1]]


def test_keyed_sampler_moves_a_whole_sequence_with_its_seed():
    keys = _keys(size=4, dims=4)
    image = ldbn_key_image(torch.arange(16, dtype=torch.int64).view(4, 4) * 977, keys.size)
    moved = image.reshape(-1).flip(0).view(4, 4)  # any permutation of the seed image
    sampler = LDBNKeyedSampler(keys, spp=4)
    a = sampler.sample(*_image_lanes(image, 4)[:2], 0, 6).view(16, 4, 6)
    b = sampler.sample(*_image_lanes(moved, 4)[:2], 0, 6).view(16, 4, 6)
    assert torch.equal(a.flip(0), b)  # the pixel (y, x) is not read


def test_keyed_sampler_is_registered_and_its_image_refuses_bad_input():
    keys = _keys()
    sampler = make_sampler("ldbn_keyed", keys=keys, spp=2)
    assert isinstance(sampler, LDBNKeyedSampler) and not sampler.needs_pixel
    assert "LDBNKeyedSampler(keys=[4, 4, 4, 4], spp=2" in repr(sampler)
    with pytest.raises(DtypeError):
        LDBNKeyedSampler(keys.scramble)  # type: ignore[arg-type]
    with pytest.raises(DtypeError, match="seeds"):
        ldbn_key_image(torch.zeros(2, 2, dtype=torch.int32), 4)
    with pytest.raises(ShapeError, match="seeds"):
        ldbn_key_image(torch.zeros(2, dtype=torch.int64), 4)
    with pytest.raises(ValueRangeError, match=r"seeds: expected 32-bit seeds"):
        ldbn_key_image(torch.full((2, 2), 1 << 32), 4)
    with pytest.raises(ValueRangeError, match=r"seeds: expected 32-bit seeds"):
        ldbn_key_image(torch.full((2, 2), -1), 4)
    with pytest.raises(ValueRangeError, match="size"):
        ldbn_key_image(torch.zeros(2, 2, dtype=torch.int64), 0)
