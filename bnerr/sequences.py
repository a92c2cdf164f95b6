"""Sample sequences: the only source of random numbers the renderer sees (METHODS.md section 3).

A sequence is a deterministic function ``X(seed, index, dim) -> [0, 1)`` of a pixel's seed, the
sample index ``i < spp`` and the integrand dimension ``d``. The renderer asks a :class:`Sampler`
for ``count`` consecutive dimensions of many (seed, index) lanes at once and never calls
``torch.rand`` (STYLE.md habit 5; Mitsuba 3's ``Sampler.next_1d``, pbrt-v4's ``Get1D``/``Get2D``).

Three sequences:

- :func:`white` / :class:`WhiteSampler`: a counter-based hash, the white-noise baseline.
- :func:`owen_sobol` / :class:`OwenSobolSampler`: Owen-scrambled Sobol (Burley 2020), padded by
  2D pairs; the first 2^m samples of every pair ``(2k, 2k+1)`` form a (0, m, 2)-net.
- :class:`BNDSSampler`: blue-noise dithered sampling (Georgiev & Fajardo 2016), one Owen-Sobol
  sequence for the whole screen, Cranley-Patterson rotated per pixel by a vector mask.

Integer arithmetic. torch has almost no uint32 support, so 32-bit words are held in int32
tensors and read as unsigned: multiplication and addition wrap modulo 2^32 (two's complement, as
in every torch backend: CPU vector units and CUDA), and every right shift is masked to make it
logical. int32 instead of masked int64 halves memory traffic and saves the masks: on 2^20
words, one CPU thread, the lowbias32 hash took 4.2 ms instead of 10.1 ms and the Laine-Karras
step 3.8 ms instead of 13.3 ms. Table lookups use ``index_select`` (5x faster than ``table[x]``).
Every result is checked bit for bit against a
pure-Python reference in ``tests/test_sequences.py``, so a backend that did not wrap would be
caught there. Seeds, indices and dimensions use their low 32 bits (an index of 2^32 aliases
index 0; no renderer gets there).

Not for: cryptography, or anything that needs independent streams for more than 2^32 seeds.
"""

from __future__ import annotations

import torch

from bnerr.errors import (
    DtypeError,
    ShapeError,
    ValueRangeError,
    check_dtype,
    check_name,
    check_positive_int,
    check_shape,
    check_tensor,
)

__all__ = [
    "BNDSSampler",
    "ONE_MINUS_EPS",
    "OwenSobolSampler",
    "SAMPLERS",
    "Sampler",
    "WhiteSampler",
    "make_sampler",
    "owen_sobol",
    "white",
]

_MASK32 = 0xFFFFFFFF
_INV_2_24 = 1.0 / (1 << 24)
#: The largest float32 below 1 (1 - 2^-24): where a value must stay < 1 after float rounding.
ONE_MINUS_EPS = 1.0 - 2.0**-24

# Salts that separate the hash domains (white noise, the Sobol keys), so that no two sequences
# share a hash chain. Arbitrary odd 32-bit constants.
_SALT_WHITE_SEED = 0x9E3779B9
_SALT_WHITE_DIM = 0x85EBCA6B
_SALT_SOBOL_SEED = 0xC2B2AE35
_SALT_SOBOL_KEY = 0x27D4EB2F

# Laine-Karras permutation constants (Burley 2020, Listing 2).
_LK_CONSTANTS = (0x6C50B47C, 0xB82F1E52, 0xC7AFE638, 0x8D22F6E6)

# Sobol direction numbers v_1 .. v_32 of dimension 1 (Joe & Kuo, "new-joe-kuo-6.21201", the
# primitive polynomial x + 1: s = 1, a = 0, m_1 = 1), i.e. the upper triangular Pascal matrix mod 2.
# Dimension 0 is the van der Corput sequence (the bit reversal of the index).
_SOBOL_DIM1_S, _SOBOL_DIM1_A, _SOBOL_DIM1_M = 1, 0, (1,)


# ------------------------------------------------------------------------------------------------
# 32-bit word helpers (int32 tensors read as unsigned; Python ints in [0, 2^32) on the host)


def _signed(value: int) -> int:
    """A Python int in [0, 2^32) as the int32 with the same bits."""
    value &= _MASK32
    return value - (1 << 32) if value >= 1 << 31 else value


