"""benchmarks.studies.jitter_loss: the wrapper pins exactly the jitter's dimensions, and the
measurement runs end to end at a tiny size with its ratios to white."""

from __future__ import annotations

import pytest
import torch

from benchmarks.studies.jitter_loss import FixedJitter, main, measure
from bnerr.errors import ValueRangeError
from bnerr.sequences import make_sampler


def _lanes(n: int = 64) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    seed = torch.arange(n, dtype=torch.int64) * 2654435761 % 2**32
    pixel = torch.stack([torch.arange(n) // 8, torch.arange(n) % 8], 1)
    return seed, torch.arange(n, dtype=torch.int64) % 4, pixel


@pytest.mark.parametrize(("dim", "count"), [(0, 6), (1, 3), (2, 4)])
def test_only_dimensions_0_and_1_are_pinned_at_the_pixel_centre(dim, count):
    inner = make_sampler("owen_sobol")
    seed, index, pixel = _lanes()
    got = FixedJitter(inner).sample(seed, index, dim, count, pixel)
    want = inner.sample(seed, index, dim, count, pixel)
    for j, d in enumerate(range(dim, dim + count)):
        if d < 2:
            assert bool((got[:, j] == 0.5).all())
        else:
            assert torch.equal(got[:, j], want[:, j])


def test_measure_gives_ratios_to_white_both_ways():
    rows = measure("direct", ("ldbn_zorder",), (4,), size=16, sets=2, ref_spp=16)
    assert [(r.strategy, r.spp, r.fixed) for r in rows] == [
        ("ldbn_zorder", 4, False),
        ("ldbn_zorder", 4, True),
    ]
    for r in rows:
        for e in (r.raw, r.blurred):
            assert e.value > 0 and e.lo <= e.value <= e.hi


def test_white_is_the_baseline_not_a_contender():
    with pytest.raises(ValueRangeError, match="white"):
        measure("direct", ("white",), (4,), size=16, sets=2, ref_spp=16)


def test_main_prints_one_row_per_strategy_and_spp(capsys):
    main(["--scenes", "direct", "--strategies", "zsobol", "--spp", "1", "--size", "16",
          "--sets", "2"])  # fmt: skip
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == 3 and lines[2].startswith("| direct | zsobol | 1 |")
