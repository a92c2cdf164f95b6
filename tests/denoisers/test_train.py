"""Tests of denoisers/train.py: determinism, resuming bit for bit, checkpoints, bad input."""

import math

import pytest
import torch

from bnerr.errors import FileFormatError, ShapeError, UnknownNameError, ValueRangeError
from bnerr.frame import Frame
from denoisers import MissingBufferError
from denoisers.train import (
    LOSSES,
    TrainConfig,
    learning_rate,
    load_checkpoint,
    loss_value,
    make_training_set,
    train,
)

TINY = TrainConfig(steps=6, batch_size=2, crop=8, warmup=2, checkpoint_every=2, widths=(4, 4, 4, 4))


pytestmark = pytest.mark.usefixtures("one_thread")


def _pairs(count=4, size=16, seed=0):
    """Noisy frames of random smooth images; the noise is exponential (positive, unbiased)."""
    g = torch.Generator().manual_seed(seed)
    pairs = []
    for _ in range(count):
        ref = torch.nn.functional.interpolate(
            torch.rand(1, 3, 4, 4, generator=g), size=size, mode="bilinear"
        )[0]
        noisy = ref * -torch.rand(3, size, size, generator=g).clamp_min(1e-7).log()
        frame = Frame(
            color=noisy, albedo=torch.full((3, size, size), 0.5), normal=torch.zeros(3, size, size)
        )
        pairs.append((frame, ref))
    return pairs


def _equal_states(a, b):
    sa, sb = a.state_dict(), b.state_dict()
    return sa.keys() == sb.keys() and all(torch.equal(sa[k], sb[k]) for k in sa)


def test_interrupted_and_resumed_equals_uninterrupted(tmp_path):
    data = make_training_set(_pairs())
    straight = train(data, TINY, tmp_path / "a.ckpt", progress=False)
    first = train(data, TINY, tmp_path / "b.ckpt", stop_at=3, progress=False)
    assert first.step == 3 and not first.finished
    resumed = train(data, TINY, tmp_path / "b.ckpt", resume=True, progress=False)
    assert resumed.step == 6 and resumed.finished
    assert _equal_states(straight.model, resumed.model)
    assert straight.losses == resumed.losses and [s for s, _ in straight.losses] == [2, 4, 6]
    a, b = load_checkpoint(tmp_path / "a.ckpt"), load_checkpoint(tmp_path / "b.ckpt")
    assert a["step"] == b["step"] == 6
    for key in a["optimizer"]["state"]:
        for name, value in a["optimizer"]["state"][key].items():
            assert torch.equal(value, b["optimizer"]["state"][key][name])


def test_two_fresh_runs_are_bit_identical():
    data = make_training_set(_pairs())
    a = train(data, TINY, progress=False)
    b = train(data, TINY, progress=False)
    assert _equal_states(a.model, b.model) and a.losses == b.losses


def test_resume_of_a_finished_run_changes_nothing(tmp_path):
    data = make_training_set(_pairs())
    done = train(data, TINY, tmp_path / "c.ckpt", progress=False)
    again = train(data, TINY, tmp_path / "c.ckpt", resume=True, progress=False)
    assert again.step == 6 and _equal_states(done.model, again.model)


def test_loss_falls_on_a_learnable_task():
    data = make_training_set(_pairs(count=8, size=24))
    config = TrainConfig(
        steps=60, batch_size=4, crop=16, warmup=5, checkpoint_every=20, widths=(8, 8, 8, 8)
    )
    result = train(data, config, progress=False)
    first, last = result.losses[0][1], result.losses[-1][1]
    # Not a tuned threshold: the last third of training must simply be better than the first.
    assert last < first, result.losses


def test_learning_rate_schedule():
    config = TrainConfig(steps=100, warmup=10, lr=1e-3)
    assert learning_rate(config, 0) == pytest.approx(1e-4)
    assert learning_rate(config, 9) == pytest.approx(1e-3)
    assert learning_rate(config, 10) == pytest.approx(1e-3)
    assert learning_rate(config, 100) == pytest.approx(1e-5)
    values = [learning_rate(config, s) for s in range(10, 101)]
    assert all(a >= b for a, b in zip(values, values[1:]))
    assert math.isfinite(learning_rate(TrainConfig(steps=1, warmup=0), 0))


