"""``bnerr train``: render a training set with our renderer and train the U-Net denoiser.

    bnerr train --out denoisers/weights/unet.pt --mix white

Steps: (1) render ``--scenes`` random held-out scenes (``benchmarks.training_data``), cached in
``OUT.data`` so that a resumed run does not render again; (2) train
(:func:`denoisers.train.train`) with a checkpoint in ``OUT.ckpt`` every ``--checkpoint-every``
steps; (3) write the weights to ``OUT`` with the command line, the settings and the loss curve in
their metadata. ``--resume`` continues an interrupted run from its checkpoint; the result is the
same as an uninterrupted run. ``--minutes`` caps the wall time of this call (the run then stops
at a checkpoint and writes the weights so far; ``--resume`` continues it).

Before rendering, the sizes (``--size``, ``--scenes``, ``--batch-size``) are checked against the
memory they need and ``OUT``, ``OUT.data`` and ``OUT.ckpt`` against their kind, writability and
free space (``--out`` naming an existing folder fails at once, not after training). While it
runs, ``bnerr train`` holds a lock on ``OUT`` (a second run into the same ``OUT`` refuses) and
first removes the hidden temporaries a killed run left next to those three files.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import asdict
from pathlib import Path

import torch

from benchmarks.commands._args import MAX_MINUTES, positive_float, positive_int, seed_int
from benchmarks.training_data import TrainingSpec, make_pairs, training_paths, training_set_bytes
from bnerr.errors import ValueRangeError, check_memory
from bnerr.outputs import check_output, clean_stale_temporaries, output_lock
from denoisers.train import TrainConfig, TrainingSet, make_training_set, step_bytes, train
from denoisers.unet import atomic_torch_save, check_parameter_count, parameter_count, save_weights
from renderers import get_scene
from renderers.budget import SHOW_ESTIMATE_S, TIME_LIMIT_S, check_render_time, format_seconds

__all__ = ["canonical_command", "load_or_render", "register", "run"]

#: v2: the ``white+blue`` mix makes its blue inputs with the benchmark's strategies
#: (``benchmarks.training_data.BLUE_STRATEGIES``); v1 rendered them with the bnds sampler.
DATA_FORMAT = "bnerr-training-set-v2"


def check_data_time(spec: TrainingSpec) -> None:
    """Refuse rendering ``spec``'s data beyond :data:`TIME_LIMIT_S` by the time model (cornell's
    measured throughput stands for the random rooms'); print the estimate beyond 10 s."""
    paths = training_paths(spec)
    what = f"--size {spec.size} --scenes {spec.scenes} --reference-spp {spec.reference_spp}"
    seconds = check_render_time(get_scene("cornell"), paths, what, limit_s=TIME_LIMIT_S)
    if seconds > SHOW_ESTIMATE_S:
        print(f"bnerr train: rendering the data, estimated {format_seconds(seconds)}", flush=True)


def load_or_render(
    spec: TrainingSpec, path: Path, progress: bool, force: bool = True
) -> TrainingSet:
    """The :class:`~denoisers.train.TrainingSet` of ``spec``: read from ``path`` if it holds
    that spec's data, else rendered and written there (atomically), after
    :func:`check_data_time` unless ``force``."""

    if path.exists():
        try:
            cached = torch.load(path, map_location="cpu", weights_only=True)
        except Exception:  # a damaged cache is rendered again, never trusted
            cached = None
        if (
            isinstance(cached, dict)
            and cached.get("format") == DATA_FORMAT
            and cached.get("spec") == asdict(spec)
        ):
            return TrainingSet(cached["inputs"], cached["targets"])
    if not force:
        check_data_time(spec)
    data = make_training_set(make_pairs(spec, progress=progress))
    atomic_torch_save(
        {
            "format": DATA_FORMAT,
            "spec": asdict(spec),
            "inputs": data.inputs,
            "targets": data.targets,
        },
        path,
    )
    return data


def canonical_command(args: argparse.Namespace) -> str:
    """The full command line that reproduces this run's weights (every setting spelled out)."""
    return (
        f"bnerr train --out {args.out} --mix {args.mix} --sampler {args.sampler} "
        f"--steps {args.steps} --scenes {args.scenes} "
        f"--size {args.size} --reference-spp {args.reference_spp} --batch-size {args.batch_size} "
        f"--crop {args.crop} --lr {args.lr} --loss {args.loss} "
        f"--checkpoint-every {args.checkpoint_every} "
        f"--seed {args.seed} --threads {args.threads}"
    )


def run(args: argparse.Namespace) -> int:

    before = torch.get_num_threads()
    torch.set_num_threads(args.threads)
    try:
        return _run(args)
    finally:
        torch.set_num_threads(before)


