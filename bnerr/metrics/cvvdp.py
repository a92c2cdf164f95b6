"""ColorVideoVDP: how visible a sequence's error is to a viewer, in JOD, as a metric of the table.

The MSE family (:mod:`bnerr.metrics.image`) and flicker (:mod:`bnerr.metrics.temporal`) measure
the error's energy; blue noise's case is that the same energy is less *visible*. ColorVideoVDP
(Mantiuk et al. 2024, the package ``cvvdp``, MIT, PyTorch; Noisebase scores denoised sequences
with it) models the eye's contrast sensitivity over space and time and the display, and answers
in JOD, just-objectionable differences: 10 is a sequence no one tells from its reference, each
JOD below it one more unit of visible difference (1 JOD: 75 % of observers pick the reference).
**Higher is better**, unlike every other metric of the table.

**What is scored.** ``cvvdp`` is the JOD of each seed set's measured sequence (the raw frames, or
one denoiser's outputs) against the reference sequence of the same frames, shown as follows,
the same for every method:

- **HDR to display** (:func:`display_encode`): the linear radiance is exposed by
  ``2 ** CVVDP_EXPOSURE`` (0 stops: the scenes' own scale), tone-mapped per channel by Reinhard's
  global ``L / (1 + L)`` (:func:`bnerr.color.tonemap`) and sRGB-encoded
  (:func:`bnerr.color.srgb_encode`): the pages' previews (:func:`bnerr.color.preview_u8`), kept
  in float rather than rounded to 8 bits, so that quantization adds no error of its own;
- **display** (:data:`CVVDP_DISPLAY`): cvvdp's ``standard_fhd``, a 24-inch Full HD SDR monitor
  (sRGB, peak 200 cd/m^2, contrast 1000:1) in an office (250 lux), seen from 0.6 m: 37.8 pixels
  per degree, so a 128 x 128 frame spans 3.4 degrees;
- **frame rate** (:data:`CVVDP_FPS`): 30 frames per second, a real-time renderer's; cvvdp's
  temporal filters span 250 ms (9 frames) and pad a shorter sequence by repeating its first frame
  (its ``replicate`` padding).

**As a metric of the table.** JOD pools nonlinearly over frames (a norm, then a curve), so a
frame cannot be scored on its own: ``cvvdp`` is a *sequence* metric
(:class:`~bnerr.metrics.frames.Metric`'s ``sequence``). :class:`~bnerr.metrics.frames.
FrameMetrics` keeps the seed set's frames and scores the sequence once, when its pairs are read
(:func:`cvvdp_sequence`), each frame getting ``(J, 1)``: the pooled mean of a seed set is the JOD
of its whole sequence, and intervals over seed sets come from the same compute step as every
other metric. A frame whose region held no pixel ends the sequence, as it ends the temporal
metrics' windows: the seed set then scores the frame-weighted mean of its sequences' JODs.

**Regions.** JOD pools over the whole image; restricted to a pixel mask, the frame shown keeps
the measured image inside the region and the reference outside it, so that only the region's
error is seen (the region's share of the image weighs in the JOD).

**Cost.** About 0.03 s for one 128 x 128 frame, 0.05 s for two and 0.07 s for three on one idle
CPU thread (a first call builds the model, about a second): a seed set of 3 frames costs 0.07 s
per image kind (raw, each denoiser) and pixel region, more than the ten metrics the suites
measure together.

**Determinism.** cvvdp runs in float32 torch: its values may differ in the last bits with the
thread count or the machine, unlike the fixed-order sums of :mod:`bnerr.metrics.image`.

Not for: a per-frame score (each frame's pair is an increment), or HDR displays (the mapping above
is an SDR preview's).
"""

from __future__ import annotations

import functools
import importlib
import importlib.util
from collections.abc import Sequence
from typing import Any

import torch

from bnerr.color import srgb_encode, tonemap
from bnerr.errors import MissingDependencyError, ShapeError
from bnerr.metrics.image import ImagePair

__all__ = [
    "CVVDP_DISPLAY",
    "CVVDP_EXPOSURE",
    "CVVDP_FPS",
    "CVVDP_TONEMAP",
    "cvvdp_available",
    "cvvdp_sequence",
    "display_encode",
    "require_cvvdp",
    "sequence_jod",
]