def test_corrupt_and_foreign_checkpoints_raise(tmp_path):
    data = make_training_set(_pairs())
    bad = tmp_path / "bad.ckpt"
    bad.write_bytes(b"this is not a checkpoint")
    with pytest.raises(
        FileFormatError, match="bad.ckpt: expected a training checkpoint, got an unreadable file"
    ):
        train(data, TINY, bad, resume=True, progress=False)
    good = tmp_path / "good.ckpt"
    train(data, TINY, good, stop_at=2, progress=False)
    truncated = tmp_path / "trunc.ckpt"
    truncated.write_bytes(good.read_bytes()[:200])
    with pytest.raises(FileFormatError, match="trunc.ckpt: expected a training checkpoint"):
        load_checkpoint(truncated)
    other = TrainConfig(
        steps=6, batch_size=2, crop=8, warmup=2, checkpoint_every=2, widths=(4, 4, 4, 4), seed=1
    )
    with pytest.raises(FileFormatError, match="good.ckpt: expected a checkpoint of config"):
        train(data, other, good, resume=True, progress=False)
    torch.save({"format": "something else"}, tmp_path / "foreign.ckpt")
    with pytest.raises(
        FileFormatError, match="expected format 'bnerr-unet-checkpoint-v1', got 'something else'"
    ):
        load_checkpoint(tmp_path / "foreign.ckpt")
    with pytest.raises(FileFormatError, match="got no such file"):
        load_checkpoint(tmp_path / "none.ckpt")


def test_bad_training_input_raises():
    with pytest.raises(ValueRangeError, match="expected at least one pair, got none"):
        make_training_set([])
    frame, ref = _pairs(1)[0]
    with pytest.raises(MissingBufferError, match="training pair 0.*without albedo"):
        make_training_set([(Frame(color=frame.color, normal=frame.normal), ref)])
    with pytest.raises(
        ShapeError, match=r"training pair 0: reference: expected shape \[3, 16, 16\]"
    ):
        make_training_set([(frame, ref[:, :8])])
    small = _pairs(1, size=8)[0]
    with pytest.raises(
        ShapeError, match="training pair 1: expected 16 x 16 like pair 0, got 8 x 8"
    ):
        make_training_set([(frame, ref), small])
    with pytest.raises(ValueRangeError, match="expected images at least 24 px, got 16 x 16"):
        train(make_training_set([(frame, ref)]), TrainConfig(crop=24), progress=False)
    with pytest.raises(ValueRangeError, match="TrainConfig.crop: expected a multiple of 8, got 12"):
        TrainConfig(crop=12)
    with pytest.raises(ValueRangeError, match="expected at most 500000 parameters"):
        train(
            make_training_set([(frame, ref)]),
            TrainConfig(crop=8, widths=(64, 128, 256, 256)),
            progress=False,
        )


def test_losses():
    t = torch.log1p(torch.tensor([[0.0, 0.5, 4.0]]))
    p = torch.log1p(torch.tensor([[0.1, 0.5, 2.0]]))
    for kind in LOSSES:
        assert float(loss_value(t, t, kind)) == 0.0
    torch.testing.assert_close(loss_value(p, t, "l1_log"), (p - t).abs().mean())
    expected = (0.1**2 / 0.01 + 0.0 + 2.0**2 / 16.01) / 3
    torch.testing.assert_close(
        loss_value(p, t, "relmse"), torch.tensor(expected), rtol=1e-5, atol=0
    )
    expected = float((p - t).abs().mean()) + (0.1 + 0.0 + 2.0) / 3
    torch.testing.assert_close(
        loss_value(p, t, "l1_log+l1"), torch.tensor(expected), rtol=1e-5, atol=0
    )
    expected = float((p - t).abs().mean()) + (0.1**2 + 0.0 + 2.0**2) / 3
    torch.testing.assert_close(
        loss_value(p, t, "l1_log+l2"), torch.tensor(expected), rtol=1e-5, atol=0
    )
    # A wild prediction is clamped instead of overflowing.
    assert math.isfinite(float(loss_value(torch.full((1, 3), 1e4), t, "relmse")))
    with pytest.raises(UnknownNameError, match="unknown training loss 'l2'"):
        TrainConfig(loss="l2")


# -- sizes are refused before building or allocating (issue 18) ------------------------------------


def test_an_absurd_batch_is_refused_before_the_first_step(monkeypatch):
    from bnerr.errors import MemoryLimitError
    from denoisers import train as train_module

    data = make_training_set(_pairs(count=1, size=16))
    config = TrainConfig(steps=1, batch_size=100_000_000, crop=8, widths=(4, 4, 4, 4))
    monkeypatch.setattr(train_module, "_step", lambda *a: pytest.fail("a step ran"))
    with pytest.raises(MemoryLimitError, match=r"train: batch_size 100000000 of 8 x 8 crops"):
        train(data, config, progress=False)


def test_step_bytes_grows_with_the_batch_and_the_crop():
    from denoisers.train import step_bytes

    small = step_bytes(TrainConfig(batch_size=16, crop=48))
    assert 16 * 48 * 48 * 2000 < small < 16 * 48 * 48 * 5000  # measured 2.4 to 2.8 KB per pixel
    assert step_bytes(TrainConfig(batch_size=32, crop=48)) == 2 * small
