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
from denoisers.identity import DenoiserIdentity, identity_in, of_kind
from denoisers.oidn import OIDN
from denoisers.temporal import SVGF, TAA
from denoisers.unet import UNetBlueDenoiser, UNetDenoiser

__all__ = [
    "DENOISERS",
    "Denoiser",
    "DenoiserIdentity",
    "MissingBufferError",
    "check_frame",
    "denoiser_identity",
    "denoisers_of_kind",
    "get_denoiser",
]

# The filters' tuning grids (``Denoiser.grid``), parameter -> candidate values, small on purpose.
# They belong on each filter's class: set here until ``denoisers/filters.py`` is split into one
# file per filter, when each line moves to its class body.
ATrous.grid = {"iterations": (1, 2, 3, 5), "sigma_color": (1.0, 4.0, 16.0, 64.0)}
Bilateral.grid = {"sigma_color": (0.5, 1.0, 2.0, 4.0, 8.0), "sigma_space": (1.0, 2.0, 3.0)}
Gaussian.grid = {"sigma": (0.5, 0.75, 1.0, 1.5, 2.0, 3.0)}
Guided.grid = {"eps": (1e-2, 1e-1, 1.0, 10.0), "radius": (1, 2, 3, 5)}
JointBilateral.grid = {
    "sigma_color": (2.0, 4.0, 8.0),
    "sigma_feature": (0.3, 1.0),
    "sigma_space": (1.0, 2.0, 3.0),
}
Median.grid = {"kernel_size": (3, 5)}

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


def denoiser_identity(name: str) -> DenoiserIdentity:
    """The kind and tuning grid of denoiser ``name``, by name alone: a registered class's, the
    base's of ``NAME:own``, else kind ``"other"`` (:mod:`denoisers.identity`)."""
    return identity_in(DENOISERS, name)


def denoisers_of_kind(kind: str) -> tuple[str, ...]:
    """The registered denoisers whose class's ``kind`` is ``kind``, sorted by name."""
    return of_kind(DENOISERS, kind)
