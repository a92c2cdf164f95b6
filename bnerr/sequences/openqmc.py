"""OpenQMC's blue-noise samplers ``sobolbn`` and ``latticebn``, bit for bit (Academy Software
Foundation, github.com/AcademySoftwareFoundation/openqmc, Apache-2.0, commit 294d656; tables and
notice in bnerr/data/README.md).

A pixel's sample comes from one shared base pattern (Owen-scrambled Sobol, or a rank-1 lattice)
read through a per-pixel *rank* (XORed into the sample index) and *key* (the scramble, or the
lattice's rotation) looked up in a 256x256 table that OpenQMC optimized offline (keys at 128 spp,
ranks flipped per power-of-two prefix so every prefix up to 128 stays blue). docs/METHODS.md,
section "OpenQMC", gives the rule; the steps for ``Sampler(x, y, frame, index).newDomain(k)``:

1. state: ``pattern = pcg_transition(pcg_init() + frame + (index >> 16) + k)``,
   ``sample = index & 0xffff`` (``State64Bit``, its ``newDomain(k)``);
2. table: ``s = pcg_output(pattern) & 0xffff`` shifts the tile per domain:
   ``(tx, ty) = ((x + (s & 255)) & 255, (y + (s >> 8)) & 255)``, then ``key``, ``rank`` at
   ``[ty, tx]`` (``bntables::tableValue``);
3. ``i = laine_karras(rev32(sample ^ rank), seed)`` (``reverseAndShuffle``), the seed being the
   key (sobolbn) or ``pcg_output(key)`` (latticebn);
4. component c: sobolbn ``rev32(laine_karras(SobolRev_c(i >> 16), rotr(key, 8c)))``
   (``shuffledScrambledSobol``); latticebn ``L_c * i + pcg_output(state_c)`` with
   ``state_c = pcg_transition^(c+1)(key)`` (``shuffledRotatedLattice``);
5. float: ``float32(w & ~(w >> 24)) * 2^-32`` (``uintToFloat``, round to nearest), always < 1.

Dimension layout behind the sampler seam: the renderer consumes dimensions in pairs
``(2k, 2k + 1)``; pair k is components 0 and 1 of ``newDomain(k)`` branched from the pixel's
domain, OpenQMC's own way to give each decision its own domain, so every pair reads its own tile
shift and both its dimensions are the ones OpenQMC's keys were optimized for.

Integers are held in int64 tensors with values in [0, 2^32) and masked after every product (no
product here exceeds 2^62), so no shift ever sees a sign bit.

Not for: pmjbn (OpenQMC's third base; its stochastic PMJ construction is not ported), sample
indices >= 2^31 (OpenQMC's ``int``), domains drawn with ``newDomainSplit``/``Distrib``.
"""

from __future__ import annotations

import functools

import numpy as np
import torch

from bnerr.errors import DtypeError, ValueRangeError, check_dtype, check_name, check_tensor
from bnerr.hashing import MASK32, reverse32
from bnerr.native import SelfCheckedKernels
from bnerr.resources import load_array
from bnerr.sequences import native
from bnerr.sequences.base import Sampler, _broadcast, _check_index_below, _columns

__all__ = [
    "OPENQMC_SAMPLERS",
    "OpenQMCLatticeBNSampler",
    "OpenQMCSobolBNSampler",
    "openqmc_draw",
    "openqmc_float",
]

#: OpenQMC's blue-noise samplers ported here -> the base sequence whose tables they read.
OPENQMC_SAMPLERS = {"sobolbn": "sobol", "latticebn": "lattice"}
_PCG_MUL, _PCG_INC, _PCG_OUT = 747796405, 2891336453, 277803737
_LAINE_KARRAS = (0x3D20ADEA, 0x05526C56, 0x53A22864)
_LATTICE = (1, 364981, 245389, 97823)
_TILE = 256
_MAX_INDEX = 1 << 31
# owen.h's Sobol generator matrices of the four dimensions in the reversed domain: column j of
# dimension d is the 16-bit word XORed in for bit j of the (reversed, shuffled) index's top half.
_SOBOL_REVERSED = (
    tuple(1 << (15 - j) for j in range(16)),
    (0xFFFF, 0x5555, 0x3333, 0x1111, 0x0F0F, 0x0505, 0x0303, 0x0101,
     0x00FF, 0x0055, 0x0033, 0x0011, 0x000F, 0x0005, 0x0003, 0x0001),
    (0xAA09, 0x7706, 0x3903, 0x1601, 0x09AA, 0x0677, 0x0339, 0x0116,
     0x00A3, 0x0071, 0x003A, 0x0017, 0x0009, 0x0006, 0x0003, 0x0001),
    (0xA0C3, 0x4041, 0x302D, 0x101E, 0x0B67, 0x079A, 0x02A4, 0x011B,
     0x00C9, 0x0045, 0x002E, 0x001F, 0x000A, 0x0004, 0x0003, 0x0001),
)  # fmt: skip


