"""Tests of bnerr.masks.stbn: the shipped spatiotemporal masks (blue per slice and along t, every
rank once per slice), the generators (ranks, determinism, device), the energies against their slow
twins, the swap gain against the energy difference, and the input checks."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from hypothesis import given
from hypothesis import strategies as st

from bnerr.errors import (
    DtypeError,
    FileFormatError,
    NonFiniteError,
    ShapeError,
    UnknownNameError,
    ValueRangeError,
)
from bnerr.masks.stbn import (
    _candidates,
    _independent,
    _initial_pattern,
    _Splatter,
    _swap_gain,
    _Window,
    load_stbn,
    shipped_stbn,
    stbn_energy_field,
    stbn_energy_field_reference,
    stbn_frame,
    stbn_scalar,
    stbn_vector,
    stbn_vector_energy,
    stbn_vector_energy_reference,
    temporal_low_frequency_fraction,
)
from bnerr.metrics.spectrum import low_frequency_fraction

pytestmark = pytest.mark.usefixtures("one_thread")

SIZE, FRAMES = 64, 32


def _ranks(slice_: torch.Tensor) -> torch.Tensor:
    """Ranks ``[T^2]`` of a slice holding values ``(rank + 0.5) / T^2``."""
    n = slice_.numel()
    return torch.round(slice_.double() * n - 0.5).long().flatten()


def _stratified(n: int) -> torch.Tensor:
    return torch.from_numpy(((np.arange(n) + 0.5) / n).astype(np.float32))


def _white_control(mask: torch.Tensor, seed: int) -> torch.Tensor:
    """The same values with every slice (and channel) shuffled independently over its pixels.

    Each slice keeps its values, so only the arrangement differs: each pixel's series over t then
    is a white sequence of the slice values.
    """
    g = torch.Generator().manual_seed(seed)
    flat = mask.reshape(-1, mask.shape[-2] * mask.shape[-1])
    rows = [r[torch.randperm(r.numel(), generator=g)] for r in flat]
    return torch.stack(rows).view_as(mask)


@pytest.fixture(scope="module")
def shipped() -> dict[str, torch.Tensor]:
    return {kind: load_stbn(kind, SIZE, FRAMES) for kind in ("scalar", "vector")}


# ---- the shipped masks --------------------------------------------------------------------------


def test_shipped_listing():
    assert ("scalar", SIZE, FRAMES) in shipped_stbn()
    assert ("vector", SIZE, FRAMES) in shipped_stbn()


def test_shipped_shapes_and_every_rank_once_per_slice(shipped):
    scalar, vector = shipped["scalar"], shipped["vector"]
    assert scalar.shape == (FRAMES, SIZE, SIZE) and scalar.dtype == torch.float32
    assert vector.shape == (FRAMES, 2, SIZE, SIZE) and vector.dtype == torch.float32
    want = _stratified(SIZE * SIZE)
    for t in range(FRAMES):
        assert torch.equal(torch.sort(_ranks(scalar[t])).values, torch.arange(SIZE * SIZE))
        assert torch.equal(torch.sort(scalar[t].flatten()).values, want)
        for c in range(2):
            assert torch.equal(torch.sort(vector[t, c].flatten()).values, want)


@pytest.mark.parametrize("kind", ["scalar", "vector"])
def test_shipped_slices_are_blue(shipped, kind):
    mask = shipped[kind]
    for t in range(FRAMES):
        assert low_frequency_fraction(mask[t], tile=SIZE) <= 0.005, t
        if kind == "vector":
            for c in range(2):
                assert low_frequency_fraction(mask[t, c], tile=SIZE) <= 0.005, (t, c)


@pytest.mark.parametrize("kind", ["scalar", "vector"])
def test_shipped_series_over_t_are_blue_against_a_white_control(shipped, kind):
    """Each pixel's series over t: low-frequency energy (< 0.125 cycles/frame) against white.

    The control is the same mask with every slice shuffled over its pixels (8 seeds). For F = 32
    white series expect 6/31 = 0.194 of their energy below the cutoff; the 8 controls measure
    0.194 +- 0.0015 (their standard deviation; the fraction averages 4096 or 8192 series). The
    margin: the mask must sit below a quarter of the control's mean and more than 20 control
    standard deviations below it. Measured: scalar 0.0049, vector 0.031 (controls 0.194 and
    0.193 +- 0.0015; bnerr/data/README.md).
    """
    mask = shipped[kind]
    fraction = temporal_low_frequency_fraction(mask)
    controls = torch.tensor(
        [temporal_low_frequency_fraction(_white_control(mask, s)) for s in range(8)]
    )
    mean, sd = float(controls.mean()), float(controls.std())
    assert abs(mean - 6 / 31) < 0.01  # the control is white
    assert fraction < 0.25 * mean
    assert mean - fraction > 20 * sd


def test_frame_t_uses_slice_t_mod_f(shipped):
    mask = shipped["scalar"]
    assert torch.equal(stbn_frame(mask, 3), mask[3])
    assert torch.equal(stbn_frame(mask, FRAMES + 3), mask[3])
    assert torch.equal(stbn_frame(shipped["vector"], 2 * FRAMES), shipped["vector"][0])


@pytest.mark.slow
def test_shipped_scalar_mask_is_what_the_generator_makes(shipped):
    assert torch.equal(stbn_scalar(SIZE, FRAMES, seed=0), shipped["scalar"])


# ---- scalar generator ---------------------------------------------------------------------------


@given(size=st.integers(2, 12), frames=st.integers(1, 6), seed=st.integers(0, 2**32 - 1))
def test_scalar_every_rank_once_per_slice(size, frames, seed):
    mask = stbn_scalar(size, frames, seed)
    assert mask.shape == (frames, size, size) and mask.dtype == torch.float32
    for t in range(frames):
        assert torch.equal(torch.sort(_ranks(mask[t])).values, torch.arange(size * size))


def test_scalar_deterministic_in_seed():
    a, b, c = stbn_scalar(16, 8, 5), stbn_scalar(16, 8, 5), stbn_scalar(16, 8, 6)
    assert torch.equal(a, b) and not torch.equal(a, c)
    assert not torch.equal(stbn_scalar(16, 8, 5, sigma_t=1.0), a)


def test_scalar_fresh_mask_is_blue_in_space_and_time():
    mask = stbn_scalar(32, 16, seed=1)
    # 32x32 slices: white noise measures ~0.04 here, the slices below 0.001.
    assert max(low_frequency_fraction(m, tile=32) for m in mask) <= 0.001
    # F = 16 at cutoff 0.25: white expects 6 / 15 = 0.4.
    fraction = temporal_low_frequency_fraction(mask, cutoff=0.25)
    white = temporal_low_frequency_fraction(_white_control(mask, 0), cutoff=0.25)
    assert fraction < 0.1 < 0.3 < white


def test_one_frame_is_a_2d_void_and_cluster_mask():
    """F = 1: the temporal kernel is empty and the result is a blue 2D rank mask."""
    mask = stbn_scalar(32, 1, seed=2)
    assert mask.shape == (1, 32, 32)
    assert low_frequency_fraction(mask[0], tile=32) <= 0.001


def test_incremental_energy_matches_the_fft_field_and_its_slow_twin():
    size, frames = 6, 4
    splat = _Splatter(size, frames, 1.9, 1.9, torch.device("cpu"))
    ones, energy = _initial_pattern(size, frames, 3, splat, torch.device("cpu"))
    assert int(ones.sum()) == frames * round(0.1 * size * size)
    slow = stbn_energy_field_reference(ones)
    assert torch.allclose(energy, slow, rtol=0, atol=1e-12)
    assert torch.allclose(stbn_energy_field(ones), slow, rtol=0, atol=1e-12)


@given(
    size=st.integers(1, 5),
    frames=st.integers(1, 5),
    sigma=st.floats(0.5, 3.0),
    sigma_t=st.floats(0.5, 3.0),
    seed=st.integers(0, 1000),
)
def test_energy_field_of_weights_matches_the_slow_twin(size, frames, sigma, sigma_t, seed):
    g = torch.Generator().manual_seed(seed)
    weights = torch.rand(frames, size, size, generator=g, dtype=torch.float64)
    fast = stbn_energy_field(weights, sigma, sigma_t)
    slow = stbn_energy_field_reference(weights, sigma, sigma_t)
    assert torch.allclose(fast, slow, rtol=0, atol=1e-11)


def test_energy_field_of_a_single_sample_is_the_cross_kernel():
    pattern = torch.zeros(5, 8, 8, dtype=torch.bool)
    pattern[1, 2, 3] = True
    field = stbn_energy_field(pattern)
    assert field[1, 2, 3] == pytest.approx(1.0)
    assert field[1, 2, 4] == pytest.approx(np.exp(-1 / (2 * 1.9**2)))
    assert field[2, 2, 3] == pytest.approx(np.exp(-1 / (2 * 1.9**2)))
    assert field[4, 2, 3] == pytest.approx(np.exp(-4 / (2 * 1.9**2)))  # t distance 2, toroidal
    assert abs(float(field[2, 2, 4])) < 1e-12  # other pixel and other slice: no interaction


# ---- vector generator ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def small_vector() -> torch.Tensor:
    return stbn_vector(24, 4, seed=3, iterations=4)


def test_vector_channels_stay_stratified_per_slice(small_vector):
    assert small_vector.shape == (4, 2, 24, 24) and small_vector.dtype == torch.float32
    want = _stratified(576)
    for t in range(4):
        for c in range(2):
            assert torch.equal(torch.sort(small_vector[t, c].flatten()).values, want)


def test_vector_energy_below_white_control(small_vector):
    energy = stbn_vector_energy(small_vector)
    white = [stbn_vector_energy(_white_control(small_vector, s)) for s in range(4)]
    assert energy < min(white)


def test_vector_deterministic_in_seed():
    a = stbn_vector(12, 3, seed=4, iterations=1)
    assert torch.equal(a, stbn_vector(12, 3, seed=4, iterations=1))
    assert not torch.equal(a, stbn_vector(12, 3, seed=5, iterations=1))


def test_vector_energy_matches_the_slow_twin():
    g = torch.Generator().manual_seed(0)
    for frames, dims in ((3, 2), (1, 3), (2, 4)):
        mask = torch.rand(frames, dims, 12, 12, generator=g, dtype=torch.float64)
        slow = stbn_vector_energy_reference(mask)
        assert stbn_vector_energy(mask) == pytest.approx(slow, rel=1e-12)


@given(seed=st.integers(0, 10_000), batch=st.integers(0, 50))
def test_swap_gain_matches_the_energy_difference(seed, batch):
    size, frames = 12, 4
    g = torch.Generator().manual_seed(seed)
    mask = torch.rand(frames, 2, size, size, generator=g, dtype=torch.float64)
    window = _Window(frames, 1.9, 1.9, 3.0).bind(size, frames, torch.device("cpu"))
    p, q = _candidates(seed, batch, size, frames, window)
    keep = _independent(p, q, window, size, frames)
    p, q = p[keep], q[keep]
    values = mask.transpose(0, 1).reshape(2, -1)
    gains = _swap_gain(values, p, q, window, 1.0)
    before = stbn_vector_energy(mask)
    swapped = values.clone()
    swapped[:, p], swapped[:, q] = values[:, q], values[:, p]
    after = stbn_vector_energy(swapped.view(2, frames, size, size).transpose(0, 1))
    # independent swaps: the changes add up exactly
    assert float(gains.sum()) == pytest.approx(after - before, abs=1e-9)
    for i in range(min(3, p.numel())):
        one = values.clone()
        one[:, [p[i], q[i]]] = values[:, [q[i], p[i]]]
        diff = stbn_vector_energy(one.view(2, frames, size, size).transpose(0, 1)) - before
        assert float(gains[i]) == pytest.approx(diff, abs=1e-9)


# ---- measuring ----------------------------------------------------------------------------------


def test_temporal_fraction_of_white_noise_is_the_share_of_low_bins():
    g = torch.Generator().manual_seed(0)
    white = torch.rand(32, 128, 128, generator=g)
    assert temporal_low_frequency_fraction(white) == pytest.approx(6 / 31, abs=0.005)
    assert temporal_low_frequency_fraction(torch.ones(4, 3, 3)) == 0.0


# ---- input checks -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("call", "error", "message"),
    [
        (lambda: stbn_scalar(1, 4), ValueRangeError, "size: expected an integer >= 2"),
        (lambda: stbn_scalar(8, 0), ValueRangeError, "frames: expected an integer >= 1"),
        (lambda: stbn_scalar(8, 4.0), DtypeError, "frames: expected an integer"),
        (lambda: stbn_scalar(8, 4, seed=-1), ValueRangeError, "seed"),
        (lambda: stbn_scalar(8, 4, seed=2**32), ValueRangeError, "seed"),
        (lambda: stbn_scalar(8, 4, sigma=0.0), ValueRangeError, "sigma"),
        (lambda: stbn_scalar(8, 4, sigma_t="1"), DtypeError, "sigma_t"),
        (lambda: stbn_scalar(8, 4, device=3), DtypeError, "device"),
        (lambda: stbn_scalar(8, 4, device="nonsense"), ValueRangeError, "device"),
        (lambda: stbn_scalar(512, 4), ValueRangeError, "size"),
        (lambda: stbn_vector(8, 4), ValueRangeError, "size: expected an integer >= 12"),
        (lambda: stbn_vector(16, 4, dims=1), ValueRangeError, "dims"),
        (lambda: stbn_vector(16, 4, dims=9), ValueRangeError, "dims"),
        (lambda: stbn_vector(16, 4, iterations=0), ValueRangeError, "iterations"),
        (lambda: stbn_vector(16, 4, radius=9.0), ValueRangeError, "radius"),
        (lambda: stbn_vector(16, 4, sigma_s=0.0), ValueRangeError, "sigma_s"),
        (lambda: load_stbn("blue", 64, 32), UnknownNameError, "mask kind"),
        (lambda: load_stbn("scalar", 128, 32), UnknownNameError, "expected one of the shipped"),
        (lambda: stbn_energy_field(torch.zeros(4, 4)), ShapeError, "pattern"),
        (lambda: stbn_energy_field(torch.zeros(2, 4, 5)), ShapeError, "pattern"),
        (lambda: stbn_energy_field(torch.zeros(2, 4, 4, dtype=torch.int64)), DtypeError, "pattern"),
        (lambda: stbn_energy_field([[0.0]]), DtypeError, "pattern"),
        (lambda: stbn_vector_energy(torch.zeros(2, 12, 12)), ShapeError, "mask"),
        (
            lambda: stbn_vector_energy(torch.full((1, 2, 12, 12), float("nan"))),
            NonFiniteError,
            "mask",
        ),
        (lambda: temporal_low_frequency_fraction(torch.zeros(1, 4)), ShapeError, "F >= 2"),
        (lambda: temporal_low_frequency_fraction(torch.zeros(4, 4), 0.7), ValueRangeError, "cut"),
        (lambda: stbn_frame(torch.zeros(4, 4), 0), ShapeError, "mask"),
        (lambda: stbn_frame(torch.zeros(2, 4, 4), -1), ValueRangeError, "t"),
    ],
)
def test_bad_input_raises_typed_errors(call, error, message):
    with pytest.raises(error, match=message):
        call()


def test_a_foreign_shipped_file_is_a_file_format_error(monkeypatch, tmp_path):
    import bnerr.masks.stbn as stbn
    import bnerr.resources as resources

    np.save(tmp_path / "stbn_scalar_8x2.npy", np.zeros((2, 8, 9), dtype=np.float32))
    monkeypatch.setattr(resources, "data_dir", lambda: tmp_path)
    monkeypatch.setattr(stbn, "shipped_files", lambda prefix: ["stbn_scalar_8x2.npy"])
    with pytest.raises(FileFormatError, match="expected float32 of shape"):
        load_stbn("scalar", 8, 2)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
def test_scalar_mask_is_the_same_on_cuda():
    assert torch.equal(stbn_scalar(16, 8, 7, device="cuda").cpu(), stbn_scalar(16, 8, 7))
