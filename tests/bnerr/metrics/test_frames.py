"""Tests of bnerr.metrics.frames: the metrics' table, update per frame and compute over frames."""

import struct

import numpy as np
import pytest
import torch

from bnerr.errors import ShapeError, UnknownNameError, ValueRangeError
from bnerr.metrics import (
    METRIC_TABLE,
    METRICS,
    FrameMetrics,
    ImagePair,
    Metric,
    PreparedReference,
    blurred_mse,
    flip,
    flip_available,
    lowfreq,
    mse,
    psnr,
    relmse,
    ssim,
)
from tests._images import noisy_pair as _pair

# -- the table -------------------------------------------------------------------------------------


def test_metrics_is_the_tables_names_in_the_column_order_of_the_results():
    assert METRICS == tuple(METRIC_TABLE)
    assert METRICS == (
        "mse",
        "relmse",
        "psnr",
        "ssim",
        "mse_blur1",
        "mse_blur2",
        "lowfreq",
        "tmse",
        "trelmse",
        "mse_tavg",
        "flip",
        "cvvdp",
    )
    assert all(isinstance(m, Metric) and callable(m.update) for m in METRIC_TABLE.values())


def test_by_default_every_metric_but_the_slow_flip_and_cvvdp_is_measured():
    assert FrameMetrics().names == tuple(m for m in METRICS if m not in ("flip", "cvvdp"))


def _max_abs_error(pair: ImagePair) -> torch.Tensor:
    return pair.score(float(pair.err.abs().max()))


def test_a_metric_added_to_the_table_is_measured_with_no_other_change(monkeypatch):
    monkeypatch.setitem(METRIC_TABLE, "maxerr", Metric(_max_abs_error, default=False))
    with pytest.raises(UnknownNameError, match="unknown metric 'maxerr2'"):
        FrameMetrics(["maxerr2"])
    assert "maxerr" not in FrameMetrics().names  # not a default one
    acc = FrameMetrics(["mse", "maxerr"])
    frames = [_pair(seed=s) for s in range(3)]
    rows = [acc.update(pred, ref, group=k) for k, (pred, ref) in enumerate(frames)]
    want = [float((p.double() - r.double()).abs().max()) for p, r in frames]
    assert [row["maxerr"] for row in rows] == want
    assert acc.values("maxerr").flatten().tolist() == want
    assert acc.compute()["maxerr"].value == pytest.approx(np.mean(want), rel=1e-12)


def test_a_required_package_is_checked_when_the_accumulator_is_made(monkeypatch):
    def missing():
        raise ImportError("toy: needs the package 'toy-metric'")

    monkeypatch.setitem(METRIC_TABLE, "toy", Metric(_max_abs_error, require=missing))
    with pytest.raises(ImportError, match="toy-metric"):
        FrameMetrics(["mse", "toy"])
    with pytest.raises(ImportError, match="toy-metric"):
        FrameMetrics()  # a default one


@pytest.mark.skipif(not flip_available(), reason="flip-evaluator not installed")
def test_flip_through_the_table_is_the_per_image_flip():
    pred, ref = _pair(shape=(3, 32, 32), noise=0.05)
    assert FrameMetrics(["flip"]).update(pred, ref)["flip"] == flip(pred, ref)


# -- update / compute over frames ------------------------------------------------------------------


def test_frame_metrics_update_returns_the_per_image_values():
    acc = FrameMetrics(
        ["mse", "relmse", "psnr", "ssim", "mse_blur1", "mse_blur2", "lowfreq"], tile=16
    )
    pred, ref = _pair(shape=(3, 32, 32))
    row = acc.update(pred, ref)
    assert row["mse"] == pytest.approx(mse(pred, ref).item(), rel=1e-12)
    assert row["relmse"] == pytest.approx(relmse(pred, ref).item(), rel=1e-12)
    assert row["psnr"] == pytest.approx(psnr(pred, ref), rel=1e-12)
    assert row["ssim"] == pytest.approx(ssim(pred, ref), rel=1e-12)
    assert row["mse_blur2"] == pytest.approx(blurred_mse(pred, ref, 2.0).item(), rel=1e-12)
    assert row["lowfreq"] == pytest.approx(lowfreq(pred, ref, tile=16), rel=1e-12)


