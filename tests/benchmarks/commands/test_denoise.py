"""Tests of benchmarks/commands/denoise.py: ``bnerr denoise`` on frame files."""

import pytest
import torch

from benchmarks.cli import main
from benchmarks.commands.denoise import parse_params
from bnerr.errors import DtypeError
from bnerr.io import read_frame, write_frame
from denoisers import get_denoiser
from denoisers.tuning import ParamStore, TuneResult
from tests._images import random_frame


def _frame_file(tmp_path, drop=()):
    drop = ("motion", "object_id", *drop)
    frame = random_frame(10, 12, scale=2.0, drop=drop, timings={"render": 12.5})
    path = tmp_path / "frame.exr"
    write_frame(path, frame)
    return path, read_frame(path)


def test_denoise_writes_the_denoised_frame(tmp_path):
    path, frame = _frame_file(tmp_path)
    out = tmp_path / "out.exr"
    assert (
        main(
            [
                "denoise",
                "--denoiser",
                "gaussian",
                "--in",
                str(path),
                "--out",
                str(out),
                "--params",
                "sigma=1.5",
            ]
        )
        == 0
    )
    result = read_frame(out)
    assert torch.equal(result.color, get_denoiser("gaussian", sigma=1.5)(frame))
    assert torch.equal(result.albedo, frame.albedo) and torch.equal(result.depth, frame.depth)
    assert result.timings["render"] == 12.5 and result.timings["denoise"] > 0


def test_denoise_with_tuned_parameters(tmp_path):
    path, frame = _frame_file(tmp_path)
    store = ParamStore()
    store.put(TuneResult("median", {"kernel_size": 5}, 0.1, 0.2, 1), "cornell", 4)
    store.save(tmp_path / "p.json")
    out = tmp_path / "out.exr"
    args = [
        "denoise",
        "--denoiser",
        "median",
        "--in",
        str(path),
        "--out",
        str(out),
        "--tuned",
        str(tmp_path / "p.json"),
    ]
    assert main(args + ["--scene", "cornell", "--spp", "4"]) == 0
    assert torch.equal(read_frame(out).color, get_denoiser("median", kernel_size=5)(frame))
    assert main(args) == 2  # --tuned without --scene and --spp


def test_bad_input_exits_with_a_named_error(tmp_path, capsys):
    path, _ = _frame_file(tmp_path, drop=("depth",))
    out = str(tmp_path / "out.exr")
    assert main(["denoise", "--denoiser", "atrous", "--in", str(path), "--out", out]) == 2
    assert "without depth" in capsys.readouterr().err
    assert main(["denoise", "--denoiser", "box", "--in", str(path), "--out", out]) == 2
    assert "unknown denoiser 'box'" in capsys.readouterr().err
    assert (
        main(
            ["denoise", "--denoiser", "gaussian", "--in", str(tmp_path / "none.exr"), "--out", out]
        )
        == 2
    )
    assert "none.exr" in capsys.readouterr().err


def test_parse_params():
    assert parse_params(["sigma=1.5", "kernel_size=3", "weights=w.pt"]) == {
        "sigma": 1.5,
        "kernel_size": 3,
        "weights": "w.pt",
    }
    with pytest.raises(DtypeError, match="--params: expected KEY=VALUE, got 'sigma'"):
        parse_params(["sigma"])


# -- issue 18 -------------------------------------------------------------------------------------


