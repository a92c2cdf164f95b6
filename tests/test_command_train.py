"""Tests of benchmarks/commands/train.py: ``bnerr train`` end to end on a tiny configuration."""

import torch

from benchmarks.cli import main
from denoisers.unet import load_weights

TINY = ["--scenes", "2", "--size", "8", "--reference-spp", "2", "--steps", "4", "--crop", "8",
        "--batch-size", "2", "--checkpoint-every", "2", "--no-progress"]


def test_train_writes_weights_with_their_command_and_resumes(tmp_path, capsys):
    out = tmp_path / "w.pt"
    assert main(["train", "--out", str(out), *TINY]) == 0
    assert "finished" in capsys.readouterr().out
    payload = torch.load(out, weights_only=True)
    meta = payload["meta"]
    assert meta["finished"] and meta["step"] == 4 and [s for s, _ in meta["losses"]] == [2, 4]
    assert meta["command"].startswith(f"bnerr train --out {out} --mix white --sampler owen_sobol --steps 4 --scenes 2 --size 8")
    assert (tmp_path / "w.pt.data").exists() and (tmp_path / "w.pt.ckpt").exists()
    first = load_weights(out).state_dict()
    # Resuming a finished run (the cached data is reused, nothing is trained again) keeps the weights.
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
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices["train"]
    choices = {a.dest: tuple(a.choices) for a in sub._actions if a.choices}
    assert choices == {"mix": MIXES, "sampler": SAMPLERS, "loss": LOSSES}