def _words(x: torch.Tensor | int, device: torch.device) -> torch.Tensor | int:
    """Low 32 bits of an int64 tensor (or int) as int32 (an int stays a host int in [0, 2^32))."""
    if isinstance(x, int):
        return x & _MASK32
    # int64 -> int32 keeps the low 32 bits (modular conversion on every torch backend).
    return x.to(device=device, dtype=torch.int32)


def _srl(x: torch.Tensor, k: int) -> torch.Tensor:
    """Logical right shift of int32 words read as unsigned."""
    return (x >> k) & ((1 << (32 - k)) - 1)


def _lowbias32(x: torch.Tensor) -> torch.Tensor:
    """Chris Wellons' ``lowbias32`` integer hash, a bijection of 32-bit words.

    Source: https://nullprogram.com/blog/2018/07/31/ ("Prospecting for Hash Functions").
    """
    x = x ^ _srl(x, 16)
    x = x * _signed(0x7FEB352D)
    x = x ^ _srl(x, 15)
    x = x * _signed(0x846CA68B)
    return x ^ _srl(x, 16)


def _lowbias32_host(x: int) -> int:
    """:func:`_lowbias32` on a Python int, for keys that are the same for every lane."""
    x &= _MASK32
    x ^= x >> 16
    x = (x * 0x7FEB352D) & _MASK32
    x ^= x >> 15
    x = (x * 0x846CA68B) & _MASK32
    return x ^ (x >> 16)


def _hash_small(value: torch.Tensor | int, salt: int) -> torch.Tensor | int:
    """``lowbias32(value ^ salt)`` of a host int (computed on the host) or an int32 tensor."""
    if isinstance(value, int):
        return _lowbias32_host(value ^ salt)
    return _lowbias32(value ^ _signed(salt))


def _xor_key(words: torch.Tensor, key: torch.Tensor | int) -> torch.Tensor:
    """``words ^ key`` where ``key`` is a host int in [0, 2^32) or an int32 tensor."""
    return words ^ (_signed(key) if isinstance(key, int) else key)


def _laine_karras(x: torch.Tensor, key: torch.Tensor) -> torch.Tensor:
    """Laine-Karras permutation of bit-reversed words (Burley 2020, Listing 2).

    Output bit j depends only on input bits <= j (an addition and multiplications by even
    constants carry upwards only), so in the reversed domain it is a nested uniform (Owen)
    scramble: the j-th most significant bit of the value is flipped by a function of the bits
    above it. That is what keeps the scrambled points a (0, m, 2)-net.
    """
    x = x + key
    for c in _LK_CONSTANTS:
        x = x ^ (x * _signed(c))
    return x


def _to_unit(top24: torch.Tensor, out: torch.Tensor | None = None) -> torch.Tensor:
    """A word < 2^24 as float32 ``top24 * 2^-24``: exact, and always < 1 (into ``out`` if given)."""
    if out is None:
        return top24.to(torch.float32) * _INV_2_24
    return torch.mul(top24, _INV_2_24, out=out)


def _columns(n: int, count: int, device: torch.device) -> torch.Tensor:
    """A ``[count, n]`` float32 buffer: dimension-major, so that each dimension is contiguous."""
    return torch.empty(count, n, dtype=torch.float32, device=device)


# ------------------------------------------------------------------------------------------------
# Tables (built once per device; every bit operation on a word is a linear map over GF(2) that
# a 2 x 16-bit or 2 x 12-bit table lookup evaluates: two gathers beat a 32-step loop by far)


def _reverse_bits_host(value: int, bits: int) -> int:
    return int(format(value, f"0{bits}b")[::-1], 2)


def _sobol_directions(s: int, a: int, m: tuple[int, ...]) -> list[int]:
    """Direction numbers ``v_1 .. v_32`` (as 32-bit words) of one Sobol dimension (Joe & Kuo 2008).

    ``v_k = m_k 2^(32-k)``; for k > s, ``v_k = v_(k-s) ^ (v_(k-s) >> s) ^ sum_j a_j v_(k-j)``.
    """
    v = [m_k << (31 - k) for k, m_k in enumerate(m)]
    for k in range(s, 32):
        word = v[k - s] ^ (v[k - s] >> s)
        for j in range(1, s):
            if (a >> (s - 1 - j)) & 1:
                word ^= v[k - j]
        v.append(word)
    return v


