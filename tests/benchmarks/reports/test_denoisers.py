"""Tests for benchmarks.reports.denoisers: denoisers.md's four sections on synthetic records whose
figures are computed by hand here."""

import pytest

from benchmarks.reports import denoisers as dr
from benchmarks.reports import write_report
from benchmarks.reports.table import summarize
from bnerr.metrics import paired_ratio
from tests._records import metric_pairs, small_record

_SETS, _FRAMES = 2, 3
_WHITE_UNET = [[3.0, 4.0, 5.0], [3.0, 4.0, 5.0]]  # mean 4, varying frames


def _frames(value):
    return value if isinstance(value, list) else [[value] * _FRAMES for _ in range(_SETS)]


def _record(strategy, denoiser, den, raw=10.0, *, blur2=0.5, spp=4, scene="direct", tcorr=None):
    """A record whose per-frame MSE pairs are (value * count, count); ``den`` and ``raw`` are a
    constant or ``[S][F]`` values, the sigma-2 blurred raw MSE is ``blur2`` times the raw MSE."""

    def pairs(values):
        return metric_pairs(_frames(values))

    raw_frames = _frames(raw)
    raw_pairs = {
        "mse": pairs(raw_frames),
        "mse_blur2": pairs([[v * blur2 for v in r] for r in raw_frames]),
    }
    return small_record(
        strategy, denoiser, raw=raw_pairs, den={"mse": pairs(den)}, frames=_FRAMES,
        seed_sets=_SETS, spp=spp, scene=scene, tcorr=tcorr,
    )  # fmt: skip


# Post-denoise MSE per strategy and denoiser (raw MSE 10 unless named; zsobol's raw MSE is 8).
_DEN = {
    "white": dict(gaussian=4.0, taa=5.0, svgf=3.0, oidn=4.0, unet=_WHITE_UNET),
    "temporal": dict(gaussian=3.0, taa=7.5, svgf=3.0, oidn=6.0, unet=3.6, unet_blue=2.52),
    "bnds": dict(gaussian=3.0, taa=4.0, svgf=2.4, oidn=4.0, unet=4.0, unet_blue=3.6),
    "zsobol": dict(gaussian=3.6, taa=5.0, oidn=4.0),
    "oracle": dict(gaussian=2.8, oidn=2.0),
}
_DEN["white"]["unet_blue"] = [[0.9 * v for v in row] for row in _WHITE_UNET]
_OWN = {"white": 3.5, "temporal": 2.0, "oracle": 1.0}
_TCORR = {"white": [[0.1, -0.1], [0.0, 0.0]], "temporal": [[0.6, 0.6], [0.5, 0.7]]}


def _records(denoisers=None, own=True, scene="direct"):
    out = []
    for s, by in _DEN.items():
        raw = 8.0 if s == "zsobol" else 10.0
        blur2 = 0.25 if s == "temporal" else 0.5
        for d, den in by.items():
            if denoisers is None or d in denoisers:
                out.append(_record(s, d, den, raw, blur2=blur2, scene=scene, tcorr=_TCORR.get(s)))
        if own and s in _OWN:
            out.append(_record(s, "gaussian:own", _OWN[s], raw, blur2=blur2, scene=scene))
    return out


def _rows(records):
    return summarize(records, resamples=200)


def test_accumulation_flags_and_factors_by_hand():
    records = _records()
    items = {a.strategy: a for a in dr.accumulation(_rows(records), records)}
    assert list(items) == ["white", "bnds", "zsobol", "temporal", "oracle"]  # the report's order
    temporal, bnds, zsobol = items["temporal"], items["bnds"], items["zsobol"]
    assert temporal.ratios["taa"] == pytest.approx((1.5, 1.5, 1.5))
    assert temporal.ratios["gaussian"] == pytest.approx((0.75, 0.75, 0.75))
    assert temporal.factor == pytest.approx((7.5 / 10) / (5 / 10))
    assert temporal.tcorr == pytest.approx(0.6) and temporal.white_tcorr == pytest.approx(0.0)
    assert temporal.flag == "loses under accumulation"
    assert bnds.flag == "" and bnds.factor == pytest.approx(0.8)  # keeps its gain
    assert bnds.ratios["svgf"] == pytest.approx((0.8, 0.8, 0.8)) and bnds.tcorr is None
    assert zsobol.ratios["taa"] == pytest.approx((1.0, 1.0, 1.0))
    assert zsobol.flag == "gain lost under accumulation"
    assert zsobol.factor == pytest.approx((5 / 8) / (5 / 10)) and zsobol.ratios["svgf"] is None
    assert items["white"].flag == "" and items["white"].mse["taa"] == pytest.approx(5.0)
    assert items["oracle"].factor is None and items["oracle"].flag == ""


def test_flag_and_verdict_rules_on_intervals():
    assert dr.accumulation_flag((0.8, 0.7, 0.9), (1.2, 1.01, 1.3)) == "loses under accumulation"
    assert dr.accumulation_flag((0.8, 0.7, 0.9), (0.9, 0.8, 1.0)) == "gain lost under accumulation"
    assert dr.accumulation_flag((0.8, 0.7, 0.9), (0.9, 0.8, 0.99)) == ""
    assert dr.accumulation_flag((0.8, 0.7, 1.1), (1.0, 0.9, 1.1)) == ""
    assert dr.accumulation_flag((0.8, 0.7, 0.9), None) == ""
    assert dr.oidn_verdict((1.1, 1.01, 1.2)) == "worse than on white"
    assert dr.oidn_verdict((0.9, 0.8, 0.99)) == "better"
    assert dr.oidn_verdict((1.1, 0.99, 1.2)) == "same within the interval"


