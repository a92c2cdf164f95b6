"""Small white-noise renders of the benchmark's named scenes, shared by the denoiser tests.

Not a test module: ``tests/denoisers/test_tuning.py``, ``test_unet.py`` and ``test_oidn.py`` import
it, and the cache below makes one pytest session render each scene once. Every render is
deterministic (fixed seeds), so the tests that use them are too.

Each scene gets, at ``SIZE x SIZE`` and ``SPP`` samples per pixel with random per-pixel seeds
("white noise") and a per-pixel sampler (``white``, independent samples, by default; or
``owen_sobol``, the per-pixel sequence every strategy of the benchmark renders with): a frame to
tune on (seed key 1), an independent frame to measure on (key 3), and a reference at
``REFERENCE_SPP`` (key 1000, always the white sampler). The reference's own noise adds the same
constant to every MSE measured against it (it is independent of the frames), so it does not
favour any denoiser; it only makes the comparison a little noisier.

64 x 64 rather than smaller: at 32 x 32 the Cornell box's light is three pixels tall and the
noise of its partly covered edge pixels is 98 % of the image's squared error, so every test
would measure only that edge.
"""

from __future__ import annotations

import functools

import torch

import renderers
from benchmarks.training_data import pixel_seeds
from bnerr.frame import Frame
from bnerr.sequences import make_sampler

SIZE = 64
SPP = 4
REFERENCE_SPP = 128
SCENES = tuple(renderers.SCENES)


def _render(name: str, key: int, spp: int, sampler: str = "white") -> Frame:
    """Scene ``name`` (static) at t = 0, seed key ``key``, per-pixel ``sampler``, SIZE x SIZE."""
    scene = renderers.get_scene(name, animated=False)
    return renderers.render(scene, 0, pixel_seeds(SIZE, SIZE, key), make_sampler(sampler), spp)


@functools.cache
def reference(name: str) -> torch.Tensor:
    """Reference color ``[3, SIZE, SIZE]`` of scene ``name``."""
    return _render(name, 1000, REFERENCE_SPP).color


@functools.cache
def scene_renders(name: str, sampler: str = "white") -> tuple[Frame, Frame, torch.Tensor]:
    """``(tuning frame, measured frame, reference color [3, SIZE, SIZE])`` of scene ``name``."""
    return _render(name, 1, SPP, sampler), _render(name, 3, SPP, sampler), reference(name)


#: Seed keys of the extra measured frames of :func:`measured_frames` (none used above).
MEASURED_KEYS = tuple(range(21, 29))


@functools.cache
def measured_frames(name: str, sampler: str = "white") -> tuple[Frame, ...]:
    """Eight more independent white-noise frames of scene ``name`` (same size, spp, time, sampler).

    For comparisons whose difference is small next to the frame-to-frame spread of one 64 x 64
    frame's error: measured on one frame, such a comparison is a coin toss.
    """
    return tuple(_render(name, key, SPP, sampler) for key in MEASURED_KEYS)


def mse(image: torch.Tensor, reference: torch.Tensor) -> float:
    """Mean squared error over pixels and channels, accumulated in float64."""
    return float((image.double() - reference.double()).square().mean())
