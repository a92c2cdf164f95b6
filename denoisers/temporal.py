"""Temporal accumulation: the history a real-time renderer blends every new frame into.

Real-time path tracers seldom denoise one frame alone. They reproject the previous output along the
motion vectors, reject it where the surface seen there is another one (a disocclusion), and blend:
``out = a * current + (1 - a) * history`` (docs/METHODS.md, section 9).

- :class:`TAA` (``taa``): that accumulation alone, with the blend factor ``alpha`` tuned like any
  filter parameter. Karis 2014, "High Quality Temporal Supersampling" (SIGGRAPH course), without
  the neighbourhood colour clamp: on path-traced input the clamp box is as noisy as the pixel and
  would throw the history away exactly where it helps.
- :class:`SVGF` (``svgf``): the accumulation followed by the edge-avoiding a-trous filter, whose
  luminance edge-stopping reads the variance estimated over time from accumulated first and second
  moments where a pixel has history, the spatial estimate where it has not. Schied et al. 2017,
  "Spatiotemporal Variance-Guided Filtering" (HPG), sections 4.1-4.4.

Both keep state between frames: they are **stateful denoisers** (``stateful = True``). Call
:meth:`TemporalDenoiser.reset` at the start of every sequence and feed its frames in order; pass
the frame index ``t`` to have the order checked. A frame of another resolution than the history,
or a frame index that does not follow the previous one, raises :class:`SequenceError`.

What differs from SVGF: the history is the accumulated colour before the spatial filter (SVGF feeds
back the first a-trous iteration's output), and there is no albedo demodulation (for the reason
:func:`denoisers.filters.atrous_filter` gives).

Not for: reprojecting across frames of different cameras' resolutions, or motion that is not
screen-space pixels from t-1 to t (the :class:`~bnerr.frame.Frame` convention).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import torch

from bnerr.color import luminance
from bnerr.errors import BnerrError, check_positive_int, check_range
from bnerr.frame import Frame
from denoisers.base import Denoiser, required
from denoisers.filters import atrous_filter

__all__ = ["SVGF", "TAA", "SequenceError", "TemporalDenoiser", "check_continues", "reproject"]

# A history tap is consistent with the current pixel when it shows the same object, at a depth
# within this relative tolerance, with normals at most ~25 degrees apart (SVGF's consistency test).
_DEPTH_TOLERANCE = 0.1
_NORMAL_COS = 0.9
# Below this summed bilinear weight of consistent taps the history is rejected (a = 1).
_MIN_WEIGHT = 1e-3
# SVGF: pixels with fewer accumulated frames than this use the spatial variance estimate.
_MIN_MOMENT_FRAMES = 4


class SequenceError(BnerrError, ValueError):
    """A stateful denoiser got a frame that does not continue its sequence."""


def check_continues(
    who: str, before: torch.Size | None, shape: torch.Size, t_before: int | None, t: int | None
) -> None:
    """Refuse a frame that does not continue a stateful denoiser's sequence.

    Args:
        who: names the denoiser in the message.
        before: the shape of the sequence's frames so far, None at its start (nothing to check).
        shape: the new frame's color shape.
        t_before, t: the previous frame's index and the new one's (None: not told, not checked).

    Raises:
        SequenceError: ``shape`` is not ``before``, or ``t`` is not ``t_before + 1``.
    """
    if before is not None and before != shape:
        raise SequenceError(
            f"{who}: expected frames of {list(before)} like the sequence so far, "
            f"got {list(shape)}; call reset() between sequences"
        )
    if before is not None and t is not None and t_before is not None and t != t_before + 1:
        raise SequenceError(
            f"{who}: expected frame {t_before + 1} after frame {t_before}, "
            f"got frame {t}; feed frames in order, or call reset() to start a new sequence"
        )


@dataclass
class _History:
    """What a temporal denoiser keeps from the previous frame (all ``[C, H, W]`` float32)."""

    color: torch.Tensor  # accumulated colour [3, H, W]
    moments: torch.Tensor  # accumulated luminance moments (mean, mean of squares) [2, H, W]
    length: torch.Tensor  # frames accumulated per pixel [1, H, W]
    depth: torch.Tensor  # [1, H, W]
    normal: torch.Tensor  # [3, H, W]
    object_id: torch.Tensor  # [1, H, W]


def _consistent(
    frame: Frame, history: _History, iy: torch.Tensor, ix: torch.Tensor
) -> torch.Tensor:
    """``[H, W]`` bool: the history pixel ``(iy, ix)`` shows the surface the current pixel shows."""
    object_id = required(frame, "object_id")[0]
    same_id = history.object_id[0, iy, ix] == object_id
    d_now, d_then = required(frame, "depth")[0], history.depth[0, iy, ix]
    close = (d_now - d_then).abs() <= _DEPTH_TOLERANCE * torch.maximum(d_now, d_then)
    cos = (history.normal[:, iy, ix] * required(frame, "normal")).sum(0)
    background = object_id < 0  # escaped rays: no depth or normal to compare
    return same_id & (background | (close & (cos >= _NORMAL_COS)))


def reproject(frame: Frame, history: _History) -> tuple[torch.Tensor, torch.Tensor]:
    """Fetch the history at ``p - motion(p)`` with a bilinear filter over its consistent taps.

    Args:
        frame: the current frame (motion, depth, normal, object_id present and checked).
        history: the previous frame's state, same ``H x W``.

    Returns:
        ``(stacked [6, H, W], valid [1, H, W])``: the bilinear fetch of the history's colour (3),
        moments (2) and length (1), renormalised over the taps that lie on screen and show the
        same surface; ``valid`` is 1.0 where their summed weight is at least ``1e-3``, else 0.0
        (and ``stacked`` is 0 there).
    """
    _, h, w = frame.color.shape
    dev, dt = frame.color.device, frame.color.dtype
    motion = required(frame, "motion")
    ys = torch.arange(h, device=dev, dtype=dt)[:, None] - motion[1]
    xs = torch.arange(w, device=dev, dtype=dt)[None, :] - motion[0]
    y0, x0 = ys.floor(), xs.floor()
    fy, fx = ys - y0, xs - x0
    state = torch.cat([history.color, history.moments, history.length])
    total = torch.zeros_like(state)
    weight = torch.zeros((h, w), device=dev, dtype=dt)
    for oy, wy in ((0, 1 - fy), (1, fy)):
        for ox, wx in ((0, 1 - fx), (1, fx)):
            ty, tx = y0 + oy, x0 + ox
            inside = (ty >= 0) & (ty < h) & (tx >= 0) & (tx < w)
            iy = ty.clamp(0, h - 1).long()
            ix = tx.clamp(0, w - 1).long()
            wt = torch.where(inside & _consistent(frame, history, iy, ix), wy * wx, 0.0)
            total += wt * state[:, iy, ix]
            weight += wt
    valid = weight >= _MIN_WEIGHT
    stacked = torch.where(valid, total / weight.clamp_min(_MIN_WEIGHT), 0.0)
    return stacked, valid[None].to(dt)


class TemporalDenoiser(Denoiser):
    """Base class of the stateful denoisers: history, reset, order and resolution checks.

    Subclasses implement :meth:`_output` (what to return from the accumulated state).

    Attributes:
        stateful: True: the benchmark resets it per sequence and feeds frames in order.
        alpha: the blend factor of the current frame, in (0, 1].
    """

    stateful: ClassVar[bool] = True
    kind = "temporal"
    requires = frozenset({"motion", "depth", "normal", "object_id"})

    def __init__(self, alpha: float = 0.2) -> None:
        self.alpha = float(check_range(alpha, f"{self.name}: alpha", 0.01, 1.0))
        self.reset()

    def reset(self) -> None:
        """Forget the history: the next frame starts a new sequence."""
        self._history: _History | None = None
        self._t: int | None = None

    def _check_sequence(self, frame: Frame, t: int | None) -> None:
        """Refuse a frame of another size than the history, or an index that does not follow."""
        before = None if self._history is None else self._history.color.shape
        check_continues(f"denoiser {self.name!r}", before, frame.color.shape, self._t, t)
        self._t = t

    def denoise(self, frame: Frame) -> torch.Tensor:
        color = frame.color
        lum = luminance(color)[None]
        moments = torch.cat([lum, lum * lum])
        if self._history is None:
            acc, acc_m, length = color, moments, torch.ones_like(lum)
        else:
            fetched, valid = reproject(frame, self._history)
            length = valid * fetched[5:6] + 1.0
            # Early frames average uniformly (1 / n) until the exponential weight takes over.
            a = torch.maximum(torch.full_like(length, self.alpha), 1.0 / length)
            acc = a * color + (1 - a) * fetched[:3]
            acc_m = a * moments + (1 - a) * fetched[3:5]
        guides = (required(frame, name) for name in ("depth", "normal", "object_id"))
        self._history = _History(acc, acc_m, length, *guides)
        return self._output(frame, acc, acc_m, length)

    def _output(
        self, frame: Frame, color: torch.Tensor, moments: torch.Tensor, length: torch.Tensor
    ) -> torch.Tensor:
        raise NotImplementedError(f"{type(self).__name__} does not implement _output()")

    def params(self) -> dict[str, float | int | str]:
        return {"alpha": self.alpha}


class TAA(TemporalDenoiser):
    """Temporal accumulation alone: the reprojected, consistency-checked exponential average."""

    name = "taa"
    grid = {"alpha": (0.05, 0.1, 0.2, 0.3, 0.5)}

    def _output(
        self, frame: Frame, color: torch.Tensor, moments: torch.Tensor, length: torch.Tensor
    ) -> torch.Tensor:
        return color


class SVGF(TemporalDenoiser):
    """Temporal accumulation, then the a-trous filter guided by the temporal variance.

    The defaults (2 iterations, ``sigma_color = 1``) are not the paper's (5 and 4): those assume
    albedo-demodulated input, and on our frames they blurred the Cornell box's light into its
    ceiling (32 x 32, 4 spp, alpha 0.3, frames 2-4: 2.0 times the noisy MSE, against 0.21 with
    these; every named scene at most 0.37 times). The tuning grid picks the values per scene.
    """

    name = "svgf"
    grid = {"alpha": (0.1, 0.2, 0.4), "iterations": (1, 3), "sigma_color": (0.5, 1.0, 2.0)}

    def __init__(
        self,
        alpha: float = 0.2,
        iterations: int = 2,
        sigma_color: float = 1.0,
        sigma_normal: float = 128.0,
        sigma_depth: float = 1.0,
    ) -> None:
        # atrous_filter checks the ranges it needs; check here too so a bad value fails at
        # construction, not at the first frame.
        self.iterations = check_positive_int(iterations, "svgf: iterations")
        check_range(iterations, "svgf: iterations", 1, 10)
        self.sigma_color = float(check_range(sigma_color, "svgf: sigma_color", 1e-3, 1e4))
        self.sigma_normal = float(check_range(sigma_normal, "svgf: sigma_normal", 0.0, 1e4))
        self.sigma_depth = float(check_range(sigma_depth, "svgf: sigma_depth", 1e-3, 1e4))
        super().__init__(alpha)

    def _output(
        self, frame: Frame, color: torch.Tensor, moments: torch.Tensor, length: torch.Tensor
    ) -> torch.Tensor:
        temporal = (moments[1:2] - moments[0:1] ** 2).clamp_min(0.0)
        # Where too few frames were accumulated the moments say little, and where a firefly's
        # squared luminance overflowed they say nothing: atrous_filter's own spatial estimate is
        # used there (NaN marks those pixels).
        usable = (length >= _MIN_MOMENT_FRAMES) & torch.isfinite(temporal)
        variance = torch.where(usable, temporal, float("nan"))
        return atrous_filter(
            color,
            required(frame, "normal"),
            required(frame, "depth"),
            self.iterations,
            self.sigma_color,
            self.sigma_normal,
            self.sigma_depth,
            variance=variance[0],
        )

    def params(self) -> dict[str, float | int | str]:
        return {
            "alpha": self.alpha,
            "iterations": self.iterations,
            "sigma_color": self.sigma_color,
            "sigma_normal": self.sigma_normal,
            "sigma_depth": self.sigma_depth,
        }
