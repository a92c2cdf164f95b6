"""Cycles' own sampling patterns as bnerr strategies, for Cycles scenes.

Stock Cycles takes one ``seed`` per frame, not a seed per pixel, so bnerr's strategies (which
choose every pixel's seed) cannot drive it; Cycles' patterns and the options that change how its
error spreads over the screen are the strategies on a Cycles scene:

=======================  ==================  ======================  ========================
strategy                 sampling_pattern    scrambling_distance     adaptive sampling
=======================  ==================  ======================  ========================
``white``                TABULATED_SOBOL     off                     off
``classic_scrambled``    TABULATED_SOBOL     0.1                     off
``classic_adaptive``     TABULATED_SOBOL     off                     on (threshold 0.01)
``blue_noise``           BLUE_NOISE          off                     off
``blue_noise_adaptive``  BLUE_NOISE          off                     on (threshold 0.01)
=======================  ==================  ======================  ========================

``white`` is bnerr's baseline strategy: on a Cycles scene it renders Cycles' classic pattern
(:func:`pattern_of` maps its per-pixel ``owen_sobol`` sampler to it), the tables' baseline. Each
seed set and frame gets its own Cycles seed: the low 31 bits of the strategy's seed image's first
pixel, a hash of (seed set, frame, strategy stream) (:func:`bnerr.strategies.base.stream_key`);
the blue-noise strategies share the classic pattern's stream, so a seed set renders every pattern
with the same Cycles seed. ``scrambling_distance`` 0.1 correlates the pixels' sequences (Cycles'
speed option; its manual suggests values near 0.1 for GPU coherence); on the blue-noise pattern
it is not offered, since Cycles applies it to the tabulated Sobol pattern. Adaptive sampling
stops pixels early below Cycles' default noise threshold, so the spp is a maximum there.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import torch

from bnerr.errors import ValueRangeError
from bnerr.frame import Frame
from bnerr.strategies import WhiteStrategy
from bnerr.strategies.base import BuildOptions, RenderFn, Strategy, pixel_seeds, stream_key
from bnerr.strategies.variants import TemporalOptions

__all__ = [
    "CYCLES_STRATEGIES",
    "CyclesPattern",
    "CyclesPatternStrategy",
    "make_pattern_strategy",
    "pattern_class",
    "pattern_of",
    "refusal",
]

_SEED_MASK = 0x7FFFFFFF  # Cycles' seed is a signed 32-bit property


@dataclass(frozen=True)
class CyclesPattern:
    """What a Cycles render is asked to sample with: the pattern, its options and the seed."""

    name: str
    pattern: str
    seed: int
    scrambling_distance: float | None = None
    adaptive: bool = False

    def request(self) -> dict[str, Any]:
        """The worker's render fields."""
        return {
            "pattern": self.pattern,
            "seed": self.seed & _SEED_MASK,
            "scrambling_distance": self.scrambling_distance,
            "adaptive": self.adaptive,
        }


def pattern_of(sampler: object, seeds: torch.Tensor, scene: str) -> CyclesPattern:
    """The Cycles pattern a render is asked for: ``sampler`` itself, or for bnerr's per-pixel
    ``owen_sobol`` sampler (``white`` and the references) the classic pattern seeded from the
    seed image's first pixel.

    Raises:
        ValueRangeError: any other sampler: a bnerr strategy that needs per-pixel seeds.
    """
    if isinstance(sampler, CyclesPattern):
        return sampler
    name = getattr(sampler, "name", type(sampler).__name__)
    if name == "owen_sobol":
        return CyclesPattern("white", "TABULATED_SOBOL", int(seeds.reshape(-1)[0]))
    raise ValueRangeError(refusal(f"(bnerr's {name} sampler)", scene))