def _linear_table(columns: list[int], device: torch.device) -> torch.Tensor:
    """``T[v] = XOR of columns[b] over the set bits b of v``, as int32, ``[2^len(columns)]``."""
    v = torch.arange(1 << len(columns), dtype=torch.int64)
    table = torch.zeros_like(v)
    for bit, column in enumerate(columns):
        table ^= ((v >> bit) & 1) * column
    return torch.where(table >= 1 << 31, table - (1 << 32), table).to(device, torch.int32)


class _Tables:
    """The lookup tables of the Owen-Sobol evaluation, on one device.

    With ``y`` the shuffled index in the reversed domain (``i' = reverse(y)``), the reversed
    Sobol values are ``reverse(sobol_0(i')) = reverse(y)`` and ``reverse(sobol_1(i')) = P y``,
    both linear in the bits of ``y``: each is two lookups over the 16-bit halves.
    """

    def __init__(self, device: torch.device) -> None:
        # reverse(y): the low half goes to the high half reversed, and vice versa.
        rev_lo = [1 << (31 - b) for b in range(16)]
        rev_hi = [1 << (15 - b) for b in range(16)]
        self.rev_lo = _linear_table(rev_lo, device)
        self.rev_hi = _linear_table(rev_hi, device)
        # P y = reverse(sobol_1(reverse(y))): bit b of y is bit 31 - b of i', whose direction
        # number is v_(32 - b).
        v = _sobol_directions(_SOBOL_DIM1_S, _SOBOL_DIM1_A, _SOBOL_DIM1_M)
        columns = [_reverse_bits_host(v[31 - b], 32) for b in range(32)]
        self.sobol1_lo = _linear_table(columns[:16], device)
        self.sobol1_hi = _linear_table(columns[16:], device)
        # The top 24 bits of reverse(w) are the low 24 bits of w reversed.
        self.top_lo = _linear_table([1 << (23 - b) for b in range(12)], device)
        self.top_hi = _linear_table([1 << (11 - b) for b in range(12)], device)

    @staticmethod
    def _apply(lo: torch.Tensor, hi: torch.Tensor, x: torch.Tensor, bits: int) -> torch.Tensor:
        # index_select wants a 1-D index (and is several times faster than lo[x]).
        flat = x.reshape(-1)
        mask = (1 << bits) - 1
        out = lo.index_select(0, flat & mask) ^ hi.index_select(0, (flat >> bits) & mask)
        return out.view(x.shape)

    def reverse(self, x: torch.Tensor) -> torch.Tensor:
        return self._apply(self.rev_lo, self.rev_hi, x, 16)

    def sobol1(self, y: torch.Tensor) -> torch.Tensor:
        return self._apply(self.sobol1_lo, self.sobol1_hi, y, 16)

    def top24(self, w: torch.Tensor) -> torch.Tensor:
        """The top 24 bits of ``reverse(w)`` as a word < 2^24."""
        return self._apply(self.top_lo, self.top_hi, w, 12)


_TABLES: dict[torch.device, _Tables] = {}


def _tables(device: torch.device) -> _Tables:
    if device not in _TABLES:
        _TABLES[device] = _Tables(device)
    return _TABLES[device]


# ------------------------------------------------------------------------------------------------
# The sequences on words (private: callers have checked their input)


def _white_seed_index(seed: torch.Tensor, index: torch.Tensor) -> torch.Tensor:
    """The per-(seed, index) part of the white-noise hash chain."""
    return _lowbias32(_lowbias32(seed ^ _signed(_SALT_WHITE_SEED)) ^ index)


def _white_words(prefix: torch.Tensor, dim: torch.Tensor | int) -> torch.Tensor:
    """The top 24 bits of the white-noise hash of (prefix, dim)."""
    h = _lowbias32(_xor_key(prefix, _hash_small(dim, _SALT_WHITE_DIM)))
    return _srl(h, 8)


def _sobol_key(seed_hash: torch.Tensor, pair: torch.Tensor | int, role: int) -> torch.Tensor:
    """Key of a pair's index shuffle (role 2) or of its coordinate 0 or 1 (roles 0, 1)."""
    return _lowbias32(_xor_key(seed_hash, _hash_small(pair * 4 + role, _SALT_SOBOL_KEY)))


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
        key = torch.where(
            role == 0, _sobol_key(seed_hash, pair, 0), _sobol_key(seed_hash, pair, 1)
        )
    return tables.top24(_laine_karras(z, key))


# ------------------------------------------------------------------------------------------------
# Public functions


def _check_words(name: str, value: object) -> None:
    """An int64 tensor, or (for dimensions) a non-negative Python int."""
    if isinstance(value, int) and not isinstance(value, bool):
        if value < 0:
            raise ValueRangeError(f"{name}: expected an integer >= 0, got {value}")
        return
    check_tensor(value, name)
    check_dtype(value, torch.int64, name)


