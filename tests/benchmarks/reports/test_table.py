"""Tests of benchmarks.reports: rows, ratios to white, flags, CSV, Markdown and charts."""

import csv
import dataclasses
import math

import numpy as np
import pytest
import torch

from benchmarks.reports import decision, table, write_report
from benchmarks.reports.table import COLUMNS, markdown_table, summarize, table_columns
from benchmarks.sweep.plan import Cell
from benchmarks.sweep.records import (
    Record,
    ReferenceInfo,
    Spectrum,
    Timings,
    write_records,
)
from bnerr.metrics import METRIC_TABLE, FrameMetrics, ImagePair, Metric, paired_ratio, t_quantile
from bnerr.strategies import strategy_identity
from tests._records import metric_pairs

_METRICS = ("mse", "relmse", "psnr", "ssim", "mse_blur1", "mse_blur2", "lowfreq")


def _record(
    strategy, spp, denoiser, den_mse, raw_mse, *, scene="direct", region="all", motion=1, crop=None
):
    """A record whose per-frame metric pairs are (value * count, count) for 2 sets x 3 frames."""
    count = 3 * 16 * 16

    def pairs(values):
        return metric_pairs(values, count)

    def flat(value):
        return [[value] * 3] * 2

    cell = Cell(
        scene=scene,
        strategy=strategy,
        spp=spp,
        denoiser=denoiser,
        motion=motion,
        depth=None,
        region=region,
        sampler="owen_sobol",
        frames=3,
        warmup=2,
        width=16,
        height=16,
        seed_sets=2,
        reference_spp=64,
    )
    per_metric = {m: pairs(flat(0.5)) for m in _METRICS}
    return Record(
        cell=cell,
        dimensions=4,
        t=[2, 3, 4],
        raw={**per_metric, "mse": pairs(raw_mse), "mse_blur1": pairs(raw_mse)},
        den={**per_metric, "mse": pairs(den_mse)},
        denoiser_params={"sigma": 1.0},
        timings=Timings(
            render_ms=[[10.0 * spp] * 3] * 2, perm_ms=[[1.0] * 3] * 2, denoise_ms=[[2.0] * 3] * 2
        ),
        reference=ReferenceInfo(spp=64, floor=1e-5, version="test"),
        spectrum={
            "raw": Spectrum(freq=[0.0, 0.25, 0.5], power=[0.0, 1.0, 2.0]),
            "den": Spectrum(freq=[0.0, 0.25, 0.5], power=[0.0, 0.1, 0.01]),
        },
        crop=crop,
    )


_WHITE = [[1.0, 2.0, 3.0], [1.5, 2.5, 3.5]]
_TEMPORAL = [[0.5, 1.1, 1.4], [0.8, 1.2, 1.8]]
_WORSE = [[2.0, 4.1, 6.3], [3.1, 5.0, 7.2]]


def _records():
    return [
        _record("white", 1, "gaussian", _WHITE, _WHITE),
        _record("temporal", 1, "gaussian", _TEMPORAL, _WHITE),
        _record("oracle", 1, "gaussian", _WORSE, _WHITE),
        _record("white", 4, "gaussian", _WHITE, _WHITE),
        _record("temporal", 4, "gaussian", _TEMPORAL, _WHITE),
    ]


def test_rows_pair_each_strategy_with_white_on_the_same_cell():
    rows = summarize(_records())
    assert len(rows) == 5 and all(set(r) == set(COLUMNS) for r in rows)
    temporal = next(r for r in rows if r["strategy"] == "temporal" and r["spp"] == 1)
    want = paired_ratio(np.asarray(_TEMPORAL), np.asarray(_WHITE))
    assert temporal["den_mse_ratio"] == pytest.approx(np.mean(_TEMPORAL) / np.mean(_WHITE))
    assert (temporal["den_mse_ratio_lo"], temporal["den_mse_ratio_hi"]) == pytest.approx(
        (want.lo, want.hi)
    )
    assert temporal["raw_mse_ratio"] == pytest.approx(1.0)
    assert temporal["worse_than_white"] is False
    assert temporal["total_ms"] == pytest.approx(10.0 + 1.0 + 2.0)
    white = next(r for r in rows if r["strategy"] == "white" and r["spp"] == 1)
    assert white["den_mse_ratio"] == pytest.approx(1.0) and white["worse_than_white"] is False
    assert white["den_mse"] == pytest.approx(np.mean(_WHITE))
    assert white["den_mse_lo"] < white["den_mse"] < white["den_mse_hi"]


