"""Owen-scrambled Sobol padded by 2D pairs (Burley 2020), one sequence per pixel seed."""

from __future__ import annotations

import torch

from bnerr.hashing import MASK32, lowbias32, lowbias32_host, signed32, srl32
from bnerr.native import SelfCheckedKernels
from bnerr.sequences import native
from bnerr.sequences.base import (
    Sampler,
    _columns,
    _hash_small,
    _prepare,
    _to_unit,
    _words,
    _xor_key,
)
from bnerr.sequences.tables import _Tables, _tables

__all__ = ["OwenSobolSampler", "owen_sobol"]

_SALT_SOBOL_SEED = 0xC2B2AE35
_SALT_SOBOL_KEY = 0x27D4EB2F

# Laine-Karras permutation constants (Burley 2020, Listing 2).
_LK_CONSTANTS = (0x6C50B47C, 0xB82F1E52, 0xC7AFE638, 0x8D22F6E6)


def _laine_karras(x: torch.Tensor, key: torch.Tensor) -> torch.Tensor:
    """Laine-Karras permutation of bit-reversed words (Burley 2020, Listing 2).

    Output bit j depends only on input bits <= j (an addition and multiplications by even
    constants carry upwards only), so in the reversed domain it is a nested uniform (Owen)
    scramble: the j-th most significant bit of the value is flipped by a function of the bits
    above it. That is what keeps the scrambled points a (0, m, 2)-net.
    """
    x = x + key
    for c in _LK_CONSTANTS:
        x = x ^ (x * signed32(c))
    return x


def _sobol_key(seed_hash: torch.Tensor, pair: torch.Tensor | int, role: int) -> torch.Tensor:
    """Key of a pair's index shuffle (role 2) or of its coordinate 0 or 1 (roles 0, 1)."""
    return lowbias32(_xor_key(seed_hash, _hash_small(pair * 4 + role, _SALT_SOBOL_KEY)))


def _shuffled_index(
    seed_hash: torch.Tensor, rindex: torch.Tensor, pair: torch.Tensor | int
) -> torch.Tensor:
    """The pair's shuffled index in the reversed domain: ``y = LK(reverse(i), key)``."""
    return _laine_karras(rindex, _sobol_key(seed_hash, pair, 2))


def _owen_coordinate(
    tables: _Tables,
    seed_hash: torch.Tensor,
    y: torch.Tensor,
    pair: torch.Tensor | int,
    role: torch.Tensor | int,
) -> torch.Tensor:
    """Top 24 bits of the scrambled Sobol coordinate ``role`` (0 or 1) of the pair."""
    if isinstance(role, int):
        z = tables.reverse(y) if role == 0 else tables.sobol1(y)
        key = _sobol_key(seed_hash, pair, role)
    else:
        z = torch.where(role == 0, tables.reverse(y), tables.sobol1(y))
        key = torch.where(role == 0, _sobol_key(seed_hash, pair, 0), _sobol_key(seed_hash, pair, 1))
    return tables.top24(_laine_karras(z, key))


def owen_sobol(seed: torch.Tensor, index: torch.Tensor, dim: torch.Tensor | int) -> torch.Tensor:
    """Owen-scrambled Sobol, padded by 2D pairs (Burley 2020, "Practical Hash-based Owen
    Scrambling", JCGT 9(4); pbrt-v4's ``PaddedSobolSampler`` with ``OwenScrambler``).

    Dimension ``d`` is coordinate ``d % 2`` of pair ``k = d // 2``. Every pair is its own copy of
    Sobol dimensions (0, 1) with its own keys ``hash(seed, k)``:

    1. shuffle the index with a nested uniform scramble keyed by ``hash(seed, k, 2)``
       (``i' = reverse(LK(reverse(i)))``, LK the Laine-Karras permutation);
    2. evaluate Sobol dimension ``d % 2`` at ``i'`` (0: van der Corput; 1: Joe-Kuo's x + 1);
    3. Owen-scramble the value with the key ``hash(seed, k, d % 2)``.

    Why pairs and not Burley's groups of four: the renderer consumes dimensions in 2D pairs
    (pixel position, light sample, BSDF sample, ...) and needs each pair's first 2^m samples to
    be a (0, m, 2)-net. Sobol dimensions (0, 1) are a (0, 2)-sequence, but dimensions (2, 3) of
    a 4D group are not: with Joe-Kuo direction numbers their first 2^m points fail the net test
    for m = 2, 3, 5, 6, 7, 8 (checked in ``tests/test_sequences.py``), and scrambling cannot fix
    that, since Owen scrambling preserves the t-value. The index shuffle keeps nets: it maps the
    first 2^m indices onto an aligned block of 2^m indices, and every such block of a (0, 2)-
    sequence is a (0, m, 2)-net. The shuffle also decorrelates the pairs from each other.

    Args:
        seed: int64 tensor, any shape; its low 32 bits are used.
        index: int64 tensor broadcastable with ``seed``: the sample index (low 32 bits).
        dim: int64 tensor or non-negative int, broadcastable with both: the dimension.

    Returns:
        float32 tensor of the broadcast shape, on ``seed``'s device, values in [0, 1) (24 bits).

    Not for: points in more than 2 dimensions that must be jointly stratified (two pairs are
    independent, not a 4D net); more than 2^32 samples per pixel.
    """
    seed, index, dim = _prepare(seed, index, dim)
    tables = _tables(seed.device)
    seed_hash = lowbias32(seed ^ signed32(_SALT_SOBOL_SEED))
    pair = dim >> 1 if isinstance(dim, int) else srl32(dim, 1)
    y = _shuffled_index(seed_hash, tables.reverse(index), pair)
    return _to_unit(_owen_coordinate(tables, seed_hash, y, pair, dim & 1))