def test_running_mean_over_frames_is_the_pooled_mean():
    acc = FrameMetrics(["mse", "psnr"])
    frames = [_pair(seed=s, noise=0.05 * (s + 1)) for s in range(5)]
    for pred, ref in frames:
        acc.update(pred, ref)
    pooled = torch.stack([(p.double() - r.double()).square().mean() for p, r in frames]).mean()
    result = acc.compute()
    assert result["mse"].value == pytest.approx(pooled.item(), rel=1e-12)
    assert result["psnr"].value == pytest.approx(
        np.mean([psnr(p, r) for p, r in frames]), rel=1e-12
    )
    assert result["mse"].lo <= result["mse"].value <= result["mse"].hi
    assert result["mse"].n == 5


def test_masked_frames_pool_by_pixel_count():
    # With masks of different sizes, the running value is sum(e^2) / sum(count), not a mean of
    # means.
    acc = FrameMetrics(["mse"])
    pred, ref = _pair()
    small = torch.zeros(24, 20, dtype=torch.bool)
    small[0, 0] = True
    acc.update(pred, ref)
    acc.update(pred, ref, small)
    e = (pred.double() - ref.double()) ** 2
    want = (e.sum() + e[:, 0, 0].sum()) / (e.numel() + 3)
    assert acc.compute()["mse"].value == pytest.approx(want.item(), rel=1e-12)


def test_seed_sets_group_frames_and_must_be_rectangular():
    acc = FrameMetrics(["mse"])
    for s in range(6):
        acc.update(*_pair(seed=s), group=s % 2)
    assert acc.stats("mse").shape == (2, 3, 2)
    assert acc.values("mse")[1, 0].item() == pytest.approx(mse(*_pair(seed=1)).item(), rel=1e-12)
    acc.update(*_pair(seed=9), group=0)
    with pytest.raises(ShapeError, match=r"equal frames per seed set, got \[4, 3\]"):
        acc.stats("mse")


def test_frame_metrics_ratio_is_a_paired_ratio():
    white, blue = FrameMetrics(["mse"]), FrameMetrics(["mse"])
    for s in range(4):
        pred, ref = _pair(seed=s)
        white.update(pred, ref)
        blue.update(ref + 0.5 * (pred - ref), ref)
    r = blue.ratio(white, "mse")
    assert r.value == pytest.approx(0.25, rel=1e-6) and r.lo == pytest.approx(0.25, rel=1e-6)


def _all_metric_values(pred, ref, mask):
    acc = FrameMetrics()
    for k in range(4):
        acc.update(pred + 0.01 * k, ref, mask=mask if k % 2 else None, group=k % 2)
    pooled = [x for e in acc.compute().values() for x in (e.value, e.lo, e.hi)]
    single = [
        mse(pred, ref).item(),
        relmse(pred, ref).item(),
        mse(pred, ref, mask).item(),
        blurred_mse(pred, ref, 1.0).item(),
        blurred_mse(pred, ref, 2.0).item(),
        lowfreq(pred, ref),
        psnr(pred, ref),
        ssim(pred, ref),
    ]
    return single + pooled + [acc.ratio(acc, "mse").lo]


def test_metrics_are_bit_identical_on_one_and_two_threads():
    # issue 18: bench --threads 1 and --threads 2 differed in 973 of 8064 metric values.
    pred, ref = _pair(seed=0, shape=(3, 128, 128), noise=0.3)
    mask = torch.rand(128, 128, generator=torch.Generator().manual_seed(1)) > 0.5
    before = torch.get_num_threads()
    try:
        torch.set_num_threads(1)
        one = _all_metric_values(pred, ref, mask)
        torch.set_num_threads(2)
        two = _all_metric_values(pred, ref, mask)
    finally:
        torch.set_num_threads(before)
    assert [struct_bits(x) for x in one] == [struct_bits(x) for x in two]


def struct_bits(x: float) -> bytes:
    return struct.pack("<d", x)


def test_a_frame_given_as_its_pair_is_the_frame_given_as_tensors():
    gen = torch.Generator().manual_seed(8)
    ref = torch.rand(3, 32, 32, generator=gen) + 0.1
    mask = torch.rand(32, 32, generator=gen) > 0.5
    tensors, pairs = FrameMetrics(tile=16), FrameMetrics(tile=16)
    for _ in range(3):
        pred = ref + 0.1 * torch.randn(3, 32, 32, generator=gen)
        tensors.update(pred, ref, mask)
        pairs.update_pair(ImagePair(pred, PreparedReference(ref), tile=16).in_region(mask))
    for name in tensors.names:
        assert torch.equal(tensors.stats(name), pairs.stats(name)), name
    with pytest.raises(ValueRangeError, match="expected the accumulator's lowfreq tile 16, got 8"):
        pairs.update_pair(ImagePair(ref, ref, tile=8))