#: cvvdp's display model: a 24-inch Full HD SDR monitor, 200 cd/m^2, 1000:1, 250 lux, 0.6 m.
CVVDP_DISPLAY = "standard_fhd"
#: Frames per second the sequences are shown at.
CVVDP_FPS = 30.0
#: Exposure in stops before the tone map (0: the radiance as rendered).
CVVDP_EXPOSURE = 0.0
#: The tone map of :func:`bnerr.color.tonemap` from radiance to the display's [0, 1].
CVVDP_TONEMAP = "reinhard"
#: The pinned version (pyproject.toml's dependency), named in the error when it is missing.
_PACKAGE = "cvvdp==0.5.7"


def cvvdp_available() -> bool:
    """Whether ``cvvdp`` (module ``pycvvdp``) is installed."""
    return importlib.util.find_spec("pycvvdp") is not None


def require_cvvdp() -> None:
    """Raise :class:`~bnerr.errors.MissingDependencyError` (an ``ImportError``), one line naming
    the package and its install command, unless ``cvvdp`` is installed."""
    if not cvvdp_available():
        raise MissingDependencyError("cvvdp", _PACKAGE, "no module named 'pycvvdp'")


@functools.cache
def _model(device: torch.device) -> Any:
    """cvvdp's metric on ``device`` with :data:`CVVDP_DISPLAY` (built once per device: it reads
    its tables from the package's own files, nothing from the network)."""
    require_cvvdp()
    pycvvdp = importlib.import_module("pycvvdp")  # untyped: Any to mypy
    return pycvvdp.cvvdp(display_name=CVVDP_DISPLAY, quiet=True, device=device)


def display_encode(color: torch.Tensor) -> torch.Tensor:
    """Linear radiance ``[..., 3, H, W]`` -> the display's sRGB-encoded values in [0, 1], float32:
    ``srgb(tonemap(color * 2 ** CVVDP_EXPOSURE))`` (the module docstring)."""
    linear = color.to(torch.float32).nan_to_num(0.0) * 2.0**CVVDP_EXPOSURE
    return srgb_encode(tonemap(linear, CVVDP_TONEMAP).clamp(0.0, 1.0))


def _check_sequence(preds: Sequence[torch.Tensor], refs: Sequence[torch.Tensor]) -> None:
    if not preds or len(preds) != len(refs):
        raise ShapeError(
            f"preds: expected one or more frames, as many as refs ({len(refs)}), got {len(preds)}"
        )
    shape = preds[0].shape
    for name, frames in (("preds", preds), ("refs", refs)):
        for frame in frames:
            if frame.ndim != 3 or frame.shape[0] != 3 or frame.shape != shape:
                raise ShapeError(
                    f"{name}: expected every frame [3, H, W] of the shape {list(shape)}, "
                    f"got {list(frame.shape)}"
                )


def sequence_jod(
    preds: Sequence[torch.Tensor],
    refs: Sequence[torch.Tensor],
    masks: Sequence[torch.Tensor | None] | None = None,
) -> float:
    """ColorVideoVDP's JOD of the sequence ``preds`` against ``refs`` (each frame ``[3, H, W]``
    linear RGB, oldest first), shown as the module docstring says; with ``masks`` (``[H, W]``
    bool per frame, None: every pixel), each frame keeps its reference outside its mask.

    Raises:
        MissingDependencyError: ``cvvdp`` is not installed.
        ShapeError: no frames, or frames of different shapes or not RGB.
    """
    require_cvvdp()
    _check_sequence(preds, refs)
    shown = []
    for i, (pred, ref) in enumerate(zip(preds, refs, strict=True)):
        mask = None if masks is None else masks[i]
        shown.append(pred if mask is None else torch.where(mask.to(pred.device), pred, ref))
    test = display_encode(torch.stack(shown))
    reference = display_encode(torch.stack(list(refs)).to(test.device))
    with torch.no_grad():
        jod, _ = _model(test.device).predict(
            test, reference, dim_order="FCHW", frames_per_second=CVVDP_FPS
        )
    return float(jod)


def cvvdp_sequence(pairs: Sequence[ImagePair]) -> torch.Tensor:
    """``cvvdp``'s pair for a seed set's sequence ``pairs`` (oldest first): ``(J, 1)`` with ``J``
    its JOD (:func:`sequence_jod`), which :class:`~bnerr.metrics.frames.FrameMetrics` gives every
    frame of the sequence, so that their pooled mean is ``J``."""
    jod = sequence_jod(
        [p.pred for p in pairs], [p.ref.color for p in pairs], [p.mask for p in pairs]
    )
    return torch.tensor([jod, 1.0], dtype=torch.float64)
