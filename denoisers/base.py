"""The denoiser interface: a Frame in, a color image ``[3, H, W]`` out.

Every denoiser (the kornia filters, the U-Net, OIDN) is a pure function over tensors plus a thin
class around it that stores its parameters. The class is what the registry hands
out and what the benchmark calls; it checks the frame at the boundary once, so the functions below
it trust their inputs.

Most denoisers keep no state between frames (``stateful = False``): each frame is denoised alone,
so the error a temporal strategy moves between frames is not mixed with an accumulation over time.
The temporal denoisers (:mod:`denoisers.temporal`: TAA, SVGF) do accumulate; they say so with
``stateful = True``. Every denoiser has :meth:`Denoiser.reset` and takes an optional frame index
``t``, so a caller treats all of them alike: reset at the start of each sequence, feed its frames in
order. For a stateless denoiser both are no-ops.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import ClassVar

import torch

from bnerr import plugins
from bnerr.errors import (
    BnerrError,
    DtypeError,
    check_dtype,
    check_finite,
    check_shape,
    check_tensor,
)
from bnerr.frame import BUFFERS, Frame

__all__ = ["Denoiser", "MissingBufferError", "check_frame", "check_output", "required"]

_CHANNELS = dict(BUFFERS, variance=3)


class MissingBufferError(BnerrError, ValueError):
    """A frame lacks an auxiliary buffer (albedo, normal, depth, ...) that a denoiser needs."""


def check_output(out: object, frame: Frame, name: str) -> torch.Tensor:
    """Raise unless ``out`` is a float32 ``[3, H, W]`` tensor of ``frame``'s size on its device.

    Raises:
        DtypeError: not a tensor, not float32, or on another device.
        ShapeError: not ``[3, H, W]``.
    """
    out = check_tensor(out, name)
    check_shape(out, f"3 {frame.height} {frame.width}", name)
    check_dtype(out, torch.float32, name)
    if out.device != frame.color.device:
        raise DtypeError(
            f"{name}: expected a tensor on the frame's device {frame.color.device}, "
            f"got one on {out.device}"
        )
    return out


def check_frame(
    frame: object,
    requires: frozenset[str],
    who: str,
    infinite_ok: frozenset[str] = frozenset(),
) -> Frame:
    """Check that ``frame`` is a :class:`~bnerr.frame.Frame` holding every buffer in ``requires``.

    Also checks that every buffer read (its color and those in ``requires``) is finite: one NaN
    spreads over the whole support of a filter (or the receptive field of a network), and the
    place it came from is then lost. The error names the buffer, the count and the first pixel.
    Buffers in ``infinite_ok`` may hold ``+inf`` (a depth of ``+inf`` marks an escaped ray in
    some renderers; the denoiser that allows it says how it reads it); NaN and ``-inf`` are
    still refused there.

    Raises:
        DtypeError: ``frame`` is not a Frame.
        MissingBufferError: a required buffer is None; the message names it and the denoiser.
        ShapeError: a buffer's shape does not match ``[C, H, W]`` of the color.
        NonFiniteError: a buffer read holds NaN or infinity (``+inf`` where allowed aside).
    """
    if not isinstance(frame, Frame):
        raise DtypeError(f"{who}: expected a bnerr.frame.Frame, got {type(frame).__name__}")
    missing = sorted(name for name in requires if getattr(frame, name, None) is None)
    if missing:
        raise MissingBufferError(
            f"{who}: expected a frame with buffer(s) {', '.join(sorted(requires))}, "
            f"got a frame without {', '.join(missing)}"
        )
    # Frame's own __post_init__ checked shapes when it was built; buffers assigned afterwards were
    # not, so check again here, where a wrong shape would otherwise fail deep inside a filter.
    size = check_shape(frame.color, "3 H W", f"{who}: frame.color")
    for name in sorted(requires):
        channels = _CHANNELS.get(name, 3)
        check_shape(
            getattr(frame, name), f"{channels} {size['H']} {size['W']}", f"{who}: frame.{name}"
        )
    for name in ("color", *sorted(requires)):
        values = getattr(frame, name)
        if name in infinite_ok:
            values = torch.where(torch.isposinf(values), torch.zeros_like(values), values)
        check_finite(values, f"{who}: frame.{name}")
    return frame


def required(frame: Frame, name: str) -> torch.Tensor:
    """``frame``'s buffer ``name``, which the denoiser declared in ``requires`` (so
    :func:`check_frame` found it present): typed as a tensor for the denoiser's function.

    Raises:
        MissingBufferError: the buffer is None (a caller that skipped :func:`check_frame`).
    """
    buffer = getattr(frame, name)
    if buffer is None:
        raise MissingBufferError(f"frame.{name}: expected a tensor, got None")
    return buffer


class Denoiser:
    """Base class: maps a :class:`~bnerr.frame.Frame` to a denoised color ``[3, H, W]``.

    Subclasses set ``name``, set ``requires`` (the auxiliary buffers they read, besides color) and
    implement :meth:`denoise`. ``__call__`` checks the frame (a missing buffer raises
    :class:`MissingBufferError` naming it, a non-finite one :class:`NonFiniteError`) and returns
    a float32 tensor on the frame's device, checked finite: a denoiser never hands back NaN.

    Stateful subclasses set ``stateful = True`` and override :meth:`reset` and
    :meth:`_check_sequence` (called with the frame and its index before :meth:`denoise`).

    Attributes:
        name: the registry name (``"gaussian"``, ``"unet"``, ...).
        requires: buffer names the denoiser reads besides ``color``.
        infinite_ok: buffers of ``requires`` that may hold ``+inf`` (see :func:`check_frame`).
        stateful: whether the output depends on the frames denoised before (since :meth:`reset`).
        kind: what kind of denoiser it is, for the reports' sections and the suites:
            ``"filter"`` (a classic single-frame filter, the default), ``"temporal"``
            (accumulates over frames), ``"learned"`` (a network trained here), ``"reference"``
            (the production denoiser the others are judged against: OIDN) or a new kind's name.
        grid: its tuning grid, parameter -> candidate values (:func:`denoisers.tuning.tune`
            searches it on white noise); empty when it is not tuned.
        Subclasses inherit these unless they set their own; :func:`denoisers.denoiser_identity`
        reads them by name.
    """

    name: ClassVar[str] = ""
    stateful: ClassVar[bool] = False
    kind: ClassVar[str] = "filter"
    grid: ClassVar[Mapping[str, Sequence[object]]] = MappingProxyType({})
    requires: frozenset[str] = frozenset()
    infinite_ok: frozenset[str] = frozenset()

    def __call__(self, frame: Frame, t: int | None = None) -> torch.Tensor:
        """Denoise ``frame`` (``[3, H, W]`` out); ``t`` is its index in the sequence, if known.

        Raises:
            DtypeError: ``t`` is not an int (or None).
            SequenceError: (stateful denoisers) ``t`` does not follow the previous frame's index,
                or the frame's size is not the sequence's; see :mod:`denoisers.temporal`.
        """
        who = f"denoiser {self.name!r}"
        frame = check_frame(frame, self.requires, who, self.infinite_ok)
        if t is not None and (isinstance(t, bool) or not isinstance(t, int)):
            raise DtypeError(f"{who}: t: expected an int frame index, got {t!r}")
        self._check_sequence(frame, t)
        out = self._denoise_named(frame, t)
        # Catch a subclass that breaks the contract here rather than in the caller's metric.
        check_output(out, frame, f"{who} output")
        check_finite(out, f"{who} output (finite input)")
        return out

    def _denoise_named(self, frame: Frame, t: int | None) -> torch.Tensor:
        """:meth:`denoise`; a plug-in's own error (not bnerr's typed ones, not out of memory)
        becomes a one-line :class:`~bnerr.errors.PluginError` naming the plug-in."""
        try:
            return self.denoise(frame)
        except (BnerrError, MemoryError):
            raise
        except Exception as err:
            plugin = plugins.loaded("bnerr.denoisers", self.name)
            if plugin is None or "out of memory" in str(err):
                raise
            where = "" if t is None else f" {t}"
            raise plugins.plugin_failure(plugin, f"to denoise frame{where}", err) from err

    def reset(self) -> None:
        """Forget every frame seen so far: the next frame starts a new sequence (no-op here)."""

    def _check_sequence(self, frame: Frame, t: int | None) -> None:
        """Check that ``frame`` (index ``t``) continues the sequence, and record it (no-op here)."""

    def denoise(self, frame: Frame) -> torch.Tensor:
        """Denoise a frame already checked by ``__call__``; return ``[3, H, W]`` float32."""
        raise NotImplementedError(f"{type(self).__name__} does not implement denoise()")

    def params(self) -> dict[str, float | int | str]:
        """The settings that define this denoiser, as stored by :mod:`denoisers.tuning`."""
        return {}

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.params().items())
        return f"{type(self).__name__}({args})"
