"""The adaptive-run door's probe (issue 41): bad ``bnerr bench --until-resolved`` command lines,
in-process, each refused in one line (exit code 2, no traceback) naming the option and what was
expected (tests/_probes.py), before anything is measured; a design of millions of looks is
refused before it is listed."""

from __future__ import annotations

import pytest

from bnerr.errors import ValueRangeError
from bnerr.metrics.sequential import MAX_LOOKS, looks
from tests._probes import refused_on_the_command_line

CASES = {
    "cap without --until-resolved": (["--seed-set-cap", "8"],
                                     r"--seed-set-cap: expected with --until-resolved"),
    "batch without --until-resolved": (["--batch", "2"], r"--batch: expected with --until"),
    "resolve without --until-resolved": (["--resolve", "all"],
                                         r"--resolve: expected with --until-resolved"),
    "stop-settled without --until-resolved": (["--stop-settled"],
                                              r"--stop-settled: expected with --until-resolved"),
    "an unknown region": (["--until-resolved", "--resolve", "lights"],
                          r"--resolve: invalid choice: 'lights'"),
    "with --report-only": (["--until-resolved", "--report-only"],
                           r"--until-resolved: expected a run that measures, got --report-only"),
    "cap 0": (["--until-resolved", "--seed-set-cap", "0"],
              r"--seed-set-cap: expected an integer >= 1, got 0"),
    "negative cap": (["--until-resolved", "--seed-set-cap", "-4"],
                     r"--seed-set-cap: expected an integer >= 1, got -4"),
    "cap as text": (["--until-resolved", "--seed-set-cap", "many"], r"--seed-set-cap.*'many'"),
    "cap 1": (["--until-resolved", "--seed-set-cap", "1"],
              r"--until-resolved: expected 2 <= seed sets <= the cap 1 .*got 2"),
    "batch 0": (["--until-resolved", "--batch", "0"], r"--batch: expected an integer >= 1, got 0"),
    "negative batch": (["--until-resolved", "--batch", "-1"], r"--batch: .*got -1"),
    "fractional batch": (["--until-resolved", "--batch", "1.5"], r"--batch: .*got '1\.5'"),
    "one seed set": (["--until-resolved", "--seed-sets", "1"],
                     r"--until-resolved: expected 2 <= seed sets .*got 1"),
    "seed sets above the cap": (["--until-resolved", "--seed-sets", "8", "--seed-set-cap", "4"],
                                r"expected 2 <= seed sets <= the cap 4 .*got 8"),
    "zero seed sets": (["--until-resolved", "--seed-sets", "0"], r"--seed-sets.*got 0"),
    "a billion looks": (["--until-resolved", "--seed-set-cap", "1000000000", "--batch", "1"],
                        rf"--seed-set-cap 1000000000 --batch 1: .*at most {MAX_LOOKS} looks"),
    "a cap of 2^70": (["--until-resolved", "--seed-set-cap", str(2**70)],
                      r"--seed-set-cap: expected an integer <= 2147483647"),
    "200 looks": (["--until-resolved", "--seed-set-cap", "201", "--batch", "1"],
                  rf"--seed-set-cap 201 --batch 1: .*at most {MAX_LOOKS} looks.*got 200"),
    "resume and overwrite": (["--until-resolved", "--resume", "--overwrite"],
                             r"--overwrite.*not allowed with.*--resume"),
}  # fmt: skip


@pytest.mark.parametrize("what", list(CASES))
def test_a_bad_adaptive_command_line_is_one_line(tmp_path, capsys, what):
    extra, words = CASES[what]
    argv = [
        "bench", "--suite", "quick", "--scenes", "direct", "--strategies", "white",
        "--denoisers", "gaussian", "--spp", "1", "--frames", "1", "--warmup", "0",
        "--res", "8x8", "--reference-spp", "2", "--seed-sets", "2", "--out",
        str(tmp_path / "out"), "--cache", str(tmp_path / "cache"), "--quiet", "--no-charts",
        *extra,
    ]  # fmt: skip
    refused_on_the_command_line(argv, capsys, words)
    assert not (tmp_path / "out" / "cells.jsonl").exists()


def test_looks_are_counted_before_they_are_listed():
    with pytest.raises(ValueRangeError, match=r"at most 64 looks .*got 999999999"):
        looks(2, 10**9, 1)
    assert len(looks(2, MAX_LOOKS + 1, 1)) == MAX_LOOKS
