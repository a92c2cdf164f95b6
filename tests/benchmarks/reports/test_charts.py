"""Tests of benchmarks.reports.charts: the ratio charts, the oracle-share chart, and that no text
overlaps text or data (bounding boxes measured with matplotlib's renderer)."""

import itertools

import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from benchmarks.reports.charts import (
    error_vs_time_figure,
    key_denoisers,
    oracle_share_figure,
    share_slug,
    write_charts,
)
from benchmarks.reports.gap import GapShare
from bnerr import plugins

_STRATEGIES = ("white", "bnds", "zsobol", "temporal", "temporal+relative+demod+groups", "oracle")
_DENOISERS = ("gaussian:own", "atrous:own", "unet_blue", "oidn", "taa", "median", "bilateral")


def _rows():
    rows = []
    for i, (s, d, spp) in enumerate(itertools.product(_STRATEGIES, _DENOISERS, (1, 2, 4, 8, 16))):
        ratio = 1.0 if s == "white" else 0.7 + 0.05 * (i % 7)
        rows.append(
            {
                "scene": "snooker", "motion": 1, "depth": None, "region": "all",
                "sampler": "owen_sobol", "strategy": s, "denoiser": d, "spp": spp,
                "den_mse_ratio": ratio, "den_mse_ratio_lo": ratio * 0.95,
                "den_mse_ratio_hi": ratio * 1.05, "total_ms": 3.0 * spp * (1 + 0.1 * (i % 3)),
            }
        )  # fmt: skip
    return rows


def _shares():
    return [
        GapShare("snooker", spp, "m1 all owen_sobol", m, s, 0.5, 0.3, 0.7, 0.2, 0.95)
        for spp in (1, 2, 4, 8)
        for m in ("raw mse_blur1", "gaussian mse", "oidn mse", "median mse")
        for s in _STRATEGIES[1:-1]
    ]


def _drawn_tick_labels(ax):
    """The tick labels drawn: those of ticks inside the view limits."""
    labels = []
    for axis, (lo, hi) in ((ax.xaxis, ax.get_xlim()), (ax.yaxis, ax.get_ylim())):
        lo, hi = min(lo, hi), max(lo, hi)
        for tick in axis.get_major_ticks() + axis.get_minor_ticks():
            if lo <= tick.get_loc() <= hi:
                labels.append(tick.label1)
    return labels


def _boxes(fig, renderer):
    """(kind, bbox) of every drawn text and legend, and the data areas, in display pixels."""
    texts = [("suptitle", fig._suptitle)] if fig._suptitle else []
    for n, ax in enumerate(fig.axes):
        texts += [(f"title{n}", ax.title), (f"xlabel{n}", ax.xaxis.label)]
        texts += [(f"ylabel{n}", ax.yaxis.label)]
        texts += [(f"tick{n}", t) for t in _drawn_tick_labels(ax)]
    boxes = [
        (kind, t.get_window_extent(renderer))
        for kind, t in texts
        if t.get_visible() and t.get_text() and t.get_window_extent(renderer).width > 0
    ]
    boxes += [("legend", leg.get_window_extent(renderer)) for leg in fig.legends]
    data = [(f"axes{n}", ax.get_window_extent(renderer)) for n, ax in enumerate(fig.axes)]
    return boxes, data


def _overlaps(fig):
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    boxes, data = _boxes(fig, canvas.get_renderer())
    found = []
    for (k1, b1), (k2, b2) in itertools.combinations(boxes, 2):
        if b1.overlaps(b2) and not (k1.startswith("tick") and k1 == k2 and b1 == b2):
            found.append((k1, k2))
    for (k1, b1), (k2, b2) in itertools.product(boxes, data):
        if not k1.startswith(("tick",)) and b1.overlaps(b2):
            found.append((k1, k2))
    return found


def test_key_denoisers_pick_the_tuned_names_first_and_fall_back_to_all():
    assert key_denoisers(["gaussian", "gaussian:own", "oidn", "median"]) == ["gaussian:own", "oidn"]
    assert key_denoisers(["median", "box"]) == ["box", "median"]


def test_error_vs_time_has_one_panel_per_denoiser_and_no_text_overlap():
    fig = error_vs_time_figure("snooker", _rows(), key_denoisers(_DENOISERS))
    assert [ax.get_title() for ax in fig.axes] == list(_DENOISERS[:5])
    assert len(fig.legends) == 1 and len(fig.legends[0].get_texts()) == len(_STRATEGIES)
    assert _overlaps(fig) == []


def test_oracle_share_chart_has_no_text_overlap():
    fig = oracle_share_figure("snooker", _shares())
    assert [ax.get_title() for ax in fig.axes] == ["raw mse_blur1", "gaussian mse", "oidn mse"]
    assert _overlaps(fig) == []


def test_the_overlap_check_finds_an_overlap():
    fig = error_vs_time_figure("snooker", _rows(), ["oidn"])
    fig.axes[0].set_title("x" * 20, y=0.5)  # a title over the data
    assert _overlaps(fig)


@pytest.mark.parametrize(
    ("condition", "slug"),
    [("m1 all owen_sobol", "snooker"), ("m0 d3 all sobol", "snooker_m0_d3_sobol")],
)
def test_share_slug_names_the_group(condition, slug):
    share = GapShare("snooker", 1, condition, "raw mse_blur1", "bnds", 0.5, 0.3, 0.7, 0.2, 0.95)
    assert share_slug(share) == slug


def test_write_charts_splits_key_and_other_denoisers(tmp_path):
    written = write_charts(_rows(), [], tmp_path, _shares())
    names = sorted(p.name for p in written)
    assert names == [
        "error_vs_time_snooker.png", "error_vs_time_snooker_other.png", "oracle_share_snooker.png"
    ]  # fmt: skip
    key_only = [r for r in _rows() if r["denoiser"] in _DENOISERS[:5]]
    write_charts(key_only, [], tmp_path)
    assert not (tmp_path / "error_vs_time_snooker_other.png").exists()  # a stale one is removed


def test_a_plugin_denoiser_is_a_key_denoiser(forget):
    forget.append(("bnerr.denoisers", "mine"))
    plugins.record("bnerr.denoisers", "mine", plugins.Plugin("mine.py:mine", object()))
    assert key_denoisers(["gaussian", "median", "mine"]) == ["gaussian", "mine"]
    assert key_denoisers(["median", "mine:own"]) == ["mine:own"]
