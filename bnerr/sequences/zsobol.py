"""pbrt-v4's ``ZSobolSampler``, bit for bit (Ahmed & Wonka 2020, "Screen-Space Blue-Noise
Diffusion of Monte Carlo Sampling Error via Hierarchical Ordering of Pixels", TOG 39(6)).

Every pixel takes an aligned block of ``2^log2spp`` consecutive indices of one global Sobol
sequence: the block of its Morton code. The index's base-4 digits are permuted, most significant
first, by one of the 24 permutations of {0, 1, 2, 3} chosen by a hash of the unpermuted higher
digits and the dimension, so neighbouring pixels get neighbouring blocks in a random order (the
error is blue). The value is then scrambled by pbrt's default ``FastOwen`` randomizer keyed by a
MurmurHash of (dimension, seed). docs/METHODS.md, section 7 ("ZSobol") gives the rule; this module
reproduces pbrt-v4 (commit 5f7a606) down to every constant, bit order and float rounding:

- ``log2spp = floor(log2(spp))``, ``R`` = the smallest power of two >= max(width, height),
  ``nDigits = log2(R) + ceil(log2spp / 2)``;
- ``mortonIndex = (Morton2(x, y) << log2spp) | index`` (x in the even bits);
- digit ``i`` (at bit ``2i - odd``, odd = log2spp & 1) goes through ``PERM[p]`` with
  ``p = (MixBits(prefix ^ salt) >> 24) mod 24``, ``prefix`` the unpermuted bits above it and
  ``salt = u32(0x55555555 * dimension)``; with odd log2spp the lowest bit is flipped by
  ``MixBits((mortonIndex >> 1) ^ salt) & 1``;
- the call then advances the dimension (by 1 for ``Get1D``, 2 for ``Get2D``) and hashes the new
  value with the seed: ``H = MurmurHash64A(int32 dimension, int32 seed)``; x (Sobol dimension 0)
  takes ``low32(H)``, y (Sobol dimension 1) ``high32(H)``;
- ``float32(v)`` rounds the scrambled word to nearest, times 2^-32, clamped to 0x3f7fffff.

64-bit words. pbrt computes in unsigned 64-bit arithmetic; here the words are int64 tensors read
as unsigned: multiplication wraps modulo 2^64 in two's complement on every torch backend, and
every right shift of a value that may have its top bit set is masked (:func:`_srl64`). The 32-bit
value scramble runs on int32 words like the other sequences.

Non-power-of-two spp. pbrt warns ("should be power of 2") and takes ``2^floor(log2(spp))``
samples per pixel: spp = 6 renders 4 samples (its ``SamplesPerPixel()`` returns 4), spp = 3
renders 2. An index >= 2^log2spp would overwrite Morton bits and alias another pixel's samples,
so it is refused here.

Not for: images larger than 2^16 pixels on a side; the ``owen`` randomizer at speed (31 hashes
per value, kept for completeness and checked against the twin).
"""

from __future__ import annotations

import warnings

import torch

from bnerr.errors import (
    DtypeError,
    ValueRangeError,
    check_dtype,
    check_name,
    check_positive_int,
    check_tensor,
)
from bnerr.hashing import MASK32, signed32, srl32
from bnerr.native import SelfCheckedKernels
from bnerr.sequences import native
from bnerr.sequences.base import ONE_MINUS_EPS, Sampler, _broadcast, _check_index_below, _columns
from bnerr.sequences.tables import _tables

__all__ = [
    "RANDOMIZERS",
    "ZSobolSampler",
    "morton2",
    "zsobol_1d",
    "zsobol_2d",
    "zsobol_keys",
]

_MASK64 = (1 << 64) - 1
_MIX_1, _MIX_2 = 0x7FB5D329728EA185, 0x81DADEF4BC2DD44D
_MURMUR_M = 0xC6A4A7935BD1E995
_MURMUR_H0 = 0x35253C9ADE8F4CA8  # (8 * m) mod 2^64: hash-seed 0 XOR len * m for an 8-byte key
_SALT = 0x55555555
_FAST_OWEN = (0x3D20ADEA, 0x05526C56, 0x53A22864)
#: pbrt's 24 permutations of {0, 1, 2, 3}, in pbrt's own order (not lexicographic).
_PERMUTATIONS = (
    "0123 0132 0213 0231 0321 0312 1023 1032 1203 1230 1320 1302 "
    "2103 2130 2013 2031 2301 2310 3120 3102 3210 3201 3021 3012"
)
#: pbrt's value randomizers; ``fastowen`` is pbrt's default.
RANDOMIZERS = ("fastowen", "none", "owen", "permutedigits")
_MAX_SIDE = 1 << 16


