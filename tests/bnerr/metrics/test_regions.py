"""The coherent-region mask (bnerr.metrics.regions): built on synthetic frames whose coherent
pixels are known by construction."""

from __future__ import annotations

import dataclasses

import pytest
import torch

from bnerr.errors import ShapeError, ValueRangeError
from bnerr.frame import Frame
from bnerr.metrics import coherent_mask


def _plane(h: int = 12, w: int = 16) -> Frame:
    """A flat, untextured object filling the frame, seen head on, not moving."""
    return Frame(
        color=torch.ones(3, h, w),
        albedo=torch.full((3, h, w), 0.5),
        normal=torch.tensor([0.0, 0.0, 1.0])[:, None, None].expand(3, h, w).clone(),
        depth=torch.full((1, h, w), 4.0),
        motion=torch.zeros(2, h, w),
        object_id=torch.zeros(1, h, w),
    )


def _interior(h: int, w: int, r: int = 2) -> torch.Tensor:
    inner = torch.zeros(h, w, dtype=torch.bool)
    inner[r : h - r, r : w - r] = True
    return inner


def test_uniform_plane_is_coherent_except_the_border():
    frame = _plane()
    assert torch.equal(coherent_mask(frame), _interior(12, 16))
    assert torch.equal(coherent_mask(frame, frame), _interior(12, 16))


def test_each_buffer_step_removes_the_pixels_within_the_window():
    for name, value in (("object_id", 1.0), ("depth", 6.0), ("albedo", 0.9)):
        frame = _plane()
        getattr(frame, name)[:, :, 8:] = value  # a step between columns 7 and 8
        want = _interior(12, 16)
        want[:, 6:10] = False  # a 5x5 window of these columns straddles the step
        assert torch.equal(coherent_mask(frame), want), name
    frame = _plane()
    frame.normal[:, :, 8:] = torch.tensor([0.0, 1.0, 0.0])[:, None, None]
    want = _interior(12, 16)
    want[:, 6:10] = False
    assert torch.equal(coherent_mask(frame), want)


def test_background_is_never_coherent():
    frame = _plane()
    frame.object_id.fill_(-1.0)
    assert not coherent_mask(frame).any()


def test_disocclusion_removes_its_window():
    frame, prev = _plane(), _plane()
    prev.object_id[0, 6, 8] = 3.0  # another object covered pixel (6, 8) in the previous frame
    want = _interior(12, 16)
    want[4:9, 6:11] = False
    assert torch.equal(coherent_mask(frame, prev), want)


def test_motion_fetches_the_previous_surface_where_it_was():
    frame, prev = _plane(), _plane()
    frame.motion[0] = 3.0  # every pixel moved 3 px right: its surface was at x - 3
    prev.object_id[0, :, :2] = 5.0  # the surface of columns 3 and 4 was hidden then
    want = _interior(12, 16)
    want[:, :7] = False  # off screen (x < 3) or hidden (x = 3, 4) before, and their windows
    assert torch.equal(coherent_mask(frame, prev), want)
    frame.motion[0] = 0.0  # read in place: the hidden columns 0, 1 and their windows
    want = _interior(12, 16)
    want[:, :4] = False
    assert torch.equal(coherent_mask(frame, prev), want)


def test_bad_input_raises_typed_errors():
    frame = _plane()
    with pytest.raises(ValueRangeError, match="albedo"):
        coherent_mask(dataclasses.replace(frame, albedo=None))
    with pytest.raises(ValueRangeError, match="motion"):
        coherent_mask(dataclasses.replace(frame, motion=None), frame)
    with pytest.raises(ShapeError):
        coherent_mask(frame, _plane(12, 18))
    with pytest.raises(ValueRangeError):
        coherent_mask(frame, depth_tol=-1.0)


def test_small_frame_and_float64_buffers():
    assert not coherent_mask(_plane(4, 4)).any()
    frame = _plane()
    mask = coherent_mask(frame)
    assert mask.dtype == torch.bool and mask.device == frame.color.device
