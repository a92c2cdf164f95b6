"""Tests of denoisers/filters/atrous.py: the edge-avoiding a-trous filter (spatial SVGF), its
background rule, its initial variance and its fast pass against the slow twin.

The slow twin (:mod:`_twins`: ``atrous_reference``) writes every constant out itself, so a wrong
tap or window in the code under test fails here.
"""

import pytest
import torch
import torch.nn.functional as F

from bnerr.errors import ShapeError, ValueRangeError
from denoisers import get_denoiser, native
from denoisers.filters import ATrous, atrous_filter, atrous_planes, atrous_torch
from tests._images import random_frame, two_surfaces
from tests._twins import atrous_reference


def test_atrous_does_not_mix_background_and_surfaces():
    frame, clean = two_surfaces(noise=0.0, gradient=0.0)
    frame.normal[:, :, :4] = 0.0  # escaped rays: no normal, no albedo, depth 0
    frame.albedo[:, :, :4] = 0.0
    frame.depth[:, :, :4] = 0.0
    frame.color[:, :, :4] = 3.0
    out = atrous_filter(frame.color, frame.normal, frame.depth)
    torch.testing.assert_close(out[:, :, :4], frame.color[:, :, :4], rtol=1e-5, atol=1e-5)
    assert float((out[:, :, 4:] - clean[:, :, 4:]).abs().max()) < 1e-3


def test_atrous_parameters_are_checked():
    with pytest.raises(
        ValueRangeError, match=r"atrous: iterations: expected a value in \[1, 10\], got 11"
    ):
        ATrous(iterations=11)


# -- values a renderer writes: infinite depth (issue 18) ------------------------------------------


def test_atrous_reads_infinite_depth_as_the_background_depth():
    frame = random_frame(24, 24, seed=5)
    frame.depth[:, :8] = 0.0
    frame.normal[:, :8] = 0.0  # escaped rays: no normal, the tracer's depth 0
    want = get_denoiser("atrous")(frame)
    frame.depth[:, :8] = float("inf")  # the same pixels as another renderer marks them
    assert torch.equal(get_denoiser("atrous")(frame), want)


def test_atrous_float64_switch_agrees_with_float32_on_ordinary_frames():
    frame = random_frame(24, 24, seed=5)
    narrow = atrous_filter(frame.color, frame.normal, frame.depth)
    wide = atrous_filter(frame.color.double(), frame.normal.double(), frame.depth.double())
    torch.testing.assert_close(narrow, wide.float(), rtol=1e-4, atol=1e-5)


# -- an initial luminance variance (SVGF's temporal estimate) -------------------------------------


