"""Tests of benchmarks.reports.perceptual: the decision's cells judged in JOD (higher is better)
and by FLIP, with the MSE table's corrections, and their agreement with the MSE verdicts."""

import math

import pytest

from benchmarks.reports import decision, perceptual
from benchmarks.reports.perceptual import JOD_MARGIN, JUDGES, judge_cells, perceptual_report
from bnerr.metrics import Estimate, t_quantile
from tests._records import table_row


def _row(strategy, spp, jod=None, mse=1.0, *, half=0.2, seed_sets=4, looks=None, den="gaussian"):
    """A table.csv row: its MSE ratio to white (``mse``, a tight interval) and its JOD difference
    to white (``jod``, +- ``half`` at 95 %)."""
    extra = {"looks": looks} if looks else {}
    return table_row(
        strategy,
        spp,
        mse,
        jod=jod,
        jod_half=half,
        den=den,
        seed_sets=seed_sets,
        render_ms=10.0,
        perm_ms=1.0,
        **extra,
    )


_JOD = JUDGES[0]


def test_the_best_rival_is_the_highest_jod_and_its_interval_is_corrected_for_m():
    rows = [
        _row("white", 1, 0.0),
        _row("ldbn", 1, 0.5, mse=0.9),
        _row("zsobol", 1, 0.3, mse=0.8),
        _row("oracle", 1, 2.0, mse=0.5),  # a bound: left out
    ]
    (found,) = judge_cells(rows, _JOD).values()
    assert found.row["strategy"] == "ldbn" and found.rivals == 2  # higher is better
    se = 0.2 / t_quantile(0.95, 3)  # a fixed design of 4 seed sets: 3 degrees of freedom
    half = se * t_quantile(1 - 0.05 / 2, 3)
    assert (found.estimate.lo, found.estimate.hi) == pytest.approx((0.5 - half, 0.5 + half))
    assert found.verdict == "better"


def test_a_rival_that_rendered_whites_own_frames_is_left_out_as_in_the_mse_table():
    twin = _row("classic_adaptive", 1, 0.0, mse=1.0, half=0.0)
    twin.update(den_mse_ratio_lo=1.0, den_mse_ratio_hi=1.0)
    twin.update(raw_mse_ratio=1.0, raw_mse_ratio_lo=1.0, raw_mse_ratio_hi=1.0)
    rows = [_row("white", 1, 0.0), twin, _row("ldbn", 1, -0.5, mse=0.9)]
    (found,) = judge_cells(rows, _JOD).values()
    assert found.row["strategy"] == "ldbn" and found.rivals == 1  # not the twin's 0.00 "equal"
    assert found.verdict == "worse"


@pytest.mark.parametrize(
    ("jod", "half", "said"),
    [(0.5, 0.2, "better"), (-0.5, 0.2, "worse"), (0.0, 0.05, "equal"), (0.1, 0.3, "open")],
)
def test_a_jod_verdict_reads_the_difference_the_right_way_round(jod, half, said):
    est = Estimate(jod, jod - half, jod + half, 0)
    assert perceptual.perceptual_verdict(est, _JOD) == said
    assert JOD_MARGIN == 0.1


def test_an_adaptive_cell_gets_the_level_of_the_look_the_mse_rule_stopped_at():
    rows = [_row("white", 4, 0.0, seed_sets=8, looks=(4, 8, 16, 32))]
    rows.append(_row("ldbn", 4, 0.5, seed_sets=8, looks=(4, 8, 16, 32)))
    (found,) = judge_cells(rows, _JOD).values()
    design = decision.design_of(rows[1])
    level = design.level(8, 1)
    half = 0.2 / t_quantile(0.95, 7) * t_quantile(level, 7)
    assert found.estimate.hi == pytest.approx(0.5 + half)


def test_the_report_counts_agreement_with_the_mse_and_lists_the_disagreements():
    rows = [
        _row("white", 1, 0.0),
        _row("ldbn", 1, 0.5, mse=0.8),  # both better
        _row("white", 4, 0.0, den="oidn"),
        _row("ldbn", 4, -0.6, mse=0.8, den="oidn"),  # MSE better, JOD worse
    ]
    agree, total, lines = perceptual.agreement(rows, _JOD)
    assert (agree, total) == (1, 2)
    assert lines == ["- direct, 4 spp, oidn: MSE says better, JOD says worse (ldbn -0.60)"]
    text = perceptual_report(rows)
    assert "| direct | 1 | **ldbn +0.50** [" in text
    assert "1 of the 2 cells agree with the MSE verdict" in text
    assert "FLIP" not in text.split("## ", 2)[-1].splitlines()[0]  # no FLIP table: not measured


def test_flip_is_judged_as_a_ratio_where_lower_is_better():
    flip = JUDGES[1]
    rows = [_row("white", 1), _row("ldbn", 1, mse=0.9), _row("zsobol", 1, mse=0.95)]
    for r, ratio in zip(rows[1:], (0.8, 0.7), strict=True):
        r.update(
            den_flip_ratio=ratio, den_flip_ratio_lo=ratio - 0.05, den_flip_ratio_hi=ratio + 0.05
        )
    (found,) = judge_cells(rows, flip).values()
    assert found.row["strategy"] == "zsobol" and found.verdict == "better"
    assert "## FLIP (flip)" in perceptual_report(rows)


def test_records_without_a_perceptual_metric_write_no_report():
    assert perceptual_report([_row("white", 1), _row("ldbn", 1, mse=0.9)]) == ""


def test_an_unbounded_interval_stays_open():
    rows = [_row("white", 1, 0.0), _row("ldbn", 1, 0.5, seed_sets=1)]
    rows[1]["den_cvvdp_diff_lo"], rows[1]["den_cvvdp_diff_hi"] = -math.inf, math.inf
    (found,) = judge_cells(rows, _JOD).values()
    assert found.verdict == "open"


def test_the_readmes_line_counts_agreement_over_the_headlines_cells_only():
    rows = [
        _row("white", 1, 0.0),
        _row("ldbn", 1, 0.5, mse=0.8),  # both better
        _row("white", 4, 0.0, den="oidn"),
        _row("ldbn", 4, -0.6, mse=0.8, den="oidn"),  # MSE better, JOD worse
        _row("white", 4, 0.0, den="taa"),  # a denoiser the headline does not show
        _row("ldbn", 4, -0.6, mse=0.8, den="taa"),
    ]
    rows += [dict(r, region="coherent") for r in rows[:2]]  # another region: not counted
    line = perceptual.headline_agreement(rows, ["gaussian", "oidn"], ["direct"])
    assert line == (
        "Judged in JOD (cvvdp, perceptual.md), 1 of these 2 cells get the MSE's verdict; in 1 "
        "one says better and the other does not."
    )
    assert perceptual.headline_agreement(rows, ["gaussian"], ["cornell"]).startswith(
        "Judged in JOD (cvvdp, perceptual.md), 0 of these 0 cells"
    )
    plain = [{k: v for k, v in r.items() if "cvvdp" not in k} for r in rows]
    assert perceptual.headline_agreement(plain, ["gaussian"], ["direct"]) == ""
