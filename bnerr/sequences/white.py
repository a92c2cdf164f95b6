"""White noise: a counter-based hash of (seed, index, dim), the baseline every sequence beats."""

from __future__ import annotations

import torch

from bnerr.hashing import lowbias32, signed32, srl32
from bnerr.sequences.base import (
    Sampler,
    _columns,
    _hash_small,
    _prepare,
    _to_unit,
    _words,
    _xor_key,
)

__all__ = ["WhiteSampler", "white"]

# Salts that separate the hash domains (white noise, the Sobol keys), so that no two sequences
# share a hash chain. Arbitrary odd 32-bit constants.
_SALT_WHITE_SEED = 0x9E3779B9
_SALT_WHITE_DIM = 0x85EBCA6B


def _white_seed_index(seed: torch.Tensor, index: torch.Tensor) -> torch.Tensor:
    """The per-(seed, index) part of the white-noise hash chain."""
    return lowbias32(lowbias32(seed ^ signed32(_SALT_WHITE_SEED)) ^ index)


def _white_words(prefix: torch.Tensor, dim: torch.Tensor | int) -> torch.Tensor:
    """The top 24 bits of the white-noise hash of (prefix, dim)."""
    h = lowbias32(_xor_key(prefix, _hash_small(dim, _SALT_WHITE_DIM)))
    return srl32(h, 8)


def white(seed: torch.Tensor, index: torch.Tensor, dim: torch.Tensor | int) -> torch.Tensor:
    """White noise: a counter-based hash of (seed, index, dim) mapped to [0, 1).

    ``h = lowbias32(lowbias32(lowbias32(seed ^ a) ^ index) ^ lowbias32(dim ^ b))`` and
    ``u = (h >> 8) * 2^-24``, so u is a multiple of 2^-24 and < 1 in float32 (docs/METHODS.md,
    section 3, "white"). The seed and index are hashed first so that a sampler computes that part
    once per lane and pays one hash per dimension.

    Args:
        seed: int64 tensor, any shape; its low 32 bits are used.
        index: int64 tensor broadcastable with ``seed``: the sample index (low 32 bits).
        dim: int64 tensor or non-negative int, broadcastable with both: the dimension.

    Returns:
        float32 tensor of the broadcast shape, on ``seed``'s device, values in [0, 1).

    Not for: low-discrepancy integration (see :func:`bnerr.sequences.owen_sobol`); it is the
    baseline that every other sequence is compared against.
    """
    seed, index, dim = _prepare(seed, index, dim)
    return _to_unit(_white_words(_white_seed_index(seed, index), dim))


def _white_columns(seed: torch.Tensor, index: torch.Tensor, dim: int, out: torch.Tensor) -> None:
    """Write :func:`white` of dims ``dim .. dim + len(out) - 1`` into the rows of ``out``."""
    prefix = _white_seed_index(_words(seed, seed.device), _words(index, seed.device))
    for j, row in enumerate(out):
        _to_unit(_white_words(prefix, dim + j), out=row)


class WhiteSampler(Sampler):
    """Independent white noise per (seed, index, dim): :func:`white`, one hash per value."""

    name = "white"

    def _sample(self, seed, index, dim, count, pixel):
        out = _columns(seed.shape[0], count, seed.device)
        _white_columns(seed, index, dim, out)
        return out.T
