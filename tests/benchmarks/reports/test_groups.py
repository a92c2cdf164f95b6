"""Tests of benchmarks.reports.groups: group keys, titles, file-name slugs and the strategy
order."""

from benchmarks.reports.groups import (
    group_key,
    group_order,
    group_slug,
    group_title,
    strategy_order,
)
from bnerr.strategies import STRATEGIES


def _row(**condition):
    row = dict(scene="snooker", motion=1, depth=None, region="all", sampler="owen_sobol")
    return {**row, **condition, "strategy": "white", "spp": 4}


def test_the_default_condition_is_the_bare_scene():
    key = group_key(_row())
    assert key == ("snooker", 1, None, "all", "owen_sobol")
    assert group_title(key) == "snooker" and group_slug(key) == "snooker"


def test_a_non_default_condition_is_named_in_title_and_slug():
    key = group_key(_row(motion=8, depth=5, region="edges", sampler="white"))
    assert group_title(key) == (
        "snooker (motion x8, max depth 5, object edges only, white sequences)"
    )
    assert group_slug(key) == "snooker_m8_d5_edges_white"
    assert group_title(group_key(_row(motion=0))) == "snooker (static camera)"
    coherent = group_key(_row(region="coherent"))
    assert group_title(coherent) == "snooker (coherent regions only)"
    assert group_slug(coherent) == "snooker_coherent"
    unlit = group_key(_row(region="unlit"))
    assert group_title(unlit) == "snooker (away from visible lights)"
    assert group_slug(unlit) == "snooker_unlit"


def test_groups_sort_by_scene_then_condition_with_the_scenes_own_depth_first():
    keys = [group_key(_row(depth=d)) for d in (5, None, 3)]
    assert [k[2] for k in sorted(keys, key=group_order)] == [None, 3, 5]


def test_strategies_follow_the_table_order_and_unlisted_names_come_last():
    names = ["temporal+groups", "oracle", "white", "temporal", "white", "temporal+demod"]
    assert strategy_order(names) == [
        "white", "temporal", "oracle", "temporal+demod", "temporal+groups",
    ]  # fmt: skip
    # the registered classes by rank: temporal_ldbn among LDBN's, the shipped key sets over
    # other bases (ldbn_zorder) beside ldbn128, vertical with the bounds
    assert strategy_order(STRATEGIES.classes()) == [
        "white", "bnds", "bnds_st", "zsobol", "openqmc_sobolbn", "openqmc_latticebn",
        "cycles_blue", "zsobol_t", "ldbn", "ldbn128", "ldbn_zorder", "ldbn_st", "ldbn_fast",
        "ldbn_atrous",
        "temporal_ldbn", "temporal_sort", "temporal", "temporal_zsobol", "oracle", "vertical",
    ]  # fmt: skip
