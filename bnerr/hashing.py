"""32-bit integer hashes: the one home of every hash bnerr uses for seeds, keys and textures.

torch has almost no uint32 support, so 32-bit words are held in int32 tensors and read as
unsigned: multiplication wraps modulo 2^32 (two's complement on every torch backend, CPU vector
units and CUDA alike) and every right shift is masked to make it logical. Each hash has a tensor
form and a host form (a Python int in [0, 2^32)) that give the same bits; ``tests/test_hashing.py``
checks both against a plain-Python twin.

- :func:`lowbias32`: Chris Wellons' ``lowbias32``, a bijection of 32-bit words ("Prospecting for
  Hash Functions", 2018). Every sequence, strategy seed and procedural texture uses it.
- :func:`mix32_45d9f3b`: the ``0x45d9f3b`` multiply-xorshift mix on int64 tensors holding 32-bit
  values. Only the benchmark's reference seeds use it; it is kept (rather than replaced by
  lowbias32) because the committed references and every result measured against them depend on it.
- :func:`reverse32`: not a hash but the bit reversal of 32-bit words on int64 tensors, which
  OpenQMC's samplers and the LDBN lattice base index by (the radical inverse in base 2).

Not for: cryptography.
"""

from __future__ import annotations

import torch

__all__ = [
    "MASK32",
    "lowbias32",
    "lowbias32_",
    "lowbias32_host",
    "mix32_45d9f3b",
    "reverse32",
    "signed32",
    "srl32",
]

#: The low 32 bits.
MASK32 = 0xFFFFFFFF
_LOWBIAS_M1, _LOWBIAS_M2 = 0x7FEB352D, 0x846CA68B


def signed32(value: int) -> int:
    """A Python int's low 32 bits as the int32 with the same bits (for int32 tensor arithmetic)."""
    value &= MASK32
    return value - (1 << 32) if value >= 1 << 31 else value


def srl32(x: torch.Tensor, k: int) -> torch.Tensor:
    """Logical right shift by ``k`` (1 <= k < 32) of int32 words read as unsigned."""
    return (x >> k) & ((1 << (32 - k)) - 1)


def lowbias32(x: torch.Tensor) -> torch.Tensor:
    """Wellons' ``lowbias32`` of int32 words read as unsigned; a new int32 tensor, same shape."""
    x = x ^ srl32(x, 16)
    x = x * signed32(_LOWBIAS_M1)
    x = x ^ srl32(x, 15)
    x = x * signed32(_LOWBIAS_M2)
    return x ^ srl32(x, 16)


def lowbias32_(x: torch.Tensor) -> torch.Tensor:
    """:func:`lowbias32` in place on an int32 tensor (half the memory traffic); returns ``x``."""
    x ^= srl32(x, 16)
    x *= signed32(_LOWBIAS_M1)
    x ^= srl32(x, 15)
    x *= signed32(_LOWBIAS_M2)
    x ^= srl32(x, 16)
    return x


def lowbias32_host(x: int) -> int:
    """:func:`lowbias32` of a Python int's low 32 bits, as an int in [0, 2^32)."""
    x &= MASK32
    x ^= x >> 16
    x = (x * _LOWBIAS_M1) & MASK32
    x ^= x >> 15
    x = (x * _LOWBIAS_M2) & MASK32
    return x ^ (x >> 16)


def mix32_45d9f3b(x: torch.Tensor) -> torch.Tensor:
    """The ``0x45d9f3b`` mix ``x = ((x >> 16) ^ x) * 0x45d9f3b`` (twice), then ``(x >> 16) ^ x``.

    Args:
        x: int64 tensor holding values in [0, 2^32).

    Returns:
        int64 tensor of the same shape, values in [0, 2^32).
    """
    x = (((x >> 16) ^ x) * 0x45D9F3B) & MASK32
    x = (((x >> 16) ^ x) * 0x45D9F3B) & MASK32
    return (x >> 16) ^ x


def reverse32(value: torch.Tensor) -> torch.Tensor:
    """The 32 bits of each word (int64 tensor, values in [0, 2^32)) in reverse order."""
    for shift, mask in ((1, 0x55555555), (2, 0x33333333), (4, 0x0F0F0F0F), (8, 0x00FF00FF)):
        value = ((value >> shift) & mask) | ((value & mask) << shift)
    return ((value >> 16) | (value << 16)) & MASK32
