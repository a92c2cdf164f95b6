"""Bindings of ``samplers.c``: the native CPU kernels of white noise, the Owen-Sobol, ZSobol and
temporal Z-order samplers, Cycles' patterns (which index Owen-Sobol), the LDBN lookup (which
reads one shared Owen-Sobol sequence through per-pixel keys) and OpenQMC's ``sobolbn``.

The C source ``samplers.c`` (package data of this package) is built, cached and loaded by
:func:`bnerr.native.library`, with the same compiler search, hash check and single warning as the
permutation kernels. This module binds its seven functions and wraps them for tensors; each
sampler module owns its dispatch, its self-check against its torch path and the fallback.

Why C: the torch paths make one full pass over the lanes per operation, and a ZSobol pair is
about 20 operations per base-4 digit (11 digits at 1080p) on int64 words: 2^20 lanes x 8
dimensions took 17 s where Owen-Sobol took 1 s. The C loop keeps a lane's words in registers
across all its digits and pairs and writes each value once. LDBN's torch path is three gathers,
two XORs and a conversion per pair over the whole lane set; in C the lane's texel is found once
and its keys (one level's tile, a few hundred KB at most) stay in cache. White noise is one hash
per value, but its torch path makes about 15 passes over the lanes per dimension (14 % of a
Cornell box render); in C a block of lanes stays in cache and the hash vectorizes: 13x faster
at 2^20 lanes and 20 dimensions, one thread.

Not for: CUDA tensors (the samplers run their torch path there).
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import torch

from bnerr import native

__all__ = [
    "LIBRARY",
    "TORCH_PATH_COST",
    "SamplerKernels",
    "kernels_for",
    "native_cycles",
    "native_ldbn",
    "native_openqmc_sobolbn",
    "native_seeded",
    "seeded_self_check",
    "native_zsobol",
    "threads_for",
    "uses_native",
]

#: What the torch path costs instead, quoted in the warnings.
TORCH_PATH_COST = "the ZSobol and temporal Z-order samplers run 10-50x slower on the CPU"
_SYMBOLS = (
    "bnerr_white",
    "bnerr_owen_sobol",
    "bnerr_zsobol",
    "bnerr_zsobol_t",
    "bnerr_cycles",
    "bnerr_ldbn",
    "bnerr_openqmc_sobolbn",
)


@dataclass(frozen=True)
class SamplerKernels:
    """The bound C functions of one loaded library (``why`` says where it came from)."""

    owen_sobol: Callable[..., int]
    zsobol: Callable[..., int]
    zsobol_t: Callable[..., int]
    cycles: Callable[..., int]
    ldbn: Callable[..., int]
    white: Callable[..., int]
    openqmc_sobolbn: Callable[..., int]
    why: str


def _bind(library: ctypes.CDLL, why: str) -> SamplerKernels:
    """Bind the expected functions; AttributeError if the library lacks one."""
    p, i64, c_int, u64 = ctypes.c_void_p, ctypes.c_int64, ctypes.c_int, ctypes.c_uint64
    owen = library.bnerr_owen_sobol
    owen.argtypes = [p, i64, p, i64, i64, i64, p, p, c_int]
    zsobol = library.bnerr_zsobol
    zsobol.argtypes = [p, p, i64, i64, i64, c_int, c_int, u64, p, p, p, c_int]
    temporal = library.bnerr_zsobol_t
    temporal.argtypes = [p, p, i64, i64, i64, c_int, c_int, u64, u64, u64, p, p, p, c_int]
    cycles = library.bnerr_cycles
    u32 = ctypes.c_uint32
    cycles.argtypes = [p, p, i64, i64, i64, u32, c_int, u32, u32, p, p, c_int]
    ldbn = library.bnerr_ldbn
    ldbn.argtypes = [p, p, p, i64, i64, i64, p, p, p, p, p, p, p, c_int]
    white = library.bnerr_white
    white.argtypes = owen.argtypes
    sobolbn = library.bnerr_openqmc_sobolbn
    sobolbn.argtypes = [p, p, i64, i64, i64, u32, p, p, p, p, c_int]
    for function in (owen, zsobol, temporal, cycles, ldbn, white, sobolbn):
        function.restype = c_int
    return SamplerKernels(owen, zsobol, temporal, cycles, ldbn, white, sobolbn, why)


#: The library of ``samplers.c``: ``LIBRARY.load()`` gives the bound :class:`SamplerKernels`
#: (building them on first use) or None.
LIBRARY = native.library(__package__, "samplers.c", _bind, _SYMBOLS, TORCH_PATH_COST)


def uses_native(*tensors: torch.Tensor) -> bool:
    """Whether the native path applies: every tensor on the CPU and outside ``torch.compile``."""
    return all(t.device.type == "cpu" for t in tensors) and not torch.compiler.is_compiling()


def kernels_for(
    lanes: tuple[torch.Tensor, ...],
    out: torch.Tensor,
    kernels: SamplerKernels | None,
    load: Callable[[], SamplerKernels | None],
) -> SamplerKernels | None:
    """The kernels to fill ``out`` for ``lanes`` with: ``kernels`` if given, else ``load()``;
    None when the native path does not apply (:func:`uses_native`) or no kernel loaded."""
    if not uses_native(*lanes, out):
        return None
    return kernels if kernels is not None else load()


def threads_for(n: int) -> int:
    """Worker threads for ``n`` lanes: torch's thread count, one thread for small calls."""
    return torch.get_num_threads() if n >= 1 << 14 else 1


