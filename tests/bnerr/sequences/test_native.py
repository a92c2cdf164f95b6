"""Tests of bnerr/sequences/native.py: the C kernels of white noise, the Owen-Sobol, ZSobol,
temporal Z-order, Cycles and LDBN samplers against their torch paths, bit for bit, over several
films (or key tiles), spp, first dimensions, dimension counts, seeds and lane orders; the dispatch
(CPU only) and the fallback when the library is unavailable.

The native comparisons skip, with the reason, when the library cannot be built or loaded here
(no C compiler, or ``BNERR_NATIVE=0``); the fallback test runs everywhere.
"""

import importlib

import pytest
import torch

from bnerr.sequences import LDBNKeys, LDBNSampler, cycles_keys, make_sampler, native, zsobol_keys

owen_sobol_module = importlib.import_module("bnerr.sequences.owen_sobol")
zsobol_module = importlib.import_module("bnerr.sequences.zsobol")
zsobol_t_module = importlib.import_module("bnerr.sequences.zsobol_t")
cycles_module = importlib.import_module("bnerr.sequences.cycles")
ldbn_module = importlib.import_module("bnerr.sequences.ldbn")
white_module = importlib.import_module("bnerr.sequences.white")
openqmc_module = importlib.import_module("bnerr.sequences.openqmc")
SELF_CHECKED = (
    white_module, owen_sobol_module, zsobol_module, zsobol_t_module, cycles_module, ldbn_module,
    openqmc_module,
)  # fmt: skip


@pytest.fixture
def kernels():
    loaded = native.LIBRARY.load()
    if loaded is None:
        pytest.skip(f"native sampler kernels unavailable: {native.LIBRARY.status()}")
    return loaded


def _torch_path(monkeypatch, sampler, *args):
    """The sampler's values with the native path turned off."""
    with monkeypatch.context() as patch:
        patch.setattr(native, "uses_native", lambda *tensors: False)
        return sampler.sample(*args)


def _lanes(keys: torch.Tensor, spp: int, pixels: int, seed: int, pixel_major: bool):
    gen = torch.Generator().manual_seed(seed)
    flat = keys.reshape(-1)
    pick = torch.randint(0, flat.numel(), (pixels,), generator=gen)
    if pixel_major:  # the renderer's order: every sample of a pixel in a row
        key = flat[pick].repeat_interleave(spp)
        index = torch.arange(spp).repeat(pixels)
    else:
        key = flat[pick.repeat_interleave(spp)[torch.randperm(pixels * spp, generator=gen)]]
        index = torch.randint(0, spp, (pixels * spp,), generator=gen)
    return key, index


CASES = [  # width, height, spp, dim, count, seed
    (64, 64, 16, 0, 8, 0),
    (37, 21, 8, 3, 5, -5),
    (300, 7, 1, 1, 1, 2**31 - 1),
    (1920, 1080, 32, 0, 12, 123),
    (1, 1, 4, 6, 3, 9),
]


@pytest.mark.parametrize("pixel_major", [True, False])
@pytest.mark.parametrize(("width", "height", "spp", "dim", "count", "seed"), CASES)
def test_zsobol_samplers_match_torch_bit_for_bit(
    kernels, monkeypatch, width, height, spp, dim, count, seed, pixel_major
):
    keys = zsobol_keys(height, width)
    key, index = _lanes(keys, spp, 97, seed & 0xFFFF, pixel_major)
    samplers = [
        make_sampler("zsobol", width=width, height=height, spp=spp, seed=seed),
        make_sampler("zsobol_t", width=width, height=height, spp=spp, frame=5, seed=seed),
        make_sampler("zsobol_t", width=width, height=height, spp=spp, frame=2**11 + 1,
                     frames=8, seed=seed),
    ]  # fmt: skip
    for sampler in samplers:
        got = sampler.sample(key, index, dim, count)
        want = _torch_path(monkeypatch, sampler, key, index, dim, count)
        assert torch.equal(got, want), sampler


