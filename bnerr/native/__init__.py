"""Optional native CPU kernels of the seed permutation (docs/METHODS.md, section 4).

A leaf package: it imports nothing from bnerr but :mod:`bnerr.errors`, and every constant (the
luminance weights, the block size, the thread count) comes in as an argument. The ops that use it,
:func:`bnerr.permutation.permute.sort_pass` and :func:`bnerr.permutation.retarget.retarget`, own
their dispatch and check the kernels once against their torch paths before trusting them.

Why a C kernel: the sorting pass is a few integer operations per pixel, so its cost is memory
traffic and per-op overhead. Eager torch needs about ten full passes over the image (keys, block
layout, sort, gathers, scatters); one C loop over blocks that keeps each group of 16 blocks in SIMD
registers (GCC/Clang vector extensions, one block per lane) is several times faster. The
retargeting kernel gathers each row's seeds in one pass through its tile row's flat offsets (AVX2
or AVX-512 gathers and streaming stores where the build has them), threads taking chunks of rows,
while one thread first walks the border band to pair the targets whose source is off screen with
the unclaimed sources.

How it is built: the C source ``permute.c`` (package data beside this file) is compiled at first
use with the system C compiler (``$CC``, else ``cc``, ``gcc`` or ``clang``) into a shared library
in a per-user cache and loaded with :mod:`ctypes` only if it is the one this source, these flags,
this compiler and this CPU built (:mod:`bnerr.native.build` says how). The build takes a few
seconds (5 s of CPU with GCC 12), once per machine. No torch headers, no Python extension module.

When it is not used: ``BNERR_NATIVE=0`` turns it off (silently). A missing compiler, a failed
build or a library without the expected functions gives one warning, which names the compiler and
quotes its first error lines, and the torch path runs instead. :func:`status` says what happened;
:func:`compiler_output` keeps the compiler's full stderr.

- :func:`load`: the bound kernels (:class:`Kernels`) or None.
- :func:`native_sort_blocks`: the block sorting pass on CPU tensors (optional groups and block-grid
  offset; grouped blocks run scalar code, about half the torch path's time at 1080p).
- :func:`native_retarget_gather`: the retargeting pass on CPU tensors, with the field in the
  kernel's form (:func:`retarget_field`, made once per field).

Not for: CUDA tensors (the callers run their torch path there). Other packages' C sources (the
filter kernels of :mod:`denoisers.native`, package data there) use the same machinery through
:func:`library`, which names the package and the file.
"""

from __future__ import annotations

import ctypes
import functools
import os
import threading
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeVar, cast

import torch

from bnerr.errors import ValueRangeError
from bnerr.native import build

__all__ = [
    "Kernels",
    "Library",
    "RetargetField",
    "SelfCheckedKernels",
    "available",
    "compiler_output",
    "library",
    "load",
    "native_retarget_gather",
    "native_sort_blocks",
    "reset",
    "retarget_field",
    "status",
]

#: What the torch path costs instead, quoted in the warnings. Measured at 1920x1080 with
#: ``bnerr bench --suite speed`` on 2 idle threads of an AVX2 host: the sort pass took 65 ms
#: against 8.0 ms, the retargeting pass 16.6 ms against 5.6 ms.
TORCH_PATH_COST = (
    "on the CPU the sort pass runs about 8x and the retargeting pass about 3x slower at 1080p"
)
_SYMBOLS = ("bnerr_sort_pass", "bnerr_retarget")

#: The bound kernels of one library (what its ``bind`` returns: :class:`Kernels` here).
K = TypeVar("K")


@dataclass(frozen=True)
class Kernels:
    """The bound C functions of one loaded library (``why`` says where it came from)."""

    sort_pass: Callable[..., int]
    retarget: Callable[..., int]
    why: str


