"""Temporal Z-order: ZSobol over the 3D Morton code of (x, y, t) (after tauray's ``sobol-z3``).

Where :mod:`~bnerr.sequences.zsobol` gives pixel (x, y) the block of ``Morton2(x, y)``, this
gives pixel (x, y) in frame t the block of ``Morton3(x, y, t)`` (bit k of x to bit 3k, of y to
3k + 1, of t to 3k + 2) of one global Sobol sequence::

    index = (Morton3(x, y, t mod F) << log2spp) | i          F = frames, a power of two

and scrambles it like pbrt scrambles its Morton index, with base-8 digits: each 3-bit digit
(one bit each of x, y and t) goes through one of the 8! permutations of {0..7} (lexicographic
order), chosen by ``(MixBits(prefix ^ salt) >> 24) mod 40320`` with ``prefix`` the unpermuted
bits above the digit and ``salt = u32(0x55555555 * dimension) ^ (t div F) << 32``; the
``log2spp`` sample bits below get a binary nested scramble (bit b flipped by
``MixBits((index >> (b + 1)) ^ salt) & 1``). The value scramble is pbrt's FastOwen keyed by
``Hash(dimension + 2, seed)``, and the dimension layout is ZSobol's (pair k is a 2D call at
dimension 2k). tauray draws the digit permutations with ``pcg2d`` and decodes them in its own
order; this module keeps pbrt's hash, so it is tauray's structure, not its bits.

What it gives: each (pixel, frame) takes an aligned block of ``2^log2spp`` indices (a
(0, log2spp, 2)-net per pixel and frame, like ZSobol), and every aligned block of 2^j x 2^j
pixels over 2^j frames an aligned block of ``8^j spp`` indices (a net of that size). Consecutive
frames of one pixel take neighbouring blocks of the sequence (they differ in the lowest t bit),
so temporal accumulation over a small space-time neighbourhood integrates one larger net. A
single pixel's points over several frames are not one block (the x and y bits sit between its
t bits), so they are not a net (measured in ``tests/test_zsobol_t.py``). Frames ``t`` and
``t + F`` re-scramble differently (the ``t div F`` salt), as tauray re-scrambles every 1024.

The frame reaches the sampler as a construction option: a strategy builds its sampler for each
frame (``make_sampler("zsobol_t", ..., frame=t)`` or :meth:`ZSobolTSampler.at_frame`). The lane's
``seed`` is the pixel's 2D Morton key, as for ZSobol (:func:`~bnerr.sequences.zsobol_keys`), so a
permutation of keys between pixels moves their space-time sequences.

Not for: more than 52 index bits (``3 max(log2 R, log2 F) + log2spp <= 52``, pbrt's Sobol
columns); bit-exact agreement with tauray.
"""

from __future__ import annotations

import itertools

import torch

from bnerr.errors import ValueRangeError, check_positive_int
from bnerr.hashing import MASK32
from bnerr.native import SelfCheckedKernels
from bnerr.sequences import native
from bnerr.sequences.base import Sampler, _check_index_below, _columns
from bnerr.sequences.zsobol import (
    _SALT,
    _check_lanes,
    _check_seed,
    _Layout,
    _mix_bits,
    _pair_seeds,
    _randomize,
    _reversed_sobol,
    _scramble_seeds,
    _srl64,
    _to_float,
)

__all__ = ["ZSobolTSampler", "morton3"]

_PERM8_COUNT = 40320
_PERM8_TABLES: dict[torch.device, torch.Tensor] = {}
_PERM8_BYTES: list[torch.Tensor] = []


def _perm8_table(device: torch.device) -> torch.Tensor:
    """All 8! permutations of {0..7} in lexicographic order, flat: ``[p * 8 + digit]``, int64."""
    if device not in _PERM8_TABLES:
        rows = list(itertools.permutations(range(8)))
        _PERM8_TABLES[device] = torch.tensor(rows, dtype=torch.int64).reshape(-1).to(device)
    return _PERM8_TABLES[device]


