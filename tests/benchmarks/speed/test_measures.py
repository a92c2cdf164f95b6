"""Each speed script's ``measure()`` run for real on a tiny input (benchmarks.speed.denoise,
masks, permute, sequences): the figures the speed suite stores come out with their keys and
plausible values. (copy: tests/test_speed.py; tracer: tests/test_throughput.py; process, which
starts ``bnerr render`` processes: tests/benchmarks/speed/test_process.py.)"""

from __future__ import annotations

import functools

import pytest

from benchmarks.speed import denoise, masks, permute, sequences
from bnerr.errors import MissingExtraError
from denoisers import get_denoiser

pytestmark = pytest.mark.usefixtures("one_thread")


def test_denoise_times_each_named_denoiser_and_none_for_one_it_cannot_build(monkeypatch):
    def get(name):
        if name == "oidn":  # as where the extra is not installed
            raise MissingExtraError("oidn", "reference", "pyoidn", "no module named pyoidn")
        return get_denoiser(name)

    monkeypatch.setattr(denoise, "get_denoiser", get)
    figures = denoise.measure(["gaussian", "atrous", "oidn"], height=8, width=8, repeats=1)
    assert list(figures) == ["gaussian", "atrous", "oidn"] and figures["oidn"] is None
    assert all(isinstance(s, float) and s > 0 for s in (figures["gaussian"], figures["atrous"]))


def test_masks_times_each_mask_and_measures_its_low_frequencies():
    figures = masks.measure(scalar_sizes=(16,), vector_dims=(2,), vector_size=16, repeats=1)
    assert set(figures) == {"scalar_16", "vector_16_d2"}
    for row in figures.values():
        assert row["seconds"] > 0 and 0 <= row["low_frequency_fraction"] < 0.049


def test_permute_times_every_pass_with_its_context():
    figures = permute.measure(width=16, height=8, repeats=1, threads=1, mask_size=64)
    for key in ("sort_pass_lum_ms", "sort_pass_rgb_ms", "argsort_ms", "torch_path_ms"):
        assert figures[key] > 0, key
    for key in ("plan_ms", "retarget_ms", "retarget_torch_ms"):
        assert figures[key] > 0, key
    assert figures["ratio"] == pytest.approx(figures["argsort_ms"] / figures["sort_pass_lum_ms"])
    assert figures["gap"] and all(v > 0 for v in figures["gap"].values())
    assert (figures["threads"], figures["device"]) == (1, "cpu")
    assert figures["size"] == "16x8, block 4" and isinstance(figures["native"], str)


def test_sequences_times_each_sampler_call_and_each_driven_render(monkeypatch):
    # measure() takes no arguments: its two parts get the tiny sizes.
    samples = functools.partial(sequences.measure_samples, n=64, counts=(2,), repeats=1)
    renders = functools.partial(sequences.measure_render, size=8, spp=1, repeats=1)
    monkeypatch.setattr(sequences, "measure_samples", samples)
    monkeypatch.setattr(sequences, "measure_render", renders)
    figures = sequences.measure()
    assert set(figures) == {"sample", "render"}
    assert figures["sample"] and all(
        set(row) == {2} and row[2] > 0 for row in figures["sample"].values()
    )
    assert figures["render"] and all(s > 0 for s in figures["render"].values())
