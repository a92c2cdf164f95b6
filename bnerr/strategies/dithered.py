"""Dithered sampling: one shared sequence per frame, rotated per pixel by a blue-noise mask.

- ``bnds``: blue-noise dithered sampling (Georgiev & Fajardo 2016): one shared Owen-Sobol
  sequence per frame, Cranley-Patterson rotated per pixel by the vector mask at the frame's R2
  offset (``make_sampler("bnds", ...)``); dimensions beyond the mask's fall back to per-pixel
  white noise keyed by white's seeds.
- ``bnds_st``: ``bnds`` with spatiotemporal blue-noise slices (:func:`bnerr.masks.stbn.load_stbn`,
  vector, 64x64x32, D = 2 per slice) instead of one mask shifted by the R2 step: frame t rotates
  dimension pair k (dimensions 2k, 2k + 1) by slice ``(t + k * F // P) mod F`` of the STBN mask,
  ``P`` the number of pairs and F = 32 its slices, unshifted. Each pair thus gets its own slice
  (pairs never share a rotation within a frame) and each pixel's rotation of one pair follows the
  mask's blue series along t. ``P`` is the channel count ``bnds`` would take (the shipped vector
  mask with the fewest channels covering the scene's D, 2, 4 or 8) divided by 2, so ``bnds_st``
  and ``bnds`` rotate the same dimensions and both fall back to white noise beyond them.

Both dictate their own sampler (``bnds``) and ignore the per-pixel sampler condition.
"""

from __future__ import annotations

import torch

from bnerr.errors import ShapeError, ValueRangeError, check_positive_int, check_tensor
from bnerr.frame import Frame
from bnerr.hashing import lowbias32_host
from bnerr.masks import frame_offset, load_mask, shipped_masks
from bnerr.masks.stbn import load_stbn, stbn_frame
from bnerr.sequences import make_sampler
from bnerr.strategies.base import BuildOptions, RenderFn, Strategy, pixel_seeds, stream_key
from bnerr.strategies.variants import TemporalOptions

__all__ = ["CRANLEY_PATTERSON_NOTE", "STBN_MASK", "BNDSSTStrategy", "BNDSStrategy", "vector_dims"]

#: Why bnds' and bnds_st's raw MSE differs from white's (their ``raw_mse_note``).
CRANLEY_PATTERSON_NOTE = (
    "Cranley-Patterson rotation of one sequence shared by all pixels: an independently written "
    "sampler that shifts the shared sequence by uniform random offsets, with no mask, has the "
    "same excess over per-pixel Owen-scrambled Sobol (docs/METHODS.md, section 3)."
)

#: The STBN mask ``bnds_st`` dithers with: ``load_stbn("vector", 64, 32)``.
STBN_MASK = ("vector", 64, 32)


def vector_dims(size: int, dimensions: int | None, mask_dims: int | None) -> int:
    """Channels of the shipped vector mask of size T with the fewest covering ``dimensions``
    (the most channels if none covers them; ``mask_dims`` forces a count)."""
    if mask_dims is not None:
        return mask_dims
    dims = sorted(m[2] for m in shipped_masks() if m[0] == "vector" and m[1] == size)
    wanted = 2 if dimensions is None else dimensions
    return next((d for d in dims if d >= wanted), dims[-1] if dims else wanted)


