"""Tests for bnerr.timing: sync is a no-op on the CPU, the stopwatch counts milliseconds."""

import time

import torch

from bnerr.timing import Stopwatch, sync


def test_sync_accepts_tensors_devices_and_none_on_the_cpu():
    sync(torch.ones(1))
    sync(torch.device("cpu"))
    sync("cpu")
    sync(None)


def test_stopwatch_measures_and_restarts():
    watch = Stopwatch()
    time.sleep(0.02)
    first = watch.ms(torch.ones(1))
    assert first >= 15.0
    watch.restart()
    assert watch.ms() < first
