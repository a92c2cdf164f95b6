"""Tests for ``bnerr render`` (benchmarks.commands.render)."""

import pytest
import torch

from benchmarks.cli import main
from bnerr.io import read_frame

pytestmark = pytest.mark.usefixtures("one_thread")


def test_writes_one_exr_and_png_per_frame(tmp_path, capsys):
    code = main(
        [
            "render",
            "--scene",
            "snooker",
            "--res",
            "12x8",
            "--spp",
            "2",
            "--frames",
            "2",
            "--start",
            "3",
            "--sampler",
            "owen_sobol",
            "--out",
            str(tmp_path),
        ]
    )
    assert code == 0
    names = sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith("."))
    assert names == ["snooker_0003.exr", "snooker_0003.png", "snooker_0004.exr", "snooker_0004.png"]
    frame = read_frame(tmp_path / "snooker_0004.exr")
    assert frame.color.shape == (3, 8, 12)
    for name in ("albedo", "normal", "depth", "motion", "object_id", "variance"):
        assert getattr(frame, name) is not None, name
    assert frame.timings["render"] > 0
    assert "M samples/s" in capsys.readouterr().out
    a, b = read_frame(tmp_path / "snooker_0003.exr"), frame
    assert not torch.equal(a.color, b.color)  # every frame has its own seeds


def test_static_frames_do_not_move(tmp_path):
    assert (
        main(
            [
                "render",
                "--scene",
                "direct",
                "--res",
                "8x8",
                "--spp",
                "1",
                "--frames",
                "2",
                "--static",
                "--out",
                str(tmp_path),
            ]
        )
        == 0
    )
    assert read_frame(tmp_path / "direct_0001.exr").motion.abs().max() < 1e-3


def test_bad_arguments_are_reported(tmp_path, capsys):
    assert main(["render", "--scene", "teapot", "--out", str(tmp_path)]) == 2
    assert "unknown scene 'teapot'" in capsys.readouterr().err
    assert main(["render", "--scene", "direct", "--res", "0x4", "--out", str(tmp_path)]) == 2
    assert "--res: expected width and height >= 1, got 0x4" in capsys.readouterr().err
    assert main(["render", "--scene", "direct", "--spp", "-1", "--out", str(tmp_path)]) == 2
    assert "--spp: expected an integer >= 1, got -1" in capsys.readouterr().err


# -- issue 18: sizes and output paths checked before any work; one writer --------------------------


