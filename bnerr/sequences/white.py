"""White noise: a counter-based hash of (seed, index, dim), the baseline every sequence beats."""

from __future__ import annotations

import torch

from bnerr.hashing import lowbias32, lowbias32_host, signed32, srl32
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
    """Write :func:`white` of dims ``dim .. dim + len(out) - 1`` into the rows of ``out``.

    On the CPU the native kernel (:mod:`bnerr.sequences.native`) writes the same bits when it
    loads and passes its self-check (measured: the torch path was 14 % of a Cornell box render,
    one pass over the lanes per operation); else :func:`_white_columns_torch`.
    """
    kernels = native.kernels_for((seed, index), out, None, _native_kernels)
    if kernels is not None and out.is_contiguous():
        keys = _dim_keys(dim, out.shape[0])
        if native.native_seeded(kernels.white, seed, index, dim, keys, out):
            return
    _white_columns_torch(seed, index, dim, out)


def _dim_keys(dim: int, count: int) -> list[int]:
    """The host hash of every dimension ``dim .. dim + count - 1`` (the kernel's keys)."""
    return [lowbias32_host(d ^ _SALT_WHITE_DIM) for d in range(dim, dim + count)]


def _white_columns_torch(
    seed: torch.Tensor, index: torch.Tensor, dim: int, out: torch.Tensor
) -> None:
    """The torch path of :func:`_white_columns`: the (seed, index) hash once, one per row."""
    prefix = _white_seed_index(_words(seed, seed.device), _words(index, seed.device))
    for j, row in enumerate(out):
        _to_unit(_white_words(prefix, dim + j), out=row)


def _self_check(kernels: native.SamplerKernels) -> bool:
    """The native kernel against the torch path on random lanes (more than one block), a shared
    0-dim seed, extreme words and high dimensions: True if bit-identical."""
    cases = ((0, 8), (5, 3), (2**31, 2))
    return native.seeded_self_check(kernels.white, _white_columns_torch, _dim_keys, cases, 1301, 89)


#: The native kernels if they load and pass :func:`_self_check` (run once per library).
_native_kernels = SelfCheckedKernels(
    _self_check, "bnerr.sequences.white: the native white-noise kernel", native.LIBRARY
)


class WhiteSampler(Sampler):
    """Independent white noise per (seed, index, dim): :func:`white`, one hash per value."""

    name = "white"

    def _sample(self, seed, index, dim, count, pixel):
        out = _columns(seed.shape[0], count, seed.device)
        _white_columns(seed, index, dim, out)
        return out.T
