"""OpenQMC's sobolbn and latticebn: bit for bit against the vectors OpenQMC's own C++ printed
(tests/bnerr/sequences/openqmc_upstream/: driver.cpp, vectors.npz, README.md), the shipped tables,
the sampler seam's dimension layout, the nets every power-of-two prefix keeps, and bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from bnerr.errors import DtypeError, ShapeError, UnknownNameError, ValueRangeError
from bnerr.resources import load_array
from bnerr.sequences import (
    SAMPLERS,
    OpenQMCLatticeBNSampler,
    OpenQMCSobolBNSampler,
    make_sampler,
    native,
    openqmc_draw,
    openqmc_float,
)

VECTORS = Path(__file__).parent / "openqmc_upstream" / "vectors.npz"
NAMES = ("sobolbn", "latticebn")


@pytest.fixture(scope="module")
def vectors():
    with np.load(VECTORS) as data:
        return {k: data[k] for k in data.files}


def _lane_tensors(lanes: np.ndarray) -> list[torch.Tensor]:
    return list(torch.from_numpy(lanes).T)


# ------------------------------------------------------------------------------------------------
# Bit for bit with OpenQMC's C++


@pytest.mark.parametrize("name", NAMES)
def test_words_and_floats_match_openqmc_bit_for_bit(vectors, name):
    lanes = vectors[f"{name}_lanes"]
    assert lanes.shape == (5760, 5)  # 24 pixels x 2 frames x 40 indices x 3 domain keys
    words = openqmc_draw(name, *_lane_tensors(lanes), size=4)
    assert np.array_equal(words.numpy(), vectors[f"{name}_words"].astype(np.int64))
    floats = openqmc_float(words).numpy().view(np.uint32)
    assert np.array_equal(floats, vectors[f"{name}_floats"])


@pytest.mark.parametrize("path", ["native", "torch"])
def test_the_sobolbn_sampler_gives_openqmcs_floats_on_both_paths(vectors, monkeypatch, path):
    # Pair k of the sampler is components 0 and 1 of newDomain(k): the vectors' lanes of keys
    # 0, 1 and 5 at frames 0 and 7, through the sampler seam (the C kernel on the CPU).
    if path == "torch":
        monkeypatch.setattr(native, "uses_native", lambda *tensors: False)
    elif native.LIBRARY.load() is None:
        pytest.skip(f"native sampler kernels unavailable: {native.LIBRARY.status()}")
    lanes = torch.from_numpy(vectors["sobolbn_lanes"])
    floats = vectors["sobolbn_floats"][:, :2]
    seen = 0
    for frame in lanes[:, 2].unique().tolist():
        sampler = OpenQMCSobolBNSampler(frame=frame)
        for key in lanes[:, 4].unique().tolist():
            rows = (lanes[:, 2] == frame) & (lanes[:, 4] == key)
            x, y, index = lanes[rows, 0], lanes[rows, 1], lanes[rows, 3]
            pixel = torch.stack([y, x], 1)
            got = sampler.sample(torch.zeros_like(index), index, 2 * key, 2, pixel)
            assert np.array_equal(got.numpy().view(np.uint32), floats[rows.numpy()])
            seen += int(rows.sum())
    assert seen == lanes.shape[0]


@pytest.mark.parametrize("name", NAMES)
def test_smaller_draws_are_the_first_components_of_larger_ones(vectors, name):
    lanes = _lane_tensors(vectors[f"{name}_lanes"][:500])
    full = openqmc_draw(name, *lanes, size=4)
    for size in (1, 2, 3):
        assert torch.equal(openqmc_draw(name, *lanes, size=size), full[:, :size])


def test_float_conversion_matches_openqmc_on_edge_words(vectors):
    words = torch.from_numpy(vectors["float_words"].astype(np.int64))
    bits = openqmc_float(words).numpy().view(np.uint32)
    assert np.array_equal(bits, vectors["float_bits"])
    top = openqmc_float(torch.tensor([0xFFFFFFFF, 0xFFFFFF80, 0]))
    assert top.tolist() == [1 - 2.0**-24, 1 - 2.0**-24, 0.0]


def test_shipped_tables_are_openqmcs():
    # the first words of include/oqmc/data/{sobol,lattice}/{keys,ranks}.txt at commit 294d656
    for base, key, rank in (("sobol", 0x818A1C22, 0x71), ("lattice", 0x9A6F0F84, 0x10)):
        keys = load_array(f"openqmc_{base}_keys.npy", np.uint32, (256, 256))
        ranks = load_array(f"openqmc_{base}_ranks.npy", np.uint8, (256, 256))
        assert (int(keys[0, 0]), int(ranks[0, 0])) == (key, rank)
        assert int(ranks.max()) < 128  # keys optimized at 128 spp: ranks permute 128 indices
        assert len(np.unique(keys)) > 65000


#: SHA-256 of OpenQMC's own table files at commit 294d656
#: (``include/oqmc/data/{sobol,lattice}/{keys,ranks}.txt``), taken from the upstream files.
UPSTREAM_TABLE_SHA256 = {
    ("sobol", "keys"): "5f5e4e12edccffc398a725671feaf6964f56e1cf6ae1d147f7327b3047fb7d1a",
    ("sobol", "ranks"): "7b99f3d0f3ae4bc8ec7d349321453b9056eddc650b71bbb7437e2688cdf5b39b",
    ("lattice", "keys"): "b67e66f013ccc1ce75d0e17881c87b20bd71e00b7951467c72f4e51b8ff1e4db",
    ("lattice", "ranks"): "14627f40fd755443a70f5ab3e4fc94147080b701fb0ad4235e8c8124fc38aff2",
}


@pytest.mark.parametrize(("base", "kind"), list(UPSTREAM_TABLE_SHA256))
def test_every_cell_of_the_shipped_tables_is_upstreams(base, kind):
    """Issue 54: the vectors touch 335 of the 65,536 cells of each table; the whole table,
    written back in the upstream file's own form (``0x%08xU,`` a line, table order), hashes to
    the upstream file's SHA-256."""
    import hashlib

    dtype = np.uint32 if kind == "keys" else np.uint8
    table = load_array(f"openqmc_{base}_{kind}.npy", dtype, (256, 256))
    text = "".join(f"0x{int(word):08x}U,\n" for word in table.reshape(-1))
    assert hashlib.sha256(text.encode()).hexdigest() == UPSTREAM_TABLE_SHA256[(base, kind)]


