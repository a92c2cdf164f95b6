"""Tests of bnerr.metrics.image: per-image metrics, their input checks, the prepared reference."""

import math

import numpy as np
import pytest
import torch
from kornia.filters import get_gaussian_kernel1d
from skimage.metrics import structural_similarity

import bnerr.metrics
from bnerr.errors import DtypeError, NonFiniteError, ShapeError, UnknownNameError, ValueRangeError
from bnerr.metrics import (
    FrameMetrics,
    ImagePair,
    PreparedReference,
    blurred_mse,
    edge_mask,
    flip,
    highlight_mask,
    image,
    light_mask,
    lowfreq,
    mse,
    pooled_mean,
    psnr,
    relmse,
    ssim,
    temporal_correlation,
)
from bnerr.metrics.spectrum import low_frequency_fraction
from tests._images import noisy_pair as _pair

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
        assert torch.equal(image._gaussian_blur(err, sigma, kernel), want[0])


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


@pytest.mark.skipif(not image.flip_available(), reason="flip-evaluator not installed")
def test_flip_is_zero_for_a_perfect_match_and_grows_with_error():
    pred, ref = _pair(shape=(3, 32, 32), noise=0.05)
    worse, _ = _pair(shape=(3, 32, 32), noise=0.3)
    assert flip(ref, ref) == pytest.approx(0.0, abs=1e-6)
    assert 0.0 < flip(pred, ref) < flip(worse, ref) <= 1.0


def test_flip_missing_package_says_how_to_install(monkeypatch):
    monkeypatch.setattr(image, "flip_available", lambda: False)
    pred, ref = _pair()
    with pytest.raises(ImportError, match="flip-evaluator"):
        flip(pred, ref)
    with pytest.raises(ImportError, match="pip install"):
        FrameMetrics(["mse", "flip"])


def test_light_mask_is_the_lights_first_hits_grown_by_a_square_window():
    ids = torch.full((1, 6, 7), 2.0)
    ids[0, 2, 3] = 5.0  # a light
    ids[0, 5, 6] = 4.0  # another light, in the corner
    ids[0, 0, 0] = -1.0  # background
    want = torch.zeros(6, 7, dtype=torch.bool)
    want[1:4, 2:5] = True
    want[4:6, 5:7] = True
    assert torch.equal(light_mask(ids, (5, 4), radius=1), want)
    assert torch.equal(light_mask(ids, (5, 4), radius=0), (ids[0] == 5) | (ids[0] == 4))
    assert not light_mask(ids, (), radius=3).any()  # no light: no pixel
    assert torch.equal(light_mask(ids[0], (5, 4)), want)  # [H, W] as well as [1, H, W]
    with pytest.raises(ShapeError):
        light_mask(ids[None], (5,))


def test_edge_mask_marks_pixels_next_to_an_id_change():
    ids = torch.zeros(1, 6, 8)
    ids[0, :, 4:] = 1.0
    mask0 = edge_mask(ids, radius=0)
    assert mask0[:, 3:5].all() and mask0.sum() == 12
    mask1 = edge_mask(ids, radius=1)
    assert mask1[:, 2:6].all() and mask1.sum() == 24
    assert not edge_mask(torch.zeros(5, 5)).any()


# -- the update halves -----------------------------------------------------------------------------


@pytest.mark.parametrize("prepared", [False, True])
def test_an_image_pairs_updates_are_the_per_image_metrics_bit_for_bit(prepared):
    pred, ref = _pair(shape=(3, 32, 40), noise=0.2)
    mask = torch.rand(32, 40, generator=torch.Generator().manual_seed(5)) > 0.3
    target = PreparedReference(ref) if prepared else ref
    whole, masked = ImagePair(pred, target, tile=16), ImagePair(pred, target, mask, tile=16)
    for pair, m in ((whole, None), (masked, mask)):
        assert torch.equal(pooled_mean(pair.mse()), mse(pred, ref, m))
        assert torch.equal(pooled_mean(pair.relmse()), relmse(pred, ref, m))
        for sigma in (1.0, 2.0):
            assert torch.equal(pooled_mean(pair.blurred(sigma)), blurred_mse(pred, ref, sigma, m))
        assert pair.psnr().tolist() == [psnr(pred, ref, mask=m), 1.0]
        assert pair.ssim().tolist() == [ssim(pred, ref, m), 1.0]
        assert pair.lowfreq().tolist() == [lowfreq(pred, ref, tile=16), 1.0]  # never masked
        assert pair.score(0.25).dtype == torch.float64 and pair.size == {"C": 3, "H": 32, "W": 40}


