"""The base point sets an LDBN key set reads (``LDBNKeys.base``): what its keys act on.

Every base gives each dimension pair ``(2k, 2k + 1)`` a sequence of 24-bit words; a texel's
ranking key ``r < N`` (``N = 2^l``, the level's samples) reads index ``i XOR r``, so every
power-of-two prefix of a pixel is one aligned block of the base; the key does the rest:

- ``sobol`` (the shipped sets): one shared padded Owen-Sobol sequence (:func:`shared_words`);
  a key is a 24-bit *digital shift* per dimension (XOR). Each aligned block is a (0, m, 2)-net.
- ``lattice``: the rank-1 lattice with generator ``(1, G)`` over 2^24 points, in radical-inverse
  order: index i is the point ``(rev24(i), G rev24(i)) mod 2^24`` (:func:`lattice_words`), so the
  first 2^m indices are the 2^m-point lattice of generator ``(1, G mod 2^m)`` and every aligned
  block of them a rotated copy of it. A key is a 24-bit *rotation* per dimension (added modulo
  2^24: a Cranley-Patterson rotation, OpenQMC's ``latticebn`` rule over our own keys). ``G = 19``
  (:data:`LATTICE_GENERATOR`): among odd generators below 256 (only ``G mod 2^m`` matters at
  2^m points), it maximizes the smallest toroidal distance between points, times ``sqrt(N)``,
  over 8 to 64 points: 1.00 / 0.79 / 0.90 / 0.95 at 8 / 16 / 32 / 64 (OpenQMC's 364981: 1.00 /
  0.79 / 0.56 / 0.79); every 4-point rank-1 lattice lies on a diagonal (0.71).
- ``zorder``: one global shared Owen-Sobol sequence cut into chunks of N indices; a key is the
  *chunk* a texel reads (the pair's first scrambling channel; the second is 0): texel t reads
  indices ``key_t N + (i XOR r)`` and, past N samples, block b of N reads chunk
  ``b T^2 + key_t`` (:func:`zorder_index`). The chunks of a tile are a permutation, starting from
  the Morton order of the texels (ZSobol's arrangement: the texels of an aligned 2^j x 2^j block
  read together the first ``4^j N`` points of one (0, 2)-sequence), so neighbouring pixels read
  *different points of one low-discrepancy set* at every sample count, and each pixel alone is
  as stratified as a pixel of ``sobol``.

The optimizer (:mod:`bnerr.ldbn.keys`) tabulates a base over the indices a level reads
(:func:`base_table`) and evaluates key choices with :func:`keyed_words`; the sampler evaluates a
lane's words directly with :func:`base_words`. Not for: indices at or past 2^24 (the lattice
wraps there), frame axes (``zorder`` and ``lattice`` sets are screen tiles).
"""

from __future__ import annotations

import torch

from bnerr.errors import ValueRangeError
from bnerr.hashing import MASK32, reverse32
from bnerr.sequences.base import _columns
from bnerr.sequences.owen_sobol import _owen_sobol_columns

__all__ = [
    "BASES",
    "LATTICE_GENERATOR",
    "base_table",
    "base_words",
    "check_base",
    "keyed_words",
    "lattice_words",
    "morton_chunks",
    "shared_words",
    "zorder_index",
]

#: The base point sets a key set may read (module docstring).
BASES = ("sobol", "lattice", "zorder")
#: The lattice base's second generator component (module docstring).
LATTICE_GENERATOR = 19
_TWO_24 = 1 << 24
_MASK24 = _TWO_24 - 1


def check_base(base: object) -> str:
    """``base`` if it names a base point set (:data:`BASES`), else a ValueRangeError."""
    if base not in BASES:
        raise ValueRangeError(f"base: expected one of {list(BASES)}, got {base!r}")
    return str(base)


