"""bnerr.views: a mapping read afresh from its registry on every access."""

from __future__ import annotations

import pytest

from bnerr.views import LiveMapping


def test_a_live_mapping_sees_what_was_registered_after_it_was_made():
    registry = {"a": 1}
    view = LiveMapping(lambda: dict(registry))
    registry["b"] = 2
    assert dict(view) == {"a": 1, "b": 2} and len(view) == 2 and view["b"] == 2
    assert repr(view) == repr({"a": 1, "b": 2})
    with pytest.raises(KeyError):
        view["c"]
