"""The flicker metrics (bnerr.metrics.temporal) through FrameMetrics: a flickering and a steady
sequence of exactly equal per-frame MSE told apart, the first frame of a seed set empty, windows
kept per seed set and ended by a frame without pixels, masks intersected over the window."""

import pytest
import torch

from bnerr.errors import ShapeError
from bnerr.metrics import FrameMetrics, ImagePair, mse
from bnerr.metrics.temporal import (
    TAVG_FRAMES,
    frame_difference_mse,
    frame_difference_relmse,
    window_average_mse,
)

_TEMPORAL = ["mse", "tmse", "trelmse", "mse_tavg"]


def _scene(seed: int = 0) -> tuple[torch.Tensor, torch.Tensor]:
    """A reference and an error image of multiples of 1/64 (float64): ``ref + e`` and ``ref - e``
    are exact, so both signs give exactly the same per-frame MSE."""
    gen = torch.Generator().manual_seed(seed)
    ref = torch.randint(8, 64, (3, 16, 16), generator=gen).double() / 64
    err = torch.randint(-4, 5, (3, 16, 16), generator=gen).double() / 64
    return ref, err


def _sequence(signs: list[int], seed: int = 0) -> FrameMetrics:
    ref, err = _scene(seed)
    acc = FrameMetrics(_TEMPORAL)
    for s in signs:
        acc.update(ref + s * err, ref)
    return acc


def test_flicker_and_a_steady_error_of_equal_per_frame_mse_are_told_apart():
    steady, flicker = _sequence([1, 1, 1, 1]), _sequence([1, -1, 1, -1])
    assert torch.equal(steady.values("mse"), flicker.values("mse"))  # exactly equal per frame
    _, err = _scene()
    e2 = float(err.square().mean())
    assert steady.compute()["tmse"].value == 0.0
    assert flicker.compute()["tmse"].value == pytest.approx(4 * e2, rel=1e-12)  # (2e)^2
    # the short temporal average keeps a steady error whole and cancels an alternating one
    assert steady.compute()["mse_tavg"].value == pytest.approx(e2, rel=1e-12)
    assert flicker.compute()["mse_tavg"].value < 0.2 * e2
    assert flicker.compute()["trelmse"].value > steady.compute()["trelmse"].value == 0.0


def test_motion_in_the_reference_is_no_error():
    # The frames move (the reference changes every frame); the error stays: no flicker.
    ref, err = _scene()
    acc = FrameMetrics(["tmse"])
    for t in range(3):
        moved = torch.roll(ref, shifts=t, dims=-1)
        acc.update(moved + err, moved)
    assert acc.compute()["tmse"].value == 0.0


def test_the_first_frame_of_a_seed_set_weighs_nothing():
    acc = _sequence([1, -1])
    stats = acc.stats("tmse")
    assert stats.shape == (1, 2, 2)
    assert stats[0, 0].tolist() == [0.0, 0.0]
    assert stats[0, 1, 1] == 3 * 16 * 16
    assert acc.stats("mse_tavg")[0, 0].tolist() == [0.0, 0.0]


def test_windows_stay_inside_their_seed_set():
    # Interleaved seed sets: each one's pair is its own frames', never the other set's.
    ref, err = _scene()
    acc = FrameMetrics(["tmse"])
    for t in range(2):
        acc.update(ref + err, ref, group=0)  # steady
        acc.update(ref + (-1) ** t * err, ref, group=1)  # flickers
    values = acc.stats("tmse")
    assert values[0].tolist() == [[0.0, 0.0], [0.0, 768.0]]
    assert float(values[1, 1, 0]) == pytest.approx(float((2 * err).square().sum()), rel=1e-12)


def test_a_frame_without_pixels_ends_the_window():
    ref, err = _scene()
    acc = FrameMetrics(["mse", "tmse"])
    acc.update(ref + err, ref)
    acc.update_empty()
    acc.update(ref - err, ref)  # its previous frame measured nothing: no pair
    acc.update(ref + err, ref)
    assert acc.stats("tmse")[0, :, 1].tolist() == [0.0, 0.0, 0.0, 768.0]


def test_masks_are_intersected_over_the_window():
    ref, err = _scene()
    left = torch.zeros(16, 16, dtype=torch.bool)
    left[:, :8] = True
    top = torch.zeros(16, 16, dtype=torch.bool)
    top[:8, :] = True
    pairs = (ImagePair(ref + err, ref, left), ImagePair(ref - err, ref, top))
    both = left & top
    want = float((2 * err)[:, both].square().sum())
    got = frame_difference_mse(pairs)
    assert got[1] == 3 * 8 * 8 and float(got[0]) == pytest.approx(want, rel=1e-12)
    apart = torch.zeros(16, 16, dtype=torch.bool)
    apart[8:, 8:] = True  # no pixel in both frames: nothing measured
    assert frame_difference_mse(
        (ImagePair(ref, ref, left), ImagePair(ref, ref, apart))
    ).tolist() == [
        0.0,
        0.0,
    ]


def test_the_temporal_average_uses_at_most_its_window():
    ref, err = _scene()
    pairs = [ImagePair(ref + s * err, ref) for s in (5, 1, -1, 1, -1)]
    # the last TAVG_FRAMES frames cancel; with the first one they would not
    assert TAVG_FRAMES == 4
    assert float(window_average_mse(pairs)[0]) == 0.0
    three = window_average_mse(pairs[-3:])
    assert float(three[0] / three[1]) == pytest.approx(float(mse(ref + err / 3, ref)), rel=1e-12)


def test_the_relative_form_divides_by_the_current_reference():
    ref, err = _scene()
    pairs = (ImagePair(ref - err, ref), ImagePair(ref + err, ref))
    want = ((2 * err).square() / (ref.square() + 0.01)).sum()
    assert float(frame_difference_relmse(pairs)[0]) == pytest.approx(float(want), rel=1e-12)


def test_frames_of_a_seed_set_must_keep_their_size():
    ref, err = _scene()
    small = ImagePair(ref[:, :8, :8] + err[:, :8, :8], ref[:, :8, :8])
    with pytest.raises(ShapeError, match="every frame of a seed set"):
        frame_difference_mse((small, ImagePair(ref + err, ref)))


def test_device_and_dtype_follow_the_frames():
    ref, err = _scene()
    out = frame_difference_mse((ImagePair(ref.float(), ref.float()),))
    assert out.dtype == torch.float64 and out.device == ref.device
