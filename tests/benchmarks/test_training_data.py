"""Tests of benchmarks/training_data.py: random held-out scenes and the rendered training pairs."""

import numpy as np
import pytest
import torch

import renderers
from benchmarks.training_data import (
    BLUE_STRATEGIES,
    BLUE_WARMUP,
    TrainingSpec,
    blue_input,
    check_held_out,
    input_spp,
    make_pairs,
    pixel_seeds,
    random_scene,
    render_pair,
)
from bnerr.errors import UnknownNameError, ValueRangeError
from bnerr.metrics import lowfreq
from bnerr.strategies import make_strategy
from renderers.scene import Box, Rectangle, Sphere


def _bounds(shape):
    """Axis-aligned bounds (lo, hi) of a sphere, box or rectangle."""
    if isinstance(shape, Sphere):
        c = np.asarray(shape.center.at(0))
        return c - shape.radius, c + shape.radius
    if isinstance(shape, Box):
        m = np.asarray(shape.to_world)
        corners = (
            np.array([[x, y, z, 1.0] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) @ m.T
        )
        return corners.min(0), corners.max(0)
    c, u, v = (np.asarray(x) for x in (shape.center, shape.u, shape.v))
    corners = np.array([c + a * u + b * v for a in (-1, 1) for b in (-1, 1)])
    return corners.min(0), corners.max(0)


def test_same_seed_same_scene_and_seeds_differ():
    assert random_scene(7) == random_scene(7)
    assert random_scene(7) != random_scene(8)
    assert len({random_scene(i).shapes for i in range(20)}) == 20


@pytest.mark.parametrize("seed", range(40))
def test_scenes_are_valid_and_media_hold_no_shapes(seed):
    scene = random_scene(seed)
    assert scene.name == f"train-{seed}" and not scene.animated
    assert 1 <= len(scene.lights) <= 2 and 2 <= scene.max_depth <= 5
    if scene.medium is not None:
        lo, hi = np.asarray(scene.medium.bounds_min), np.asarray(scene.medium.bounds_max)
        for shape in scene.shapes:
            s_lo, s_hi = _bounds(shape)
            overlap = np.all(s_lo < hi) and np.all(s_hi > lo)
            assert not overlap, (seed, shape.name)
        eye = np.asarray(scene.camera.origin.at(0))
        assert not (np.all(eye > lo) and np.all(eye < hi))


def test_the_population_covers_what_the_benchmark_needs():
    scenes = [random_scene(i) for i in range(100)]
    assert {s.max_depth for s in scenes} == {2, 3, 4, 5}
    assert 5 <= sum(s.medium is not None for s in scenes) <= 40
    textured = sum(
        any(isinstance(x, Rectangle) and x.material.textured for x in s.shapes) for s in scenes
    )
    assert textured >= 50
    assert any(len(s.lights) == 2 for s in scenes) and any(len(s.lights) == 1 for s in scenes)


def test_benchmark_scenes_are_held_out():
    named = [renderers.get_scene(name, animated=False) for name in renderers.SCENES]
    check_held_out([random_scene(i) for i in range(50)], named)
    with pytest.raises(
        ValueRangeError, match="training scene 'cornell': expected a held-out scene"
    ):
        check_held_out([named[0]], named)


def test_pixel_seeds_are_distinct_within_and_across_keys():
    a, b = pixel_seeds(16, 12, 3), pixel_seeds(16, 12, 4)
    assert a.dtype == torch.int64 and a.shape == (16, 12)
    assert len(torch.cat([a.flatten(), b.flatten()]).unique()) == 2 * 16 * 12


def test_render_pair_is_deterministic_and_consistent():
    scene = random_scene(1)
    frame, ref = render_pair(scene, size=8, spp=2, reference_spp=8, key=5)
    again, ref_again = render_pair(scene, size=8, spp=2, reference_spp=8, key=5)
    assert torch.equal(frame.color, again.color) and torch.equal(ref, ref_again)
    assert frame.color.shape == ref.shape == (3, 8, 8)
    assert frame.albedo is not None and frame.normal is not None
    assert not torch.equal(frame.color, ref)


def test_make_pairs_and_bad_specs():
    pairs = make_pairs(TrainingSpec(scenes=2, size=8, reference_spp=4, seed=3), progress=False)
    assert len(pairs) == 2 and pairs[0][0].color.shape == (3, 8, 8)
    with pytest.raises(UnknownNameError, match="unknown training mix 'pink'"):
        TrainingSpec(mix="pink")
    with pytest.raises(ValueRangeError, match="TrainingSpec.size: expected an integer >= 8, got 4"):
        TrainingSpec(size=4)


def _blue_twin(scene, size, spp, key, strategy, sampler):
    """blue_input spelled out: the strategy run frame by frame as the benchmark runs it."""
    made = make_strategy(
        strategy, size, size, seed=key, sampler=sampler, spp=spp, dimensions=scene.dimensions
    )
    frames = [
        made.frame(t, lambda seeds, smp, t=t: renderers.render(scene, t, seeds, smp, spp))
        for t in range(BLUE_WARMUP + 1 if strategy == "temporal" else 1)
    ]
    return frames[-1]


@pytest.mark.parametrize("strategy", sorted(set(BLUE_STRATEGIES)))
def test_blue_inputs_are_the_strategies_frames_and_keep_the_reference(strategy):
    scene = random_scene(1)
    white, ref = render_pair(scene, size=8, spp=2, reference_spp=4, key=5, sampler="owen_sobol")
    blue, ref_blue = render_pair(
        scene, size=8, spp=2, reference_spp=4, key=5, blue=strategy, sampler="owen_sobol"
    )
    again = blue_input(scene, 8, 2, 5, strategy, "owen_sobol")
    twin = _blue_twin(scene, 8, 2, 5, strategy, "owen_sobol")
    assert torch.equal(ref, ref_blue) and not torch.equal(white.color, blue.color)
    assert torch.equal(blue.color, again.color) and torch.equal(blue.color, twin.color)
    assert blue.albedo is not None and blue.normal is not None


def test_white_blue_mix_alternates_and_keeps_the_white_pairs():
    spec = dict(scenes=4, size=8, reference_spp=2, seed=0, sampler="owen_sobol")
    mixed = make_pairs(TrainingSpec(mix="white+blue", **spec), progress=False)
    white = make_pairs(TrainingSpec(**spec), progress=False)
    assert BLUE_STRATEGIES == ("temporal", "zsobol", "temporal", "cycles_blue")
    for i in (0, 2):
        assert torch.equal(mixed[i][0].color, white[i][0].color)
    for i in range(4):
        assert torch.equal(mixed[i][1], white[i][1])
    for i, strategy in ((1, "temporal"), (3, "zsobol")):
        assert not torch.equal(mixed[i][0].color, white[i][0].color)
        made = blue_input(random_scene(i), 8, input_spp(i), i + 1, strategy, "owen_sobol")
        assert torch.equal(mixed[i][0].color, made.color)
    again = make_pairs(TrainingSpec(mix="white+blue", **spec), progress=False)
    assert all(torch.equal(a[0].color, b[0].color) for a, b in zip(mixed, again, strict=True))
    with pytest.raises(UnknownNameError, match="unknown blue training strategy 'bnds'"):
        blue_input(random_scene(1), 8, 2, 5, "bnds", "owen_sobol")


def test_blue_inputs_have_less_low_frequency_error_than_white():
    """On the flat felt of ``snooker_plain`` (32 x 32, 4 spp, four keys), the error of every
    blue strategy's input has a lower low-frequency fraction than the white input's."""
    scene = renderers.get_scene("snooker_plain", animated=False)
    _, ref = render_pair(scene, 32, 4, 256, key=99, sampler="owen_sobol")
    keys = (5, 6, 7, 8)

    def fraction(blue):
        inputs = [
            render_pair(scene, 32, 4, 1, key=k, blue=blue, sampler="owen_sobol") for k in keys
        ]
        return sum(lowfreq(f.color, ref, tile=32) for f, _ in inputs) / len(keys)

    white = fraction(None)
    fractions = {name: fraction(name) for name in sorted(set(BLUE_STRATEGIES))}
    assert all(f < white for f in fractions.values()), (white, fractions)


def test_owen_sobol_inputs_keep_the_reference_and_are_checked():
    scene = random_scene(1)
    white, ref = render_pair(scene, size=8, spp=4, reference_spp=4, key=5)
    sobol, ref_sobol = render_pair(
        scene, size=8, spp=4, reference_spp=4, key=5, sampler="owen_sobol"
    )
    assert torch.equal(ref, ref_sobol) and not torch.equal(white.color, sobol.color)
    spec = TrainingSpec(scenes=1, size=8, reference_spp=4, sampler="owen_sobol")
    white_spec = TrainingSpec(scenes=1, size=8, reference_spp=4)
    assert torch.equal(
        make_pairs(spec, progress=False)[0][1], make_pairs(white_spec, progress=False)[0][1]
    )
    with pytest.raises(UnknownNameError, match="unknown training sampler 'sobol'"):
        TrainingSpec(sampler="sobol")