def test_the_pairs_of_an_image_in_several_regions_are_separate_pairs_bit_for_bit():
    pred, ref = _pair(shape=(3, 32, 40), noise=0.2)
    target = PreparedReference(ref)
    gen = torch.Generator().manual_seed(6)
    regions = [
        None,
        torch.rand(32, 40, generator=gen) > 0.3,
        torch.rand(32, 40, generator=gen) > 0.8,
    ]
    whole = ImagePair(pred, target, tile=16)
    for mask in regions:
        shared, alone = whole.in_region(mask), ImagePair(pred, target, mask, tile=16)
        for update in ("mse", "relmse", "psnr", "ssim", "lowfreq"):
            assert torch.equal(getattr(shared, update)(), getattr(alone, update)()), update
        for sigma in (1.0, 2.0):
            assert torch.equal(shared.blurred(sigma), alone.blurred(sigma))
        assert shared.mask is mask and shared.tile == 16
    # the whole-image maps were computed once, by whichever region asked first
    assert sorted(map(str, whole._maps)) == sorted(
        ["err", "err^2", "err^2/den", "('blur^2', 1.0)", "('blur^2', 2.0)", "ssim", "lowfreq"]
    )
    kept = whole.in_region(regions[1]).error_only()
    assert list(kept._maps) == ["err"] and kept.err is whole.err
    with pytest.raises(ValueRangeError, match="mask: expected at least one selected pixel"):
        whole.in_region(torch.zeros(32, 40, dtype=torch.bool))
    with pytest.raises(ShapeError, match="mask"):
        whole.in_region(torch.ones(32, 41, dtype=torch.bool))


def test_an_image_pair_checks_its_inputs_as_the_per_image_functions_do():
    pred, ref = _pair()
    with pytest.raises(ShapeError, match=r"pred: expected the shape of ref \[3, 24, 20\]"):
        ImagePair(pred[..., :19], ref)
    with pytest.raises(ShapeError, match=r"pred: expected the shape of ref"):
        ImagePair(pred[..., :19], PreparedReference(ref))
    with pytest.raises(ValueRangeError, match="mask: expected at least one selected pixel"):
        ImagePair(pred, ref, torch.zeros(24, 20, dtype=torch.bool))
    with pytest.raises(ValueRangeError, match="tile: expected an integer >= 2"):
        ImagePair(pred, ref, tile=1)
    with pytest.raises(ShapeError, match=r"expected H and W > 6 for a sigma 2.0 blur"):
        ImagePair(pred[:, :6], ref[:, :6]).blurred(2.0)


# The names the single module bnerr/metrics.py exported before it became a package.
_FORMER_API = (
    "BLUR_SIGMAS METRICS Estimate FrameMetrics PreparedReference blurred_mse bootstrap_interval "
    "edge_mask flip flip_available lowfreq mse paired_ratio psnr relmse ssim temporal_correlation"
).split()


def test_the_package_keeps_every_name_of_the_former_module():
    assert set(_FORMER_API) <= set(bnerr.metrics.__all__)
    for name in bnerr.metrics.__all__:
        assert getattr(bnerr.metrics, name) is not None, name
    assert not [n for n in bnerr.metrics.__all__ if n.startswith("_")]


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


def test_the_blur_is_the_one_methods_md_states_in_scipys_words():
    """Issue 54: METHODS said "a Gaussian blur of sigma 1 and 2 pixels" without the border rule
    or the truncation; with SciPy's defaults a reader got another number. The paragraph now
    gives SciPy's call, and this checks it against the code (and that the defaults differ)."""
    from scipy.ndimage import gaussian_filter

    from tests._paths import ROOT

    methods = " ".join((ROOT / "docs/METHODS.md").read_text().split())
    call = 'scipy.ndimage.gaussian_filter(err, (0, sigma, sigma), mode="mirror", truncate=3.0)'
    assert call in methods and "`2 ceil(3 sigma) + 1` taps: 7 and 13" in methods
    gen = torch.Generator().manual_seed(54)
    ref = torch.rand(3, 24, 30, generator=gen, dtype=torch.float64)
    noise = torch.randn(3, 24, 30, generator=gen, dtype=torch.float64)
    high = noise - torch.nn.functional.avg_pool2d(noise[None], 3, 1, 1, False)[0]  # blue-ish
    for err in (noise, high):
        for sigma in (1.0, 2.0):
            ours = float(blurred_mse(ref + err, ref, sigma))
            kernel = 2 * math.ceil(3 * sigma) + 1
            assert kernel == {1.0: 7, 2.0: 13}[sigma]
            scipy = gaussian_filter(err.numpy(), (0, sigma, sigma), mode="mirror", truncate=3.0)
            assert ours == pytest.approx(float(np.mean(scipy**2)), rel=1e-12)
            default = float(np.mean(gaussian_filter(err.numpy(), (0, sigma, sigma)) ** 2))
            assert abs(default / ours - 1) > 1e-3  # the defaults are another blur


def test_highlight_mask_marks_pixels_brighter_than_display_white_grown():
    ref = torch.full((3, 32, 32), 0.5, dtype=torch.float64)
    ref[:, 3, 4] = 500.0  # a mirror image of a light: > 90.5x the mean (1.01) -> clipped
    ref[:, 0, 0] = 20.0  # bright but below the display's white
    got = highlight_mask(ref, radius=1)
    want = torch.zeros(32, 32, dtype=torch.bool)
    want[2:5, 3:6] = True
    assert torch.equal(got, want)
    assert torch.equal(highlight_mask(ref, radius=0), want & (ref[0] == 500.0))
    assert not highlight_mask(torch.ones(3, 4, 4)).any()  # a flat frame has no highlight
    assert highlight_mask(ref, over_mean=2.0, radius=0)[0, 0]  # a lower white clips it too
    with pytest.raises(ValueRangeError):
        highlight_mask(ref, over_mean=0.0)
