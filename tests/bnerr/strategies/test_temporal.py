"""Tests for bnerr.strategies.temporal: seed images that stay a permutation (over the Owen-Sobol,
ZSobol and LDBN keys), and the statistical claims of the method on the analytic integrand: raw MSE
unchanged, lower blurred MSE than white, the oracle lower still, retargeting carries the gain."""

import math

import pytest
import torch
from kornia.filters import gaussian_blur2d

from bnerr import strategies
from bnerr.errors import (
    DtypeError,
    UnknownNameError,
    ValueRangeError,
)
from bnerr.masks import load_mask
from bnerr.metrics import blurred_mse, equivalent
from bnerr.permutation.retarget import load_retarget
from bnerr.sequences import ldbn_key_image, zsobol_keys
from bnerr.strategies import (
    BNDSStrategy,
    make_strategy,
)
from tests._images import block_multisets
from tests.bnerr.strategies._renders import (
    RAW_LEVEL,
    RAW_MARGIN,
    SIZE,
    hash_render,
    paired,
    paired_ratio,
    shadow_errors,
    tiles,
)


@pytest.mark.parametrize("name", ["temporal", "temporal_sort"])
def test_temporal_seed_image_stays_a_permutation_over_100_frames(name):
    record: list = []
    strategy = make_strategy(name, 37, 53, seed=3, block=4)
    render = hash_render(record, special=True)
    for t in range(100):
        strategy.frame(t, render)
    initial = record[0][0]
    for seeds, _ in record:
        assert torch.equal(seeds.reshape(-1).sort().values, initial.reshape(-1).sort().values)
        if name == "temporal_sort":  # seeds never leave their block
            assert block_multisets(seeds, 4) == block_multisets(initial, 4)
    assert initial.unique().numel() == 37 * 53
    assert not torch.equal(record[-1][0], initial)


def _blur(errors: torch.Tensor, sigma: float) -> torch.Tensor:
    """The blur of :func:`bnerr.metrics.blurred_mse` (kornia, reflect border) applied per frame."""
    kernel = 2 * math.ceil(3 * sigma) + 1
    return gaussian_blur2d(
        errors[:, None], (kernel, kernel), (sigma, sigma), border_type="reflect"
    )[:, 0]


@pytest.fixture(scope="module", params=["owen_sobol", "white"])
def analytic(request):
    sampler = request.param
    names = ["white", "temporal", "temporal_sort", "oracle"]
    errors = {
        name: shadow_errors(make_strategy(name, SIZE, SIZE, seed=0, sampler=sampler))
        for name in names
    }
    bnds_mask = torch.rand(2, 64, 64, generator=torch.Generator().manual_seed(9))
    errors["bnds_random_mask"] = shadow_errors(BNDSStrategy(SIZE, SIZE, seed=0, mask=bnds_mask))
    return errors


def test_blur_matches_the_project_metric(analytic):
    e = analytic["white"][0]
    ours = float(_blur(e[None], 1.0).square().mean())
    assert ours == pytest.approx(
        float(blurred_mse(e[None], torch.zeros_like(e[None]), 1.0)), rel=1e-9
    )


def test_raw_mse_is_the_same_for_every_strategy(analytic):
    # Moving errors around never changes their amplitude: every strategy's raw MSE must be
    # equivalent to white's within RAW_MARGIN (the whole interval inside, so a noisier
    # measurement fails instead of passing). (A random "vector mask" makes bnds a plain
    # Cranley-Patterson rotation: unbiased, same variance.)
    white = tiles(analytic["white"].square())
    for name, err in analytic.items():
        ratio = paired_ratio(tiles(err.square()), white, RAW_LEVEL)
        assert equivalent(ratio, RAW_MARGIN), (name, str(ratio))


def test_temporal_beats_white_after_a_sigma1_blur_and_the_oracle_beats_temporal(analytic):
    blurred = {name: tiles(_blur(e, 1.0).square()) for name, e in analytic.items()}
    diff, se = paired(blurred["temporal"], blurred["white"])
    assert diff < -4 * se, (diff, se)
    diff, se = paired(blurred["oracle"], blurred["temporal"])
    assert diff < -4 * se, (diff, se)
    # The sorting pass alone helps too.
    diff, se = paired(blurred["temporal_sort"], blurred["white"])
    assert diff < -4 * se, (diff, se)


def test_retargeting_carries_the_gain_to_the_sigma2_scale(analytic):
    # Seeds never leave their 4x4 block in the sorting pass, so the error summed over a block stays
    # white and a sigma-2 blur (wider than the block) sees little gain; retargeting moves seeds
    # across blocks (docs/METHODS.md, section 4).
    blurred = {name: tiles(_blur(e, 2.0).square()) for name, e in analytic.items()}
    diff, se = paired(blurred["temporal"], blurred["temporal_sort"])
    assert diff < -4 * se, (diff, se)


def test_temporal_zsobol_keys_stay_a_permutation_over_100_frames():
    record: list = []
    strategy = make_strategy("temporal_zsobol", 21, 26, seed=1, spp=4)
    render = hash_render(record, special=True)
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
        strategy.frame(t, hash_render(record, special=True))
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
