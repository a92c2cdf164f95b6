"""``benchmarks.speed.permute.measure()`` for real on a tiny image: every pass timed, with
its context."""

from __future__ import annotations

import pytest

from benchmarks.speed import permute

pytestmark = pytest.mark.usefixtures("one_thread")


def test_permute_times_every_pass_with_its_context():
    figures = permute.measure(width=16, height=8, repeats=1, threads=1, mask_size=64)
    for key in ("sort_pass_lum_ms", "sort_pass_rgb_ms", "argsort_ms", "torch_path_ms"):
        assert figures[key] > 0, key
    for key in ("plan_ms", "retarget_ms", "retarget_torch_ms"):
        assert figures[key] > 0, key
    assert figures["ratio"] == pytest.approx(figures["argsort_ms"] / figures["sort_pass_lum_ms"])
    assert figures["gap"] and all(v > 0 for v in figures["gap"].values())
    assert (figures["threads"], figures["device"]) == (1, "cpu")
    assert figures["size"] == "16x8, block 4" and isinstance(figures["native"], str)
