"""A tiny denoiser run as an external program: a joint-bilateral filter guided by albedo and normal.

bnerr runs it through ``manifest.toml`` (:mod:`denoisers.external`); it imports nothing of bnerr,
only numpy and OpenEXR, as a denoiser written outside the project would. Usage::

    python denoise.py --color color.exr --albedo albedo.exr --normal normal.exr \\
        --output out.exr [--sigma-space 1.5] [--sigma-albedo 0.1] [--sigma-normal 0.3]

Each output pixel is the mean of the noisy colors in a (2r + 1)^2 window, r = ceil(2 sigma_space),
weighted by ``exp(-d^2 / 2 sigma_space^2)`` for the distance, and by ``exp(-|a_p - a_q|^2 / 2
sigma_albedo^2)`` and ``exp(-|n_p - n_q|^2 / 2 sigma_normal^2)`` for the albedo and normal
differences: it smooths the noise within a surface and keeps the edges between surfaces. The
image border repeats the edge pixels. Computed in float32, written as a float32 ``R G B`` EXR.
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np
import OpenEXR


def read_buffer(path: str, channels: tuple[str, ...]) -> np.ndarray:
    """The named channels of an EXR file as a float32 ``[C, H, W]`` array."""
    found = OpenEXR.File(path, separate_channels=True).channels()
    missing = [c for c in channels if c not in found]
    if missing:
        raise SystemExit(f"{path}: expected channels {', '.join(channels)}, missing {missing}")
    return np.stack([np.asarray(found[c].pixels, dtype=np.float32) for c in channels])


def write_rgb(path: str, image: np.ndarray) -> None:
    """Write a ``[3, H, W]`` image as a float32 ``R G B`` EXR."""
    planes = {c: np.ascontiguousarray(image[k], dtype=np.float32) for k, c in enumerate("RGB")}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    OpenEXR.File(header, planes).write(path)


def joint_bilateral(
    color: np.ndarray,
    albedo: np.ndarray,
    normal: np.ndarray,
    sigma_space: float = 1.5,
    sigma_albedo: float = 0.1,
    sigma_normal: float = 0.3,
) -> np.ndarray:
    """Filter ``color [3, H, W]`` guided by ``albedo`` and ``normal`` (float32 in and out)."""
    radius = max(1, math.ceil(2 * sigma_space))
    _, height, width = color.shape
    guide = np.concatenate([color, albedo, normal]).astype(np.float32)
    padded = np.pad(guide, ((0, 0), (radius, radius), (radius, radius)), mode="edge")
    total = np.zeros_like(color, dtype=np.float32)
    weights = np.zeros((height, width), dtype=np.float32)
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            y, x = radius + dy, radius + dx
            window = padded[:, y : y + height, x : x + width]
            d_albedo = np.square(window[3:6] - albedo).sum(0)
            d_normal = np.square(window[6:9] - normal).sum(0)
            exponent = (
                (dy * dy + dx * dx) / (2 * sigma_space**2)
                + d_albedo / (2 * sigma_albedo**2)
                + d_normal / (2 * sigma_normal**2)
            )
            w = np.exp(-exponent).astype(np.float32)
            total += w * window[0:3]
            weights += w
    return total / weights  # the centre tap has weight 1: never a division by zero


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--color", required=True)
    parser.add_argument("--albedo", required=True)
    parser.add_argument("--normal", required=True)
    parser.add_argument("--output", required=True)
    parser.add_argument("--sigma-space", type=float, default=1.5)
    parser.add_argument("--sigma-albedo", type=float, default=0.1)
    parser.add_argument("--sigma-normal", type=float, default=0.3)
    args = parser.parse_args(argv)
    if min(args.sigma_space, args.sigma_albedo, args.sigma_normal) <= 0:
        print("denoise.py: expected sigmas > 0", file=sys.stderr)
        return 2
    color = read_buffer(args.color, ("R", "G", "B"))
    albedo = read_buffer(args.albedo, ("albedo.R", "albedo.G", "albedo.B"))
    normal = read_buffer(args.normal, ("normal.X", "normal.Y", "normal.Z"))
    out = joint_bilateral(
        color, albedo, normal, args.sigma_space, args.sigma_albedo, args.sigma_normal
    )
    write_rgb(args.output, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