def _bind(library: ctypes.CDLL, why: str) -> Kernels:
    """Bind the expected functions; AttributeError if the library lacks one."""
    p, i64, f32 = ctypes.c_void_p, ctypes.c_int64, ctypes.c_float
    sort = library.bnerr_sort_pass
    c_int = ctypes.c_int
    sort.argtypes = [p, p, p, f32, f32, f32, p, p, p, p, i64, i64, c_int, i64, i64, c_int]
    sort.restype = ctypes.c_int
    gather = library.bnerr_retarget
    gather.argtypes = [p, p, p, p, i64, i64, i64, i64, i64, i64, ctypes.c_int]
    gather.restype = ctypes.c_int
    return Kernels(sort, gather, why)


@dataclass(frozen=True)
class _State(Generic[K]):
    """What a :class:`Library`'s first load decided, replaced as a whole (so that a reader
    outside the lock sees either the old state or the new one)."""

    loaded: bool
    kernels: K | None
    why: str
    cc: str


class Library(Generic[K]):
    """One C source's library: built, cached and bound on first use, once per process.

    ``package``: the dotted name of the package whose data holds the source (``"bnerr.native"``
    for ``permute.c``); ``source``: the file name there; ``bind``: ``(CDLL, why) -> kernels``
    that sets the functions' argument types (AttributeError when one is missing); ``symbols``:
    the names ``bind`` needs (quoted when one is missing); ``cost``: what the fallback costs, for
    warnings. The first :meth:`load` in a process decides; a problem is reported once, as a
    RuntimeWarning.
    """

    def __init__(
        self,
        package: str,
        source: str,
        bind: Callable[[ctypes.CDLL, str], K],
        symbols: tuple[str, ...],
        cost: str,
    ) -> None:
        self.package, self.source = package, source
        self._bind, self.symbols, self.cost = bind, symbols, cost
        self._lock = threading.Lock()
        self._state: _State[K] = _State(False, None, "not loaded yet", "")

    def _obtain(self) -> tuple[K | None, str, str | None, str]:
        """``(kernels, why, warning, compiler stderr)``, building the library if needed."""
        if os.environ.get("BNERR_NATIVE", "1") == "0":
            return None, "disabled by BNERR_NATIVE=0", None, ""
        outcome = build.obtain(self.cost, self.package, self.source)
        if outcome.library is None:
            return None, outcome.why, outcome.warning, outcome.compiler_output
        try:
            kernels = self._bind(outcome.library, outcome.why)
        except AttributeError:
            missing = [s for s in self.symbols if not hasattr(outcome.library, s)]
            why = f"the library {outcome.why} lacks the functions {', '.join(missing)}"
            warning = f"bnerr: {why}; the torch path is used ({self.cost})"
            return None, why, warning, outcome.compiler_output
        return kernels, outcome.why, outcome.warning, outcome.compiler_output

    def load(self) -> K | None:
        """The bound kernels, building them on first use; None when unavailable."""
        if self._state.loaded:
            return self._state.kernels
        with self._lock:
            if not self._state.loaded:
                kernels, why, warning, stderr = self._obtain()
                self._state = _State(True, kernels, why, stderr)
                if warning:
                    warnings.warn(warning, RuntimeWarning, stacklevel=3)
        return self._state.kernels

    def reset(self) -> None:
        """Forget the loaded kernels, so that the next :meth:`load` looks again."""
        with self._lock:
            self._state = _State(False, None, "not loaded yet", "")

    def status(self) -> str:
        """What happened: where the library came from, or why it is not used."""
        self.load()
        return self._state.why

    def compiler_output(self) -> str:
        """The compiler's stderr of this process's last build ("" after a cache hit)."""
        self.load()
        return self._state.cc


_LIBRARIES: list[Library[Any]] = []


def library(
    package: str,
    source: str,
    bind: Callable[[ctypes.CDLL, str], K],
    symbols: tuple[str, ...],
    cost: str,
) -> Library[K]:
    """A :class:`Library` of the C source ``source`` (package data of ``package``), registered so
    that :func:`reset` forgets it too. Create one per source, at import time of the module that
    binds its kernels (:mod:`denoisers.native` for its own sources: the denoisers' kernels ship
    with the denoisers, the library only reads them by name)."""
    made = Library(package, source, bind, symbols, cost)
    _LIBRARIES.append(made)
    return made


