"""Tests for bnerr.strategies: the interface, seeds that stay a permutation, and the statistical
claims of the method on an analytic integrand (a moving soft-shadow edge)."""

import dataclasses
import math

import pytest
import torch
from kornia.filters import gaussian_blur2d

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
from bnerr.masks import frame_offset, load_mask, tile_mask
from bnerr.metrics import Estimate, blurred_mse, equivalent, not_worse, t_quantile
from bnerr.permute import histogram_select, luminance, sort_pass_reference
from bnerr.retarget import load_retarget
from bnerr.sequences import BNDSSampler, cycles_keys, ldbn_key_image, zsobol_2d, zsobol_keys
from bnerr.stbn import load_stbn
from bnerr.strategies import (
    OWN_SAMPLERS,
    STRATEGIES,
    VARIANTS,
    BNDSStrategy,
    OracleStrategy,
    TemporalOptions,
    dithered,
    estimate_bytes,
    make_strategy,
    parse_variant,
    pixel_seeds,
    temporal,
    zorder,
)

# --------------------------------------------------------------------------------------------------
# Cheap stand-in renders


def _hash_render(record: list | None = None, special: bool = False):
    """A render whose every buffer is a fixed function of the pixel's seed (like a real renderer,
    whose pixel estimate is a function of its seed); optionally NaN and inf in some pixels."""

    def render(seeds: torch.Tensor, sampler) -> Frame:
        if record is not None:
            record.append((seeds.clone(), sampler))
        h, w = seeds.shape
        u = ((seeds * 2654435761) % 1000003).float() / 1000003
        color = torch.stack([u, u * u, 1 - u])
        if special:
            color[0][seeds % 97 == 0] = float("nan")
            color[1][seeds % 89 == 0] = float("inf")
        return Frame(
            color=color,
            albedo=torch.stack([1 - u, u, u * 0.5]),
            depth=(seeds % 7).float()[None],
            **_features(h, w),
            timings={"render": 1.0},
        )

    return render


