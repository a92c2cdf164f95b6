"""Shared pytest configuration: deterministic hypothesis, bounded torch threads, and a check that
no test or fixture writes into the checkout (outside its temporary folders)."""

import os
from pathlib import Path

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


#: The test files that take longest, longest first (seconds of wall time in a full run on the
#: 2-core machine, measured with a per-test log on 2026-12-04), which run before every other file.
#: ``make test`` hands whole files to two workers in collection order (``--dist loadfile
#: --no-loadscope-reorder``; xdist's own reorder puts the files with most tests first), so a long
#: file handed out last keeps one worker busy while the other idles: 50 s of a fresh clone's 476.
#: A file missing here only runs in its usual place.
LONGEST_FIRST = (
    "tests/benchmarks/sweep/test_ordering.py",  # 104 s
    "tests/benchmarks/test_cli_installed.py",  # 76
    "tests/benchmarks/reports/test_table_committed.py",  # 76
    "tests/benchmarks/speed/test_process.py",  # 72
    "tests/benchmarks/sweep/test_ray_runner.py",  # 57 (mostly waiting for Ray)
    "tests/benchmarks/sweep/test_ordering_variants.py",  # 50
    "tests/benchmarks/commands/test_bench_external.py",  # 39
    "tests/benchmarks/sweep/test_ordering_coherent.py",  # 35
    "tests/benchmarks/commands/test_bench_renderer.py",  # 35
    "tests/benchmarks/commands/test_bench_cycles.py",  # 35 (Blender renders, where bpy is)
    "tests/benchmarks/commands/test_bench_docs.py",  # 26
    "tests/benchmarks/sweep/test_external_renderer.py",  # 22
    "tests/denoisers/test_external.py",  # 20
    "tests/benchmarks/test_cli.py",  # 19
    "tests/denoisers/test_unet.py",  # 17
    "tests/benchmarks/sweep/test_runner_faults.py",  # 16
)


def pytest_collection_modifyitems(items):
    """The files of :data:`LONGEST_FIRST` first, in its order; every other test after them in
    collection order (a stable sort: the tests of a file keep theirs)."""
    rank = {path: i for i, path in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.nodeid.split("::", 1)[0], len(rank)))


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


# -- No test writes into the checkout ------------------------------------------------------------

_ROOT = Path(__file__).resolve().parents[1]
#: Folders of tools, not tests: git, caches of Python, pytest, hypothesis, mypy and ruff.
_NOT_CHECKED = {
    ".git",
    ".venv",
    "__pycache__",
    ".pytest_cache",
    ".hypothesis",
    ".mypy_cache",
    ".ruff_cache",
}


_BEFORE = pytest.StashKey[dict]()


def checkout_files(root: Path = _ROOT) -> dict[str, int]:
    """Every file of the checkout (tools' folders aside) -> its modification time in ns: about a
    thousand ``stat`` calls, milliseconds."""
    found = {}
    for folder, dirs, files in os.walk(root):
        dirs[:] = [d for d in dirs if d not in _NOT_CHECKED and not d.endswith(".egg-info")]
        for name in files:
            path = os.path.join(folder, name)
            try:
                found[os.path.relpath(path, root)] = os.stat(path).st_mtime_ns
            except OSError:  # removed while walking
                continue
    return found


def checkout_changes(before: dict[str, int], after: dict[str, int]) -> list[str]:
    """The files written, created or removed between two :func:`checkout_files`."""
    written = [f"{p} (written)" for p in after if p in before and after[p] != before[p]]
    created = [f"{p} (created)" for p in after if p not in before]
    removed = [f"{p} (removed)" for p in before if p not in after]
    return sorted(written + created + removed)


def pytest_sessionstart(session):
    session.config.stash[_BEFORE] = checkout_files()


def pytest_sessionfinish(session, exitstatus):
    """Fail the session if the checkout changed while it ran: a test or fixture wrote outside its
    temporary folder (``tmp_path``), e.g. a command run from the repository root without
    ``--out``. ``BNERR_ALLOW_CHECKOUT_WRITES=1`` skips the check (editing files while tests run)."""
    before = session.config.stash.get(_BEFORE, None)
    if before is None or os.environ.get("BNERR_ALLOW_CHECKOUT_WRITES") == "1":
        return
    changes = checkout_changes(before, checkout_files())
    if changes:
        shown = ", ".join(changes[:10]) + (f" and {len(changes) - 10} more" if changes[10:] else "")
        reporter = session.config.pluginmanager.get_plugin("terminalreporter")
        line = (
            "tests wrote into the checkout, outside their temporary folders: "
            f"{shown} (set BNERR_ALLOW_CHECKOUT_WRITES=1 if you edited files meanwhile)"
        )
        if reporter is not None:
            reporter.ensure_newline()
            reporter.write_line(line, red=True)
        session.exitstatus = pytest.ExitCode.TESTS_FAILED