def _broadcast(seed, index, dim) -> torch.Size:
    shapes = [x.shape for x in (seed, index, dim) if isinstance(x, torch.Tensor)]
    try:
        return torch.broadcast_shapes(*shapes)
    except RuntimeError:
        raise ShapeError(
            f"seed, index, dim: expected broadcastable shapes, got {[list(s) for s in shapes]}"
        ) from None


def _prepare(seed, index, dim):
    """Check the elementwise functions' input; return their broadcast int32 words."""
    check_tensor(seed, "seed")
    check_dtype(seed, torch.int64, "seed")
    check_tensor(index, "index")
    check_dtype(index, torch.int64, "index")
    _check_words("dim", dim)
    shape = _broadcast(seed, index, dim)
    device = seed.device
    seed, index = (_words(x, device).expand(shape) for x in (seed, index))
    if isinstance(dim, torch.Tensor):
        dim = _words(dim, device).expand(shape)
    return seed, index, dim


def white(seed: torch.Tensor, index: torch.Tensor, dim: torch.Tensor | int) -> torch.Tensor:
    """White noise: a counter-based hash of (seed, index, dim) mapped to [0, 1).

    ``h = lowbias32(lowbias32(lowbias32(seed ^ a) ^ index) ^ lowbias32(dim ^ b))`` and
    ``u = (h >> 8) * 2^-24``, so u is a multiple of 2^-24 and < 1 in float32 (METHODS.md
    section 3, "white"). The seed and index are hashed first so that a sampler computes that part
    once per lane and pays one hash per dimension.

    Args:
        seed: int64 tensor, any shape; its low 32 bits are used.
        index: int64 tensor broadcastable with ``seed``: the sample index (low 32 bits).
        dim: int64 tensor or non-negative int, broadcastable with both: the dimension.

    Returns:
        float32 tensor of the broadcast shape, on ``seed``'s device, values in [0, 1).

    Not for: low-discrepancy integration (see :func:`owen_sobol`); it is the baseline that every
    other sequence is compared against.
    """
    seed, index, dim = _prepare(seed, index, dim)
    return _to_unit(_white_words(_white_seed_index(seed, index), dim))


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
    seed_hash = _lowbias32(seed ^ _signed(_SALT_SOBOL_SEED))
    pair = dim >> 1 if isinstance(dim, int) else _srl(dim, 1)
    y = _shuffled_index(seed_hash, tables.reverse(index), pair)
    return _to_unit(_owen_coordinate(tables, seed_hash, y, pair, dim & 1))


# ------------------------------------------------------------------------------------------------
# Samplers