def test_an_absurd_resolution_is_refused_before_allocating(tmp_path, capsys, monkeypatch):
    import benchmarks.commands.render as command

    monkeypatch.setattr(command, "render", lambda *a, **k: pytest.fail("rendered"))
    args = ["render", "--scene", "direct", "--res", "40000x40000", "--out", str(tmp_path / "o")]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "--res 40000x40000: expected a size that fits in memory" in err
    assert "GiB available), got an estimate of" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("out", "message"),
    [
        ("file", "expected a folder, got an existing file"),
        ("file/sub", "an existing file"),
        ("/proc/bnerr-render", "expected a folder that can be created"),
        ("/proc/self", "expected a writable folder"),
    ],
)
def test_bad_output_folders_fail_before_rendering_in_one_line(tmp_path, capsys, out, message):
    (tmp_path / "file").write_text("x")
    path = out if out.startswith("/") else str(tmp_path / out)
    assert main(["render", "--scene", "direct", "--res", "4x4", "--out", path]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err


def test_a_second_render_into_the_same_folder_refuses(tmp_path, capsys):
    from bnerr.outputs import output_lock

    with output_lock(tmp_path, "bnerr render"):
        args = ["render", "--scene", "direct", "--res", "4x4", "--spp", "1", "--out", str(tmp_path)]
        assert main(args) == 2
    assert "another bnerr render holds its lock" in capsys.readouterr().err
    assert not list(tmp_path.glob("*.exr"))


def _benchmark_frames(strategy, seed_set, frames, warmup=0, res=(16, 12), spp=1):
    """The frames ``bnerr bench`` renders for one seed set: t -> Frame, captured from the strategy
    the runner builds (:func:`benchmarks.sweep.measure.measure_seed_set`)."""
    import dataclasses

    from benchmarks.suites import Suite, Sweep
    from benchmarks.sweep.measure import measure_seed_set
    from benchmarks.sweep.parts import real_parts
    from benchmarks.sweep.plan import plan

    base, seen = real_parts(), {}

    class _Capturing:
        def __init__(self, inner):
            self.inner = inner
            self.overhead_ms, self.stateful = inner.overhead_ms, inner.stateful
            self.sampler_name = inner.sampler_name

        def frame(self, t, render):
            seen[t] = self.inner.frame(t, render)
            return seen[t]

    def make_strategy(*args):
        return _Capturing(base.make_strategy(*args))

    class _NoReference:  # measuring is not the point: compare each frame with itself
        def get(self, run, scene, t):
            return seen[t]

    sweep = Sweep(scenes=("direct",), strategies=(strategy,), spp=(spp,), denoisers=("gaussian",),
                  frames=frames, warmup=warmup, res=res, reference_spp=1,
                  seed_sets=seed_set + 1)  # fmt: skip
    (run,) = plan(Suite("t", "t", sweeps=(sweep,)))
    run = dataclasses.replace(run, denoisers=())
    parts = dataclasses.replace(base, make_strategy=make_strategy)
    measure_seed_set(run, parts, _NoReference(), {}, seed_set)
    return seen


def _render_strategy(out, strategy, *extra):
    return main(["render", "--scene", "direct", "--res", "16x12", "--spp", "1",
                 "--strategy", strategy, "--out", str(out), *extra])  # fmt: skip


def test_strategy_frames_are_the_benchmarks_frames_bit_for_bit(tmp_path):
    assert _render_strategy(tmp_path, "temporal", "--frames", "8", "--seed-set", "1") == 0
    exrs = sorted(tmp_path.glob("direct_*.exr"))
    assert [p.name for p in exrs] == [f"direct_{t:04d}.exr" for t in range(8)]
    assert len(list(tmp_path.glob("direct_*.png"))) == 8
    bench = _benchmark_frames("temporal", seed_set=1, frames=8)
    for t, path in enumerate(exrs):
        written = read_frame(path)
        assert set(written.buffers()) == set(bench[t].buffers())
        for name, value in bench[t].buffers().items():
            assert torch.equal(written.buffers()[name], value), (t, name)
    other = tmp_path / "seed_set_0"
    assert _render_strategy(other, "temporal", "--frames", "1") == 0
    assert not torch.equal(read_frame(other / "direct_0000.exr").color, read_frame(exrs[0]).color)


def test_a_stateful_strategy_carries_its_state_into_a_later_start(tmp_path):
    assert _render_strategy(tmp_path, "temporal", "--frames", "2", "--start", "3") == 0
    assert sorted(p.name for p in tmp_path.glob("*.exr")) == ["direct_0003.exr", "direct_0004.exr"]
    bench = _benchmark_frames("temporal", seed_set=0, frames=2, warmup=3)
    for t in (3, 4):
        assert torch.equal(read_frame(tmp_path / f"direct_{t:04d}.exr").color, bench[t].color)


def test_a_stateless_strategy_starts_where_asked_as_the_benchmark_does(tmp_path):
    assert _render_strategy(tmp_path, "zsobol", "--frames", "1", "--start", "2") == 0
    bench = _benchmark_frames("zsobol", seed_set=0, frames=1, warmup=2)
    assert list(bench) == [2]  # the benchmark skips a stateless strategy's warmup too
    assert torch.equal(read_frame(tmp_path / "direct_0002.exr").color, bench[2].color)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--strategy", "nope"], "nope"),
        (["--strategy", "temporal", "--seed", "3"], "--seed: expected no --seed with --strategy"),
        (["--seed-set", "2"], "--seed-set: expected it with --strategy only"),
        (["--strategy", "temporal", "--seed-set", "-1"], "--seed-set"),
    ],
)
def test_strategy_errors_are_one_line_before_anything_is_written(tmp_path, capsys, extra, message):
    out = tmp_path / "out"
    args = ["render", "--scene", "direct", "--res", "8x8", "--spp", "1", "--out", str(out)]
    assert main([*args, *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err
    assert not list(out.glob("*.exr")) if out.exists() else True


@pytest.mark.parametrize(
    ("extra", "cached", "compiled"),
    [
        (["--res", "256x256", "--spp", "32"], True, True),  # 2^21 paths, package cached
        (["--res", "256x256", "--spp", "32"], False, False),  # not cached: eager, build later
        (["--res", "256x256", "--spp", "16"], True, False),
        (["--res", "256x256", "--spp", "16", "--frames", "2"], True, True),  # all frames' paths
        (["--res", "256x256", "--spp", "32", "--no-compile"], True, False),
        (["--res", "8x8", "--spp", "1", "--compile"], False, True),  # built first if need be
        (["--res", "256x256", "--spp", "32", "--strategy", "white"], True, False),  # bench's path
    ],
)
def test_the_compiled_tracer_is_the_default_for_large_fixed_seed_renders_once_built(
    tmp_path, capsys, monkeypatch, extra, cached, compiled
):
    import benchmarks.commands.render as command
    from renderers import aot

    seen = []

    def fake_render(scene, t, seeds, sampler, spp, *, compile=None):
        seen.append(compile)
        raise SystemExit(0)  # stop before rendering anything

    monkeypatch.setattr(command, "render", fake_render)
    monkeypatch.setattr(aot, "has_package", lambda name, static=False: cached)
    with pytest.raises(SystemExit):
        main(["render", "--scene", "direct", *extra, "--out", str(tmp_path)])
    assert seen == [aot.stage if compiled else False]


def _temporal(out, frames, res, *extra):
    return main(
        ["render", "--scene", "direct", "--res", res, "--spp", "1", "--strategy", "temporal",
         "--frames", str(frames), "--out", str(out), *extra]
    )  # fmt: skip


def test_many_frames_show_a_progress_bar_on_stderr_and_the_lines_on_stdout(tmp_path, capsys):
    assert _temporal(tmp_path / "a", 3, "8x8") == 0
    shown = capsys.readouterr()
    assert "3/3" in shown.err and "frame" in shown.err
    assert len(shown.out.splitlines()) == 3 and "3/3" not in shown.out
    assert _temporal(tmp_path / "b", 3, "8x8", "--no-progress") == 0
    assert "3/3" not in capsys.readouterr().err


def _rss_mib():
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) / 1024 for line in status if line.startswith("VmRSS"))


