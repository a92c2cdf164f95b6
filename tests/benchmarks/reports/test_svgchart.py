"""Tests of benchmarks.reports.svgchart: the hoverable error-against-time chart."""

import re
import xml.etree.ElementTree as ET

from benchmarks.reports.palette import strategy_color
from benchmarks.reports.svgchart import legend_html, ratio_svg


def _row(strategy, spp, ratio, ms, denoiser="oidn"):
    return {
        "strategy": strategy, "spp": spp, "denoiser": denoiser, "den_mse_ratio": ratio,
        "den_mse_ratio_lo": ratio - 0.05, "den_mse_ratio_hi": ratio + 0.05, "total_ms": ms,
    }  # fmt: skip


def test_each_point_has_a_title_with_strategy_spp_ratio_and_interval():
    rows = [_row("white", 1, 1.0, 10), _row("temporal", 1, 0.8, 12), _row("temporal", 4, 0.9, 40)]
    svg = ratio_svg(rows, "oidn")
    root = ET.fromstring(svg)  # well-formed
    titles = [t.text for t in root.iter("{http://www.w3.org/2000/svg}title")]
    assert "temporal, 4 spp: 0.900 [0.850, 0.950] of white, 40 ms" in titles
    assert len(titles) == 3
    assert strategy_color("temporal") in svg


def test_no_points_no_chart():
    assert ratio_svg([_row("white", 1, 1.0, 10)], "taa") == ""
    assert ratio_svg([{**_row("white", 1, 1.0, 10), "den_mse_ratio": None}], "oidn") == ""


def test_legend_lists_strategies_in_table_order():
    html = legend_html({"oracle", "white", "temporal"})
    assert re.findall(r"</i>([a-z]+)</span>", html) == ["white", "temporal", "oracle"]
