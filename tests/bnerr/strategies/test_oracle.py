"""Tests for bnerr.strategies.oracle: histogram-sampled selection that assembles every buffer,
candidates rendered through render_batch when the render offers it."""

import pytest
import torch

from bnerr.errors import (
    DtypeError,
)
from bnerr.masks import frame_offset, load_mask, tile_mask
from bnerr.permutation.permute import histogram_select, luminance
from bnerr.strategies import (
    OracleStrategy,
)
from tests.bnerr.strategies._renders import hash_render


def test_oracle_selects_by_histogram_sampling_and_assembles_every_buffer():
    record: list = []
    strategy = OracleStrategy(12, 18, seed=0, mask=load_mask("scalar", 64), K=5)
    out = strategy.frame(4, hash_render(record))
    frames = [hash_render()(s, None) for s, _ in record]
    assert len(frames) == 5
    assert all(s.unique().numel() == 12 * 18 for s, _ in record)
    b = tile_mask(load_mask("scalar", 64), 12, 18, frame_offset(4, 64))
    choice = histogram_select(torch.stack([luminance(f.color) for f in frames]), b)
    for name in ("color", "albedo", "depth"):
        stacked = torch.stack([getattr(f, name) for f in frames])
        want = stacked.gather(0, choice[None, None].expand(1, stacked.shape[1], 12, 18))[0]
        assert torch.equal(getattr(out, name), want)
    assert out.timings["render"] == 5.0  # summed over the candidates
    assert out.timings["strategy"] == strategy.overhead_ms >= 0


def test_the_oracle_renders_its_candidates_through_render_batch_when_offered():
    one_by_one: list = []
    want = OracleStrategy(12, 18, seed=3, mask=load_mask("scalar", 64), K=4).frame(
        2, hash_render(one_by_one)
    )
    batches: list = []
    render = hash_render()

    def batch(seeds, sampler):
        batches.append(seeds.clone())
        return [render(s, sampler) for s in seeds]

    render.batch = batch
    got = OracleStrategy(12, 18, seed=3, mask=load_mask("scalar", 64), K=4).frame(2, render)
    assert len(batches) == 1 and batches[0].shape == (4, 12, 18)
    assert torch.equal(batches[0], torch.stack([s for s, _ in one_by_one]))
    for name, value in want.buffers().items():
        assert torch.equal(value, got.buffers()[name]), name
    assert got.timings["render"] == 4.0  # summed over the candidates either way
    render.batch = lambda seeds, sampler: [render(s, sampler).color for s in seeds]
    with pytest.raises(DtypeError, match="expected a Frame"):  # the same checks as one by one
        OracleStrategy(12, 18, mask=load_mask("scalar", 64), K=2).frame(0, render)