def test_a_strategy_is_flagged_only_when_its_interval_lies_above_white():
    rows = summarize(_records())
    oracle = next(r for r in rows if r["strategy"] == "oracle")
    assert oracle["den_mse_ratio_lo"] > 1.0 and oracle["worse_than_white"] is True
    text = markdown_table(rows)
    flagged = text.split("## Worse than white beyond the interval")[1]
    assert "oracle" in flagged and "temporal" not in flagged


def test_no_white_record_leaves_the_ratio_empty():
    rows = summarize([_record("temporal", 1, "gaussian", _TEMPORAL, _WHITE)])
    assert rows[0]["den_mse_ratio"] is None and rows[0]["worse_than_white"] is None


def test_markdown_shows_ratios_per_scene_and_spp():
    text = markdown_table(summarize(_records()), "T")
    assert text.startswith("# T")
    assert "### direct" in text
    header = next(line for line in text.splitlines() if line.startswith("| spp | denoiser |"))
    assert header == "| spp | denoiser | white | temporal | oracle |"
    ratio = np.mean(_TEMPORAL) / np.mean(_WHITE)
    assert f"| 1 | gaussian | {np.mean(_WHITE):.4g} | {ratio:.3f} [" in text
    assert "(worse)" in text


def test_headline_gives_temporal_and_oracle_per_scene_spp_and_denoiser():
    rows = summarize(_records())
    lines = markdown_table(rows, "T").splitlines()
    start = lines.index("| scene | spp | gaussian |")
    by = {(r["strategy"], r["spp"]): r for r in rows}
    temporal, oracle = by["temporal", 1], by["oracle", 1]
    assert temporal["den_mse_ratio_hi"] < 1.0 < oracle["den_mse_ratio_lo"]  # the fixture's premise
    # better beyond the interval: bold; worse beyond it: an arrow; not measured: a dash
    assert (
        lines[start + 2]
        == f"| direct | 1 | **{temporal['den_mse_ratio']:.2f}** / {oracle['den_mse_ratio']:.2f}↑ |"
    )
    assert lines[start + 3] == f"| direct | 4 | **{by['temporal', 4]['den_mse_ratio']:.2f}** / - |"


def test_headline_is_left_out_without_the_compared_strategies():
    rows = summarize([r for r in _records() if r.cell.strategy == "white"])
    assert "## Headline" not in markdown_table(rows, "T")


def test_write_report_writes_csv_markdown_and_charts(tmp_path):
    crop = tmp_path / "crops"
    crop.mkdir()
    image = np.zeros((8, 8, 3), np.uint8)
    np.savez_compressed(crop / "c.npz", reference=image, raw=image, denoised__gaussian=image)
    records = [dataclasses.replace(r, crop="crops/c.npz") for r in _records()]
    text = write_report(tmp_path, records, title="T")
    assert (tmp_path / "table.md").read_text() == text
    with open(tmp_path / "table.csv") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 5 and tuple(rows[0]) == COLUMNS
    assert rows[0]["scene"] == "direct" and float(rows[0]["den_mse"]) == pytest.approx(
        np.mean(_WHITE)
    )
    for name in ("error_vs_time_direct.png", "spectra_direct.png", "crops/c.webp", "index.html"):
        assert (tmp_path / name).exists(), name
    assert not (tmp_path / "crops" / "c.npz").exists()  # kept as the strip the page shows
    assert not list(tmp_path.glob(".*.tmp*"))  # atomic writes leave no temporary files


