"""Tests for bnerr.sequences.ldbn_bases: the base point sets LDBN keys act on, their prefixes'
stratification, the z-order chunks' bijection, and the sampler reading what the optimizer saw."""

import numpy as np
import pytest
import torch

from bnerr.errors import ValueRangeError
from bnerr.sequences.ldbn_bases import (
    LATTICE_GENERATOR,
    base_table,
    base_words,
    check_base,
    keyed_words,
    lattice_words,
    morton_chunks,
    shared_words,
    zorder_index,
)


def _strata(words: torch.Tensor, bits_x: int, bits_y: int) -> int:
    """How many distinct elementary intervals of ``2^bits_x x 2^bits_y`` the words ``[K, 2]``
    (24-bit) fall in."""
    cells = (words[:, 0] >> (24 - bits_x)) * (1 << bits_y) + (words[:, 1] >> (24 - bits_y))
    return int(torch.unique(cells).numel())


@pytest.mark.parametrize("m", range(7))
def test_every_aligned_lattice_block_is_the_rotated_2m_point_lattice(m):
    n = 1 << m
    first = lattice_words(torch.arange(n), 0, 2).T.long()  # [n, 2]
    want = {(k << (24 - m), ((k * LATTICE_GENERATOR) % n) << (24 - m)) for k in range(n)}
    assert {tuple(w) for w in first.tolist()} == want
    for block in (1, 5):  # a later aligned block, read through a rank: the same set rotated
        rank = block * n
        words = lattice_words(torch.arange(n) ^ rank, 0, 2).T.long()
        shift = words[0] - first[0]
        assert {tuple(w) for w in ((first + shift) & 0xFFFFFF).tolist()} == {
            tuple(w) for w in words.tolist()
        }
        assert len({int(x) >> (24 - m) for x in words[:, 0]}) == n  # 1D stratified in x


def test_lattice_words_follow_the_dimension_parity():
    index = torch.tensor([0, 1, 6, 123456])
    both = lattice_words(index, 4, 2)
    assert torch.equal(lattice_words(index, 5, 1)[0], both[1])
    assert torch.equal(lattice_words(index, 7, 1)[0], both[1])
    assert both.dtype == torch.int32 and int(both.max()) < 1 << 24


def test_zorder_index_is_a_bijection_onto_the_blocks_of_the_tile():
    level, texels = 3, 16
    n = 1 << level
    chunk = torch.randperm(texels, generator=torch.Generator().manual_seed(1))
    index = torch.arange(3 * n)  # three blocks of n samples
    glob = zorder_index(index[None, :], chunk[:, None], level, texels)
    assert torch.equal(glob.reshape(-1).sort().values, torch.arange(3 * n * texels))
    assert torch.equal(glob[:, :n] // n, chunk[:, None].expand(-1, n))  # block 0 in the chunk


def test_morton_chunks_and_the_union_of_an_aligned_block_is_a_net():
    assert morton_chunks(4).reshape(4, 4).tolist() == [
        [0, 1, 4, 5],
        [2, 3, 6, 7],
        [8, 9, 12, 13],
        [10, 11, 14, 15],
    ]
    with pytest.raises(ValueRangeError, match="power of two"):
        morton_chunks(6)
    level, size = 2, 8  # 4 samples per texel; a 2x2 texel block holds 16 points of one sequence
    table = base_table("zorder", 18, 1, level, size * size)
    keys = torch.stack([morton_chunks(size), torch.zeros(size * size, dtype=torch.int64)], 1)
    words = keyed_words("zorder", table, torch.arange(4).expand(size * size, -1), keys, 4)
    block = words.reshape(size, size, 4, 2)[2:4, 4:6].reshape(-1, 2)  # an aligned 2x2 block
    for bits_x in range(5):  # a (0, 4, 2)-net: one point in every elementary interval
        assert _strata(block, bits_x, 4 - bits_x) == 16


@pytest.mark.parametrize("base", ["sobol", "lattice", "zorder"])
def test_the_samplers_words_are_the_optimizers_points(base):
    level, texels, pair = 3, 25, 1
    n = 1 << level
    gen = torch.Generator().manual_seed(7)
    if base == "zorder":
        keys = torch.stack([torch.randperm(texels, generator=gen), torch.zeros(texels).long()], 1)
    else:
        keys = torch.randint(0, 1 << 24, (texels, 2), generator=gen)
    rank = torch.randint(0, n, (texels,), generator=gen)
    indices = torch.arange(n)[None, :] ^ rank[:, None]
    table = base_table(base, 18, pair, level, texels)
    want = keyed_words(base, table, indices, keys, n)  # [K, n, 2]
    lanes = keys.repeat_interleave(n, 0).T  # [2, K n]
    got = base_words(base, 18, indices.reshape(-1), lanes, (2 * pair, 2), (level, texels))
    assert torch.equal(got.T.reshape(texels, n, 2).long(), want)
    odd = base_words(base, 18, indices.reshape(-1), lanes, (2 * pair + 1, 1), (level, texels))
    assert torch.equal(odd[0].long(), want[..., 1].reshape(-1))


def test_shared_words_are_the_top_24_bits_of_owen_sobol():
    from bnerr.sequences import make_sampler

    index = torch.arange(64)
    words = shared_words(18, index, 2, 2)
    values = make_sampler("owen_sobol").sample(torch.full((64,), 18), index, 2, 2)
    assert np.array_equal(words.T.numpy(), (values.numpy() * (1 << 24)).astype(np.int32))


def test_check_base_names_the_bases():
    assert check_base("zorder") == "zorder"
    with pytest.raises(ValueRangeError, match="sobol.*lattice.*zorder.*got 'halton'"):
        check_base("halton")
