"""Tests of denoisers/filters/guided.py: its parameters and window checked, and the fast guided
filter against kornia's ``guided_blur`` (its slow twin, :mod:`_twins`: ``guided_reference``)."""

import pytest
import torch
import torch.nn.functional as F

from bnerr.errors import DtypeError, MemoryLimitError
from denoisers import get_denoiser
from denoisers.filters import Guided, guided_filter
from tests._images import random_frame
from tests._twins import guided_reference


def test_guided_parameters_are_checked():
    with pytest.raises(DtypeError, match="guided: radius: expected an integer, got float"):
        Guided(radius=2.5)


def test_an_absurd_radius_is_refused_before_allocating():
    match = "guided: radius 100000 on 24x24: expected a size that fits in memory .* got an"
    with pytest.raises(MemoryLimitError, match=match):
        get_denoiser("guided", radius=100000)(random_frame(24, 24, seed=5))


# Tolerance: 1e-5 of the image's largest value, relative and absolute. Both compute the same
# window statistics in float32, in another order (separable sums against a 2-D convolution), and
# solve the same 7 x 7 system per pixel (Cholesky against LU): at eps >= 1e-2 (the grid's
# smallest) the system's condition number is below 1e3, so a rounding of 6e-8 in the statistics
# moves the output by at most about 6e-5 relative; measured below 2e-6 of the largest value.


@pytest.mark.parametrize(("radius", "eps"), [(1, 1e-2), (2, 1.0), (3, 0.1), (5, 10.0)])
def test_fast_guided_matches_kornia(radius, eps):
    g = torch.Generator().manual_seed(radius)
    color = torch.rand(3, 41, 37, generator=g).square() * 4.0
    color[0, 7, 9] = 60.0
    albedo = torch.rand(3, 41, 37, generator=g)
    albedo[:, :, :10] = 0.5  # a flat region: a singular covariance but for eps
    normal = F.normalize(torch.randn(3, 41, 37, generator=g), dim=0)
    want = guided_reference(color, albedo, normal, radius, eps)
    got = guided_filter(color, albedo, normal, radius, eps)
    scale = float(want.abs().amax())
    torch.testing.assert_close(got, want, rtol=1e-5, atol=1e-5 * scale)
