"""The sampler seam and the 32-bit word helpers every sequence shares.

A sequence is a deterministic function ``X(seed, index, dim) -> [0, 1)`` of a pixel's seed, the
sample index ``i < spp`` and the integrand dimension ``d``. The renderer asks a :class:`Sampler`
for ``count`` consecutive dimensions of many (seed, index) lanes at once and never draws random
numbers itself.

Integer arithmetic. torch has almost no uint32 support, so 32-bit words are held in int32
tensors and read as unsigned: multiplication and addition wrap modulo 2^32 (two's complement, as
in every torch backend: CPU vector units and CUDA), and every right shift is masked to make it
logical (the helpers live in :mod:`bnerr.hashing`). int32 instead of masked int64 halves memory
traffic and saves the masks: on 2^20 words, one CPU thread, the lowbias32 hash took 4.2 ms
instead of 10.1 ms and the Laine-Karras step 3.8 ms instead of 13.3 ms. Every result is checked
bit for bit against a pure-Python reference in the tests, so a backend that did not wrap would be
caught there. Seeds, indices and dimensions use their low 32 bits (an index of 2^32 aliases
index 0; no renderer gets there). The Z-order samplers need 64-bit words; they hold them in int64
tensors the same way (:mod:`bnerr.sequences.zsobol`).
"""

from __future__ import annotations

from typing import overload

import torch

from bnerr.errors import (
    ShapeError,
    ValueRangeError,
    check_dtype,
    check_positive_int,
    check_shape,
    check_tensor,
)
from bnerr.hashing import MASK32, lowbias32, lowbias32_host, signed32

__all__ = ["ONE_MINUS_EPS", "Sampler"]

_INV_2_24 = 1.0 / (1 << 24)
#: The largest float32 below 1 (1 - 2^-24): where a value must stay < 1 after float rounding.
ONE_MINUS_EPS = 1.0 - 2.0**-24


# ------------------------------------------------------------------------------------------------
# 32-bit word helpers (int32 tensors read as unsigned; Python ints in [0, 2^32) on the host)


@overload
def _words(x: int, device: torch.device) -> int: ...
@overload
def _words(x: torch.Tensor, device: torch.device) -> torch.Tensor: ...
@overload
def _words(x: torch.Tensor | int, device: torch.device) -> torch.Tensor | int: ...
def _words(x: torch.Tensor | int, device: torch.device) -> torch.Tensor | int:
    """Low 32 bits of an int64 tensor (or int) as int32 (an int stays a host int in [0, 2^32))."""
    if isinstance(x, int):
        return x & MASK32
    # int64 -> int32 keeps the low 32 bits (modular conversion on every torch backend).
    return x.to(device=device, dtype=torch.int32)


def _hash_small(value: torch.Tensor | int, salt: int) -> torch.Tensor | int:
    """``lowbias32(value ^ salt)`` of a host int (computed on the host) or an int32 tensor."""
    if isinstance(value, int):
        return lowbias32_host(value ^ salt)
    return lowbias32(value ^ signed32(salt))


def _xor_key(words: torch.Tensor, key: torch.Tensor | int) -> torch.Tensor:
    """``words ^ key`` where ``key`` is a host int in [0, 2^32) or an int32 tensor."""
    return words ^ (signed32(key) if isinstance(key, int) else key)


def _to_unit(top24: torch.Tensor, out: torch.Tensor | None = None) -> torch.Tensor:
    """A word < 2^24 as float32 ``top24 * 2^-24``: exact, and always < 1 (into ``out`` if given)."""
    if out is None:
        return top24.to(torch.float32) * _INV_2_24
    return torch.mul(top24, _INV_2_24, out=out)


def _columns(n: int, count: int, device: torch.device) -> torch.Tensor:
    """A ``[count, n]`` float32 buffer: dimension-major, so that each dimension is contiguous."""
    return torch.empty(count, n, dtype=torch.float32, device=device)


# ------------------------------------------------------------------------------------------------
# Input checks of the elementwise functions


def _check_words(name: str, value: object) -> torch.Tensor | int:
    """An int64 tensor, or (for dimensions) a non-negative Python int; returned."""
    if isinstance(value, int) and not isinstance(value, bool):
        if value < 0:
            raise ValueRangeError(f"{name}: expected an integer >= 0, got {value}")
        return value
    value = check_tensor(value, name)
    check_dtype(value, torch.int64, name)
    return value


def _broadcast(names: str, *values: object) -> torch.Size:
    """The broadcast shape of the tensors among ``values`` (``names`` lists them for errors)."""
    shapes = [x.shape for x in values if isinstance(x, torch.Tensor)]
    try:
        return torch.broadcast_shapes(*shapes)
    except RuntimeError:
        raise ShapeError(
            f"{names}: expected broadcastable shapes, got {[list(s) for s in shapes]}"
        ) from None


def _prepare(
    seed: object, index: object, dim: object
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor | int]:
    """Check the elementwise functions' input; return their broadcast int32 words."""
    seed = check_tensor(seed, "seed")
    check_dtype(seed, torch.int64, "seed")
    index = check_tensor(index, "index")
    check_dtype(index, torch.int64, "index")
    dim = _check_words("dim", dim)
    shape = _broadcast("seed, index, dim", seed, index, dim)
    device = seed.device
    seed, index = (_words(x, device).expand(shape) for x in (seed, index))
    if isinstance(dim, torch.Tensor):
        dim = _words(dim, device).expand(shape)
    return seed, index, dim


# ------------------------------------------------------------------------------------------------
# The seam


class Sampler:
    """Base class: gives ``count`` consecutive dimensions for many (seed, index) lanes at once.

    Subclasses implement :meth:`_sample`; :meth:`sample` checks the input once at the boundary.
    A sampler is a pure function of its arguments and its construction options: equal inputs
    give bit-identical outputs, on the device of ``seed``. For the Z-order samplers (``zsobol``,
    ``zsobol_t``, ``cycles_pure``, ``cycles_first``) the per-lane ``seed`` is the pixel's key
    (its Morton code, plain or scrambled), not a random seed: moving a key to another pixel moves
    that pixel's whole sample sequence with it.
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
            seed: ``[N]`` int64, the pixel seed (or key) of each lane (low 32 bits used by the
                hash-seeded samplers).
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


def _check_index_below(index: torch.Tensor, bound: int, what: str) -> None:
    """Raise :class:`ValueRangeError` unless every index lies in ``[0, bound)`` (one reduction)."""
    if index.numel():
        lo, hi = (int(v) for v in torch.aminmax(index))
        if lo < 0 or hi >= bound:
            raise ValueRangeError(
                f"index: expected sample indices in [0, {bound}) ({what}), got min {lo} max {hi}"
            )
