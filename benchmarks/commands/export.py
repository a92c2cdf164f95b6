"""``bnerr export``: write a shipped key set or mask as textures an engine loads.

One of ``--ldbn KIND`` (``screen``, ``fast``, ``st``: the LDBN key sets, bnerr.ldbn), ``--stbn
KIND`` (``scalar``, ``vector``: the spatiotemporal masks, bnerr.masks.stbn) or ``--fast`` (the
FAST mask, bnerr.masks.fast), in ``--format``:

- ``npy``: the array as shipped, one file ``<name>.npy``;
- ``exr``: one float32 EXR per slice, ``<name>_<slice>.exr``, channels ``c.0 .. c.<C-1>``; the LDBN
  keys (24-bit words) are exact in float32;
- ``png``: one 16-bit greyscale PNG per slice and channel, ``<name>_<slice>_c<channel>.png``:
  mask values as ``round(65535 v)``, LDBN scrambling keys as their top 16 bits (``key >> 8``:
  XOR ``png << 8`` into the value's top 24 bits), ranking keys as they are;
- ``h``: a C header ``<name>.h`` with one ``uint32_t`` (keys) or ``float`` (masks) array in
  pixel-major order and its dimensions as macros.

Layout (docs/METHODS.md, section 10): every array is ``[S, T, T, C]`` after flattening the
leading axes into slices S (LDBN: level-major then frame, ``slice = level * F + frame``; STBN:
frame; FAST: one slice), row y, column x, channel c; entry ``((s * T + y) * T + x) * C + c``. LDBN's
channels are the D scrambling keys (dimension d in channel d) then the D/2 ranking keys (pair k in
channel D + k); a mask's channels are its dimensions.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch

from benchmarks.commands._args import positive_int
from bnerr.errors import ValueRangeError
from bnerr.io import atomic_write, write_exr
from bnerr.outputs import check_output

__all__ = ["export_array", "register", "run"]

_FORMATS = ("npy", "exr", "png", "h")


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "export",
        help="write a shipped LDBN key set or blue-noise mask as engine textures",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    which = parser.add_mutually_exclusive_group(required=True)
    which.add_argument("--ldbn", choices=("screen", "fast", "st"), help="an LDBN key set")
    which.add_argument("--stbn", choices=("scalar", "vector"), help="a spatiotemporal mask")
    which.add_argument("--fast", action="store_true", help="the FAST mask (Gaussian 0.75)")
    parser.add_argument("--size", type=positive_int, default=64, help="tile size T (default 64)")
    parser.add_argument("--format", choices=_FORMATS, required=True, help="output format")
    parser.add_argument("--out", type=Path, required=True, help="output folder (created)")
    parser.set_defaults(func=run)


def _load(args: argparse.Namespace) -> tuple[str, np.ndarray, bool]:
    """``(name, [S, T, T, C] array, is_keys)`` of the asked-for set."""
    if args.ldbn is not None:
        from bnerr.ldbn.keys import ldbn_file_name, load_ldbn_keys
        from bnerr.strategies.ldbn import LDBN_SETS

        kind, frames, levels = next(s for s in LDBN_SETS.values() if s[0] == args.ldbn)
        keys = load_ldbn_keys(kind, args.size, frames, levels)
        slices = [
            torch.cat([k.scramble[level], k.rank[level]], -1)
            for level in range(levels)
            for k in keys
        ]
        name = ldbn_file_name(kind, args.size, frames).removesuffix(".npy")
        return name, torch.stack(slices).numpy(), True
    if args.stbn is not None:
        from bnerr.masks.stbn import load_stbn

        mask = load_stbn(args.stbn, args.size, 32).numpy()
        array = mask[..., None] if mask.ndim == 3 else mask.transpose(0, 2, 3, 1)
        return f"stbn_{args.stbn}_{args.size}x32", array, False
    from bnerr.masks.fast import load_fast_mask

    return f"fast_gauss_{args.size}", load_fast_mask(args.size).numpy()[None, ..., None], False


def run(args: argparse.Namespace) -> int:
    name, array, keys = _load(args)
    args.out.mkdir(parents=True, exist_ok=True)
    written = export_array(args.out, name, array, args.format, keys=keys)
    print(f"{name}: {list(array.shape)} -> {len(written)} file(s) in {args.out}")
    return 0


def export_array(folder: Path, name: str, array: np.ndarray, fmt: str, *, keys: bool) -> list[Path]:
    """Write ``array [S, T, T, C]`` (int32 keys or float32 mask values) in ``fmt`` (module
    docstring); returns the paths written."""
    if array.ndim != 4:
        raise ValueRangeError(f"array: expected [S, T, T, C], got {list(array.shape)}")
    if fmt == "npy":
        path = folder / f"{name}.npy"
        check_output(path, "file")
        with atomic_write(path) as tmp:
            np.save(tmp, array, allow_pickle=False)
        return [path]
    if fmt == "h":
        return [_write_header(folder / f"{name}.h", name, array, keys)]
    if fmt == "exr":
        return [_write_exr_slice(folder / f"{name}_{s}.exr", a) for s, a in enumerate(array)]
    return _write_pngs(folder, name, array, keys)


def _write_exr_slice(path: Path, slice_: np.ndarray) -> Path:
    check_output(path, "file")
    data = torch.from_numpy(slice_.astype(np.float32)).permute(2, 0, 1).contiguous()
    write_exr(path, {"c": data})
    return path


def _write_pngs(folder: Path, name: str, array: np.ndarray, keys: bool) -> list[Path]:
    from skimage.io import imsave  # slow to import

    dims = (array.shape[-1] * 2) // 3 if keys else 0  # LDBN: D scrambling + D/2 ranking keys
    paths = []
    for s, slice_ in enumerate(array):
        for c in range(array.shape[-1]):
            plane = slice_[..., c]
            if keys:
                plane = plane >> 8 if c < dims else plane
            else:
                plane = np.round(plane.astype(np.float64) * 65535)
            path = folder / f"{name}_{s}_c{c}.png"
            check_output(path, "file")
            with atomic_write(path, suffix=".png") as tmp:
                imsave(tmp, plane.astype(np.uint16), check_contrast=False)
            paths.append(path)
    return paths


def _write_header(path: Path, name: str, array: np.ndarray, keys: bool) -> Path:
    check_output(path, "file")
    ident = name.upper()
    s, t, _, c = array.shape
    flat = array.reshape(-1)
    ctype, fmt = ("uint32_t", "{}u") if keys else ("float", "{!r}f")
    body = ",".join(fmt.format(int(v) if keys else float(v)) for v in flat)
    text = (
        f"/* {name}: [S={s}][T={t}][T={t}][C={c}], pixel-major; written by bnerr export */\n"
        f"#pragma once\n#include <stdint.h>\n"
        f"#define {ident}_SLICES {s}\n#define {ident}_SIZE {t}\n#define {ident}_CHANNELS {c}\n"
        f"static const {ctype} {name}[{flat.size}] = {{{body}}};\n"
    )
    with atomic_write(path) as tmp:
        tmp.write_text(text, encoding="ascii")
    return path
