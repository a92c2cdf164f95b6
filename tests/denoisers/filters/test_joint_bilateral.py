"""Tests of denoisers/filters/joint_bilateral.py: its parameters checked, and its colour term:
a light with its surroundings' albedo and normal is not blurred into them."""

import pytest
import torch

from bnerr.errors import DtypeError
from denoisers.filters import JointBilateral, gaussian_filter, joint_bilateral_filter


def test_joint_bilateral_parameters_are_checked():
    with pytest.raises(
        DtypeError, match="joint_bilateral: sigma_color: expected a number, got str"
    ):
        JointBilateral(sigma_color="wide")


def test_a_light_with_the_ceilings_albedo_and_normal_keeps_its_edge():
    # The Cornell box's light: radiance 17 in a ceiling of 0.5, the same albedo and normal.
    color = torch.full((3, 24, 24), 0.5)
    color[:, 10:14, 10:14] = 17.0
    albedo = torch.full((3, 24, 24), 0.7)
    normal = torch.tensor([0.0, -1.0, 0.0])[:, None, None].expand(3, 24, 24).clone()
    out = joint_bilateral_filter(color, albedo, normal, 2.0, 0.3, 4.0)
    assert float((out - color).abs().max()) < 0.02
    assert float((gaussian_filter(color, 2.0) - color).abs().max()) > 1.0