def _perm8_bytes() -> torch.Tensor:
    """:func:`_perm8_table` on the CPU as uint8, for the native kernel (built once)."""
    if not _PERM8_BYTES:
        _PERM8_BYTES.append(_perm8_table(torch.device("cpu")).to(torch.uint8))
    return _PERM8_BYTES[0]


def _compact2(v: torch.Tensor) -> torch.Tensor:
    """The even bits of ``v`` (< 2^62) packed: the inverse of spreading to bit 2k."""
    v = v & 0x5555555555555555
    v = (v | (v >> 1)) & 0x3333333333333333
    v = (v | (v >> 2)) & 0x0F0F0F0F0F0F0F0F
    v = (v | (v >> 4)) & 0x00FF00FF00FF00FF
    v = (v | (v >> 8)) & 0x0000FFFF0000FFFF
    return (v | (v >> 16)) & 0xFFFFFFFF


def _spread3(v: torch.Tensor) -> torch.Tensor:
    """Bit k of ``v`` (< 2^21) moved to bit 3k."""
    v = v & 0x1FFFFF
    v = (v | (v << 32)) & 0x1F00000000FFFF
    v = (v | (v << 16)) & 0x1F0000FF0000FF
    v = (v | (v << 8)) & 0x100F00F00F00F00F
    v = (v | (v << 4)) & 0x10C30C30C30C30C3
    return (v | (v << 2)) & 0x1249249249249249


def morton3(x: torch.Tensor, y: torch.Tensor, t: torch.Tensor | int) -> torch.Tensor:
    """``Morton3(x, y, t)``: bit k of x, y, t to bits 3k, 3k + 1, 3k + 2 (values < 2^21)."""
    return _spread3(x) | (_spread3(y) << 1) | (_spread3(torch.as_tensor(t)) << 2)


def _scramble_index(index: torch.Tensor, salt: int, log2spp: int, n_digits: int) -> torch.Tensor:
    """Base-8 digit permutation above ``log2spp`` and a binary nested scramble below it."""
    perm = _perm8_table(index.device)
    out = torch.zeros_like(index)
    for j in range(n_digits - 1, -1, -1):
        shift = log2spp + 3 * j
        digit = (index >> shift) & 7
        p = _srl64(_mix_bits((index >> (shift + 3)) ^ salt), 24) % _PERM8_COUNT
        out |= perm.index_select(0, (p * 8 + digit).reshape(-1)).view(index.shape) << shift
    for b in range(log2spp - 1, -1, -1):
        flip = _mix_bits((index >> (b + 1)) ^ salt) & 1
        out |= (((index >> b) & 1) ^ flip) << b
    return out