_PERMUTE = library(__name__, "permute.c", _bind, _SYMBOLS, TORCH_PATH_COST)


def load() -> Kernels | None:
    """The bound permutation kernels, building them on first use; None when unavailable (see
    :func:`status`). The first call in a process decides; a problem is reported once, as a
    RuntimeWarning."""
    return _PERMUTE.load()


class SelfCheckedKernels(Generic[K]):
    """The loaded kernels, handed out only once they pass a caller's self-check.

    Each op that has a native path (the sort pass, the retargeting pass, a filter) owns one of
    these with its own check, a function ``kernels -> bool`` that compares the kernel with the
    op's torch path. The check runs once per loaded library (again after :func:`reset`); a
    failure is reported once, as a RuntimeWarning naming ``what``, and the op then gets None.
    ``source``: the library (default: the permutation kernels).
    """

    def __init__(
        self, check: Callable[[K], bool], what: str, source: Library[K] | None = None
    ) -> None:
        self._check, self._what = check, what
        # Without a source, K is Kernels: the check is one of the permutation kernels'.
        self._source = cast("Library[K]", _PERMUTE) if source is None else source
        self._checked: tuple[K | None, bool] = (None, False)
        self._lock = threading.Lock()

    def __call__(self) -> K | None:
        kernels = self._source.load()
        if kernels is None:
            return None
        if self._checked[0] is not kernels:
            with self._lock:
                if self._checked[0] is not kernels:
                    ok = self._check(kernels)
                    if not ok:
                        warnings.warn(
                            f"{self._what} disagrees with the torch path on the self-check; "
                            "the torch path is used",
                            RuntimeWarning,
                            stacklevel=3,
                        )
                    self._checked = (kernels, ok)
        return kernels if self._checked[1] else None


def reset() -> None:
    """Forget every loaded library, so that the next load looks again (for tests; the
    environment variables are read again then)."""
    for each in _LIBRARIES:
        each.reset()


def available() -> bool:
    """Whether the permutation kernels are (or can be) built and loaded on this machine."""
    return load() is not None


def status() -> str:
    """What happened to the permutation kernels: where they came from, or why they are not used."""
    return _PERMUTE.status()


def compiler_output() -> str:
    """The compiler's stderr of this process's last build of the permutation kernels."""
    return _PERMUTE.compiler_output()


def _threads(threads: int) -> int:
    return max(1, min(64, int(threads)))


@functools.lru_cache(maxsize=8)
def _float32(weights: tuple[float, ...]) -> list[float]:
    """The weights rounded to float32, as torch rounds a Python scalar times a float32 tensor."""
    return [float(torch.tensor(x, dtype=torch.float32)) for x in weights]


