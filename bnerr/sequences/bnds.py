"""Blue-noise dithered sampling (Georgiev & Fajardo 2016): one sequence, rotated per pixel."""

from __future__ import annotations

import torch

from bnerr.errors import DtypeError, ValueRangeError, check_dtype, check_shape
from bnerr.hashing import MASK32
from bnerr.sequences.base import ONE_MINUS_EPS, Sampler, _columns
from bnerr.sequences.owen_sobol import _owen_sobol_columns
from bnerr.sequences.white import _white_columns

__all__ = ["BNDSSampler"]


class BNDSSampler(Sampler):
    """Blue-noise dithered sampling (Georgiev & Fajardo 2016, "Blue-noise Dithered Sampling").

    One Owen-Sobol sequence (seed ``seed0``) is shared by every pixel and Cranley-Patterson
    rotated per pixel by the vector mask (docs/METHODS.md, section 3):

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
        shared = torch.tensor(self.seed0 & MASK32, dtype=torch.int64, device=index.device)
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
