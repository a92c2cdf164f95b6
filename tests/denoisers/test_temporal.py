"""Tests for denoisers.temporal: TAA and SVGF accumulate, reject, reset and check their input."""

from __future__ import annotations

import functools

import pytest
import torch

import renderers
from benchmarks.training_data import pixel_seeds
from bnerr.frame import Frame
from bnerr.sequences import make_sampler
from denoisers import get_denoiser
from denoisers.base import MissingBufferError
from denoisers.temporal import SVGF, TAA, SequenceError

pytestmark = pytest.mark.usefixtures("one_thread")

H, W = 16, 20


def _frame(color: torch.Tensor, motion=(0.0, 0.0), object_id: float = 0.0, depth=1.0) -> Frame:
    h, w = color.shape[1:]
    normal = torch.zeros(3, h, w)
    normal[2] = 1.0
    mot = torch.empty(2, h, w)
    mot[0], mot[1] = motion
    return Frame(
        color=color,
        normal=normal,
        depth=torch.full((1, h, w), float(depth)),
        motion=mot,
        object_id=torch.full((1, h, w), float(object_id)),
    )


def _noisy(seed: int, mean: float = 0.5) -> torch.Tensor:
    g = torch.Generator().manual_seed(seed)
    return mean + 0.2 * torch.randn(3, H, W, generator=g)


@pytest.mark.parametrize("cls", [TAA, SVGF])
def test_first_frame_passes_through_taa_and_is_filtered_by_svgf(cls) -> None:
    color = _noisy(0)
    out = cls()(_frame(color), t=0)
    assert out.shape == (3, H, W) and out.dtype == torch.float32
    if cls is TAA:
        assert torch.equal(out, color)


def test_static_sequence_averages_uniformly_then_exponentially() -> None:
    taa = TAA(alpha=0.1)
    frames = [_noisy(s) for s in range(5)]
    for t, c in enumerate(frames):
        out = taa(_frame(c), t=t)
    # a = max(alpha, 1/n): with alpha = 0.1 the first 5 frames are a plain running mean.
    torch.testing.assert_close(out, torch.stack(frames).mean(0), rtol=0, atol=1e-6)


def test_accumulation_lowers_the_error_of_white_noise() -> None:
    taa = TAA(alpha=0.2)
    errs = []
    for t in range(12):
        out = taa(_frame(_noisy(100 + t)), t=t)
        errs.append(float(((out - 0.5) ** 2).mean()))
    # Stationary white noise: the exponential average of rate a has a / (2 - a) of the variance.
    assert errs[-1] < errs[0] * (0.2 / 1.8) * 2.0


def test_integer_motion_fetches_the_moved_history_exactly() -> None:
    base = torch.rand(3, H, W, generator=torch.Generator().manual_seed(3))
    moved = torch.roll(base, shifts=2, dims=2)  # the content moves 2 pixels to the right
    taa = TAA(alpha=0.5)
    taa(_frame(base), t=0)
    out = taa(_frame(moved, motion=(2.0, 0.0)), t=1)
    # Where the history is on screen it shows the same values: the blend changes nothing.
    torch.testing.assert_close(out[:, :, 2:], moved[:, :, 2:], rtol=0, atol=1e-6)
    # The two columns that entered from off screen have no history: current frame as is.
    assert torch.equal(out[:, :, :2], moved[:, :, :2])


def test_disocclusion_rejects_the_history() -> None:
    taa = TAA(alpha=0.1)
    taa(_frame(torch.zeros(3, H, W), object_id=0), t=0)
    now = _noisy(1)
    out = taa(_frame(now, object_id=1), t=1)  # another object: nothing to blend with
    assert torch.equal(out, now)
    out = taa(_frame(now + 1, object_id=1, depth=5.0), t=2)  # same object, depth jumped
    assert torch.equal(out, now + 1)


