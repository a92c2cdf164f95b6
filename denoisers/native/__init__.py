"""Optional native CPU kernels of three filters of :mod:`denoisers.filters`: their C sources and
bindings, nothing more.

The C sources live here as package data, beside their only users' bindings (gsplat keeps its
``csrc/`` beside its ``cuda/_backend.py`` the same way); :mod:`bnerr.native` only builds them
(system C compiler, per-user cache, hash-checked load, one warning; ``BNERR_NATIVE=0`` turns
them off), reading them by package and file name, so the library ships no denoiser code.

- ``filters.c``, bound by :mod:`denoisers.native.filters`: the edge-avoiding a-trous filter
  (:func:`native_atrous`, its spatial variance estimate :func:`native_luminance_variance`) and
  the (joint) bilateral filter (:func:`native_bilateral`).
- ``guided.c``, bound by :mod:`denoisers.native.guided`: the guided filter
  (:func:`native_guided`).
- :data:`FILTERS` and :data:`GUIDED`: the two libraries (``load()``, ``status()``,
  ``compiler_output()``); :func:`eligible` and :func:`threads_for`: which tensors the kernels
  take and how many threads they get.

What stays with the caller, :mod:`denoisers.filters` (as :mod:`bnerr.permutation.permute` keeps its
own): the dispatch (CPU float32 only; CUDA, float64 and the firefly float64 switch keep the torch
path), the a-trous constants, the self-check of each kernel against its torch path
(:class:`bnerr.native.SelfCheckedKernels`) and the fallback. Nothing here imports
:mod:`denoisers.filters`, so the check can live there without an import circle.
"""

from __future__ import annotations

import torch

from denoisers.native.filters import LIBRARY as FILTERS
from denoisers.native.filters import (
    FilterKernels,
    native_atrous,
    native_bilateral,
    native_luminance_variance,
)
from denoisers.native.guided import LIBRARY as GUIDED
from denoisers.native.guided import GuidedKernels, native_guided

__all__ = [
    "FILTERS",
    "GUIDED",
    "FilterKernels",
    "GuidedKernels",
    "eligible",
    "native_atrous",
    "native_bilateral",
    "native_guided",
    "native_luminance_variance",
    "threads_for",
]

# Below this many pixels one thread does the work (starting threads costs more than it saves).
_THREADED_PIXELS = 1 << 16


def eligible(*tensors: torch.Tensor) -> bool:
    """Whether the kernels may run on these tensors: all float32 on the CPU."""
    return all(t.device.type == "cpu" and t.dtype == torch.float32 for t in tensors)


def threads_for(pixels: int) -> int:
    """Worker threads for an image of ``pixels``: torch's thread count, 1 for small images."""
    return max(1, min(64, torch.get_num_threads())) if pixels >= _THREADED_PIXELS else 1
