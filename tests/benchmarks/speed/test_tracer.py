"""Tests for benchmarks.speed.tracer: figures for both renderers, graceful without LLVM or
Mitsuba."""

import pytest

from benchmarks.speed import tracer as throughput

pytestmark = pytest.mark.usefixtures("one_thread")


def test_measure_ours():
    figures = throughput.measure_ours("direct", 8, 8, 2, repeats=2, compile="eager")
    assert figures["best_s"] <= figures["median_s"]
    assert figures["samples_per_s"] == pytest.approx(8 * 8 * 2 / figures["best_s"])


def test_measure_side_by_side(monkeypatch):
    pytest.importorskip("mitsuba")
    result = throughput.measure(
        ("direct",), 8, 8, 2, repeats=1, compile="eager", variants=("scalar_rgb",)
    )
    row = result["direct"]
    assert result["settings"]["spp"] == 2
    assert row["mitsuba_scalar_rgb"]["samples_per_s"] > 0
    assert row["ratio_scalar_rgb"] == pytest.approx(
        row["bnerr"]["samples_per_s"] / row["mitsuba_scalar_rgb"]["samples_per_s"]
    )


def test_missing_llvm_or_broken_variant_is_an_error_string(monkeypatch):
    pytest.importorskip("mitsuba")
    monkeypatch.delenv("DRJIT_LIBLLVM_PATH", raising=False)
    monkeypatch.setattr(throughput, "DEFAULT_LLVM", "/nonexistent/libLLVM.so")
    message = throughput.measure_mitsuba("llvm_ad_rgb", "direct", 8, 8, 1, repeats=1)
    assert isinstance(message, str) and "libllvm19" in message
    message = throughput.measure_mitsuba("no_such_variant", "direct", 8, 8, 1, repeats=1)
    assert isinstance(message, str) and "no_such_variant failed" in message


def test_without_mitsuba(monkeypatch):
    monkeypatch.setattr(throughput, "mitsuba_available", lambda: False)
    assert "not installed" in throughput.measure_mitsuba("scalar_rgb", "direct", 8, 8, 1)


def test_unknown_stage_is_refused():
    with pytest.raises(throughput.UnknownNameError, match="aot"):
        throughput.measure_ours("direct", 8, 8, 2, compile="jit")