# ------------------------------------------------------------------------------------------------
# OpenQMC's integer building blocks (int64 tensors holding u32 words)


def _pcg_transition(state: torch.Tensor) -> torch.Tensor:
    """``pcg::stateTransition``: one LCG step modulo 2^32."""
    return (state * _PCG_MUL + _PCG_INC) & MASK32


def _pcg_output(state: torch.Tensor) -> torch.Tensor:
    """``pcg::output``: PCG's RXS-M-XS permutation of a 32-bit state."""
    state = state ^ torch.bitwise_right_shift(state, 4 + (state >> 28))
    state = (state * _PCG_OUT) & MASK32
    return state ^ (state >> 22)


def _laine_karras(value: torch.Tensor, seed: torch.Tensor) -> torch.Tensor:
    """``laineKarrasPermutation``: a nested scramble in the bit-reversed domain."""
    value = value ^ ((value * _LAINE_KARRAS[0]) & MASK32)
    value = (value + seed) & MASK32
    value = (value * ((seed >> 16) | 1)) & MASK32
    value = value ^ ((value * _LAINE_KARRAS[1]) & MASK32)
    return value ^ ((value * _LAINE_KARRAS[2]) & MASK32)


_SOBOL_BYTES: dict[tuple[int, torch.device], tuple[torch.Tensor, torch.Tensor]] = {}


def _sobol_byte_tables(dimension: int, device: torch.device) -> tuple[torch.Tensor, torch.Tensor]:
    """``[256]`` int64 twice: the XOR of dimension's columns 0-7 (then 8-15) over each byte."""
    if (dimension, device) not in _SOBOL_BYTES:
        byte = torch.arange(256, dtype=torch.int64)
        columns = _SOBOL_REVERSED[dimension]
        low, high = torch.zeros_like(byte), torch.zeros_like(byte)
        for j in range(8):
            low ^= ((byte >> j) & 1) * columns[j]
            high ^= ((byte >> j) & 1) * columns[j + 8]
        _SOBOL_BYTES[dimension, device] = (low.to(device), high.to(device))
    return _SOBOL_BYTES[dimension, device]


def _sobol_reversed(index16: torch.Tensor, dimension: int) -> torch.Tensor:
    """``sobolReversedIndex``: the XOR of dimension's columns over the set bits of a 16-bit word
    (two byte lookups: the XOR is linear, so the low and the high byte's parts are independent)."""
    low, high = _sobol_byte_tables(dimension, index16.device)
    return low[index16 & 0xFF] ^ high[index16 >> 8]


def _rotate_bytes(key: torch.Tensor, count: int) -> torch.Tensor:
    """``rotateBytes(key, count)``: the word rotated right by ``8 * count`` bits."""
    bits = (8 * count) & 31
    return key if bits == 0 else ((key >> bits) | (key << (32 - bits))) & MASK32


# ------------------------------------------------------------------------------------------------
# The tables and the draw


_TABLES: dict[tuple[str, torch.device], tuple[torch.Tensor, torch.Tensor]] = {}


def _tables(base: str, device: torch.device) -> tuple[torch.Tensor, torch.Tensor]:
    """OpenQMC's ``(keys, ranks)`` of ``base`` as flat int64 ``[65536]`` (index ``y * 256 + x``)."""
    if (base, device) not in _TABLES:
        shape = (_TILE, _TILE)
        keys = load_array(f"openqmc_{base}_keys.npy", np.uint32, shape).astype(np.int64)
        ranks = load_array(f"openqmc_{base}_ranks.npy", np.uint8, shape).astype(np.int64)
        _TABLES[base, device] = tuple(  # type: ignore[assignment]
            torch.from_numpy(t.reshape(-1)).to(device) for t in (keys, ranks)
        )
    return _TABLES[base, device]


def _domain_table(sampler, x, y, frame, index, key):
    """The domain's ``(key, rank)`` words from the shifted tile, and its 16-bit sample id."""
    pattern = (_PCG_INC + frame + (index >> 16)) & MASK32  # pcg::init(frame + indexKey)
    pattern = _pcg_transition((pattern + key) & MASK32)
    shift = _pcg_output(pattern)
    tx = (x + (shift & 0xFF)) & 0xFF
    ty = (y + ((shift >> 8) & 0xFF)) & 0xFF
    keys, ranks = _tables(OPENQMC_SAMPLERS[sampler], index.device)
    flat = (ty * _TILE + tx).reshape(-1)
    pick = (keys.index_select(0, flat), ranks.index_select(0, flat))
    return *(t.view(index.shape) for t in pick), index & 0xFFFF


