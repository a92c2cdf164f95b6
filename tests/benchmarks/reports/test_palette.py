"""Tests of benchmarks.reports.palette: one colour per strategy, families kept together."""

import colorsys
import re

import pytest

from benchmarks.reports.palette import FIXED, family, strategy_color, strategy_style


def _hue(color: str) -> float:
    r, g, b = (int(color[i : i + 2], 16) / 255 for i in (1, 3, 5))
    return colorsys.rgb_to_hls(r, g, b)[0]


def test_every_strategy_gets_a_stable_colour():
    names = [*FIXED, "temporal+demod", "temporal+fast", "bnds_x", "ldbn_new"]
    colours = [strategy_color(n) for n in names]
    assert all(re.fullmatch(r"#[0-9a-f]{6}", c) for c in colours)
    assert colours == [strategy_color(n) for n in names]  # the same on every call
    assert len(set(colours)) == len(colours)  # no two strategies share one


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("white", "baseline"),
        ("oracle", "bound"),
        ("bnds", "rival"),
        ("zsobol_t", "rival"),
        ("temporal+relative+demod+groups", "temporal"),
        ("ldbn_fast", "ldbn"),
        ("temporal_ldbn", "ldbn"),
    ],
)
def test_family_of_a_name(name, expected):
    assert family(name) == expected


def test_a_new_temporal_variant_stays_in_the_temporal_hue():
    hue = _hue(strategy_color("temporal+something_new"))
    assert min(abs(hue - 0.06), 1 - abs(hue - 0.06)) < 0.06


def test_bounds_are_dashed_and_the_baseline_dotted():
    assert strategy_style("oracle")["linestyle"] == "--"
    assert strategy_style("white")["linestyle"] == ":"
    assert strategy_style("temporal")["linestyle"] == "-"