def _owen_sobol_columns(
    seed: torch.Tensor, index: torch.Tensor, dim: int, out: torch.Tensor
) -> None:
    """Write :func:`owen_sobol` of dims ``dim .. dim + len(out) - 1`` into the rows of ``out``.

    ``seed`` may be ``[N]`` or a 0-dim tensor (one seed for every lane, as in BNDS). On the CPU
    the native kernel (:mod:`bnerr.sequences.native`) writes the same bits when it loads and
    passes its self-check; else :func:`_owen_sobol_columns_torch`.
    """
    if native.uses_native(seed, index, out) and out.is_contiguous():
        kernels = _native_kernels()
        if kernels is not None:
            keys = _pair_keys(dim, out.shape[0])
            if native.native_seeded(kernels.owen_sobol, seed, index, dim, keys, out):
                return
    _owen_sobol_columns_torch(seed, index, dim, out)


def _pair_keys(dim: int, count: int) -> list[int]:
    """The host hashes of roles 0, 1, 2 of every pair that dims ``dim .. dim + count - 1`` touch."""
    pairs = range(dim // 2, (dim + count - 1) // 2 + 1)
    return [lowbias32_host((4 * p + role) ^ _SALT_SOBOL_KEY) for p in pairs for role in (0, 1, 2)]


def _seeded_pair_keys(seed: int, dim: int, count: int) -> list[int]:
    """The three per-pair hashes ``lowbias32(seed_hash ^ key)`` that every lane of the one
    ``seed`` shares, per pair as :func:`_pair_keys`: a kernel reading one sequence at many
    indices (LDBN's shared sequence) takes them once instead of hashing them per lane."""
    seed_hash = lowbias32_host((seed & MASK32) ^ _SALT_SOBOL_SEED)
    return [lowbias32_host(seed_hash ^ key) for key in _pair_keys(dim, count)]


def _owen_sobol_columns_torch(
    seed: torch.Tensor, index: torch.Tensor, dim: int, out: torch.Tensor
) -> None:
    """The torch path of :func:`_owen_sobol_columns`: the seed hash and the reversed index are
    shared by every pair, the shuffled index by both coordinates of a pair."""
    tables = _tables(index.device)
    seed_hash = lowbias32(_words(seed, index.device) ^ signed32(_SALT_SOBOL_SEED))
    rindex = tables.reverse(_words(index, index.device))
    end = dim + out.shape[0]
    for pair in range(dim // 2, (end - 1) // 2 + 1):
        y = _shuffled_index(seed_hash, rindex, pair)
        for role in (0, 1):
            if dim <= 2 * pair + role < end:
                word = _owen_coordinate(tables, seed_hash, y, pair, role)
                _to_unit(word, out=out[2 * pair + role - dim])


def _self_check(kernels: native.SamplerKernels) -> bool:
    """The native kernel against the torch path on random lanes, odd and even first dimensions,
    a shared 0-dim seed and extreme words: True if bit-identical."""
    cases = ((0, 8), (5, 4), (64, 3))
    return native.seeded_self_check(
        kernels.owen_sobol, _owen_sobol_columns_torch, _pair_keys, cases, 301, 97
    )


#: The native kernels if they load and pass :func:`_self_check` (run once per library).
_native_kernels = SelfCheckedKernels(
    _self_check, "bnerr.sequences.owen_sobol: the native Owen-Sobol kernel", native.LIBRARY
)


class OwenSobolSampler(Sampler):
    """Owen-scrambled Sobol padded by 2D pairs, one sequence per pixel seed: :func:`owen_sobol`."""

    name = "owen_sobol"

    def _sample(self, seed, index, dim, count, pixel):
        out = _columns(seed.shape[0], count, seed.device)
        _owen_sobol_columns(seed, index, dim, out)
        return out.T
