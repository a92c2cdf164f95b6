"""``cycles_oidn``: the image Cycles denoised from the frame's own samples, on the frame's device;
a frame from any other renderer refused in one line."""

import pytest
import torch

from bnerr.frame import Frame
from denoisers import MissingBufferError, get_denoiser
from tests._images import random_frame


def test_it_returns_cycles_own_output_of_the_same_render():
    frame = random_frame(seed=3)
    out = get_denoiser("cycles_oidn")(frame)
    assert torch.equal(out, frame.own_denoised["cycles_oidn"])
    assert get_denoiser("cycles_oidn").kind == "renderer"


def test_a_frame_without_cycles_output_is_refused_in_one_line():
    frame = Frame(color=torch.rand(3, 4, 4))
    with pytest.raises(
        MissingBufferError,
        match=r"^cycles_oidn: expected a frame rendered by "
        r"Cycles with its denoiser's output, got one without",
    ):
        get_denoiser("cycles_oidn")(frame)
