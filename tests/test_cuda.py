"""Everything that runs on the CPU runs unchanged on CUDA: strategies, tracer, denoisers, metrics
and a whole ``bnerr bench --device cuda`` sweep, each compared with the same work on the CPU.

Skipped with "needs CUDA" where torch has no CUDA device. ``BNERR_TEST_DEVICE=cpu`` runs every
test with the CPU standing in for the GPU (the comparisons then hold trivially): a check, on a
machine without a GPU, that this file has no typo before it meets one
(``benchmarks/device_check.sh`` runs it on the GPU).

Tolerances, and why:

- **Seeds**: equal bit for bit wherever no rendered value can have reached them (each
  strategy's first seed image; every seed image of a stateless strategy, whose candidates the
  oracle draws without looking). The temporal strategies sort by rendered colors, which round
  differently on the two devices, so their later seeds may differ.
- **Tracer**: the same seeds give paths that may branch differently where a comparison sits at
  a rounding boundary, so images are compared as Monte Carlo estimates: the image means within
  6 standard errors of a difference of two independent estimates (the per-pixel variance the
  tracer returns), and the per-pixel MSE between the devices below 4x what two independent
  renders would give. On the same device the same seeds give the same bits.
- **Denoisers**: cuDNN runs float32 convolutions in TF32 by default (10-bit mantissa, about
  1e-3 relative per product, compounding through the U-Net's layers, which run as
  :class:`denoisers.unet.UNet` on the GPU and its fused CPU twin on the CPU), so outputs agree
  to 3 % of the image's largest value per pixel and 0.3 % on average; a wrong device path
  (a lost channel, a buffer left unmoved) is off by far more.
- **Metrics**: float64 accumulations with float32 stages (blurs, the spectrum's FFT), summed in
  another order: 1e-5 relative.
- **Sweep**: white and ldbn render the same seeds on both devices, so their raw MSE agrees to
  5 % (references and frames differ by rounding only); every ratio to white of the CUDA run falls
  inside the CPU run's own 95 % interval for it, widened by 5 % (the temporal strategy's sort,
  and a tuning grid's near-tie, may follow another realisation: the interval is what that noise
  is).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import pytest
import torch

import denoisers
import renderers
from benchmarks.cli import main
from benchmarks.reports.table import summarize
from benchmarks.sweep.records import Record, load_records
from benchmarks.sweep.references import reference_seeds
from bnerr import sequences, strategies
from bnerr.errors import MissingExtraError
from bnerr.frame import Frame
from bnerr.metrics import FrameMetrics

_FORCED = os.environ.get("BNERR_TEST_DEVICE") or None

pytestmark = pytest.mark.skipif(
    _FORCED is None and not torch.cuda.is_available(), reason="needs CUDA"
)


def _device() -> str:
    """The device under test: ``cuda``, or ``BNERR_TEST_DEVICE`` (``cpu`` to check this file on
    a machine without a GPU)."""
    return _FORCED or "cuda"


def _on(x: torch.Tensor, device: str) -> bool:
    return x.device.type == torch.device(device).type


def _scene(name: str = "direct") -> renderers.Scene:
    return renderers.get_scene(name, animated=False)


def _sampler() -> sequences.Sampler:
    return sequences.make_sampler("owen_sobol")


def _play(name: str, device: str) -> tuple[bool, list[Frame], list[torch.Tensor]]:
    """Frames 0 and 1 of strategy ``name`` on ``device`` (direct, 16x16, 2 spp): whether it is
    stateful, its frames and every seed image it handed the renderer (on the CPU)."""
    scene = _scene()
    strategy = strategies.make_strategy(
        name, 16, 16, seed=3, sampler="owen_sobol", spp=2, dimensions=scene.dimensions,
        device=device,
    )  # fmt: skip
    given: list[torch.Tensor] = []

    def render(seeds: torch.Tensor, sampler: sequences.Sampler) -> Frame:
        given.append(seeds.detach().cpu().clone())
        return renderers.render(scene, 0, seeds.to(device), sampler, 2)

    frames = [strategy.frame(t, render) for t in range(2)]
    return bool(strategy.stateful), frames, given


@pytest.mark.parametrize("name", sorted(strategies.STRATEGIES))
def test_a_strategy_renders_on_the_device_with_the_cpu_seeds(name):
    device = _device()
    try:
        stateful, frames, given = _play(name, device)
    except MissingExtraError as err:
        pytest.skip(str(err))
    for frame in frames:
        assert _on(frame.color, device), f"{name}: frame on {frame.color.device}"
        assert bool(torch.isfinite(frame.color).all()), f"{name}: non-finite pixels"
    _, _, on_cpu = _play(name, "cpu")
    assert torch.equal(given[0], on_cpu[0]), f"{name}: first seeds differ from the CPU's"
    if not stateful:  # no rendered value reaches a stateless strategy's seeds
        assert len(given) == len(on_cpu)
        for mine, theirs in zip(given, on_cpu, strict=True):
            assert torch.equal(mine, theirs), f"{name}: seeds differ from the CPU's"


def _denoise(denoiser: denoisers.Denoiser, frames: list[Frame]) -> torch.Tensor:
    """The denoiser's output for the last of ``frames`` (a stateful one sees them all)."""
    out = torch.empty(0)
    for t, frame in enumerate(frames):
        stateful = getattr(denoiser, "stateful", False)
        out = denoiser(frame, t=t) if stateful else denoiser(frame)  # type: ignore[call-arg]
    return out