def test_tuned_parameters_by_scene_name_alone(tmp_path, capsys):
    path, frame = _frame_file(tmp_path)
    store = ParamStore()
    store.put(
        TuneResult("median", {"kernel_size": 5}, 0.1, 0.2, 1), "direct/m1/owen_sobol/128x128", 4
    )
    store.put(TuneResult("median", {"kernel_size": 3}, 0.1, 0.2, 1), "cornell/m1/white/64x64", 4)
    store.put(TuneResult("median", {"kernel_size": 3}, 0.1, 0.2, 1), "cornell/m1/white/64x64", 8)
    store.put(TuneResult("median", {"kernel_size": 3}, 0.1, 0.2, 1), "snooker/m1/white/64x64", 4)
    store.put(TuneResult("median", {"kernel_size": 3}, 0.1, 0.2, 1), "snooker/m2/white/64x64", 4)
    store.save(tmp_path / "p.json")
    out = tmp_path / "out.exr"
    args = ["denoise", "--denoiser", "median", "--in", str(path), "--out", str(out)]
    args += ["--tuned", str(tmp_path / "p.json")]
    assert main(args + ["--scene", "direct"]) == 0
    assert torch.equal(read_frame(out).color, get_denoiser("median", kernel_size=5)(frame))
    assert main(args + ["--scene", "cornell", "--spp", "8"]) == 0
    assert main(args + ["--scene", "cornell"]) == 2
    assert "cornell/m1/white/64x64, which holds 4, 8 spp" in capsys.readouterr().err
    assert main(args + ["--scene", "snooker"]) == 2
    err = capsys.readouterr().err
    assert "got 2: snooker/m1/white/64x64, snooker/m2/white/64x64" in err


@pytest.mark.parametrize("buffer", ["normal", "albedo"])
def test_nan_guides_never_give_a_nan_output_with_exit_0(tmp_path, capsys, buffer):
    path, frame = _frame_file(tmp_path)
    getattr(frame, buffer)[:, 2:6, 3:7] = float("nan")  # 16 NaN pixels
    write_frame(path, frame)
    out = tmp_path / "out.exr"
    assert main(["denoise", "--denoiser", "unet", "--in", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"frame.{buffer}: expected finite values, got 48 NaN" in err
    assert "first at pixel (y, x) = (2, 3)" in err and not out.exists()


@pytest.mark.parametrize(
    ("out", "message"),
    [
        ("dir.exr", "expected a file name, got an existing folder"),
        ("/proc/self/out.exr", "expected a writable folder"),
        ("frame.exr", "expected a file other than --in"),
    ],
)
def test_bad_output_files_fail_before_denoising_in_one_line(tmp_path, capsys, out, message):
    path, _ = _frame_file(tmp_path)
    (tmp_path / "dir.exr").mkdir()
    target = out if out.startswith("/") else str(tmp_path / out)
    args = ["denoise", "--denoiser", "gaussian", "--in", str(path), "--out", target]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err


def test_denoise_on_a_device_it_cannot_use_refuses_before_writing(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    path, _ = _frame_file(tmp_path)
    out = tmp_path / "out.exr"
    args = ["denoise", "--denoiser", "gaussian", "--in", str(path), "--out", str(out)]
    assert main([*args, "--device", "cuda"]) == 2
    assert "--device: expected an available device (cpu), got cuda" in capsys.readouterr().err
    assert not out.exists()
    assert main([*args, "--device", "cpu"]) == 0 and out.exists()


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
def test_denoise_on_cuda_writes_what_the_cpu_does_to_rounding(tmp_path):
    path, frame = _frame_file(tmp_path)
    args = ["denoise", "--denoiser", "atrous", "--in", str(path)]
    assert main([*args, "--out", str(tmp_path / "cpu.exr")]) == 0
    assert main([*args, "--out", str(tmp_path / "cuda.exr"), "--device", "cuda"]) == 0
    cpu, cuda = read_frame(tmp_path / "cpu.exr").color, read_frame(tmp_path / "cuda.exr").color
    assert torch.allclose(cuda, cpu, rtol=0, atol=3e-2 * float(cpu.abs().max()))  # cuDNN's TF32


@pytest.mark.parametrize(("name", "kind"), [("gaussian", "filter"), ("unet", "learned")])
def test_denoise_says_the_denoisers_kind(tmp_path, capsys, name, kind):
    """Issue 54: a denoiser's kind, which the plug-in docs describe, appeared in no output."""
    path, _ = _frame_file(tmp_path)
    out = tmp_path / "out.exr"
    assert main(["denoise", "--denoiser", name, "--in", str(path), "--out", str(out)]) == 0
    line = capsys.readouterr().out.strip()
    assert f"({kind}): 12x10 in " in line and line.endswith(f"-> {out}")
