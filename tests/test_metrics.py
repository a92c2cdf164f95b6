"""Tests of bnerr.metrics: per-image metrics, update/compute over frames, bootstrap intervals."""

import math

import numpy as np
import pytest
import torch
from kornia.filters import get_gaussian_kernel1d
from skimage.metrics import structural_similarity

from bnerr import metrics
from bnerr.errors import DtypeError, NonFiniteError, ShapeError, UnknownNameError, ValueRangeError
from bnerr.metrics import (
    Estimate,
    FrameMetrics,
    PreparedReference,
    blurred_mse,
    bootstrap_interval,
    edge_mask,
    flip,
    lowfreq,
    mse,
    paired_ratio,
    psnr,
    relmse,
    ssim,
    temporal_correlation,
)
from bnerr.spectrum import low_frequency_fraction


def _pair(seed=0, shape=(3, 24, 20), noise=0.1):
    gen = torch.Generator().manual_seed(seed)
    ref = torch.rand(shape, generator=gen) + 0.1
    pred = ref + noise * torch.randn(shape, generator=gen)
    return pred, ref


# -- per-image metrics -----------------------------------------------------------------------------


def test_mse_relmse_psnr_follow_their_formulas():
    pred, ref = _pair()
    e = (pred.double() - ref.double()) ** 2
    assert mse(pred, ref).item() == pytest.approx(e.mean().item(), rel=1e-12)
    assert relmse(pred, ref).item() == pytest.approx(
        (e / (ref.double() ** 2 + 0.01)).mean().item(), rel=1e-12
    )
    peak = (ref.max() - ref.min()).item()
    assert psnr(pred, ref) == pytest.approx(10 * math.log10(peak**2 / e.mean().item()), rel=1e-9)
    assert psnr(pred, ref, data_range=1.0) == pytest.approx(
        -10 * math.log10(e.mean().item()), rel=1e-9
    )
    assert psnr(ref, ref) == math.inf
    assert mse(pred, ref).dtype == torch.float64


def test_mask_restricts_the_average_to_selected_pixels():
    pred, ref = _pair()
    mask = torch.zeros(24, 20, dtype=torch.bool)
    mask[5:9, 3:17] = True
    e = (pred.double() - ref.double()) ** 2
    assert mse(pred, ref, mask).item() == pytest.approx(e[:, mask].mean().item(), rel=1e-12)


def test_ssim_is_scikit_image_with_the_reference_range():
    pred, ref = _pair(shape=(3, 32, 32))
    want = structural_similarity(
        ref.double().numpy(),
        pred.double().numpy(),
        data_range=float(ref.max() - ref.min()),
        channel_axis=0,
    )
    assert ssim(pred, ref) == pytest.approx(want, rel=1e-12)
    assert ssim(ref, ref) == pytest.approx(1.0)
    noisier, _ = _pair(shape=(3, 32, 32), noise=0.3)
    assert ssim(noisier, ref) < ssim(pred, ref)


@pytest.mark.parametrize("shape", [(3, 128, 128), (3, 17, 23), (1, 9, 7), (2, 40, 31)])
def test_ssim_map_is_scikit_image_bit_for_bit_with_and_without_a_mask(shape):
    # computed here with scipy's filters so that the reference's half is computed once; the
    # committed results were measured with scikit-image: exact equality, not approx
    pred, ref = _pair(shape=shape, noise=0.3)
    want, want_map = structural_similarity(
        ref.double().numpy(),
        pred.double().numpy(),
        data_range=float(ref.max() - ref.min()),
        channel_axis=0,
        full=True,
    )
    prepared = PreparedReference(ref)
    assert ssim(pred, ref) == float(want)
    assert np.array_equal(prepared.ssim.map(pred), want_map)
    mask = torch.rand(shape[1:], generator=torch.Generator().manual_seed(3)) > 0.5
    keep = mask.numpy().copy()
    keep[:3, :] = keep[-3:, :] = keep[:, :3] = keep[:, -3:] = False
    assert ssim(pred, ref, mask) == float(want_map[:, keep].mean())


@pytest.mark.parametrize("shape", [(3, 128, 128), (3, 17, 23), (1, 40, 9), (3, 256, 256)])
@pytest.mark.parametrize("sigma", [1.0, 2.0])
def test_the_blur_is_kornias_bit_for_bit(shape, sigma):
    # the fast path (below 256 x 256) against kornia's own call; above it kornia is called
    from kornia.filters import gaussian_blur2d

    kernel = 2 * math.ceil(3 * sigma) + 1
    gen = torch.Generator().manual_seed(shape[1])
    for scale in (1e-3, 1.0, 1e3):
        err = torch.randn(*shape, dtype=torch.float64, generator=gen) * scale
        want = gaussian_blur2d(err[None], (kernel, kernel), (sigma, sigma), border_type="reflect")
        assert torch.equal(metrics._gaussian_blur(err, sigma, kernel), want[0])