@pytest.mark.parametrize("name", sorted(denoisers.DENOISERS))
def test_a_denoiser_gives_its_output_on_the_device_close_to_the_cpu(name):
    if name == "cycles_oidn":
        pytest.skip("cycles_oidn computes nothing: it returns Cycles' own output of a Cycles frame")
    device = _device()
    scene = _scene()
    frames = [
        renderers.render(scene, t, reference_seeds(16, 16, t), _sampler(), 4) for t in range(2)
    ]
    try:
        expected = _denoise(denoisers.get_denoiser(name), frames)
        got = _denoise(denoisers.get_denoiser(name), [f.to(device) for f in frames])
    except MissingExtraError as err:
        pytest.skip(str(err))
    assert _on(got, device), f"{name}: output on {got.device}"
    assert got.dtype == frames[0].color.dtype, f"{name}: output {got.dtype}"
    assert got.shape == expected.shape
    scale = float(expected.abs().max()) or 1.0
    diff = (got.cpu() - expected).abs()
    assert float(diff.max()) <= 3e-2 * scale, f"{name}: max difference {float(diff.max())}"
    assert float(diff.mean()) <= 3e-3 * scale, f"{name}: mean difference {float(diff.mean())}"


@pytest.mark.parametrize("name", sorted(renderers.SCENES))
def test_the_tracer_on_the_device_agrees_with_the_cpu_within_the_noise(name):
    device = _device()
    scene = _scene(name)
    seeds = reference_seeds(32, 32, 0)
    cpu = renderers.render(scene, 0, seeds, _sampler(), 16)
    dev = renderers.render(scene, 0, seeds.to(device), _sampler(), 16)
    assert _on(dev.color, device)
    assert bool(torch.isfinite(dev.color).all())
    assert cpu.variance is not None and dev.variance is not None
    pixels = seeds.numel()
    var = cpu.variance.double()  # [3, H, W] variance of each pixel's mean
    standard_error = (2 * var.sum(dim=(1, 2))).sqrt() / pixels  # of a difference of two means
    gap = (dev.color.cpu().double().mean(dim=(1, 2)) - cpu.color.double().mean(dim=(1, 2))).abs()
    assert bool((gap <= 6 * standard_error + 1e-6).all()), f"{name}: means differ by {gap}"
    mse = float((dev.color.cpu().double() - cpu.color.double()).square().mean())
    assert mse <= 4 * 2 * float(var.mean()) + 1e-9, f"{name}: MSE {mse} between devices"
    again = renderers.render(scene, 0, seeds.to(device), _sampler(), 16)
    for buffer, image in dev.buffers().items():
        assert torch.equal(image, again.buffers()[buffer]), f"{name}: {buffer} not deterministic"


def test_frame_metrics_on_the_device_equal_the_cpu_to_rounding():
    device = _device()
    generator = torch.Generator().manual_seed(5)
    refs = [torch.rand(3, 32, 32, generator=generator) for _ in range(2)]
    preds = [r + 0.1 * torch.randn(3, 32, 32, generator=generator) for r in refs]
    mask = torch.rand(32, 32, generator=generator) > 0.3
    cpu, dev = FrameMetrics(), FrameMetrics()
    for pred, ref in zip(preds, refs, strict=True):
        for region in (None, mask):
            cpu.update(pred, ref, region)
            dev.update(pred.to(device), ref.to(device), None if region is None else mask.to(device))
    for name in cpu.names:
        expected, got = cpu.stats(name), dev.stats(name)
        assert torch.allclose(got, expected, rtol=1e-5, atol=1e-12), f"{name}: {got} {expected}"


def _sweep(out: Path, device: str) -> list[Record]:
    """A tiny ``bnerr bench --device DEVICE`` (direct, 16x16, 2 spp, 2 seed sets; white, temporal,
    ldbn; gaussian, atrous), in-process, with its own reference cache; its region-``all``
    records."""
    argv = ["bench", "--suite", "quick", "--scenes", "direct"]
    argv += ["--strategies", "white", "temporal", "ldbn", "--denoisers", "gaussian", "atrous"]
    argv += ["--spp", "2", "--res", "16x16", "--seed-sets", "2", "--frames", "2"]
    argv += ["--warmup", "2", "--reference-spp", "64", "--quiet", "--no-charts"]
    argv += ["--out", str(out / "results"), "--cache", str(out / "cache"), "--device", device]
    assert main(argv) == 0
    return [r for r in load_records(out / "results") if r.cell.region == "all"]


def _rows(records: list[Record]) -> dict[tuple, dict]:
    return {(r["strategy"], r["denoiser"]): r for r in summarize(records)}


def test_a_bench_sweep_on_the_device_agrees_with_the_cpu(tmp_path):
    device = _device()
    on_device = _sweep(tmp_path / "device", device)
    on_cpu = _sweep(tmp_path / "cpu", "cpu")
    for record in on_device:
        if torch.device(device).type == "cpu":
            assert record.device is None  # CPU records stay as they were
        else:
            assert record.device is not None and record.device["torch"] == torch.__version__
            assert record.device["device"].startswith("cuda")
    mine, theirs = _rows(on_device), _rows(on_cpu)
    assert sorted(mine) == sorted(theirs)
    for key, row in mine.items():
        base = theirs[key]
        if key[0] in ("white", "ldbn"):  # the same seeds on both devices
            assert math.isclose(row["raw_mse"], base["raw_mse"], rel_tol=0.05), key
        if key[0] == "white":
            continue  # its ratios are 1 by definition
        for ratio in ("raw_mse_ratio", "den_mse_ratio"):
            lo, hi = base[f"{ratio}_lo"] / 1.05, base[f"{ratio}_hi"] * 1.05
            assert lo <= row[ratio] <= hi, f"{key} {ratio}: {row[ratio]} not in [{lo}, {hi}]"
