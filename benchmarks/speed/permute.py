"""Time the seed permutation: ``python -m benchmarks.speed.permute``.

At 1920x1080 with 4x4 blocks (Heitz & Belcour 2019 report 1035 ms on one CPU thread, 64 ms on 16
threads and 0.60 ms on an RTX 2080 for their 1080p sort):

- ``sort_pass`` with the frame's luminance ``[H, W]`` and with its color ``[3, H, W]`` (luminance
  taken inside), mask plan cached (as the temporal strategy runs it every frame);
- the straightforward torch version, reshape into blocks + two stable argsorts + gather/scatter,
  measured in the same run and interleaved with the above, so the ratio survives a busy machine;
- the torch fallback path of ``sort_pass`` (what runs without a C compiler, and on CUDA);
- the plan (mask side, once per mask offset) and the retargeting pass (every frame), with the
  native gather and with torch gather indices (uncached);
- the options of docs/METHODS.md, section 8 (``gap``): the sort pass with groups and with a
  shifted block grid (native kernel and torch path), the sort keys (``bnerr.permutation.sortkeys``:
  residual, relative, demodulated), the group labels, and the bijective reprojection
  (``bnerr.permutation.reproject``, forward and backward), on synthetic buffers (objects of a few
  hundred pixels, a pan with jitter, random depths).

Each figure is the median of ``repeats`` runs after one warm-up, with ``threads`` torch threads
(the native kernel uses as many threads). Timings depend on the machine and on what else runs on
it; report them with the machine and the native kernel's status, which the result includes.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable, Mapping
from typing import Any

import torch

from benchmarks.reports.markdown import table_lines
from benchmarks.speed.copy import JOB_BYTES, PASS_JOBS
from benchmarks.speed.formatting import DASH, fmt, get, number, ratio
from bnerr import native
from bnerr.masks import frame_offset, load_mask, tile_mask
from bnerr.permutation.permute import SortPlan, luminance, plan_sort, sort_pass, sort_torch
from bnerr.permutation.reproject import reproject_seeds
from bnerr.permutation.retarget import Retarget, load_retarget, retarget_sources
from bnerr.permutation.sortkeys import group_labels, sort_key
from bnerr.timing import sync

__all__ = ["table", "argsort_sort_pass", "main", "measure"]


def argsort_sort_pass(
    seeds: torch.Tensor, lum: torch.Tensor, mask: torch.Tensor, block: int
) -> torch.Tensor:
    """The straightforward block sort: reshape to ``[blocks, B*B]``, argsort values and mask, move.

    Full blocks only (H and W multiples of B); the baseline the fast op is compared with.
    """
    h, w = seeds.shape
    nby, nbx, n = h // block, w // block, block * block

    def rows(x: torch.Tensor) -> torch.Tensor:
        return x.view(nby, block, nbx, block).permute(0, 2, 1, 3).reshape(-1, n)

    by_value = torch.argsort(rows(lum), dim=1, stable=True)
    by_mask = torch.argsort(rows(mask), dim=1, stable=True)
    blocks = rows(seeds)
    out = torch.empty_like(blocks).scatter_(1, by_mask, blocks.gather(1, by_value))
    return out.view(nby, nbx, block, block).permute(0, 2, 1, 3).reshape(h, w)


def _interleaved(
    fns: dict[str, Callable[[], object]], repeats: int, device: torch.device
) -> dict[str, float]:
    """Median milliseconds of each function, run round-robin so load affects all alike."""
    for fn in fns.values():
        fn()
    times: dict[str, list[float]] = {name: [] for name in fns}
    for _ in range(repeats):
        for name, fn in fns.items():
            sync(device)
            start = time.perf_counter()
            fn()
            sync(device)
            times[name].append((time.perf_counter() - start) * 1e3)
    return {name: statistics.median(ts) for name, ts in times.items()}


def _inputs(
    width: int, height: int, block: int, device: torch.device, mask_size: int
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor, SortPlan]:
    """``(color [3, H, W], lum [H, W], seeds [H, W], mask [H, W], plan)``, the sort pass checked
    against the argsort baseline."""
    gen = torch.Generator().manual_seed(0)
    color = torch.rand(3, height, width, generator=gen).to(device)
    lum = luminance(color)
    seeds = torch.randperm(height * width, generator=gen).view(height, width).to(device)
    tile = load_mask("scalar", mask_size).to(device)
    mask = tile_mask(tile, height, width, frame_offset(1, mask_size))
    plan = plan_sort(mask, block)
    fast = sort_pass(seeds, lum, plan, block)
    if height % block == 0 and width % block == 0:
        # Random floats, no ties or NaN: every stable sort agrees, so the baseline must too.
        if not torch.equal(fast, argsort_sort_pass(seeds, lum, mask, block)):
            raise RuntimeError("speed_permute: the argsort baseline disagrees with sort_pass")
    return color, lum, seeds, mask, plan


def _gap_buffers(width: int, height: int, device: torch.device) -> dict[str, torch.Tensor]:
    """Synthetic guide buffers: object ids in patches of 37 x 23 pixels (5 objects), a random unit
    normal per patch, random albedo and depth, and a 1.3-pixel pan with Gaussian jitter."""
    gen = torch.Generator().manual_seed(1)
    ys = torch.arange(height)[:, None]
    xs = torch.arange(width)[None, :]
    patch = (xs // 37 + (ys // 23) * (width // 37 + 1)).reshape(-1)
    oid = ((xs // 37 + ys // 23) % 5).float()[None]
    normals = torch.randn(3, int(patch.max()) + 1, generator=gen)
    normals = normals / normals.norm(dim=0, keepdim=True)
    motion = torch.randn(2, height, width, generator=gen) * 0.5
    motion[0] += 1.3
    return {
        "oid": oid.to(device),
        "normal": normals[:, patch].reshape(3, height, width).to(device),
        "albedo": torch.rand(3, height, width, generator=gen).to(device),
        "depth": (torch.rand(1, height, width, generator=gen) * 10 + 1).to(device),
        "motion": motion.to(device),
    }


def _gap_fns(
    color: torch.Tensor, lum: torch.Tensor, seeds: torch.Tensor, mask: torch.Tensor, block: int
) -> dict[str, Callable[[], object]]:
    """The section 8 options, each a function of no arguments (``measure()['gap']``)."""
    height, width = lum.shape
    b = _gap_buffers(width, height, lum.device)
    labels = group_labels(b["oid"], b["normal"])
    plan = plan_sort(mask, block)
    grid = (block // 2, block // 2)
    shifted = plan_sort(mask, block, grid)
    albedo, depth, motion = b["albedo"], b["depth"], b["motion"]
    return {
        "sort_pass_groups_ms": lambda: sort_pass(seeds, lum, plan, block, groups=labels),
        "sort_pass_groups_torch_ms": lambda: sort_torch(seeds, lum, plan, labels),
        "sort_pass_grid_ms": lambda: sort_pass(seeds, lum, shifted, block),
        "sort_pass_grid_torch_ms": lambda: sort_torch(seeds, lum, shifted),
        "plan_grid_ms": lambda: plan_sort(mask, block, grid),
        "group_labels_ms": lambda: group_labels(b["oid"], b["normal"]),
        "group_labels_depth_ms": lambda: group_labels(b["oid"], b["normal"], depth),
        "key_luminance_ms": lambda: sort_key(color),
        "key_luminance_demod_ms": lambda: sort_key(color, demodulate=True, albedo=albedo),
        "key_residual_ms": lambda: sort_key(color, "residual", labels=labels),
        "key_residual_unguided_ms": lambda: sort_key(color, "residual"),
        "key_residual_5x5_ms": lambda: sort_key(color, "residual", labels=labels, radius=2),
        "key_relative_demod_ms": lambda: sort_key(
            color, "relative", demodulate=True, albedo=albedo, labels=labels
        ),
        "reproject_forward_ms": lambda: reproject_seeds(seeds, motion, depth),
        "reproject_backward_ms": lambda: reproject_seeds(
            seeds, motion, depth, direction="backward"
        ),
    }


def measure(
    width: int = 1920,
    height: int = 1080,
    block: int = 4,
    repeats: int = 50,
    threads: int | None = 2,
    device: str | torch.device = "cpu",
    mask_size: int = 64,
) -> dict[str, Any]:
    """Time the permutation passes; returns milliseconds by name plus context.

    Keys: ``sort_pass_lum_ms``, ``sort_pass_rgb_ms``, ``argsort_ms``, ``ratio`` (argsort over
    sort_pass_lum), ``torch_path_ms``, ``plan_ms``, ``retarget_ms`` (as the temporal strategy
    runs it: the native gather where available), ``retarget_torch_ms`` (torch gather indices,
    uncached), ``gap`` (the section 8 options by name, ms, median of ``max(3, repeats // 5)``
    runs), and ``native`` (the C kernels' status), ``threads``, ``device``, ``size``.
    """
    device = torch.device(device)
    before = torch.get_num_threads()
    if threads:
        torch.set_num_threads(threads)
    try:
        color, lum, seeds, mask, plan = _inputs(width, height, block, device, mask_size)
        field = load_retarget(mask_size).to(device)
        retarget = Retarget(field)
        offsets = [frame_offset(t, mask_size) for t in range(16)]
        counter = iter(range(1 << 62))

        def retarget_torch() -> torch.Tensor:
            src = retarget_sources(height, width, field, offsets[next(counter) % 16])
            return seeds.reshape(-1).index_select(0, src)

        fns: dict[str, Callable[[], object]] = {
            "sort_pass_lum_ms": lambda: sort_pass(seeds, lum, plan, block),
            "sort_pass_rgb_ms": lambda: sort_pass(seeds, color, plan, block),
            "argsort_ms": lambda: argsort_sort_pass(seeds, lum, mask, block),
            "torch_path_ms": lambda: sort_torch(seeds, lum, plan),
            "retarget_ms": lambda: retarget(seeds, offsets[next(counter) % 16]),
            "retarget_torch_ms": retarget_torch,
        }
        times = _interleaved(fns, repeats, device)
        result: dict[str, Any] = dict(times)
        result["plan_ms"] = _interleaved(
            {"plan": lambda: plan_sort(mask, block)}, max(3, repeats // 10), device
        )["plan"]
        result["ratio"] = times["argsort_ms"] / times["sort_pass_lum_ms"]
        result["gap"] = _interleaved(
            _gap_fns(color, lum, seeds, mask, block), max(3, repeats // 5), device
        )
        result["native"] = native.status() if device.type == "cpu" else "not used on " + device.type
        result["threads"] = torch.get_num_threads()
        result["device"] = str(device)
        result["size"] = f"{width}x{height}, block {block}"
        return result
    finally:
        torch.set_num_threads(before)


def table(values: Mapping[str, Any], figures: Mapping[str, Any]) -> list[str]:
    """The permutation passes against a memory copy of the same bytes."""
    copy = figures.get("speed.copy")
    size = _size(values.get("size"))
    names = {
        "sort_pass_lum_ms": "sort pass, luminance key",
        "sort_pass_rgb_ms": "sort pass, color key",
        "torch_path_ms": "sort pass, torch path (fallback)",
        "argsort_ms": "sort pass, reshape + argsort baseline",
        "retarget_ms": "retargeting pass",
        "retarget_torch_ms": "retargeting pass, torch gather indices",
    }
    rows = []
    for key, name in names.items():
        job = PASS_JOBS[key]
        moved = get(copy, job, "bytes")
        if moved is None and size is not None:
            moved = JOB_BYTES[job] * size[0] * size[1]
        ms = number(values.get(key))
        rate = None if ms is None or moved is None else moved / (ms * 1e-3) / 1e9
        copy_ms = get(copy, job, "copy_ms")
        rows.append(
            [
                name,
                fmt(ms),
                fmt(None if moved is None else moved / 1e6),
                fmt(rate),
                fmt(copy_ms),
            ]
            + [ratio(ms, copy_ms)]
        )
    rows.append(["mask plan (once per mask offset)", fmt(values.get("plan_ms"))] + [DASH] * 4)
    lines = [
        "## Permutation passes against a memory copy (`speed.permute`, `speed.copy`)",
        "",
        f"{values.get('size')}, {values.get('threads')} threads on {values.get('device')}; "
        f"native kernels: {values.get('native')}. Median milliseconds per call over interleaved "
        "rounds. MB moved: the bytes the job reads and writes (`benchmarks/speed/copy.py`: "
        f"sort {JOB_BYTES['sort_lum']} bytes per pixel with a luminance key, "
        f"{JOB_BYTES['sort_rgb']} with a color key, retarget {JOB_BYTES['retarget']}); GB/s: "
        "those bytes over the time; copy: a memory copy of as many bytes, measured in the same "
        "run; ratio: the pass over that copy (1 would be the memory's speed).",
        "",
    ]
    header = ["pass", "ms", "MB moved", "GB/s", "copy ms", "pass / copy"]
    lines += table_lines(header, rows) + [""]
    if copy is None:
        lines += [
            "No memory-copy anchor in these figures: they predate `speed.copy`; the next "
            "`bnerr bench --suite speed` measures it in the same run.",
            "",
        ]
    return lines + _gap(values)


def _size(size: Any) -> tuple[int, int] | None:
    """``(width, height)`` from speed.permute's ``"1920x1080, block 4"``, or None."""
    try:
        width, height = str(size).split(",")[0].split("x")
        return int(width), int(height)
    except ValueError:
        return None


def _gap(values: Mapping[str, Any]) -> list[str]:
    """The closing-the-gap options against the plain sort pass."""
    lines = ["## Closing-the-gap options against the sort pass (`speed.permute`, `gap`)", ""]
    gap = values.get("gap")
    if not isinstance(gap, Mapping) or not gap:
        return lines + [
            "Not in these figures: they predate the timing of the docs/METHODS.md, section 8 "
            "options; the next `bnerr bench --suite speed` measures them.",
            "",
        ]
    anchor = values.get("sort_pass_lum_ms")
    lines += [
        f"{values.get('size')}: median milliseconds per call of each option's extra work "
        "(docs/METHODS.md, section 8); ratio: over the plain sort pass with a luminance key "
        f"({fmt(anchor)} ms in the same run).",
        "",
    ]
    rows = [[name.removesuffix("_ms"), fmt(ms), ratio(ms, anchor)] for name, ms in gap.items()]
    return lines + table_lines(["option", "ms", "option / sort pass"], rows) + [""]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.speed.permute", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--width", type=int, default=1920)
    parser.add_argument("--height", type=int, default=1080)
    parser.add_argument("--block", type=int, default=4)
    parser.add_argument("--repeats", type=int, default=50)
    parser.add_argument("--threads", type=int, default=2, help="torch threads (default 2)")
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--mask-size", type=int, default=64)
    args = parser.parse_args(argv)
    r = measure(
        args.width, args.height, args.block, args.repeats, args.threads, args.device, args.mask_size
    )
    where = f"{r['size']}, {r['device']}, {r['threads']} threads"
    print(f"permutation passes, {where}, median of {args.repeats}")
    print(f"  native kernel: {r['native']}")
    print(f"  sort_pass, luminance [H, W]      {r['sort_pass_lum_ms']:8.2f} ms")
    print(f"  sort_pass, color [3, H, W]       {r['sort_pass_rgb_ms']:8.2f} ms")
    ratio = f"({r['ratio']:.1f}x the sort pass)"
    print(f"  reshape + argsort baseline       {r['argsort_ms']:8.2f} ms   {ratio}")
    print(f"  sort_pass torch path (fallback)  {r['torch_path_ms']:8.2f} ms")
    print(f"  retargeting pass                 {r['retarget_ms']:8.2f} ms")
    print(f"  retargeting pass, torch indices  {r['retarget_torch_ms']:8.2f} ms")
    print(f"  mask plan (once per offset)      {r['plan_ms']:8.2f} ms")
    print("  closing the gap (docs/METHODS.md, section 8):")
    for name, ms in r["gap"].items():
        print(f"    {name.removesuffix('_ms'):30s} {ms:8.2f} ms")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
