"""Sample sequences: the only source of random numbers the renderer sees (METHODS.md section 3).

A sequence is a deterministic function ``X(seed, index, dim) -> [0, 1)`` of a pixel's seed, the
sample index ``i < spp`` and the integrand dimension ``d``. The renderer asks a :class:`Sampler`
for ``count`` consecutive dimensions of many (seed, index) lanes at once and never calls
``torch.rand`` (STYLE.md habit 5; Mitsuba 3's ``Sampler.next_1d``, pbrt-v4's ``Get1D``/``Get2D``).

Integer arithmetic: torch has almost no uint32 support, so every 32-bit word is held in an int64
tensor and masked back to 32 bits after each operation that can carry out of them. Seeds, indices
and dimensions use their low 32 bits (an index of 2^32 aliases index 0; no renderer gets there).

Not for: cryptography, or anything that needs statistically independent streams across more than
2^32 seeds.
"""

from __future__ import annotations

import torch

from bnerr.errors import (
    ShapeError,
    check_dtype,
    check_name,
    check_positive_int,
    check_shape,
    check_tensor,
)

__all__ = [
    "SAMPLERS",
    "Sampler",
    "WhiteSampler",
    "make_sampler",
    "white",
]

_MASK32 = 0xFFFFFFFF
_INV_2_24 = 1.0 / (1 << 24)


def _mul32(x: torch.Tensor, c: int) -> torch.Tensor:
    """``x * c mod 2^32`` for ``0 <= x < 2^32`` held in int64, without signed overflow.

    A plain int64 product of two 32-bit words reaches 2^64 and overflows int64, which is
    undefined behaviour in C++ even if it wraps in practice. Splitting ``c`` into 16-bit halves
    keeps every intermediate below 2^49.
    """
    lo, hi = c & 0xFFFF, c >> 16
    return (x * lo + (((x * hi) & 0xFFFF) << 16)) & _MASK32


def _lowbias32(x: torch.Tensor) -> torch.Tensor:
    """Chris Wellons' ``lowbias32`` integer hash (bias 0.17), a bijection of 32-bit words.

    Source: https://nullprogram.com/blog/2018/07/31/ ("Prospecting for Hash Functions").
    """
    x = x ^ (x >> 16)
    x = _mul32(x, 0x7FEB352D)
    x = x ^ (x >> 15)
    x = _mul32(x, 0x846CA68B)
    return x ^ (x >> 16)


def _hash3(a: torch.Tensor, b: torch.Tensor | int, c: torch.Tensor | int) -> torch.Tensor:
    """A 32-bit hash of three 32-bit words (a chain of ``lowbias32``, each word folded in turn)."""
    h = _lowbias32((torch.as_tensor(c, device=a.device) & _MASK32) ^ 0x9E3779B9)
    h = _lowbias32(h ^ (torch.as_tensor(b, device=a.device) & _MASK32))
    return _lowbias32(h ^ (a & _MASK32))


def _to_unit(h: torch.Tensor) -> torch.Tensor:
    """The top 24 bits of a 32-bit word as float32 in [0, 1): every value is exact, and < 1."""
    return (h >> 8).to(torch.float32) * _INV_2_24


def _check_int_tensors(**tensors: torch.Tensor | int) -> None:
    """Raise DtypeError unless every argument is an int64 tensor or a Python int."""
    for name, value in tensors.items():
        if isinstance(value, int) and not isinstance(value, bool):
            continue
        check_tensor(value, name)
        check_dtype(value, torch.int64, name)


def white(seed: torch.Tensor, index: torch.Tensor, dim: torch.Tensor | int) -> torch.Tensor:
    """White noise: a counter-based hash of (seed, index, dim) mapped to [0, 1).

    ``u = (h >> 8) * 2^-24`` with ``h`` a ``lowbias32`` hash chain of the three words, so u is a
    multiple of 2^-24 and always < 1 in float32 (METHODS.md section 3, "white").

    Args:
        seed: int64 tensor, any shape; its low 32 bits are used.
        index: int64 tensor broadcastable with ``seed``: the sample index.
        dim: int64 tensor or int broadcastable with both: the dimension.

    Returns:
        float32 tensor of the broadcast shape, on ``seed``'s device, values in [0, 1).

    Not for: low-discrepancy integration (see :func:`owen_sobol`); it is the baseline that every
    other sequence is compared against.
    """
    _check_int_tensors(seed=seed, index=index, dim=dim)
    return _to_unit(_hash3(seed, index, dim))


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
            index: ``[N]`` int64, the sample index of each lane.
            dim: first dimension, an int >= 0.
            count: number of consecutive dimensions, an int >= 1.
            pixel: ``[N, 2]`` int64 pixel coordinates ``(y, x)`` of each lane; required by
                samplers with ``needs_pixel`` (bnds), ignored by the others.

        Returns:
            ``[N, count]`` float32 in [0, 1), on ``seed``'s device.
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
                f"pixel: expected a [N, 2] int64 tensor of (y, x) for sampler {self.name!r}, got None"
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
    """Independent white noise per (seed, index, dim): see :func:`white`."""

    name = "white"

    def _sample(self, seed, index, dim, count, pixel):
        dims = torch.arange(dim, dim + count, dtype=torch.int64, device=seed.device)
        return _to_unit(_hash3(seed[:, None], index[:, None], dims[None, :]))


#: Sampler name -> class. ``make_sampler`` looks names up here.
SAMPLERS: dict[str, type[Sampler]] = {
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
