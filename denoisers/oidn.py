"""Intel Open Image Denoise as the reference production denoiser (optional extra ``reference``).

Afra et al., "Intel Open Image Denoise" (https://www.openimagedenoise.org), through the ``pyoidn``
bindings: the ``RT`` filter in HDR mode with albedo and normal, at "high" quality, with the
auxiliary buffers prefiltered by OIDN itself (they are noisy at low spp: ``clean_aux=False``).

OIDN is a fixed network trained on far more data than ours; it is here to show what a production
denoiser does with white and blue-noise input, not to be tuned. Measured on the project's 2-core
CPU machine: about 1.4 s for 1920 x 1080.
"""

from __future__ import annotations

import importlib
from collections.abc import Sequence
from types import ModuleType

import torch

from bnerr.errors import MissingExtraError, check_name
from bnerr.frame import Frame
from denoisers.base import Denoiser, required

__all__ = ["OIDN", "available_denoisers", "load_pyoidn", "oidn_denoise"]


def load_pyoidn() -> ModuleType:
    """Import ``pyoidn``, or raise :class:`MissingExtraError` naming the extra that provides it."""
    try:
        return importlib.import_module("pyoidn")
    except ImportError as err:
        raise MissingExtraError(
            "oidn", "reference", "pyoidn", f"{type(err).__name__}: {err}"
        ) from None


def available_denoisers(names: Sequence[str]) -> list[str]:
    """``names`` without ``oidn`` when its optional extra is missing (:func:`load_pyoidn`)."""
    try:
        load_pyoidn()
    except MissingExtraError:
        return [n for n in names if n != "oidn"]
    return list(names)


def oidn_denoise(
    color: torch.Tensor,
    albedo: torch.Tensor,
    normal: torch.Tensor,
    quality: str = "high",
    pyoidn: ModuleType | None = None,
) -> torch.Tensor:
    """Denoise ``color [3, H, W]`` with OIDN's RT filter, guided by ``albedo`` and ``normal``.

    Transposes to OIDN's ``[H, W, 3]`` layout and back; clamps color to >= 0 (OIDN's HDR domain),
    albedo to [0, 1] and normal to [-1, 1] (OIDN's documented input ranges). Runs on the tensors'
    device when pyoidn supports it (CPU always; CUDA when pyoidn was built with it).
    """
    oidn = pyoidn if pyoidn is not None else load_pyoidn()

    def hwc(x: torch.Tensor) -> torch.Tensor:
        return x.permute(1, 2, 0).contiguous()

    out = oidn.denoise(
        hwc(color.clamp_min(0.0)),
        hwc(albedo.clamp(0.0, 1.0)),
        hwc(normal.clamp(-1.0, 1.0)),
        hdr=True,
        quality=quality,
    )
    return out.permute(2, 0, 1).contiguous()


class OIDN(Denoiser):
    """Intel Open Image Denoise behind the Denoiser interface; see :func:`oidn_denoise`.

    Raises :class:`MissingExtraError` at construction when the ``reference`` extra is missing.
    """

    name = "oidn"
    kind = "reference"
    requires = frozenset({"albedo", "normal"})

    _QUALITIES = ("balanced", "fast", "high")

    def __init__(self, quality: str = "high") -> None:
        self.quality = check_name(quality, self._QUALITIES, "oidn quality")
        self._pyoidn = load_pyoidn()

    def denoise(self, frame: Frame) -> torch.Tensor:
        return oidn_denoise(
            frame.color,
            required(frame, "albedo"),
            required(frame, "normal"),
            self.quality,
            self._pyoidn,
        )

    def params(self) -> dict[str, float | int | str]:
        return {"quality": self.quality}