def _signed64(value: int) -> int:
    """A Python int's low 64 bits as the int64 with the same bits."""
    value &= _MASK64
    return value - (1 << 64) if value >= 1 << 63 else value


def _srl64(x: torch.Tensor, k: int) -> torch.Tensor:
    """Logical right shift by ``k`` (1 <= k < 64) of int64 words read as unsigned."""
    return (x >> k) & ((1 << (64 - k)) - 1)


def _mix_bits(v: torch.Tensor) -> torch.Tensor:
    """pbrt's ``MixBits`` (u64 -> u64) on int64 words read as unsigned."""
    v = v ^ _srl64(v, 31)
    v = v * _signed64(_MIX_1)
    v = v ^ _srl64(v, 27)
    v = v * _signed64(_MIX_2)
    return v ^ _srl64(v, 33)


def _murmur_host(e: int, seed: int) -> int:
    """pbrt's ``Hash(e, seed)``: MurmurHash64A of the 8 bytes (int32 e, int32 seed), seed 0."""
    k = ((seed & MASK32) << 32) | (e & MASK32)
    k = (k * _MURMUR_M) & _MASK64
    k = ((k ^ (k >> 47)) * _MURMUR_M) & _MASK64
    h = ((_MURMUR_H0 ^ k) * _MURMUR_M) & _MASK64
    h = ((h ^ (h >> 47)) * _MURMUR_M) & _MASK64
    return h ^ (h >> 47)


def _murmur(e: torch.Tensor, seed: int) -> torch.Tensor:
    """:func:`_murmur_host` of an int64 tensor of dimensions (low 32 bits) and a host seed."""
    m = _signed64(_MURMUR_M)
    k = (e & MASK32) | _signed64((seed & MASK32) << 32)
    k = k * m
    k = (k ^ _srl64(k, 47)) * m
    h = (k ^ _signed64(_MURMUR_H0)) * m
    h = (h ^ _srl64(h, 47)) * m
    return h ^ _srl64(h, 47)


def _scramble_seeds(e: torch.Tensor | int, seed: int) -> tuple:
    """``(low32(H), high32(H))`` of ``H = Hash(e, seed)`` as int32 words (tensors) or host ints."""
    if isinstance(e, int):
        h = _murmur_host(e, seed)
        return h & MASK32, h >> 32
    words = _murmur(e, seed)
    return words.to(torch.int32), (words >> 32).to(torch.int32)


def _spread2(v: torch.Tensor) -> torch.Tensor:
    """Bit k of ``v`` (< 2^32) moved to bit 2k."""
    v = v & MASK32
    v = (v | (v << 16)) & 0x0000FFFF0000FFFF
    v = (v | (v << 8)) & 0x00FF00FF00FF00FF
    v = (v | (v << 4)) & 0x0F0F0F0F0F0F0F0F
    v = (v | (v << 2)) & 0x3333333333333333
    return (v | (v << 1)) & 0x5555555555555555


