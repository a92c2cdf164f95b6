"""ColorVideoVDP as a metric (bnerr.metrics.cvvdp): its rankings on synthetic sequences of equal
MSE, the telescoping pairs, regions, and what it says when the package is missing."""

from __future__ import annotations

import importlib.util
import math
import socket

import pytest
import torch

from bnerr.errors import MissingDependencyError, ShapeError
from bnerr.metrics import METRIC_TABLE, FrameMetrics, mse
from bnerr.metrics import cvvdp as cv

pytestmark = [
    pytest.mark.skipif(not cv.cvvdp_available(), reason="cvvdp is not installed"),
    pytest.mark.usefixtures("one_thread"),
]

_SIZE = 128  # the suites' frames
_FRAMES = 3


def _reference(seed: int) -> list[torch.Tensor]:
    """A smooth coloured reference sequence (a slowly moving gradient) in linear radiance."""
    y, x = torch.meshgrid(torch.linspace(0, 1, _SIZE), torch.linspace(0, 1, _SIZE), indexing="ij")
    frames = []
    for t in range(_FRAMES):
        base = 0.3 + 0.4 * (x + 0.02 * t) * (1 - 0.5 * y)
        frames.append(torch.stack([base, 0.9 * base, 0.7 * base + 0.05 * seed]))
    return frames


def _white(seed: int, t: int) -> torch.Tensor:
    g = torch.Generator().manual_seed(1000 * seed + t)
    return torch.randn(3, _SIZE, _SIZE, generator=g)


def _blue(seed: int, t: int) -> torch.Tensor:
    """White noise with its low frequencies removed (a high-pass in the Fourier domain)."""
    spectrum = torch.fft.fft2(_white(seed, t))
    f = torch.fft.fftfreq(_SIZE)
    radius = (f[:, None] ** 2 + f[None, :] ** 2).sqrt()
    return torch.fft.ifft2(spectrum * (radius > 0.25)).real


def _at_mse(noise: torch.Tensor, target: float) -> torch.Tensor:
    return noise * math.sqrt(target / float(noise.square().mean()))


def _jod(errors: list[torch.Tensor], refs: list[torch.Tensor]) -> float:
    return cv.sequence_jod([r + e for r, e in zip(refs, errors, strict=True)], refs)


_MSE = 0.004  # sigma 0.063 on a reference of 0.3-0.7


def test_blue_noise_ranks_above_white_noise_of_equal_mse():
    whites, blues = [], []
    for seed in range(3):
        refs = _reference(seed)
        white = [_at_mse(_white(seed, t), _MSE) for t in range(_FRAMES)]
        blue = [_at_mse(_blue(seed, t), _MSE) for t in range(_FRAMES)]
        for w, b, r in zip(white, blue, refs, strict=True):  # equal MSE, frame by frame
            assert float(mse(r + w, r)) == pytest.approx(float(mse(r + b, r)), rel=1e-5)
        whites.append(_jod(white, refs))
        blues.append(_jod(blue, refs))
    # every seed's blue sequence above every seed's white one: the seeds' spread is the margin
    assert min(blues) > max(whites), (blues, whites)
    assert all(j < 10.0 for j in whites + blues)


def test_a_steady_sequence_ranks_above_a_flickering_one_of_equal_mse():
    """Flicker a viewer sees: the frame's brightness pumping (a uniform error that changes sign
    from frame to frame, against the same error held), and noise whose strength comes and goes
    (every other frame twice the MSE, the others none, against noise of steady strength); equal
    MSE over the sequence in both pairs."""
    for seed in range(3):
        refs = _reference(seed)
        offset = _at_mse(torch.ones(3, _SIZE, _SIZE) * (1 + seed), _MSE)
        steady, pumping = [offset] * _FRAMES, [offset * (-1) ** t for t in range(_FRAMES)]
        assert _jod(steady, refs) > _jod(pumping, refs)
        noise = [_at_mse(_white(seed, t), _MSE) for t in range(_FRAMES)]
        strength = [2.0 * (t % 2 == 0) for t in range(_FRAMES)]
        scale = math.sqrt(_FRAMES / sum(strength))  # the same MSE over the sequence
        coming = [n * math.sqrt(k) * scale for n, k in zip(noise, strength, strict=True)]
        assert sum(float(c.square().mean()) for c in coming) == pytest.approx(_FRAMES * _MSE)
        assert _jod(noise, refs) > _jod(coming, refs)


def test_a_fine_noise_that_changes_every_frame_is_less_visible_than_a_frozen_one():
    """What the eye's temporal integration does at 30 frames per second, measured: a noise
    pattern drawn afresh (or its sign flipped) every frame, of the MSE of one held still, scores
    higher (6.60-6.67 against 6.42 JOD on seed 0), the reverse of tMSE's ordering; so the
    per-frame-denoised flicker tMSE counts is not, for fine-grained noise, what cvvdp sees."""
    for seed in range(3):
        refs = _reference(seed)
        frozen = [_at_mse(_white(seed, 0), _MSE)] * _FRAMES
        fresh = [_at_mse(_white(seed, t), _MSE) for t in range(_FRAMES)]
        flipped = [frozen[0] * (-1) ** t for t in range(_FRAMES)]
        assert _jod(fresh, refs) > _jod(frozen, refs)
        assert _jod(flipped, refs) > _jod(frozen, refs)