def test_an_empty_region_adds_a_weightless_frame():
    full, gapped = FrameMetrics(["mse", "psnr"]), FrameMetrics(["mse", "psnr"])
    gen = torch.Generator().manual_seed(3)
    pred, ref = torch.rand(3, 8, 8, generator=gen), torch.rand(3, 8, 8, generator=gen)
    full.update(pred, ref)
    gapped.update(pred, ref)
    gapped.update_empty()
    assert len(gapped) == 2 and gapped.stats("mse")[0, 1].tolist() == [0.0, 0.0]
    assert torch.equal(gapped.stats("mse").sum(1), full.stats("mse").sum(1))  # same pooled mean
    with pytest.raises(ValueRangeError):
        gapped.update_empty(group=-1)


def test_a_plug_in_metric_measures_the_region_with_or_without_a_mask_parameter(forget):
    """Issue 54: a plug-in metric without a ``mask`` parameter reported its whole-image value in
    the region rows. It now sees no error outside the region (a maximum is the region's); one
    with ``mask`` gets the region's mask itself."""
    from bnerr import plugins
    from bnerr.metrics.frames import load_metric

    def maxerr(pred, ref):
        """the largest absolute error"""
        return float((pred - ref).abs().max())

    def masked_max(pred, ref, mask=None):
        """the largest absolute error in the region"""
        err = (pred - ref).abs().amax(0)
        return float(err[mask].max() if mask is not None else err.max())

    table = METRIC_TABLE
    for fn, name in ((maxerr, "blind_max"), (masked_max, "masked_max")):
        fn.name = name
        forget.append(("bnerr.metrics", name))
        assert table.add(plugins.Plugin(f"test:{name}", fn)) == name
    assert load_metric("blind_max") == "blind_max"
    ref = torch.full((3, 8, 8), 0.5)
    pred = ref + 0.1
    pred[:, 0, 0] = 9.0  # a firefly outside the region
    mask = torch.ones(8, 8, dtype=torch.bool)
    mask[0, 0] = False
    region = FrameMetrics(["blind_max", "masked_max"]).update(pred, ref, mask=mask)
    assert region == {"blind_max": pytest.approx(0.1), "masked_max": pytest.approx(0.1)}
    whole = FrameMetrics(["blind_max", "masked_max"]).update(pred, ref)
    assert whole == {"blind_max": pytest.approx(8.5), "masked_max": pytest.approx(8.5)}


# -- sequence metrics ------------------------------------------------------------------------------


def test_a_sequence_metric_scores_each_sequence_once_and_gives_every_frame_its_pair(monkeypatch):
    """A value of the whole sequence (its frame count times 10 plus its first frame's max error,
    which no frame has alone): the update runs once per sequence, when the pairs are read; an
    empty frame ends a sequence; frames added after a read extend theirs, scored again."""
    calls = []

    def whole(pairs):
        calls.append(len(pairs))
        first = float(pairs[0].err.abs().max())
        return torch.tensor([10.0 * len(pairs) + first, 1.0], dtype=torch.float64)

    monkeypatch.setitem(METRIC_TABLE, "whole", Metric(whole, default=False, sequence=True))
    acc = FrameMetrics(["mse", "whole"])
    frames = [_pair(seed=k) for k in range(5)]
    firsts = [float((p - r).abs().max()) for p, r in frames]
    assert np.isnan(acc.update(*frames[0], group=0)["whole"])  # not known before the end
    acc.update(*frames[2], group=0)
    acc.update_empty(group=0)
    acc.update(*frames[3], group=0)  # a second sequence of seed set 0
    for k in (1, 4, 0, 1):
        acc.update(*frames[k], group=1)
    assert calls == []
    stats = acc.stats("whole")
    assert sorted(calls) == [1, 2, 4]
    assert stats[0].tolist() == [[20 + firsts[0], 1.0]] * 2 + [[0.0, 0.0], [10 + firsts[3], 1.0]]
    assert stats[1].tolist() == [[40 + firsts[1], 1.0]] * 4
    acc.stats("whole")
    assert sorted(calls) == [1, 2, 4]  # read again: nothing scored again
    acc.update(*frames[4], group=0)  # extends seed set 0's second sequence
    acc.update(*frames[2], group=1)
    stats = acc.stats("whole")
    assert sorted(calls) == [1, 2, 2, 4, 5]
    assert stats[0, 3:].tolist() == [[20 + firsts[3], 1.0]] * 2
    assert stats[1].tolist() == [[50 + firsts[1], 1.0]] * 5
    assert acc.compute()["mse"].n == acc.compute()["whole"].n