def _u32(values: Sequence[int]) -> torch.Tensor:
    return torch.tensor([v & 0xFFFFFFFF for v in values], dtype=torch.int64).to(torch.int32)


def native_seeded(
    kernel: Callable[..., int],
    seed: torch.Tensor,
    index: torch.Tensor,
    dim: int,
    keys: Sequence[int],
    out: torch.Tensor,
) -> bool:
    """Dims ``dim .. dim + len(out) - 1`` of the lanes (seed, index) into the rows of ``out`` (in
    place) by a kernel of the signature (seed, seed stride, index, n, dim, count, keys, out,
    threads): ``kernels.white`` or ``kernels.owen_sobol``.

    Args:
        kernel: the bound C function.
        seed: int64 ``[N]``, or 0-dim (one seed for every lane).
        index: int64 ``[N]``.
        keys: white noise: per dimension from ``dim``, its host hash; Owen-Sobol: per pair from
            ``dim // 2``, the three host hashes of roles 0, 1, 2.
        out: float32 ``[count, N]``, contiguous.

    Returns:
        False when the kernel refused the sizes (``out`` is then to be filled by the caller).
    """
    seed, index = seed.contiguous(), index.contiguous()
    table = _u32(keys)
    count, n = out.shape
    stride = 0 if seed.ndim == 0 else 1
    code = kernel(
        seed.data_ptr(), stride, index.data_ptr(), n, dim, count, table.data_ptr(),
        out.data_ptr(), threads_for(n),
    )  # fmt: skip
    return code == 0


def seeded_self_check(
    kernel: Callable[..., int],
    torch_path: Callable[[torch.Tensor, torch.Tensor, int, torch.Tensor], None],
    keys: Callable[[int, int], list[int]],
    cases: Sequence[tuple[int, int]],
    lanes: int,
    seed: int,
) -> bool:
    """A :func:`native_seeded` kernel against its sampler's torch path, bit for bit: ``lanes``
    random (seed, index) lanes drawn with ``seed`` (the first three extreme words), each
    ``(dim, count)`` of ``cases`` for the per-lane seeds, and dimension 3 with one shared 0-dim
    seed; ``keys(dim, count)`` gives the kernel's host keys."""
    gen = torch.Generator().manual_seed(seed)
    seeds = torch.randint(-(2**40), 2**40, (lanes,), generator=gen)
    index = torch.randint(0, 2**33, (lanes,), generator=gen)
    seeds[:3], index[:3] = torch.tensor([0, -1, 2**32 - 1]), torch.tensor([0, 2**32 - 1, 1])
    runs = [(seeds, dim, count) for dim, count in cases] + [(seeds[7], 3, 1)]
    for lane_seeds, dim, count in runs:
        want = torch.empty(count, lanes)
        got = torch.empty(count, lanes)
        torch_path(lane_seeds, index, dim, want)
        ok = native_seeded(kernel, lane_seeds, index, dim, keys(dim, count), got)
        if not ok or not torch.equal(got, want):
            return False
    return True


def native_zsobol(
    kernels: SamplerKernels,
    lanes: tuple[torch.Tensor, torch.Tensor],
    dim: int,
    seeds: Sequence[int],
    perm: torch.Tensor,
    digits: tuple[int, int, int],
    out: torch.Tensor,
    frame: tuple[int, int] | None = None,
) -> bool:
    """ZSobol (``frame`` None) or the temporal Z-order sampler into the rows of ``out``.

    Args:
        lanes: int64 ``[N]`` each: the pixel's Morton key and the sample index.
        seeds: per pair from ``dim // 2``, the value scramble's two 32-bit seeds.
        perm: uint8 digit permutation table (24 x 4 for ZSobol, 8! x 8 for the temporal one).
        digits: ``(log2spp, n_digits, log2r)``: the key keeps its low ``2 log2r`` bits.
        out: float32 ``[count, N]``, contiguous.
        frame: the temporal sampler's ``(t mod F, epoch)``, the epoch the salt bits above 32.

    Returns:
        False when the kernel refused the sizes.
    """
    key, index = (t.contiguous() for t in lanes)
    table = _u32(seeds)
    count, n = out.shape
    key_mask = (1 << (2 * digits[2])) - 1
    args = (key.data_ptr(), index.data_ptr(), n, dim, count, digits[0], digits[1], key_mask)
    tail = (table.data_ptr(), perm.data_ptr(), out.data_ptr(), threads_for(n))
    if frame is None:
        code = kernels.zsobol(*args, *tail)
    else:
        code = kernels.zsobol_t(*args, *frame, *tail)
    return code == 0


