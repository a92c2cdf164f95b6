"""Tests of bnerr.masks.spatial: rank and permutation properties, blueness against white controls,
R2 offsets, tiling, determinism, the shipped masks and the input checks."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from hypothesis import given
from hypothesis import strategies as st

from bnerr.errors import DtypeError, ShapeError, UnknownNameError, ValueRangeError
from bnerr.masks.spatial import (
    PLASTIC_NUMBER,
    _gf_window,
    _swap_gain,
    frame_offset,
    load_mask,
    r2_step,
    shipped_masks,
    tile_mask,
    vector_mask,
    vector_mask_energy,
    void_and_cluster,
)
from bnerr.metrics.spectrum import low_frequency_fraction

SHIPPED_VECTOR_DIMS = (2, 4, 8)


@pytest.fixture(scope="module")
def small_vector_mask() -> torch.Tensor:
    return vector_mask(32, 4, seed=5, iterations=16)


def _ranks(mask: torch.Tensor) -> torch.Tensor:
    n = mask.numel()
    return torch.round(mask.double() * n - 0.5).long().flatten()


def _stratified(n: int) -> torch.Tensor:
    return torch.from_numpy(((np.arange(n) + 0.5) / n).astype(np.float32))


def _shuffled(mask: torch.Tensor, seed: int) -> torch.Tensor:
    """White-noise control: every channel of ``mask [D, T, T]`` in an independent random order."""
    g = torch.Generator().manual_seed(seed)
    return torch.stack(
        [c.flatten()[torch.randperm(c.numel(), generator=g)].view_as(c) for c in mask]
    )


# ---- scalar masks -----------------------------------------------------------------------------


@pytest.mark.parametrize("size", [64, 128])
def test_shipped_scalar_mask_is_a_blue_rank_mask(size):
    mask = load_mask("scalar", size)
    assert mask.shape == (size, size) and mask.dtype == torch.float32
    assert torch.equal(torch.sort(_ranks(mask)).values, torch.arange(size * size))
    # values are exactly (rank + 0.5) / N in float32
    assert torch.equal(torch.sort(mask.flatten()).values, _stratified(size * size))
    assert low_frequency_fraction(mask, tile=size) <= 0.005


def test_shipped_scalar_mask_is_what_the_generator_makes():
    assert torch.equal(load_mask("scalar", 64), void_and_cluster(64, seed=0))


def test_fresh_scalar_mask_every_rank_once():
    for size in (1, 2, 5, 32):
        mask = void_and_cluster(size, seed=3)
        assert torch.equal(torch.sort(_ranks(mask)).values, torch.arange(size * size))


def test_fresh_scalar_mask_is_blue_while_white_is_not():
    # 64x64: at 32x32 the white fraction rests on ~24 independent bins and spreads too wide for
    # a 4-sigma margin to say anything.
    mask = void_and_cluster(64, seed=1)
    white = [low_frequency_fraction(_shuffled(mask[None], s)[0]) for s in range(16)]
    mean, std = float(np.mean(white)), float(np.std(white, ddof=1))
    assert low_frequency_fraction(mask) < mean - 4 * std
    assert low_frequency_fraction(mask) <= 0.005


def test_scalar_mask_deterministic_in_seed():
    assert torch.equal(void_and_cluster(32, seed=7), void_and_cluster(32, seed=7))
    assert not torch.equal(void_and_cluster(32, seed=7), void_and_cluster(32, seed=8))
    assert not torch.equal(void_and_cluster(32, seed=7), void_and_cluster(32, seed=7, sigma=1.9))


# ---- vector masks -----------------------------------------------------------------------------


def test_vector_channels_are_permutations_of_the_initial_values(small_vector_mask):
    d, t, _ = small_vector_mask.shape
    assert small_vector_mask.shape == (4, 32, 32) and small_vector_mask.dtype == torch.float32
    for channel in small_vector_mask:
        assert torch.equal(torch.sort(channel.flatten()).values, _stratified(t * t))


def test_vector_energy_below_white_control(small_vector_mask):
    white = [vector_mask_energy(_shuffled(small_vector_mask, s)) for s in range(12)]
    mean, std = float(np.mean(white)), float(np.std(white, ddof=1))
    assert vector_mask_energy(small_vector_mask) < mean - 6 * std


def _gf_energy_twin(values: np.ndarray, size: int) -> float:
    """Slow twin of :func:`vector_mask_energy` at its defaults, from Georgiev & Fajardo 2016,
    "Blue-noise dithered sampling" (SIGGRAPH talk), eq. 2: every ordered pair of distinct pixels
    (p, q) of the torus, ``exp(-|p - q|^2 / sigma_i^2 - |v_p - v_q|^(D/2) / sigma_s^2)`` with the
    paper's sigma_i = 2.1 and sigma_s = 1, truncated to ``|p - q| <= 3 sigma_i`` (the documented
    window). ``values [T * T, D]``, pixel ``y * T + x``. Shares nothing with bnerr.masks."""
    sigma_i, sigma_s, radius = 2.1, 1.0, 3.0
    dims = values.shape[1]
    rows = values.tolist()
    total = 0.0
    for p in range(size * size):
        py, px = divmod(p, size)
        for q in range(size * size):
            qy, qx = divmod(q, size)
            ay, ax = abs(py - qy), abs(px - qx)
            r2 = min(ay, size - ay) ** 2 + min(ax, size - ax) ** 2  # the shorter way round
            if p == q or r2 > (radius * sigma_i) ** 2:
                continue
            dist = math.sqrt(sum((a - b) ** 2 for a, b in zip(rows[p], rows[q])))
            total += math.exp(-r2 / sigma_i**2 - dist ** (dims / 2) / sigma_s**2)
    return total


def test_vector_mask_energy_equals_its_slow_twin():
    size = 16
    for dims, seed in ((2, 0), (3, 1), (4, 2)):
        values = np.random.default_rng(seed).random((size * size, dims))
        mask = torch.from_numpy(values.T.reshape(dims, size, size).copy())
        assert vector_mask_energy(mask) == pytest.approx(_gf_energy_twin(values, size), rel=1e-12)


def test_swap_gain_matches_the_energy_difference():
    # The fast batched energy change against the slow, obviously correct one: recompute E with
    # the twin (which shares neither the window nor the weights with bnerr.masks).
    size, dims = 16, 3
    rng = np.random.default_rng(0)
    values = rng.random((size * size, dims))
    dy, dx, weight, reach = _gf_window(2.1, 3.0)
    table = np.zeros((2 * reach + 1, 2 * reach + 1))
    table[dy + reach, dx + reach] = weight
    p = np.array([0, 17, 40, 100, 5])
    q = np.array([1, 200, 43, 100 + 3 * 16 + 2, 250])  # neighbours, far, inside and outside window

    def energy(v: np.ndarray) -> float:
        return _gf_energy_twin(v, size)

    gains = _swap_gain(values, p, q, (dy, dx, weight), table, size, 1.0)
    before = energy(values)
    for k in range(p.size):
        swapped = values.copy()
        swapped[[p[k], q[k]]] = swapped[[q[k], p[k]]]
        assert gains[k] == pytest.approx(energy(swapped) - before, abs=1e-9)


def test_vector_mask_deterministic_in_seed():
    a = vector_mask(28, 2, seed=1, iterations=4)
    assert torch.equal(a, vector_mask(28, 2, seed=1, iterations=4))
    assert not torch.equal(a, vector_mask(28, 2, seed=2, iterations=4))


@pytest.mark.parametrize("dims", SHIPPED_VECTOR_DIMS)
def test_shipped_vector_masks(dims):
    mask = load_mask("vector", 64, dims)
    assert mask.shape == (dims, 64, 64) and mask.dtype == torch.float32
    white = [_shuffled(mask, s) for s in range(8)]
    energies = [vector_mask_energy(w) for w in white]
    assert vector_mask_energy(mask) < float(np.mean(energies)) - 6 * float(np.std(energies, ddof=1))
    for c, channel in enumerate(mask):
        assert torch.equal(torch.sort(channel.flatten()).values, _stratified(64 * 64))
        # each channel alone is bluer than its own shuffles (margin from their spread)
        control = [low_frequency_fraction(w[c]) for w in white]
        assert low_frequency_fraction(channel) < np.mean(control) - 4 * np.std(control, ddof=1)


# ---- offsets and tiling -----------------------------------------------------------------------


def test_r2_step():
    assert r2_step(64) == (48, 36)
    assert r2_step(128) == (97, 73)
    # The test's own plastic number: the real root of x^3 = x + 1 by Cardano's formula (Roberts
    # 2018, the R2 sequence), not the module's constant.
    g = ((9 + math.sqrt(69)) / 18) ** (1 / 3) + ((9 - math.sqrt(69)) / 18) ** (1 / 3)
    assert g**3 == pytest.approx(g + 1, abs=1e-14)
    for size in (1, 7, 64, 100, 512):
        assert r2_step(size) == (round(size / g), round(size / g**2))
    assert PLASTIC_NUMBER == pytest.approx(g, abs=1e-15)


@given(t=st.integers(0, 10_000), size=st.sampled_from([16, 64, 128, 97]))
def test_frame_offset_moves_by_a_constant_step(t, size):
    dy, dx = r2_step(size)
    oy, ox = frame_offset(t, size)
    assert (oy, ox) == ((t * dy) % size, (t * dx) % size)
    ny, nx = frame_offset(t + 1, size)
    assert ((ny - oy) % size, (nx - ox) % size) == (dy % size, dx % size)
    assert 0 <= oy < size and 0 <= ox < size
    assert frame_offset(0, size) == (0, 0)


@given(
    height=st.integers(1, 70),
    width=st.integers(1, 70),
    oy=st.integers(-200, 200),
    ox=st.integers(-200, 200),
)
def test_tile_mask_formula(height, width, oy, ox):
    mask = torch.arange(3 * 16 * 16, dtype=torch.float32).view(3, 16, 16)
    tiled = tile_mask(mask, height, width, (oy, ox))
    assert tiled.shape == (3, height, width) and tiled.dtype == mask.dtype
    y, x = height - 1, width // 2
    assert torch.equal(tiled[:, y, x], mask[:, (y + oy) % 16, (x + ox) % 16])
    assert torch.equal(tile_mask(mask[1], height, width, (oy, ox)), tiled[1])


def test_tile_mask_repeats_and_shifts():
    mask = load_mask("scalar", 64)
    tiled = tile_mask(mask, 150, 130)
    assert torch.equal(tiled[:64, :64], mask)
    assert torch.equal(tiled[64:128, 64:128], mask)
    assert torch.equal(tile_mask(mask, 64, 64, (48, 36)), torch.roll(mask, (-48, -36), (0, 1)))
    assert tile_mask(mask.double(), 3, 3).dtype == torch.float64


# ---- shipped data and input checks ------------------------------------------------------------


def test_shipped_listing_and_fresh_copies():
    shipped = shipped_masks()
    assert ("scalar", 64) in shipped and ("scalar", 128) in shipped
    assert all(("vector", 64, d) in shipped for d in SHIPPED_VECTOR_DIMS)
    a = load_mask("scalar", 64)
    a.zero_()
    assert load_mask("scalar", 64).sum() > 0


def test_load_mask_errors():
    with pytest.raises(UnknownNameError, match="unknown mask kind 'sobol': expected one of scal"):
        load_mask("sobol", 64)
    listed = r"mask \('scalar', 32\): expected one of the shipped .*load_mask\('scalar', 64\)"
    with pytest.raises(UnknownNameError, match=listed):
        load_mask("scalar", 32)
    with pytest.raises(UnknownNameError, match=r"mask \('vector', 64, 3\): expected one of the"):
        load_mask("vector", 64, 3)
    with pytest.raises(DtypeError, match="dims: expected an integer, got NoneType"):
        load_mask("vector", 64)
    with pytest.raises(ValueRangeError, match="dims: expected None for a scalar mask, got 2"):
        load_mask("scalar", 64, 2)


def test_bad_arguments():
    with pytest.raises(ValueRangeError, match="size: expected an integer >= 1, got 0"):
        void_and_cluster(0)
    with pytest.raises(ValueRangeError, match="size: expected an integer >= 1, got -4"):
        void_and_cluster(-4)
    with pytest.raises(ValueRangeError, match="size: expected an integer <= 512, got 1024"):
        void_and_cluster(1024)
    with pytest.raises(DtypeError, match="size: expected an integer, got float 64.0"):
        void_and_cluster(64.0)
    with pytest.raises(ValueRangeError, match="seed: expected an integer >= 0, got -1"):
        void_and_cluster(8, seed=-1)
    with pytest.raises(ValueRangeError, match=r"sigma: expected a value in \[0.1, 100.0\], got 0"):
        void_and_cluster(8, sigma=0.0)
    with pytest.raises(ValueRangeError, match="dims: expected an integer >= 2, got 1"):
        vector_mask(32, 1)
    with pytest.raises(ValueRangeError, match=r"dims: expected an integer in \[2, 16\], got 17"):
        vector_mask(32, 17)
    with pytest.raises(ValueRangeError, match="size: expected an integer >= 14, got 8"):
        vector_mask(8, 2)
    with pytest.raises(ValueRangeError, match=r"iterations: expected an integer >= 1, got 0"):
        vector_mask(32, 2, iterations=0)
    with pytest.raises(ValueRangeError, match="t: expected an integer >= 0, got -1"):
        frame_offset(-1, 64)
    with pytest.raises(ValueRangeError, match="size: expected an integer >= 1, got 0"):
        r2_step(0)


def test_tile_mask_bad_arguments():
    square = r"mask: expected \[T, T\] or \[D, T, T\] with T >= 1, got shape \[4, 5\]"
    with pytest.raises(ShapeError, match=square):
        tile_mask(torch.zeros(4, 5), 8, 8)
    with pytest.raises(ShapeError, match=r"got shape \[1, 2, 4, 4\]"):
        tile_mask(torch.zeros(1, 2, 4, 4), 8, 8)
    with pytest.raises(DtypeError, match="mask: expected dtype .*, got int64"):
        tile_mask(torch.zeros(4, 4, dtype=torch.int64), 8, 8)
    with pytest.raises(DtypeError, match="mask: expected a torch.Tensor, got ndarray"):
        tile_mask(np.zeros((4, 4)), 8, 8)
    with pytest.raises(ValueRangeError, match="height: expected an integer >= 1, got 0"):
        tile_mask(torch.zeros(4, 4), 0, 8)
    pair = r"offset: expected a pair of integers \(oy, ox\), got \(1.5, 0\)"
    with pytest.raises(DtypeError, match=pair):
        tile_mask(torch.zeros(4, 4), 8, 8, (1.5, 0))
    with pytest.raises(ShapeError, match=r"mask: expected 3 dimensions \[D, T, T\]"):
        vector_mask_energy(torch.zeros(16, 16))
    with pytest.raises(ValueRangeError, match="mask: expected T >= 13 for this kernel, got 12"):
        vector_mask_energy(torch.zeros(2, 12, 12))


def test_vector_energy_of_a_constant_mask_is_the_kernel_sum():
    # all vectors equal: every value term is exp(0) = 1, so E = T^2 * (sum of pixel weights)
    _, _, weight, _ = _gf_window(2.1, 3.0)
    assert vector_mask_energy(torch.full((3, 16, 16), 0.25)) == pytest.approx(256 * weight.sum())
    cut2 = (3.0 * 2.1) ** 2
    inside = [(i, j) for i in range(-7, 8) for j in range(-7, 8) if 0 < i * i + j * j <= cut2]
    assert weight.size == len(inside)
