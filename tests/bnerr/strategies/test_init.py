"""Tests for bnerr.strategies as a whole: the names, make_strategy and estimate_bytes, the
invariants every strategy keeps (determinism, typed errors, the frame's own clock, the device), and
the rivals' raw MSE against white's on the analytic integrand and on a small real render."""

import pytest
import torch

from bnerr import errors, strategies
from bnerr.errors import (
    DtypeError,
    MemoryLimitError,
    ShapeError,
    UnknownNameError,
    ValueRangeError,
)
from bnerr.frame import Frame
from bnerr.hashing import lowbias32_host
from bnerr.masks.stbn import load_stbn
from bnerr.metrics import not_worse
from bnerr.strategies import (
    OWN_SAMPLERS,
    STRATEGIES,
    VARIANTS,
    BNDSStrategy,
    OracleStrategy,
    dithered,
    estimate_bytes,
    make_strategy,
    parse_variant,
    pixel_seeds,
    temporal,
    zorder,
)
from tests.bnerr.strategies._renders import (
    RAW_MARGIN,
    REAL_MARGIN,
    SIZE,
    hash_render,
    paired_ratio,
    pixels,
    shadow_errors,
    small_render_errors,
    tiles,
)


def test_names_are_sorted_and_complete():
    from bnerr.strategies.ldbn import LDBN128_SHIPPED, LDBN_BASE_STRATEGIES

    assert tuple(STRATEGIES) == tuple(sorted(STRATEGIES))
    assert set(STRATEGIES) == {
        *("white", "bnds", "temporal", "temporal_sort", "oracle", "vertical"),
        *("zsobol", "cycles_blue", "zsobol_t", "bnds_st", "temporal_zsobol"),
        *("ldbn", "ldbn_st", "ldbn_fast", "ldbn_atrous", "temporal_ldbn"),
        *("openqmc_sobolbn", "openqmc_latticebn"),
        *(("ldbn128",) if LDBN128_SHIPPED else ()),
        *(cls.label for cls in LDBN_BASE_STRATEGIES),
        *VARIANTS,
    }
    for name in VARIANTS:
        base, options = parse_variant(name)
        assert base + options.suffix == name and not options.plain
    assert set(OWN_SAMPLERS) <= set(STRATEGIES)


def test_pixel_seeds_are_distinct_32bit_and_keyed():
    a = pixel_seeds(37, 53, key=5)
    assert a.shape == (37, 53) and a.dtype == torch.int64
    assert a.unique().numel() == 37 * 53
    assert int(a.min()) >= 0 and int(a.max()) < 2**32
    assert torch.equal(a, pixel_seeds(37, 53, key=5))
    assert (a != pixel_seeds(37, 53, key=6)).float().mean() > 0.99
    # Bit-exact against a pure-Python lowbias32 (the int32 wrap-around the fast version relies on).
    key = 2**32 - 700
    want = [lowbias32_host(i + key) for i in range(37 * 53)]
    assert pixel_seeds(37, 53, key=key).reshape(-1).tolist() == want


@pytest.mark.parametrize("name", STRATEGIES)
def test_same_arguments_give_identical_frames(name):
    outs = []
    for _ in range(2):
        if name == "bnds":  # a random vector mask: the test must not depend on the shipped ones
            mask = torch.rand(2, 64, 64, generator=torch.Generator().manual_seed(1))
            strategy = BNDSStrategy(9, 11, seed=4, mask=mask)
        else:
            strategy = make_strategy(name, 9, 11, seed=4, K=3, spp=4)
        frames = [strategy.frame(t, hash_render()) for t in range(3)]
        outs.append(torch.stack([f.color for f in frames]))
        assert strategy.overhead_ms >= 0 and frames[-1].timings["strategy"] == strategy.overhead_ms
    assert torch.equal(outs[0], outs[1])


