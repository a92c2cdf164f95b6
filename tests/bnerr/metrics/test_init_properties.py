"""Property tests of bnerr.metrics (issue 28, item 5): bounds, invariance to the order of pixels
for the pointwise metrics, equality with numpy twins written here, and paired ratios of a series
against itself.

Examples are small (at most 3 x 16 x 16) so that the whole module runs in a few seconds; hypothesis
is derandomized by tests/conftest.py.
"""

from __future__ import annotations

import math

import numpy as np
import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from bnerr.metrics import (
    blurred_mse,
    bootstrap_interval,
    lowfreq,
    mse,
    paired_ratio,
    psnr,
    relmse,
    ssim,
)

# --------------------------------------------------------------------------------------------------
# Drawing image pairs


@st.composite
def image_pairs(draw, min_side: int = 1, max_side: int = 12, channels=(1, 3)):
    """``(pred, ref, mask, rng seed)``: float64 images ``[C, H, W]`` whose values span several
    decades (HDR radiance), a non-empty mask, and a seed for any further draws."""
    c = draw(st.sampled_from(channels))
    h = draw(st.integers(min_side, max_side))
    w = draw(st.integers(min_side, max_side))
    seed = draw(st.integers(0, 2**31 - 1))
    scale = draw(st.sampled_from([1e-3, 1.0, 30.0]))
    g = torch.Generator().manual_seed(seed)
    ref = torch.rand(c, h, w, generator=g, dtype=torch.float64) * scale
    noise = draw(st.sampled_from([0.0, 1e-3, 0.3, 3.0]))
    pred = ref + noise * scale * torch.randn(c, h, w, generator=g, dtype=torch.float64)
    if draw(st.booleans()):
        pred, ref = pred.float(), ref.float()
    mask = torch.rand(h, w, generator=g) < draw(st.sampled_from([0.3, 0.7, 1.0]))
    mask.view(-1)[draw(st.integers(0, h * w - 1))] = True  # at least one selected pixel
    return pred, ref, mask, seed


# --------------------------------------------------------------------------------------------------
# Numpy twins (written from the module's documented definitions, no imports of its helpers)


def _np_mse(pred, ref, mask=None):
    e = pred.numpy().astype(np.float64) - ref.numpy().astype(np.float64)
    e2 = e**2
    if mask is not None:
        e2 = e2[:, mask.numpy()]
    return float(e2.mean())


def _np_relmse(pred, ref, mask=None):
    p, r = pred.numpy().astype(np.float64), ref.numpy().astype(np.float64)
    v = (p - r) ** 2 / (r**2 + 0.01)
    if mask is not None:
        v = v[:, mask.numpy()]
    return float(v.mean())


def _np_psnr(pred, ref):
    r = ref.numpy()
    peak = float(r.max() - r.min())  # in the reference's own dtype, as documented (its range)
    err = _np_mse(pred, ref)
    return math.inf if err == 0 else 10 * math.log10(peak**2 / err)


def _np_box7(x):
    """7x7 mean of every channel of ``[C, H, W]``, scipy's default ``reflect`` border
    (half-sample symmetric: numpy's ``symmetric`` pad)."""
    p = np.pad(x, ((0, 0), (3, 3), (3, 3)), mode="symmetric")
    h, w = x.shape[1:]
    out = np.zeros_like(x)
    for dy in range(7):
        for dx in range(7):
            out += p[:, dy : dy + h, dx : dx + w]
    return out / 49.0


def _np_ssim(pred, ref):
    """Wang et al. 2004 with scikit-image's defaults: 7x7 uniform window, sample covariance,
    K1 = 0.01, K2 = 0.03, data range of the reference, mean over the map less a 3-pixel border,
    channels averaged."""
    x = ref.numpy().astype(np.float64)
    y = pred.numpy().astype(np.float64)
    peak = float(ref.numpy().max() - ref.numpy().min())  # the range in the reference's dtype
    c1, c2 = (0.01 * peak) ** 2, (0.03 * peak) ** 2
    norm = 49 / 48
    ux, uy = _np_box7(x), _np_box7(y)
    vx = norm * (_np_box7(x * x) - ux * ux)
    vy = norm * (_np_box7(y * y) - uy * uy)
    vxy = norm * (_np_box7(x * y) - ux * uy)
    smap = ((2 * ux * uy + c1) * (2 * vxy + c2)) / ((ux**2 + uy**2 + c1) * (vx + vy + c2))
    return float(np.mean([c[3:-3, 3:-3].mean() for c in smap]))


