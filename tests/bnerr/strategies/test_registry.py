"""bnerr.strategies.registry: a plug-in strategy that subclasses a shipped one gets its own
identity where it declares none (issue 54, item 8): subclassing ``WhiteStrategy`` without a
``family`` made the bench fail with "expected exactly one registered strategy of family
'baseline'", and a new family inherited white's rank 0 and was listed before white."""

from __future__ import annotations

import textwrap

import pytest

from bnerr import strategies
from bnerr.errors import UnknownNameError
from bnerr.strategies.identity import baseline, strategy_identity

PLUGIN = """
from bnerr.strategies import WhiteStrategy, TemporalStrategy


class Bare(WhiteStrategy):  # declares nothing of its identity
    name = "reg_bare"
    stream = 0x51A7E101


class Family(WhiteStrategy):  # a new family, no rank
    name = "reg_family"
    family = "mine"
    stream = 0x51A7E102


class Declared(TemporalStrategy):  # everything declared: kept
    name = "reg_declared"
    family = "temporal"
    rank = 55
    raw_mse_note = "its own note"
    stream = 0x51A7E103


class Base(WhiteStrategy):  # the plug-in's own base carries the identity
    family = "mine"
    rank = 2000


class Child(Base):
    name = "reg_child"
    stream = 0x51A7E104
"""

SECOND = """
from bnerr.strategies import WhiteStrategy


class Second(WhiteStrategy):  # a plug-in that means to be the baseline
    name = "reg_second"
    family = "baseline"
    stream = 0x51A7E105
"""


@pytest.fixture
def plugin(tmp_path, forget):
    path = tmp_path / "regplug.py"
    path.write_text(textwrap.dedent(PLUGIN))
    forget.extend(
        ("bnerr.strategies", n)
        for n in ("reg_bare", "reg_family", "reg_declared", "reg_child", "reg_second")
    )
    return path


def test_a_subclass_of_a_shipped_strategy_gets_its_own_identity(plugin):
    white = strategy_identity("white")
    for cls in ("Bare", "Family", "Declared", "Child"):
        strategies.REGISTRY.load(f"{plugin}:{cls}")
    bare = strategy_identity("reg_bare")
    assert (bare.family, bare.rank, bare.raw_mse_note) == ("other", 1000, "")
    family = strategy_identity("reg_family")
    assert family.family == "mine" and family.rank > white.rank  # listed after white
    declared = strategy_identity("reg_declared")
    assert (declared.family, declared.rank, declared.raw_mse_note) == (
        "temporal",
        55,
        "its own note",
    )
    child = strategy_identity("reg_child")
    assert (child.family, child.rank) == ("mine", 2000)
    assert baseline() == "white"  # no plug-in above made a second baseline
    assert strategies.WhiteStrategy.family == "baseline"  # the shipped class is untouched


def test_a_second_baseline_is_refused_naming_the_plug_in(plugin):
    second = plugin.with_name("second.py")
    second.write_text(textwrap.dedent(SECOND))
    strategies.REGISTRY.load(f"{second}:Second")
    with pytest.raises(UnknownNameError) as caught:
        baseline()
    message = str(caught.value)
    assert "white (bnerr.strategies.white.WhiteStrategy)" in message
    assert "reg_second (plug-in '" in message and "second.py:Second" in message
    assert "\n" not in message