def test_a_sequence_equal_to_its_reference_scores_10():
    refs = _reference(0)
    assert cv.sequence_jod(refs, refs) == pytest.approx(10.0)


def test_the_pooled_pairs_of_a_seed_set_are_the_jod_of_its_sequence():
    acc = FrameMetrics(["cvvdp"])
    expected = []
    for group in range(2):
        refs = _reference(group)
        preds = [r + _at_mse(_white(group, t), _MSE) for t, r in enumerate(refs)]
        for pred, ref in zip(preds, refs, strict=True):
            acc.update(pred, ref, group=group)
        expected.append(cv.sequence_jod(preds, refs))
    stats = acc.stats("cvvdp")
    assert stats[..., 0].tolist() == [[j] * _FRAMES for j in expected]  # (J, 1) on every frame
    assert stats[..., 1].tolist() == [[1.0] * _FRAMES] * 2
    est = acc.compute()["cvvdp"]
    assert est.value == pytest.approx(sum(expected) / 2, abs=1e-9)
    assert est.lo <= est.value <= est.hi


def test_an_empty_frame_ends_the_sequence():
    refs = _reference(0)
    preds = [r + _at_mse(_white(0, t), _MSE) for t, r in enumerate(refs)]
    acc = FrameMetrics(["cvvdp"])
    acc.update(preds[0], refs[0])
    acc.update_empty()
    acc.update(preds[1], refs[1])
    acc.update(preds[2], refs[2])
    stats = acc.stats("cvvdp")[0]
    pooled = float(stats[:, 0].sum() / stats[:, 1].sum())
    first = cv.sequence_jod(preds[:1], refs[:1])
    rest = cv.sequence_jod(preds[1:], refs[1:])
    assert pooled == pytest.approx((first + 2 * rest) / 3, abs=1e-9)


def test_a_region_shows_the_reference_outside_its_mask():
    refs = _reference(0)
    preds = [r + _at_mse(_white(0, t), _MSE) for t, r in enumerate(refs)]
    nothing = [torch.zeros(_SIZE, _SIZE, dtype=torch.bool)] * _FRAMES
    half = torch.zeros(_SIZE, _SIZE, dtype=torch.bool)
    half[:, : _SIZE // 2] = True
    assert cv.sequence_jod(preds, refs, nothing) == pytest.approx(10.0)
    whole = cv.sequence_jod(preds, refs)
    part = cv.sequence_jod(preds, refs, [half] * _FRAMES)
    assert whole < part < 10.0
    acc = FrameMetrics(["cvvdp"])
    for pred, ref in zip(preds, refs, strict=True):
        acc.update(pred, ref, mask=half)
    assert acc.compute()["cvvdp"].value == pytest.approx(part, abs=1e-9)


def test_display_encode_is_the_previews_mapping():
    linear = torch.tensor([0.0, 1.0, 3.0]).reshape(3, 1, 1)
    encoded = cv.display_encode(linear).flatten()
    assert encoded[0] == 0.0
    assert float(encoded[1]) == pytest.approx(1.055 * 0.5 ** (1 / 2.4) - 0.055, rel=1e-6)
    assert float(encoded[2]) == pytest.approx(1.055 * 0.75 ** (1 / 2.4) - 0.055, rel=1e-6)


def test_it_runs_offline(monkeypatch):
    """Building the model and scoring read the package's own files: no socket is opened."""

    def refuse(*args, **kwargs):
        raise AssertionError("cvvdp tried to open a network connection")

    monkeypatch.setattr(socket, "socket", refuse)
    monkeypatch.setattr(socket, "create_connection", refuse)
    cv._model.cache_clear()
    refs = _reference(1)
    assert cv.sequence_jod([r + 0.05 for r in refs], refs) < 10.0


def test_it_checks_its_frames():
    refs = _reference(0)
    with pytest.raises(ShapeError, match="preds: expected one or more frames"):
        cv.sequence_jod(refs[:2], refs)
    with pytest.raises(ShapeError, match=r"refs: expected every frame \[3, H, W\]"):
        cv.sequence_jod([refs[0]], [refs[0][:1]])


def test_a_missing_package_is_said_in_one_line(monkeypatch):
    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "pycvvdp" else real(name, *a)
    )
    with pytest.raises(MissingDependencyError) as info:
        FrameMetrics(["cvvdp"])  # before any frame
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith("cvvdp: expected the package cvvdp==0.5.7")
    assert isinstance(info.value, ImportError)


def test_its_table_entry_gives_a_difference_not_a_ratio():
    entry = METRIC_TABLE["cvvdp"]
    assert entry.difference and entry.interval and not entry.ratio
    assert not entry.default and entry.sequence
