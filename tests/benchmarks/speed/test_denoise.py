"""``benchmarks.speed.denoise.measure()`` for real on a tiny frame: a median time per
denoiser, None for one it cannot build."""

from __future__ import annotations

import pytest

from benchmarks.speed import denoise
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