def native_cycles(
    kernels: SamplerKernels,
    lanes: tuple[torch.Tensor, torch.Tensor],
    dim: int,
    pattern: tuple[int, bool, int, int],
    keys: Sequence[int],
    out: torch.Tensor,
) -> bool:
    """Cycles' blue-noise indexing over Owen-Sobol into the rows of ``out``.

    Args:
        lanes: int64 ``[N]`` each: the pixel's key and the sample index.
        pattern: ``(spp, first, seed0, first_seed)``: FIRST when ``first``, else PURE.
        keys: as :func:`native_seeded`'s for Owen-Sobol.
        out: float32 ``[count, N]``, contiguous.

    Returns:
        False when the kernel refused the sizes.
    """
    key, index = (t.contiguous() for t in lanes)
    table = _u32(keys)
    count, n = out.shape
    spp, first, seed0, first_seed = pattern
    code = kernels.cycles(
        key.data_ptr(), index.data_ptr(), n, dim, count, spp & 0xFFFFFFFF, int(first),
        seed0 & 0xFFFFFFFF, first_seed & 0xFFFFFFFF, table.data_ptr(), out.data_ptr(),
        threads_for(n),
    )  # fmt: skip
    return code == 0


def native_ldbn(
    kernels: SamplerKernels,
    lanes: tuple[torch.Tensor, torch.Tensor, torch.Tensor],
    dim: int,
    tiles: tuple[torch.Tensor, torch.Tensor, torch.Tensor | None],
    offset: tuple[int, int],
    hashes: tuple[Sequence[int], Sequence[int]],
    out: torch.Tensor,
) -> bool:
    """The LDBN lookup of one level into the rows of ``out``.

    Args:
        lanes: the lanes' seed and index (int64 ``[N]``) and pixel (int64 ``[N, 2]``, (y, x)).
        tiles: the level's scrambling keys (int32 ``[T, T, D]``), ranking keys (int32
            ``[T, T, D / 2]``) and the shared words of indices ``0 .. M - 1`` of its first dims
            (int32 ``[M, E]``, E even), or None (every shared word evaluated).
        offset: the frame's toroidal offset ``(oy, ox)``.
        hashes: per pair from ``dim // 2``: the shared sequence's three seeded pair hashes, and
            Owen-Sobol's three host hashes of :func:`native_seeded` (for the pairs past the keys).
        out: float32 ``[count, N]``, contiguous.

    Returns:
        False when the kernel refused the sizes.
    """
    seed, index, pixel = (t.contiguous() for t in lanes)
    scramble, rank = (t.contiguous() for t in tiles[:2])
    table = torch.zeros(0, 0, dtype=torch.int32) if tiles[2] is None else tiles[2].contiguous()
    shared, keys = (_u32(h) for h in hashes)
    geometry = torch.tensor(
        [scramble.shape[0], scramble.shape[2], *offset, *table.shape], dtype=torch.int64
    )
    count, n = out.shape
    code = kernels.ldbn(
        seed.data_ptr(), index.data_ptr(), pixel.data_ptr(), n, dim, count, geometry.data_ptr(),
        scramble.data_ptr(), rank.data_ptr(), table.data_ptr(), shared.data_ptr(),
        keys.data_ptr(), out.data_ptr(), threads_for(n),
    )  # fmt: skip
    return code == 0


def native_openqmc_sobolbn(
    kernels: SamplerKernels,
    lanes: tuple[torch.Tensor, torch.Tensor],
    dim: int,
    frame: int,
    tables: tuple[torch.Tensor, torch.Tensor, torch.Tensor],
    out: torch.Tensor,
) -> bool:
    """OpenQMC's ``sobolbn`` (:mod:`bnerr.sequences.openqmc`) into the rows of ``out``.

    Args:
        lanes: the lanes' index (int64 ``[N]``, in [0, 2^31)) and pixel (int64 ``[N, 2]``, (y,
            x)).
        frame: OpenQMC's frame (low 32 bits).
        tables: OpenQMC's keys (int32 ``[65536]``, the u32 words), ranks (uint8 ``[65536]``) and
            the byte tables of the reversed Sobol columns of components 0 and 1 (int32
            ``[2, 2, 256]``: component, low / high byte).
        out: float32 ``[count, N]``, contiguous.

    Returns:
        False when the kernel refused the sizes.
    """
    index, pixel = (t.contiguous() for t in lanes)
    keys, ranks, sobol = (t.contiguous() for t in tables)
    count, n = out.shape
    code = kernels.openqmc_sobolbn(
        index.data_ptr(), pixel.data_ptr(), n, dim, count, frame & 0xFFFFFFFF, keys.data_ptr(),
        ranks.data_ptr(), sobol.data_ptr(), out.data_ptr(), threads_for(n),
    )  # fmt: skip
    return code == 0