def test_oidn_keeps_only_strategies_of_the_same_raw_mse():
    kept, left = dr.oidn_response(_rows(_records()))
    by = {k.strategy: k for k in kept}
    assert list(by) == ["bnds", "temporal", "oracle"]
    assert by["temporal"].verdict == "worse than on white"  # 6 / 4 on the same raw MSE
    assert by["temporal"].ratios["oidn"] == pytest.approx((1.5, 1.5, 1.5))
    assert by["temporal"].raw_blur2 == pytest.approx((0.5, 0.5, 0.5))
    assert by["temporal"].ratios["unet_blue"][0] == pytest.approx(2.52 / 3.6)
    assert by["bnds"].verdict == "same within the interval"
    assert by["oracle"].verdict == "better" and by["oracle"].ratios["unet"] is None
    assert [(s, raw) for _, _, s, raw in left] == [("zsobol", pytest.approx((0.8, 0.8, 0.8)))]


def test_best_denoiser_over_every_column_and_the_goal():
    items = dr.best_denoisers(_rows(_records()))
    assert len(items) == 1
    b = items[0]
    assert b.best["white"] == ("svgf", pytest.approx(3.0))
    assert b.best["temporal"] == ("gaussian:own", pytest.approx(2.0))
    assert b.best["bnds"] == ("svgf", pytest.approx(2.4))
    assert b.best["oracle"] == ("gaussian:own", pytest.approx(1.0))  # a bound, not the challenger
    assert b.challenger == "temporal" and b.ratio == pytest.approx(2.0 / 3.0)
    text = "\n".join(dr._best_markdown(items))
    assert "oracle (bound)" in text and "direct, 4 spp: goal at most 0.7 of white's: met" in text
    worse = dr.best_denoisers(_rows(_records({"gaussian"}, scene="medium")))
    assert worse[0].ratio == pytest.approx(2.0 / 3.5)  # gaussian:own is in every set
    medium = _records({"gaussian"}, own=False, scene="medium")  # bnds and temporal tie at 3
    goal = "\n".join(dr._goal_lines(dr.best_denoisers(_rows(medium))))
    assert goal == "- medium, 4 spp: goal at most 0.7 of white's: not met (bnds at 0.75).\n"


def test_unet_gains_and_whites_paired_ratio():
    records = _records()
    items = {u.strategy: u for u in dr.unet_gains(_rows(records), records)}
    assert list(items) == ["bnds", "temporal"]
    t = items["temporal"]
    assert t.unet[0] == pytest.approx(0.9) and t.unet[1] <= 0.9 <= t.unet[2]
    assert t.unet_blue[0] == pytest.approx(0.7)
    assert (t.gain_unet, t.gain_blue, t.gain_ratio) == pytest.approx((0.1, 0.3, 3.0))
    # white's two records hold the same frames: the pairing leaves no spread around 0.9
    want = paired_ratio(
        [[[v * 256, 256] for v in row] for row in _DEN["white"]["unet_blue"]],
        [[[v * 256, 256] for v in row] for row in _WHITE_UNET],
    )
    assert t.white == pytest.approx((want.value, want.lo, want.hi))
    assert t.white == pytest.approx((0.9, 0.9, 0.9))
    assert items["bnds"].gain_unet == pytest.approx(0.0) and items["bnds"].gain_ratio is None
    assert "direct: goal" in dr._unet_goal(list(items.values()), "direct")
    assert ": met (gain 0.10 after unet, 0.30 after unet_blue" in dr._unet_goal([t], "direct")


def test_file_holds_each_section_only_with_its_denoisers(tmp_path):
    records = _records()
    assert dr.write_denoise_tables(tmp_path, records, _rows(records))
    text = (tmp_path / dr.DENOISERS_MD).read_text()
    for title in ("Temporal accumulation", "OIDN on blue-noise", "best denoiser", "U-Net trained"):
        assert title in text
    assert "1.50 [1.50, 1.50]" in text and "- direct, 4 spp, temporal: loses under" in text
    assert "Left out, raw MSE different from white's (raw ratio): direct 4 spp zsobol 0.80" in text
    only_oidn = _records({"gaussian", "oidn"}, own=False)
    text = dr.denoise_markdown(only_oidn, _rows(only_oidn))
    assert "OIDN on blue-noise" in text
    assert not any(t in text for t in ("Temporal accumulation", "best denoiser", "U-Net trained"))
    no_tcorr = [_record("white", "taa", 5.0), _record("temporal", "taa", 4.0)]
    text = dr.denoise_markdown(no_tcorr, _rows(no_tcorr))
    assert "| 4 | temporal | - | 0.80 [0.80, 0.80] | - | - | - | 0.80 |  |" in text


def test_nothing_is_written_without_the_sections_denoisers(tmp_path):
    plain = _records({"gaussian", "unet"}, own=False)
    assert dr.denoise_markdown(plain, _rows(plain)) == ""
    assert not dr.write_denoise_tables(tmp_path, plain, _rows(plain))
    assert not list(tmp_path.iterdir())


def test_the_report_writes_it(tmp_path):
    records = _records({"gaussian", "oidn"}, own=False)
    write_report(tmp_path, records, charts=False)
    assert "OIDN on blue-noise" in (tmp_path / dr.DENOISERS_MD).read_text()
