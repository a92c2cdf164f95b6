"""Cycles' patterns as strategies: what each asks Cycles for, the seeds they share, the classic
pattern behind ``white``, and the refusal of bnerr's per-pixel strategies."""

import pytest
import torch

from bnerr.errors import ValueRangeError
from bnerr.frame import Frame
from bnerr.sequences import make_sampler
from bnerr.strategies import WhiteStrategy, as_render
from renderers.cycles.patterns import (
    CYCLES_STRATEGIES,
    CyclesPattern,
    make_pattern_strategy,
    pattern_class,
    pattern_of,
)


def _asked(name: str, seed: int = 0, frames: int = 3) -> list[CyclesPattern]:
    """The pattern each frame of strategy ``name`` asks its render for."""
    asked = []

    def render(seeds, sampler):
        asked.append(pattern_of(sampler, seeds, "scene"))
        return Frame(color=torch.zeros(3, *seeds.shape))

    strategy = make_pattern_strategy(name, 4, 5, seed=seed, scene="scene", device="cpu")
    for t in range(frames):
        frame = strategy.frame(t, as_render(render))
        assert frame.color.shape == (3, 4, 5)
    return asked


@pytest.mark.parametrize(
    ("name", "pattern", "distance", "adaptive"),
    [
        ("white", "TABULATED_SOBOL", None, False),
        ("blue_noise", "BLUE_NOISE", None, False),
        ("blue_noise_adaptive", "BLUE_NOISE", None, True),
        ("classic_scrambled", "TABULATED_SOBOL", 0.1, False),
        ("classic_adaptive", "TABULATED_SOBOL", None, True),
    ],
)
def test_each_strategy_asks_cycles_for_its_pattern_and_options(name, pattern, distance, adaptive):
    asked = _asked(name)
    assert {(a.pattern, a.scrambling_distance, a.adaptive) for a in asked} == {
        (pattern, distance, adaptive)
    }
    assert pattern_class(name) == pattern
    request = asked[0].request()
    assert request["pattern"] == pattern and 0 <= request["seed"] < 2**31


def test_the_table_lists_every_strategy_and_nothing_else():
    assert CYCLES_STRATEGIES[0] == "white" and len(set(CYCLES_STRATEGIES)) == 5
    assert pattern_class("temporal") is None


def test_every_frame_and_seed_set_gets_its_own_cycles_seed_shared_by_the_patterns():
    seeds = {name: [a.seed for a in _asked(name, seed=3)] for name in CYCLES_STRATEGIES}
    assert len(set(seeds["white"])) == 3  # one per frame
    assert all(s == seeds["white"] for s in seeds.values())  # one seed set: one Cycles seed
    assert [a.seed for a in _asked("blue_noise", seed=4)] != seeds["blue_noise"]


def test_white_is_bnerr_white_on_the_per_pixel_owen_sobol_sampler():
    strategy = make_pattern_strategy("white", 4, 4, seed=0, scene="s", device="cpu")
    assert isinstance(strategy, WhiteStrategy) and strategy.sampler_name == "owen_sobol"
    seeds = torch.full((2, 2), 2**32 - 1, dtype=torch.int64)
    classic = pattern_of(make_sampler("owen_sobol"), seeds, "s")
    assert classic.pattern == "TABULATED_SOBOL" and classic.request()["seed"] == 2**31 - 1


@pytest.mark.parametrize("name", ["temporal", "ldbn", "oracle", "cycles_blue"])
def test_a_bnerr_strategy_is_refused_on_a_cycles_scene_in_one_line(name):
    with pytest.raises(
        ValueRangeError,
        match=rf"^--strategies {name}: expected one of Cycles' "
        r"patterns .* per-pixel seeds, which stock Cycles does not take$",
    ):
        make_pattern_strategy(name, 4, 4, seed=0, scene="s", device="cpu")


def test_a_render_with_another_bnerr_sampler_is_refused():
    with pytest.raises(ValueRangeError, match="bnerr.s white sampler.*per-pixel seeds"):
        pattern_of(make_sampler("white"), torch.zeros(2, 2, dtype=torch.int64), "s")
