"""Classic image filters as denoisers: kornia's five, and the edge-avoiding a-trous filter of SVGF.

One file per filter, as kornia keeps them (``kornia/filters/median.py``): the pure function over
tensors (``color [3, H, W]`` plus the guides it reads, all on one device, float32) and a thin
:class:`~denoisers.base.Denoiser` class that stores its parameters and reads the buffers from a
Frame, together:

- :mod:`~denoisers.filters.gaussian`, :mod:`~denoisers.filters.median`: kornia's linear blur and
  median;
- :mod:`~denoisers.filters.bilateral`, :mod:`~denoisers.filters.joint_bilateral`: the bilateral
  filter and its feature-guided cross variant (their kernel dispatch is shared, in
  :mod:`~denoisers.filters.common`, with the border rule and the float64 switch);
- :mod:`~denoisers.filters.guided`: the guided filter with an albedo, normal and luminance guide;
- :mod:`~denoisers.filters.atrous`: the edge-avoiding a-trous filter (spatial SVGF).

Parameters are not chosen here: :mod:`denoisers.tuning` picks them per scene and spp on
white-noise renders, and the benchmark then uses them unchanged for every strategy. The defaults
are only reasonable starting points for a 4 spp frame.

Borders are padded by replication everywhere, so every filter works on any image size (a
reflection pad must be narrower than the image).

Native kernels: each filter's file owns their dispatch and checks, as
:mod:`bnerr.permutation.permute` owns its kernel's. CPU float32 inputs of the a-trous, (joint)
bilateral and guided filters go to the C kernels of :mod:`denoisers.native` once each kernel has
matched its torch path (:func:`atrous_torch`, :func:`bilateral_torch`, :func:`guided_torch`) on a
self-check, run once per loaded library; CUDA, float64, a missing compiler or ``BNERR_NATIVE=0`` run
the torch paths.

What these filters are not: production denoisers. They are the range of classical behaviours the
benchmark needs, from a linear low-pass (which removes most of a blue-noise error and little of a
white one) to feature-guided filters (which may not care how the error is distributed).
"""

from denoisers.filters.atrous import (
    ATrous,
    atrous_filter,
    atrous_native,
    atrous_planes,
    atrous_torch,
)
from denoisers.filters.bilateral import Bilateral, bilateral_filter
from denoisers.filters.common import bilateral_torch
from denoisers.filters.gaussian import Gaussian, gaussian_filter
from denoisers.filters.guided import (
    Guided,
    guided_bytes,
    guided_filter,
    guided_torch,
)
from denoisers.filters.joint_bilateral import JointBilateral, joint_bilateral_filter
from denoisers.filters.median import Median, median_bytes, median_filter

__all__ = [
    "ATrous",
    "Bilateral",
    "Gaussian",
    "Guided",
    "JointBilateral",
    "Median",
    "atrous_filter",
    "atrous_native",
    "atrous_planes",
    "atrous_torch",
    "bilateral_filter",
    "bilateral_torch",
    "gaussian_filter",
    "guided_bytes",
    "guided_filter",
    "guided_torch",
    "joint_bilateral_filter",
    "median_bytes",
    "median_filter",
]
