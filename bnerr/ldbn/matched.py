"""``python -m bnerr.ldbn.matched``: LDBN keys optimized for a measured denoiser kernel.

FAST's lesson (Donnelly et al. 2024) is that a mask optimized for the filter actually applied beats
a generic one. ``benchmarks.studies.denoiser_kernels`` measures the effective kernel of our
denoisers and writes its autocorrelation (``<denoiser>_<spp>_autocorr.npy``, ``[K, K]``, centred);
this command optimizes a key set whose energy weighs exactly that autocorrelation
(:func:`bnerr.ldbn.swaps.measured_kernel`, ``KeyOptions.kernel``) and writes it in the shipped
layout (:func:`bnerr.ldbn.keys.write_keys`). It imports only torch and numpy (and bnerr's
torch-only modules), so it runs on a bare GPU machine::

    python3 -m bnerr.ldbn.matched --kernel atrous_4_autocorr.npy --spp 16 --device cuda \\
        --out ldbn_atrous_64.npy

The defaults are the shipped ``ldbn`` set's (64 x 64, 8 dimensions, 600 iterations per stage,
seed 0, the shared sequence's seed 18). The descents run batched on ``--device``
(``KeyOptions.device``, :func:`bnerr.ldbn.keys.optimize_keys`). The checkpoint (``--checkpoint``,
default the output with ``.ckpt.npz``) is written after each round and a rerun resumes from it;
it is removed once the output is written. With the same arguments on one device a rerun is the
same bit for bit.
"""

from __future__ import annotations

import argparse
import hashlib
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch

from bnerr.errors import FileFormatError, ValueRangeError
from bnerr.ldbn.keys import KeyOptions, optimize_keys, write_keys

__all__ = ["main", "matched_options"]


def matched_options(
    kernel: np.ndarray,
    spp: int = 16,
    size: int = 64,
    iterations: int = 600,
    seed: int = 0,
    device: str = "cpu",
) -> KeyOptions:
    """The key options for the autocorrelation ``kernel [K, K]``, tiles for 1 .. ``spp`` samples
    (a power of two), 8 dimensions (as the shipped ``ldbn`` set), the descents on ``device``."""
    if spp < 1 or spp & (spp - 1):
        raise ValueRangeError(f"spp: expected a power of two, got {spp}")
    rows = tuple(tuple(float(v) for v in row) for row in np.asarray(kernel, np.float64))
    return KeyOptions(
        size=size,
        levels=spp.bit_length(),
        iterations=iterations,
        seed=seed,
        device=device,
        kernel=rows,
    )


def _load_kernel(path: Path) -> np.ndarray:
    try:
        return np.load(path, allow_pickle=False)
    except (OSError, ValueError) as exc:
        raise FileFormatError(f"{path}: expected a .npy autocorrelation [K, K]: {exc}") from exc


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bnerr.ldbn.matched", description=__doc__)
    parser.add_argument("--kernel", type=Path, required=True, help="autocorrelation .npy [K, K]")
    parser.add_argument("--spp", type=int, default=16, help="the largest level (power of two)")
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--iterations", type=int, default=600)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("--checkpoint", type=Path, default=None)
    parser.add_argument("--out", type=Path, required=True, help="the key set, .npy")
    args = parser.parse_args(argv)
    if args.out.suffix.lower() != ".npy":
        raise FileFormatError(f"{args.out}: expected a .npy file for the keys")
    if args.threads is not None:
        torch.set_num_threads(args.threads)
    kernel = _load_kernel(args.kernel)
    opts = matched_options(kernel, args.spp, args.size, args.iterations, args.seed, args.device)
    checkpoint = args.checkpoint or args.out.with_suffix(".ckpt.npz")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    scramble, rank = optimize_keys(opts, checkpoint)
    write_keys(args.out, scramble, rank)
    checkpoint.unlink(missing_ok=True)
    digest = hashlib.sha256(args.kernel.read_bytes()).hexdigest()[:16]
    print(
        f"LDBN keys {opts.size}x{opts.size}, spp 1..{args.spp}, kernel {args.kernel} "
        f"(sha256 {digest}), {opts.steps()} iterations on {args.device}: "
        f"{time.perf_counter() - start:.1f} s -> {args.out}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
