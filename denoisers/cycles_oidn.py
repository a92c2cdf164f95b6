"""``cycles_oidn``: Cycles' own denoiser, the image a Blender user gets from the same samples.

Cycles denoises inside the render (Intel OIDN with its accurate prefilter, fed the Denoising
Albedo and Denoising Normal passes as Cycles computes them), so this denoiser computes nothing: it
returns the denoised Combined pass that rode along with the noisy frame
(``frame.own_denoised["cycles_oidn"]``, :mod:`renderers.cycles.scene`). The noisy colour and the
denoised image come from one render, so both see the same samples, and bnerr's own denoisers run
on the same noisy frame beside it.

Not for: frames from any other renderer (they carry no Cycles output: refused in one line).
"""

from __future__ import annotations

import torch

from bnerr.frame import Frame
from denoisers.base import Denoiser, MissingBufferError

__all__ = ["CyclesOIDN"]


class CyclesOIDN(Denoiser):
    """Cycles' own OIDN output of the frame's samples (module docstring)."""

    name = "cycles_oidn"
    kind = "renderer"  # the renderer's own output: not bnerr's OIDN ("reference"), whose report
    # section reads the first denoiser of that kind

    def denoise(self, frame: Frame) -> torch.Tensor:
        image = frame.own_denoised.get(self.name)
        if image is None:
            raise MissingBufferError(
                f"{self.name}: expected a frame rendered by Cycles with its denoiser's output, got "
                "one without (Cycles' own denoiser runs only on Cycles scenes)"
            )
        return image.to(frame.color.device)
