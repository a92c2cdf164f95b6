"""Tests of benchmarks/commands/train.py: ``bnerr train`` end to end on a tiny configuration."""

import torch

from benchmarks.cli import main
from denoisers.unet import load_weights

TINY = [
    "--scenes",
    "2",
    "--size",
    "8",
    "--reference-spp",
    "2",
    "--steps",
    "4",
    "--crop",
    "8",
    "--batch-size",
    "2",
    "--checkpoint-every",
    "2",
    "--no-progress",
]


def test_train_writes_weights_with_their_command_and_resumes(tmp_path, capsys):
    out = tmp_path / "w.pt"
    assert main(["train", "--out", str(out), *TINY]) == 0
    assert "finished" in capsys.readouterr().out
    payload = torch.load(out, weights_only=True)
    meta = payload["meta"]
    assert meta["finished"] and meta["step"] == 4 and [s for s, _ in meta["losses"]] == [2, 4]
    assert meta["command"].startswith(
        f"bnerr train --out {out} --mix white --sampler owen_sobol --steps 4 --scenes 2 --size 8"
    )
    assert (tmp_path / "w.pt.data").exists() and (tmp_path / "w.pt.ckpt").exists()
    first = load_weights(out).state_dict()
    # Resuming a finished run (the cached data is reused, nothing is trained again) keeps the
    # weights.
    assert main(["train", "--out", str(out), *TINY, "--resume"]) == 0
    again = load_weights(out).state_dict()
    assert all(torch.equal(first[k], again[k]) for k in first)


def test_corrupt_checkpoint_is_a_clean_error(tmp_path, capsys):
    out = tmp_path / "w.pt"
    (tmp_path / "w.pt.ckpt").write_bytes(b"garbage")
    assert main(["train", "--out", str(out), *TINY, "--resume"]) == 2
    assert "w.pt.ckpt: expected a training checkpoint" in capsys.readouterr().err


def test_sampler_choice_reaches_the_training_set_and_the_command(tmp_path):
    out = tmp_path / "w.pt"
    assert main(["train", "--out", str(out), *TINY, "--sampler", "white"]) == 0
    meta = torch.load(out, weights_only=True)["meta"]
    assert meta["spec"]["sampler"] == "white" and " --sampler white " in meta["command"]
    data = torch.load(tmp_path / "w.pt.data", weights_only=True)
    assert data["spec"]["sampler"] == "white"


def test_white_blue_mix_reaches_the_training_set_and_a_v1_cache_is_rendered_again(tmp_path):
    from benchmarks.commands.train import DATA_FORMAT, load_or_render
    from benchmarks.training_data import TrainingSpec, make_pairs
    from denoisers.train import make_training_set

    out = tmp_path / "w.pt"
    assert main(["train", "--out", str(out), *TINY, "--mix", "white+blue"]) == 0
    meta = torch.load(out, weights_only=True)["meta"]
    assert meta["spec"]["mix"] == "white+blue" and " --mix white+blue " in meta["command"]
    data = torch.load(tmp_path / "w.pt.data", weights_only=True)
    assert data["format"] == DATA_FORMAT == "bnerr-training-set-v2"
    spec = TrainingSpec(**data["spec"])
    expected = make_training_set(make_pairs(spec, progress=False))
    assert torch.equal(data["inputs"], expected.inputs)
    # A cache of the same spec written before the blue inputs came from the strategies (v1:
    # bnds) is not trusted: the set is rendered again.
    stale = tmp_path / "stale.data"
    torch.save({**data, "format": "bnerr-training-set-v1", "inputs": data["inputs"] * 0}, stale)
    assert torch.equal(load_or_render(spec, stale, progress=False).inputs, expected.inputs)