def test_bad_input_raises_typed_errors():
    with pytest.raises(UnknownNameError, match=r"unknown strategy 'blue'"):
        make_strategy("blue", 8, 8)
    with pytest.raises(UnknownNameError, match=r"unknown per-pixel sampler 'bnds'"):
        make_strategy("white", 8, 8, sampler="bnds")
    with pytest.raises(ValueRangeError, match=r"block: expected an integer in \[2, 8\], got 9"):
        make_strategy("temporal", 8, 8, block=9)
    with pytest.raises(ValueRangeError, match=r"height: expected an integer >= 1, got 0"):
        make_strategy("white", 0, 8)
    with pytest.raises(
        UnknownNameError, match=r"mask \('scalar', 32\): expected one of the shipped masks"
    ):
        make_strategy("temporal", 8, 8, mask_size=32)
    strategy = make_strategy("white", 8, 8)
    wrong = r"render: expected a 8 x 8 frame \(width x height\), got 4 x 4"
    with pytest.raises(ShapeError, match=wrong):
        strategy.frame(0, lambda seeds, sampler: Frame(color=torch.zeros(3, 4, 4)))
    with pytest.raises(DtypeError, match=r"render: expected a Frame, got Tensor"):
        strategy.frame(0, lambda seeds, sampler: torch.zeros(3, 8, 8))
    with pytest.raises(ValueRangeError, match=r"t: expected an integer >= 0, got -1"):
        strategy.frame(-1, hash_render())


def test_seeds_are_bit_identical_to_the_committed_results():
    # Golden sums of the seed images white, temporal, oracle (K=2) and bnds hand the renderer in
    # frames 0..2 at 5x7, seed set 3: the results in results/ were measured with these seeds.
    seen = []

    def render(seeds, sampler):
        seen.append(seeds.clone())
        return Frame(color=((seeds % 1000).float() / 1000)[None].expand(3, 5, 7).contiguous())

    for name in ("white", "temporal", "oracle", "bnds"):
        strategy = make_strategy(name, 5, 7, seed=3, K=2)
        for t in range(3):
            strategy.frame(t, render)
    assert [int(s.sum()) for s in seen] == [
        70358823516, 81288201629, 65263942431, 57871870507, 57871870507, 57871870507,
        75462953130, 65660522734, 85864484647, 85987330565, 69227019401, 85572368527,
        85140353968, 72305712353, 80625497681,
    ]  # fmt: skip
    assert seen[0].reshape(-1)[:4].tolist() == [652237301, 1506559471, 385227796, 65317854]


def test_render_time_comes_from_the_frames_own_clock():
    # One stopwatch per render: the strategy sums the renders' timings["render"] and times only
    # the whole call; the overhead is the rest, never negative.
    oracle = make_strategy("oracle", 6, 6, K=3)
    out = oracle.frame(0, hash_render())  # each candidate reports 1.0 ms
    assert out.timings["render"] == 3.0 and out.timings["strategy"] == oracle.overhead_ms >= 0

    def slow(seeds, sampler):
        import time

        time.sleep(0.4)
        return Frame(color=torch.zeros(3, 6, 6), timings={"render": 400.0})

    # Had the render's 400 ms not been subtracted, the overhead would be at least that; half of
    # it leaves room for a loaded machine's scheduling (a timing, not a speed claim).
    white = make_strategy("white", 6, 6)
    out = white.frame(0, slow)
    assert out.timings["render"] == 400.0 and white.overhead_ms < 200.0
    silent = white.frame(1, lambda seeds, sampler: Frame(color=torch.zeros(3, 6, 6)))
    assert "render" not in silent.timings and silent.timings["strategy"] >= 0


def test_absurd_sizes_are_refused_with_an_estimate_before_allocating(monkeypatch):
    need = estimate_bytes("temporal", 40000, 40000)
    if errors.available_memory(torch.device("cpu")) < need:  # this machine, as it is
        with pytest.raises(MemoryLimitError, match=r"temporal strategy at 40000 x 40000"):
            make_strategy("temporal", 40000, 40000)
    allocated = []
    monkeypatch.setattr(temporal, "pixel_seeds", lambda *a, **k: allocated.append(a))
    monkeypatch.setattr(errors, "available_memory", lambda device=None: 64 * 2**30)
    with pytest.raises(MemoryLimitError) as err:
        make_strategy("temporal", 40000, 40000)
    assert str(err.value) == (
        "temporal strategy at 40000 x 40000 (176 bytes per pixel): expected a size that fits in "
        "memory (at most 57.6 GiB of the 64 GiB available), got an estimate of 262 GiB"
    )
    assert not allocated
    with pytest.raises(ValueRangeError, match=r"expected at most 2\^31 pixels"):
        make_strategy("white", 50000, 50000)
    monkeypatch.setattr(errors, "available_memory", lambda device=None: 10_000)
    with pytest.raises(MemoryLimitError, match=r"oracle strategy at 8 x 8"):
        OracleStrategy(8, 8, mask=torch.zeros(64, 64), K=32)
    assert estimate_bytes("oracle", 8, 8, K=32) > 10_000 > estimate_bytes("white", 8, 8)