@pytest.mark.parametrize(("width", "height", "spp", "dim", "count", "seed"), CASES)
def test_white_owen_sobol_and_cycles_match_torch_bit_for_bit(
    kernels, monkeypatch, width, height, spp, dim, count, seed
):
    key, index = _lanes(cycles_keys(height, width, seed), spp, 97, seed & 0xFFFF, True)
    random_seeds = torch.randint(-(2**40), 2**40, key.shape, generator=torch.Generator())
    runs = [
        (make_sampler("white"), random_seeds),
        (make_sampler("owen_sobol"), random_seeds),
        (make_sampler("cycles_pure", spp=spp, seed0=seed), key),
        (make_sampler("cycles_first", spp=spp, seed0=seed), key),
    ]
    for sampler, seeds in runs:
        got = sampler.sample(seeds, index, dim, count)
        want = _torch_path(monkeypatch, sampler, seeds, index, dim, count)
        assert torch.equal(got, want), sampler


def _ldbn_keys(levels: int, size: int, dims: int, seed0: int) -> LDBNKeys:
    gen = torch.Generator().manual_seed(size * 31 + dims)
    scramble = torch.randint(0, 1 << 24, (levels, size, size, dims), generator=gen)
    rank = torch.stack(
        [torch.randint(0, 1 << lv, (size, size, dims // 2), generator=gen) for lv in range(levels)]
    )
    return LDBNKeys(scramble.to(torch.int32), rank.to(torch.int32), seed0=seed0)


def _ldbn_lanes(spp: int, pixels: int, seed: int, index_range: tuple[int, int]):
    """Pixel-major lanes on and off the tile (negative and far pixels): spp indices each, the
    first at ``index_range[0]`` (the sample indices) or random in ``index_range``."""
    gen = torch.Generator().manual_seed(seed)
    pixel = torch.randint(-1000, 1000, (pixels, 2), generator=gen).repeat_interleave(spp, 0)
    seeds = torch.randint(-(2**40), 2**40, (pixels,), generator=gen).repeat_interleave(spp)
    low, high = index_range
    if high - low == spp:
        index = torch.arange(low, high).repeat(pixels)
    else:
        index = torch.randint(low, high, (pixels * spp,), generator=gen)
    return seeds, index, pixel


LDBN_CASES = [  # levels, size, dims, spp, offset, dim, count, index range
    (5, 64, 8, 16, (24, 40), 0, 20, (0, 16)),  # the renderer's call
    (3, 5, 4, 3, (2, 4), 1, 6, (0, 3)),  # odd tile, odd spp, odd first dim across the keys
    (4, 7, 6, 8, (0, 0), 0, 5, (0, 32)),  # indices past the tile's spp, a pair cut short
    (2, 4, 2, 64, (3, 1), 0, 3, (0, 64)),  # spp past the last level
    (3, 4, 4, 4, (1, 1), 2, 3, (0, 1 << 20)),  # past the shared table
    (3, 4, 4, 4, (0, 2), 0, 4, (-(2**33), 2**33)),  # negative and 33-bit indices
    (3, 3, 4, 2, (0, 0), 4, 4, (0, 2)),  # every dim past the keys
]


@pytest.mark.parametrize(("levels", "size", "dims", "spp", "offset", "dim", "count", "indices"),
                         LDBN_CASES)  # fmt: skip
def test_ldbn_matches_torch_bit_for_bit(
    kernels, monkeypatch, levels, size, dims, spp, offset, dim, count, indices
):
    seed0 = -(2**35) + size
    sampler = LDBNSampler(_ldbn_keys(levels, size, dims, seed0), spp=spp, offset=offset)
    seeds, index, pixel = _ldbn_lanes(spp, 67, size, indices)
    native_out = torch.empty(count, seeds.shape[0])
    assert ldbn_module._native_values(sampler, (seeds, index, pixel), dim, native_out, kernels)
    want = _torch_path(monkeypatch, sampler, seeds, index, dim, count, pixel)
    assert torch.equal(native_out.T, want)
    assert torch.equal(sampler.sample(seeds, index, dim, count, pixel), want)


@pytest.mark.parametrize(
    ("frame", "high", "dim", "count"), [(0, 64, 0, 8), (2**32 - 1, 2**31, 3, 6)]
)
def test_openqmc_sobolbn_matches_torch_bit_for_bit(kernels, monkeypatch, frame, high, dim, count):
    gen = torch.Generator().manual_seed(frame & 0xFF)
    pixel = torch.randint(-1000, 1000, (4099, 2), generator=gen)
    index = torch.randint(0, high, (4099,), generator=gen)
    sampler = make_sampler("openqmc_sobolbn", frame=frame)
    seeds = torch.zeros_like(index)
    got = sampler.sample(seeds, index, dim, count, pixel)
    want = _torch_path(monkeypatch, sampler, seeds, index, dim, count, pixel)
    assert torch.equal(got, want)


def test_results_do_not_depend_on_the_thread_count(kernels):
    key, index = _lanes(zsobol_keys(256, 256), 16, 4096, 3, True)
    seeds, ldbn_index, pixel = _ldbn_lanes(16, 4096, 3, (0, 16))
    runs = [
        (make_sampler("zsobol", width=256, height=256, spp=16), (key, index, 0, 6)),
        (LDBNSampler(_ldbn_keys(5, 64, 8, 0), spp=16), (seeds, ldbn_index, 0, 12, pixel)),
        (make_sampler("white"), (key, index, 1, 7)),
        (make_sampler("openqmc_sobolbn"), (seeds, ldbn_index, 1, 7, pixel)),
    ]
    before = torch.get_num_threads()
    try:
        for sampler, args in runs:
            torch.set_num_threads(1)
            one = sampler.sample(*args)
            torch.set_num_threads(max(2, before))
            many = sampler.sample(*args)
            assert torch.equal(one, many), sampler
    finally:
        torch.set_num_threads(before)


def test_self_checks_pass(kernels):
    for module in SELF_CHECKED:
        assert module._self_check(kernels), module.__name__


def test_kernel_refuses_bad_sizes(kernels):
    out = torch.empty(2, 4)
    seeds = torch.zeros(4, dtype=torch.int64)
    assert not native.native_zsobol(
        kernels, (seeds, seeds), 0, [0] * 4, torch.zeros(96, dtype=torch.uint8), (2, 40, 3), out
    )
    pixel = torch.zeros(4, 2, dtype=torch.int64)
    odd = torch.zeros(2, 2, 3, dtype=torch.int32), torch.zeros(2, 2, 1, dtype=torch.int32), None
    assert not native.native_ldbn(
        kernels, (seeds, seeds, pixel), 0, odd, (0, 0), ([0] * 3, [0] * 3), out
    )


def test_without_the_library_the_torch_path_runs(monkeypatch):
    monkeypatch.setattr(native.LIBRARY, "load", lambda: None)
    monkeypatch.setattr(zsobol_module, "_native_kernels", lambda: None)
    sampler = make_sampler("zsobol", width=8, height=8, spp=4)
    key, index = _lanes(zsobol_keys(8, 8), 4, 5, 0, True)
    out = sampler.sample(key, index, 0, 4)
    assert out.shape == (20, 4) and out.dtype == torch.float32
    monkeypatch.setattr(ldbn_module, "_native_kernels", lambda: None)
    seeds, index, pixel = _ldbn_lanes(4, 5, 0, (0, 4))
    out = LDBNSampler(_ldbn_keys(3, 4, 4, 0), spp=4).sample(seeds, index, 0, 6, pixel)
    assert out.shape == (20, 6) and out.dtype == torch.float32


def test_dispatch_is_cpu_only():
    cpu = torch.zeros(3, dtype=torch.int64)
    assert native.uses_native(cpu, cpu)
    assert not native.uses_native(cpu, torch.zeros(3, device="meta"))