def _np_blurred_mse(pred, ref, sigma):
    """MSE of the error blurred by a normalized Gaussian of ``2 ceil(3 sigma) + 1`` taps, border
    mirrored without repeating the edge pixel (numpy's ``reflect``)."""
    k = 2 * math.ceil(3 * sigma) + 1
    r = k // 2
    x = np.arange(k) - r
    taps = np.exp(-(x**2) / (2 * sigma**2))
    taps /= taps.sum()
    e = pred.numpy().astype(np.float64) - ref.numpy().astype(np.float64)
    h, w = e.shape[1:]
    p = np.pad(e, ((0, 0), (0, 0), (r, r)), mode="reflect")
    rows = sum(taps[i] * p[:, :, i : i + w] for i in range(k))
    p = np.pad(rows, ((0, 0), (r, r), (0, 0)), mode="reflect")
    blurred = sum(taps[i] * p[:, i : i + h, :] for i in range(k))
    return float((blurred**2).mean())


# --------------------------------------------------------------------------------------------------
# Bounds


@given(image_pairs())
def test_mse_family_is_non_negative_and_zero_exactly_for_identical_images(pair):
    pred, ref, mask, _ = pair
    for fn in (mse, relmse):
        assert float(fn(pred, ref)) >= 0.0
        assert float(fn(pred, ref, mask)) >= 0.0
        assert float(fn(ref, ref)) == 0.0
    # relmse's denominator is >= 0.01, so it never exceeds 100 x the MSE
    assert float(relmse(pred, ref)) <= 100.0 * float(mse(pred, ref)) * (1 + 1e-12)


@given(image_pairs(min_side=7, max_side=14))
def test_ssim_is_at_most_one_and_one_for_the_reference_itself(pair):
    pred, ref, _, _ = pair
    value = ssim(pred, ref)
    assert math.isfinite(value)
    assert -1.0 - 1e-9 <= value <= 1.0 + 1e-12
    assert abs(ssim(ref, ref) - 1.0) <= 1e-12


@settings(max_examples=25)  # a blur or an FFT per example: fewer, still varied
@given(image_pairs(min_side=7, max_side=14), st.sampled_from([1.0, 2.0]))
def test_blurred_mse_is_non_negative_and_linear_in_the_error_squared(pair, sigma):
    pred, ref, _, _ = pair
    pred, ref = pred.double(), ref.double()
    if sigma == 2.0 and min(ref.shape[1:]) <= 6:
        sigma = 1.0  # 13 taps need H, W > 6
    b = float(blurred_mse(pred, ref, sigma))
    assert b >= 0.0
    # the blur is linear: doubling the error quadruples the blurred MSE
    b2 = float(blurred_mse(ref + 2 * (pred - ref), ref, sigma))
    assert math.isclose(b2, 4 * b, rel_tol=1e-9, abs_tol=1e-300)


@settings(max_examples=25)  # a blur or an FFT per example: fewer, still varied
@given(image_pairs(min_side=8, max_side=16), st.sampled_from([2, 4, 8]))
def test_lowfreq_is_a_fraction_and_ignores_the_errors_scale(pair, tile):
    pred, ref, _, _ = pair
    pred, ref = pred.double(), ref.double()
    f = lowfreq(pred, ref, tile=tile)
    assert 0.0 <= f <= 1.0
    scaled = lowfreq(ref + 7.0 * (pred - ref), ref, tile=tile)
    assert math.isclose(scaled, f, rel_tol=1e-9, abs_tol=1e-12)
    assert lowfreq(ref, ref, tile=tile) == 0.0  # no error, no energy


@given(image_pairs(min_side=2))
def test_psnr_is_infinite_for_a_perfect_match_and_falls_as_the_error_grows(pair):
    pred, ref, _, _ = pair
    pred, ref = pred.double(), ref.double()
    if float(ref.max() - ref.min()) <= 0.0 or float(mse(pred, ref)) == 0.0:
        return
    assert psnr(ref, ref) == math.inf
    worse = ref + 2 * (pred - ref)
    # 4 x the MSE is 10 log10(4) = 6.02 dB lower
    assert math.isclose(psnr(pred, ref) - psnr(worse, ref), 10 * math.log10(4), abs_tol=1e-9)


# --------------------------------------------------------------------------------------------------
# Invariance to the order of pixels (pointwise metrics)


@given(image_pairs())
def test_pointwise_metrics_ignore_the_order_of_pixels(pair):
    pred, ref, mask, seed = pair
    c, h, w = pred.shape
    perm = torch.randperm(h * w, generator=torch.Generator().manual_seed(seed ^ 0x5EED))

    def shuffle(x):
        return x.reshape(c, h * w)[:, perm].reshape(c, h, w)

    mask_s = mask.reshape(-1)[perm].reshape(h, w)
    for fn in (mse, relmse):
        # fixed-order float64 sums in a different order: equal up to rounding
        for m, ms in ((None, None), (mask, mask_s)):
            a = float(fn(pred, ref, m))
            b = float(fn(shuffle(pred), shuffle(ref), ms))
            assert math.isclose(a, b, rel_tol=1e-12, abs_tol=0.0), (fn.__name__, a, b)


