"""Tests for bnerr.strategies.base: the registry the classes fill, the render adapter, and play,
the one loop that plays a strategy through its frames."""

import pytest
import torch

from bnerr.errors import DtypeError, UnknownNameError, ValueRangeError
from bnerr.frame import Frame
from bnerr.sequences import make_sampler
from bnerr.strategies import (
    OWN_SAMPLERS,
    STRATEGIES,
    Strategy,
    WhiteStrategy,
    as_render,
    first_frame,
    make_strategy,
    play,
)
from bnerr.strategies.base import RenderFn, pixel_seeds, stream_key
from bnerr.strategies.registry import REGISTRY


def _render(record: list | None = None, motion: bool = True):
    """A render whose colour is a function of the seed and which records its calls."""

    def render(seeds: torch.Tensor, sampler) -> Frame:
        if record is not None:
            record.append(seeds.clone())
        h, w = seeds.shape
        u = ((seeds * 2654435761) % 1000003).float() / 1000003
        move = torch.stack([torch.full((h, w), 1.5), torch.full((h, w), -0.5)]) if motion else None
        return Frame(color=torch.stack([u, u, u]), motion=move, timings={"render": 1.0})

    return render


@pytest.fixture
def toy():
    """A toy strategy registered by subclassing alone, forgotten after the test."""

    class ToyStrategy(Strategy):
        name = "toy"
        own_sampler = "owen_sobol"
        stream = 1001

        @classmethod
        def create(cls, height, width, build, options):
            return cls(height, width, **build.common)

        def _frame(self, t, render):
            key = stream_key(self.seed, t, self.stream)
            seeds = pixel_seeds(self.height, self.width, key, self.device)
            return render(seeds, make_sampler("owen_sobol"))

    yield ToyStrategy
    REGISTRY.remove("toy")


def test_a_subclass_registers_itself_with_its_own_sampler(toy):
    assert "toy" in STRATEGIES and STRATEGIES["toy"] is toy
    assert OWN_SAMPLERS["toy"] == "owen_sobol"
    assert list(STRATEGIES) == sorted(STRATEGIES)
    made = make_strategy("toy", 6, 8, seed=2)
    assert isinstance(made, toy) and made.sampler_name == "owen_sobol"
    assert made.frame(3, _render()).color.shape == (3, 6, 8)


def test_the_registry_forgets_and_refuses_clashes(toy):
    with pytest.raises(ValueRangeError, match="a name no other strategy has, got 'white'"):
        type("Other", (Strategy,), {"name": "white", "stream": 1002})
    with pytest.raises(ValueRangeError, match="a seed stream no other strategy uses, got 1"):
        type("Clash", (Strategy,), {"name": "clash", "stream": 1})
    assert "clash" not in STRATEGIES
    REGISTRY.remove("toy")
    assert "toy" not in STRATEGIES and "toy" not in OWN_SAMPLERS
    with pytest.raises(UnknownNameError, match="unknown strategy 'toy'"):
        make_strategy("toy", 4, 4)


def test_every_registered_class_has_its_own_stream():
    classes = REGISTRY.classes()
    own = {n: c.stream for n, c in classes.items() if "stream" in vars(c)}
    assert len(set(own.values())) == len(own)
    assert classes["temporal_sort"].stream == classes["temporal"].stream  # one S_0 on purpose
    assert stream_key(0, 1, 1) != stream_key(0, 1, 2) != stream_key(0, 2, 2)


def test_as_render_adds_a_batch_that_renders_one_image_at_a_time():
    record: list = []
    render = as_render(_render(record))
    assert isinstance(render, RenderFn)
    seeds = torch.stack([pixel_seeds(4, 5, k) for k in range(3)])
    frames = render.batch(seeds, None)
    assert len(frames) == 3 and all(torch.equal(a, b) for a, b in zip(record, seeds))
    assert as_render(render) is render  # already a RenderFn


def test_play_renders_a_stateful_strategys_earlier_frames_and_scales_the_motion():
    strategy = make_strategy("temporal", 8, 8, seed=1)
    asked: list[int] = []

    def render_at(k):
        asked.append(k)
        return _render()

    played = list(play(strategy, render_at, range(3, 5), motion=2))
    assert [t for t, _ in played] == [0, 1, 2, 3, 4]  # the state needs frames 0..2
    assert asked == [0, 2, 4, 6, 8]  # strategy frame t is the renderer's frame 2t
    assert all(
        torch.equal(f.motion, _render()(pixel_seeds(8, 8, 0), None).motion * 2) for _, f in played
    )


def test_play_starts_a_stateless_strategy_at_the_first_wanted_frame_and_matches_frame():
    white = make_strategy("white", 8, 8, seed=5)
    played = list(play(white, lambda k: _render(), range(2, 4)))
    assert [t for t, _ in played] == [2, 3] and first_frame(white, range(2, 4)) == 2
    assert first_frame(white, range(2, 4), in_order=True) == 0
    again = make_strategy("white", 8, 8, seed=5)
    for t, frame in played:  # the same frames as calling frame(t, render) by hand
        assert torch.equal(frame.color, again.frame(t, _render()).color)
    with pytest.raises(DtypeError, match="motion: expected an integer"):
        next(play(white, lambda k: _render(), range(1), motion=1.5))


def test_white_is_the_control_registered_under_its_name():
    assert STRATEGIES["white"] is WhiteStrategy and "white" not in OWN_SAMPLERS


def test_a_strategy_in_one_new_file_runs_through_bnerr_bench(toy, tmp_path):
    """The registry is all a new strategy needs: the benchmark's command line knows it, measures
    it beside white on a tiny cell, and records the sampler it dictates."""
    from benchmarks.cli import main
    from benchmarks.sweep.records import load_records

    out = tmp_path / "out"
    args = [
        "bench", "--suite", "quick", "--scenes", "direct", "--strategies", "white,toy",
        "--spp", "1", "--denoisers", "gaussian", "--frames", "1", "--warmup", "0",
        "--res", "8x8", "--reference-spp", "4", "--seed-sets", "1", "--out", str(out),
        "--cache", str(tmp_path / "cache"), "--quiet", "--no-charts", "--metrics", "mse",
    ]  # fmt: skip
    assert main(args) == 0
    records = {r.cell.strategy: r for r in load_records(out)}
    assert set(records) == {"white", "toy"}
    assert records["toy"].render_sampler == "owen_sobol"
    assert "toy" in (out / "table.md").read_text()
