"""Tests of benchmarks.reports.palette: one colour per strategy, families kept together."""

import colorsys
import re

import pytest

from benchmarks.reports.palette import family, family_hue, strategy_color, strategy_style
from bnerr.strategies import STRATEGIES


def _hue(color: str) -> float:
    r, g, b = (int(color[i : i + 2], 16) / 255 for i in (1, 3, 5))
    return colorsys.rgb_to_hls(r, g, b)[0]


def test_every_strategy_gets_a_stable_colour():
    names = [*STRATEGIES.classes(), "temporal+demod", "temporal+fast", "bnds_x", "ldbn_new"]
    colours = [strategy_color(n) for n in names]
    assert all(re.fullmatch(r"#[0-9a-f]{6}", c) for c in colours)
    assert colours == [strategy_color(n) for n in names]  # the same on every call
    assert len(set(colours)) == len(colours)  # no two strategies share one


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("white", "baseline"),
        ("oracle", "bound"),
        ("vertical", "bound"),
        ("bnds_x", "other"),
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


def test_a_strategy_keeps_its_class_colour_and_a_variant_gets_its_own_shade():
    assert strategy_color("temporal") == STRATEGIES["temporal"].color == "#d62728"
    assert strategy_color("temporal+demod") != strategy_color("temporal")
    assert strategy_color("vertical") != strategy_color("oracle")  # both bounds, told apart


def test_a_new_family_gets_a_stable_hue_of_its_own():
    hue, saturation = family_hue("my_family")
    assert (hue, saturation) == family_hue("my_family") and saturation > 0
    assert family_hue("my_family") != family_hue("their_family")


def test_bounds_are_dashed_and_the_baseline_dotted():
    assert strategy_style("oracle")["linestyle"] == "--"
    assert strategy_style("vertical")["linestyle"] == "--"
    assert strategy_style("white")["linestyle"] == ":"
    assert strategy_style("temporal")["linestyle"] == "-"