def _draw_words(sampler, x, y, frame, index, key, size):
    """The ``size`` u32 words of ``drawSample<size>`` for broadcast int64 tensors of the inputs."""
    table_key, rank, sample = _domain_table(sampler, x, y, frame, index, key)
    if sampler == "sobolbn":
        shuffled = _laine_karras(reverse32(sample ^ rank), table_key)
        top = shuffled >> 16
        return [
            reverse32(_laine_karras(_sobol_reversed(top, c), _rotate_bytes(table_key, c)))
            for c in range(size)
        ]
    shuffled = _laine_karras(reverse32(sample ^ rank), _pcg_output(table_key))
    state, words = table_key, []
    for c in range(size):
        state = _pcg_transition(state)
        words.append((_LATTICE[c] * shuffled + _pcg_output(state)) & MASK32)
    return words


def openqmc_float(words: torch.Tensor) -> torch.Tensor:
    """OpenQMC's ``uintToFloat`` of int64 words in [0, 2^32): ``float32(w & ~(w >> 24)) * 2^-32``.

    The low byte loses the bits of the top byte before the nearest-even rounding to float32, so
    no word rounds up to 1 (0xffffffff gives 0x3f7fffff). float64 holds every word exactly, so the
    conversion rounds once, on every backend.
    """
    safe = words & ~(words >> 24)
    return safe.to(torch.float64).to(torch.float32) * 2.0**-32


def _check_int_tensor(value: object, name: str) -> torch.Tensor:
    value = check_tensor(value, name)
    check_dtype(value, torch.int64, name)
    return value


def openqmc_draw(
    sampler: str,
    x: torch.Tensor,
    y: torch.Tensor,
    frame: torch.Tensor,
    index: torch.Tensor,
    key: torch.Tensor,
    size: int = 4,
) -> torch.Tensor:
    """``Sampler(x, y, frame, index).newDomain(key).drawSample<size>`` of OpenQMC, as u32 words.

    Args:
        sampler: ``"sobolbn"`` or ``"latticebn"``.
        x, y: int64 tensors, the pixel (any ints: the tables wrap every 256 pixels).
        frame, key: int64 tensors, OpenQMC's ``frame`` and the ``newDomain`` key (low 32 bits).
        index: int64 tensor, the sample index in [0, 2^31) (OpenQMC's int).
        size: the draw's dimensions, 1 to 4.

    Returns:
        int64 ``[..., size]`` (the broadcast shape), the words in [0, 2^32); pass them through
        :func:`openqmc_float` for OpenQMC's float overload.
    """
    check_name(sampler, list(OPENQMC_SAMPLERS), "OpenQMC sampler")
    if isinstance(size, bool) or not isinstance(size, int) or not 1 <= size <= 4:
        raise ValueRangeError(f"size: expected an int in 1..4 (drawSample<Size>), got {size!r}")
    values = [_check_int_tensor(v, n) for v, n in ((x, "x"), (y, "y"), (frame, "frame"),
                                                    (index, "index"), (key, "key"))]  # fmt: skip
    shape = _broadcast("x, y, frame, index, key", *values)
    x, y, frame, index, key = (v.to(values[0].device).expand(shape) for v in values)
    _check_index_below(index.reshape(-1), _MAX_INDEX, "OpenQMC's int index")
    words = _draw_words(sampler, x, y, frame & MASK32, index, key & MASK32, size)
    return torch.stack(words, dim=-1)


# ------------------------------------------------------------------------------------------------
# The samplers