def test_reset_starts_a_new_sequence_and_replays_bit_identically() -> None:
    taa = TAA(alpha=0.3)
    frames = [_frame(_noisy(s), motion=(0.5, -0.25)) for s in range(4)]
    first = [taa(f, t=t) for t, f in enumerate(frames)]
    taa.reset()
    second = [taa(f, t=t) for t, f in enumerate(frames)]
    assert all(torch.equal(a, b) for a, b in zip(first, second, strict=True))


def test_out_of_order_frames_raise() -> None:
    taa = TAA()
    taa(_frame(_noisy(0)), t=0)
    with pytest.raises(SequenceError, match="expected frame 1 after frame 0, got frame 2"):
        taa(_frame(_noisy(1)), t=2)


def test_resolution_change_mid_sequence_raises() -> None:
    svgf = SVGF()
    svgf(_frame(_noisy(0)), t=0)
    with pytest.raises(SequenceError, match="call reset"):
        svgf(_frame(torch.rand(3, H + 1, W)), t=1)
    svgf.reset()
    svgf(_frame(torch.rand(3, H + 1, W)), t=1)


@pytest.mark.parametrize("missing", ["motion", "depth", "normal", "object_id"])
def test_missing_buffer_raises(missing: str) -> None:
    frame = _frame(_noisy(0))
    setattr(frame, missing, None)
    with pytest.raises(MissingBufferError, match=missing):
        TAA()(frame)


def test_bad_parameters_and_registry() -> None:
    with pytest.raises(ValueError, match="alpha"):
        TAA(alpha=0.0)
    assert isinstance(get_denoiser("taa", alpha=0.1), TAA)
    assert isinstance(get_denoiser("svgf"), SVGF)
    assert TAA.stateful and SVGF.stateful
    assert get_denoiser("svgf").params()["alpha"] == 0.2


# ------------------------------------------------------------------------------------------------
# On the renderer's frames: a moving camera, white noise, every named scene.

SIZE, SPP, REF_SPP, FRAMES = 32, 4, 128, 5


@functools.cache
def _sequence(name: str) -> tuple[list[Frame], list[torch.Tensor]]:
    scene = renderers.get_scene(name, animated=True)
    white = make_sampler("white")
    frames = [
        renderers.render(scene, t, pixel_seeds(SIZE, SIZE, 10 + t), white, SPP)
        for t in range(FRAMES)
    ]
    refs = [
        renderers.render(scene, t, pixel_seeds(SIZE, SIZE, 9000 + t), white, REF_SPP).color
        for t in range(FRAMES)
    ]
    return frames, refs


@pytest.mark.parametrize("name", sorted(renderers.SCENES))
@pytest.mark.parametrize("denoiser", ["taa", "svgf"])
def test_accumulation_lowers_mse_on_every_scene(name: str, denoiser: str) -> None:
    frames, refs = _sequence(name)
    den = get_denoiser(denoiser, alpha=0.3)
    outs = [den(f, t=t) for t, f in enumerate(frames)]
    noisy = sum(float(((f.color - r) ** 2).mean()) for f, r in zip(frames[2:], refs[2:]))
    after = sum(float(((o - r) ** 2).mean()) for o, r in zip(outs[2:], refs[2:]))
    assert after < noisy


def test_svgf_uses_the_temporal_variance_once_four_frames_are_accumulated() -> None:
    # The same noisy image every frame: its spatial variance is large, its variance over time 0.
    color = _noisy(7)
    svgf = SVGF(alpha=0.2)
    outs = [svgf(_frame(color), t=t) for t in range(5)]
    change = [float((o - color).abs().mean()) for o in outs]
    # Frames 0-2 (history shorter than 4): the spatial estimate, the noise is filtered out.
    assert min(change[:3]) > 0.05
    # From the 4th frame on the moments say the pixel never varies: nothing is noise, almost no
    # blur (float32 leaves a variance of ~1e-8, about 1e-4 of luminance: neighbours that close
    # still mix).
    assert max(change[3:]) < 0.01 * min(change[:3])