def test_a_prepared_reference_gives_the_same_stats_bit_for_bit():
    names = ("mse", "relmse", "psnr", "ssim", "mse_blur1", "mse_blur2", "lowfreq")
    _, ref = _pair(shape=(3, 32, 40))
    prepared = PreparedReference(ref)
    mask = torch.zeros(32, 40, dtype=torch.bool)
    mask[4:20, 6:30] = True
    plain, fast = FrameMetrics(names, tile=16), FrameMetrics(names, tile=16)
    for noise in (0.3, 0.1, 0.01):
        pred, _ = _pair(shape=(3, 32, 40), noise=noise)
        for m in (None, mask):
            assert plain.update(pred, ref, m) == fast.update(pred, prepared, m)
    for name in names:
        assert torch.equal(plain.stats(name), fast.stats(name))
    with pytest.raises(ShapeError, match="pred: expected the shape of ref"):
        fast.update(torch.zeros(3, 8, 8), prepared)
    with pytest.raises(NonFiniteError):
        PreparedReference(torch.full((3, 8, 8), math.nan))
    with pytest.raises(ValueRangeError, match="non-constant reference"):
        FrameMetrics(["ssim"]).update(torch.rand(3, 8, 8), PreparedReference(torch.ones(3, 8, 8)))


def _blur_twin(err: np.ndarray, sigma: float) -> np.ndarray:
    """Slow twin: explicit separable convolution with numpy's 'reflect' padding (no edge repeat)."""
    k = 2 * math.ceil(3 * sigma) + 1
    r = k // 2
    taps = np.exp(-(np.arange(-r, r + 1) ** 2) / (2 * sigma**2))
    taps /= taps.sum()
    pad = np.pad(err, ((0, 0), (r, r), (r, r)), mode="reflect")
    out = np.zeros_like(err)
    for dy in range(k):
        for dx in range(k):
            out += taps[dy] * taps[dx] * pad[:, dy : dy + err.shape[1], dx : dx + err.shape[2]]
    return out


@pytest.mark.parametrize("sigma", [1.0, 2.0])
def test_blurred_mse_equals_an_explicit_convolution(sigma):
    pred, ref = _pair(shape=(3, 30, 26))
    err = (pred.double() - ref.double()).numpy()
    want = (_blur_twin(err, sigma) ** 2).mean()
    assert blurred_mse(pred, ref, sigma).item() == pytest.approx(want, rel=1e-9)


@pytest.mark.parametrize("sigma", [1.0, 2.0])
def test_blur_removes_a_checkerboard_error_by_its_exact_nyquist_gain(sigma):
    # A +-a checkerboard is the bluest possible error. Mirror padding keeps it a checkerboard, so
    # the blurred error is the checkerboard times the kernel's response at Nyquist, everywhere.
    y, x = torch.meshgrid(torch.arange(32), torch.arange(32), indexing="ij")
    board = ((-1.0) ** (x + y)).float().expand(3, 32, 32) * 0.5
    ref = torch.full((3, 32, 32), 0.5)
    taps = get_gaussian_kernel1d(2 * math.ceil(3 * sigma) + 1, sigma).double()[0]
    gain = float((taps * (-1.0) ** torch.arange(taps.numel())).sum()) ** 2  # 2D = product of 1D
    assert mse(ref + board, ref).item() == pytest.approx(0.25)
    assert blurred_mse(ref + board, ref, sigma).item() == pytest.approx(0.25 * gain**2, rel=1e-6)


def test_lowfreq_is_the_spectrum_fraction_of_the_error():
    pred, ref = _pair(shape=(3, 64, 64))
    want = low_frequency_fraction(pred.double() - ref.double(), tile=32)
    assert lowfreq(pred, ref, tile=32) == pytest.approx(want, rel=1e-12)


@pytest.mark.skipif(not metrics.flip_available(), reason="flip-evaluator not installed")
def test_flip_is_zero_for_a_perfect_match_and_grows_with_error():
    pred, ref = _pair(shape=(3, 32, 32), noise=0.05)
    worse, _ = _pair(shape=(3, 32, 32), noise=0.3)
    assert flip(ref, ref) == pytest.approx(0.0, abs=1e-6)
    assert 0.0 < flip(pred, ref) < flip(worse, ref) <= 1.0