def test_cli_choices_are_the_libraries_names():
    # The command spells its choices out so that ``bnerr`` starts without importing torch-heavy
    # modules; this keeps them equal to the names the libraries accept.
    import argparse

    from benchmarks.commands.train import register
    from benchmarks.training_data import MIXES, SAMPLERS
    from denoisers.train import LOSSES

    parser = argparse.ArgumentParser()
    register(parser.add_subparsers())
    train = parser.parse_args(["train", "--out", "w.pt"])
    assert train.loss == "l1_log+l1" and train.mix == "white" and train.sampler == "owen_sobol"
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[
        "train"
    ]
    choices = {a.dest: tuple(a.choices) for a in sub._actions if a.choices}
    assert choices == {"mix": MIXES, "sampler": SAMPLERS, "loss": LOSSES}


# -- issue 18: checked before rendering or training; one writer; stale temporaries ---------------


def _no_work(monkeypatch):
    import pytest

    from benchmarks.commands import train as command

    monkeypatch.setattr(command, "make_pairs", lambda *a, **k: pytest.fail("rendered"))


def test_out_naming_an_existing_folder_fails_before_training(tmp_path, capsys, monkeypatch):
    _no_work(monkeypatch)
    (tmp_path / "w.pt").mkdir()
    assert main(["train", "--out", str(tmp_path / "w.pt"), *TINY]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "w.pt: expected a file name, got an existing folder" in err


def test_out_under_proc_fails_before_training(capsys, monkeypatch):
    _no_work(monkeypatch)
    assert main(["train", "--out", "/proc/self/w.pt", *TINY]) == 2
    assert "expected a writable folder" in capsys.readouterr().err


def test_absurd_sizes_are_refused_before_rendering(tmp_path, capsys, monkeypatch):
    _no_work(monkeypatch)
    out = str(tmp_path / "w.pt")
    assert main(["train", "--out", out, *TINY, "--size", "100000"]) == 2
    assert "--size 100000 with --scenes 2: expected a size that fits in memory" in (
        capsys.readouterr().err
    )
    assert main(["train", "--out", out, *TINY, "--batch-size", "100000000"]) == 2
    assert "--batch-size 100000000 with --crop 8: expected a size that fits" in (
        capsys.readouterr().err
    )
    assert main(["train", "--out", out, *TINY, "--crop", "16"]) == 2
    assert "--crop: expected at most --size (8) pixels, got 16" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_a_second_train_into_the_same_out_refuses(tmp_path, capsys, monkeypatch):
    from bnerr.outputs import output_lock

    _no_work(monkeypatch)
    with output_lock(tmp_path, "bnerr train", lock_name=".w.pt.bnerr.lock"):
        assert main(["train", "--out", str(tmp_path / "w.pt"), *TINY]) == 2
    assert "another bnerr train holds its lock" in capsys.readouterr().err


def test_temporaries_a_killed_run_left_are_removed_at_the_next_start(tmp_path):
    import subprocess
    import sys

    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    stale = [
        tmp_path / f".w.pt.ckpt.bnerr-tmp-{proc.pid}-0123abcd.ckpt",
        tmp_path / ".w.pt.ckpt.0123456789ab.tmp.ckpt",  # the naming before issue 18
    ]
    for path in stale:
        path.write_bytes(b"half a checkpoint")
    assert main(["train", "--out", str(tmp_path / "w.pt"), *TINY]) == 0
    assert not any(path.exists() for path in stale)
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == [".w.pt.bnerr.lock", "w.pt", "w.pt.ckpt", "w.pt.data"]


def test_the_blue_trained_weights_record_unet_pts_command_with_the_white_blue_mix():
    from denoisers.unet import DEFAULT_WEIGHTS, UNetDenoiser

    blue = DEFAULT_WEIGHTS.with_name("unet_blue.pt")
    meta = torch.load(blue, weights_only=True)["meta"]
    white = torch.load(DEFAULT_WEIGHTS, weights_only=True)["meta"]
    assert meta["finished"] and meta["step"] == 2500 and meta["spec"]["mix"] == "white+blue"
    readme = (blue.parent / "README.md").read_text()
    assert f"\n{meta['command']}\n" in readme
    expected = (
        white["command"]
        .replace("unet.pt", "unet_blue.pt")
        .replace("--mix white ", "--mix white+blue ")
    )
    assert meta["command"] == expected and meta["config"] == white["config"]
    assert UNetDenoiser(blue).model.widths == UNetDenoiser().model.widths