# ------------------------------------------------------------------------------------------------
# The sampler seam


def _pixel_lanes(h: int, w: int, spp: int) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    lane = torch.arange(h * w * spp)
    pix, index = lane // spp, lane % spp
    pixel = torch.stack([pix // w, pix % w], dim=1)
    return torch.zeros_like(lane), index, pixel


@pytest.mark.parametrize("cls", [OpenQMCSobolBNSampler, OpenQMCLatticeBNSampler])
def test_pair_k_is_components_0_and_1_of_domain_k(cls):
    seed, index, pixel = _pixel_lanes(5, 7, 4)
    sampler = cls(frame=-3)
    got = sampler.sample(seed, index, 1, 6, pixel)
    y, x = pixel[:, 0], pixel[:, 1]
    for j, d in enumerate(range(1, 7)):
        key = torch.tensor(d // 2)
        words = openqmc_draw(cls.openqmc, x, y, torch.tensor(-3), index, key, size=2)
        assert torch.equal(got[:, j], openqmc_float(words[:, d % 2])), d
    assert torch.equal(sampler.sample(seed, index, 4, 1, pixel)[:, 0], got[:, 3])


def test_the_seed_is_not_read_and_the_frame_moves_the_pattern():
    seed, index, pixel = _pixel_lanes(4, 4, 2)
    sampler = make_sampler("openqmc_sobolbn", frame=5)
    a = sampler.sample(seed, index, 0, 4, pixel)
    assert torch.equal(sampler.sample(seed + 12345, index, 0, 4, pixel), a)
    assert not torch.equal(make_sampler("openqmc_sobolbn", frame=6).sample(seed, index, 0, 4,
                                                                           pixel), a)  # fmt: skip
    low = make_sampler("openqmc_sobolbn", frame=-1).sample(seed, index, 0, 4, pixel)
    assert torch.equal(low, OpenQMCSobolBNSampler(frame=2**32 - 1).sample(seed, index, 0, 4, pixel))
    assert repr(sampler) == "OpenQMCSobolBNSampler(frame=5)"


def _is_net(x: torch.Tensor, y: torch.Tensor, m: int) -> bool:
    """Whether the 2^m u32 points fall one per elementary interval of every shape 2^a x 2^(m-a)."""
    for a in range(m + 1):
        cells = (x >> (32 - a) if a else 0) * (1 << (m - a)) + (y >> (32 - m + a) if m - a else 0)
        if torch.unique(cells).numel() != 1 << m:
            return False
    return True


@pytest.mark.parametrize("m", [1, 3, 5, 7])
def test_every_power_of_two_prefix_of_a_pixel_stays_stratified(m):
    """sobolbn: the first 2^m samples of each pixel form a (0, m, 2)-net in every domain (the rank
    is an XOR, the index shuffle and value scramble nested); latticebn: one per 1D stratum."""
    index = torch.arange(1 << m)
    for px, py, key in ((0, 0, 0), (77, 200, 1), (300, 9, 4)):
        lane = [torch.tensor(v) for v in (px, py, 11)]
        sobol = openqmc_draw("sobolbn", *lane, index, torch.tensor(key), size=2)
        assert _is_net(sobol[:, 0], sobol[:, 1], m)
        lattice = openqmc_draw("latticebn", *lane, index, torch.tensor(key), size=1)
        assert torch.unique(lattice[:, 0] >> (32 - m)).numel() == 1 << m


# ------------------------------------------------------------------------------------------------
# Registration and bad input


def test_registration_and_errors():
    assert SAMPLERS["openqmc_sobolbn"] is OpenQMCSobolBNSampler
    assert SAMPLERS["openqmc_latticebn"] is OpenQMCLatticeBNSampler
    seed, index, pixel = _pixel_lanes(2, 2, 2)
    sampler = OpenQMCLatticeBNSampler()
    with pytest.raises(ShapeError, match="pixel: expected a \\[N, 2\\] int64 tensor"):
        sampler.sample(seed, index, 0, 2)
    with pytest.raises(ValueRangeError, match=r"index: expected sample indices in \[0, 2147483648"):
        sampler.sample(seed, index + 2**31, 0, 2, pixel)
    with pytest.raises(DtypeError, match="frame: expected an int, got float"):
        OpenQMCSobolBNSampler(frame=1.0)
    t = torch.tensor([0, 1])
    with pytest.raises(UnknownNameError, match="unknown OpenQMC sampler 'pmjbn'"):
        openqmc_draw("pmjbn", t, t, t, t, t)
    with pytest.raises(ValueRangeError, match=r"size: expected an int in 1..4"):
        openqmc_draw("sobolbn", t, t, t, t, t, size=5)
    with pytest.raises(DtypeError, match="frame: expected dtype int64, got float32"):
        openqmc_draw("sobolbn", t, t, t.float(), t, t)
    with pytest.raises(ShapeError, match="x, y, frame, index, key: expected broadcastable"):
        openqmc_draw("sobolbn", t, t, t, torch.arange(3), t)
    with pytest.raises(ValueRangeError, match=r"index: expected sample indices in \[0, "):
        openqmc_draw("sobolbn", t, t, t, -t, t)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
def test_runs_on_cuda_and_agrees_with_cpu(vectors):
    for name in NAMES:
        lanes = [v.cuda() for v in _lane_tensors(vectors[f"{name}_lanes"])]
        words = openqmc_draw(name, *lanes, size=4)
        assert words.device.type == "cuda"
        assert np.array_equal(words.cpu().numpy(), vectors[f"{name}_words"].astype(np.int64))
        bits = openqmc_float(words).cpu().numpy().view(np.uint32)
        assert np.array_equal(bits, vectors[f"{name}_floats"])
    seed, index, pixel = _pixel_lanes(3, 5, 4)
    sampler = OpenQMCSobolBNSampler(frame=9)
    cpu = sampler.sample(seed, index, 0, 5, pixel)
    assert torch.equal(sampler.sample(seed.cuda(), index.cuda(), 0, 5, pixel.cuda()).cpu(), cpu)
