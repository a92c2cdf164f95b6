"""Blender Cycles 4.2's blue-noise sampling patterns over our Owen-scrambled Sobol.

Cycles (src/kernel/sample/pattern.h, ``blue_noise_indexing`` and ``path_rng_pixel_init``) gives
every pixel a key ``k = nested_uniform_scramble_base4(morton2d(x, y), hash(seed))``: the pixel's
Morton code (Cycles puts x in the odd bits) through a base-4 Owen scramble, a hash that permutes
the two bits of each base-4 digit together, prefix by prefix (Vegdahl 2022, "A fast hash for
base-4 Owen scrambling"). Pixels in an aligned 2^j x 2^j block have keys in an aligned block of
4^j keys, in a random order. Then (docs/METHODS.md, section 7):

- ``BLUE_NOISE_PURE`` (:class:`CyclesPureSampler`): sample ``i`` of the pixel is index
  ``i + k * spp`` (mod 2^32) of one global sequence, so each pixel takes its own block and
  neighbouring pixels neighbouring blocks.
- ``BLUE_NOISE_FIRST`` (:class:`CyclesFirstSampler`): sample 0 is index ``k`` of a separate
  sequence (a 1-spp blue-noise pattern for the viewport), samples ``i >= 1`` are index
  ``(i - 1) + k * (spp - 1)`` of the global one.

The global sequence is our :func:`~bnerr.sequences.owen_sobol` with one seed for every pixel
(``seed0``; Cycles uses seed 0 and ``0x0cd0519f`` for the separate first-sample sequence, which
here is ``seed0 ^ 0x0cd0519f``). The user's seed enters only the keys, as in Cycles; Cycles
hashes it with its own ``hash_uint``, here with ``lowbias32``. With a non-power-of-two spp (or
any spp - 1 for FIRST) the pixels' blocks are not aligned and lose their nets, as in Cycles
(whose ``BLUE_NOISE_ROUND`` mode, not built here, rounds the length up).

The sampler seam: the lane's ``seed`` is the pixel's key (:func:`cycles_keys` builds the seed
image, low 32 bits used); ``pixel`` is ignored. A permutation of keys between pixels moves their
sample sequences.

Not for: bit-exact agreement with Cycles' own values (its Sobol-Burley differs from ours in the
hash constants and dimension padding); images wider than 2^16 pixels.
"""

from __future__ import annotations

import torch

from bnerr.errors import DtypeError, check_positive_int
from bnerr.hashing import MASK32, lowbias32_host, signed32
from bnerr.native import SelfCheckedKernels
from bnerr.sequences import native
from bnerr.sequences.base import Sampler, _check_index_below, _columns
from bnerr.sequences.owen_sobol import _owen_sobol_columns, _pair_keys
from bnerr.sequences.tables import _tables

__all__ = ["CyclesFirstSampler", "CyclesPureSampler", "cycles_keys", "morton2d_cycles"]

#: Cycles' seed of the separate 1-spp sequence of ``BLUE_NOISE_FIRST``.
FIRST_SEQUENCE_SALT = 0x0CD0519F
_BASE4_MULTIPLIERS = (0x3D20ADEA, 0x05526C56, 0x53A22864)
_PAIR_BITS = 0x55555555


def _expand_bits(v: torch.Tensor) -> torch.Tensor:
    """Cycles' ``expand_bits``: bit k of the low 16 bits moved to bit 2k."""
    v = v & 0xFFFF
    v = (v ^ (v << 8)) & 0x00FF00FF
    v = (v ^ (v << 4)) & 0x0F0F0F0F
    v = (v ^ (v << 2)) & 0x33333333
    return (v ^ (v << 1)) & 0x55555555


