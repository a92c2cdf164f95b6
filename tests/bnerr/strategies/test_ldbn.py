"""Tests for bnerr.strategies.ldbn: the LDBN strategies read their key sets at the frame's offset or
slice."""

from bnerr.masks import frame_offset
from bnerr.strategies import (
    make_strategy,
)
from tests.bnerr.strategies._renders import hash_render


def test_ldbn_strategies_read_their_key_sets_at_the_frames_offset_or_slice():
    from bnerr.strategies.ldbn import LDBN_SETS

    for name in ("ldbn", "ldbn_fast", "ldbn_atrous", "ldbn_st"):
        record: list = []
        strategy = make_strategy(name, 6, 9, seed=2, spp=3)
        for t in range(5):
            strategy.frame(t, hash_render(record))
        frames = LDBN_SETS[name][1]
        first = record[0][1]
        assert first.level == 2 and first.spp == 3  # the tile for 4 spp serves 3
        for t, (_, sampler) in enumerate(record):
            assert sampler.name == "ldbn" and sampler.keys.dims == 8
            if name == "ldbn_st":  # slice t mod F at one offset per seed set
                assert sampler.keys is strategy.keys[t % frames] and sampler.offset == first.offset
            else:  # one tile shifted by the R2 step per frame
                dy, dx = frame_offset(t, 64)
                assert sampler.keys is strategy.keys[0]
                assert sampler.offset == ((first.offset[0] + dy) % 64, (first.offset[1] + dx) % 64)
        assert len({int(s[0, 0]) for s, _ in record}) == 5  # fresh per-pixel seeds per frame