# --------------------------------------------------------------------------------------------------
# Numpy twins


@given(image_pairs())
def test_mse_and_relmse_equal_their_numpy_twins(pair):
    pred, ref, mask, _ = pair
    for fn, twin in ((mse, _np_mse), (relmse, _np_relmse)):
        assert math.isclose(float(fn(pred, ref)), twin(pred, ref), rel_tol=1e-12)
        assert math.isclose(float(fn(pred, ref, mask)), twin(pred, ref, mask), rel_tol=1e-12)


@given(image_pairs(min_side=2))
def test_psnr_equals_its_numpy_twin(pair):
    pred, ref, _, _ = pair
    if float(ref.max() - ref.min()) <= 0.0:
        return
    want = _np_psnr(pred, ref)
    got = psnr(pred, ref)
    assert got == want if math.isinf(want) else math.isclose(got, want, rel_tol=1e-12)


@given(image_pairs(min_side=7, max_side=14))
def test_ssim_equals_its_numpy_twin(pair):
    pred, ref, _, _ = pair
    assert math.isclose(ssim(pred, ref), _np_ssim(pred, ref), rel_tol=1e-9, abs_tol=1e-12)


@settings(max_examples=25)  # a blur or an FFT per example: fewer, still varied
@given(image_pairs(min_side=7, max_side=14, channels=(1, 2, 3)), st.sampled_from([1.0, 2.0]))
def test_blurred_mse_equals_its_numpy_twin(pair, sigma):
    pred, ref, _, _ = pair
    if sigma == 2.0 and min(ref.shape[1:]) <= 6:
        sigma = 1.0
    got = float(blurred_mse(pred, ref, sigma))
    want = _np_blurred_mse(pred, ref, sigma)
    assert math.isclose(got, want, rel_tol=1e-9, abs_tol=1e-300), (got, want)


# --------------------------------------------------------------------------------------------------
# Paired ratios against themselves


@st.composite
def positive_series(draw):
    """Per-frame values ``[F]``, ``[S, F]`` or ``[S, F, 2]`` with positive means."""
    shape = draw(st.sampled_from(["F", "SF", "SF2"]))
    s = draw(st.integers(1, 6))
    f = draw(st.integers(1, 8))
    g = torch.Generator().manual_seed(draw(st.integers(0, 2**31 - 1)))
    values = torch.rand(s, f, generator=g, dtype=torch.float64) * 10 + 1e-3
    if shape == "F":
        return values[0]
    if shape == "SF":
        return values
    counts = torch.randint(1, 50, (s, f), generator=g).double()
    return torch.stack([values * counts, counts], dim=-1)


@given(positive_series(), st.sampled_from(["t", "bootstrap"]), st.sampled_from([0.8, 0.95]))
def test_a_series_against_itself_has_ratio_one_and_an_interval_with_one(values, method, level):
    est = paired_ratio(values, values.clone(), level=level, resamples=200, seed=1, method=method)
    assert est.value == 1.0
    # the t-interval over log ratios that are all 0 is [1, 1] (or (0, inf) with one replicate);
    # each bootstrap resample is a ratio of the same sums, 1 up to rounding
    assert est.lo <= 1.0 + 1e-12 and est.hi >= 1.0 - 1e-12, est
    assert est.lo <= est.hi
    if method == "t":
        replicates = values.numel() // (2 if values.dim() == 3 else 1)
        if values.dim() >= 2 and values.shape[0] >= 2:
            assert (est.lo, est.hi) == (1.0, 1.0)
        elif replicates == 1:
            assert (est.lo, est.hi) == (0.0, math.inf)


@given(positive_series(), st.floats(0.01, 100.0))
def test_a_ratio_scales_with_the_values_and_its_interval_with_it(values, c):
    base = paired_ratio(values, values, method="t")
    if values.dim() == 3:  # [S, F, 2]: scale the numerators, keep the counts
        scaled_values = torch.stack([values[..., 0] * c, values[..., 1]], dim=-1)
    else:
        scaled_values = values * c
    est = paired_ratio(scaled_values, values, method="t")
    assert math.isclose(est.value, c * base.value, rel_tol=1e-12)
    if math.isfinite(base.hi):
        assert math.isclose(est.lo, c * base.lo, rel_tol=1e-9)
        assert math.isclose(est.hi, c * base.hi, rel_tol=1e-9)


@given(positive_series())
def test_a_bootstrap_interval_contains_its_pooled_mean(values):
    est = bootstrap_interval(values, level=0.9, resamples=200, seed=0)
    assert est.lo <= est.value * (1 + 1e-12) and est.hi >= est.value * (1 - 1e-12), est
