"""The effective spatial kernel of a denoiser, measured on the scenes' own buffers.

A denoiser is not a fixed filter (the a-trous filter's edge-stopping weights and the networks
depend on the image), but around a noisy frame ``x`` it has a linear response: the change of its
output when the color at pixel p moves by a small ``eps``. :func:`impulse_kernel` measures it by
central differences, ``(denoise(x + eps d_p) - denoise(x - eps d_p)) / (2 eps)``, with impulses
``d_p`` at many pixels at once (a grid of ``spacing`` pixels at a random offset per pattern, so
their responses do not overlap within the kernel's window), re-centred at p and averaged over the
positions and frames: a ``K x K`` kernel, ``K = 2 half + 1``, of the output at ``p + d`` per unit
of error at p. Its autocorrelation (:func:`autocorrelation`) is what the LDBN energy weighs
(docs/METHODS.md, "The optimizer": with ``w = k * k~`` the energy plus a constant is the error the
kernel leaves), and what ``python -m bnerr.ldbn.matched --kernel`` optimizes keys for.

``python -m benchmarks.studies.denoiser_kernels --out DIR`` measures a-trous (its tuned parameters
per scene and spp, ``results/quality/tuned_params.json``), the U-Net and OIDN (when ``pyoidn`` is
installed) on ``direct`` and ``indirect`` at 1, 4 and 16 spp, and writes per (denoiser, spp) the
kernel averaged over the scenes and its autocorrelation (``<denoiser>_<spp>.npy``,
``<denoiser>_<spp>_autocorr.npy``, the latter scaled to 1 at its centre), per scene the kernel
(``<denoiser>_<scene>_<spp>.npy``), and ``summary.json`` / ``summary.md``: each kernel's sum, width
(the sigma of the Gaussian with its second moment, :func:`kernel_width`), noise width (the sigma of
the Gaussian that keeps the same share of white noise, :func:`noise_width`) and radial profiles of
the kernel and its autocorrelation. With impulses 32 pixels apart a kernel wider than that (a-trous
with 5 iterations reaches 62 pixels) sees its neighbours' tails: small, but not zero. Measured:
docs/METHODS.md, section 10 (about 80 s for all 27 kernels on one core).

The finding it measures: docs/FINDINGS.md, "Flicker, matched keys, larger keys, the GPU", "Keys
matched to our denoisers do not beat generic ones" (its measured cause: the filters leave 22-44 %
of each pixel's own error in place, and the a-trous kernel differs between scenes); the keys
matched to these kernels are compared by :mod:`benchmarks.studies.matched_keys`.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import torch

import renderers
from benchmarks.training_data import pixel_seeds
from bnerr.errors import ValueRangeError, check_positive_int
from bnerr.frame import Frame
from bnerr.io import atomic_write
from bnerr.sequences import make_sampler
from denoisers.oidn import available_denoisers
from denoisers.tuning import ParamStore, tuned_denoiser

__all__ = [
    "autocorrelation",
    "impulse_kernel",
    "kernel_width",
    "main",
    "measure",
    "noise_width",
    "radial_profile",
    "tuned_denoise",
]

Denoise = Callable[[Frame], torch.Tensor]
_PARAMS = Path("results/quality/tuned_params.json")


def _positions(
    height: int, width: int, half: int, spacing: int, gen: torch.Generator
) -> tuple[torch.Tensor, torch.Tensor]:
    """Impulse pixels ``(ys, xs)``: a grid of ``spacing`` at a random offset, ``half`` from the
    borders (so every window lies inside the image)."""
    oy, ox = (int(v) for v in torch.randint(0, spacing, (2,), generator=gen))
    ys = torch.arange(half + oy, height - half, spacing)
    xs = torch.arange(half + ox, width - half, spacing)
    return ys[:, None].expand(-1, len(xs)).reshape(-1), xs[None, :].expand(len(ys), -1).reshape(-1)


def impulse_kernel(
    denoise: Denoise,
    frame: Frame,
    half: int = 10,
    spacing: int = 32,
    patterns: int = 8,
    eps: float = 0.05,
    seed: int = 0,
) -> np.ndarray:
    """The denoiser's linear response to an error impulse, averaged over positions (module
    docstring): ``[2 half + 1, 2 half + 1]`` float64, ``k[half + dy, half + dx]`` the output at
    ``p + (dy, dx)`` per unit added to every color channel at p (channels averaged).

    Args:
        denoise: ``Frame -> [3, H, W]``. frame: the noisy frame the response is taken around.
        half: the window's half width. spacing: the impulses' grid step (at least ``2 half + 1``,
            so windows do not overlap). patterns: impulse grids, each at its own random offset.
        eps: the impulse, relative to the frame's mean absolute color. seed: the offsets' RNG.

    Raises:
        ValueRangeError: spacing below the window, or a window larger than the frame.
    """
    check_positive_int(half, "half")
    if check_positive_int(spacing, "spacing") < 2 * half + 1:
        raise ValueRangeError(
            f"spacing: expected at least 2 half + 1 = {2 * half + 1}, got {spacing}"
        )
    _, height, width = frame.color.shape
    if min(height, width) < 2 * half + 1:
        raise ValueRangeError(
            f"frame: expected at least {2 * half + 1} pixels a side, got {height}x{width}"
        )
    step = eps * float(frame.color.abs().mean().clamp_min(1e-6))
    gen = torch.Generator().manual_seed(seed)
    total, count = np.zeros((2 * half + 1,) * 2), 0
    for _ in range(check_positive_int(patterns, "patterns")):
        ys, xs = _positions(height, width, half, spacing, gen)
        delta = torch.zeros_like(frame.color)
        delta[:, ys.to(delta.device), xs.to(delta.device)] = step
        plus = denoise(dataclasses.replace(frame, color=frame.color + delta))
        minus = denoise(dataclasses.replace(frame, color=frame.color - delta))
        response = ((plus - minus).double().mean(0) / (2 * step)).cpu().numpy()
        for y, x in zip(ys.tolist(), xs.tolist()):
            total += response[y - half : y + half + 1, x - half : x + half + 1]
        count += len(ys)
    return total / count


def autocorrelation(kernel: np.ndarray) -> np.ndarray:
    """``(k * k~)(d) = sum_p k(p) k(p + d)``: ``[2K - 1, 2K - 1]`` for a ``[K, K]`` kernel."""
    k = np.asarray(kernel, dtype=np.float64)
    size = 2 * k.shape[0] - 1, 2 * k.shape[1] - 1
    f = np.fft.rfft2(k, s=size)
    full = np.fft.irfft2(f * np.conj(f), s=size)
    return np.fft.fftshift(full)


def _offsets(shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    dy = np.arange(shape[0]) - shape[0] // 2
    dx = np.arange(shape[1]) - shape[1] // 2
    return dy[:, None] + 0 * dx[None, :], 0 * dy[:, None] + dx[None, :]


def kernel_width(kernel: np.ndarray) -> float:
    """The sigma of the Gaussian with the kernel's second moment, per axis:
    ``sqrt(sum k |d|^2 / (2 sum k))`` (a Gaussian filter of sigma s measures s)."""
    dy, dx = _offsets(kernel.shape)
    moment = (kernel * (dy**2 + dx**2)).sum() / (2 * kernel.sum())
    return float(np.sqrt(moment)) if moment > 0 else float("nan")


def noise_width(kernel: np.ndarray) -> float:
    """The sigma of the Gaussian that lets through the same share of white noise as the kernel,
    for its sum: ``|sum k| / sqrt(4 pi sum k^2)`` (white noise keeps ``sum k^2`` of its variance;
    a Gaussian of sigma s keeps ``1 / (4 pi s^2)``). Defined for any kernel, unlike
    :func:`kernel_width`, which a kernel with negative lobes can make imaginary."""
    return float(abs(kernel.sum()) / np.sqrt(4 * np.pi * (kernel**2).sum()))


def radial_profile(kernel: np.ndarray) -> list[float]:
    """The kernel's mean over rings of radius ``r = 0, 1, ..., half`` (``|d|`` rounded)."""
    dy, dx = _offsets(kernel.shape)
    ring = np.rint(np.sqrt(dy**2 + dx**2)).astype(int)
    return [float(kernel[ring == r].mean()) for r in range(kernel.shape[0] // 2 + 1)]


def tuned_denoise(name: str, scene: str, spp: int) -> Denoise:
    """``name``'s denoise function with its tuned parameters for ``scene`` at ``spp`` (defaults
    where none are stored)."""
    store = ParamStore.load(_PARAMS) if _PARAMS.exists() else ParamStore()
    key, spp = store.resolve(name, scene, spp)
    return tuned_denoiser(name, key, spp, store).denoise


def measure(
    denoiser: str, scene: str, spp: int, size: int = 128, frames: int = 2, half: int = 10
) -> np.ndarray:
    """The kernel of ``denoiser`` (tuned for ``scene`` at ``spp``) on ``frames`` renders of the
    static ``scene`` (white noise, independent per frame), averaged over them."""
    scene_obj = renderers.get_scene(scene, animated=False)
    denoise = tuned_denoise(denoiser, scene, spp)
    sampler = make_sampler("owen_sobol")
    kernels = [
        impulse_kernel(
            denoise,
            renderers.render(scene_obj, 0, pixel_seeds(size, size, 7000 + t), sampler, spp),
            half=half,
            seed=t,
        )
        for t in range(check_positive_int(frames, "frames"))
    ]
    return np.mean(kernels, axis=0)


def _unit(auto: np.ndarray) -> np.ndarray:
    """An autocorrelation scaled to 1 at its centre."""
    return auto / auto[auto.shape[0] // 2, auto.shape[1] // 2]


def _save(path: Path, array: np.ndarray) -> None:
    with atomic_write(path) as tmp:
        np.save(tmp, array.astype(np.float64), allow_pickle=False)


def _summary_md(rows: list[dict]) -> str:
    lines = [
        "# Effective denoiser kernels (benchmarks.studies.denoiser_kernels)",
        "",
        "| denoiser | scene | spp | sum | width | noise width | radial profile r = 0..5 "
        "| autocorrelation r = 0..5 |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        prof = " ".join(f"{v:.4f}" for v in r["radial"][:6])
        auto = " ".join(f"{v:.3f}" for v in r["auto_radial"][:6])
        lines.append(
            f"| {r['denoiser']} | {r['scene']} | {r['spp']} | {r['sum']:.3f} | "
            f"{r['width']:.3f} | {r['noise_width']:.3f} | {prof} | {auto} |"
        )
    return "\n".join(lines) + "\n"


def _row(denoiser: str, scene: str, spp: int, kernel: np.ndarray) -> dict:
    return {
        "denoiser": denoiser,
        "scene": scene,
        "spp": spp,
        "sum": float(kernel.sum()),
        "width": kernel_width(kernel),
        "noise_width": noise_width(kernel),
        "radial": radial_profile(kernel),
        "auto_radial": radial_profile(_unit(autocorrelation(kernel)))[: kernel.shape[0] // 2 + 1],
    }


def run(args: argparse.Namespace) -> list[dict]:
    """Measure every (denoiser, spp, scene) and write the files of the module docstring."""
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in args.denoisers:
        for spp in args.spp:
            per_scene = []
            for scene in args.scenes:
                kernel = measure(name, scene, spp, args.size, args.frames, args.half)
                _save(args.out / f"{name}_{scene}_{spp}.npy", kernel)
                rows.append(_row(name, scene, spp, kernel))
                per_scene.append(kernel)
            mean = np.mean(per_scene, axis=0)
            auto = autocorrelation(mean)
            _save(args.out / f"{name}_{spp}.npy", mean)
            _save(args.out / f"{name}_{spp}_autocorr.npy", _unit(auto))
            rows.append(_row(name, "mean", spp, mean))
            print(f"{name} {spp} spp: width {rows[-1]['noise_width']:.3f}", flush=True)
    for path, text in (
        (args.out / "summary.json", json.dumps(rows, indent=1)),
        (args.out / "summary.md", _summary_md(rows)),
    ):
        with atomic_write(path) as tmp:
            Path(tmp).write_text(text)
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.studies.denoiser_kernels", description=__doc__
    )
    parser.add_argument("--denoisers", nargs="+", default=["atrous", "unet", "oidn"])
    parser.add_argument("--scenes", nargs="+", default=["direct", "indirect"])
    parser.add_argument("--spp", nargs="+", type=int, default=[1, 4, 16])
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--frames", type=int, default=2)
    parser.add_argument("--half", type=int, default=10)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    torch.set_num_threads(args.threads)
    args.denoisers = available_denoisers(args.denoisers)
    run(args)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