def _settings(args: argparse.Namespace) -> tuple[TrainingSpec, TrainConfig]:
    """The run's :class:`TrainingSpec` and :class:`TrainConfig`, checked before any work: the
    network's size, the memory the training set and a batch need, and the output files."""

    spec = TrainingSpec(
        scenes=args.scenes,
        size=args.size,
        reference_spp=args.reference_spp,
        mix=args.mix,
        seed=args.seed,
        sampler=args.sampler,
    )
    config = TrainConfig(
        steps=args.steps,
        batch_size=args.batch_size,
        crop=args.crop,
        lr=args.lr,
        seed=args.seed,
        checkpoint_every=args.checkpoint_every,
        loss=args.loss,
    )
    if config.crop > spec.size:
        raise ValueRangeError(
            f"--crop: expected at most --size ({spec.size}) pixels, got {config.crop}"
        )
    check_parameter_count(config.widths, "train: widths")
    check_memory(training_set_bytes(spec), f"--size {spec.size} with --scenes {spec.scenes}")
    check_memory(step_bytes(config), f"--batch-size {config.batch_size} with --crop {config.crop}")
    out = Path(args.out)
    weights = 4 * parameter_count(config.widths)
    # The data cache (inputs and targets), the checkpoint (weights and Adam's two moments).
    need = {
        out: weights,
        _data_path(out): training_set_bytes(spec, stored=True),
        _ckpt(out): 3 * weights,
    }
    for path, size in need.items():
        check_output(path, "file", need_bytes=sum(need.values()) if path == out else size)
    return spec, config


def _data_path(out: Path) -> Path:
    return out.with_name(out.name + ".data")


def _ckpt(out: Path) -> Path:
    return out.with_name(out.name + ".ckpt")


def _run(args: argparse.Namespace) -> int:

    start = time.perf_counter()
    spec, config = _settings(args)
    out = Path(args.out)
    names = [out.name, _data_path(out).name, _ckpt(out).name]
    with output_lock(out.parent, "bnerr train", lock_name=f".{out.name}.bnerr.lock"):
        # A run killed while writing left hidden temporaries of these files: this run owns them.
        clean_stale_temporaries(out.parent, names)
        return _train(args, spec, config, out, start)


def _train(
    args: argparse.Namespace, spec: TrainingSpec, config: TrainConfig, out: Path, start: float
) -> int:

    data = load_or_render(spec, _data_path(out), not args.no_progress, force=args.force)
    render_s = time.perf_counter() - start
    limit = None if args.minutes is None else max(args.minutes * 60.0 - render_s, 0.0)
    result = train(
        data,
        config,
        _ckpt(out),
        resume=args.resume,
        time_limit_s=limit,
        progress=not args.no_progress,
    )
    total_s = time.perf_counter() - start
    meta = {
        "command": canonical_command(args),
        "spec": asdict(spec),
        "config": asdict(config),
        "step": result.step,
        "finished": result.finished,
        "losses": [list(x) for x in result.losses],
        "seconds_this_call": {"render": render_s, "train": result.seconds, "total": total_s},
    }
    save_weights(result.model, out, meta=meta)
    if result.finished:
        state = "finished"
    else:
        state = f"stopped at step {result.step} of {config.steps} (--resume continues)"
    print(
        f"{state}; render {render_s:.0f} s, train {result.seconds:.0f} s, "
        f"total {total_s:.0f} s -> {out}"
    )
    for step, loss in result.losses:
        print(f"  step {step:6d}  loss {loss:.5f}")
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "train",
        help="render training data and train the U-Net denoiser",
        description=__doc__.split("\n\n")[0],
    )
    add = p.add_argument
    add("--out", required=True, metavar="WEIGHTS.pt", help="where to write the weights")
    add(
        "--mix",
        default="white",
        choices=("white", "white+blue"),
        help="noise of the training inputs: white (every input rendered with --sampler and "
        "random seeds), or white+blue (every second input made by the benchmark's temporal, "
        "zsobol or cycles_blue strategy instead; benchmarks.training_data.BLUE_STRATEGIES)",
    )
    add(
        "--sampler",
        default="owen_sobol",
        choices=("white", "owen_sobol"),
        help="per-pixel sampler of the white-noise inputs (the benchmark renders with owen_sobol)",
    )
    add("--steps", type=positive_int, default=2500, help="optimizer steps of the full run")
    add(
        "--minutes",
        type=positive_float(MAX_MINUTES),
        help="wall-time cap of this call (stops at a checkpoint)",
    )
    add("--resume", action="store_true", help="continue from OUT.ckpt")
    add("--scenes", type=positive_int, default=128, help="random training scenes (one pair each)")
    add("--size", type=positive_int, default=64, help="training image side in pixels")
    add("--reference-spp", type=positive_int, default=256, help="spp of the training references")
    add("--batch-size", type=positive_int, default=16)
    add("--crop", type=positive_int, default=48, help="crop side (multiple of 8, at most --size)")
    add("--lr", type=positive_float(10.0), default=2e-3, help="peak learning rate (Adam)")
    add(
        "--loss",
        default="l1_log+l1",
        choices=("l1_log", "l1_log+l1", "l1_log+l2", "relmse"),
        help="training loss",
    )
    add("--checkpoint-every", type=positive_int, default=100)
    add(
        "--threads",
        type=positive_int,
        default=2,
        help="torch threads (2: both cores of an idle 2-core machine, 1.7x faster than 1; 1 when "
        "the other core is busy, where two threads that wait on each other are slower)",
    )
    add("--seed", type=seed_int, default=0, help="seeds the scenes, the weights and the batches")
    add("--no-progress", action="store_true", help="no progress bars")
    add("--force", action="store_true", help="render the data even if its estimate exceeds 1 h")
    p.set_defaults(func=run)
