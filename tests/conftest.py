"""Shared pytest configuration: deterministic hypothesis, bounded torch threads."""

import os

import torch
from hypothesis import HealthCheck, settings

# Property tests draw their examples from a fixed seed: the same run every time, never
# "flaky until green" (the project's testing standard).
settings.register_profile(
    "bnerr",
    derandomize=True,
    deadline=None,
    max_examples=int(os.environ.get("BNERR_HYPOTHESIS_EXAMPLES", "60")),
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile("bnerr")

torch.set_num_threads(min(2, os.cpu_count() or 1))
