"""``bnerr mask --ldbn``: optimize a set of LDBN key tiles (bnerr.ldbn) and write them as ``.npy``.

``--spp N`` (a power of two) gives the levels: tiles for 1, 2, ..., N samples; ``--dims D`` the
optimized dimensions (even); ``--size T`` the tile. ``--frames F`` adds a frame axis (keys blue in
space and along t at each pixel, the ``ldbn_st`` set); ``--fast SIGMA`` targets a Gaussian filter
of SIGMA pixels (its autocorrelation as the kernel, the ``ldbn_fast`` set) instead of Heitz et
al.'s weight of width 2.1; ``--joint`` optimizes every pair past the first (the pixel jitter) on 4D
test integrands of both pairs, the first pair's keys fixed and its ranks shared (bnerr.ldbn.keys).
A progress bar counts descent iterations; ``--checkpoint`` (default:
the output's name with ``.ckpt.npz``) is written after each (level, pair) job, and a rerun with
the same options resumes from it (it is removed once the output is written). The command prints
the time taken and, per level, the share of the error variance a sigma-2 blur keeps on held-out
test integrands (independent pixels keep about 0.020 on a 64 tile). ``--base lattice|zorder``
makes keys over another base point set (bnerr.sequences.ldbn_bases). ``--device`` (shared with the
masks, default cpu) runs the descents there, every (level, pair) job of a round batched: CPU and
CUDA give different keys, each reproducible (bnerr.ldbn.keys).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from tqdm import tqdm

from benchmarks.commands._args import positive_int
from bnerr.errors import FileFormatError, ValueRangeError
from bnerr.ldbn.keys import KeyOptions, optimize_keys, write_keys
from bnerr.ldbn.quality import blurred_share, white_share
from bnerr.outputs import check_output

__all__ = ["add_ldbn_arguments", "run_ldbn"]


def add_ldbn_arguments(parser: argparse.ArgumentParser) -> None:
    """The options only ``--ldbn`` reads (it shares ``--size``, ``--dims``, ``--seed``,
    ``--frames``, ``--fast``, ``--iterations``, ``--threads`` and ``--out`` with the masks)."""
    parser.add_argument(
        "--ldbn",
        action="store_true",
        help="optimize LDBN key tiles (bnerr.ldbn) instead of a mask; .npy output",
    )
    parser.add_argument(
        "--spp",
        type=positive_int,
        default=None,
        help="--ldbn: the largest sample count, a power of two (default 16)",
    )
    parser.add_argument(
        "--joint",
        action="store_true",
        help="--ldbn: optimize the pairs past the pixel jitter jointly with it (4D tests)",
    )
    parser.add_argument(
        "--base",
        choices=("sobol", "lattice", "zorder"),
        default="sobol",
        help="--ldbn: the base point set the keys act on (bnerr.sequences.ldbn_bases; "
        "default sobol, the shipped sets)",
    )
    parser.add_argument(
        "--checkpoint",
        type=Path,
        default=None,
        help="--ldbn: the resumable checkpoint (default: the output with .ckpt.npz)",
    )


def _options(args: argparse.Namespace) -> KeyOptions:
    spp = 16 if args.spp is None else args.spp
    if spp & (spp - 1):
        raise ValueRangeError(f"--spp: expected a power of two for --ldbn, got {spp}")
    dims = 8 if args.dims == 1 else args.dims
    return KeyOptions(
        size=args.size,
        levels=spp.bit_length(),
        dims=dims,
        frames=1 if args.frames is None else args.frames,
        sigma=2.1 if args.fast is None else args.fast,
        autocorrelation=args.fast is not None,
        iterations=600 if args.iterations is None else args.iterations,
        seed=args.seed,
        joint=args.joint,
        device=args.device,
        base=args.base,
    )


def run_ldbn(args: argparse.Namespace) -> int:
    """Optimize, write ``--out`` (int32 ``[L, F, T, T, D + D/2]``) and report (module docstring)."""
    if args.out.suffix.lower() != ".npy":
        raise FileFormatError(f"{args.out}: expected a .npy file for --ldbn keys")
    opts = _options(args)
    check_output(args.out, "file")
    checkpoint = args.checkpoint or args.out.with_suffix(".ckpt.npz")
    start = time.perf_counter()
    with tqdm(total=opts.steps(), unit="it", dynamic_ncols=True) as bar:
        scramble, rank = optimize_keys(opts, checkpoint, bar.update)
    seconds = time.perf_counter() - start
    write_keys(args.out, scramble, rank)
    Path(checkpoint).unlink(missing_ok=True)
    print(
        f"LDBN keys {opts.size}x{opts.size}x{opts.frames}, spp 1..{1 << (opts.levels - 1)}, "
        f"D={opts.dims}{', joint' if opts.joint else ''}, base {opts.base}: {seconds:.1f} s "
        f"-> {args.out}"
    )
    print(f"sigma-2 blur keeps (held-out tests, pair 0; white {white_share(opts.size):.4f}):")
    for level in range(opts.levels):
        shares = [
            blurred_share(
                scramble[level], rank[level], m, seed0=opts.seed0, base=opts.base, level=level
            )
            for m in (1 << k for k in range(level + 1))
        ]
        text = " ".join(f"{m}:{s:.4f}" for m, s in zip((1 << k for k in range(level + 1)), shares))
        print(f"  tile for {1 << level} spp, prefixes {text}")
    return 0