def native_sort_blocks(
    kernels: Kernels,
    seeds: torch.Tensor,
    values: torch.Tensor,
    order: torch.Tensor,
    block: int,
    weights: tuple[float, float, float],
    threads: int = 1,
    *,
    groups: torch.Tensor | None = None,
    grid_offset: tuple[int, int] = (0, 0),
) -> torch.Tensor | None:
    """The block sorting pass in C (the rule of :func:`bnerr.permutation.permute.sort_pass`).

    Args:
        kernels: from :func:`load`.
        seeds: ``[H, W]`` int64 CPU tensor.
        values: ``[H, W]`` float32 sort keys, or ``[3, H, W]`` float32 planes whose luminance
            ``(w0 * R + w1 * G) + w2 * B`` (float32, in that order) is the key.
        order: ``[ceil((H + oy) / B) * ceil((W + ox) / B), B * B]`` uint8, each block's positions
            in mask order (:class:`bnerr.permutation.permute.SortPlan` for the same
            ``grid_offset``).
        block: B in 2..8.
        weights: ``(w0, w1, w2)``, used for ``[3, H, W]`` values (rounded to float32).
        threads: worker threads (split by block rows; the result does not depend on it).
        groups: ``[H, W]`` int64 labels or None; with labels, each block sorts each group of equal
            labels among its own pixels (scalar code, no SIMD: see
            :func:`bnerr.permutation.permute.sort_pass`).
        grid_offset: ``(oy, ox)`` in ``[0, B)^2``: pixel (y, x) is in block
            ``((y + oy) // B, (x + ox) // B)``.

    Returns:
        ``[H, W]`` int64, or None when the kernel refuses the sizes (the caller falls back).

    Raises:
        ValueRangeError: ``order`` holds a position outside its block (nothing is written out of
            bounds).
    """
    seeds, values, order = seeds.contiguous(), values.contiguous(), order.contiguous()
    out = torch.empty_like(seeds)
    h, w = seeds.shape
    planes: list[int | None]
    if values.ndim == 3:
        planes = [values[c].data_ptr() for c in range(3)]
        floats = _float32(tuple(weights))
    else:
        planes, floats = [values.data_ptr(), None, None], [1.0, 0.0, 0.0]
    labels = None if groups is None else groups.to(torch.int64).contiguous()
    code = kernels.sort_pass(
        *planes, *floats, seeds.data_ptr(), order.data_ptr(),
        None if labels is None else labels.data_ptr(), out.data_ptr(), h, w, block,
        grid_offset[0], grid_offset[1], _threads(threads),
    )  # fmt: skip
    if code == 2:
        raise ValueRangeError(
            "mask: expected a plan made by plan_sort, got one whose order leaves its blocks"
        )
    return out if code == 0 else None


@dataclass(frozen=True)
class RetargetField:
    """A displacement field and its inverse as the retargeting kernel reads them, made once per
    field by :func:`retarget_field` (the conversion and the reach are not redone every frame).

    Attributes:
        field: ``[2, T, T]`` contiguous int32 CPU tensor, the displacement ``d``.
        back: ``[2, T, T]`` contiguous int32 CPU tensor, its inverse.
        size: the tile size T.
        reach: the largest ``|dy|`` or ``|dx|`` of ``field``.
    """

    field: torch.Tensor
    back: torch.Tensor
    size: int
    reach: int


def retarget_field(displacement: torch.Tensor, inverse: torch.Tensor) -> RetargetField:
    """The kernel's form of ``displacement [2, T, T]`` (an integer field, a permutation of the
    tile, checked by the caller) and of ``inverse`` (its
    :func:`bnerr.permutation.retarget.inverse_field`)."""
    field = displacement.to("cpu", torch.int32).contiguous()
    back = inverse.to("cpu", torch.int32).contiguous()
    return RetargetField(field, back, field.shape[-1], int(field.abs().max()))


def native_retarget_gather(
    kernels: Kernels,
    seeds: torch.Tensor,
    field: RetargetField,
    offset: tuple[int, int],
    threads: int = 1,
) -> torch.Tensor | None:
    """The retargeting pass in C (the rule of :func:`bnerr.permutation.retarget.retarget`).

    Args:
        kernels: from :func:`load`.
        seeds: ``[H, W]`` int64 CPU tensor.
        field: the displacement field and its inverse, from :func:`retarget_field`.
        offset: the frame's toroidal offset ``(oy, ox)``.
        threads: worker threads (split by rows; the result does not depend on it).

    Returns:
        ``[H, W]`` int64, or None when the kernel refuses the sizes.

    Raises:
        ValueRangeError: ``field``'s displacement and inverse are not inverse permutations.
    """
    seeds = seeds.contiguous()
    size = field.size
    h, w = seeds.shape
    out = torch.empty((h, w), dtype=torch.int64)
    code = kernels.retarget(
        seeds.data_ptr(), field.field.data_ptr(), field.back.data_ptr(), out.data_ptr(),
        h, w, size, offset[0] % size, offset[1] % size, field.reach, _threads(threads),
    )  # fmt: skip
    if code == 3:
        raise ValueRangeError(
            "inverse: expected the inverse of the displacement field, got a field that is not"
        )
    return out if code == 0 else None
