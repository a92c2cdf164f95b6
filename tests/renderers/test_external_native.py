"""The C example (examples/native/tracer.c) against bnerr: built with the system compiler, its
sampler gives bnerr's values bit for bit (per-pixel Owen-Sobol from the seed file, and LDBN from
the exported header), and its frames come back through the seed protocol with every buffer."""

from __future__ import annotations

import argparse
import shutil
import subprocess

import numpy as np
import pytest
import torch

from benchmarks.commands import export
from bnerr.sequences import make_sampler, owen_sobol
from bnerr.strategies import make_strategy, pixel_seeds
from renderers.external import (
    ExternalRenderer,
    command_manifest,
    sampler_values,
    write_seed_file,
)
from tests._paths import ROOT

H, W, SPP, DIMS = 12, 10, 4, 8


@pytest.fixture(scope="module")
def tracer(tmp_path_factory):
    """The built tracer and the exported screen-space LDBN header, in one folder."""
    compiler = shutil.which("cc")
    if compiler is None:
        pytest.skip("no C compiler 'cc' on the PATH: the native example cannot be built")
    folder = tmp_path_factory.mktemp("native")
    source = ROOT / "examples" / "native" / "tracer.c"
    build = [compiler, "-O2", "-Wall", "-Werror", "-o", str(folder / "tracer"), str(source), "-lm"]
    subprocess.run(build, check=True, capture_output=True, timeout=120)
    args = dict(ldbn="screen", stbn=None, fast=False, size=64, format="h", out=folder)
    export.run(argparse.Namespace(**args))  # bnerr export --ldbn screen --format h
    return folder


def _dump(tracer, seeds: torch.Tensor, extra: list[str]) -> np.ndarray:
    write_seed_file(tracer / "seeds.bin", seeds)
    argv = [str(tracer / "tracer"), "--seeds", str(tracer / "seeds.bin"), "--spp", str(SPP)]
    argv += [*extra, "--dump-samples", str(tracer / "dump.bin")]
    subprocess.run(argv, check=True, capture_output=True, timeout=60)
    return np.fromfile(tracer / "dump.bin", dtype="<f4").reshape(H, W, SPP, DIMS)


def test_its_owen_sobol_gives_bnerrs_values_for_the_same_seeds(tracer):
    seeds = pixel_seeds(H, W, 11)
    index = torch.arange(SPP)[None, None, :, None]
    expected = owen_sobol(seeds[:, :, None, None], index, torch.arange(DIMS)).numpy()
    assert np.array_equal(_dump(tracer, seeds, []), expected)


@pytest.mark.parametrize("t", [0, 7])
def test_its_ldbn_lookup_gives_bnerrs_values_from_the_exported_header(tracer, t):
    strategy = make_strategy("ldbn", H, W, seed=2, spp=SPP)
    sampler, seeds = strategy.sampler(t), strategy.seeds(t)
    manifest = command_manifest(
        "./tracer {seeds} {spp} {out} {sampler} {ldbn_keys} {ldbn_slice} {ldbn_offset_y} "
        "{ldbn_offset_x}",
        folder=tracer,
    )
    values = sampler_values(manifest, sampler)
    extra = ["--sampler", "ldbn", "--ldbn", str(tracer / f"{values['ldbn_keys']}.h")]
    for key in ("ldbn_slice", "ldbn_offset_y", "ldbn_offset_x"):
        extra += [f"--{key.replace('_', '-')}", values[key]]
    y, x = torch.meshgrid(torch.arange(H), torch.arange(W), indexing="ij")
    pixel = torch.stack([y, x], -1).reshape(-1, 1, 2).expand(-1, SPP, 2).reshape(-1, 2)
    lanes = seeds.reshape(-1, 1).expand(-1, SPP).reshape(-1)
    expected = sampler.sample(lanes, torch.arange(SPP).repeat(H * W), 0, DIMS, pixel=pixel)
    assert np.array_equal(_dump(tracer, seeds, extra), expected.numpy().reshape(H, W, SPP, DIMS))


def test_its_frames_come_back_through_the_protocol_with_every_buffer(tracer):
    renderer = ExternalRenderer(
        command_manifest("./tracer --seeds {seeds} --spp {spp} --out {out}", folder=tracer)
    )
    seeds = torch.stack([pixel_seeds(H, W, k) for k in range(2)])
    one, two = renderer.render_batch(0, seeds, make_sampler("owen_sobol"), 2)
    again = renderer.render(0, seeds[0], make_sampler("owen_sobol"), 2)
    assert torch.equal(one.color, again.color) and not torch.equal(one.color, two.color)
    for name in ("albedo", "normal", "depth", "object_id"):
        assert getattr(one, name) is not None, name
    assert set(one.object_id.unique().tolist()) <= {-1.0, 0.0, 1.0, 2.0}
    assert float(one.color.mean()) > 0 and one.timings["render"] > 0