def test_flip_missing_package_says_how_to_install(monkeypatch):
    monkeypatch.setattr(metrics, "flip_available", lambda: False)
    pred, ref = _pair()
    with pytest.raises(ImportError, match="flip-evaluator"):
        flip(pred, ref)
    with pytest.raises(ImportError, match="pip install"):
        FrameMetrics(["mse", "flip"])


def test_edge_mask_marks_pixels_next_to_an_id_change():
    ids = torch.zeros(1, 6, 8)
    ids[0, :, 4:] = 1.0
    mask0 = edge_mask(ids, radius=0)
    assert mask0[:, 3:5].all() and mask0.sum() == 12
    mask1 = edge_mask(ids, radius=1)
    assert mask1[:, 2:6].all() and mask1.sum() == 24
    assert not edge_mask(torch.zeros(5, 5)).any()


# -- input checks ----------------------------------------------------------------------------------


def test_bad_inputs_raise_typed_errors():
    pred, ref = _pair()
    with pytest.raises(
        ShapeError, match=r"pred: expected the shape of ref \[3, 24, 20\], got \[3, 24, 19\]"
    ):
        mse(pred[..., :19], ref)
    with pytest.raises(ShapeError, match="ref: expected 3 dimensions"):
        mse(pred, ref[0])
    bad = pred.clone()
    bad[1, 2, 3] = float("nan")
    with pytest.raises(
        NonFiniteError, match="pred: expected finite values, got 1 NaN and 0 infinite"
    ):
        relmse(bad, ref)
    with pytest.raises(
        NonFiniteError, match="ref: expected finite values, got 0 NaN and 1 infinite"
    ):
        FrameMetrics(["mse"]).update(
            pred, ref.index_put((torch.tensor(0),) * 3, torch.tensor(math.inf))
        )
    with pytest.raises(DtypeError, match="pred: expected dtype"):
        mse(pred.to(torch.int32), ref)
    with pytest.raises(ShapeError, match="mask: expected shape"):
        mse(pred, ref, torch.ones(24, 21, dtype=torch.bool))
    with pytest.raises(DtypeError, match="mask: expected dtype bool"):
        mse(pred, ref, torch.ones(24, 20))
    with pytest.raises(ValueRangeError, match="mask: expected at least one selected pixel"):
        mse(pred, ref, torch.zeros(24, 20, dtype=torch.bool))
    with pytest.raises(ShapeError, match=r"expected H and W > 6 for a sigma 2.0 blur"):
        blurred_mse(pred[:, :6], ref[:, :6], 2.0)
    with pytest.raises(ShapeError, match="H and W >= 7 for SSIM"):
        ssim(pred[:, :6], ref[:, :6])
    with pytest.raises(ValueRangeError, match="non-constant reference"):
        psnr(pred, torch.ones_like(ref))
    with pytest.raises(UnknownNameError, match="unknown metric 'msee'"):
        FrameMetrics(["msee"])


# -- update / compute over frames ------------------------------------------------------------------


def test_frame_metrics_update_returns_the_per_image_values():
    acc = FrameMetrics(
        ["mse", "relmse", "psnr", "ssim", "mse_blur1", "mse_blur2", "lowfreq"], tile=16
    )
    pred, ref = _pair(shape=(3, 32, 32))
    row = acc.update(pred, ref)
    assert row["mse"] == pytest.approx(mse(pred, ref).item(), rel=1e-12)
    assert row["relmse"] == pytest.approx(relmse(pred, ref).item(), rel=1e-12)
    assert row["psnr"] == pytest.approx(psnr(pred, ref), rel=1e-12)
    assert row["ssim"] == pytest.approx(ssim(pred, ref), rel=1e-12)
    assert row["mse_blur2"] == pytest.approx(blurred_mse(pred, ref, 2.0).item(), rel=1e-12)
    assert row["lowfreq"] == pytest.approx(lowfreq(pred, ref, tile=16), rel=1e-12)


def test_running_mean_over_frames_is_the_pooled_mean():
    acc = FrameMetrics(["mse", "psnr"])
    frames = [_pair(seed=s, noise=0.05 * (s + 1)) for s in range(5)]
    for pred, ref in frames:
        acc.update(pred, ref)
    pooled = torch.stack([(p.double() - r.double()).square().mean() for p, r in frames]).mean()
    result = acc.compute()
    assert result["mse"].value == pytest.approx(pooled.item(), rel=1e-12)
    assert result["psnr"].value == pytest.approx(
        np.mean([psnr(p, r) for p, r in frames]), rel=1e-12
    )
    assert result["mse"].lo <= result["mse"].value <= result["mse"].hi
    assert result["mse"].n == 5


