"""Wall-clock timing that covers the device's work: the one home of device sync.

CUDA kernels run asynchronously, so a timer read right after a launch measures the launch, not
the work. :func:`sync` waits for the device of a tensor (or a device) and is a no-op on the CPU;
:class:`Stopwatch` syncs before reading the clock.
"""

from __future__ import annotations

import time

import torch

__all__ = ["Stopwatch", "sync"]


def sync(where: torch.Tensor | torch.device | str | None = None) -> None:
    """Wait until the device of ``where`` (a tensor or a device) has finished its queued work."""
    if where is None:
        return
    device = where.device if isinstance(where, torch.Tensor) else torch.device(where)
    if device.type == "cuda":
        torch.cuda.synchronize(device)


class Stopwatch:
    """Milliseconds since construction (or :meth:`restart`), read after syncing a device.

    Example::

        watch = Stopwatch()
        out = work(x)
        ms = watch.ms(out)  # waits for out's device first
    """

    def __init__(self) -> None:
        self._start = time.perf_counter()

    def restart(self) -> None:
        self._start = time.perf_counter()

    def ms(self, where: torch.Tensor | torch.device | str | None = None) -> float:
        sync(where)
        return (time.perf_counter() - self._start) * 1e3
