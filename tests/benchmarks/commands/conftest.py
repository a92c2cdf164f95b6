"""Fixtures shared by the command tests."""

import pytest

from tests._native import build_native


@pytest.fixture(scope="session")
def native_example(tmp_path_factory):
    """A folder holding examples/native/ with the tracer built and the LDBN keys exported, as
    the doc pages' first lines do (shared by the seed-protocol and the eval tests)."""
    return build_native(tmp_path_factory.mktemp("native"))