def test_a_long_temporal_run_keeps_memory_flat_and_the_seeds_a_permutation(tmp_path, monkeypatch):
    """Issue 28, item 7, in small: 100 frames at 32x32 (1000 at 64x64 measured 586.1 MiB at frame
    100, 586.6 MiB at frame 1000: the render module's docstring). A frame's buffers kept per
    frame would grow RSS by 64 KiB a frame, 3.8 MiB over the 60 frames watched: the margin, 2
    MiB, is above the allocator's noise (0.1 MiB here) and below that."""
    from benchmarks.commands import render as command

    made, rss = [], {}
    make, write = command.make_strategy, command.write_frame

    def keep(*args, **kwargs):
        made.append(make(*args, **kwargs))
        return made[-1]

    def watch(path, frame):
        write(path, frame)
        rss[int(path.stem.rsplit("_", 1)[1])] = _rss_mib()

    monkeypatch.setattr(command, "make_strategy", keep)
    monkeypatch.setattr(command, "write_frame", watch)
    assert _temporal(tmp_path, 100, "32x32", "--no-progress") == 0
    assert rss[99] - rss[39] < 2.0, f"RSS grew from {rss[39]:.1f} to {rss[99]:.1f} MiB"
    strategy = made[0]
    first = strategy._initial("owen_sobol")[0]  # frame 0's seed image
    assert torch.equal(strategy.seeds.reshape(-1).sort().values, first.reshape(-1).sort().values)
    assert not torch.equal(strategy.seeds, first)  # they moved: the check is not vacuous
    assert len(strategy._plans) <= strategy._plan_slots  # the per-offset caches are bounded


def test_a_render_that_repays_the_build_builds_it_first(tmp_path, monkeypatch):
    import benchmarks.commands.render as command
    from renderers import aot

    seen = []

    def fake_render(scene, t, seeds, sampler, spp, *, compile=None):
        seen.append(compile)
        raise SystemExit(0)

    monkeypatch.setattr(command, "render", fake_render)
    monkeypatch.setattr(aot, "has_package", lambda name, static=False: False)
    monkeypatch.setattr(command, "estimate_seconds", lambda scene, paths, compile=False: 1e3)
    args = ["render", "--scene", "direct", "--res", "256x256", "--spp", "32", "--force"]
    with pytest.raises(SystemExit):
        main([*args, "--out", str(tmp_path)])
    assert seen == [aot.stage]


def test_an_eager_render_without_a_package_starts_its_build_in_the_background(
    tmp_path, capsys, monkeypatch
):
    import benchmarks.commands.render as command
    from renderers import aot

    started = []
    monkeypatch.setattr(aot, "has_package", lambda name, static=False: False)
    monkeypatch.setattr(aot, "start_background_build", lambda *a: started.append(a))
    monkeypatch.setattr(command, "estimate_seconds", lambda scene, paths, compile=False: 1.0)
    monkeypatch.setattr(command, "check_render_time", lambda *a, **k: 0.0)
    monkeypatch.setattr(command, "AUTO_COMPILE_PATHS", 16)
    args = ["render", "--scene", "direct", "--res", "4x4", "--spp", "1", "--out", str(tmp_path)]
    assert main(args) == 0
    assert started == [("direct", False)] and "in the background" in capsys.readouterr().out
    monkeypatch.setenv("BNERR_BACKGROUND_BUILD", "0")
    started.clear()
    assert main(args) == 0 and started == []


def test_a_small_compiled_render_skips_the_time_calibration(tmp_path, monkeypatch):
    import benchmarks.commands.render as command
    from renderers import aot

    checked = []
    monkeypatch.setattr(aot, "has_package", lambda name, static=False: True)
    monkeypatch.setattr(command, "check_render_time", lambda *a, **k: checked.append(a) or 0.0)

    def fake_render(scene, t, seeds, sampler, spp, *, compile=None):
        raise SystemExit(0)

    monkeypatch.setattr(command, "render", fake_render)
    base = ["render", "--scene", "direct", "--res", "256x256", "--out", str(tmp_path)]
    with pytest.raises(SystemExit):
        main([*base, "--spp", "32"])  # 2^21 paths compiled: under a few seconds
    assert checked == []
    with pytest.raises(SystemExit):
        main([*base, "--spp", "64"])  # 2^22: estimated
    assert len(checked) == 1
