"""The Z-order rivals: a-priori patterns over one sequence indexed along a Morton curve.

Their seed image holds each pixel's *key* (the lane's seed that the Z-order samplers read,
:func:`bnerr.sequences.zsobol_keys`, :func:`bnerr.sequences.cycles_keys`), and they need ``spp``
at construction (the samplers' blocks are ``spp`` long):

- ``zsobol``: pbrt-v4's ZSobolSampler: the identity key image ``zsobol_keys(H, W)`` and the
  ``zsobol`` sampler built with ``(width, height, spp, seed)``; the scramble's seed is fresh every
  frame (pbrt's ``seed`` option keyed by (seed set, t), as an animation with a changing seed), so
  frames are independent like white's. spp must be a power of two (pbrt's blocks).
- ``cycles_blue``: Blender Cycles' ``BLUE_NOISE_PURE`` for final frames: keys
  ``cycles_keys(H, W, seed_t)`` with a fresh seed every frame (Cycles' animated seed) and the
  ``cycles_pure`` sampler over one global Owen-Sobol sequence of seed 0, as in Cycles.
- ``zsobol_t``: temporal Z-order: the identity key image and the ``zsobol_t`` sampler at frame t
  (:meth:`bnerr.sequences.ZSobolTSampler.at_frame`), one scramble seed per seed set for all
  frames, so consecutive frames take neighbouring blocks of one sequence. spp a power of two.
"""

from __future__ import annotations

import torch

from bnerr.errors import ValueRangeError, check_positive_int
from bnerr.frame import Frame
from bnerr.sequences import ZSobolTSampler, cycles_keys, make_sampler, zsobol_keys
from bnerr.strategies.base import BuildOptions, RenderFn, Strategy, power_of_two_spp, stream_key
from bnerr.strategies.variants import TemporalOptions

__all__ = [
    "SCRAMBLE_PER_SEED_SET_NOTE",
    "SHARED_SCRAMBLE",
    "CyclesBlueStrategy",
    "ZSobolStrategy",
    "ZSobolTStrategy",
]

#: The start of a ``raw_mse_note`` of a strategy whose pixels share one scramble.
SHARED_SCRAMBLE = (
    "one scramble shared by all pixels, each pixel an aligned block of one sequence: the image's "
    "raw MSE is one draw per scramble instead of an average over per-pixel scrambles; "
)
_SCRAMBLE_SOURCE = " (docs/METHODS.md, section 7; tests/test_sequences.py)."
#: Why zsobol_t's and temporal_zsobol's raw MSE differs from white's (their ``raw_mse_note``).
SCRAMBLE_PER_SEED_SET_NOTE = (
    SHARED_SCRAMBLE + "this strategy keeps one scramble per seed set, so a suite's few seed sets "
    "are few draws" + _SCRAMBLE_SOURCE
)


class _SppStrategy(Strategy):
    """A strategy built with the samples per pixel its sampler's blocks need."""

    @classmethod
    def create(
        cls, height: int, width: int, build: BuildOptions, options: TemporalOptions
    ) -> Strategy:
        return cls(height, width, spp=build.spp, **build.common)  # type: ignore[call-arg]


class _ZOrderKeys(_SppStrategy):
    """A power-of-two spp and the identity key image ``zsobol_keys(H, W)``, made once."""

    def __init__(
        self,
        height: int,
        width: int,
        *,
        seed: int = 0,
        spp: int,
        device: torch.device | str = "cpu",
    ) -> None:
        self.spp = power_of_two_spp(spp, self.name)
        super().__init__(height, width, seed=seed, device=device)
        self.keys = zsobol_keys(height, width, self.device)


class ZSobolStrategy(_ZOrderKeys):
    """``zsobol``: pbrt-v4's ZSobolSampler, the identity key image and a fresh scramble per frame.

    Memory as white's (33 bytes per pixel measured: the key image, made once through a few int64
    temporaries).

    Args:
        spp: samples per pixel, a power of two (pbrt's per-pixel blocks).
    """

    name = "zsobol"
    own_sampler = "zsobol"
    stream = 5
    family = "rival"
    rank = 30
    raw_mse_note = (
        SHARED_SCRAMBLE + "ZSobol draws a fresh scramble each frame, so its MSE varies more from "
        "frame to frame and not on average" + _SCRAMBLE_SOURCE
    )
    color = "#2ca02c"

    def _frame(self, t: int, render: RenderFn) -> Frame:
        key = stream_key(self.seed, t, self.stream)
        sampler = make_sampler(
            "zsobol", width=self.width, height=self.height, spp=self.spp, seed=key
        )
        return render(self.keys, sampler)


class CyclesBlueStrategy(_SppStrategy):
    """``cycles_blue``: Cycles' ``BLUE_NOISE_PURE``, keys scrambled by a fresh seed every frame.

    Memory: 96 bytes per pixel beyond the frame (87 measured: fresh keys every frame, the Morton
    code and the base-4 scramble in int32 and int64 copies).

    Args:
        spp: samples per pixel (each pixel's block of the global sequence is spp long; any spp,
            though only a power of two keeps the blocks aligned, as in Cycles).
    """

    name = "cycles_blue"
    own_sampler = "cycles_pure"
    stream = 6
    bytes_per_pixel = 96
    family = "rival"
    rank = 40
    raw_mse_note = (
        "one scramble shared by all pixels with a fixed sequence seed: its raw MSE is one draw "
        "that never changes, above or below white's depending on the scene and spp "
        "(docs/METHODS.md, section 7; tests/test_sequences.py)."
    )
    color = "#17becf"

    def __init__(
        self,
        height: int,
        width: int,
        *,
        seed: int = 0,
        spp: int,
        device: torch.device | str = "cpu",
    ) -> None:
        if spp is None:
            raise ValueRangeError("spp: expected the samples per pixel for cycles_blue, got None")
        self.spp = check_positive_int(spp, "spp")
        super().__init__(height, width, seed=seed, device=device)
        self.sampler = make_sampler("cycles_pure", spp=self.spp, seed0=0)

    def _frame(self, t: int, render: RenderFn) -> Frame:
        key = stream_key(self.seed, t, self.stream)
        return render(cycles_keys(self.height, self.width, key, self.device), self.sampler)


class ZSobolTStrategy(_ZOrderKeys):
    """``zsobol_t``: temporal Z-order, the identity key image and the sampler at frame t.

    One scramble seed per seed set for every frame: frame t's blocks neighbour frame t - 1's in
    the same sequence. Frame t depends on t alone, not on earlier frames (stateless). Memory as
    zsobol's.

    Args:
        spp: samples per pixel, a power of two.
    """

    name = "zsobol_t"
    own_sampler = "zsobol_t"
    stream = 7
    family = "rival"
    rank = 50
    raw_mse_note = SCRAMBLE_PER_SEED_SET_NOTE
    color = "#98df8a"

    def __init__(
        self,
        height: int,
        width: int,
        *,
        seed: int = 0,
        spp: int,
        device: torch.device | str = "cpu",
    ) -> None:
        super().__init__(height, width, seed=seed, spp=spp, device=device)
        key = stream_key(self.seed, 0, self.stream)
        # The class itself (what make_sampler("zsobol_t") builds): _frame needs its at_frame.
        self.sampler = ZSobolTSampler(width=width, height=height, spp=self.spp, seed=key)

    def _frame(self, t: int, render: RenderFn) -> Frame:
        return render(self.keys, self.sampler.at_frame(t))
