"""Property tests of bnerr.strategies (issue 28, item 5): the permuting strategies' seed images
stay a permutation of the previous frame's, every strategy is deterministic, and
:func:`bnerr.strategies.play` at any motion factor gives the frames of calling
``strategy.frame(t, render)`` by hand with the renderer's frame ``motion * t`` and its motion
buffer scaled.

Renders are a cheap stand-in whose buffers are functions of the seeds (as a real renderer's pixel
estimate is a function of its seed), so each example costs milliseconds.
"""

from __future__ import annotations

import dataclasses

import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from bnerr.frame import Frame
from bnerr.strategies import STRATEGIES, first_frame, make_strategy, play

# The strategies that move seeds between pixels instead of drawing new ones.
PERMUTING = (
    "temporal",
    "temporal_sort",
    "temporal_zsobol",
    "temporal_ldbn",
    "temporal+relative+demod+groups+shift_r2+reproject",
    "temporal+residual+groups_depth+shift",
    "temporal_zsobol+relative+groups+shift_r2+reproject",
)


def _stand_in(k: int = 0, record: list | None = None, drift: tuple[float, float] = (1.4, -0.6)):
    """A render of renderer frame ``k``: colour, albedo and depth are hashes of the seed (and of
    k), object ids in vertical bands, a uniform motion ``drift`` (a pixel came from
    ``(x - dx, y - dy)``)."""

    def render(seeds: torch.Tensor, sampler) -> Frame:
        if record is not None:
            record.append(seeds.clone())
        h, w = seeds.shape
        u = (((seeds + 7919 * k) * 2654435761) % 1000003).float() / 1000003
        x = torch.arange(w).expand(h, w)
        band = (x * 3 // w).float()
        return Frame(
            color=torch.stack([u, u * u, 1 - u]),
            albedo=torch.stack([1 - u, u, u * 0.5]),
            normal=torch.stack([band - 1.0, torch.ones(h, w), torch.zeros(h, w)]),
            depth=(seeds % 7).float()[None] + 1.0,
            object_id=band[None],
            motion=torch.stack([torch.full((h, w), drift[0]), torch.full((h, w), drift[1])]),
            timings={"render": 1.0},
        )

    return render


def _build(name: str, h: int, w: int, seed: int):
    return make_strategy(name, h, w, seed=seed, spp=4, K=2, mask_size=64)


sizes = st.integers(3, 14)


@given(
    st.sampled_from(PERMUTING),
    sizes,
    sizes,
    st.integers(0, 2**20),
    st.integers(2, 5),
    st.tuples(st.sampled_from([0.0, 1.0, -2.5, 0.4]), st.sampled_from([0.0, -1.0, 3.0])),
)
@settings(max_examples=40)
def test_every_frames_seeds_are_a_permutation_of_the_previous_frames(name, h, w, seed, n, drift):
    record: list = []
    strategy = _build(name, h, w, seed)
    for t in range(n):
        strategy.frame(t, _stand_in(t, record, drift))
    assert len(record) == n
    assert record[0].unique().numel() == h * w  # distinct seeds (or Morton keys) to start with
    for before, after in zip(record, record[1:], strict=False):
        assert torch.equal(before.reshape(-1).sort().values, after.reshape(-1).sort().values)
    # the state carried to the next frame is still the same multiset
    assert torch.equal(
        strategy.seeds.reshape(-1).sort().values, record[0].reshape(-1).sort().values
    )


@given(st.sampled_from(sorted(STRATEGIES)), sizes, sizes, st.integers(0, 2**20), st.integers(1, 3))
@settings(max_examples=40)
def test_the_same_arguments_give_identical_seeds_and_frames(name, h, w, seed, n):
    runs = []
    for _ in range(2):
        record: list = []
        strategy = _build(name, h, w, seed)
        frames = [strategy.frame(t, _stand_in(t, record)) for t in range(n)]
        runs.append((record, frames))
    (rec_a, frames_a), (rec_b, frames_b) = runs
    assert len(rec_a) == len(rec_b)
    assert all(torch.equal(a, b) for a, b in zip(rec_a, rec_b, strict=True))
    for fa, fb in zip(frames_a, frames_b, strict=True):
        assert torch.equal(fa.color, fb.color)


@given(
    st.sampled_from(sorted(STRATEGIES) + list(PERMUTING[4:])),
    st.integers(1, 4),
    st.integers(0, 3),
    st.integers(1, 3),
    st.integers(0, 2**20),
)
@settings(max_examples=40)
def test_play_equals_frames_called_by_hand_for_any_motion_factor(name, motion, start, count, seed):
    h, w = 9, 11
    frames = range(start, start + count)
    played_seeds: list = []

    def render_at(k: int):
        return _stand_in(k, played_seeds)

    played = list(play(_build(name, h, w, seed), render_at, frames, motion))

    by_hand_seeds: list = []
    strategy = _build(name, h, w, seed)
    by_hand = []
    for t in range(first_frame(strategy, frames), frames.stop):
        inner = _stand_in(motion * t, by_hand_seeds)

        def scaled(seeds, sampler, inner=inner):
            out = inner(seeds, sampler)
            return dataclasses.replace(out, motion=out.motion * motion)

        by_hand.append((t, strategy.frame(t, scaled)))

    assert [t for t, _ in played] == [t for t, _ in by_hand]
    if not strategy.stateful:
        assert played[0][0] == frames.start  # a stateless strategy skips to the first frame
    assert all(torch.equal(a, b) for a, b in zip(played_seeds, by_hand_seeds, strict=True))
    for (_, a), (_, b) in zip(played, by_hand, strict=True):
        for key, value in a.buffers().items():
            assert torch.equal(value, b.buffers()[key]), key
        if motion > 1:  # the motion the caller sees is the renderer's, scaled
            want = torch.stack([torch.full((h, w), 1.4), torch.full((h, w), -0.6)]) * motion
            assert torch.equal(a.motion, want)


@pytest.mark.parametrize("name", ["temporal", "temporal_zsobol", "temporal_ldbn"])
def test_the_stand_in_makes_the_permuting_strategies_move_seeds(name):
    # guard: the permutation property above is not vacuous (seeds do move between pixels)
    record: list = []
    strategy = _build(name, 12, 12, 1)
    for t in range(4):
        strategy.frame(t, _stand_in(t, record))
    assert not torch.equal(record[0], record[-1])