class CyclesPatternStrategy(Strategy):
    """A Cycles pattern as a strategy (module docstring): every frame one render with its own
    Cycles seed. Not in bnerr's strategy registry (it renders only on Cycles scenes):
    :func:`make_pattern_strategy` makes one by its ``label``."""

    label: ClassVar[str] = ""
    stream = WhiteStrategy.stream  # the classic pattern's seeds: one Cycles seed per seed set
    bytes_per_pixel = 44
    family = "cycles"
    pattern: ClassVar[str] = ""
    scrambling_distance: ClassVar[float | None] = None
    adaptive: ClassVar[bool] = False

    def __init__(
        self, height: int, width: int, *, seed: int = 0, device: torch.device | str = "cpu"
    ) -> None:
        self.name = self.label
        super().__init__(height, width, seed=seed, device=device)

    @classmethod
    def create(
        cls, height: int, width: int, build: BuildOptions, options: TemporalOptions
    ) -> Strategy:
        return cls(height, width, **build.common)

    def _frame(self, t: int, render: RenderFn) -> Frame:
        seeds = pixel_seeds(1, 1, stream_key(self.seed, t, self.stream), self.device)
        pattern = CyclesPattern(
            self.label, self.pattern, int(seeds[0, 0]), self.scrambling_distance, self.adaptive
        )
        return render(seeds.expand(self.height, self.width), pattern)  # type: ignore[arg-type]


class BlueNoise(CyclesPatternStrategy):
    """``blue_noise``: Cycles' blue-noise pattern (Blender 4.4's default through AUTOMATIC)."""

    own_sampler = "cycles_blue_noise"
    label = "blue_noise"
    pattern = "BLUE_NOISE"


class BlueNoiseAdaptive(CyclesPatternStrategy):
    """``blue_noise_adaptive``: the blue-noise pattern under adaptive sampling."""

    own_sampler = "cycles_blue_noise"
    label = "blue_noise_adaptive"
    pattern = "BLUE_NOISE"
    adaptive = True


class ClassicScrambled(CyclesPatternStrategy):
    """``classic_scrambled``: the classic pattern with scrambling distance 0.1."""

    own_sampler = "cycles_tabulated_sobol"
    label = "classic_scrambled"
    pattern = "TABULATED_SOBOL"
    scrambling_distance = 0.1


class ClassicAdaptive(CyclesPatternStrategy):
    """``classic_adaptive``: the classic pattern under adaptive sampling."""

    own_sampler = "cycles_tabulated_sobol"
    label = "classic_adaptive"
    pattern = "TABULATED_SOBOL"
    adaptive = True


_PATTERNS: dict[str, type[CyclesPatternStrategy]] = {
    cls.label: cls for cls in (BlueNoise, BlueNoiseAdaptive, ClassicScrambled, ClassicAdaptive)
}
#: The strategies a Cycles scene runs: the baseline and Cycles' own patterns.
CYCLES_STRATEGIES: tuple[str, ...] = ("white", *_PATTERNS)


def make_pattern_strategy(
    name: str, height: int, width: int, *, seed: int, scene: str, device: torch.device | str
) -> Strategy:
    """Strategy ``name`` on the Cycles scene ``scene``: bnerr's ``white`` (the classic pattern,
    :func:`pattern_of`) or one of Cycles' patterns.

    Raises:
        ValueRangeError: any other strategy (it needs per-pixel seeds).
    """
    if name == "white":
        return WhiteStrategy(height, width, seed=seed, sampler="owen_sobol", device=device)
    if name not in _PATTERNS:
        raise ValueRangeError(refusal(name, scene))
    return _PATTERNS[name](height, width, seed=seed, device=device)


def pattern_class(name: str) -> str | None:
    """The Cycles ``sampling_pattern`` strategy ``name`` renders with (None: not a pattern)."""
    if name == "white":
        return "TABULATED_SOBOL"
    found = _PATTERNS.get(name)
    return None if found is None else found.pattern


def refusal(name: str, scene: str) -> str:
    """The one line that refuses bnerr's strategy ``name`` on the Cycles scene ``scene``."""
    return (
        f"--strategies {name}: expected one of Cycles' patterns ({', '.join(CYCLES_STRATEGIES)}) "
        f"on the Cycles scene {scene}, got a bnerr strategy: it needs per-pixel seeds, which "
        "stock Cycles does not take"
    )
