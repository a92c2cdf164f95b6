"""The permutation op's anchor: a memory copy of the bytes each pass reads and writes.

A pass that only moves data cannot beat a copy that moves as many bytes; the ratio of a pass's
time to that copy's says how far the pass is from the memory's speed. The bytes of each job, per
pixel (at 1080p a T x T mask, field or plan header is negligible next to them):

- ``sort_lum``: the sort pass with a luminance key reads the seeds (int64, 8 bytes), the key
  (float32, 4) and the mask plan (uint8, 1) and writes the seeds (8): 21 bytes;
- ``sort_rgb``: the same with a color key (3 float32, 12): 29 bytes;
- ``retarget``: the retargeting pass reads the seeds (8) and writes them (8): 16 bytes.

The copy of a job is ``dst.copy_(src)`` of two uint8 buffers of half its bytes, so that the copy
reads and writes as many bytes in all as the job. :func:`measure` times the three copies in
interleaved rounds (median), at the size and thread count of ``benchmarks.speed.permute``'s
defaults; ``bnerr bench --suite speed`` runs it right after that script, so that both are measured
in the same run under the same load (:func:`benchmarks.speed.run_speed`).

Run: ``python -m benchmarks.speed.copy``.
"""

from __future__ import annotations

import argparse
import statistics
import time

import torch

from bnerr.errors import check_positive_int
from bnerr.timing import sync

__all__ = ["JOB_BYTES", "PASS_JOBS", "measure"]

#: Bytes per pixel each job reads and writes (module docstring).
JOB_BYTES: dict[str, int] = {"sort_lum": 21, "sort_rgb": 29, "retarget": 16}
#: ``benchmarks.speed.permute`` figure -> the job it does (the baselines and fallbacks do the same
#: job as the pass they stand in for, so they share its anchor).
PASS_JOBS: dict[str, str] = {
    "sort_pass_lum_ms": "sort_lum",
    "sort_pass_rgb_ms": "sort_rgb",
    "torch_path_ms": "sort_lum",
    "argsort_ms": "sort_lum",
    "retarget_ms": "retarget",
    "retarget_torch_ms": "retarget",
}


def measure(
    width: int = 1920,
    height: int = 1080,
    repeats: int = 50,
    threads: int | None = 2,
    device: str | torch.device = "cpu",
) -> dict[str, object]:
    """Median milliseconds of a memory copy of each permutation job's bytes at ``width x height``.

    Returns ``{job: {"bytes": bytes read and written, "copy_ms": median ms}}`` for every job of
    :data:`JOB_BYTES`, plus ``threads``, ``device`` and ``size`` (``"1920x1080"``).
    """
    check_positive_int(width, "width")
    check_positive_int(height, "height")
    check_positive_int(repeats, "repeats")
    device = torch.device(device)
    before = torch.get_num_threads()
    if threads:
        torch.set_num_threads(threads)
    try:
        buffers = {}
        for job, per_pixel in JOB_BYTES.items():
            half = width * height * per_pixel // 2
            src = torch.arange(half, dtype=torch.int64, device=device).to(torch.uint8)
            buffers[job] = (src, torch.empty_like(src))
        times = _interleaved_copies(buffers, repeats, device)
        result: dict[str, object] = {
            job: {"bytes": 2 * buffers[job][0].numel(), "copy_ms": statistics.median(ts)}
            for job, ts in times.items()
        }
        result.update(threads=torch.get_num_threads(), device=str(device), size=f"{width}x{height}")
        return result
    finally:
        torch.set_num_threads(before)


def _interleaved_copies(
    buffers: dict[str, tuple[torch.Tensor, torch.Tensor]], repeats: int, device: torch.device
) -> dict[str, list[float]]:
    """Milliseconds of ``repeats`` copies of each job's ``src`` into its ``dst``, one copy of each
    job per round (after one warm-up copy each), so that the load of a shared machine hits all
    alike."""
    for src, dst in buffers.values():
        dst.copy_(src)
    times: dict[str, list[float]] = {job: [] for job in buffers}
    for _ in range(repeats):
        for job, (src, dst) in buffers.items():
            sync(device)
            start = time.perf_counter()
            dst.copy_(src)
            sync(device)
            times[job].append((time.perf_counter() - start) * 1e3)
    return times


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.speed.copy", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--width", type=int, default=1920)
    parser.add_argument("--height", type=int, default=1080)
    parser.add_argument("--repeats", type=int, default=50)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--device", default="cpu")
    args = parser.parse_args(argv)
    r = measure(args.width, args.height, args.repeats, args.threads, args.device)
    print(f"memory copy, {r['size']}, {r['device']}, {r['threads']} threads")
    for job in JOB_BYTES:
        figures = r[job]
        assert isinstance(figures, dict)
        mb = figures["bytes"] / 1e6
        print(f"  {job:10s} {mb:7.1f} MB moved  {figures['copy_ms']:8.2f} ms")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