def test_estimates_grow_with_the_frame_and_the_candidates():
    assert estimate_bytes("white", 1080, 1920) == 1080 * 1920 * (64 + 44)
    assert estimate_bytes("temporal", 4, 4) == estimate_bytes("temporal_sort", 4, 4)
    assert estimate_bytes("oracle", 4, 4, K=8) < estimate_bytes("oracle", 4, 4, K=32)
    with pytest.raises(UnknownNameError):
        estimate_bytes("blue", 4, 4)


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
def test_state_follows_the_render_device():
    cpu = make_strategy("temporal", 33, 47, seed=1)
    gpu = make_strategy("temporal", 33, 47, seed=1)
    render = hash_render(special=True)
    for t in range(5):
        a = cpu.frame(t, render)
        b = gpu.frame(t, lambda s, smp: hash_render(special=True)(s.cuda(), smp).to("cuda"))
        # special=True plants NaN and inf pixels (NaN where NaN); the hash's float arithmetic
        # rounds differently in the last bit on CUDA (measured on an H200: at most 1.2e-7)
        torch.testing.assert_close(b.color.cpu(), a.color, equal_nan=True)
    assert gpu.seeds.device.type == "cuda" and torch.equal(gpu.seeds.cpu(), cpu.seeds)


RIVALS = (
    *("zsobol", "cycles_blue", "zsobol_t", "bnds_st", "temporal_zsobol"),
    *("ldbn", "ldbn_st", "ldbn_fast", "ldbn_atrous", "temporal_ldbn"),
    *("openqmc_sobolbn", "openqmc_latticebn"),
)


def _samples(seeds: torch.Tensor, sampler, spp: int) -> torch.Tensor:
    """Every sample index's first four dimensions for every pixel: ``[spp, H * W, 4]``."""
    h, w = seeds.shape
    flat = seeds.reshape(-1)
    return torch.stack(
        [sampler.sample(flat, torch.full_like(flat, i), 0, 4, pixels(h, w)) for i in range(spp)]
    )


@pytest.mark.parametrize("name", RIVALS)
def test_rivals_are_deterministic_and_seed_sets_differ(name):
    def run(seed):
        record: list = []
        strategy = make_strategy(name, 10, 13, seed=seed, spp=4, dimensions=4)
        for t in range(3):
            strategy.frame(t, hash_render(record))
        return [(s, _samples(s, smp, 4)) for s, smp in record]

    a, b, other = run(5), run(5), run(6)
    for (seeds_a, values_a), (seeds_b, values_b) in zip(a, b, strict=True):
        assert torch.equal(seeds_a, seeds_b) and torch.equal(values_a, values_b)
    assert not torch.equal(a[-1][1], other[-1][1])  # another seed set, other samples


@pytest.mark.parametrize("name", RIVALS)
def test_rivals_render_with_their_own_sampler_whatever_they_are_given(name):
    record: list = []
    for sampler in ("owen_sobol", "white"):
        strategy = make_strategy(name, 8, 8, sampler=sampler, spp=2)
        strategy.frame(0, hash_render(record))
        assert strategy.sampler_name == OWN_SAMPLERS[name] == record[-1][1].name
    assert make_strategy("white", 8, 8, sampler="white").sampler_name == "white"
    assert make_strategy("temporal", 8, 8).sampler_name == "owen_sobol"


def test_rivals_refuse_a_missing_or_unusable_spp():
    for name in ("zsobol", "zsobol_t", "temporal_zsobol"):
        with pytest.raises(ValueRangeError, match=rf"spp: expected a power of two for {name}"):
            make_strategy(name, 8, 8, spp=6)
        with pytest.raises(ValueRangeError, match=r"spp: expected the samples per pixel"):
            make_strategy(name, 8, 8)
    with pytest.raises(ValueRangeError, match=r"spp: expected the samples per pixel"):
        make_strategy("cycles_blue", 8, 8)
    with pytest.raises(ValueRangeError, match=r"channels: expected an even number, got 3"):
        strategies.BNDSSTStrategy(8, 8, stbn=load_stbn("vector", 64, 32), channels=3)
    with pytest.raises(ShapeError, match=r"stbn: expected \[F, 2, T, T\]"):
        strategies.BNDSSTStrategy(8, 8, stbn=torch.zeros(2, 64, 64))


