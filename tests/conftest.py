"""Shared pytest configuration: deterministic hypothesis, bounded torch threads."""

import os

import pytest
import torch
from hypothesis import HealthCheck, settings

# Property tests draw their examples from a fixed seed: the same run every time, never
# "flaky until green" (the project's testing standard).
settings.register_profile(
    "bnerr",
    derandomize=True,
    deadline=None,
    max_examples=int(os.environ.get("BNERR_HYPOTHESIS_EXAMPLES", "60")),
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile("bnerr")

# Under pytest-xdist each worker gets its share of the cores (two workers on two cores: one torch
# thread each), so that workers do not oversubscribe the machine and stall on OpenMP barriers.
_WORKERS = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
torch.set_num_threads(max(1, min(2, (os.cpu_count() or 1) // _WORKERS)))


@pytest.fixture(scope="module")
def one_thread():
    """Run a module on one torch thread (``pytestmark = pytest.mark.usefixtures("one_thread")``).

    On a shared 2-core machine OpenMP's barriers stall whenever one of two threads is descheduled
    (measured here: tests/benchmarks/sweep/test_ordering.py's renders took 407 s on 2 threads under
    load, 32 s on 1), and tiny networks are faster on one thread anyway. Renders are bit-identical
    either way.
    """
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


@pytest.fixture
def forget():
    """Unregister the plug-ins a test registered (the registries are process-wide): the test
    appends ``(group, name)`` of each."""
    import denoisers
    import renderers
    from bnerr import plugins, sequences, strategies
    from bnerr.metrics import METRIC_TABLE

    names: list[tuple[str, str]] = []
    yield names
    for group, name in names:
        registry = {
            "bnerr.strategies": None,
            "bnerr.denoisers": denoisers.DENOISERS,
            "bnerr.scenes": renderers.SCENES,
            "bnerr.samplers": sequences.SAMPLERS,
            "bnerr.metrics": METRIC_TABLE,
        }[group]
        if registry is None:
            strategies.REGISTRY.remove(name)
        else:
            dict.pop(registry, name, None)
        plugins._LOADED.pop((group, name), None)