def test_conditions_get_their_own_sections_and_charts(tmp_path):
    records = _records() + [
        _record("white", 1, "gaussian", _WHITE, _WHITE, motion=0),
        _record("temporal", 1, "gaussian", _TEMPORAL, _WHITE, motion=0),
        _record("white", 1, "gaussian", _WHITE, _WHITE, region="edges"),
        _record("temporal", 1, "gaussian", _WORSE, _WHITE, region="edges"),
    ]
    text = write_report(tmp_path, records)
    assert "### direct (static camera)" in text and "### direct (object edges only)" in text
    assert (tmp_path / "error_vs_time_direct_m0.png").exists()
    assert not (tmp_path / "error_vs_time_direct_edges.png").exists()  # charts: whole image only
    assert table.summarize(records)[-1]["worse_than_white"] is True


def test_raw_mse_differences_from_white_are_listed_once_per_run():
    records = _records() + [
        _record("bnds", 1, "gaussian", _WHITE, _WORSE),
        _record("bnds", 1, "median", _WHITE, _WORSE),
        _record("bnds", 4, "gaussian", _WHITE, _WORSE),
    ]
    rows = summarize(records)
    bnds = {r["denoiser"]: r["raw_differs_from_white"] for r in rows if r["strategy"] == "bnds"}
    assert bnds == {"gaussian": True, "median": None}  # no white median record: nothing to compare
    assert not any(r["raw_differs_from_white"] for r in rows if r["strategy"] == "temporal")
    section = markdown_table(rows).split("## Raw MSE different from white beyond the interval")[1]
    section = section.split("## Worse than white")[0]
    assert (
        section.count("| direct | direct | bnds | 1 |") == 1
        and section.count("| direct | direct | bnds | 4 |") == 1
    )
    assert f"- bnds: {strategy_identity('bnds').raw_mse_note}" in section  # the cause, once


def test_a_raw_difference_without_a_known_cause_says_so():
    assert table._raw_causes(["temporal+groups", "zsobol_t"]) == [
        "- temporal+groups: cause not established.",
        f"- zsobol_t: {strategy_identity('zsobol_t').raw_mse_note}",
        "",
    ]


def test_write_report_reads_the_results_file_when_given_no_records(tmp_path):
    write_records(tmp_path, _records())
    assert write_report(tmp_path, title="T", charts=False) == markdown_table(
        summarize(_records()), "T"
    )


def _max_abs_error(pair: ImagePair):
    """A toy metric: the largest absolute error of the frame, as a per-image score."""
    return pair.score(float(pair.err.abs().max()))


