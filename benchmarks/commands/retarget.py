"""``bnerr retarget``: optimize the retargeting permutation of a scalar mask and write it as NPY.

Heitz & Belcour 2019's retargeting pass moves every seed by at most 6 pixels so that the seed
ranked like ``M(q)`` in frame t lands where frame t + 1's mask (shifted by the constant R2 step)
wants that rank (bnerr.permutation.retarget). The command optimizes the displacement field for the
shipped scalar mask of size T (or for ``--mask FILE.npy``), writes it as an int8 ``[2, T, T]``
(dy, dx) array, and prints the energy ``mean |M(q + d(q)) - M(q + step)|`` of the result next to the
identity's. A constant mask (every field scores 0, so no ratio exists) is refused before any
work or output. ``--method exact`` (sparse minimum-cost matching, scipy) finds the optimum;
``--method anneal`` is the paper's simulated annealing. The shipped ``bnerr/data/retarget_<T>.npy``
were made with it (see that folder's README.md).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import torch

from benchmarks.commands._args import finite_float, nonnegative_int, positive_int, seed_int
from bnerr.errors import FileFormatError, ValueRangeError
from bnerr.masks import load_mask, r2_step
from bnerr.permutation.retarget import (
    MAX_DISPLACEMENT,
    METHODS,
    optimize_retarget,
    retarget_energy,
    save_retarget,
)

__all__ = ["register", "run"]


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "retarget",
        help="optimize the retargeting permutation of a scalar mask and write it",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--size",
        type=positive_int,
        default=64,
        help="tile size T of the shipped scalar mask (default 64)",
    )
    parser.add_argument(
        "--mask", type=Path, help="a [T, T] float32 .npy mask instead of the shipped one"
    )
    parser.add_argument(
        "--method", choices=METHODS, default="exact", help="optimizer (default exact)"
    )
    parser.add_argument("--seed", type=seed_int, default=0, help="annealing seed (default 0)")
    parser.add_argument(
        "--iterations", type=nonnegative_int, default=40000, help="annealing steps (default 40000)"
    )
    parser.add_argument(
        "--temperature",
        type=finite_float(0.0, 1.0),
        default=0.05,
        help="initial annealing temperature",
    )
    parser.add_argument(
        "--radius",
        type=nonnegative_int,
        default=MAX_DISPLACEMENT,
        help="largest |dy|, |dx| (default 6)",
    )
    parser.add_argument("--out", type=Path, required=True, help="output .npy file (int8 [2, T, T])")
    parser.set_defaults(func=run)


def _mask(args: argparse.Namespace) -> torch.Tensor:
    if args.mask is None:
        return load_mask("scalar", args.size)
    try:
        array = np.load(args.mask, allow_pickle=False)
    except (OSError, ValueError) as err:
        raise FileFormatError(
            f"{args.mask}: expected a .npy array, got unreadable data ({err})"
        ) from err
    if array.ndim != 2 or array.shape[0] != array.shape[1] or array.dtype.kind != "f":
        raise FileFormatError(
            f"{args.mask}: expected a float [T, T] array, got {array.dtype} {list(array.shape)}"
        )
    return torch.from_numpy(array.astype(np.float32))


def _identity_energy(mask: torch.Tensor, step: tuple[int, int]) -> float:
    """The identity field's energy, refusing a mask for which it is 0 (no ratio would exist):
    checked before the optimizer runs and before anything is written."""
    size = mask.shape[0]
    identity = retarget_energy(mask, torch.zeros(2, size, size, dtype=torch.int64), step)
    if identity > 0.0:
        return identity
    if bool(mask.min() == mask.max()):
        raise ValueRangeError(
            f"mask: expected at least two distinct values (nothing to retarget), "
            f"got a constant {size}x{size} mask"
        )
    raise ValueRangeError(
        f"mask: expected a mask that changes under the per-frame step {step}, "
        f"got one equal to its own shift (nothing to retarget)"
    )


def run(args: argparse.Namespace) -> int:
    if args.out.suffix.lower() != ".npy":
        raise FileFormatError(f"{args.out}: expected a .npy file, got {args.out.suffix!r}")
    mask = _mask(args)
    size = mask.shape[0]
    step = r2_step(size)
    identity = _identity_energy(mask, step)
    start = time.perf_counter()
    field = optimize_retarget(
        mask,
        step,
        method=args.method,
        radius=args.radius,
        iterations=args.iterations,
        temperature=args.temperature,
        seed=args.seed,
    )
    seconds = time.perf_counter() - start
    save_retarget(args.out, field)
    final = retarget_energy(mask, field, step)
    moved = float((field != 0).any(dim=0).double().mean())
    print(
        f"retarget {size}x{size}, step {step}, method {args.method}: {seconds:.2f} s -> {args.out}"
    )
    print(
        f"energy mean |M(q + d(q)) - M(q + step)|: {final:.6f}  (identity {identity:.6f}, "
        f"ratio {final / identity:.4f}); {moved:.1%} of the pixels move"
    )
    return 0
