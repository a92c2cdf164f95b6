"""Tests for benchmarks.animate: tiles are the benchmark's frames, files are written and read back,
the same arguments give the same files, labels and crops have the right sizes."""

import dataclasses

import imageio.v2 as imageio
import imageio.v3 as iio
import numpy as np
import pytest
import torch

import denoisers
import renderers
from benchmarks.animate import (
    Animation,
    animate,
    animate_scene,
    compose_frame,
    default_strategies,
    fit_size,
    render_tiles,
    text_strip,
    tuned_denoiser,
    write_animations,
    write_gif,
    write_mp4,
)
from benchmarks.sweep.parts import known_names, real_parts
from benchmarks.sweep.references import ReferenceCache, reference_seeds
from bnerr import sequences, strategies
from bnerr.errors import UnknownNameError, ValueRangeError
from bnerr.frame import Frame

pytestmark = pytest.mark.usefixtures("one_thread")

SPEC = Animation(
    scene="direct",
    strategies=("white", "temporal"),
    frames=4,
    warmup=2,
    width=32,
    height=32,
    spp=2,
    seed_set=1,
    reference_spp=8,
    fps=4,
    gif_crop=16,
    gif_frames=3,
)


@pytest.fixture(scope="module")
def parts():
    return real_parts()


@pytest.fixture(scope="module")
def cache(tmp_path_factory, parts):
    return ReferenceCache(tmp_path_factory.mktemp("refs"), parts)


@pytest.fixture(scope="module")
def tiles(parts, cache):
    return render_tiles(parts, cache, SPEC)


def _strategy_colors(name: str) -> list[torch.Tensor]:
    """The benchmark's frames written out by hand: every frame from t = 0, shown from warmup."""
    scene = renderers.get_scene(SPEC.scene, animated=True)
    strategy = strategies.make_strategy(
        name, SPEC.height, SPEC.width, seed=SPEC.seed_set, spp=SPEC.spp, dimensions=scene.dimensions
    )
    colors = []
    for t in range(SPEC.warmup + SPEC.frames):

        def render(seeds, sampler, t=t):
            return renderers.render(scene, t, seeds, sampler, SPEC.spp)

        frame = strategy.frame(t, render)
        if t >= SPEC.warmup:
            colors.append(frame.color)
    return colors


def _mp4_frames(path) -> list[np.ndarray]:
    """Every decoded frame (the ffmpeg reader's length is unknown, so no ``list(reader)``)."""
    with imageio.get_reader(path, format="FFMPEG") as reader:
        return [frame for frame in reader.iter_data()]


def test_raw_tiles_are_the_strategies_frames_bit_for_bit(tiles):
    assert tiles.columns == ("reference", "white", "temporal")
    for name in SPEC.strategies:
        expected = _strategy_colors(name)
        assert len(tiles.raw[name]) == SPEC.frames
        for got, want in zip(tiles.raw[name], expected, strict=True):
            assert torch.equal(got, want), name


def test_reference_tiles_are_the_benchmark_references(tiles):
    scene = renderers.get_scene(SPEC.scene, animated=True)
    sampler = sequences.make_sampler("owen_sobol")
    for i, t in enumerate(SPEC.times):
        seeds = reference_seeds(SPEC.height, SPEC.width, t)
        want = renderers.render(scene, t, seeds, sampler, SPEC.reference_spp).color
        assert torch.equal(tiles.raw["reference"][i], want)
        assert tiles.den["reference"][i] is tiles.raw["reference"][i]


def test_denoised_tiles_use_default_parameters_without_a_store(tiles):
    assert "default parameters" in tiles.denoiser_label
    gaussian = denoisers.get_denoiser("gaussian")
    expected = _strategy_colors("white")
    for got, color in zip(tiles.den["white"], expected, strict=True):
        assert torch.equal(got, gaussian(Frame(color=color)))


def test_tuned_parameters_come_from_the_store(parts):
    from denoisers.tuning import ParamStore, TuneResult

    store = ParamStore()
    result = TuneResult(
        denoiser="gaussian", params={"sigma": 2.5}, mse=1.0, noisy_mse=2.0, frames=3
    )
    store.put(result, "direct/m1/owen_sobol/32x32", SPEC.spp)
    denoiser, label = tuned_denoiser(parts, SPEC, store)
    assert denoiser.params() == {"sigma": 2.5}
    assert label == "gaussian sigma=2.5 (tuned on white noise)"
    other = dataclasses.replace(SPEC, spp=4)  # nothing stored at 4 spp: the defaults
    denoiser, label = tuned_denoiser(parts, other, store)
    assert denoiser.params() == {"sigma": 1.0} and "default parameters" in label


def test_compose_frame_sizes_and_determinism(tiles):
    frame = compose_frame(tiles, 0, ["caption"])
    again = compose_frame(tiles, 0, ["caption"])
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert np.array_equal(frame, again)
    columns = len(tiles.columns)
    assert frame.shape[1] == 14 + columns * SPEC.width
    assert frame.shape[0] == 13 + 14 + 2 * SPEC.height
    small = compose_frame(tiles, 0, ["caption"], crop=16, scale=2)
    assert small.shape[:2] == (13 + 14 + 2 * 32, 14 + columns * 32)
    assert not np.array_equal(compose_frame(tiles, 1, ["caption"]), frame)


