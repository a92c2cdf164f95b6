"""``bnerr mask``: generate a blue-noise mask and write it as NPY, EXR or PNG.

``--dims 1`` (the default) makes a void-and-cluster scalar mask ``[T, T]``; ``--dims D`` with
D >= 2 a Georgiev-Fajardo vector mask ``[D, T, T]`` (bnerr.masks). The command prints the mask's
low-frequency energy fraction (bnerr.spectrum; white noise measures about 0.049) and the time the
generation took. The shipped masks in ``bnerr/data`` were made with it (see its README.md).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import torch

from bnerr.errors import FileFormatError
from bnerr.io import atomic_write, write_exr, write_png
from bnerr.masks import vector_mask, void_and_cluster
from bnerr.spectrum import low_frequency_fraction

__all__ = ["register", "run", "write_mask"]

_FORMATS = (".npy", ".exr", ".png")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "mask",
        help="generate a blue-noise mask (void-and-cluster or vector) and write it",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--size", type=int, default=64, help="tile size T (default 64)")
    parser.add_argument(
        "--dims", type=int, default=1, help="1: scalar void-and-cluster mask; D >= 2: vector mask"
    )
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument(
        "--sigma", type=float, default=1.5, help="void-and-cluster Gaussian sigma (scalar masks)"
    )
    parser.add_argument(
        "--iterations",
        type=int,
        default=64,
        help="candidate swaps per pixel (vector masks, default 64)",
    )
    parser.add_argument(
        "--out", type=Path, required=True, help="output file: .npy (float32), .exr or .png"
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    suffix = args.out.suffix.lower()
    if suffix not in _FORMATS:
        raise FileFormatError(f"{args.out}: expected a {', '.join(_FORMATS)} file, got {suffix!r}")
    start = time.perf_counter()
    if args.dims == 1:
        mask = void_and_cluster(args.size, seed=args.seed, sigma=args.sigma)
    else:
        mask = vector_mask(args.size, args.dims, seed=args.seed, iterations=args.iterations)
    seconds = time.perf_counter() - start
    write_mask(args.out, mask)
    kind = "scalar" if mask.ndim == 2 else f"vector D={mask.shape[0]}"
    print(f"{kind} mask {args.size}x{args.size}, seed {args.seed}: {seconds:.2f} s -> {args.out}")
    fraction = low_frequency_fraction(mask, tile=args.size)
    print(
        f"low-frequency fraction (< 0.125 cycles/pixel): {fraction:.6f}"
        "  (white noise ~0.049, blue noise ~0)"
    )
    if mask.ndim == 3:
        per_channel = " ".join(f"{low_frequency_fraction(c, tile=args.size):.4f}" for c in mask)
        print(f"  per channel: {per_channel}")
    return 0


def write_mask(path: Path, mask: torch.Tensor) -> None:
    """Write ``mask [T, T]`` or ``[D, T, T]`` by extension, atomically (bnerr.io.atomic_write).

    ``.npy``: the float32 array as is (what :func:`bnerr.masks.load_mask` reads). ``.exr``: one
    buffer ``mask`` (channel ``mask.0`` for a scalar mask, ``mask.0 .. mask.<D-1>`` for a vector
    mask), exact float32. ``.png``: an 8-bit preview whose stored values are ``round(255 v)`` (the
    usual blue-noise texture convention): grey for a scalar mask, the first three channels as RGB
    for a vector mask (blue channel 0 for D = 2).
    """
    suffix = path.suffix.lower()
    if suffix == ".npy":
        with atomic_write(path) as tmp:
            np.save(tmp, mask.numpy().astype(np.float32), allow_pickle=False)
        return
    channels = mask.unsqueeze(0) if mask.ndim == 2 else mask
    if suffix == ".exr":
        write_exr(path, {"mask": channels.contiguous()})
        return
    rgb = channels[:3]
    if rgb.shape[0] == 1:
        rgb = rgb.expand(3, -1, -1)
    elif rgb.shape[0] == 2:
        rgb = torch.cat([rgb, torch.zeros_like(rgb[:1])])
    # write_png encodes linear values with the sRGB curve; decode first so that the stored 8-bit
    # values are the mask values themselves.
    linear = torch.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    write_png(path, linear.contiguous(), exposure=0.0, tonemap="clamp")
