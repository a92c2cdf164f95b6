"""LDBN (Heitz, Belcour, Ostromoukhov, Coeurjolly, Iehl 2019): one shared sequence read through
per-pixel ranking and scrambling keys, so that each pixel keeps a low-discrepancy sequence and
neighbouring pixels make different errors (docs/METHODS.md, section 10).

The lookup, for sample ``i`` of dimension ``d`` at pixel ``(y, x)`` with the keys of level ``l``
(the tile optimized for ``N = 2^l`` samples):

1. ``(ty, tx) = ((y + oy) mod T, (x + ox) mod T)``, the frame's toroidal offset ``(oy, ox)``;
2. ``i' = i XOR rank[l, ty, tx, d // 2]`` (one ranking key per dimension pair, ``< N``);
3. ``w = top24(owen_sobol(seed0, i', d))``, the shared padded Owen-Sobol sequence as a 24-bit word;
4. ``v = (w XOR scramble[l, ty, tx, d]) * 2^-24``: a digital shift at full float32 precision.

Why padded Owen-Sobol pairs and not the authors' true Sobol table: every pair ``(2k, 2k+1)`` of
the shared sequence is a (0, 2)-sequence, so the first 2^m samples of every pair form a (0, m, 2)-
net. A ranking key ``< N`` maps the first 2^m indices (``2^m <= N``) onto one aligned block of
2^m indices, itself a (0, m, 2)-net; XOR by a constant word is a digital shift, which keeps every
elementary interval's count. So every power-of-two prefix of every pixel is stratified in every
pair, the property the authors' table lacks beyond dims (0, 1) (docs/METHODS.md, section 10,
measures it against a rank-1 lattice).

Rules beyond the tiles:

- **Level.** ``spp`` selects the smallest level with ``2^l >= spp``, or the largest level.
- **Past the tile's spp** (``i >= 2^l``): the same XOR; since the key is ``< 2^l`` it permutes
  every aligned block of ``2^l`` indices within itself, so every power-of-two prefix stays one
  aligned block (stratified), and blocks after the first are not optimized.
- **Past the optimized dimensions** (``d >= D``): the pixel's own Owen-Sobol sequence,
  ``owen_sobol(seed_p, i, d)`` with the lane's seed, like ``white`` (no blue noise designed there,
  nothing worse than the baseline either).

On the CPU the lookup runs in the native sampler kernel (:mod:`bnerr.sequences.native`), which
writes the same bits as the torch path here when it loads and passes its self-check; the torch
path serves CUDA and machines without a C compiler.

Not for: odd ``D`` (the keys come in pairs), or keys optimized for another shared sequence: keys
only work with the point set (``seed0``) they were optimized for.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from bnerr.errors import (
    DtypeError,
    ShapeError,
    ValueRangeError,
    check_dtype,
    check_offset,
    check_positive_int,
    check_shape,
    check_tensor,
)
from bnerr.hashing import MASK32
from bnerr.native import SelfCheckedKernels
from bnerr.sequences import native
from bnerr.sequences.base import Sampler, _columns, _to_unit
from bnerr.sequences.ldbn_bases import base_words, check_base, shared_words
from bnerr.sequences.owen_sobol import _owen_sobol_columns, _pair_keys, _seeded_pair_keys

__all__ = [
    "LDBNKeyedSampler",
    "LDBNKeys",
    "LDBNSampler",
    "ldbn_key_image",
    "ldbn_level",
    "shared_words",
]

_TWO_24 = 1 << 24
# The shared-sequence table is built over the indices 0 .. M - 1 when M is at most this (else
# each lane is evaluated directly): 2^16 indices x 8 dims is 2 MB.
_TABLE_LIMIT = 1 << 16


@dataclass(frozen=True)
class LDBNKeys:
    """The key tiles of one LDBN sampler.

    Attributes:
        scramble: ``[L, T, T, D]`` int32, the scrambling keys (24-bit words, ``[0, 2^24)``) of
            level ``l`` (tile optimized for ``2^l`` samples), pixel ``(y, x)``, dimension ``d``.
        rank: ``[L, T, T, D // 2]`` int32, the ranking keys, ``rank[l] < 2^l``, one per pair.
        seed0: the seed of the shared Owen-Sobol sequence the keys were optimized for.
        base: the base point set the keys act on (:mod:`bnerr.sequences.ldbn_bases`):
            ``sobol`` (digital shifts, the shipped sets), ``lattice`` (rotations of a rank-1
            lattice) or ``zorder`` (chunks of one global sequence, the chunk in each pair's
            first channel).
    """

    scramble: torch.Tensor
    rank: torch.Tensor
    seed0: int = 0
    base: str = "sobol"

    def __post_init__(self) -> None:
        size = check_shape(self.scramble, "L T T D", "scramble")
        check_dtype(self.scramble, torch.int32, "scramble")
        check_shape(self.rank, "L T T *", "rank")
        check_dtype(self.rank, torch.int32, "rank")
        if size["D"] % 2 or size["D"] < 2:
            raise ShapeError(f"scramble: expected an even number of dims D >= 2, got {size['D']}")
        if self.rank.shape != (size["L"], size["T"], size["T"], size["D"] // 2):
            raise ShapeError(
                f"rank: expected shape {[size['L'], size['T'], size['T'], size['D'] // 2]} "
                f"(one key per pair), got {list(self.rank.shape)}"
            )
        if isinstance(self.seed0, bool) or not isinstance(self.seed0, int):
            raise DtypeError(f"seed0: expected an int, got {type(self.seed0).__name__}")
        check_base(self.base)
        _check_key_ranges(self.scramble, self.rank)
        if self.base == "zorder" and self.scramble.numel():
            chunks, texels = self.scramble[..., 0::2], size["T"] * size["T"]
            if int(chunks.max()) >= texels or bool(self.scramble[..., 1::2].any()):
                raise ValueRangeError(
                    f"scramble: expected zorder chunks in [0, {texels}) in each pair's first "
                    f"channel and 0 in its second, got chunks up to {int(chunks.max())}"
                )

    @property
    def levels(self) -> int:
        return self.scramble.shape[0]

    @property
    def size(self) -> int:
        return self.scramble.shape[1]

    @property
    def dims(self) -> int:
        return self.scramble.shape[3]


def _check_key_ranges(scramble: torch.Tensor, rank: torch.Tensor) -> None:
    if scramble.numel() and (int(scramble.min()) < 0 or int(scramble.max()) >= _TWO_24):
        raise ValueRangeError("scramble: expected 24-bit words in [0, 2^24)")
    for level in range(rank.shape[0]):
        r = rank[level]
        if r.numel() and (int(r.min()) < 0 or int(r.max()) >= 1 << level):
            raise ValueRangeError(
                f"rank: expected level {level}'s keys in [0, {1 << level}), "
                f"got min {int(r.min())} max {int(r.max())}"
            )


def ldbn_level(spp: int, levels: int) -> int:
    """The level the sampler reads for ``spp`` samples: the smallest ``l < levels`` with
    ``2^l >= spp``, else the last one."""
    spp = check_positive_int(spp, "spp")
    levels = check_positive_int(levels, "levels")
    return min((spp - 1).bit_length(), levels - 1)


class LDBNSampler(Sampler):
    """The LDBN lookup (module docstring): shared Owen-Sobol read through per-pixel keys.

    Args:
        keys: the key tiles (:class:`LDBNKeys`).
        spp: the frame's samples per pixel; selects the level (:func:`ldbn_level`).
        offset: the frame's toroidal offset ``(oy, ox)`` of the tiles.

    The lane's ``seed`` is read only past the optimized dimensions (``d >= D``).
    """

    name = "ldbn"
    needs_pixel = True

    def __init__(self, keys: LDBNKeys, spp: int = 1, offset: tuple[int, int] = (0, 0)) -> None:
        if not isinstance(keys, LDBNKeys):
            raise DtypeError(f"keys: expected LDBNKeys, got {type(keys).__name__}")
        self.keys = keys
        self.spp = check_positive_int(spp, "spp")
        self.level = ldbn_level(self.spp, keys.levels)
        oy, ox = check_offset(offset)
        self.offset = (oy % keys.size, ox % keys.size)
        tile = keys.size * keys.size
        # the native kernel's texel-major tiles [T, T, D] and [T, T, D / 2] (one lane's keys
        # together), the torch path's dimension-major flat ones [D, T * T] and [P, T * T]
        self._tiles = (keys.scramble[self.level].contiguous(), keys.rank[self.level].contiguous())
        self._scramble = keys.scramble[self.level].reshape(tile, -1).T.contiguous()
        self._rank = keys.rank[self.level].reshape(tile, -1).T.to(torch.int64).contiguous()

    def _sample(self, seed, index, dim, count, pixel):
        out = _columns(seed.shape[0], count, seed.device)
        if not _native_values(self, (seed, index, pixel), dim, out):
            self._values_torch(seed, index, dim, pixel, out)
        return out.T

    def _values_torch(
        self,
        seed: torch.Tensor,
        index: torch.Tensor,
        dim: int,
        pixel: torch.Tensor,
        out: torch.Tensor,
    ) -> None:
        """The torch path: the keyed dimensions pair by pair, then the lane's own Owen-Sobol."""
        count = out.shape[0]
        keyed = max(min(dim + count, self.keys.dims) - dim, 0)
        if keyed:
            flat = self._texels(pixel)
            self._keyed(index, flat, dim, out[:keyed])
        if keyed < count:
            _owen_sobol_columns(seed, index, dim + keyed, out[keyed:])

    def _texels(self, pixel: torch.Tensor) -> torch.Tensor:
        size = self.keys.size
        y = (pixel[:, 0] + self.offset[0]) % size
        x = (pixel[:, 1] + self.offset[1]) % size
        return y * size + x

    def _keyed(self, index: torch.Tensor, flat: torch.Tensor, dim: int, out: torch.Tensor) -> None:
        """Write the keyed dimensions ``dim .. dim + len(out) - 1`` into the rows of ``out``."""
        device = index.device
        scramble, rank = (t.to(device) for t in (self._scramble, self._rank))
        end = dim + out.shape[0]
        table = self._table(index, end, device) if self.keys.base == "sobol" else None
        for pair in range(dim // 2, (end - 1) // 2 + 1):
            first = max(2 * pair, dim)
            count = min(2 * pair + 2, end) - first
            permuted = index ^ rank[pair].index_select(0, flat)
            keys = scramble[2 * pair : 2 * pair + 2].index_select(1, flat)
            if table is not None:
                words = table[first : first + count].index_select(1, permuted)
                words = words ^ keys[first % 2 : first % 2 + count]
            else:
                tile = (self.level, self.keys.size * self.keys.size)
                words = base_words(
                    self.keys.base, self.keys.seed0, permuted, keys, (first, count), tile
                )
            _to_unit(words, out=out[first - dim : first - dim + count])

    def _table(self, index: torch.Tensor, end: int, device: torch.device) -> torch.Tensor | None:
        """The shared words of dims ``0 .. end - 1`` over indices ``0 .. M - 1``, M the power of
        two above every index (and at least the level's block), or None when M is too large."""
        if not index.numel():
            return None
        lo, hi = (int(v) for v in torch.aminmax(index))
        span = 1 << max(hi.bit_length(), self.level)
        if lo < 0 or span > max(_TABLE_LIMIT, index.shape[0]):
            return None
        indices = torch.arange(span, dtype=torch.int64, device=device)
        return shared_words(self.keys.seed0, indices, 0, end)

    def __repr__(self) -> str:
        k = self.keys
        return (
            f"LDBNSampler(keys=[{k.levels}, {k.size}, {k.size}, {k.dims}], spp={self.spp}, "
            f"offset={self.offset}, seed0={k.seed0}"
            + ("" if k.base == "sobol" else f", base={k.base!r}")
            + ")"
        )


def ldbn_key_image(
    seeds: torch.Tensor, size: int, offset: tuple[int, int] = (0, 0)
) -> torch.Tensor:
    """The seed image of :class:`LDBNKeyedSampler`: ``seeds * T^2 + k`` (int64 ``[H, W]``).

    ``k = ty * T + tx`` is the texel :class:`LDBNSampler` reads at pixel ``(y, x)`` with
    ``offset``, and ``seeds`` the lanes' own seeds (int64 in ``[0, 2^32)``, e.g.
    :func:`bnerr.strategies.pixel_seeds`), so that the keyed sampler renders this image exactly
    as :class:`LDBNSampler` renders ``seeds`` at ``offset``. For T = 64: ``seed << 12 | k``.
    """
    seeds = check_tensor(seeds, "seeds")
    check_shape(seeds, "H W", "seeds")
    check_dtype(seeds, torch.int64, "seeds")
    size = check_positive_int(size, "size")
    if seeds.numel() and (int(seeds.min()) < 0 or int(seeds.max()) > MASK32):
        raise ValueRangeError(
            f"seeds: expected 32-bit seeds in [0, 2^32), got min {int(seeds.min())} "
            f"max {int(seeds.max())}"
        )
    oy, ox = check_offset(offset)
    height, width = seeds.shape
    y = (torch.arange(height, device=seeds.device) + oy) % size
    x = (torch.arange(width, device=seeds.device) + ox) % size
    return seeds * (size * size) + (y[:, None] * size + x[None, :])


class LDBNKeyedSampler(LDBNSampler):
    """The LDBN lookup with the texel read from the lane's seed instead of its pixel.

    The seed is ``s = u * T^2 + k`` (:func:`ldbn_key_image`): ``k = ty * T + tx`` says which
    texel's ranking and scrambling keys the lane reads, ``u`` is the lane's own seed, read past
    the optimized dimensions as :class:`LDBNSampler` reads its seed. So a strategy that moves
    seeds between pixels (the temporal permutation of ``temporal_ldbn``) moves each texel's keys,
    and the whole sample sequence they make, with them; at rest, the image of
    :func:`ldbn_key_image` renders exactly as :class:`LDBNSampler` at the same offset. There is
    no frame offset here: where a key lands is the strategy's business.

    Args:
        keys: the key tiles (:class:`LDBNKeys`).
        spp: the frame's samples per pixel; selects the level (:func:`ldbn_level`).
    """

    name = "ldbn_keyed"
    needs_pixel = False

    def __init__(self, keys: LDBNKeys, spp: int = 1) -> None:
        super().__init__(keys, spp)

    def _sample(self, seed, index, dim, count, pixel):
        # The texel as the pixel that reads it at offset (0, 0): both paths then run unchanged.
        size = self.keys.size
        texel = seed % (size * size)
        return super()._sample(seed // (size * size), index, dim, count, _texel_pixels(texel, size))

    def __repr__(self) -> str:
        k = self.keys
        return (
            f"LDBNKeyedSampler(keys=[{k.levels}, {k.size}, {k.size}, {k.dims}], spp={self.spp}, "
            f"seed0={k.seed0})"
        )


def _texel_pixels(texel: torch.Tensor, size: int) -> torch.Tensor:
    """``[N, 2]`` pixels ``(k // T, k % T)`` that read the flat texels ``k`` at offset (0, 0)."""
    return torch.stack((texel // size, texel % size), dim=1)


def _native_values(
    sampler: LDBNSampler,
    lanes: tuple[torch.Tensor, torch.Tensor, torch.Tensor],
    dim: int,
    out: torch.Tensor,
    kernels: native.SamplerKernels | None = None,
) -> bool:
    """The lookup of the lanes' (seed, index, pixel) in C into ``out``; False when the native
    path does not apply."""
    if sampler.keys.base != "sobol":
        return False  # the C kernel reads the sobol base only
    kernels = native.kernels_for(lanes, out, kernels, _native_kernels)
    if kernels is None:
        return False
    count = out.shape[0]
    scramble, rank = (t.to(out.device) for t in sampler._tiles)
    table = None
    if dim < sampler.keys.dims:  # the keyed pairs' dims, whole pairs
        end = min(dim + count + (dim + count) % 2, sampler.keys.dims)
        table = sampler._table(lanes[1], end, out.device)
    tiles = (scramble, rank, None if table is None else table.T.contiguous())
    hashes = (_seeded_pair_keys(sampler.keys.seed0, dim, count), _pair_keys(dim, count))
    return native.native_ldbn(kernels, lanes, dim, tiles, sampler.offset, hashes, out)


def _check_sampler(gen: torch.Generator) -> LDBNSampler:
    """Random keys of an odd tile (5 x 5, 3 levels, 4 dims) and seed0 above 32 bits, read at an
    offset and a level below the last."""
    scramble = torch.randint(0, _TWO_24, (3, 5, 5, 4), generator=gen, dtype=torch.int32)
    rank = torch.stack([torch.randint(0, 1 << lv, (5, 5, 2), generator=gen) for lv in range(3)])
    keys = LDBNKeys(scramble, rank.to(torch.int32), seed0=-(2**33) + 5)
    return LDBNSampler(keys, spp=3, offset=(2, 4))


def _self_check(kernels: native.SamplerKernels) -> bool:
    """The native kernel against the torch path: pixels negative and off the tile, indices in
    the shared table's range (with a table of a pair cut by the dims asked), past it and
    negative, first dimensions inside, across and past the keys: True if bit-identical."""
    gen = torch.Generator().manual_seed(59)
    sampler = _check_sampler(gen)
    seed = torch.randint(-(2**40), 2**40, (211,), generator=gen)
    pixel = torch.randint(-300, 300, (211, 2), generator=gen)
    for low, high, dim, count in ((0, 8, 0, 6), (0, 16, 1, 2), (-(2**33), 2**33, 1, 2),
                                  (0, 2**20, 3, 4), (0, 4, 5, 1)):  # fmt: skip
        index = torch.randint(low, high, (211,), generator=gen)
        want, got = (_columns(211, count, seed.device) for _ in range(2))
        sampler._values_torch(seed, index, dim, pixel, want)
        ok = _native_values(sampler, (seed, index, pixel), dim, got, kernels)
        if not ok or not torch.equal(got, want):
            return False
    return True


#: The native kernels if they load and pass :func:`_self_check` (run once per library).
_native_kernels = SelfCheckedKernels(
    _self_check, "bnerr.sequences.ldbn: the native LDBN kernel", native.LIBRARY
)