def morton2(x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    """pbrt's ``EncodeMorton2(x, y)``: bit k of x to bit 2k, bit k of y to bit 2k + 1.

    Args:
        x, y: int64 tensors (broadcastable) with values in [0, 2^31).

    Returns:
        int64 tensor of the broadcast shape. Example: ``morton2(37, 11) = 0x49b``.
    """
    return _spread2(x) | (_spread2(y) << 1)


class _Layout:
    """pbrt's derived constants of one (width, height, spp)."""

    def __init__(self, width: object, height: object, spp: object) -> None:
        self.width = check_positive_int(width, "width")
        self.height = check_positive_int(height, "height")
        self.spp = check_positive_int(spp, "spp")
        if max(self.width, self.height) > _MAX_SIDE:
            raise ValueRangeError(
                f"width, height: expected at most {_MAX_SIDE}, got {self.width} x {self.height}"
            )
        self.log2spp = self.spp.bit_length() - 1
        self.log2r = (max(self.width, self.height) - 1).bit_length()
        self.n_digits = self.log2r + (self.log2spp + 1) // 2
        self.samples_per_pixel = 1 << self.log2spp


_PERM_TABLES: dict[torch.device, torch.Tensor] = {}


def _perm_table(device: torch.device) -> torch.Tensor:
    """``PERM`` flattened: entry ``4 p + digit`` is ``PERM[p][digit]``, int64 ``[96]``."""
    if device not in _PERM_TABLES:
        flat = [int(c) for c in _PERMUTATIONS.replace(" ", "")]
        _PERM_TABLES[device] = torch.tensor(flat, dtype=torch.int64, device=device)
    return _PERM_TABLES[device]


def _sample_index(
    morton: torch.Tensor, dim: torch.Tensor | int, log2spp: int, n_digits: int
) -> torch.Tensor:
    """pbrt's ``SampleIndex``: the base-4 digit permutation of ``mortonIndex`` at ``dim``.

    ``morton`` is an int64 tensor of non-negative Morton indices; ``dim`` the dimension before
    the call's increment (an int or an int64 tensor of ``morton``'s shape).
    """
    salt = (dim * _SALT) & MASK32
    odd = log2spp & 1
    perm = _perm_table(morton.device)
    out = torch.zeros_like(morton)
    for i in range(n_digits - 1, odd - 1, -1):
        shift = 2 * i - odd
        digit = (morton >> shift) & 3
        p = _srl64(_mix_bits((morton >> (shift + 2)) ^ salt), 24) % 24
        out |= perm.index_select(0, (p * 4 + digit).reshape(-1)).view(morton.shape) << shift
    if odd:
        out |= (morton & 1) ^ (_mix_bits((morton >> 1) ^ salt) & 1)
    return out


def _reversed_sobol(index: torch.Tensor, coordinate: int) -> torch.Tensor:
    """``rev32(Sobol_c(index))`` as int32 words, for pbrt's 52 stored columns of dims 0 and 1.

    Dimension 0 is ``rev32(index mod 2^32)``, so its reversal is the low word itself. Dimension 1
    is Pascal's matrix mod 2; its columns 32..51 repeat columns 0..19.
    """
    low = (index & MASK32).to(torch.int32)
    if coordinate == 0:
        return low
    tables = _tables(index.device)
    high = ((index >> 32) & 0xFFFFF).to(torch.int32)
    return tables.sobol1(tables.reverse(low)) ^ tables.sobol1(tables.reverse(high))


def _owen(v: torch.Tensor, s: torch.Tensor | int) -> torch.Tensor:
    """pbrt's ``OwenScrambler`` on int32 words (31 hashes, most significant bit first)."""
    v = v.to(torch.int64) & MASK32
    s = s & MASK32 if isinstance(s, int) else s.to(torch.int64) & MASK32
    v = v ^ ((s & 1) << 31)
    for b in range(1, 32):
        prefix = v & ((MASK32 << (32 - b)) & MASK32)
        v = v ^ (((_mix_bits(prefix ^ s) >> b) & 1) << (31 - b))
    return v.to(torch.int32)


def _randomize(x: torch.Tensor, s: torch.Tensor | int, randomizer: str) -> torch.Tensor:
    """The scrambled u32 word from the reversed Sobol word ``x`` and the 32-bit seed ``s``."""
    reverse = _tables(x.device).reverse
    if randomizer == "fastowen":
        k1, k2, k3 = (signed32(c) for c in _FAST_OWEN)
        mult = ((s >> 16) | 1) if isinstance(s, int) else (srl32(s, 16) | 1)
        x = x ^ (x * k1)
        x = x + (signed32(s) if isinstance(s, int) else s)
        x = x * (signed32(mult) if isinstance(mult, int) else mult)
        x = x ^ (x * k2)
        return reverse(x ^ (x * k3))
    v = reverse(x)
    if randomizer == "none":
        return v
    if randomizer == "permutedigits":
        return v ^ (signed32(s) if isinstance(s, int) else s)
    return _owen(v, s)


def _to_float(v: torch.Tensor) -> torch.Tensor:
    """pbrt's ``min(float32(v) * 2^-32, 0x1.fffffep-1)``: round to nearest even, then clamp."""
    f = (v.to(torch.int64) & MASK32).to(torch.float64).to(torch.float32) * 2.0**-32
    return f.clamp_(max=ONE_MINUS_EPS)


def _zsobol_words(morton, dim, advance, coordinates, layout, seed, randomizer):
    """The scrambled words of Sobol ``coordinates`` of one pbrt call at dimension ``dim``."""
    a = _sample_index(morton, dim, layout.log2spp, layout.n_digits)
    seeds = _scramble_seeds(dim + advance, seed)
    return [_randomize(_reversed_sobol(a, c), seeds[c], randomizer) for c in coordinates]


def _check_seed(seed: object) -> int:
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise DtypeError(f"seed: expected an int, got {type(seed).__name__} {seed!r}")
    return seed


def _check_below(x: torch.Tensor, bound: int, name: str, what: str) -> None:
    """Raise :class:`ValueRangeError` unless every value lies in ``[0, bound)``."""
    if x.numel():
        lo, hi = (int(v) for v in torch.aminmax(x))
        if lo < 0 or hi >= bound:
            raise ValueRangeError(
                f"{name}: expected values in [0, {bound}) ({what}), got min {lo} max {hi}"
            )


def _prepare_pixels(x, y, index, dimension, layout):
    """Check the pbrt-style entry points' input; return broadcast ``(morton index, dimension)``."""
    for value, name in ((x, "x"), (y, "y"), (index, "index")):
        check_tensor(value, name)
        check_dtype(value, torch.int64, name)
    if isinstance(dimension, int) and not isinstance(dimension, bool):
        check_positive_int(dimension, "dimension", minimum=0)
        if dimension >= 1 << 30:
            raise ValueRangeError(f"dimension: expected an integer < 2^30, got {dimension}")
    else:
        check_tensor(dimension, "dimension")
        check_dtype(dimension, torch.int64, "dimension")
        _check_below(dimension, 1 << 30, "dimension", "pbrt's int dimension counter")
    shape = _broadcast("x, y, index, dimension", x, y, index, dimension)
    _check_below(x, layout.width, "x", f"the film is {layout.width} wide")
    _check_below(y, layout.height, "y", f"the film is {layout.height} high")
    _check_below(index, layout.samples_per_pixel, "index", f"pbrt takes spp {layout.spp} as "
                 f"{layout.samples_per_pixel} samples per pixel")  # fmt: skip
    device = x.device
    x, y, index = (v.to(device).expand(shape) for v in (x, y, index))
    morton = (morton2(x, y) << layout.log2spp) | index
    if isinstance(dimension, torch.Tensor):
        dimension = dimension.to(device).expand(shape)
    return morton, dimension


def _zsobol(x, y, index, dimension, seed, width, height, spp, randomizer, coordinates):
    layout = _Layout(width, height, spp)
    seed = _check_seed(seed)
    check_name(randomizer, RANDOMIZERS, "randomizer")
    morton, dimension = _prepare_pixels(x, y, index, dimension, layout)
    advance = len(coordinates)
    words = _zsobol_words(morton, dimension, advance, coordinates, layout, seed, randomizer)
    return [_to_float(w) for w in words]


def zsobol_1d(
    x: torch.Tensor,
    y: torch.Tensor,
    index: torch.Tensor,
    dimension: torch.Tensor | int,
    *,
    seed: int = 0,
    width: int,
    height: int,
    spp: int,
    randomizer: str = "fastowen",
) -> torch.Tensor:
    """pbrt-v4's ``ZSobolSampler::Get1D`` with the dimension counter at ``dimension``.

    Bit for bit what pbrt returns for ``StartPixelSample((x, y), index, dimension)`` followed by
    ``Get1D()``, with pbrt's sampler built for a ``width x height`` film, ``spp`` pixel samples,
    the int32 ``seed`` (low 32 bits, two's complement) and the ``randomizer``.

    Args:
        x, y: int64 tensors, the pixel, ``0 <= x < width`` and ``0 <= y < height``.
        index: int64 tensor, the sample index, ``0 <= index < 2^floor(log2(spp))``.
        dimension: int64 tensor or int >= 0 (< 2^30): the dimension counter before the call.
        seed, width, height, spp: the sampler's construction parameters.
        randomizer: ``fastowen`` (pbrt's default), ``none``, ``permutedigits`` or ``owen``.

    Returns:
        float32 tensor of the broadcast shape of the inputs, on ``x``'s device, in [0, 1).
    """
    args = (x, y, index, dimension, seed, width, height, spp, randomizer)
    return _zsobol(*args, coordinates=(0,))[0]


def zsobol_2d(
    x: torch.Tensor,
    y: torch.Tensor,
    index: torch.Tensor,
    dimension: torch.Tensor | int,
    *,
    seed: int = 0,
    width: int,
    height: int,
    spp: int,
    randomizer: str = "fastowen",
) -> torch.Tensor:
    """pbrt-v4's ``ZSobolSampler::Get2D`` (and ``GetPixel2D``) at ``dimension``.

    The same arguments as :func:`zsobol_1d`; the call consumes two dimensions, so its value
    scramble hashes ``dimension + 2``.

    Returns:
        float32 tensor ``[..., 2]`` (the broadcast shape, then (Sobol dim 0, Sobol dim 1)).
    """
    args = (x, y, index, dimension, seed, width, height, spp, randomizer)
    return torch.stack(_zsobol(*args, coordinates=(0, 1)), dim=-1)


def zsobol_keys(height: int, width: int, device: torch.device | str = "cpu") -> torch.Tensor:
    """The seed image of a ZSobol strategy: ``keys[y, x] = morton2(x, y)``, int64 ``[H, W]``."""
    check_positive_int(height, "height")
    check_positive_int(width, "width")
    y, x = torch.meshgrid(
        torch.arange(height, device=device), torch.arange(width, device=device), indexing="ij"
    )
    return morton2(x, y)


class ZSobolSampler(Sampler):
    """pbrt-v4's ZSobol behind the sampler seam; the per-lane ``seed`` is the pixel's key.

    The lane's ``seed`` is read as the pixel's Morton key ``morton2(x, y)`` (:func:`zsobol_keys`
    builds the seed image), taken modulo ``R^2``; ``pixel`` is ignored. So a strategy that moves
    keys between pixels (a temporal permutation) moves whole sample sequences, and with the
    identity key image every lane gets exactly pbrt's values for its pixel.

    Dimension layout: the renderer consumes dimensions in 2D pairs ``(2k, 2k + 1)``; pair ``k`` is
    pbrt's ``Get2D()`` with the dimension counter at ``2k`` (its x then its y), also for the
    one-dimensional decisions the renderer bundles into pairs. Pair 0 is thus exactly pbrt's
    ``GetPixel2D`` (the pixel jitter); pbrt's camera then spends ``Get1D`` at 2 (time) and
    ``Get2D`` at 3 (lens), which this renderer has no use for, so the pairs stay aligned instead.

    Args:
        width, height: the film, as pbrt's ``fullResolution`` (only the larger side matters).
        spp: samples per pixel; a non-power of two warns and takes ``2^floor(log2(spp))``
            (pbrt's rule), and the renderer must then use that many.
        seed: pbrt's int32 ``seed`` (low 32 bits).
        randomizer: ``fastowen`` (pbrt's default), ``none``, ``permutedigits`` or ``owen``.

    Not for: sample indices >= ``samples_per_pixel`` (refused: they would alias other pixels).
    """

    name = "zsobol"

    def __init__(self, width: int, height: int, spp: int, seed: int = 0,
                 randomizer: str = "fastowen") -> None:  # fmt: skip
        self.layout = _Layout(width, height, spp)
        self.seed = _check_seed(seed)
        self.randomizer = check_name(randomizer, RANDOMIZERS, "randomizer")
        self.samples_per_pixel = self.layout.samples_per_pixel
        if self.samples_per_pixel != spp:
            warnings.warn(
                f"zsobol: spp {spp} is not a power of two; pbrt-v4 takes "
                f"{self.samples_per_pixel} samples per pixel",
                stacklevel=2,
            )

    def _morton(self, seed: torch.Tensor, index: torch.Tensor) -> torch.Tensor:
        keys = seed & ((1 << (2 * self.layout.log2r)) - 1)
        return (keys << self.layout.log2spp) | index

    def _sample(self, seed, index, dim, count, pixel):
        _check_index_below(index, self.samples_per_pixel, f"{self.name} spp")
        out = _columns(seed.shape[0], count, seed.device)
        if not (self.randomizer == "fastowen" and _native_words(self, (seed, index), dim, out)):
            self._words_torch(self._morton(seed, index), dim, out)
        return out.T

    def _words_torch(self, morton: torch.Tensor, dim: int, out: torch.Tensor) -> None:
        """The torch path: every pair's values into the rows of ``out``."""
        end = dim + out.shape[0]
        for pair in range(dim // 2, (end - 1) // 2 + 1):
            wanted = [c for c in (0, 1) if dim <= 2 * pair + c < end]
            words = _zsobol_words(morton, 2 * pair, 2, wanted, self.layout, self.seed,
                                  self.randomizer)  # fmt: skip
            for c, word in zip(wanted, words, strict=True):
                out[2 * pair + c - dim] = _to_float(word)

    def __repr__(self) -> str:
        lay = self.layout
        return (
            f"ZSobolSampler(width={lay.width}, height={lay.height}, spp={lay.spp}, "
            f"seed={self.seed}, randomizer={self.randomizer!r})"
        )


def _pair_seeds(dim: int, count: int, seed: int) -> list[int]:
    """The value scramble's two seeds of every pair that dims ``dim .. dim + count - 1`` touch."""
    pairs = range(dim // 2, (dim + count - 1) // 2 + 1)
    return [word for p in pairs for word in _scramble_seeds(2 * p + 2, seed)]


def _native_words(
    sampler: ZSobolSampler,
    lanes: tuple[torch.Tensor, torch.Tensor],
    dim: int,
    out: torch.Tensor,
    kernels: native.SamplerKernels | None = None,
) -> bool:
    """The FastOwen values of the lanes' (key, index) in C into ``out``; False when the native
    path does not apply."""
    kernels = native.kernels_for(lanes, out, kernels, _native_kernels)
    if kernels is None:
        return False
    lay = sampler.layout
    perm = _perm_table(out.device).to(torch.uint8)
    seeds = _pair_seeds(dim, out.shape[0], sampler.seed)
    digits = (lay.log2spp, lay.n_digits, lay.log2r)
    return native.native_zsobol(kernels, lanes, dim, seeds, perm, digits, out)


def _check_lanes(
    height: int, width: int, spp: int, gen: torch.Generator
) -> tuple[torch.Tensor, torch.Tensor]:
    """257 random lanes ``(key, index)`` of a film for the native kernels' self-checks: pixel-major
    like the renderer's lanes (so the kernel's reuse of a pixel's digits runs), with bits above
    the Morton key set (the samplers drop them)."""
    keys = zsobol_keys(height, width).reshape(-1)
    lanes = torch.randint(0, keys.numel(), (257,), generator=gen).sort().values
    index = torch.randint(0, spp, (257,), generator=gen)
    return keys[lanes] + (torch.arange(257) << 40), index


def _self_check(kernels: native.SamplerKernels) -> bool:
    """The native kernel against the torch path for odd and even log2 spp, odd first dimensions
    and negative seeds: True if bit-identical."""
    gen = torch.Generator().manual_seed(41)
    for width, height, spp, seed, dim, count in (
        (37, 21, 8, -3, 0, 6), (300, 5, 16, 2**31 - 1, 3, 4), (1, 1, 1, 0, 1, 2),
    ):  # fmt: skip
        sampler = ZSobolSampler(width, height, spp, seed)
        key, index = _check_lanes(height, width, spp, gen)
        want, got = (_columns(257, count, key.device) for _ in range(2))
        sampler._words_torch(sampler._morton(key, index), dim, want)
        if not _native_words(sampler, (key, index), dim, got, kernels) or not torch.equal(
            got, want
        ):
            return False
    return True


#: The native kernels if they load and pass :func:`_self_check` (run once per library).
_native_kernels = SelfCheckedKernels(
    _self_check, "bnerr.sequences.zsobol: the native ZSobol kernel", native.LIBRARY
)