class Sampler:
    """Base class: gives ``count`` consecutive dimensions for many (seed, index) lanes at once.

    Subclasses implement :meth:`_sample`; :meth:`sample` checks the input once at the boundary.
    A sampler is a pure function of its arguments and its construction options: equal inputs
    give bit-identical outputs, on the device of ``seed``.
    """

    #: Registry name of the sampler (``make_sampler(name)``).
    name: str = ""
    #: Whether :meth:`sample` needs ``pixel``.
    needs_pixel: bool = False

    def sample(
        self,
        seed: torch.Tensor,
        index: torch.Tensor,
        dim: int,
        count: int,
        pixel: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """Values of dimensions ``dim .. dim + count - 1`` for each lane.

        Args:
            seed: ``[N]`` int64, the pixel seed of each lane (low 32 bits used).
            index: ``[N]`` int64, the sample index of each lane (low 32 bits used).
            dim: first dimension, an int >= 0.
            count: number of consecutive dimensions, an int >= 1.
            pixel: ``[N, 2]`` int64 pixel coordinates ``(y, x)`` of each lane; required by
                samplers with ``needs_pixel`` (bnds), ignored by the others.

        Returns:
            ``[N, count]`` float32 in [0, 1), on ``seed``'s device. The tensor is the transposed
            view of a ``[count, N]`` buffer, so that each dimension's column ``out[:, j]`` is
            contiguous (the renderer reads columns); call ``.contiguous()`` for row-major.
        """
        check_shape(seed, "N", "seed")
        check_dtype(seed, torch.int64, "seed")
        check_shape(index, "N", "index")
        check_dtype(index, torch.int64, "index")
        if index.shape != seed.shape:
            raise ShapeError(
                f"index: expected shape [N] = {list(seed.shape)} like seed, got {list(index.shape)}"
            )
        check_positive_int(dim, "dim", minimum=0)
        check_positive_int(count, "count", minimum=1)
        if pixel is not None:
            check_shape(pixel, "* 2", "pixel")
            check_dtype(pixel, torch.int64, "pixel")
            if pixel.shape[0] != seed.shape[0]:
                raise ShapeError(
                    f"pixel: expected shape [N, 2] with N = {seed.shape[0]} like seed, "
                    f"got {list(pixel.shape)}"
                )
        elif self.needs_pixel:
            raise ShapeError(
                f"pixel: expected a [N, 2] int64 tensor of (y, x) for sampler {self.name!r}, "
                "got None"
            )
        return self._sample(seed, index, dim, count, pixel)

    def _sample(
        self,
        seed: torch.Tensor,
        index: torch.Tensor,
        dim: int,
        count: int,
        pixel: torch.Tensor | None,
    ) -> torch.Tensor:
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


class WhiteSampler(Sampler):
    """Independent white noise per (seed, index, dim): :func:`white`, one hash per value."""

    name = "white"

    def _sample(self, seed, index, dim, count, pixel):
        out = _columns(seed.shape[0], count, seed.device)
        _white_columns(seed, index, dim, out)
        return out.T


def _white_columns(seed: torch.Tensor, index: torch.Tensor, dim: int, out: torch.Tensor) -> None:
    """Write :func:`white` of dims ``dim .. dim + len(out) - 1`` into the rows of ``out``."""
    prefix = _white_seed_index(_words(seed, seed.device), _words(index, seed.device))
    for j, row in enumerate(out):
        _to_unit(_white_words(prefix, dim + j), out=row)


def _owen_sobol_columns(seed: torch.Tensor, index: torch.Tensor, dim: int, out: torch.Tensor):
    """Write :func:`owen_sobol` of dims ``dim .. dim + len(out) - 1`` into the rows of ``out``.

    ``seed`` may be ``[N]`` or a 0-dim tensor (one seed for every lane, as in BNDS). The seed
    hash and the reversed index are shared by every pair, the shuffled index by both
    coordinates of a pair.
    """
    tables = _tables(index.device)
    seed_hash = _lowbias32(_words(seed, index.device) ^ _signed(_SALT_SOBOL_SEED))
    rindex = tables.reverse(_words(index, index.device))
    end = dim + out.shape[0]
    for pair in range(dim // 2, (end - 1) // 2 + 1):
        y = _shuffled_index(seed_hash, rindex, pair)
        for role in (0, 1):
            if dim <= 2 * pair + role < end:
                word = _owen_coordinate(tables, seed_hash, y, pair, role)
                _to_unit(word, out=out[2 * pair + role - dim])


class OwenSobolSampler(Sampler):
    """Owen-scrambled Sobol padded by 2D pairs, one sequence per pixel seed: :func:`owen_sobol`."""

    name = "owen_sobol"

    def _sample(self, seed, index, dim, count, pixel):
        out = _columns(seed.shape[0], count, seed.device)
        _owen_sobol_columns(seed, index, dim, out)
        return out.T


class BNDSSampler(Sampler):
    """Blue-noise dithered sampling (Georgiev & Fajardo 2016, "Blue-noise Dithered Sampling").

    One Owen-Sobol sequence (seed ``seed0``) is shared by every pixel and Cranley-Patterson
    rotated per pixel by the vector mask (METHODS.md section 3):

        ``X'(p, i, d) = frac(owen_sobol(seed0, i, d) + mask[d, (y + oy) % T, (x + ox) % T])``

    for ``d < D``. Neighbouring pixels get rotations that differ like blue noise, so their
    errors are negatively correlated as long as the integrand is smooth in the rotated
    dimensions. Dimensions ``d >= D`` fall back to per-pixel white noise ``white(seed_p, i, d)``
    keyed by the lane's own seed: the mask says nothing about them, and this is exactly where
    BNDS stops working for integrands of high dimension (a path of several bounces), which the
    benchmark must show.

    Args:
        mask: ``[D, T, T]`` float32 vector mask with values in [0, 1) (``bnerr.masks``).
        offset: the frame's toroidal offset ``(oy, ox)`` of the mask (``frame_offset(t, T)``).
        seed0: the seed of the shared sequence, an int.

    Not for: decorrelating pixels in dimensions beyond the mask's D; the shared sequence makes the
    per-pixel estimates of a constant integrand identical up to the rotation, by design.
    """

    name = "bnds"
    needs_pixel = True

    def __init__(self, mask: torch.Tensor, offset: tuple[int, int] = (0, 0), seed0: int = 0):
        size = check_shape(mask, "D T T", "mask")
        check_dtype(mask, torch.float32, "mask")
        if mask.numel() and not bool(((mask >= 0) & (mask < 1)).all()):
            raise ValueRangeError(
                f"mask: expected values in [0, 1), got min {float(mask.min())} "
                f"max {float(mask.max())}"
            )
        if (
            not isinstance(offset, (tuple, list))
            or len(offset) != 2
            or not all(isinstance(o, int) and not isinstance(o, bool) for o in offset)
        ):
            raise DtypeError(f"offset: expected a pair of ints (oy, ox), got {offset!r}")
        if isinstance(seed0, bool) or not isinstance(seed0, int):
            raise DtypeError(f"seed0: expected an int, got {type(seed0).__name__} {seed0!r}")
        self.mask = mask
        self._flat = mask.reshape(size["D"], -1)
        self.size = size["T"]
        self.dims = size["D"]
        self.offset = (offset[0] % self.size, offset[1] % self.size)
        self.seed0 = seed0

    def _sample(self, seed, index, dim, count, pixel):
        out = _columns(seed.shape[0], count, seed.device)
        rotated = max(min(dim + count, self.dims) - dim, 0)  # how many of the dims the mask covers
        if rotated:
            base = out[:rotated]
            self._shared_sequence(index, dim, base)
            y = (pixel[:, 0] + self.offset[0]) % self.size
            x = (pixel[:, 1] + self.offset[1]) % self.size
            # one gather per dimension along the flattened tile (3-D advanced indexing is ~10x
            # slower on CPU)
            base += self._flat_mask(seed.device)[dim : dim + rotated].index_select(
                1, y * self.size + x
            )
            # frac of a sum of two values in [0, 1); the clamp keeps float rounding below 1.
            base -= (base >= 1).to(base.dtype)
            base.clamp_(max=ONE_MINUS_EPS)
        if rotated < count:
            _white_columns(seed, index, dim + rotated, out[rotated:])
        return out.T

    def _shared_sequence(self, index: torch.Tensor, dim: int, out: torch.Tensor) -> None:
        """Write ``owen_sobol(seed0, index, d)`` for the rows of ``out``.

        Every lane shares ``seed0``, so when the indices are 0 .. max with max < N (the renderer
        passes spp distinct indices for N >> spp lanes) the sequence is evaluated once per index
        and gathered. This costs one reduction over ``index`` (a device sync on CUDA).
        """
        shared = torch.tensor(self.seed0 & _MASK32, dtype=torch.int64, device=index.device)
        n = index.shape[0]
        if n:
            lo, hi = (int(v) for v in torch.aminmax(index))
            if lo >= 0 and hi < n:
                table = _columns(hi + 1, out.shape[0], index.device)
                indices = torch.arange(hi + 1, dtype=torch.int64, device=index.device)
                _owen_sobol_columns(shared, indices, dim, table)
                torch.index_select(table, 1, index, out=out)
                return
        _owen_sobol_columns(shared, index, dim, out)

    def _flat_mask(self, device: torch.device) -> torch.Tensor:
        """The mask as ``[D, T * T]`` on ``device`` (moved once, then cached)."""
        if self._flat.device != device:
            self._flat = self._flat.to(device)
        return self._flat

    def __repr__(self) -> str:
        return (
            f"BNDSSampler(mask=[{self.dims}, {self.size}, {self.size}], offset={self.offset}, "
            f"seed0={self.seed0})"
        )


#: Sampler name -> class. ``make_sampler`` looks names up here.
SAMPLERS: dict[str, type[Sampler]] = {
    "bnds": BNDSSampler,
    "owen_sobol": OwenSobolSampler,
    "white": WhiteSampler,
}


def make_sampler(name: str, **options) -> Sampler:
    """Build the sampler registered as ``name`` with its options.

    Names: ``white`` (no options), ``owen_sobol`` (no options), ``bnds`` (``mask [D, T, T]``,
    ``offset (oy, ox)``, ``seed0``). An unknown name raises :class:`UnknownNameError` listing the
    known ones.
    """
    check_name(name, list(SAMPLERS), "sampler")
    return SAMPLERS[name](**options)
