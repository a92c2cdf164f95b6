"""The OpenQMC rivals: their sampler at a fresh OpenQMC frame per frame and seed set, the constant
seed image, and their identity for the reports."""

from __future__ import annotations

import pytest
import torch

from bnerr.sequences import OpenQMCLatticeBNSampler, OpenQMCSobolBNSampler
from bnerr.strategies import OWN_SAMPLERS, make_strategy, strategy_identity, stream_key
from tests.bnerr.strategies._renders import hash_render

CASES = [("openqmc_sobolbn", OpenQMCSobolBNSampler), ("openqmc_latticebn", OpenQMCLatticeBNSampler)]


@pytest.mark.parametrize(("name", "cls"), CASES)
def test_each_frame_and_seed_set_takes_a_fresh_openqmc_frame(name, cls):
    record: list = []
    strategy = make_strategy(name, 6, 9, seed=2)
    for t in range(3):
        strategy.frame(t, hash_render(record))
    frames = [sampler.frame for _, sampler in record]
    assert all(type(sampler) is cls for _, sampler in record)
    assert frames == [stream_key(2, t, strategy.stream) for t in range(3)]
    assert len(set(frames)) == 3
    assert all(torch.equal(seeds, torch.zeros(6, 9, dtype=torch.int64)) for seeds, _ in record)
    other: list = []
    make_strategy(name, 6, 9, seed=3).frame(0, hash_render(other))
    assert other[0][1].frame != frames[0]


@pytest.mark.parametrize(("name", "cls"), CASES)
def test_identity_for_the_reports(name, cls):
    identity = strategy_identity(name)
    assert identity.family == "rival" and not identity.bound
    assert "OpenQMC's 256x256 tables" in identity.raw_mse_note
    assert OWN_SAMPLERS[name] == cls.name == name
    assert make_strategy(name, 4, 4, spp=3).sampler_name == name  # any spp