def test_masked_frames_pool_by_pixel_count():
    # With masks of different sizes, the running value is sum(e^2) / sum(count), not a mean of
    # means.
    acc = FrameMetrics(["mse"])
    pred, ref = _pair()
    small = torch.zeros(24, 20, dtype=torch.bool)
    small[0, 0] = True
    acc.update(pred, ref)
    acc.update(pred, ref, small)
    e = (pred.double() - ref.double()) ** 2
    want = (e.sum() + e[:, 0, 0].sum()) / (e.numel() + 3)
    assert acc.compute()["mse"].value == pytest.approx(want.item(), rel=1e-12)


def test_seed_sets_group_frames_and_must_be_rectangular():
    acc = FrameMetrics(["mse"])
    for s in range(6):
        acc.update(*_pair(seed=s), group=s % 2)
    assert acc.stats("mse").shape == (2, 3, 2)
    assert acc.values("mse")[1, 0].item() == pytest.approx(mse(*_pair(seed=1)).item(), rel=1e-12)
    acc.update(*_pair(seed=9), group=0)
    with pytest.raises(ShapeError, match=r"equal frames per seed set, got \[4, 3\]"):
        acc.stats("mse")


# -- bootstrap -------------------------------------------------------------------------------------


def test_bootstrap_is_deterministic_and_brackets_the_mean():
    values = torch.tensor([1.0, 2.0, 4.0, 3.0, 5.0, 2.5, 3.5])
    a = bootstrap_interval(values, seed=3)
    assert a == bootstrap_interval(values, seed=3)
    assert a.value == pytest.approx(values.double().mean().item())
    assert a.lo < a.value < a.hi
    assert bootstrap_interval(torch.full((9,), 2.0)) == Estimate(2.0, 2.0, 2.0, 9)


def test_bootstrap_interval_covers_the_true_mean_at_its_level():
    # 200 independent data sets of 30 normal values: the count of intervals holding the true mean is
    # binomial; the percentile bootstrap must stay within 3 binomial standard deviations of 95%.
    gen = torch.Generator().manual_seed(1)
    data = 1.0 + torch.randn(200, 30, generator=gen, dtype=torch.float64)
    intervals = [bootstrap_interval(row, resamples=1000, seed=i) for i, row in enumerate(data)]
    hits = sum(e.lo <= 1.0 <= e.hi for e in intervals)
    band = 3 * math.sqrt(0.95 * 0.05 / 200)
    assert abs(hits / 200 - 0.95) <= band


def test_two_stage_bootstrap_is_wider_when_seed_sets_differ():
    # Seed sets with different means: the two-stage interval must see that spread, which a plain
    # bootstrap over the pooled frames understates.
    gen = torch.Generator().manual_seed(2)
    values = torch.tensor([[1.0], [3.0], [5.0]], dtype=torch.float64) + 0.1 * torch.randn(
        3, 8, generator=gen
    )
    grouped = bootstrap_interval(values)
    flat = bootstrap_interval(values.flatten())
    assert grouped.value == pytest.approx(flat.value)
    assert grouped.hi - grouped.lo > flat.hi - flat.lo


def test_paired_ratio_removes_the_shared_frame_variation():
    # Frames differ a lot in content; a strategy at exactly 0.6x white on every frame must get a
    # ratio of 0.6 with no width at all, because the pairing cancels the content.
    content = torch.tensor([0.1, 5.0, 0.7, 2.0, 9.0, 0.3], dtype=torch.float64)
    exact = paired_ratio(0.6 * content, content)
    assert (exact.value, exact.lo, exact.hi, exact.n) == (
        pytest.approx(0.6),
        pytest.approx(0.6),
        pytest.approx(0.6),
        6,
    )
    gen = torch.Generator().manual_seed(4)
    noisy = 0.6 * content * (1 + 0.05 * torch.randn(6, generator=gen, dtype=torch.float64))
    r = paired_ratio(noisy, content)
    assert r.lo < r.value < r.hi and r.hi < 1.0
    with pytest.raises(ShapeError, match=r"values: expected the shape of baseline \[1, 6, 2\]"):
        paired_ratio(content[:5], content)


def test_frame_metrics_ratio_is_a_paired_ratio():
    white, blue = FrameMetrics(["mse"]), FrameMetrics(["mse"])
    for s in range(4):
        pred, ref = _pair(seed=s)
        white.update(pred, ref)
        blue.update(ref + 0.5 * (pred - ref), ref)
    r = blue.ratio(white, "mse")
    assert r.value == pytest.approx(0.25, rel=1e-6) and r.lo == pytest.approx(0.25, rel=1e-6)


