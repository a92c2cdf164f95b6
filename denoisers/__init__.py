"""Denoisers: a Frame in, a denoised color ``[3, H, W]`` out, all behind one interface.

Names (the registry, :data:`DENOISERS`):

- ``gaussian``, ``bilateral``, ``median``: kornia filters that read the color only;
- ``joint_bilateral``, ``guided``: kornia filters guided by albedo and normal;
- ``atrous``: the edge-avoiding a-trous wavelet filter, the spatial part of SVGF (normal, depth);
- ``taa``, ``svgf``: temporal accumulation alone, and followed by the a-trous filter guided by the
  variance over time (:mod:`denoisers.temporal`); **stateful**: call ``reset()`` at the start of
  each sequence and feed its frames in order (motion, depth, normal, object_id);
- ``unet``: a small OIDN-style U-Net trained here on white-noise inputs (:mod:`denoisers.train`);
- ``unet_blue``: the same network trained on white and blue-noise inputs (``--mix white+blue``);
- ``oidn``: Intel Open Image Denoise, the production reference (optional extra ``reference``).

``get_denoiser(name, **params)`` builds one; filter parameters come from :mod:`denoisers.tuning`
(tuned per scene and spp on white noise, then used unchanged for every strategy). This package
does not import :mod:`renderers`: training data is made in ``benchmarks.training_data``.
"""

from __future__ import annotations

import inspect

from bnerr.errors import UnknownNameError, check_name
from denoisers.base import Denoiser, MissingBufferError, check_frame
from denoisers.filters import ATrous, Bilateral, Gaussian, Guided, JointBilateral, Median
from denoisers.oidn import OIDN
from denoisers.temporal import SVGF, TAA
from denoisers.unet import UNetBlueDenoiser, UNetDenoiser

__all__ = [
    "DENOISERS",
    "Denoiser",
    "MissingBufferError",
    "check_frame",
    "get_denoiser",
]

#: The denoisers this package ships.
_SHIPPED: tuple[type[Denoiser], ...] = (
    ATrous,
    Bilateral,
    Gaussian,
    Guided,
    JointBilateral,
    Median,
    OIDN,
    SVGF,
    TAA,
    UNetBlueDenoiser,
    UNetDenoiser,
)
#: Registry: name -> Denoiser class. Sorted by name.
DENOISERS: dict[str, type[Denoiser]] = {
    cls.name: cls for cls in sorted(_SHIPPED, key=lambda c: c.name)
}


def get_denoiser(name: str, **params: object) -> Denoiser:
    """Build the denoiser registered as ``name`` with keyword ``params``.

    Raises:
        UnknownNameError: ``name`` is not registered, or a parameter is not one the denoiser
            takes (the message lists the ones it does).
        DtypeError, ValueRangeError: a parameter has the wrong type or is out of range.
        MissingExtraError: ``oidn`` without the ``reference`` extra installed.
        FileFormatError: ``unet`` with a missing or corrupt weights file.
    """
    cls = DENOISERS[check_name(name, list(DENOISERS), "denoiser")]
    accepted = [p for p in inspect.signature(cls.__init__).parameters if p != "self"]
    unknown = sorted(set(params) - set(accepted))
    if unknown:
        raise UnknownNameError(
            f"denoiser {name!r}: unknown parameter(s) {', '.join(unknown)}: expected one of "
            f"{', '.join(accepted) or '(none)'}"
        )
    return cls(**params)