def _toy_pairs(noise: float) -> list:
    """``[2][3][2]`` pairs of the toy metric over 2 seed sets x 3 frames of 16 x 16 images."""
    acc = FrameMetrics(["maxerr"])
    gen = torch.Generator().manual_seed(int(noise * 100))
    for k in range(6):
        ref = torch.rand(3, 16, 16, generator=gen) + 0.1
        acc.update(ref + noise * torch.randn(3, 16, 16, generator=gen), ref, group=k // 3)
    return acc.stats("maxerr").tolist()


def test_a_metric_added_to_the_table_reaches_table_csv(tmp_path, monkeypatch):
    # One update function and one table entry: the records carry it, the report writes its
    # columns (its ratio to white too, as the entry asks) with no change to the report.
    monkeypatch.setitem(METRIC_TABLE, "maxerr", Metric(_max_abs_error, ratio=True))
    white, blue = _toy_pairs(0.2), _toy_pairs(0.1)
    records = []
    for rec, pairs in ((r, white if r.cell.strategy == "white" else blue) for r in _records()):
        raw, den = {**rec.raw, "maxerr": pairs}, {**rec.den, "maxerr": pairs}
        records.append(dataclasses.replace(rec, raw=raw, den=den))
    write_records(tmp_path, records)
    write_report(tmp_path, charts=False)  # from cells.jsonl, as --report-only does
    with open(tmp_path / "table.csv") as handle:
        header = next(csv.reader(handle))
        rows = list(csv.DictReader(handle, fieldnames=header))
    added = [c for c in header if "maxerr" in c]
    assert added == [
        *(f"{k}_maxerr_ratio{b}" for k in ("raw", "den") for b in ("", "_lo", "_hi")),
        "raw_maxerr",
        "den_maxerr",
    ]
    assert [c for c in header if c not in added] == list(COLUMNS)
    assert header.index("raw_maxerr") == header.index("den_flip") + 1  # the last value
    want = np.asarray(white)[..., 0].sum() / np.asarray(white)[..., 1].sum()
    assert float(rows[0]["raw_maxerr"]) == pytest.approx(want, rel=1e-5)  # written as .6g
    temporal = next(r for r in rows if r["strategy"] == "temporal" and r["spp"] == "1")
    ratio = paired_ratio(np.asarray(blue), np.asarray(white))
    assert float(temporal["den_maxerr_ratio"]) == pytest.approx(ratio.value, rel=1e-5)
    monkeypatch.delitem(METRIC_TABLE, "maxerr")
    assert table_columns() == COLUMNS


def test_a_metric_the_table_keeps_out_of_tables_gets_no_column(monkeypatch):
    monkeypatch.setitem(METRIC_TABLE, "hidden", Metric(_max_abs_error, ratio=True, tabled=False))
    assert not [c for c in table_columns() if "hidden" in c]
    assert "den_flip_ratio" in COLUMNS  # flip's ratio is a perceptual verdict (empty unmeasured)
    assert all(
        f"raw_{name}" in COLUMNS or f"raw_{name}_ratio" in COLUMNS
        for name, m in METRIC_TABLE.items()
        if m.tabled
    )


def test_the_decision_table_bolds_only_an_established_winner():
    rows = summarize(_records(), resamples=200)
    text = decision.decision_table(rows, title="T")
    assert text.startswith("# T\n")
    (line1,) = [line for line in text.splitlines() if line.startswith("| direct | 1 |")]
    assert "**temporal** " in line1  # temporal below white beyond the interval at 1 spp
    assert "Left out: oracle (it renders K candidates per frame" in text
    with_oracle = decision.best_rows(rows, exclude=())
    assert {r["strategy"] for r in with_oracle.values()} <= {"white", "temporal", "oracle"}
    assert "| direct | 4 |" in text


def test_a_strategy_with_its_own_sampler_is_named_in_its_section():
    records = _records() + [
        dataclasses.replace(
            _record("zsobol", 1, "gaussian", _WHITE, _WHITE), render_sampler="zsobol"
        )
    ]
    rows = summarize(records, resamples=200)
    assert {r["strategy"]: r["render_sampler"] for r in rows}["zsobol"] == "zsobol"
    text = markdown_table(rows)
    assert (
        "Samplers: owen_sobol per-pixel sequences, except the strategies that dictate their own "
        in text
    )
    assert "(zsobol: zsobol)" in text
    old = dataclasses.replace(records[-1], render_sampler=None)
    assert table.render_sampler(old) == "zsobol"  # files from before: the strategy's own
    assert "Samplers:" not in markdown_table(summarize(_records(), resamples=200))


def _with_flicker(rec: Record, tmse: list[list[float]]) -> Record:
    """``rec`` with the temporal metrics measured: ``tmse`` per frame after the first of each
    seed set, which weighs nothing (no frame before it)."""
    pairs = [[[0.0, 0.0]] + row for row in metric_pairs([v[1:] for v in tmse], 768.0)]
    temporal = {"tmse": pairs, "trelmse": pairs, "mse_tavg": pairs}
    return dataclasses.replace(rec, raw={**rec.raw, **temporal}, den={**rec.den, **temporal})


_STEADY = [[0.0, 1.0, 1.1], [0.0, 1.2, 0.9]]
_FLICKERS = [[0.0, 3.0, 3.3], [0.0, 3.1, 2.8]]


def test_flicker_beyond_its_interval_is_noted_in_the_decision_table_and_tabled():
    records = [
        _with_flicker(r, _FLICKERS if r.cell.strategy == "temporal" else _STEADY)
        for r in _records()
    ]
    rows = summarize(records)
    temporal = next(r for r in rows if r["strategy"] == "temporal" and r["spp"] == 1)
    want = np.mean([v[1:] for v in _FLICKERS]) / np.mean([v[1:] for v in _STEADY])
    assert temporal["den_tmse_ratio"] == pytest.approx(want)
    assert temporal["den_tmse_ratio_lo"] > 1.0 and temporal["den_mse_tavg_ratio"] is not None
    notes = decision.decision_table(rows).split("Flicker:")[1]
    assert "direct, 1 spp, gaussian: temporal flickers more than white" in notes
    assert "oracle" not in notes  # a bound, left out of the decision
    text = markdown_table(rows)
    assert "Flicker after denoising" in text and "(worse)" in text.split("Flicker after")[1]
    steady = [_with_flicker(r, _STEADY) for r in _records()]
    assert "No strategy flickers more than white" in decision.decision_table(summarize(steady))


def test_records_without_the_temporal_metrics_build_reports_as_before():
    old = _records()  # written before the temporal metrics existed
    rows = summarize(old)
    assert all(r["den_tmse"] is None and r["den_tmse_ratio"] is None for r in rows)
    assert "Flicker" not in markdown_table(rows) and "Flicker" not in decision.decision_table(rows)
    # a resumed folder mixes them: the old cells say "not measured", never a crash
    mixed = summarize([_with_flicker(old[0], _STEADY), *old[1:]])
    assert "not measured" in markdown_table(mixed)
    one_frame = _with_flicker(old[0], _STEADY)
    single = dataclasses.replace(
        one_frame, den={**one_frame.den, "tmse": [[[0.0, 0.0]]] * 2}
    )  # a single measured frame: nothing to difference
    assert summarize([single])[0]["den_tmse"] is None


def _jod_pairs(per_set: list[float]) -> list:
    """cvvdp's pairs of 2 seed sets x 3 frames, pooling to ``per_set`` (the telescoping
    increments of a constant JOD are the JOD itself)."""
    return [[[j, 1.0]] * 3 for j in per_set]


def test_cvvdp_gets_its_value_interval_and_difference_to_white_not_a_ratio():
    jods = {"white": [6.0, 6.4], "temporal": [7.1, 7.3], "oracle": [5.0, 5.6]}
    records = [
        dataclasses.replace(
            r,
            raw={**r.raw, "cvvdp": _jod_pairs([6.0, 6.0])},
            den={**r.den, "cvvdp": _jod_pairs(jods[r.cell.strategy])},
        )
        for r in _records()
    ]
    rows = summarize(records)
    temporal = next(r for r in rows if r["strategy"] == "temporal" and r["spp"] == 1)
    assert temporal["den_cvvdp"] == pytest.approx(7.2)
    diffs = np.array([7.1 - 6.0, 7.3 - 6.4])
    half = t_quantile(0.95, 1) * diffs.std(ddof=1) / math.sqrt(2)
    assert temporal["den_cvvdp_diff"] == pytest.approx(diffs.mean())
    assert (temporal["den_cvvdp_diff_lo"], temporal["den_cvvdp_diff_hi"]) == pytest.approx(
        (diffs.mean() - half, diffs.mean() + half)
    )
    assert temporal["raw_cvvdp_diff"] == pytest.approx(0.0)
    assert "den_cvvdp_ratio" not in COLUMNS and "den_cvvdp_diff_lo" in COLUMNS
    assert all(r["den_cvvdp_diff"] is None for r in summarize(_records()))  # not measured


def test_an_installed_metric_the_records_lack_adds_no_columns(forget):
    """Issue 54: a metric plug-in registered in this process (as an installed entry point is)
    added empty columns to every table.csv, so that the same folder's report differed with the
    environment. Its columns appear only where a record measured it; shipped ones always."""
    from benchmarks.reports.table import csv_text
    from bnerr import plugins
    from tests._records import small_record

    def blind(pred, ref):
        """a plug-in metric"""
        return 0.0

    blind.name = "tab_plug"
    forget.append(("bnerr.metrics", "tab_plug"))
    before = [
        small_record(
            s, "gaussian", raw={"mse": metric_pairs([[1.0, 2.0]] * 2)},
            den={"mse": metric_pairs([[1.0, 2.0]] * 2)}, frames=2, seed_sets=2,
        )
        for s in ("white", "temporal")
    ]  # fmt: skip
    text = csv_text(summarize(before))
    METRIC_TABLE.add(plugins.Plugin("entry point tab_plug", blind, "tabdist 1.0"))
    assert "raw_tab_plug" in table_columns()
    assert csv_text(summarize(before)) == text  # the records alone decide
    measured = [
        dataclasses.replace(r, raw={**r.raw, "tab_plug": metric_pairs([[0.5, 0.5]] * 2, 1.0)})
        for r in before
    ]
    header = csv_text(summarize(measured)).splitlines()[0].split(",")
    assert "raw_tab_plug" in header and "den_tab_plug" not in header
    assert "den_mse_ratio" in header  # a shipped metric's columns stay, filled or not


def test_a_rival_stopped_at_an_earlier_look_pairs_with_whites_first_seed_sets():
    """White went on to 4 seed sets (another sweep's rival still open) while temporal settled at
    2: temporal's ratio pairs with white's first 2 seed sets, the records of white's look at 2
    (issue 52: four Cycles cells showed no ratio), and equals the ratio against that look."""
    from benchmarks.sweep.records import earlier_look

    white = _looked("white", [[1.0, 1.2], [0.9, 1.1], [5.0, 6.0], [4.0, 3.0]])
    rival = _looked("temporal", [[0.8, 0.9], [0.7, 0.95]])
    late = {r["strategy"]: r for r in summarize([white, rival])}
    assert late["temporal"]["den_mse_ratio"] is not None
    at_two = {r["strategy"]: r for r in summarize([earlier_look(white, 2), rival])}
    for column in ("den_mse_ratio", "den_mse_ratio_lo", "den_mse_ratio_hi"):
        assert late["temporal"][column] == at_two["temporal"][column]
    assert late["white"]["seed_sets"] == 4  # white's own row is its last look's
    beyond = _looked("temporal", [[0.8, 0.9]] * 3)  # 3 is not a look of white's: no pairing
    assert summarize([white, beyond])[1]["den_mse_ratio"] is None


def test_a_rival_a_look_past_white_is_shown_at_whites_look():
    """A run stopped after the rival's look at 4 and before white's: the rival's row is its
    first 2 seed sets, paired with white's look at 2."""
    from benchmarks.sweep.records import earlier_look

    white = _looked("white", [[1.0, 1.2], [0.9, 1.1]])
    rival = _looked("temporal", [[0.8, 0.9], [0.7, 0.95], [3.0, 2.0], [0.1, 0.2]])
    rows = {r["strategy"]: r for r in summarize([white, rival])}
    want = {r["strategy"]: r for r in summarize([white, earlier_look(rival, 2)])}
    assert rows["temporal"]["seed_sets"] == 2
    assert rows["temporal"]["den_mse_ratio"] == want["temporal"]["den_mse_ratio"] is not None


def _looked(strategy, values):
    """A record of an adaptive run with looks at 2 and 4 seed sets: ``values`` [S][F] its MSE."""
    from tests._records import small_record

    pairs = metric_pairs(values)
    r = small_record(
        strategy, "gaussian", raw={"mse": pairs}, den={"mse": pairs}, frames=2,
        seed_sets=len(values),
    )  # fmt: skip
    return dataclasses.replace(r, looks=(2, 4))