def morton2d_cycles(x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    """Cycles' ``morton2d(x, y) = (expand_bits(x) << 1) | expand_bits(y)`` (x in the odd bits).

    Args:
        x, y: int64 tensors (broadcastable); their low 16 bits are used.

    Returns:
        int64 tensor in [0, 2^32).
    """
    return (_expand_bits(x) << 1) | _expand_bits(y)


def _pair_carry(n: torch.Tensor) -> torch.Tensor:
    """``n ^ ((n >> 1) & (n << 1) & 0x55555555)`` on int32 words (the mask drops the sign fill)."""
    return n ^ ((n >> 1) & (n << 1) & signed32(_PAIR_BITS))


def _nested_uniform_scramble_base4(words: torch.Tensor, seed: int) -> torch.Tensor:
    """Cycles' ``nested_uniform_scramble_base4`` of int32 words with a host 32-bit seed."""
    tables = _tables(words.device)
    k1, k2, k3 = (signed32(c) for c in _BASE4_MULTIPLIERS)
    n = tables.reverse(words)
    n = _pair_carry(n ^ (n * k1))
    n = n + signed32(seed)
    n = _pair_carry(n * signed32((seed >> 16) | 1))
    n = n ^ (n * k2)
    return tables.reverse(n ^ (n * k3))


def cycles_keys(
    height: int, width: int, seed: int = 0, device: torch.device | str = "cpu"
) -> torch.Tensor:
    """The seed image of a Cycles blue-noise strategy: each pixel's scrambled Morton key.

    ``keys[y, x] = nested_uniform_scramble_base4(morton2d(x, y), lowbias32(seed))``.

    Returns:
        int64 ``[height, width]`` with values in [0, 2^32), on ``device``.
    """
    check_positive_int(height, "height")
    check_positive_int(width, "width")
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise DtypeError(f"seed: expected an int, got {type(seed).__name__} {seed!r}")
    y, x = torch.meshgrid(
        torch.arange(height, device=device), torch.arange(width, device=device), indexing="ij"
    )
    words = morton2d_cycles(x, y).to(torch.int32)
    scrambled = _nested_uniform_scramble_base4(words, lowbias32_host(seed))
    return scrambled.to(torch.int64) & MASK32


class _CyclesSampler(Sampler):
    """Shared part of the two patterns: the key's block of the global sequence."""

    first = False

    def __init__(self, spp: int, seed0: int = 0) -> None:
        self.spp = check_positive_int(spp, "spp")
        if isinstance(seed0, bool) or not isinstance(seed0, int):
            raise DtypeError(f"seed0: expected an int, got {type(seed0).__name__} {seed0!r}")
        self.seed0 = seed0

    def _indices(self, key: torch.Tensor, index: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Per lane: (sequence seed, index in that sequence), int64 ``[N]`` each."""
        seed = torch.full_like(key, self.seed0 & MASK32)
        if not self.first:
            return seed, (index + key * self.spp) & MASK32
        length = self.spp - 1
        later = ((index - 1) + key * length) & MASK32
        is_first = index == 0
        seed = torch.where(is_first, (self.seed0 ^ FIRST_SEQUENCE_SALT) & MASK32, seed)
        return seed, torch.where(is_first, key, later)

    def _sample(self, seed, index, dim, count, pixel):
        _check_index_below(index, self.spp, f"{self.name} spp")
        out = _columns(seed.shape[0], count, seed.device)
        if not _native_values(self, (seed, index), dim, out):
            self._values_torch(seed, index, dim, out)
        return out.T

    def _values_torch(self, seed, index, dim, out):
        """The torch path: the lanes' indices, then :func:`_owen_sobol_columns`."""
        sequence_seed, sequence_index = self._indices(seed & MASK32, index)
        _owen_sobol_columns(sequence_seed, sequence_index, dim, out)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(spp={self.spp}, seed0={self.seed0})"


class CyclesPureSampler(_CyclesSampler):
    """Cycles' ``BLUE_NOISE_PURE``: sample i of key k is index ``i + k spp`` of one sequence.

    Args:
        spp: samples per pixel (the length of each pixel's block).
        seed0: seed of the global Owen-Sobol sequence (Cycles: 0).
    """

    name = "cycles_pure"


class CyclesFirstSampler(_CyclesSampler):
    """Cycles' ``BLUE_NOISE_FIRST``: sample 0 from a separate 1-spp sequence, then PURE's rule
    with blocks of ``spp - 1``.

    Args:
        spp: samples per pixel.
        seed0: seed of the global sequence; the first-sample sequence uses ``seed0 ^ 0x0cd0519f``.
    """

    name = "cycles_first"
    first = True


def _native_values(
    sampler: _CyclesSampler,
    lanes: tuple[torch.Tensor, torch.Tensor],
    dim: int,
    out: torch.Tensor,
    kernels: native.SamplerKernels | None = None,
) -> bool:
    """The values of the lanes' (key, index) in C into ``out``; False when the native path does
    not apply."""
    kernels = native.kernels_for(lanes, out, kernels, _native_kernels)
    if kernels is None:
        return False
    first_seed = sampler.seed0 ^ FIRST_SEQUENCE_SALT
    pattern = (sampler.spp, sampler.first, sampler.seed0, first_seed)
    keys = _pair_keys(dim, out.shape[0])
    return native.native_cycles(kernels, lanes, dim, pattern, keys, out)


def _self_check(kernels: native.SamplerKernels) -> bool:
    """The native kernel against the torch path for both patterns, spp 1 and odd spp, odd first
    dimensions, negative seeds and keys above 32 bits: True if bit-identical."""
    gen = torch.Generator().manual_seed(47)
    key = torch.randint(-(2**40), 2**40, (257,), generator=gen)
    for sampler_type, spp, seed0, dim, count in (
        (CyclesPureSampler, 16, 0, 0, 6), (CyclesFirstSampler, 5, -9, 3, 4),
        (CyclesFirstSampler, 1, 7, 1, 1), (CyclesPureSampler, 3, 2**31, 2, 3),
    ):  # fmt: skip
        sampler = sampler_type(spp, seed0)
        index = torch.randint(0, spp, (257,), generator=gen)
        want, got = (_columns(257, count, key.device) for _ in range(2))
        sampler._values_torch(key, index, dim, want)
        if not _native_values(sampler, (key, index), dim, got, kernels) or not torch.equal(
            got, want
        ):
            return False
    return True


#: The native kernels if they load and pass :func:`_self_check` (run once per library).
_native_kernels = SelfCheckedKernels(
    _self_check, "bnerr.sequences.cycles: the native Cycles kernel", native.LIBRARY
)