def test_text_strip_is_read_only_and_sized():
    strip = text_strip("temporal", 60, 14, fit_size(["temporal"], 60, 14))
    assert strip.shape == (14, 60, 3) and strip.dtype == np.uint8 and strip.max() > 128
    assert not strip.flags.writeable
    assert text_strip("x", 14, 40, 10.0, rotate=True).shape == (40, 14, 3)


def test_writers_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    frames = [rng.integers(0, 256, (40, 50, 3), dtype=np.uint8) for _ in range(5)]
    mp4 = write_mp4(tmp_path / "a.mp4", frames, fps=5)
    decoded = _mp4_frames(mp4)
    assert len(decoded) == 5 and decoded[0].shape == (48, 64, 3)  # padded to 16
    gif = write_gif(tmp_path / "a.gif", frames, fps=5)
    back = iio.imread(gif, index=None)
    assert back.shape[:3] == (5, 40, 50)
    assert write_gif(tmp_path / "b.gif", frames, fps=5).read_bytes() == gif.read_bytes()
    assert not [p for p in tmp_path.iterdir() if "bnerr-tmp" in p.name]


def test_animate_scene_writes_readable_files_deterministically(tmp_path, parts, cache):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    first = animate_scene(parts, cache, SPEC, tmp_path / "a")
    second = animate_scene(parts, cache, SPEC, tmp_path / "b")
    mp4 = _mp4_frames(first["mp4"])
    assert len(mp4) == SPEC.frames
    columns = 1 + len(SPEC.strategies)
    width, height = 14 + columns * SPEC.width, 2 * 13 + 14 + 2 * SPEC.height
    assert mp4[0].shape == (-(-height // 16) * 16, -(-width // 16) * 16, 3)
    gif = iio.imread(first["gif"], index=None)
    assert gif.shape[:3] == (SPEC.gif_frames, 2 * 13 + 14 + 2 * 16, 14 + columns * 16)
    assert first["gif"].read_bytes() == second["gif"].read_bytes()
    assert all(np.array_equal(a, b) for a, b in zip(mp4, _mp4_frames(second["mp4"]), strict=True))
    assert set(first["seconds"]) == {"reference", "white", "temporal", "encode"}


def test_animate_locks_and_checks_the_folder(tmp_path, parts):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(OSError, match="expected a folder"):
        animate([SPEC], blocker, cache_dir=tmp_path / "c", parts=parts)


def test_check_refuses_bad_names_and_counts():
    known = known_names()
    with pytest.raises(UnknownNameError, match="unknown scene 'nope'"):
        dataclasses.replace(SPEC, scene="nope").check(known)
    with pytest.raises(UnknownNameError, match="unknown strategy 'nope'"):
        dataclasses.replace(SPEC, strategies=("white", "nope")).check(known)
    with pytest.raises(UnknownNameError, match="unknown denoiser"):
        dataclasses.replace(SPEC, denoiser="nope").check(known)
    with pytest.raises(ValueRangeError, match="frames: expected an integer >= 1"):
        dataclasses.replace(SPEC, frames=0).check(known)
    assert SPEC.check(known) is SPEC


def test_default_strategies_start_with_white_and_temporal():
    names = default_strategies()
    assert names[:2] == ("white", "temporal")
    assert set(names) <= set(strategies.STRATEGIES)


def test_write_animations_follows_the_suite(tmp_path):
    from benchmarks.suites import Suite, Sweep

    sweep = Sweep(
        scenes=("direct",),
        strategies=("white",),
        spp=(1, 2),
        denoisers=("gaussian",),
        frames=2,
        warmup=1,
        res=(16, 12),
        reference_spp=4,
    )
    suite = Suite(name="tiny", description="tiny", sweeps=(sweep,))
    results = write_animations(
        suite, tmp_path / "anim", cache_dir=tmp_path / "c", strategies=("white",), frames=2
    )
    assert [r["mp4"].name for r in results] == ["direct.mp4"]
    assert _mp4_frames(results[0]["mp4"])[0].shape == (64, 48, 3)  # 26 + 14 + 24; 14 + 2 x 16
    refs = sorted(p.name for p in (tmp_path / "c" / "direct").iterdir())
    assert len(refs) == 2 and all("16x12_spp4_" in n for n in refs)


def test_animate_removes_its_own_stale_temporaries(tmp_path, parts, cache):
    out = tmp_path / "anim"
    out.mkdir()
    stale = out / ".direct.gif.bnerr-tmp-999999999-0123abcd.gif"
    stale.write_bytes(b"x")
    spec = dataclasses.replace(SPEC, strategies=("white",), frames=1, gif_frames=1)
    animate([spec], out, cache_dir=cache.root, parts=parts)
    assert not stale.exists() and (out / "direct.gif").is_file()
