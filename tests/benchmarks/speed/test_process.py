"""benchmarks.speed.process's ``measure()`` for real, and the compiled tracer's real default path
that it times (renderers.aot): the package built by ``python -m renderers.aot`` (what ``bnerr
render`` starts in the background), loaded by the default choice of a large ``bnerr render``,
and called through ctypes (:class:`renderers.aot.AotStep`).

Building the package takes about a minute of CPU, so this file builds one, for the cheapest
layout (``direct``, static), once, into a temporary ``BNERR_CACHE_DIR`` and
``TORCHINDUCTOR_CACHE_DIR``: nothing is written outside the test's temporary folders.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import torch

from benchmarks.commands.render import AUTO_COMPILE_PATHS
from benchmarks.speed import process
from bnerr.sequences import make_sampler
from renderers import aot, get_scene, render
from renderers.geometry import scene_tensors
from tests._processes import bnerr_command, child_env

pytestmark = [pytest.mark.slow, pytest.mark.usefixtures("one_thread")]


@pytest.fixture(scope="module")
def package(tmp_path_factory) -> Path:
    """The package of the static ``direct`` layout, built by the module entry point into
    temporary caches that this module's processes (and this one) use."""
    root = tmp_path_factory.mktemp("caches")
    with pytest.MonkeyPatch.context() as env:
        env.setenv("BNERR_CACHE_DIR", str(root / "bnerr"))
        env.setenv("TORCHINDUCTOR_CACHE_DIR", str(root / "inductor"))
        env.setenv("BNERR_BACKGROUND_BUILD", "0")
        env.setenv("PYTHONPATH", child_env()["PYTHONPATH"])
        assert not aot.has_package("direct", static=True)
        cmd = [sys.executable, "-m", "renderers.aot", "direct", "--static"]
        done = subprocess.run(cmd, cwd=root, capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr
        built = Path(done.stdout.strip())
        st = scene_tensors(get_scene("direct", animated=False), 0, torch.device("cpu"))
        assert built == aot.package_path(st) and built.parent == root / "bnerr" / "aot"
        assert aot.has_package("direct", static=True)
        yield built


def test_the_package_renders_what_the_eager_tracer_renders_and_the_same_twice(package):
    scene = get_scene("direct", animated=False)
    seeds = torch.arange(16 * 16, dtype=torch.int64).reshape(16, 16)
    white = make_sampler("white")
    step = aot.load(scene_tensors(scene, 0, torch.device("cpu")))
    assert isinstance(step, aot.AotStep)
    first = render(scene, 0, seeds, white, 4, compile=aot.stage).color
    again = render(scene, 0, seeds, white, 4, compile=aot.stage).color
    eager = render(scene, 0, seeds, white, 4, compile=False).color
    assert torch.equal(first, again)  # deterministic across calls
    # the fused kernels may round differently in the last bits, never more
    torch.testing.assert_close(first, eager, rtol=1e-4, atol=1e-5)


def test_a_large_render_runs_the_cached_package_by_default(package, tmp_path):
    # 512 x 512 x 8 spp: the smallest render the default choice runs compiled.
    assert 512 * 512 * 8 == AUTO_COMPILE_PATHS
    args = ["render", "--scene", "direct", "--static", "--res", "512x512", "--spp", "8"]
    done = subprocess.run(
        [*bnerr_command(), *args, "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert "512x512 8 spp" in done.stdout and "compiled)" in done.stdout, done.stdout
    assert "background" not in done.stdout  # the package was there: nothing to build
    assert (tmp_path / "direct_0000.exr").is_file()


def test_measure_times_each_process_and_the_build_it_found_cached(package):
    figures = process.measure("direct", width=16, height=16, spp=1, repeats=1)
    settings = figures["settings"]
    assert (settings["scene"], settings["res"], settings["spp"]) == ("direct", "16x16", 1)
    assert isinstance(settings["package_build"], float)  # the cached package: a quick exit
    rows = figures["processes"]
    assert set(rows) == {"cold", "warm", "eager", "mitsuba_llvm"}
    for name in ("cold", "warm", "eager"):
        assert rows[name]["runs"] == 1 and rows[name]["best_s"] > 0, rows[name]
    anchor = rows["mitsuba_llvm"]
    assert "best_s" in anchor or anchor["error"], anchor  # Mitsuba and LLVM, or why not
    if "best_s" in anchor:
        assert rows["warm"]["ratio_to_mitsuba"] > 0
    assert "| warm |" in "\n".join(process.table(figures, {}))
