"""Tests of benchmarks.sweep.parts: the project's own parts and registries."""

import pytest
import torch

import renderers
from benchmarks.sweep.parts import known_names, real_parts, render_any, render_batch_any
from benchmarks.sweep.version import code_version
from bnerr.errors import ValueRangeError
from bnerr.strategies import STRATEGIES
from renderers.cycles import CYCLES_STRATEGIES

pytestmark = pytest.mark.usefixtures("one_thread")


def test_known_names_are_the_registries():
    names = known_names()
    # bnerr's strategies, then Cycles' own patterns (they run on Cycles scenes only)
    assert names["known_strategies"] == tuple(dict.fromkeys((*STRATEGIES, *CYCLES_STRATEGIES)))
    assert "direct" in names["known_scenes"] and "gaussian" in names["known_denoisers"]


def test_real_parts_render_through_a_strategy():
    parts = real_parts()
    assert parts.code_version == code_version()
    scene = parts.get_scene("direct", True)
    strategy = parts.make_strategy("temporal", scene, 6, 8, 0, "owen_sobol", 1)
    assert strategy.stateful
    assert not parts.make_strategy("white", scene, 6, 8, 0, "owen_sobol", 1).stateful
    zsobol = parts.make_strategy("temporal_zsobol", scene, 6, 8, 0, "white", 4)
    assert zsobol.stateful and zsobol.sampler_name == "zsobol" and zsobol.spp == 4
    assert not parts.make_strategy("zsobol_t", scene, 6, 8, 0, "white", 4).stateful
    frame = strategy.frame(0, lambda seeds, sampler: parts.render(scene, 0, seeds, sampler, 1))
    assert frame.color.shape == (3, 6, 8) and frame.timings["render"] > 0
    assert parts.with_depth(scene, 2).max_depth == 2
    assert parts.reference_sampler().name == "owen_sobol"
    assert parts.tune_denoiser("gaussian_does_not_exist", [], []) is None
    out = parts.make_denoiser("gaussian", None)(frame)
    assert out.shape == (3, 6, 8) and out.dtype == torch.float32


def test_real_parts_render_on_their_device_and_refuse_one_not_here(monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    parts = real_parts()
    assert parts.device == "cpu"
    with pytest.raises(ValueRangeError, match=r"device: expected an available device \(cpu\)"):
        real_parts(device="cuda")


def test_the_parts_render_moves_the_seeds_to_their_device(monkeypatch):
    seen = []
    monkeypatch.setattr(renderers, "render", lambda scene, t, seeds, *a, **k: seen.append(seeds))
    monkeypatch.setattr(renderers, "render_batch", lambda scene, t, seeds, *a: seen.append(seeds))
    scene = renderers.get_scene("direct")
    seeds = torch.zeros(4, 4, dtype=torch.int64)
    render_any(scene, 0, seeds, None, 1, device="meta")  # meta: a device every machine has
    render_batch_any(scene, 0, seeds[None], None, 1, device="meta")
    render_any(scene, 0, seeds, None, 1)  # no device: where the seeds are
    assert [s.device.type for s in seen] == ["meta", "meta", "cpu"]
