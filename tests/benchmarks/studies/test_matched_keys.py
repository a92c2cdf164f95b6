"""Tests of benchmarks.studies.matched_keys: a tiny comparison runs (a key set given by file is read
like ldbn), and the paired ratios are the pooled means' ratios with an interval around them."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.studies.matched_keys import compare, ratio_table
from bnerr.ldbn.keys import load_ldbn_keys


def test_a_tiny_comparison_gives_every_strategy_after_every_denoiser(tmp_path):
    keys = load_ldbn_keys("screen", 64)[0]
    array = np.concatenate([keys.scramble.numpy(), keys.rank.numpy()], -1)[:, None]
    np.save(tmp_path / "k.npy", array)
    out = compare(
        "direct", ["white", "ldbn", "mine"], ["gaussian"], {"mine": tmp_path / "k.npy"},
        size=16, seeds=2, frames=1, ref_spp=4,
    )  # fmt: skip
    assert set(out) == {"raw", "gaussian"} and set(out["raw"]) == {"white", "ldbn", "mine"}
    # the same keys read from the file render the same frames as the shipped ldbn, but with
    # the ldbn strategy's own seeds: both are finite, positive MSEs of the right shape
    assert np.array(out["gaussian"]["mine"]).shape == (2, 1)
    assert np.all(np.array(out["raw"]["mine"]) > 0)


def test_ratios_are_paired_and_centred_on_the_pooled_means():
    white = [[1.0, 1.2], [0.9, 1.1], [1.0, 1.0]]
    blue = [[0.5, 0.6], [0.45, 0.55], [0.5, 0.5]]
    rows = ratio_table({"s": {"raw": {"white": white, "ldbn": blue}}})
    by = {r["strategy"]: r for r in rows}
    value, lo, hi = by["ldbn"]["vs_white"]
    assert value == pytest.approx(0.5) and lo <= value <= hi
    assert "vs_ldbn" not in by["ldbn"] and by["white"]["vs_ldbn"][0] == pytest.approx(2.0)
