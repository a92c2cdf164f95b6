"""``bnerr mask``: generate a blue-noise mask and write it as NPY, EXR or PNG.

``--dims 1`` (the default) makes a void-and-cluster scalar mask ``[T, T]``; ``--dims D`` with
D >= 2 a Georgiev-Fajardo vector mask ``[D, T, T]`` (bnerr.masks.spatial). With ``--frames F`` it
makes a spatiotemporal blue-noise mask instead (bnerr.masks.stbn): scalar ``[F, T, T]`` or vector
``[F, D, T, T]``, written as ``.npy`` only. The command prints the mask's low-frequency energy
fraction (bnerr.metrics.spectrum; white noise measures about 0.049; for a spatiotemporal mask the
largest and the mean over slices, and the fraction of each pixel's series over t) and the time the
generation took. With ``--fast SIGMA`` the scalar void-and-cluster mask it would make is then
annealed into a FAST mask for a Gaussian filter of SIGMA pixels (bnerr.masks.fast: same values,
rearranged for that filter), and the FAST energy before and after is printed too. With ``--ldbn`` it
optimizes LDBN key tiles instead (bnerr.ldbn; ``--spp``, ``--dims``, ``--size``, ``--frames`` for
the spatiotemporal set, ``--fast SIGMA`` for the filter-adapted set; resumable from
``--checkpoint``). The output path is checked before the generation starts. The shipped masks
in ``bnerr/data`` were made with it (see its README.md).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import torch

from benchmarks.commands._args import positive_float, positive_int, seed_int
from benchmarks.commands._mask_ldbn import add_ldbn_arguments, run_ldbn
from bnerr.errors import FileFormatError, ValueRangeError, check_positive_int
from bnerr.io import IMAGE_SUFFIXES, atomic_write, image_format, write_exr, write_png
from bnerr.masks import vector_mask, void_and_cluster
from bnerr.masks.fast import DEFAULT_ITERATIONS, fast_energy, fast_mask
from bnerr.masks.stbn import (
    DEFAULT_SIGMA,
    stbn_scalar,
    stbn_vector,
    temporal_low_frequency_fraction,
)
from bnerr.metrics.spectrum import low_frequency_fraction
from bnerr.outputs import check_output

__all__ = ["register", "run", "write_mask"]

_FORMATS = (".npy", *IMAGE_SUFFIXES)


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "mask",
        help="generate a blue-noise mask (void-and-cluster or vector) and write it",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--size", type=positive_int, default=64, help="tile size T (default 64)")
    parser.add_argument(
        "--dims", type=positive_int, default=1, help="1: scalar mask; D >= 2: vector mask"
    )
    parser.add_argument("--seed", type=seed_int, default=0, help="random seed (default 0)")
    parser.add_argument(
        "--frames",
        type=positive_int,
        default=None,
        help="F: make a spatiotemporal mask of F slices (bnerr.masks.stbn; .npy output only)",
    )
    parser.add_argument(
        "--sigma",
        type=positive_float(100.0),
        default=None,
        help="Gaussian sigma in pixels (default 1.5 for a 2D scalar mask; 1.9 for --frames)",
    )
    parser.add_argument(
        "--sigma-t",
        type=positive_float(100.0),
        default=DEFAULT_SIGMA,
        help="Gaussian sigma in frames (--frames only, default 1.9)",
    )
    parser.add_argument(
        "--device", default="cpu", help="torch device for --frames masks and --ldbn (default cpu)"
    )
    parser.add_argument(
        "--threads",
        type=positive_int,
        default=None,
        help="torch intra-op threads (default: torch's own); 1 on a shared machine",
    )
    parser.add_argument(
        "--fast",
        type=positive_float(100.0),
        default=None,
        metavar="SIGMA",
        help="anneal the scalar mask into a FAST mask for a Gaussian filter of SIGMA pixels",
    )
    parser.add_argument(
        "--iterations",
        type=positive_int,
        default=None,
        help=f"candidate swaps per pixel (vector masks, default 64; --fast, default "
        f"{DEFAULT_ITERATIONS})",
    )
    add_ldbn_arguments(parser)
    parser.add_argument(
        "--out", type=Path, required=True, help="output file: .npy (float32), .exr or .png"
    )
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    image_format(args.out, "--out", _FORMATS)
    if args.threads is not None:
        torch.set_num_threads(check_positive_int(args.threads, "--threads"))
    if args.ldbn:
        return run_ldbn(args)
    if args.spp is not None or args.checkpoint is not None or args.joint:
        raise ValueRangeError("--spp, --checkpoint, --joint: expected only with --ldbn")
    if args.fast is not None and (args.frames is not None or args.dims != 1):
        raise ValueRangeError(
            f"--fast: expected a scalar 2D mask (--dims 1, no --frames), got --dims {args.dims}"
            + ("" if args.frames is None else f" --frames {args.frames}")
        )
    if args.frames is not None:
        return _run_spatiotemporal(args)
    check_output(args.out, "file")
    start = time.perf_counter()
    if args.dims == 1:
        sigma = 1.5 if args.sigma is None else args.sigma
        mask = void_and_cluster(args.size, seed=args.seed, sigma=sigma)
        if args.fast is not None:
            return _run_fast(args, mask, start)
    else:
        mask = vector_mask(args.size, args.dims, seed=args.seed, iterations=_iterations(args))
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


def _run_spatiotemporal(args: argparse.Namespace) -> int:
    """``--frames F``: a spatiotemporal mask, written as float32 ``.npy`` and measured."""
    if args.out.suffix.lower() != ".npy":
        raise FileFormatError(
            f"{args.out}: expected a .npy file for a spatiotemporal mask (--frames), "
            f"got {args.out.suffix.lower()!r}"
        )
    size = check_positive_int(args.size, "--size", minimum=2)
    frames = check_positive_int(args.frames, "--frames")
    dims = check_positive_int(args.dims, "--dims")
    check_output(args.out, "file", need_bytes=4 * frames * dims * size * size)
    sigma = DEFAULT_SIGMA if args.sigma is None else args.sigma
    start = time.perf_counter()
    if args.dims == 1:
        mask = stbn_scalar(
            args.size, args.frames, args.seed, sigma, args.sigma_t, device=args.device
        )
    else:
        mask = stbn_vector(
            args.size,
            args.frames,
            args.dims,
            args.seed,
            sigma,
            args.sigma_t,
            iterations=_iterations(args),
            device=args.device,
        )
    seconds = time.perf_counter() - start
    mask = mask.cpu()
    with atomic_write(args.out) as tmp:
        np.save(tmp, mask.numpy().astype(np.float32), allow_pickle=False)
    kind = "scalar" if args.dims == 1 else f"vector D={args.dims}"
    print(
        f"spatiotemporal {kind} mask {args.size}x{args.size}x{args.frames}, seed {args.seed}: "
        f"{seconds:.2f} s -> {args.out}"
    )
    fractions = [low_frequency_fraction(m, tile=args.size) for m in mask]
    print(
        f"low-frequency fraction (< 0.125 cycles/pixel) per slice: max {max(fractions):.6f}, "
        f"mean {sum(fractions) / len(fractions):.6f}  (white noise ~0.049, blue noise ~0)"
    )
    if args.frames >= 2:
        bins = sum(
            1 for k in range(1, args.frames) if min(k, args.frames - k) / args.frames < 0.125
        )
        print(
            f"temporal low-frequency fraction (< 0.125 cycles/frame): "
            f"{temporal_low_frequency_fraction(mask):.6f}  (white noise "
            f"{bins / (args.frames - 1):.3f})"
        )
    return 0


def _iterations(args: argparse.Namespace) -> int:
    """``--iterations``, or the generator's default: 64 for vector masks, FAST's for --fast."""
    if args.iterations is not None:
        return args.iterations
    return DEFAULT_ITERATIONS if args.fast is not None else 64


def _run_fast(args: argparse.Namespace, start_mask: torch.Tensor, start: float) -> int:
    """``--fast SIGMA``: anneal the void-and-cluster ``start_mask`` for a Gaussian of SIGMA,
    write it and print its FAST energy before and after and its low-frequency fraction."""
    mask = fast_mask(
        args.size, args.fast, seed=args.seed, iterations=_iterations(args), start=start_mask
    )
    seconds = time.perf_counter() - start
    write_mask(args.out, mask)
    before, after = fast_energy(start_mask, args.fast), fast_energy(mask, args.fast)
    print(
        f"FAST mask {args.size}x{args.size} for a Gaussian of sigma {args.fast}, seed {args.seed}, "
        f"{_iterations(args)} swaps per pixel: {seconds:.2f} s -> {args.out}"
    )
    print(
        f"FAST energy: {after:.4f} (void-and-cluster start {before:.4f}, "
        f"{(after - before) / abs(before):+.4%})"
    )
    fraction = low_frequency_fraction(mask, tile=args.size)
    print(
        f"low-frequency fraction (< 0.125 cycles/pixel): {fraction:.6f}"
        "  (white noise ~0.049, blue noise ~0)"
    )
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