def test_bootstrap_checks_its_arguments():
    with pytest.raises(ShapeError, match="values: expected per-frame values"):
        bootstrap_interval(torch.zeros(2, 2, 2, 2))
    with pytest.raises(ValueRangeError, match="level: expected a value in"):
        bootstrap_interval([1.0, 2.0], level=1.5)
    with pytest.raises(NonFiniteError, match="values: expected finite"):
        bootstrap_interval([1.0, math.nan])


# -- determinism across thread counts --------------------------------------------------------------


def _all_metric_values(pred, ref, mask):
    acc = FrameMetrics()
    for k in range(4):
        acc.update(pred + 0.01 * k, ref, mask=mask if k % 2 else None, group=k % 2)
    pooled = [x for e in acc.compute().values() for x in (e.value, e.lo, e.hi)]
    single = [
        mse(pred, ref).item(),
        relmse(pred, ref).item(),
        mse(pred, ref, mask).item(),
        blurred_mse(pred, ref, 1.0).item(),
        blurred_mse(pred, ref, 2.0).item(),
        lowfreq(pred, ref),
        psnr(pred, ref),
        ssim(pred, ref),
    ]
    return single + pooled + [acc.ratio(acc, "mse").lo]


def test_metrics_are_bit_identical_on_one_and_two_threads():
    # issue 18: bench --threads 1 and --threads 2 differed in 973 of 8064 metric values.
    pred, ref = _pair(seed=0, shape=(3, 128, 128), noise=0.3)
    mask = torch.rand(128, 128, generator=torch.Generator().manual_seed(1)) > 0.5
    before = torch.get_num_threads()
    try:
        torch.set_num_threads(1)
        one = _all_metric_values(pred, ref, mask)
        torch.set_num_threads(2)
        two = _all_metric_values(pred, ref, mask)
    finally:
        torch.set_num_threads(before)
    assert [struct_bits(x) for x in one] == [struct_bits(x) for x in two]


def struct_bits(x: float) -> bytes:
    import struct

    return struct.pack("<d", x)


def test_fixed_order_sums_stay_within_1e_12_of_torch_sum():
    pred, ref = _pair(seed=3, shape=(3, 96, 80), noise=0.5)
    err = (pred.double() - ref.double()).square()
    assert float(mse(pred, ref)) == pytest.approx(float(err.mean()), rel=1e-12)
    assert lowfreq(pred, ref) == pytest.approx(
        low_frequency_fraction(pred.double() - ref.double()), rel=1e-12
    )


def test_temporal_correlation_is_one_for_a_repeated_error_and_near_zero_for_fresh_noise():
    g = torch.Generator().manual_seed(7)
    prev = torch.randn(3, 64, 64, generator=g)
    fresh = torch.randn(3, 64, 64, generator=g)
    assert temporal_correlation(prev, prev) == pytest.approx(1.0, abs=1e-12)
    assert temporal_correlation(-prev, prev) == pytest.approx(-1.0, abs=1e-12)
    # independent normals: the coefficient's standard deviation is 1/sqrt(n); 4 of them
    assert abs(temporal_correlation(fresh, prev)) < 4 / math.sqrt(prev.numel())
    assert temporal_correlation(torch.zeros(3, 8, 8), torch.ones(3, 8, 8)) == 0.0


def test_temporal_correlation_follows_the_motion_to_the_same_surface():
    g = torch.Generator().manual_seed(8)
    prev = torch.randn(3, 32, 40, generator=g)
    err = torch.roll(prev, shifts=(1, 2), dims=(1, 2))  # moved by (dx, dy) = (2, 1) pixels
    motion = torch.stack([torch.full((32, 40), 2.2), torch.full((32, 40), 0.9)])
    assert temporal_correlation(err, prev, motion) == pytest.approx(1.0, abs=1e-12)
    assert abs(temporal_correlation(err, prev)) < 4 / math.sqrt(prev.numel())
    # the numpy twin: pixels whose source (nearest to p - motion) is on screen, all channels pooled
    now, then = err.numpy()[:, 1:, 2:], prev.numpy()[:, :-1, :-2]
    want = np.corrcoef(now.ravel(), then.ravel())[0, 1]
    assert temporal_correlation(err, prev, motion) == pytest.approx(want, abs=1e-12)


def test_temporal_correlation_refuses_mismatched_shapes():
    with pytest.raises(ShapeError, match="motion"):
        temporal_correlation(torch.zeros(3, 8, 8), torch.zeros(3, 8, 8), torch.zeros(2, 8, 9))
    with pytest.raises(ShapeError):
        temporal_correlation(torch.zeros(3, 8, 8), torch.zeros(3, 8, 9))
