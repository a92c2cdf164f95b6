"""A deadline-bounded, resumable run of LDBN key sets for a borrowed accelerator:
``python -m bnerr.ldbn.device`` (what ``benchmarks/ldbn_device.sh`` runs).

It imports only torch, numpy and bnerr's own torch code (no kornia, OpenEXR, scipy, tqdm), so it
runs on a bare machine with ``PYTHONPATH`` at the repository root. In order:

1. ``--measure``: the cost of one descent iteration, each pair alone (the sequential optimizer)
   and all pairs batched (one FFT over every pair), at each ``--measure`` size, printed;
2. every key set asked for (``--sets``; :data:`SETS`: the 128 x 128 screen set to 64 spp and the
   128 x 128 x 4 spatiotemporal set to 16 spp, D = 12), one after another, each with a checkpoint
   ``<out>/<name>.ckpt.npz`` written after every round, and its final table ``<out>/<name>.npy``
   (int32 ``[L, F, T, T, D + D/2]``, :func:`bnerr.ldbn.keys.write_keys`) once it finishes; a
   table over ``--max-file-mib`` is written compressed as ``<name>.npz`` (array ``keys``; convert
   with ``--convert``);
3. at ``--budget`` seconds after the start (less a margin for the writes) the running round stops
   at its next iteration, the checkpoints keep every finished round, and ``<out>/NOTE.txt`` says
   what finished; a second call with the same ``--out`` (the checkpoints copied back) continues.

Progress goes to stdout with the seconds since the start.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch

from bnerr.errors import FileFormatError
from bnerr.io import atomic_write
from bnerr.ldbn.keys import KeyOptions, ldbn_file_name, run_keys, write_keys
from bnerr.ldbn.swaps import energy_kernel, swap_descents

__all__ = ["SETS", "convert", "main", "measure"]

#: The key sets a device run makes: name -> options (the device and iterations set per run).
#: D = 12: the first two bounces of every shipped scene (docs/METHODS.md, section 10).
SETS: dict[str, KeyOptions] = {
    "screen_128": KeyOptions(size=128, levels=7, dims=12, iterations=1000),
    "st_128x4": KeyOptions(size=128, levels=5, dims=12, frames=4, iterations=500),
}


class _Clock:
    """Seconds since the start, for the progress lines."""

    def __init__(self) -> None:
        self.start = time.monotonic()

    def __call__(self, text: str) -> None:
        print(f"[{time.monotonic() - self.start:7.1f} s] {text}", flush=True)


def _sync(device: torch.device) -> None:
    if device.type == "cuda":
        torch.cuda.synchronize(device)


def measure(
    size: int, pairs: int, iterations: int, device: str, components: int = 32
) -> tuple[float, float]:
    """Seconds per descent iteration of one ``size`` tile with ``components`` features: each of
    ``pairs`` descents alone (per pair), and all at once batched (per pair and iteration)."""
    dev = torch.device(device)
    gen = torch.Generator().manual_seed(size)
    x = torch.randn(pairs, size * size, components, generator=gen).to(dev)
    kernel = energy_kernel(size)
    seeds = torch.arange(pairs, dtype=torch.int32)
    swap_descents(x[:1], kernel, 2, seeds[:1])  # warm-up: plans, kernels
    _sync(dev)
    start = time.perf_counter()
    for p in range(pairs):
        swap_descents(x[p : p + 1], kernel, iterations, seeds[p : p + 1])
    _sync(dev)
    alone = (time.perf_counter() - start) / (pairs * iterations)
    start = time.perf_counter()
    swap_descents(x, kernel, iterations, seeds)
    _sync(dev)
    batched = (time.perf_counter() - start) / (pairs * iterations)
    return alone, batched


def _file(out: Path, opts: KeyOptions, suffix: str) -> Path:
    return out / ldbn_file_name(*_kind(opts)).replace(".npy", suffix)


def _kind(opts: KeyOptions) -> tuple[str, int, int]:
    return ("screen" if opts.frames == 1 else "st", opts.size, opts.frames)


def _write_table(
    out: Path, opts: KeyOptions, arrays: tuple[np.ndarray, np.ndarray], mib: float
) -> Path:
    """The finished table as ``.npy``, or compressed ``.npz`` when larger than ``mib``."""
    scramble, rank = arrays
    if (scramble.nbytes + rank.nbytes) / 2**20 <= mib:
        path = _file(out, opts, ".npy")
        write_keys(path, scramble, rank)
        return path
    path = _file(out, opts, ".npz")
    with atomic_write(path) as tmp, open(tmp, "wb") as f:
        np.savez_compressed(f, keys=np.concatenate([scramble, rank], -1).astype(np.int32))
    return path


def _run_set(name: str, opts: KeyOptions, args: argparse.Namespace, clock: _Clock) -> str:
    """One key set up to the deadline: its line for NOTE.txt."""
    total, done = opts.steps(), [0]
    last = [time.monotonic()]

    def progress(count: int) -> None:
        done[0] += count
        if time.monotonic() - last[0] >= args.every:
            last[0] = time.monotonic()
            clock(f"{name}: {done[0]}/{total} job-iterations ({100 * done[0] / total:.1f} %)")

    ckpt = _file(args.out, opts, ".ckpt.npz")
    deadline = clock.start + args.budget - args.margin
    clock(f"{name}: start {opts} -> {ckpt}")
    scramble, rank, finished = run_keys(opts, ckpt, progress, deadline)
    if not finished:
        clock(f"{name}: stopped at the deadline, {done[0]}/{total} job-iterations kept in {ckpt}")
        return f"{name}: UNFINISHED, {done[0]}/{total} job-iterations; rerun to continue"
    path = _write_table(args.out, opts, (scramble, rank), args.max_file_mib)
    clock(f"{name}: finished -> {path}")
    return f"{name}: finished -> {path.name} ({opts})"


def convert(source: Path, target: Path) -> None:
    """A compressed table ``.npz`` (array ``keys``) or a finished checkpoint -> ``.npy``."""
    with np.load(source, allow_pickle=False) as data:
        if "keys" in data:
            keys = data["keys"]
        elif "stage" in data:
            keys = np.concatenate([data["scramble"], data["rank"]], -1)
        else:
            raise FileFormatError(f"{source}: expected a key table or a checkpoint")
    with atomic_write(target) as tmp:
        np.save(tmp, keys.astype(np.int32), allow_pickle=False)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m bnerr.ldbn.device", description=__doc__)
    p.add_argument("--out", type=Path, help="folder of the checkpoints, tables and NOTE.txt")
    p.add_argument("--device", default="cuda" if torch.cuda.is_available() else "cpu")
    p.add_argument("--sets", nargs="*", default=list(SETS), choices=list(SETS))
    p.add_argument("--budget", type=float, default=400.0, help="seconds from the start")
    p.add_argument("--margin", type=float, default=15.0, help="seconds kept for the writes")
    p.add_argument("--every", type=float, default=10.0, help="seconds between progress lines")
    p.add_argument("--measure", type=int, nargs="*", default=[], help="tile sizes to time")
    p.add_argument("--measure-iterations", type=int, default=20)
    p.add_argument("--max-file-mib", type=float, default=15.0)
    p.add_argument("--tiny", action="store_true", help="16 x 16 tiles, 2 levels, D 4: a test")
    p.add_argument("--convert", type=Path, nargs=2, metavar=("IN", "OUT"), default=None)
    return p


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.convert is not None:
        convert(*args.convert)
        return 0
    clock = _Clock()
    clock(f"torch {torch.__version__}, device {args.device}, threads {torch.get_num_threads()}")
    for size in args.measure:
        alone, batched = measure(size, 6, args.measure_iterations, args.device)
        clock(
            f"{size}x{size}, 6 pairs: {1e3 * alone:.2f} ms per pair-iteration alone, "
            f"{1e3 * batched:.2f} batched"
        )
    if args.out is None:
        return 0
    args.out.mkdir(parents=True, exist_ok=True)
    notes = []
    for name in args.sets:
        opts = replace(SETS[name], device=args.device)
        if args.tiny:
            opts = replace(opts, size=16, levels=2, dims=4, tests=16, components=8, iterations=8)
        notes.append(_run_set(name, opts, args, clock))
    with atomic_write(args.out / "NOTE.txt") as tmp:
        Path(tmp).write_text("\n".join(notes) + "\n")
    clock("done:\n  " + "\n  ".join(notes))
    return 0


if __name__ == "__main__":
    sys.exit(main())
