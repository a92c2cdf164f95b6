"""Tests of denoisers/filters/bilateral.py: its parameters checked, its range sigma relative to
the frame's mean colour (one value means the same on a dark and on a bright frame)."""

import pytest
import torch

from bnerr.errors import ValueRangeError
from denoisers.filters import Bilateral, bilateral_filter
from tests._images import two_surfaces


def test_bilateral_parameters_are_checked():
    with pytest.raises(ValueRangeError, match="bilateral: sigma_space: expected a value in"):
        Bilateral(sigma_space=0.0)


@pytest.mark.parametrize("scale", [1e-3, 1e3])
def test_bilateral_filter_is_scale_free(scale):
    color = two_surfaces(noise=0.5, seed=3)[0].color
    want = bilateral_filter(color, 1.0, 1.5) * scale
    torch.testing.assert_close(bilateral_filter(color * scale, 1.0, 1.5), want, rtol=1e-4, atol=0)
