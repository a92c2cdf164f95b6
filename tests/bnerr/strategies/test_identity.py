"""bnerr.strategies.identity: a strategy's identity read by name alone."""

from __future__ import annotations

import pytest

from bnerr.errors import UnknownNameError
from bnerr.strategies import identity
from bnerr.strategies.identity import OTHER_FAMILY, baseline, bounds, strategy_identity
from bnerr.strategies.registry import REGISTRY


def test_a_registered_strategy_is_its_class():
    cls = REGISTRY.classes()["vertical"]
    found = strategy_identity("vertical")
    assert (found.family, found.rank, found.bound, found.registered) == (
        "bound",
        cls.rank,
        True,
        True,
    )
    assert strategy_identity("white").family == "baseline" and strategy_identity("white").color


def test_a_variant_takes_its_bases_identity_but_not_its_colour():
    base, variant = strategy_identity("temporal"), strategy_identity("temporal+relative+demod")
    assert (variant.family, variant.rank, variant.raw_mse_note) == (
        base.family,
        base.rank,
        base.raw_mse_note,
    )
    assert variant.color is None and not variant.registered


def test_an_unknown_name_is_neutral_and_ranked_after_every_registered_one():
    found = strategy_identity("retired_method")
    last = max(c.rank for c in REGISTRY.classes().values())
    assert (found.family, found.rank, found.bound) == (OTHER_FAMILY, last + 1, False)


def test_the_baseline_is_white_and_the_bounds_are_ordered_by_rank():
    assert baseline() == "white"
    assert bounds()[0] == "oracle" and set(bounds()) >= {"oracle", "vertical"}


def test_no_baseline_or_two_baselines_is_a_typed_error(monkeypatch):
    classes = dict(REGISTRY.classes())
    monkeypatch.setattr(
        REGISTRY, "classes", lambda: {k: v for k, v in classes.items() if k != "white"}
    )
    with pytest.raises(UnknownNameError, match="got none"):
        identity.baseline()