def shared_words(seed0: int, index: torch.Tensor, dim: int, count: int) -> torch.Tensor:
    """``[count, N]`` int32: the top 24 bits of ``owen_sobol(seed0, index, d)``, one row per d."""
    shared = torch.tensor(seed0 & MASK32, dtype=torch.int64, device=index.device)
    out = _columns(index.shape[0], count, index.device)
    _owen_sobol_columns(shared, index, dim, out)
    # values are k * 2^-24 exactly, so the product is an exact integer
    return (out * _TWO_24).to(torch.int32)


def lattice_words(index: torch.Tensor, dim: int, count: int) -> torch.Tensor:
    """``[count, N]`` int32: the lattice base's words of dims ``dim .. dim + count - 1`` at the
    int64 ``index`` (modulo 2^24): ``rev24(i)`` in even dims, ``G rev24(i) mod 2^24`` in odd."""
    radical = reverse32(index & _MASK24) >> 8
    rows = [radical if d % 2 == 0 else (radical * LATTICE_GENERATOR) & _MASK24
            for d in range(dim, dim + count)]  # fmt: skip
    return torch.stack(rows).to(torch.int32)


def zorder_index(
    permuted: torch.Tensor, chunk: torch.Tensor, level: int, texels: int
) -> torch.Tensor:
    """The global index of the ``zorder`` base: ``(b T^2 + chunk) N + (i' mod N)`` with
    ``b = i' div N``, for the ranked indices ``i'`` and the texels' chunks (int64)."""
    n = 1 << level
    return ((permuted >> level) * texels + chunk) * n + (permuted & (n - 1))


def base_words(
    base: str,
    seed0: int,
    permuted: torch.Tensor,
    keys: torch.Tensor,
    dims: tuple[int, int],
    tile: tuple[int, int],
) -> torch.Tensor:
    """``[count, N]`` int32 words of dims ``first .. first + count - 1`` (``dims``), all in one
    pair, for lanes at ranked indices ``permuted`` [N] with their texels' scrambling keys
    ``keys [2, N]`` (the pair's two channels); ``tile`` is ``(level, T^2)``."""
    first, count = dims
    rows = keys[first % 2 : first % 2 + count]
    if base == "sobol":
        return shared_words(seed0, permuted, first, count) ^ rows
    if base == "lattice":
        return (lattice_words(permuted, first, count) + rows) & _MASK24
    return shared_words(seed0, zorder_index(permuted, keys[0].long(), *tile), first, count)


def base_table(base: str, seed0: int, pair: int, level: int, texels: int) -> torch.Tensor:
    """``[M, 2]`` int64 words of ``pair`` over the indices a level-``level`` tile of ``texels``
    texels reads in its first N samples (M = N, or ``texels N`` for ``zorder``)."""
    n = 1 << level
    index = torch.arange(n * texels if base == "zorder" else n)
    if base == "lattice":
        return lattice_words(index, 0, 2).T.long()
    return shared_words(seed0, index, 2 * pair, 2).T.long()


def keyed_words(
    base: str, table: torch.Tensor, indices: torch.Tensor, keys: torch.Tensor, n: int
) -> torch.Tensor:
    """``[K, m, 2]`` words of point sets: rows ``indices [K, m]`` (``< n``) of the
    :func:`base_table` read through one key pair ``keys [K, 2]`` each."""
    if base == "sobol":
        return table[indices] ^ keys[:, None, :]
    if base == "lattice":
        return (table[indices] + keys[:, None, :]) & _MASK24
    return table[keys[:, None, 0] * n + indices]


def morton_chunks(size: int) -> torch.Tensor:
    """``[T^2]`` int64: the Morton (Z-order) rank of each texel ``y T + x`` of a tile whose
    side is a power of two (the ``zorder`` base's starting arrangement)."""
    if size & (size - 1):
        raise ValueRangeError(f"size: expected a power of two for the zorder base, got {size}")
    coords = torch.arange(size)
    rank = torch.zeros(size, size, dtype=torch.int64)
    for bit in range(max(size.bit_length() - 1, 0)):
        rank |= ((coords[:, None] >> bit) & 1) << (2 * bit + 1)  # y
        rank |= ((coords[None, :] >> bit) & 1) << (2 * bit)  # x
    return rank.reshape(-1)