class BNDSStrategy(Strategy):
    """``bnds``: one shared sequence per frame, dithered per pixel by the vector mask at offset o_t.

    The shared sequence's seed changes every frame (like white's seeds), and the per-pixel seeds
    (used by the dimensions beyond the mask's) are fresh every frame. Memory as white's.
    """

    name = "bnds"
    own_sampler = "bnds"
    stream = 3
    family = "rival"
    rank = 10
    raw_mse_note = CRANLEY_PATTERSON_NOTE
    color = "#1f77b4"

    def __init__(
        self,
        height: int,
        width: int,
        *,
        seed: int = 0,
        mask: torch.Tensor,
        device: torch.device | str = "cpu",
    ) -> None:
        super().__init__(height, width, seed=seed, device=device)
        check_tensor(mask, "mask")
        self.mask = mask
        self.mask_size = mask.shape[-1]

    @classmethod
    def create(
        cls, height: int, width: int, build: BuildOptions, options: TemporalOptions
    ) -> Strategy:
        channels = vector_dims(build.mask_size, build.dimensions, build.mask_dims)
        mask = load_mask("vector", build.mask_size, channels)
        return cls(height, width, mask=mask, **build.common)

    def _frame(self, t: int, render: RenderFn) -> Frame:
        key = stream_key(self.seed, t, self.stream)
        sampler = make_sampler(
            "bnds",
            mask=self.mask,
            offset=frame_offset(t, self.mask_size),
            seed0=lowbias32_host(key + 1),
        )
        return render(pixel_seeds(self.height, self.width, key, self.device), sampler)


class BNDSSTStrategy(Strategy):
    """``bnds_st``: Georgiev-Fajardo dithering with spatiotemporal blue-noise slices.

    Frame t rotates dimension pair k by slice ``(t + k * (F // P)) mod F`` of the vector STBN mask
    ``[F, 2, T, T]`` (``P = channels // 2`` pairs; see the module docstring), unshifted. As in
    ``bnds``, the shared sequence's seed and the per-pixel seeds of the dimensions beyond the
    mask's are fresh every frame. Memory as white's (34 bytes per pixel measured).

    Args:
        stbn: ``[F, 2, T, T]`` float32 vector STBN mask in [0, 1)
            (:func:`bnerr.masks.stbn.load_stbn`).
        channels: rotated dimensions, even, >= 2 (pairs of slices).
    """

    name = "bnds_st"
    own_sampler = "bnds"
    stream = 8
    family = "rival"
    rank = 20
    raw_mse_note = CRANLEY_PATTERSON_NOTE
    color = "#6baed6"

    def __init__(
        self,
        height: int,
        width: int,
        *,
        seed: int = 0,
        stbn: torch.Tensor,
        channels: int = 2,
        device: torch.device | str = "cpu",
    ) -> None:
        super().__init__(height, width, seed=seed, device=device)
        check_tensor(stbn, "stbn")
        if stbn.ndim != 4 or stbn.shape[1] != 2 or stbn.shape[0] < 1:
            raise ShapeError(f"stbn: expected [F, 2, T, T] with F >= 1, got {list(stbn.shape)}")
        channels = check_positive_int(channels, "channels", minimum=2)
        if channels % 2:
            raise ValueRangeError(f"channels: expected an even number, got {channels}")
        self.stbn = stbn
        self.pairs = channels // 2
        self.slice_step = max(1, stbn.shape[0] // self.pairs)

    @classmethod
    def create(
        cls, height: int, width: int, build: BuildOptions, options: TemporalOptions
    ) -> Strategy:
        channels = vector_dims(build.mask_size, build.dimensions, build.mask_dims)
        stbn = load_stbn(*STBN_MASK)
        return cls(height, width, stbn=stbn, channels=channels, **build.common)

    def slices(self, t: int) -> list[int]:
        """The STBN slice of each dimension pair in frame ``t``: ``[P]`` indices in [0, F)."""
        frames = self.stbn.shape[0]
        return [(t + k * self.slice_step) % frames for k in range(self.pairs)]

    def mask(self, t: int) -> torch.Tensor:
        """Frame ``t``'s vector mask ``[2P, T, T]``: the pairs' slices stacked, in order."""
        return torch.cat([stbn_frame(self.stbn, i) for i in self.slices(t)])

    def _frame(self, t: int, render: RenderFn) -> Frame:
        key = stream_key(self.seed, t, self.stream)
        sampler = make_sampler(
            "bnds", mask=self.mask(t), offset=(0, 0), seed0=lowbias32_host(key + 1)
        )
        return render(pixel_seeds(self.height, self.width, key, self.device), sampler)
