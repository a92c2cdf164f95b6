"""Tests of bnerr.errors: the checks' messages, the first bad pixel, the memory check."""

import pytest
import torch

from bnerr import errors
from bnerr.errors import (
    MemoryLimitError,
    MissingDependencyError,
    NonFiniteError,
    available_memory,
    check_finite,
    check_memory,
)


def test_check_finite_names_the_count_and_the_first_bad_pixel():
    x = torch.ones(3, 5, 6)
    x[2, 1, 4] = float("nan")  # raster order: (1, 4) comes before (3, 1) whatever the channel
    x[0, 3, 1] = float("inf")
    with pytest.raises(
        NonFiniteError,
        match=r"^normal: expected finite values, got 1 NaN and 1 infinite of 90, "
        r"first at pixel \(y, x\) = \(1, 4\)$",
    ):
        check_finite(x, "normal")


def test_check_finite_on_vectors_and_scalars():
    with pytest.raises(NonFiniteError, match=r"first at index 2$"):
        check_finite(torch.tensor([0.0, 1.0, float("-inf")]), "v")
    with pytest.raises(NonFiniteError, match=r"got 1 NaN and 0 infinite of 1$"):
        check_finite(torch.tensor(float("nan")), "s")
    check_finite(torch.zeros(2, 3), "fine")


def test_available_memory_is_positive_and_at_most_physical():
    have = available_memory()
    import os

    assert 0 < have <= os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")


def test_check_memory_refuses_with_the_estimate_and_what_is_available(monkeypatch):
    monkeypatch.setattr(errors, "available_memory", lambda device=None: 2 * 2**30)
    check_memory(1.5 * 2**30, "fits")
    with pytest.raises(
        MemoryLimitError,
        match=r"^--res 40000x40000: expected a size that fits in memory \(at most 1\.8 GiB of the "
        r"2 GiB available\), got an estimate of 256 GiB$",
    ):
        check_memory(256 * 2**30, "--res 40000x40000")
    assert issubclass(MemoryLimitError, MemoryError)


def _no_cuda(monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)


def test_check_device_accepts_the_cpu_in_either_spelling(monkeypatch):
    _no_cuda(monkeypatch)
    assert errors.available_devices() == ["cpu"]
    assert errors.check_device("cpu") == torch.device("cpu")
    assert errors.check_device(torch.device("cpu")) == torch.device("cpu")


def test_check_device_names_what_came_and_what_is_available(monkeypatch):
    _no_cuda(monkeypatch)
    with pytest.raises(errors.ValueRangeError, match=r"--device: expected an available device "
                       r"\(cpu\), got cuda:1"):  # fmt: skip
        errors.check_device("cuda:1", "--device")
    with pytest.raises(errors.ValueRangeError, match=r"expected a torch device \(cpu\), got 'gpu'"):
        errors.check_device("gpu")
    with pytest.raises(errors.ValueRangeError, match="got meta"):
        errors.check_device("meta")  # a torch device, but not one that computes
    with pytest.raises(errors.DtypeError, match="expected a torch.device or str, got int 0"):
        errors.check_device(0)


def test_check_device_takes_a_cuda_index_that_exists(monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    monkeypatch.setattr(torch.cuda, "device_count", lambda: 2)
    assert errors.available_devices() == ["cpu", "cuda:0", "cuda:1"]
    assert errors.check_device("cuda") == torch.device("cuda")
    assert errors.check_device("cuda:1") == torch.device("cuda", 1)
    with pytest.raises(errors.ValueRangeError, match=r"\(cpu, cuda:0, cuda:1\), got cuda:2"):
        errors.check_device("cuda:2")


def test_a_missing_dependency_is_one_line_that_says_how_to_install_it_and_pickles():
    import pickle

    err = MissingDependencyError("cvvdp", "cvvdp==0.5.7", "no module named 'pycvvdp'")
    assert str(err) == (
        "cvvdp: expected the package cvvdp==0.5.7 (a dependency of bnerr; install: pip install "
        "cvvdp==0.5.7), got no module named 'pycvvdp'"
    )
    assert isinstance(err, ImportError)
    again = pickle.loads(pickle.dumps(err))
    assert str(again) == str(err) and again.package == "cvvdp==0.5.7"
