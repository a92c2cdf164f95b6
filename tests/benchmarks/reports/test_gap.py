"""Tests for benchmarks.reports.gap: the share of the white-to-oracle distance, on synthetic
records."""

import csv
import io
import math

import pytest

from benchmarks.reports.gap import (
    GAP_CSV,
    GAP_MD,
    gap_csv,
    gap_markdown,
    gap_shares,
    write_gap_tables,
)
from bnerr.errors import ValueRangeError
from tests._records import metric_pairs, small_record

_SETS, _FRAMES = 3, 4


def _record(strategy, level, *, denoiser="gaussian", spp=4, motion=1, noise=0.0, den=None):
    """A record whose every metric's per-frame MSE is ``level`` (plus a small frame-dependent
    ``noise``), as (value * count, count) pairs over 3 seed sets x 4 frames."""

    def pairs(value):
        return metric_pairs(
            [
                [value + noise * ((s * _FRAMES + f) % 5 - 2) for f in range(_FRAMES)]
                for s in range(_SETS)
            ]
        )

    raw = {m: pairs(level) for m in ("mse", "mse_blur1", "mse_blur2")}
    den_pairs = {"mse": pairs(level if den is None else den)}
    return small_record(
        strategy, denoiser, raw=raw, den=den_pairs, frames=_FRAMES, seed_sets=_SETS, spp=spp,
        motion=motion,
    )  # fmt: skip


def _records(noise=0.0):
    return [
        _record("white", 10.0, noise=noise),
        _record("temporal", 8.0, noise=noise),
        _record("temporal+residual", 6.0, noise=noise),
        _record("oracle", 2.0, noise=noise),
        _record("white", 10.0, denoiser="atrous", den=4.0, noise=noise),
        _record("temporal", 8.0, denoiser="atrous", den=3.0, noise=noise),
        _record("oracle", 2.0, denoiser="atrous", den=2.0, noise=noise),
    ]


def test_share_is_white_minus_strategy_over_white_minus_oracle():
    rows = gap_shares(_records())
    by = {(r.measure, r.strategy): r for r in rows}
    assert by["raw mse_blur2", "temporal"].share == pytest.approx(0.25)
    assert by["raw mse_blur1", "temporal+residual"].share == pytest.approx(0.5)
    assert by["gaussian mse", "temporal"].share == pytest.approx(0.25)
    assert by["atrous mse", "temporal"].share == pytest.approx(0.5)
    assert by["raw mse_blur2", "temporal"].gap == pytest.approx(0.8)
    # constant frames: the interval collapses onto the value
    r = by["raw mse_blur2", "temporal"]
    assert r.lo == pytest.approx(0.25) and r.hi == pytest.approx(0.25)
    # white and oracle are the bounds, not rows; raw measures come once per run, not per denoiser
    assert {s for _, s in by} == {"temporal", "temporal+residual"}
    assert sum(1 for r in rows if r.measure == "raw mse_blur1" and r.strategy == "temporal") == 1


def test_interval_contains_the_share_when_frames_vary():
    for r in gap_shares(_records(noise=0.3)):
        assert r.lo <= r.share <= r.hi and r.hi - r.lo > 0


def test_cells_without_white_and_oracle_or_with_other_frame_counts_are_left_out():
    records = [_record("white", 10.0), _record("temporal", 8.0)]
    assert gap_shares(records) == []
    other_spp = [_record("white", 10.0), _record("oracle", 2.0), _record("temporal", 8.0, spp=1)]
    assert gap_shares(other_spp) == []


def test_tables_carry_every_row(tmp_path):
    rows = gap_shares(_records())
    md = gap_markdown(rows)
    assert "temporal+residual" in md and "0.25 [0.25, 0.25]" in md
    assert md.count("\n| direct |") == 4  # blur1, blur2, gaussian, atrous
    parsed = list(csv.DictReader(io.StringIO(gap_csv(rows))))
    assert len(parsed) == len(rows) and float(parsed[0]["share"]) == pytest.approx(rows[0].share)
    assert gap_markdown([]) == ""
    write_gap_tables(tmp_path, _records())
    assert (tmp_path / GAP_MD).read_text() == md
    assert (tmp_path / GAP_CSV).exists()
    empty = tmp_path / "none"
    empty.mkdir()
    assert write_gap_tables(empty, [_record("white", 1.0)]) == [] and not list(empty.iterdir())


def test_bad_level_is_refused():
    with pytest.raises(ValueRangeError, match="level"):
        gap_shares(_records(), level=0.2)


def test_no_distance_to_close_gives_nan_not_a_division_error():
    # The oracle no better than white (as on a scene where moving seeds cannot help): every
    # share is undefined, and the report must still be written.
    rows = gap_shares([_record("white", 4.0), _record("temporal", 5.0), _record("oracle", 4.0)])
    assert rows and all(math.isnan(r.share) and math.isnan(r.lo) for r in rows)
    assert all(r.gap == 0.0 for r in rows)