def test_atrous_variance_nan_is_the_spatial_estimate_and_none_the_default():
    frame = random_frame(24, 24, seed=5)
    args = (frame.color, frame.normal, frame.depth)
    plain = atrous_filter(*args)
    h, w = frame.color.shape[1:]
    assert torch.equal(atrous_filter(*args, variance=torch.full((h, w), float("nan"))), plain)
    # The variance every pass starts from (the native kernel's where atrous_filter runs it).
    spatial = atrous_planes(*args, None, native.FILTERS.load())[1][0]
    given = torch.rand(h, w, generator=torch.Generator().manual_seed(5))
    mixed = torch.where(torch.arange(w) < w // 2, given, float("nan"))
    want = atrous_filter(*args, variance=torch.where(mixed.isnan(), spatial, mixed))
    assert torch.equal(atrous_filter(*args, variance=mixed), want)


def test_atrous_variance_sets_how_much_luminance_difference_is_noise():
    frame = random_frame(24, 24, seed=5)
    args = (frame.color, frame.normal, frame.depth)
    h, w = frame.color.shape[1:]
    # Zero variance: every neighbour of another luminance is an edge, the image stays as it is.
    kept = atrous_filter(*args, variance=torch.zeros(h, w))
    torch.testing.assert_close(kept, frame.color, rtol=0, atol=1e-6)
    # A larger variance lets more neighbours in: the output is smoother.
    rough = [
        float(atrous_filter(*args, variance=torch.full((h, w), v)).diff(dim=2).abs().mean())
        for v in (1e-4, 1e-2, 1.0)
    ]
    assert rough[0] > rough[1] > rough[2]


def test_atrous_variance_is_checked():
    frame = random_frame(24, 24, seed=5)
    args = (frame.color, frame.normal, frame.depth)
    h, w = frame.color.shape[1:]
    with pytest.raises(ShapeError, match="atrous_filter: variance"):
        atrous_filter(*args, variance=torch.zeros(1, h, w))
    bad = torch.zeros(h, w)
    bad[3, 4], bad[5, 1] = -1.0, float("inf")
    with pytest.raises(
        ValueRangeError,
        match=r"variance: expected values >= 0 and finite .* got 2 others, first "
        r"-1.0 at pixel \(y, x\) = \(3, 4\)",
    ):
        atrous_filter(*args, variance=bad)


# -- the fast a-trous pass against its slow twin (issue 16) ---------------------------------------
#
# Tolerance: relative 1e-4 of each output value (absolute 1e-6 near 0) for sigma_normal up to 128,
# the value every tuned and default filter uses. The fast pass computes each weight as one
# exp(sigma_normal * log(cos) - ...) instead of exp(...) * cos ** sigma_normal, and the cosine with
# fused multiply-adds: a one-ulp change of the cosine (6e-8) moves cos ** 128 by 128 times that,
# about 8e-6 per pass, measured up to 1.9e-5 after 5 passes. Weights below exp(-80) become exp(-80)
# (see _ATROUS_MIN_LOG_WEIGHT): 1e-35 of a value, far below a float32 ulp. The twin estimates the
# spatial variance with another box sum (avg_pool2d, not kornia's box_blur) and normalizes the
# normals with torch.norm: a few ulps more, far inside the tolerance.


def _atrous_case(h=70, w=53, seed=1):
    g = torch.Generator().manual_seed(seed)
    color = torch.rand(3, h, w, generator=g).square() * 4.0
    color[1, 10, 12] = 40.0  # a firefly
    tilt = torch.randn(3, h, w, generator=g) * 0.2 + torch.tensor([0.0, 0.0, 1.0])[:, None, None]
    normal = F.normalize(tilt, dim=0)
    normal[:, :20, :15] = 0.0  # escaped rays
    depth = torch.rand(1, h, w, generator=g) + 1.0
    depth[:, :20, :15] = 0.0
    return color, normal, depth


@pytest.mark.parametrize(
    ("iterations", "sigma_color", "sigma_normal", "sigma_depth"),
    [(5, 4.0, 128.0, 1.0), (1, 1.0, 128.0, 1.0), (3, 16.0, 0.5, 0.1), (2, 64.0, 0.0, 10.0)],
)
def test_fast_atrous_matches_its_slow_twin(iterations, sigma_color, sigma_normal, sigma_depth):
    color, normal, depth = _atrous_case()
    sigmas = (sigma_color, sigma_normal, sigma_depth)
    want = atrous_reference(color, normal, depth, iterations, *sigmas)
    got = atrous_filter(color, normal, depth, iterations, *sigmas)  # native where it loads
    torch.testing.assert_close(got, want, rtol=1e-4, atol=1e-6)
    torch_path = atrous_torch(atrous_planes(color, normal, depth, None), iterations, sigmas)
    torch.testing.assert_close(torch_path, want, rtol=1e-4, atol=1e-6)
    variance = torch.rand(70, 53, generator=torch.Generator().manual_seed(2))
    variance[::3] = float("nan")
    want = atrous_reference(color, normal, depth, iterations, *sigmas, initial=variance)
    got = atrous_filter(color, normal, depth, iterations, *sigmas, variance=variance)
    torch.testing.assert_close(got, want, rtol=1e-4, atol=1e-6)


def test_fast_atrous_strips_meet_without_a_seam(monkeypatch):
    import denoisers.filters.atrous as atrous

    color, normal, depth = _atrous_case(h=45)
    planes = atrous_planes(color, normal, depth, None)  # the torch path (strips are its own)
    whole = atrous_torch(planes, 3, (4.0, 128.0, 1.0))
    monkeypatch.setattr(atrous, "_ATROUS_ROWS", 7)  # strips of 7 rows, taps up to 8 rows away
    assert torch.equal(atrous_torch(planes, 3, (4.0, 128.0, 1.0)), whole)
