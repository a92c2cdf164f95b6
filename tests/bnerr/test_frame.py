"""Tests for bnerr.frame: a Frame checks every buffer's channels, dtype and size against color,
lists the buffers it holds, and moves them all (with a copy of its timings) to a device."""

import pytest
import torch

from bnerr.errors import DtypeError, ShapeError
from bnerr.frame import BUFFERS, Frame
from tests._images import random_frame


def test_a_frame_holds_its_buffers_and_size():
    frame = random_frame(5, 7, drop=("motion",), timings={"render": 1.5})
    assert (frame.height, frame.width) == (5, 7)
    assert list(frame.buffers()) == ["color", "albedo", "normal", "depth", "object_id"]
    assert set(BUFFERS) == {"color", "albedo", "normal", "depth", "motion", "object_id"}


def test_to_copies_every_buffer_and_the_timings():
    frame = random_frame(3, 4, timings={"render": 2.0})
    moved = frame.to("cpu")
    assert moved is not frame and moved.timings == frame.timings
    assert moved.timings is not frame.timings
    for name, tensor in frame.buffers().items():
        assert torch.equal(moved.buffers()[name], tensor)


def test_bad_buffers_are_refused_naming_the_buffer():
    color = torch.zeros(3, 4, 5)
    with pytest.raises(ShapeError, match=r"Frame\.albedo: expected H x W = 4 x 5 like color"):
        Frame(color=color, albedo=torch.zeros(3, 4, 6))
    with pytest.raises(ShapeError, match=r"Frame\.depth"):
        Frame(color=color, depth=torch.zeros(2, 4, 5))
    with pytest.raises(DtypeError, match=r"Frame\.color"):
        Frame(color=color.double())


def test_a_renderer_s_own_denoised_image_rides_along_checked_and_moved():
    own = {"cycles_oidn": torch.rand(3, 4, 5)}
    frame = Frame(color=torch.rand(3, 4, 5), own_denoised=own)
    assert "own_denoised" not in frame.buffers()
    moved = frame.to("cpu")
    assert torch.equal(moved.own_denoised["cycles_oidn"], own["cycles_oidn"])
    with pytest.raises(ShapeError, match=r"Frame.own_denoised\['cycles_oidn'\]: expected H x W"):
        Frame(color=torch.rand(3, 4, 5), own_denoised={"cycles_oidn": torch.rand(3, 5, 4)})