def _features(h: int, w: int) -> dict:
    """Geometric buffers that depend on the pixel only: 3 objects and the background in vertical
    bands, normals by band, a motion of (1.4, -0.6) px that takes the right border off screen."""
    x = torch.arange(w).expand(h, w)
    band = (x * 4 // w).float()
    return {
        "object_id": (band - 1)[None],
        "normal": torch.stack([band - 1.5, torch.ones(h, w), torch.zeros(h, w)]),
        "motion": torch.stack([torch.full((h, w), 1.4), torch.full((h, w), -0.6)]),
    }


def _block_multisets(x: torch.Tensor, block: int) -> list[list[int]]:
    h, w = x.shape
    return [
        sorted(x[y : y + block, c : c + block].reshape(-1).tolist())
        for y in range(0, h, block)
        for c in range(0, w, block)
    ]


# --------------------------------------------------------------------------------------------------
# Interface and invariants


def test_names_are_sorted_and_complete():
    assert tuple(STRATEGIES) == tuple(sorted(STRATEGIES))
    assert set(STRATEGIES) == {
        *("white", "bnds", "temporal", "temporal_sort", "oracle", "vertical"),
        *("zsobol", "cycles_blue", "zsobol_t", "bnds_st", "temporal_zsobol"),
        *("ldbn", "ldbn_st", "ldbn_fast", "temporal_ldbn"),
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


@pytest.mark.parametrize("name", ["temporal", "temporal_sort"])
def test_temporal_seed_image_stays_a_permutation_over_100_frames(name):
    record: list = []
    strategy = make_strategy(name, 37, 53, seed=3, block=4)
    render = _hash_render(record, special=True)
    for t in range(100):
        strategy.frame(t, render)
    initial = record[0][0]
    for seeds, _ in record:
        assert torch.equal(seeds.reshape(-1).sort().values, initial.reshape(-1).sort().values)
        if name == "temporal_sort":  # seeds never leave their block
            assert _block_multisets(seeds, 4) == _block_multisets(initial, 4)
    assert initial.unique().numel() == 37 * 53
    assert not torch.equal(record[-1][0], initial)


def test_white_seeds_are_fresh_and_distinct_every_frame():
    record: list = []
    strategy = make_strategy("white", 16, 24, seed=1)
    for t in range(3):
        strategy.frame(t, _hash_render(record))
    seeds = [s for s, _ in record]
    assert all(s.unique().numel() == 16 * 24 for s in seeds)
    assert (seeds[0] != seeds[1]).float().mean() > 0.99
    assert isinstance(record[0][1], type(make_strategy("temporal", 4, 4).sampler))  # same sampler


def test_bnds_dithers_by_the_vector_mask_at_the_frame_offset():
    record: list = []
    mask = torch.rand(2, 64, 64, generator=torch.Generator().manual_seed(0))
    strategy = BNDSStrategy(20, 30, seed=2, mask=mask)
    for t in range(3):
        strategy.frame(t, _hash_render(record))
    samplers = [s for _, s in record]
    assert all(isinstance(s, BNDSSampler) for s in samplers)
    assert [s.offset for s in samplers] == [frame_offset(t, 64) for t in range(3)]
    assert len({s.seed0 for s in samplers}) == 3  # a fresh shared sequence every frame
    assert record[0][0].unique().numel() == 20 * 30


def test_oracle_selects_by_histogram_sampling_and_assembles_every_buffer():
    record: list = []
    strategy = OracleStrategy(12, 18, seed=0, mask=load_mask("scalar", 64), K=5)
    out = strategy.frame(4, _hash_render(record))
    frames = [_hash_render()(s, None) for s, _ in record]
    assert len(frames) == 5
    assert all(s.unique().numel() == 12 * 18 for s, _ in record)
    b = tile_mask(load_mask("scalar", 64), 12, 18, frame_offset(4, 64))
    choice = histogram_select(torch.stack([luminance(f.color) for f in frames]), b)
    for name in ("color", "albedo", "depth"):
        stacked = torch.stack([getattr(f, name) for f in frames])
        want = stacked.gather(0, choice[None, None].expand(1, stacked.shape[1], 12, 18))[0]
        assert torch.equal(getattr(out, name), want)
    assert out.timings["render"] == 5.0  # summed over the candidates
    assert out.timings["strategy"] == strategy.overhead_ms >= 0


def test_the_oracle_renders_its_candidates_through_render_batch_when_offered():
    one_by_one: list = []
    want = OracleStrategy(12, 18, seed=3, mask=load_mask("scalar", 64), K=4).frame(
        2, _hash_render(one_by_one)
    )
    batches: list = []
    render = _hash_render()

    def batch(seeds, sampler):
        batches.append(seeds.clone())
        return [render(s, sampler) for s in seeds]

    render.batch = batch
    got = OracleStrategy(12, 18, seed=3, mask=load_mask("scalar", 64), K=4).frame(2, render)
    assert len(batches) == 1 and batches[0].shape == (4, 12, 18)
    assert torch.equal(batches[0], torch.stack([s for s, _ in one_by_one]))
    for name, value in want.buffers().items():
        assert torch.equal(value, got.buffers()[name]), name
    assert got.timings["render"] == 4.0  # summed over the candidates either way
    render.batch = lambda seeds, sampler: [render(s, sampler).color for s in seeds]
    with pytest.raises(DtypeError, match="expected a Frame"):  # the same checks as one by one
        OracleStrategy(12, 18, mask=load_mask("scalar", 64), K=2).frame(0, render)


def test_bnds_takes_the_vector_mask_with_the_fewest_channels_covering_the_integrand(monkeypatch):
    from bnerr.strategies import dithered

    shipped = [("scalar", 64), ("vector", 64, 2), ("vector", 64, 4), ("vector", 64, 8)]
    monkeypatch.setattr(dithered, "shipped_masks", lambda: shipped)
    monkeypatch.setattr(
        dithered, "load_mask", lambda kind, size, dims=None: torch.zeros(dims, size, size)
    )
    for dimensions, want in ((None, 2), (2, 2), (3, 4), (8, 8), (20, 8)):
        strategy = make_strategy("bnds", 8, 8, dimensions=dimensions)
        assert strategy.mask.shape == (want, 64, 64), dimensions
    assert make_strategy("bnds", 8, 8, dimensions=20, mask_dims=4).mask.shape[0] == 4


@pytest.mark.parametrize("name", STRATEGIES)
def test_same_arguments_give_identical_frames(name):
    outs = []
    for _ in range(2):
        if name == "bnds":  # a random vector mask: the test must not depend on the shipped ones
            mask = torch.rand(2, 64, 64, generator=torch.Generator().manual_seed(1))
            strategy = BNDSStrategy(9, 11, seed=4, mask=mask)
        else:
            strategy = make_strategy(name, 9, 11, seed=4, K=3, spp=4)
        frames = [strategy.frame(t, _hash_render()) for t in range(3)]
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
    with pytest.raises(ShapeError, match=r"render: expected a 8 x 8 frame, got 4 x 4"):
        strategy.frame(0, lambda seeds, sampler: Frame(color=torch.zeros(3, 4, 4)))
    with pytest.raises(DtypeError, match=r"render: expected a Frame, got Tensor"):
        strategy.frame(0, lambda seeds, sampler: torch.zeros(3, 8, 8))
    with pytest.raises(ValueRangeError, match=r"t: expected an integer >= 0, got -1"):
        strategy.frame(-1, _hash_render())


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
    out = oracle.frame(0, _hash_render())  # each candidate reports 1.0 ms
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
    render = _hash_render(special=True)
    for t in range(5):
        a = cpu.frame(t, render)
        b = gpu.frame(t, lambda s, smp: _hash_render(special=True)(s.cuda(), smp).to("cuda"))
        assert torch.equal(a.color, b.color.cpu())
    assert gpu.seeds.device.type == "cuda" and torch.equal(gpu.seeds.cpu(), cpu.seeds)


# --------------------------------------------------------------------------------------------------
# The analytic integrand: a soft shadow whose penumbra edge moves across the image
#
# Pixel (y, x) of frame t sees a fraction c_t(y, x) of an area light: a ramp from 0 to 1 over
# 0.75 W pixels whose edge follows a sine in y and moves 1.5 pixels to the right per frame. One
# sample per pixel draws two dimensions from the sampler: the light point is visible iff
# u0 < c, and the light's radiance there is 0.5 + u1 (mean 1). The reference is exactly c.

SIZE = 64
FRAMES = 16
MEASURED = range(8, FRAMES)  # the temporal strategies start from white noise; frames 8..15 count
TILE = 8  # 8x8 tiles (two 4x4 sort blocks across) are the independent units of the statistics


def _coverage(t: int) -> torch.Tensor:
    y = torch.arange(SIZE, dtype=torch.float64).view(SIZE, 1)
    x = torch.arange(SIZE, dtype=torch.float64).view(1, SIZE)
    edge = 0.1 * SIZE + 0.15 * SIZE * torch.sin(2 * math.pi * y / SIZE) + 1.5 * t
    return ((x - edge) / (0.75 * SIZE) + 0.5).clamp(0, 1)


def _soft_shadow_render(t: int):
    c = _coverage(t).reshape(-1)
    ys, xs = torch.meshgrid(torch.arange(SIZE), torch.arange(SIZE), indexing="ij")
    pixel = torch.stack([ys.reshape(-1), xs.reshape(-1)], dim=1)

    def render(seeds: torch.Tensor, sampler) -> Frame:
        u = sampler.sample(
            seeds.reshape(-1), torch.zeros(SIZE * SIZE, dtype=torch.int64), 0, 2, pixel
        )
        value = (u[:, 0].double() < c).double() * (0.5 + u[:, 1].double())
        return Frame(color=value.float().view(1, SIZE, SIZE).expand(3, SIZE, SIZE).contiguous())

    return render


def _errors(strategy) -> torch.Tensor:
    """``[F, H, W]`` float64 errors (one channel; all three are equal) of the measured frames."""
    errs = []
    for t in range(FRAMES):
        frame = strategy.frame(t, _soft_shadow_render(t))
        if t in MEASURED:
            errs.append(frame.color[0].double() - _coverage(t))
    return torch.stack(errs)


def _blur(errors: torch.Tensor, sigma: float) -> torch.Tensor:
    """The blur of :func:`bnerr.metrics.blurred_mse` (kornia, reflect border) applied per frame."""
    kernel = 2 * math.ceil(3 * sigma) + 1
    return gaussian_blur2d(
        errors[:, None], (kernel, kernel), (sigma, sigma), border_type="reflect"
    )[:, 0]


def _tiles(squared: torch.Tensor) -> torch.Tensor:
    """Mean over frames and over each TILE x TILE tile: ``[(H / TILE) * (W / TILE)]``."""
    per_pixel = squared.mean(dim=0)
    return per_pixel.view(SIZE // TILE, TILE, SIZE // TILE, TILE).mean(dim=(1, 3)).reshape(-1)


def _paired(a: torch.Tensor, b: torch.Tensor) -> tuple[float, float]:
    """Mean and standard error of the tile-paired difference ``a - b`` (same tile and coverage)."""
    d = a - b
    return float(d.mean()), float(d.std() / math.sqrt(d.numel()))


@pytest.fixture(scope="module", params=["owen_sobol", "white"])
def analytic(request):
    sampler = request.param
    names = ["white", "temporal", "temporal_sort", "oracle"]
    errors = {
        name: _errors(make_strategy(name, SIZE, SIZE, seed=0, sampler=sampler)) for name in names
    }
    bnds_mask = torch.rand(2, 64, 64, generator=torch.Generator().manual_seed(9))
    errors["bnds_random_mask"] = _errors(BNDSStrategy(SIZE, SIZE, seed=0, mask=bnds_mask))
    return errors


def test_blur_matches_the_project_metric(analytic):
    e = analytic["white"][0]
    ours = float(_blur(e[None], 1.0).square().mean())
    assert ours == pytest.approx(
        float(blurred_mse(e[None], torch.zeros_like(e[None]), 1.0)), rel=1e-9
    )


# Equivalence margin of the raw MSE ratio to white. The smallest round margin these 64 tiles x 8
# frames resolve: the tile-paired difference has a relative standard error of 0.7-1.9 % (measured:
# temporal_sort 1.7-1.9 %, the others 0.7-1.1 %), so the 99.5 % interval's half-width is up to
# 2.9 x 1.9 = 5.5 %; a 3 % margin would need about 4x the tiles. Measured ratios 0.988-1.010.
_RAW_MARGIN = 0.07
_RAW_LEVEL = 1 - 0.05 / 10  # 5 strategies x 2 samplers


def _paired_ratio(a: torch.Tensor, b: torch.Tensor, level: float) -> Estimate:
    """``mean(a) / mean(b)`` with the t-interval of the tile-paired difference (tiles are the
    independent units), divided by ``mean(b)``."""
    diff, se = _paired(a, b)
    base = float(b.mean())
    half = t_quantile(level, a.numel() - 1) * se
    return Estimate(1 + diff / base, 1 + (diff - half) / base, 1 + (diff + half) / base, 0, level)


def test_raw_mse_is_the_same_for_every_strategy(analytic):
    # Moving errors around never changes their amplitude: every strategy's raw MSE must be
    # equivalent to white's within _RAW_MARGIN (the whole interval inside, so a noisier
    # measurement fails instead of passing). (A random "vector mask" makes bnds a plain
    # Cranley-Patterson rotation: unbiased, same variance.)
    white = _tiles(analytic["white"].square())
    for name, err in analytic.items():
        ratio = _paired_ratio(_tiles(err.square()), white, _RAW_LEVEL)
        assert equivalent(ratio, _RAW_MARGIN), (name, str(ratio))


def test_temporal_beats_white_after_a_sigma1_blur_and_the_oracle_beats_temporal(analytic):
    blurred = {name: _tiles(_blur(e, 1.0).square()) for name, e in analytic.items()}
    diff, se = _paired(blurred["temporal"], blurred["white"])
    assert diff < -4 * se, (diff, se)
    diff, se = _paired(blurred["oracle"], blurred["temporal"])
    assert diff < -4 * se, (diff, se)
    # The sorting pass alone helps too.
    diff, se = _paired(blurred["temporal_sort"], blurred["white"])
    assert diff < -4 * se, (diff, se)


def test_retargeting_carries_the_gain_to_the_sigma2_scale(analytic):
    # Seeds never leave their 4x4 block in the sorting pass, so the error summed over a block stays
    # white and a sigma-2 blur (wider than the block) sees little gain; retargeting moves seeds
    # across blocks (docs/METHODS.md, section 4).
    blurred = {name: _tiles(_blur(e, 2.0).square()) for name, e in analytic.items()}
    diff, se = _paired(blurred["temporal"], blurred["temporal_sort"])
    assert diff < -4 * se, (diff, se)


# --------------------------------------------------------------------------------------------------
# The rivals: Z-order keys, Cycles' blue noise, STBN dithering, the temporal method over ZSobol

RIVALS = (
    *("zsobol", "cycles_blue", "zsobol_t", "bnds_st", "temporal_zsobol"),
    *("ldbn", "ldbn_st", "ldbn_fast", "temporal_ldbn"),
)


def _pixels(h: int, w: int) -> torch.Tensor:
    ys, xs = torch.meshgrid(torch.arange(h), torch.arange(w), indexing="ij")
    return torch.stack([ys.reshape(-1), xs.reshape(-1)], dim=1)


def _samples(seeds: torch.Tensor, sampler, spp: int) -> torch.Tensor:
    """Every sample index's first four dimensions for every pixel: ``[spp, H * W, 4]``."""
    h, w = seeds.shape
    flat = seeds.reshape(-1)
    return torch.stack(
        [sampler.sample(flat, torch.full_like(flat, i), 0, 4, _pixels(h, w)) for i in range(spp)]
    )


@pytest.mark.parametrize("name", RIVALS)
def test_rivals_are_deterministic_and_seed_sets_differ(name):
    def run(seed):
        record: list = []
        strategy = make_strategy(name, 10, 13, seed=seed, spp=4, dimensions=4)
        for t in range(3):
            strategy.frame(t, _hash_render(record))
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
        strategy.frame(0, _hash_render(record))
        assert strategy.sampler_name == OWN_SAMPLERS[name] == record[-1][1].name
    assert make_strategy("white", 8, 8, sampler="white").sampler_name == "white"
    assert make_strategy("temporal", 8, 8).sampler_name == "owen_sobol"


def test_zsobol_keys_are_the_identity_morton_image_and_the_scramble_is_fresh_per_frame():
    record: list = []
    strategy = make_strategy("zsobol", 6, 9, seed=2, spp=4)
    for t in range(3):
        strategy.frame(t, _hash_render(record))
    for seeds, sampler in record:
        assert torch.equal(seeds, zsobol_keys(6, 9))
        assert sampler.samples_per_pixel == 4 and sampler.layout.width == 9
    assert len({sampler.seed for _, sampler in record}) == 3
    # frame 0 is exactly pbrt's ZSobol with that seed: pair 0 is GetPixel2D
    seeds, sampler = record[0]
    want = zsobol_2d(torch.tensor(4), torch.tensor(3), torch.tensor(1), 0,
                     seed=sampler.seed, width=9, height=6, spp=4)  # fmt: skip
    got = sampler.sample(seeds[3, 4].reshape(1), torch.tensor([1]), 0, 2, _pixels(1, 1))
    assert torch.equal(got[0], want)


def test_ldbn_strategies_read_their_key_sets_at_the_frames_offset_or_slice():
    from bnerr.strategies.ldbn import LDBN_SETS

    for name in ("ldbn", "ldbn_fast", "ldbn_st"):
        record: list = []
        strategy = make_strategy(name, 6, 9, seed=2, spp=3)
        for t in range(5):
            strategy.frame(t, _hash_render(record))
        frames = LDBN_SETS[name][1]
        first = record[0][1]
        assert first.level == 2 and first.spp == 3  # the tile for 4 spp serves 3
        for t, (_, sampler) in enumerate(record):
            assert sampler.name == "ldbn" and sampler.keys.dims == 8
            if name == "ldbn_st":  # slice t mod F at one offset per seed set
                assert sampler.keys is strategy.keys[t % frames] and sampler.offset == first.offset
            else:  # one tile shifted by the R2 step per frame
                dy, dx = frame_offset(t, 64)
                assert sampler.keys is strategy.keys[0]
                assert sampler.offset == ((first.offset[0] + dy) % 64, (first.offset[1] + dx) % 64)
        assert len({int(s[0, 0]) for s, _ in record}) == 5  # fresh per-pixel seeds per frame


def test_zsobol_t_keeps_one_scramble_and_moves_to_the_frames_block():
    record: list = []
    strategy = make_strategy("zsobol_t", 8, 8, seed=1, spp=2)
    for t in range(4):
        strategy.frame(t, _hash_render(record))
    assert [sampler.frame for _, sampler in record] == [0, 1, 2, 3]
    assert len({sampler.seed for _, sampler in record}) == 1
    assert all(torch.equal(seeds, zsobol_keys(8, 8)) for seeds, _ in record)
    assert not strategy.stateful


def test_cycles_blue_keys_are_distinct_and_fresh_every_frame():
    record: list = []
    strategy = make_strategy("cycles_blue", 12, 20, seed=3, spp=3)  # any spp
    for t in range(3):
        strategy.frame(t, _hash_render(record))
    keys = [seeds for seeds, _ in record]
    assert all(k.unique().numel() == 12 * 20 for k in keys)
    assert torch.equal(keys[0], cycles_keys(12, 20, _cycles_seed(3, 0)))
    assert (keys[0] != keys[1]).float().mean() > 0.9
    assert all(s.name == "cycles_pure" and s.spp == 3 and s.seed0 == 0 for _, s in record)


def _cycles_seed(seed: int, t: int) -> int:
    return strategies.stream_key(seed, t, strategies.CyclesBlueStrategy.stream)


def test_bnds_st_gives_each_dimension_pair_its_own_stbn_slice():
    stbn = load_stbn("vector", 64, 32)
    record: list = []
    strategy = make_strategy("bnds_st", 16, 16, seed=0, dimensions=7)  # 8 channels: 4 pairs
    assert strategy.pairs == 4 and strategy.slice_step == 8
    for t in range(3):
        strategy.frame(t, _hash_render(record))
    for t, (seeds, sampler) in enumerate(record):
        assert isinstance(sampler, BNDSSampler) and sampler.offset == (0, 0)
        assert strategy.slices(t) == [t, t + 8, t + 16, t + 24]
        want = torch.cat([stbn[(t + 8 * k) % 32] for k in range(4)])
        assert torch.equal(sampler.mask, want) and sampler.dims == 8
        assert seeds.unique().numel() == 16 * 16
    assert len({s.seed0 for _, s in record}) == 3
    assert make_strategy("bnds_st", 8, 8, dimensions=2).pairs == 1
    assert make_strategy("bnds_st", 8, 8, dimensions=3).pairs == 2  # as bnds: 4 channels
    assert strategies.BNDSSTStrategy(8, 8, stbn=stbn, channels=2).slices(33) == [1]


def test_temporal_zsobol_keys_stay_a_permutation_over_100_frames():
    record: list = []
    strategy = make_strategy("temporal_zsobol", 21, 26, seed=1, spp=4)
    render = _hash_render(record, special=True)
    for t in range(100):
        strategy.frame(t, render)
    keys = zsobol_keys(21, 26).reshape(-1).sort().values
    assert torch.equal(record[0][0], zsobol_keys(21, 26))  # frame 0 is ZSobol itself
    for seeds, _ in record:
        assert torch.equal(seeds.reshape(-1).sort().values, keys)
    assert not torch.equal(record[-1][0], record[0][0]) and strategy.stateful
    assert len({id(sampler) for _, sampler in record}) == 1  # one sequence per key for the run


def test_temporal_ldbn_keys_stay_a_permutation_of_ldbns_first_frame():
    record: list = []
    strategy = make_strategy("temporal_ldbn", 21, 26, seed=1, spp=4)
    for t in range(60):
        strategy.frame(t, _hash_render(record, special=True))
    ldbn = make_strategy("ldbn", 21, 26, seed=1, spp=4)
    first = ldbn_key_image(ldbn.seeds(0), 64, ldbn.sampler(0).offset)
    assert torch.equal(record[0][0], first)  # frame 0 reads ldbn's frame 0 (seeds, texels)
    keys = first.reshape(-1).sort().values
    for seeds, _ in record:
        assert torch.equal(seeds.reshape(-1).sort().values, keys)
    assert not torch.equal(record[-1][0], record[0][0]) and strategy.stateful
    assert len({id(sampler) for _, sampler in record}) == 1  # one sequence per key for the run
    assert record[0][1].name == "ldbn_keyed" and record[0][1].level == 2


def test_temporal_ldbn_drives_the_renderer_and_its_frame_0_is_ldbns_bit_for_bit(one_thread):
    import renderers

    scene = renderers.get_scene("direct", animated=True)
    frames = {}
    for name in ("ldbn", "temporal_ldbn"):
        strategy = make_strategy(name, 12, 16, seed=4, spp=4, dimensions=scene.dimensions)
        frames[name] = [
            strategy.frame(t, lambda s, smp, t=t: renderers.render(scene, t, s, smp, 4)).color
            for t in range(3)
        ]
    assert torch.equal(frames["temporal_ldbn"][0], frames["ldbn"][0])
    assert not torch.equal(frames["temporal_ldbn"][2], frames["ldbn"][2])
    assert all(bool(torch.isfinite(c).all()) for c in frames["temporal_ldbn"])


def test_temporal_ldbn_refuses_bad_input():
    with pytest.raises(ValueRangeError, match=r"spp: expected the samples per pixel"):
        make_strategy("temporal_ldbn", 8, 8)
    with pytest.raises(ValueRangeError, match=r"spp: expected an integer >= 1"):
        make_strategy("temporal_ldbn", 8, 8, spp=0)
    passes = dict(mask=load_mask("scalar", 64), retarget=load_retarget(64))
    with pytest.raises(DtypeError, match=r"keys: expected LDBNKeys, got list"):
        strategies.TemporalLDBNStrategy(8, 8, keys=[], spp=4, **passes)
    with pytest.raises(UnknownNameError):
        make_strategy("temporal_ldbn+relative", 8, 8, spp=4)  # no variants of it


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
    return {name: _errors(make_strategy(name, SIZE, SIZE, seed=0, spp=1)) for name in names}


@pytest.mark.parametrize("name", RIVALS)
def test_rivals_raw_mse_is_not_worse_than_white_on_the_analytic_integrand(analytic_rivals, name):
    # Each pixel's single sample is uniform under every rival, so the raw MSE must not exceed
    # white's by more than _RAW_MARGIN (non-inferiority: the interval's upper end below 1 + d).
    ratio = _paired_ratio(
        _tiles(analytic_rivals[name].square()),
        _tiles(analytic_rivals["white"].square()),
        1 - 0.05 / len(RIVALS),
    )
    assert not_worse(ratio, _RAW_MARGIN), (name, str(ratio))


# A small real render: direct (animated), 48x48, 4 spp, 8 frames, against 256-spp references.
_REAL = dict(size=48, spp=4, frames=8, tile=4)
#: Non-inferiority margin of raw MSE ratios on that render. Its 144 tiles x 8 frames give a
#: relative standard error of 6-9 % per comparison, so the Bonferroni interval spans about -+20 %
#: (measured upper ends up to 1.30): it can only catch a gross loss, such as the doubled raw MSE of
#: repeated seeds (bnds here: 2.29x), and that is all it is asked. Equivalence within the strict
#: _RAW_MARGIN is tested on the analytic integrand, which resolves it.
_REAL_MARGIN = 0.35
_BNDS_RAW = (
    "bnds_st renders with the bnds sampler, which has about twice white's raw MSE here: measured "
    "on direct 48x48 at 4 spp over 8 frames, raw MSE / white 2.29 (5.6 standard errors of the "
    "tile-paired difference) and bnds itself 2.08 (5.5 se); one Owen-Sobol sequence shared by "
    "every pixel and Cranley-Patterson rotated loses the per-pixel Owen scrambling white's "
    "sequences have (issue 13, part 5 investigates whether this is inherent)"
)


@pytest.fixture(scope="module")
def real_raw_errors(one_thread):
    """Per-tile raw MSE of white and the rivals on small real renders: name -> ``[tiles]``."""
    import renderers
    from benchmarks.sweep.references import reference_seeds
    from bnerr.sequences import make_sampler

    n, spp, frames, tile = (_REAL[k] for k in ("size", "spp", "frames", "tile"))
    scene = renderers.get_scene("direct", animated=True)
    refs = [
        renderers.render(scene, t, reference_seeds(n, n, t), make_sampler("owen_sobol"), 256)
        for t in range(frames)
    ]
    out = {}
    for name in ("white", *RIVALS):
        strategy = make_strategy(name, n, n, seed=0, spp=spp, dimensions=scene.dimensions)
        squared = []
        for t in range(frames):
            frame = strategy.frame(t, lambda s, smp, t=t: renderers.render(scene, t, s, smp, spp))
            squared.append((frame.color.double() - refs[t].color.double()).square().mean(0))
        per_pixel = torch.stack(squared).mean(0)
        out[name] = per_pixel.view(n // tile, tile, n // tile, tile).mean(dim=(1, 3)).reshape(-1)
    return out


@pytest.mark.slow
@pytest.mark.parametrize(
    "name",
    [
        pytest.param(n, marks=pytest.mark.xfail(strict=True, reason=_BNDS_RAW))
        if n == "bnds_st"
        else n
        for n in RIVALS
    ],
)
def test_rivals_raw_mse_is_not_worse_than_white_on_a_small_render(real_raw_errors, name):
    level = 1 - 0.05 / len(RIVALS)
    ratio = _paired_ratio(real_raw_errors[name], real_raw_errors["white"], level)
    assert not_worse(ratio, _REAL_MARGIN), (name, str(ratio))


# --------------------------------------------------------------------------------------------------
# Temporal variants (docs/METHODS.md, section 8): options parsed from the name, each pass a
# bijection, the composition checked against the slow twins


def test_variant_names_parse_and_refuse_bad_spellings():
    base, options = parse_variant("temporal_zsobol+relative+demod+groups_depth+shift_r2+reproject")
    assert base == "temporal_zsobol"
    assert options == TemporalOptions("relative", True, "depth", "r2", True)
    assert parse_variant("temporal") == ("temporal", TemporalOptions())
    with pytest.raises(ValueRangeError, match=r"expected options in the order .*, got"):
        make_strategy("temporal+shift+residual", 8, 8)
    with pytest.raises(ValueRangeError, match=r"at most one of residual/relative"):
        make_strategy("temporal+residual+relative", 8, 8)
    with pytest.raises(ValueRangeError, match=r"each option once"):
        make_strategy("temporal+groups+groups", 8, 8)
    with pytest.raises(UnknownNameError, match=r"unknown temporal option 'blur'"):
        make_strategy("temporal+blur", 8, 8)
    with pytest.raises(UnknownNameError, match=r"unknown variant base 'oracle'"):
        estimate_bytes("oracle+groups", 8, 8)
    # any well-formed combination builds, registered or not, and keeps its name
    assert make_strategy("temporal+relative+groups_depth", 8, 8).name == (
        "temporal+relative+groups_depth"
    )
    assert estimate_bytes("temporal+reproject", 10, 10) > estimate_bytes("temporal", 10, 10)


def test_grid_offsets_stay_in_the_block_and_cycle():
    half = TemporalOptions(shift="half")
    assert [half.grid_offset(t, 4) for t in range(4)] == [(0, 0), (2, 2), (0, 0), (2, 2)]
    r2 = TemporalOptions(shift="r2")
    offsets = [r2.grid_offset(t, 4) for t in range(32)]
    assert offsets[:16] == offsets[16:] and len(set(offsets[:16])) >= 12
    assert all(0 <= oy < 4 and 0 <= ox < 4 for oy, ox in offsets)
    assert TemporalOptions().grid_offset(7, 4) == (0, 0)


def _adversarial_render(case: str):
    """Stand-in renders for the bijection tests: ties, NaN frames, degenerate groups, motion."""
    base = _hash_render(special=True)

    def render(seeds: torch.Tensor, sampler) -> Frame:
        out = base(seeds, sampler)
        h, w = seeds.shape
        changes: dict = {}
        if case == "ties":
            changes["color"] = torch.ones(3, h, w)
        elif case == "nan":
            changes["color"] = torch.full((3, h, w), float("nan"))
            changes["motion"] = torch.full((2, h, w), float("nan"))
            changes["depth"] = torch.full((1, h, w), float("nan"))
        elif case == "one_group":
            changes["object_id"] = torch.zeros(1, h, w)
        elif case == "pixel_groups":
            changes["object_id"] = torch.arange(h * w, dtype=torch.float32).view(1, h, w)
        elif case == "off_screen":
            changes["motion"] = torch.stack([torch.full((h, w), 1e6), torch.full((h, w), -3.5)])
        elif case == "inf_motion":
            changes["motion"] = torch.full((2, h, w), float("inf"))
        return dataclasses.replace(out, **changes)

    return render


_CASES = ("random", "ties", "nan", "one_group", "pixel_groups", "off_screen", "inf_motion")
_COMBOS = (
    *VARIANTS,
    "temporal+relative+demod+groups_depth+shift_r2+reproject",
    "temporal+demod+groups_normal+shift+reproject",
    "temporal_zsobol+relative+demod+groups+shift_r2+reproject+fast",
)


@pytest.mark.parametrize("name", _COMBOS)
def test_variant_seed_image_stays_a_permutation_on_adversarial_frames(name):
    strategy = make_strategy(name, 37, 53, seed=2, spp=4)  # 37 x 53: partial blocks everywhere
    initial = strategy.seeds.reshape(-1).sort().values
    for i, case in enumerate(_CASES * 3):
        strategy.frame(i, _adversarial_render(case))
        assert torch.equal(strategy.seeds.reshape(-1).sort().values, initial), (name, case)
    assert not torch.equal(strategy.seeds.reshape(-1), initial)


def _labelled_multisets(x, labels, block, grid):
    """Per (block of the shifted grid, label): the sorted values of ``x``."""
    out: dict = {}
    h, w = x.shape
    for y in range(h):
        for c in range(w):
            key = ((y + grid[0]) // block, (c + grid[1]) // block, int(labels[y, c]))
            out.setdefault(key, []).append(int(x[y, c]))
    return {k: sorted(v) for k, v in out.items()}


@pytest.mark.parametrize("shift", [None, "half", "r2"])
def test_sort_only_variants_permute_inside_each_shifted_block_and_group(shift):
    # Without retargeting or reprojection the seeds never leave their (shifted) block and group.
    options = TemporalOptions(key="residual", groups="object", shift=shift)
    strategy = strategies.TemporalStrategy(
        21, 30, seed=1, mask=load_mask("scalar", 64), options=options
    )
    assert strategy.name == "temporal_sort+residual+groups" + (
        "" if shift is None else ("+shift" if shift == "half" else "+shift_r2")
    )
    labels = (_features(21, 30)["object_id"][0] + 2).long()
    for t in range(6):
        before = strategy.seeds.clone()
        strategy.frame(t, _hash_render())
        grid = options.grid_offset(t, 4)
        assert _labelled_multisets(strategy.seeds, labels, 4, grid) == _labelled_multisets(
            before, labels, 4, grid
        )


def test_variant_frame_equals_the_slow_twins_composition():
    # One frame of temporal+residual+groups+shift+reproject, rebuilt from the slow twins: the
    # sort_pass reference with the key, labels and grid offset, the retargeting field, and the
    # reprojection reference along the frame's motion with the collision depth.
    from bnerr.reproject import collision_depth, reproject_seeds_reference
    from bnerr.retarget import load_retarget, retarget
    from bnerr.sortkeys import group_labels, sort_key

    h, w, t = 19, 26, 3
    strategy = make_strategy("temporal+residual+groups+shift+reproject", h, w, seed=5)
    strategy.seeds = pixel_seeds(h, w, 77)
    before = strategy.seeds.clone()
    out = strategy.frame(t, _hash_render())
    labels = group_labels(out.object_id)
    key = sort_key(out.color, "residual", labels=group_labels(out.object_id, out.normal))
    offset = frame_offset(t, 64)
    mask = tile_mask(load_mask("scalar", 64), h, w, offset)
    sorted_ = sort_pass_reference(before, key, mask, 4, groups=labels, grid_offset=(2, 2))
    moved = retarget(sorted_, load_retarget(64), offset)
    want = reproject_seeds_reference(moved, out.motion, collision_depth(out.depth, out.object_id))
    assert torch.equal(strategy.seeds, want)


def test_fast_sorts_against_the_fast_mask_and_retargets_with_its_field():
    # One frame of temporal+relative+demod+groups+fast, rebuilt from the slow twins with the FAST
    # mask and its retargeting field in place of the void-and-cluster mask's.
    from bnerr.fast import load_fast_mask, load_fast_retarget
    from bnerr.retarget import retarget
    from bnerr.sortkeys import group_labels, sort_key

    name = "temporal+relative+demod+groups+fast"
    assert parse_variant(name)[1] == TemporalOptions("relative", True, "object", fast=True)
    with pytest.raises(ValueRangeError, match=r"expected options in the order"):
        parse_variant("temporal+fast+groups")
    h, w, t = 19, 26, 2
    strategy = make_strategy(name, h, w, seed=5)
    assert strategy.name == name and torch.equal(strategy.mask, load_fast_mask(64))
    strategy.seeds = pixel_seeds(h, w, 77)
    before = strategy.seeds.clone()
    out = strategy.frame(t, _hash_render())
    labels = group_labels(out.object_id)
    key = sort_key(out.color, "relative", demodulate=True, albedo=out.albedo, labels=labels)
    offset = frame_offset(t, 64)
    mask = tile_mask(load_fast_mask(64), h, w, offset)
    want = retarget(
        sort_pass_reference(before, key, mask, 4, groups=labels), load_fast_retarget(64), offset
    )
    assert torch.equal(strategy.seeds, want)


def test_plain_options_are_the_paper_passes_bit_for_bit():
    a = make_strategy("temporal", 23, 17, seed=4)
    b = strategies.TemporalStrategy(
        23,
        17,
        seed=4,
        mask=load_mask("scalar", 64),
        retarget=load_retarget(64),
        options=TemporalOptions(),
    )
    assert b.name == "temporal"
    for t in range(5):
        a.frame(t, _hash_render())
        b.frame(t, _hash_render())
        assert torch.equal(a.seeds, b.seeds)


def test_variants_refuse_frames_without_the_buffers_they_need():
    def bare(seeds, sampler):
        return Frame(color=torch.rand(3, *seeds.shape, generator=torch.Generator().manual_seed(0)))

    for name, what in (
        ("temporal+groups", "object_id"),
        ("temporal+demod", "albedo"),
        ("temporal+reproject", "motion"),
    ):
        with pytest.raises(ValueRangeError, match=rf"expected a frame with a {what} buffer"):
            make_strategy(name, 8, 8).frame(0, bare)
    # the residual key without an object id smooths over every neighbour instead
    make_strategy("temporal+residual", 8, 8).frame(0, bare)


def _with_buffers(render):
    """The soft-shadow render with the aux buffers the variants read: one object, unit albedo, a
    flat normal and depth, no motion."""

    def full(seeds: torch.Tensor, sampler) -> Frame:
        frame = render(seeds, sampler)
        ones = torch.ones(1, SIZE, SIZE)
        return dataclasses.replace(
            frame,
            albedo=ones.expand(3, SIZE, SIZE).contiguous(),
            normal=torch.cat([torch.zeros(2, SIZE, SIZE), ones]),
            depth=ones.clone(),
            motion=torch.zeros(2, SIZE, SIZE),
            object_id=torch.zeros(1, SIZE, SIZE),
        )

    return full


@pytest.fixture(scope="module")
def analytic_variants():
    """Per-tile raw MSE of white and every variant on the soft-shadow integrand: name -> tiles."""
    out = {}
    for name in ("white", "zsobol", *VARIANTS):
        strategy = make_strategy(name, SIZE, SIZE, seed=0, spp=1)
        errs = [
            strategy.frame(t, _with_buffers(_soft_shadow_render(t))).color[0].double()
            - _coverage(t)
            for t in range(FRAMES)
        ]
        out[name] = _tiles(torch.stack([errs[t] for t in MEASURED]).square())
    return out


@pytest.mark.parametrize("name", VARIANTS)
def test_variants_raw_mse_is_whites_on_the_analytic_integrand(analytic_variants, name):
    # They only move seeds: the raw MSE must be equivalent to that of the sampler they permute
    # (white's, or zsobol's for temporal_zsobol) within _RAW_MARGIN, the whole Bonferroni interval
    # inside (a noisier measurement fails instead of passing).
    base = "zsobol" if name.startswith("temporal_zsobol") else "white"
    level = 1 - 0.05 / len(VARIANTS)
    ratio = _paired_ratio(analytic_variants[name], analytic_variants[base], level)
    assert equivalent(ratio, _RAW_MARGIN), (name, str(ratio))


@pytest.fixture(scope="module")
def variant_raw_errors(one_thread):
    """Per-tile raw MSE of white, temporal and every registered variant on a small real render
    (direct, animated, 48x48, 4 spp, 8 frames, 256-spp references): name -> ``[tiles]``."""
    import renderers
    from benchmarks.sweep.references import reference_seeds
    from bnerr.sequences import make_sampler

    n, spp, frames, tile = (_REAL[k] for k in ("size", "spp", "frames", "tile"))
    scene = renderers.get_scene("direct", animated=True)
    refs = [
        renderers.render(scene, t, reference_seeds(n, n, t), make_sampler("owen_sobol"), 256)
        for t in range(frames)
    ]
    out = {}
    for name in ("white", "zsobol", "temporal", *VARIANTS):
        strategy = make_strategy(name, n, n, seed=0, spp=spp, dimensions=scene.dimensions)
        squared = []
        for t in range(frames):
            frame = strategy.frame(t, lambda s, smp, t=t: renderers.render(scene, t, s, smp, spp))
            squared.append((frame.color.double() - refs[t].color.double()).square().mean(0))
        per_pixel = torch.stack(squared).mean(0)
        out[name] = per_pixel.view(n // tile, tile, n // tile, tile).mean(dim=(1, 3)).reshape(-1)
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name", VARIANTS)
def test_variants_raw_mse_equals_whites_on_a_small_render(variant_raw_errors, name):
    # On real buffers (object ids, motion, albedo) no variant may lose more than _REAL_MARGIN of
    # raw MSE against the sampler it permutes (white's, or zsobol's for temporal_zsobol); the
    # equivalence itself is tested on the analytic integrand.
    base = "zsobol" if name.startswith("temporal_zsobol") else "white"
    level = 1 - 0.05 / len(VARIANTS)
    ratio = _paired_ratio(variant_raw_errors[name], variant_raw_errors[base], level)
    assert not_worse(ratio, _REAL_MARGIN), (name, str(ratio))


def test_vertical_picks_among_the_oracles_candidates_for_a_lower_blurred_error():
    from bnerr.vertical import blurred_objective

    oracle_seeds: list = []
    vertical_seeds: list = []
    oracle = make_strategy("oracle", 14, 18, seed=2, K=6).frame(3, _hash_render(oracle_seeds))
    vertical = make_strategy("vertical", 14, 18, seed=2, K=6).frame(3, _hash_render(vertical_seeds))
    assert all(
        torch.equal(a, b) for (a, _), (b, _) in zip(oracle_seeds, vertical_seeds, strict=True)
    )
    frames = [_hash_render()(s, None) for s, _ in vertical_seeds]
    colors = torch.stack([f.color for f in frames]).double()
    target = colors.mean(0)
    # one candidate per pixel, every buffer from the same one
    match = (colors == vertical.color.double()[None]).all(1)
    assert bool(match.any(0).all())
    pick = match.double().argmax(0)
    albedo = torch.stack([f.albedo for f in frames])
    assert torch.equal(vertical.albedo, albedo.gather(0, pick[None, None].expand(1, 3, 14, 18))[0])
    got = blurred_objective(vertical.color, target, 2.0)
    assert got <= blurred_objective(oracle.color, target, 2.0)
    assert got < min(blurred_objective(c, target, 2.0) for c in colors)
