"""Tests for the tracer's time model (renderers.budget) and ``bnerr render``'s refusal of a
render estimated beyond its limit unless ``--force``. Timing checks compare orders of magnitude
only, so that a loaded machine does not make them flaky."""

import time

import pytest
import torch

import benchmarks.commands.render as render_command
from benchmarks.cli import main
from bnerr.errors import ValueRangeError
from bnerr.sequences import make_sampler
from bnerr.strategies import pixel_seeds
from renderers import get_scene, render
from renderers.budget import (
    UNMEASURED_PATHS,
    check_render_time,
    estimate_seconds,
    format_seconds,
    seconds_per_path,
)

ABSURD = ["render", "--scene", "direct", "--res", "64x64", "--spp", "100000000"]


def test_absurd_render_is_refused_fast_in_one_line(tmp_path, capsys):
    get_scene("direct")  # the scene's construction is not the check's cost
    start = time.perf_counter()
    code = main([*ABSURD, "--out", str(tmp_path / "out")])
    elapsed = time.perf_counter() - start
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert elapsed < 1.5, elapsed  # calibration is ~0.1 s for direct; a loaded machine, more
    assert len(err.splitlines()) == 1, err
    assert "estimate of" in err and "at most 1 h" in err and "--force" in err
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


class _Reached(Exception):
    pass


def test_force_skips_the_estimate(tmp_path, monkeypatch):
    def stub(*args, **kwargs):
        raise _Reached

    def no_estimate(*args, **kwargs):
        raise AssertionError("--force must not estimate")

    monkeypatch.setattr(render_command, "render", stub)
    monkeypatch.setattr(render_command, "check_render_time", no_estimate)
    with pytest.raises(_Reached):
        main([*ABSURD, "--force", "--no-compile", "--out", str(tmp_path / "out")])


def test_oracle_counts_its_k_renders_per_frame(tmp_path, monkeypatch, capsys):
    seen = []

    def record(scene, paths, name, *, limit_s, compile=False):
        seen.append(paths)
        raise ValueRangeError("stop")

    monkeypatch.setattr(render_command, "check_render_time", record)
    args = ["render", "--scene", "direct", "--res", "16x8", "--spp", "2", "--frames", "3"]
    main([*args, "--start", "2", "--strategy", "oracle", "--out", str(tmp_path / "a")])
    main([*args, "--start", "2", "--out", str(tmp_path / "b")])
    main([*args, "--start", "2", "--strategy", "temporal", "--out", str(tmp_path / "c")])
    assert seen == [16 * 8 * 2 * 3 * 32, 16 * 8 * 2 * 3, 16 * 8 * 2 * 5]


def test_estimate_is_linear_in_paths():
    scene = get_scene("direct")
    one = estimate_seconds(scene, 1 << 20)
    assert estimate_seconds(scene, 1 << 22) == pytest.approx(4 * one)
    assert estimate_seconds(scene, 3 << 20, compile=True) < 3 * one
    assert one > 0


def test_deeper_scene_costs_more_per_path():
    assert seconds_per_path(get_scene("cornell")) > seconds_per_path(get_scene("direct"))


def test_tiny_render_is_not_calibrated():
    assert check_render_time(get_scene("indirect"), UNMEASURED_PATHS - 1, "x", limit_s=1.0) == 0


@pytest.mark.parametrize("name", ["direct", "cornell"])
def test_estimate_is_within_5x_of_a_measured_render(name):
    scene = get_scene(name)
    height, width, spp = 64, 64, 64  # 2^18 paths: several chunks, a fraction of a second
    estimate = estimate_seconds(scene, width * height * spp)
    seeds = pixel_seeds(height, width, 0)
    start = time.perf_counter()
    render(scene, 0, seeds, make_sampler("white"), spp, compile=False)
    took = time.perf_counter() - start
    assert took / 5 < estimate < 5 * took, (estimate, took)


def test_format_seconds_reads_as_an_estimate():
    assert format_seconds(42) == "42 s"
    assert format_seconds(720) == "12 min"
    assert format_seconds(3.5 * 3600) == "3.5 h"
    assert format_seconds(41 * 86400) == "41 days"


def test_threads_do_not_change_the_estimate():
    threads = torch.get_num_threads()
    scene = get_scene("direct")
    one = estimate_seconds(scene, 1 << 22)
    torch.set_num_threads(1)
    try:
        assert estimate_seconds(scene, 1 << 22) == one
    finally:
        torch.set_num_threads(threads)


TRAIN_ABSURD = ["train", "--size", "128", "--scenes", "512", "--reference-spp", "4096"]


def test_train_refuses_absurd_data_in_one_line(tmp_path, capsys):
    code = main([*TRAIN_ABSURD, "--out", str(tmp_path / "w.pt")])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and "--force" in err and "estimate of" in err
    assert not (tmp_path / "w.pt").exists()


def test_train_force_skips_the_estimate(tmp_path, monkeypatch):
    import benchmarks.commands.train as train_command

    def stub(*args, **kwargs):
        raise _Reached

    def no_estimate(*args, **kwargs):
        raise AssertionError("--force must not estimate")

    monkeypatch.setattr(train_command, "make_pairs", stub)
    monkeypatch.setattr(train_command, "check_render_time", no_estimate)
    with pytest.raises(_Reached):
        main([*TRAIN_ABSURD, "--force", "--out", str(tmp_path / "w.pt")])


ANIMATE_ABSURD = ["animate", "--scene", "cornell", "--res", "256x256", "--spp", "4096"]


def test_animate_refuses_absurd_work_in_one_line(tmp_path, capsys):
    code = main([*ANIMATE_ABSURD, "--out", str(tmp_path / "a"), "--cache", str(tmp_path / "c")])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and "--force" in err and "estimate of" in err


def test_animate_force_skips_the_estimate(tmp_path, monkeypatch):
    import benchmarks.commands.animate as animate_command

    def stub(*args, **kwargs):
        raise _Reached

    def no_estimate(*args, **kwargs):
        raise AssertionError("--force must not estimate")

    monkeypatch.setattr(animate_command, "animate", stub)
    monkeypatch.setattr(animate_command, "check_render_time", no_estimate)
    with pytest.raises(_Reached):
        main([*ANIMATE_ABSURD, "--force", "--out", str(tmp_path / "a")])