class ZSobolTSampler(Sampler):
    """Temporal Z-order behind the sampler seam; the lane's ``seed`` is the pixel's Morton key.

    Args:
        width, height: the film (only the larger side matters, as for ZSobol).
        spp: samples per pixel per frame, a power of two.
        frame: the frame index t >= 0.
        frames: F, the power of two of frames the Morton code spans (default 1024).
        seed: the value scramble's int32 seed (low 32 bits).
    """

    name = "zsobol_t"

    def __init__(self, width: int, height: int, spp: int, frame: int = 0,
                 frames: int = 1024, seed: int = 0) -> None:  # fmt: skip
        self.layout = _Layout(width, height, spp)
        if self.layout.samples_per_pixel != spp:
            raise ValueRangeError(f"spp: expected a power of two, got {spp}")
        self.frame = check_positive_int(frame, "frame", minimum=0)
        self.frames = check_positive_int(frames, "frames")
        if frames & (frames - 1):
            raise ValueRangeError(f"frames: expected a power of two, got {frames}")
        self.seed = _check_seed(seed)
        self.n_digits = max(self.layout.log2r, frames.bit_length() - 1)
        if 3 * self.n_digits + self.layout.log2spp > 52:
            raise ValueRangeError(
                f"width, height, spp, frames: expected 3 max(log2 R, log2 F) + log2 spp <= 52 "
                f"index bits, got {3 * self.n_digits + self.layout.log2spp}"
            )

    def at_frame(self, frame: int) -> ZSobolTSampler:
        """The same sampler for frame ``frame``."""
        lay = self.layout
        return ZSobolTSampler(lay.width, lay.height, lay.spp, frame, self.frames, self.seed)

    def _index(self, seed: torch.Tensor, index: torch.Tensor) -> torch.Tensor:
        """The unscrambled global index ``(Morton3(x, y, t mod F) << log2spp) | i``."""
        key = seed & ((1 << (2 * self.layout.log2r)) - 1)
        t = self.frame % self.frames
        return (morton3(_compact2(key), _compact2(key >> 1), t) << self.layout.log2spp) | index

    def _epoch(self) -> int:
        """The salt bits above 32: ``(t div F) << 32``."""
        return ((self.frame // self.frames) & 0x7FFFFFFF) << 32

    def _sample(self, seed, index, dim, count, pixel):
        _check_index_below(index, self.layout.samples_per_pixel, f"{self.name} spp")
        out = _columns(seed.shape[0], count, seed.device)
        if not _native_words(self, (seed, index), dim, out):
            self._words_torch(self._index(seed, index), dim, out)
        return out.T

    def _words_torch(self, base: torch.Tensor, dim: int, out: torch.Tensor) -> None:
        """The torch path: every pair's values into the rows of ``out``."""
        end = dim + out.shape[0]
        for pair in range(dim // 2, (end - 1) // 2 + 1):
            salt = ((2 * pair * _SALT) & MASK32) ^ self._epoch()
            a = _scramble_index(base, salt, self.layout.log2spp, self.n_digits)
            seeds = _scramble_seeds(2 * pair + 2, self.seed)
            for c in (0, 1):
                if dim <= 2 * pair + c < end:
                    word = _randomize(_reversed_sobol(a, c), seeds[c], "fastowen")
                    out[2 * pair + c - dim] = _to_float(word)

    def __repr__(self) -> str:
        lay = self.layout
        return (
            f"ZSobolTSampler(width={lay.width}, height={lay.height}, spp={lay.spp}, "
            f"frame={self.frame}, frames={self.frames}, seed={self.seed})"
        )


def _native_words(
    sampler: ZSobolTSampler,
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
    seeds = _pair_seeds(dim, out.shape[0], sampler.seed)
    lay = sampler.layout
    digits = (lay.log2spp, sampler.n_digits, lay.log2r)
    frame = (sampler.frame % sampler.frames, sampler._epoch())
    return native.native_zsobol(kernels, lanes, dim, seeds, _perm8_bytes(), digits, out, frame)


def _self_check(kernels: native.SamplerKernels) -> bool:
    """The native kernel against the torch path for several films, frames (a later epoch
    included), spp and first dimensions: True if bit-identical."""
    gen = torch.Generator().manual_seed(43)
    for width, height, spp, frame, frames, dim, count in (
        (37, 21, 8, 5, 16, 0, 6), (300, 5, 1, 2**20 + 3, 1024, 3, 4), (1, 1, 4, 0, 1, 1, 2),
    ):  # fmt: skip
        sampler = ZSobolTSampler(width, height, spp, frame, frames, seed=-7)
        key, index = _check_lanes(height, width, spp, gen)
        want, got = (_columns(257, count, key.device) for _ in range(2))
        sampler._words_torch(sampler._index(key, index), dim, want)
        if not _native_words(sampler, (key, index), dim, got, kernels) or not torch.equal(
            got, want
        ):
            return False
    return True


#: The native kernels if they load and pass :func:`_self_check` (run once per library).
_native_kernels = SelfCheckedKernels(
    _self_check, "bnerr.sequences.zsobol_t: the native temporal Z-order kernel", native.LIBRARY
)