@pytest.mark.parametrize("name", RIVALS)
def test_rivals_refuse_absurd_sizes_before_allocating(monkeypatch, name):
    allocated = []
    for module in (dithered, zorder, temporal):
        for helper in ("pixel_seeds", "zsobol_keys", "cycles_keys", "load_stbn"):
            if hasattr(module, helper):
                monkeypatch.setattr(module, helper, lambda *a, **k: allocated.append(a))
    monkeypatch.setattr(errors, "available_memory", lambda device=None: 64 * 2**30)
    per_pixel = estimate_bytes(name, 1, 1)
    like = {"temporal_zsobol": "temporal", "temporal_ldbn": "temporal", "cycles_blue": None}
    like = like.get(name, "white")
    assert per_pixel == (64 + 96 if like is None else estimate_bytes(like, 1, 1))
    with pytest.raises(MemoryLimitError) as err:
        make_strategy(name, 30000, 30000, spp=4)
    assert str(err.value).startswith(
        f"{name} strategy at 30000 x 30000 ({per_pixel} bytes per pixel): expected a size that "
        "fits in memory"
    )
    assert not allocated


@pytest.fixture(scope="module")
def analytic_rivals():
    """The soft-shadow errors of white and the rivals (1 spp: every Z-order block is one index)."""
    names = ("white", *RIVALS)
    return {name: shadow_errors(make_strategy(name, SIZE, SIZE, seed=0, spp=1)) for name in names}


@pytest.mark.parametrize("name", RIVALS)
def test_rivals_raw_mse_is_not_worse_than_white_on_the_analytic_integrand(analytic_rivals, name):
    # Each pixel's single sample is uniform under every rival, so the raw MSE must not exceed
    # white's by more than RAW_MARGIN (non-inferiority: the interval's upper end below 1 + d).
    ratio = paired_ratio(
        tiles(analytic_rivals[name].square()),
        tiles(analytic_rivals["white"].square()),
        1 - 0.05 / len(RIVALS),
    )
    assert not_worse(ratio, RAW_MARGIN), (name, str(ratio))


_BNDS_RAW = (
    "bnds_st renders with the bnds sampler, which has about twice white's raw MSE here: measured "
    "with this test's own run (direct 48x48, 4 spp, 8 frames, 144 tiles, Bonferroni level 1 - "
    "0.05/12, the 12 rivals compared) raw MSE / white 2.286 [1.622, 2.950]; one Owen-Sobol "
    "sequence shared by every pixel "
    "and Cranley-Patterson rotated loses the per-pixel Owen scrambling white's sequences have "
    "(issue 13, part 5 investigates whether this is inherent)"
)

_LATTICE_RAW = (
    "openqmc_latticebn renders a rank-1 lattice rotated per pixel by OpenQMC's keys (a "
    "Cranley-Patterson rotation, as bnds), bit for bit OpenQMC's: on this render raw MSE / white "
    "1.581 [1.215, 1.947] (this test's own run, tile-paired, Bonferroni level 1 - 0.05/12); "
    "openqmc_sobolbn, Owen-scrambled Sobol under the same tables, is not worse"
)
#: The rivals whose raw MSE is measured above white's on the small render, and why.
_RAW_XFAIL = {"bnds_st": _BNDS_RAW, "openqmc_latticebn": _LATTICE_RAW}


def test_the_xfail_reasons_quote_the_correction_the_test_applies():
    """Issue 54: the reasons quoted a best-of-11 correction where 12 rivals are compared."""
    for reason in _RAW_XFAIL.values():
        assert f"1 - 0.05/{len(RIVALS)}" in reason, reason


@pytest.fixture(scope="module")
def real_raw_errors(one_thread):
    """Per-tile raw MSE of white and the rivals on small real renders: name -> ``[tiles]``."""
    return small_render_errors(("white", *RIVALS))


@pytest.mark.slow
@pytest.mark.parametrize(
    "name",
    [
        pytest.param(
            n, marks=pytest.mark.xfail(strict=True, raises=AssertionError, reason=_RAW_XFAIL[n])
        )
        if n in _RAW_XFAIL
        else n
        for n in RIVALS
    ],
)
def test_rivals_raw_mse_is_not_worse_than_white_on_a_small_render(real_raw_errors, name):
    level = 1 - 0.05 / len(RIVALS)
    ratio = paired_ratio(real_raw_errors[name], real_raw_errors["white"], level)
    assert not_worse(ratio, REAL_MARGIN), (name, str(ratio))