class _OpenQMCSampler(Sampler):
    """One of OpenQMC's blue-noise samplers behind the sampler seam (module docstring).

    The lane's pixel ``(y, x)`` selects the table entry; the lane's ``seed`` is not read. Pair k
    of dimensions ``(2k, 2k + 1)`` is components 0 and 1 of ``newDomain(k)``.

    Args:
        frame: OpenQMC's ``frame`` (low 32 bits): it moves every domain's tile shift, so frames
            are different draws of the same blue pattern.
    """

    needs_pixel = True
    #: OpenQMC's sampler name (a key of :data:`OPENQMC_SAMPLERS`).
    openqmc: str = ""

    def __init__(self, frame: int = 0) -> None:
        if isinstance(frame, bool) or not isinstance(frame, int):
            raise DtypeError(f"frame: expected an int, got {type(frame).__name__} {frame!r}")
        self.frame = frame & MASK32

    def _sample(self, seed, index, dim, count, pixel):
        _check_index_below(index, _MAX_INDEX, "OpenQMC's int index")
        out = _columns(seed.shape[0], count, seed.device)
        pixel = pixel.to(seed.device)
        if not _native_values(self, (index, pixel), dim, out):
            self._values_torch(index, pixel, dim, out)
        return out.T

    def _values_torch(
        self, index: torch.Tensor, pixel: torch.Tensor, dim: int, out: torch.Tensor
    ) -> None:
        """The lanes' dimensions ``dim ..`` into the rows of ``out [count, N]`` with torch."""
        y, x = pixel[:, 0], pixel[:, 1]
        end = dim + out.shape[0]
        for pair in range(dim // 2, (end - 1) // 2 + 1):
            key = torch.full_like(index, pair)
            wanted = [c for c in (0, 1) if dim <= 2 * pair + c < end]
            words = _draw_words(self.openqmc, x, y, self.frame, index, key, wanted[-1] + 1)
            for c in wanted:
                out[2 * pair + c - dim] = openqmc_float(words[c])

    def __repr__(self) -> str:
        return f"{type(self).__name__}(frame={self.frame})"


class OpenQMCSobolBNSampler(_OpenQMCSampler):
    """OpenQMC's ``SobolBnSampler``: Owen-scrambled Sobol through blue-noise ranks and keys."""

    name = "openqmc_sobolbn"
    openqmc = "sobolbn"


class OpenQMCLatticeBNSampler(_OpenQMCSampler):
    """OpenQMC's ``LatticeBnSampler``: a rank-1 lattice, shuffled and rotated by blue-noise ranks
    and keys."""

    name = "openqmc_latticebn"
    openqmc = "latticebn"


# ------------------------------------------------------------------------------------------------
# The native path (sobolbn on the CPU: bnerr/sequences/samplers.c, bnerr_openqmc_sobolbn)


@functools.cache
def _native_tables() -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """sobolbn's keys (int32, the u32 words), ranks (uint8) and the byte tables of the reversed
    Sobol columns of components 0 and 1 (int32 ``[2, 2, 256]``), as the C kernel reads them."""
    keys, ranks = _tables("sobol", torch.device("cpu"))
    columns = [torch.stack(_sobol_byte_tables(c, torch.device("cpu"))) for c in (0, 1)]
    sobol = torch.stack(columns).to(torch.int32)  # values < 2^16
    return keys.to(torch.int32), ranks.to(torch.uint8), sobol


def _native_values(
    sampler: _OpenQMCSampler,
    lanes: tuple[torch.Tensor, torch.Tensor],
    dim: int,
    out: torch.Tensor,
    kernels: native.SamplerKernels | None = None,
) -> bool:
    """sobolbn's values of the lanes' (index, pixel) in C into ``out``; False when the native
    path does not apply (another sampler, a CUDA tensor, no kernel)."""
    if sampler.openqmc != "sobolbn":
        return False  # latticebn keeps its torch path (a render at 1.16x Owen-Sobol's)
    kernels = native.kernels_for(lanes, out, kernels, _native_kernels)
    if kernels is None:
        return False
    tables = _native_tables()
    return native.native_openqmc_sobolbn(kernels, lanes, dim, sampler.frame, tables, out)


def _self_check(kernels: native.SamplerKernels) -> bool:
    """The native kernel against the torch path: pixels negative and off the tile, indices up to
    OpenQMC's 2^31 - 1 (past one 2^16 block), a frame above 2^31, first dimensions even and odd:
    True if bit-identical."""
    gen = torch.Generator().manual_seed(61)
    sampler = OpenQMCSobolBNSampler(frame=2**31 + 12345)
    pixel = torch.randint(-600, 600, (211, 2), generator=gen)
    for high, dim, count in ((4, 0, 4), (2**17, 1, 2), (_MAX_INDEX, 3, 5), (70000, 6, 1)):
        index = torch.randint(0, high, (211,), generator=gen)
        want, got = (_columns(211, count, index.device) for _ in range(2))
        sampler._values_torch(index, pixel, dim, want)
        ok = _native_values(sampler, (index, pixel), dim, got, kernels)
        if not ok or not torch.equal(got, want):
            return False
    return True


#: The native kernels if they load and pass :func:`_self_check` (run once per library).
_native_kernels = SelfCheckedKernels(
    _self_check, "bnerr.sequences.openqmc: the native sobolbn kernel", native.LIBRARY
)
