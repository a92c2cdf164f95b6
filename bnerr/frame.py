"""The Frame: one rendered image with the auxiliary buffers denoisers and strategies use.

A Frame is what a renderer returns and what a denoiser reads. It lives in :mod:`bnerr` (not in
:mod:`renderers`) so that denoisers and strategies can use it without importing a renderer.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import torch

from bnerr.errors import ShapeError, check_dtype, check_shape

__all__ = ["BUFFERS", "Frame"]

#: Buffer name -> number of channels. Every buffer is a float32 ``[C, H, W]`` tensor.
BUFFERS: dict[str, int] = {
    "color": 3,  # linear radiance estimate, the pixel mean over its samples
    "albedo": 3,  # first-hit diffuse reflectance (the texture, if any)
    "normal": 3,  # first-hit world-space shading normal, zero where the ray escaped
    "depth": 1,  # first-hit distance along the camera ray, +inf replaced by 0 where escaped
    "motion": 2,  # screen-space motion (dx, dy) in pixels from frame t-1 to frame t
    "object_id": 1,  # first-hit object index as a float, -1 where the ray escaped
}


@dataclass
class Frame:
    """One frame: ``color [3, H, W]`` plus optional auxiliary buffers, all float32.

    Attributes:
        color: linear RGB radiance ``[3, H, W]``.
        albedo: ``[3, H, W]`` first-hit albedo, or None.
        normal: ``[3, H, W]`` first-hit normal, or None.
        depth: ``[1, H, W]`` first-hit distance, or None.
        motion: ``[2, H, W]`` motion in pixels from t-1 to t, or None. A pixel at (x, y) in frame t
            was at (x - motion[0], y - motion[1]) in frame t-1.
        object_id: ``[1, H, W]`` object index as float (-1: background), or None.
        variance: ``[3, H, W]`` per-pixel sample variance of the color mean (the variance of the
            estimate, i.e. sample variance / spp), or None.
        timings: wall-clock milliseconds by stage name. ``"render"``: time inside the renderer,
            filled by the renderer itself (the one clock every caller reads; a strategy that
            renders several times reports the sum); ``"strategy"``: a seed strategy's own work
            outside the renderer (:meth:`bnerr.strategies.Strategy.frame`); ``"denoise"``: the
            denoiser's (``bnerr denoise``).
        own_denoised: ``[3, H, W]`` images the renderer denoised itself from the same samples, by
            denoiser name (Cycles' own OIDN output rides along as ``"cycles_oidn"``, read by the
            denoiser of that name); empty for a renderer that does not denoise.
    """

    color: torch.Tensor
    albedo: torch.Tensor | None = None
    normal: torch.Tensor | None = None
    depth: torch.Tensor | None = None
    motion: torch.Tensor | None = None
    object_id: torch.Tensor | None = None
    variance: torch.Tensor | None = None
    timings: dict[str, float] = field(default_factory=dict)
    own_denoised: dict[str, torch.Tensor] = field(default_factory=dict)

    def __post_init__(self) -> None:
        size = check_shape(self.color, "3 H W", "Frame.color")
        check_dtype(self.color, torch.float32, "Frame.color")
        channels = dict(BUFFERS, variance=3)
        for name in channels:
            value = getattr(self, name)
            if name == "color" or value is None:
                continue
            got = check_shape(value, f"{channels[name]} H W", f"Frame.{name}")
            check_dtype(value, torch.float32, f"Frame.{name}")
            if got != size:
                raise ShapeError(
                    f"Frame.{name}: expected H x W = {size['H']} x {size['W']} like color, "
                    f"got {got['H']} x {got['W']}"
                )
        for name, image in self.own_denoised.items():
            got = check_shape(image, "3 H W", f"Frame.own_denoised[{name!r}]")
            if got != size:
                raise ShapeError(
                    f"Frame.own_denoised[{name!r}]: expected H x W = {size['H']} x {size['W']} "
                    f"like color, got {got['H']} x {got['W']}"
                )

    @property
    def height(self) -> int:
        return self.color.shape[1]

    @property
    def width(self) -> int:
        return self.color.shape[2]

    def buffers(self) -> dict[str, torch.Tensor]:
        """The buffers that are present, by name (timings excluded)."""
        return {
            f.name: getattr(self, f.name)
            for f in fields(self)
            if f.name not in ("timings", "own_denoised") and getattr(self, f.name) is not None
        }

    def to(self, device: torch.device | str) -> Frame:
        """A copy with every buffer on ``device``."""
        moved = {name: t.to(device) for name, t in self.buffers().items()}
        own = {name: t.to(device) for name, t in self.own_denoised.items()}
        return Frame(**moved, timings=dict(self.timings), own_denoised=own)
